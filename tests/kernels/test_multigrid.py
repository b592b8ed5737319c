"""The multigrid-preconditioned CG solver (proxyshade/kernels/multigrid.py): its
buffer-sharing solve gives the same bits as conjugate gradients written out with a
buffer per vector, and holds fewer frame-sized arrays."""
from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from proxyshade.kernels import multigrid as mg
from proxyshade.kernels.stencil import fine_operator


def reference_solve(fixed, b, *, screen, tol, max_iter, float_weights=False):
    """Preconditioned CG with its own array for every vector (b kept, z and q apart): the
    textbook loop, on the module's kernels. ``float_weights``: the finest level's edge
    weights stored as float32 arrays (``fine_operator``'s 0/1 weights; the solver reads
    them from the diagonal), its coarse levels aggregated from those."""
    hier = mg._Hierarchy(np.ascontiguousarray(fixed, np.bool_), screen=screen)
    if float_weights:
        diag, we, ws = fine_operator(np.ascontiguousarray(fixed, np.bool_), np.float32(screen))
        ops = [(diag, we.astype(np.float32), ws.astype(np.float32))]
        mass = np.where(diag > 0, np.float32(screen), np.float32(0.0)).astype(np.float32)
        for _ in hier.ops[1:]:
            d, e, s, mass = mg._coarsen(*ops[-1], mass, np.float32(1.9))
            ops.append((d, e, s))
        hier.ops = ops
        if hier.serial_from < len(ops):  # the serial levels' flat copies of the operators, from these
            for i in range(3):
                hier.serial[i][...] = np.concatenate([op[i].ravel() for op in ops[hier.serial_from:]])
    diag, we, ws = hier.ops[0]
    b = np.array(b, np.float32)
    v = np.zeros(b.shape, np.float32)
    r = np.empty(b.shape, np.float32)
    mg._residual(diag, we, ws, v, b, r)
    rr = np.zeros(3)
    mg._dot3(r, r, rr)
    r0 = np.sqrt(rr)
    target = tol * r0
    z = np.empty(b.shape, np.float32)
    q = np.empty(b.shape, np.float32)
    hier.vcycle(r, z)
    p = z.copy()
    rz = np.zeros(3)
    mg._dot3(r, z, rz)
    pq = np.zeros(3)
    for it in range(1, max_iter + 1):
        mg._matvec_dot(diag, we, ws, p, q, pq)
        a = np.where(pq > 0, rz / np.where(pq > 0, pq, 1.0), 0.0)
        mg._cg_update(v, r, p, q, a, rr)
        if np.all(np.sqrt(rr) <= target):
            break
        z[...] = np.nan  # the V-cycle must write every cell
        hier.vcycle(r, z)
        rz_new = np.zeros(3)
        mg._dot3(r, z, rz_new)
        beta = np.where(rz > 0, rz_new / np.where(rz > 0, rz, 1.0), 0.0)
        rz = rz_new
        mg._xpby3(z, beta, p)
    return v, it


def case(rng, h, w):
    fixed = rng.random((h, w)) < 0.02
    fixed[:, 0] = True
    b = rng.normal(size=(h, w, 3)).astype(np.float32)
    b[fixed] = 0.0
    return fixed, b


@pytest.mark.parametrize("h,w,screen", [(37, 53, 0.0), (210, 190, 0.0), (210, 190, 0.5)])
def test_solve_is_bit_identical_to_the_textbook_loop(h, w, screen):
    """Sizes below and above ``SERIAL_CELLS`` (the finest level in the serial buffers or
    not), with and without ``overwrite_b``."""
    rng = np.random.default_rng(h * w)
    fixed, b = case(rng, h, w)
    want, iters = reference_solve(fixed, b, screen=screen, tol=1e-6, max_iter=60)
    got, info = mg.solve_system(fixed, b.copy(), screen=screen, tol=1e-6, max_iter=60)
    assert info["iterations"] == iters and iters > 2
    assert np.array_equal(got.view(np.uint32), want.view(np.uint32))
    b2 = b.copy()
    got2, _ = mg.solve_system(fixed, b2, screen=screen, tol=1e-6, max_iter=60, overwrite_b=True)
    assert np.array_equal(got2.view(np.uint32), want.view(np.uint32))
    got3, _ = mg.solve_system(fixed, b.astype(np.float64), screen=screen, tol=1e-6, max_iter=60, overwrite_b=True)
    assert np.array_equal(got3.view(np.uint32), want.view(np.uint32))  # a float64 b is converted, not reused


@pytest.mark.parametrize("h,w,screen", [(37, 53, 0.0), (210, 190, 0.5)])
def test_fine_weights_from_the_diagonal_give_the_stored_weights_bits(h, w, screen):
    """The finest level's 0/1 edge weights, not stored but read from the diagonal (empty
    weight arrays, ``stencil.edge``), give what float32 weights stored as arrays gave: the
    same coarse operators, the same solution bits."""
    rng = np.random.default_rng(h + w)
    fixed, b = case(rng, h, w)
    hier = mg._Hierarchy(np.ascontiguousarray(fixed, np.bool_), screen=screen)
    diag, we, ws = hier.ops[0]
    assert we.size == ws.size == 0 and diag.dtype == np.float32
    _, we8, ws8 = fine_operator(np.ascontiguousarray(fixed, np.bool_), np.float32(screen))
    assert set(np.unique(we8)) == set(np.unique(ws8)) == {0, 1}
    mass = np.where(diag > 0, np.float32(screen), np.float32(0.0)).astype(np.float32)
    c0 = mg._coarsen(diag, we, ws, mass, np.float32(1.9))
    c32 = mg._coarsen(diag, we8.astype(np.float32), ws8.astype(np.float32), mass, np.float32(1.9))
    for a, b_ in zip(c0, c32):
        assert a.dtype == b_.dtype == np.float32 and np.array_equal(a.view(np.uint32), b_.view(np.uint32))
    for name in ("_smooth", "_residual_restrict", "_coarsen"):  # one signature for every level
        assert {str(sig[1].dtype) for sig in getattr(mg, name).signatures} == {"float32"}
    want, iters = reference_solve(fixed, b, screen=screen, tol=1e-6, max_iter=60, float_weights=True)
    got, info = mg.solve_system(fixed, b.copy(), screen=screen, tol=1e-6, max_iter=60)
    assert info["iterations"] == iters and iters > 2
    assert np.array_equal(got.view(np.uint32), want.view(np.uint32))


def test_solve_holds_three_frames_of_vectors_and_its_operators():
    """The solve's peak allocation (tracemalloc: numpy's buffers) with ``overwrite_b``:
    v, p and the shared z/q buffer (3 frame-sized float32 arrays of 3 channels), the
    operators (a float32 diagonal at the finest level, its weights read from it, and a
    third of a frame more below) and the coarse levels' work arrays: under 5 frames, where
    stored float32 weights took 5.4 and a buffer per vector (r, z, q apart) and the finest
    level's unused x and b 9.4."""
    rng = np.random.default_rng(5)
    fixed, b = case(rng, 256, 256)
    frame = b.nbytes
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        base = tracemalloc.get_traced_memory()[0]
        mg.solve_system(fixed, b, screen=0.0, tol=1e-6, max_iter=60, overwrite_b=True)
        peak = tracemalloc.get_traced_memory()[1] - base
    finally:
        tracemalloc.stop()
    assert peak < 5.0 * frame, peak / frame
