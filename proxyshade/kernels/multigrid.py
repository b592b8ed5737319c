"""Multigrid-preconditioned conjugate gradients for the Poisson correction A v = b of
``kernels.poisson`` (whole frames and windows).

Conjugate gradients preconditioned by a multigrid V-cycle: red-black Gauss-Seidel
smoothing and Galerkin coarse operators of 2×2 aggregation (every level is again a
5-point stencil, so irregular fixed pixels need no special cases). All three channels
are swept together.

References
----------
Bonneel, van de Panne, Lefebvre, Drettakis. Proxy-Guided Texture Synthesis for Rendering
Natural Scenes. INRIA RR-7298, 2010 (§5 step 3).
A. McAdams, E. Sifakis, J. Teran. A parallel multigrid Poisson solver for fluids
simulation on large grids. SCA 2010.
D. Braess. Towards algebraic multigrid for elliptic problems of second order.
Computing 55, 1995 (over-correction of aggregation coarse grids).
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import JIT, PJIT
from proxyshade.kernels.stencil import apply_at, edge, fine_operator, neighbour_sum

@njit(**JIT)
def _coarsen(diag, we, ws, mass, alpha):
    """Coarse operator for 2x2 piecewise-constant aggregation: the Galerkin product
    P^T A P, its Laplacian part (edge weights, and the diagonal less the screening mass)
    divided by ``alpha``, its mass part (the screening term) kept exact. The fine weights
    are read as float32 (``stencil.edge``: the finest level's from its diagonal)."""
    h, w = diag.shape
    hc = (h + 1) // 2
    wc = (w + 1) // 2
    dc = np.zeros((hc, wc), np.float32)
    ec = np.zeros((hc, wc), np.float32)
    sc = np.zeros((hc, wc), np.float32)
    mc = np.zeros((hc, wc), np.float32)
    inv = 1.0 / alpha
    for I in range(hc):  # serial: a few milliseconds a solve (a parallel loop compiles 1 s slower)
        for J in range(wc):
            d = 0.0
            m = 0.0
            i0 = 2 * I
            j0 = 2 * J
            for di in range(2):
                i = i0 + di
                if i >= h:
                    continue
                for dj in range(2):
                    j = j0 + dj
                    if j >= w:
                        continue
                    d += diag[i, j] - mass[i, j]
                    m += mass[i, j]
            # internal edges count twice (both off-diagonal entries)
            if i0 < h and j0 + 1 < w:
                d -= 2.0 * edge(diag, we, i0, j0, i0, j0 + 1)
            if i0 + 1 < h and j0 + 1 < w:
                d -= 2.0 * edge(diag, we, i0 + 1, j0, i0 + 1, j0 + 1)
            if i0 + 1 < h:
                d -= 2.0 * edge(diag, ws, i0, j0, i0 + 1, j0)
                if j0 + 1 < w:
                    d -= 2.0 * edge(diag, ws, i0, j0 + 1, i0 + 1, j0 + 1)
            dc[I, J] = d * inv + m
            mc[I, J] = m
            # east: fine edges from column j0+1 to j0+2
            if j0 + 2 < w:
                e = edge(diag, we, i0, j0 + 1, i0, j0 + 2)
                if i0 + 1 < h:
                    e += edge(diag, we, i0 + 1, j0 + 1, i0 + 1, j0 + 2)
                ec[I, J] = e * inv
            if i0 + 2 < h:
                s = edge(diag, ws, i0 + 1, j0, i0 + 2, j0)
                if j0 + 1 < w:
                    s += edge(diag, ws, i0 + 1, j0 + 1, i0 + 2, j0 + 1)
                sc[I, J] = s * inv
    return dc, ec, sc, mc


@njit(**JIT)
def _smooth_serial(diag, we, ws, x, b, color):
    """``_smooth`` on one thread (for the tiny coarsest level: no parallel launch). The
    cells of one colour do not neighbour each other, so the result is the same."""
    for i in range(diag.shape[0]):
        _smooth_row(diag, we, ws, x, b, color, i)


@njit(**JIT)
def _coarse_solve(diag, we, ws, x, b, sweeps):
    """The coarsest level of a V-cycle: from x = 0, ``sweeps`` red-black then ``sweeps``
    black-red Gauss-Seidel sweeps, in one compiled call."""
    x[...] = 0.0
    red, black = np.int64(0), np.int64(1)  # not literals: one signature of _smooth_serial for both
    for _ in range(sweeps):
        _smooth_serial(diag, we, ws, x, b, red)
        _smooth_serial(diag, we, ws, x, b, black)
    for _ in range(sweeps):
        _smooth_serial(diag, we, ws, x, b, black)
        _smooth_serial(diag, we, ws, x, b, red)


@njit(inline="always", **JIT)
def _smooth_row(diag, we, ws, x, b, color, i):
    """Row i of a Gauss-Seidel half sweep on cells with (i + j) % 2 == color."""
    h, w = diag.shape
    j0 = (color + i) % 2
    for j in range(j0, w, 2):
        d = diag[i, j]
        if d == 0.0:
            continue
        n0, n1, n2 = neighbour_sum(diag, x, we, ws, i, j, h, w)
        s0 = b[i, j, 0] + n0
        s1 = b[i, j, 1] + n1
        s2 = b[i, j, 2] + n2
        inv = 1.0 / d
        x[i, j, 0] = s0 * inv
        x[i, j, 1] = s1 * inv
        x[i, j, 2] = s2 * inv


@njit(**PJIT)
def _smooth(diag, we, ws, x, b, color):
    """One Gauss-Seidel half sweep on cells with (i + j) % 2 == color, 3 channels."""
    for i in prange(diag.shape[0]):
        _smooth_row(diag, we, ws, x, b, color, i)


@njit(**PJIT)
def _residual(diag, we, ws, x, b, r):
    h, w = diag.shape
    for i in prange(h):
        for j in range(w):
            d = diag[i, j]
            if d == 0.0:
                r[i, j, 0] = 0.0
                r[i, j, 1] = 0.0
                r[i, j, 2] = 0.0
                continue
            n0, n1, n2 = neighbour_sum(diag, x, we, ws, i, j, h, w)
            s0 = b[i, j, 0] - d * x[i, j, 0] + n0
            s1 = b[i, j, 1] - d * x[i, j, 1] + n1
            s2 = b[i, j, 2] - d * x[i, j, 2] + n2
            r[i, j, 0] = s0
            r[i, j, 1] = s1
            r[i, j, 2] = s2


@njit(inline="always", **JIT)
def _jacobi_start_row(diag, x, b, color, i):
    for j in range(diag.shape[1]):
        d = diag[i, j]
        if (i + j) % 2 == color and d != 0.0:
            inv = 1.0 / d
            x[i, j, 0] = b[i, j, 0] * inv
            x[i, j, 1] = b[i, j, 1] * inv
            x[i, j, 2] = b[i, j, 2] * inv
        else:
            x[i, j, 0] = 0.0
            x[i, j, 1] = 0.0
            x[i, j, 2] = 0.0


@njit(**PJIT)
def _jacobi_start(diag, x, b, color):
    """x = 0 except cells of ``color``: b / diag (a red half-sweep from zero)."""
    for i in prange(diag.shape[0]):
        _jacobi_start_row(diag, x, b, color, i)


@njit(inline="always", **JIT)
def _residual_restrict_row(diag, we, ws, x, b, rc, I):
    h, w = diag.shape
    for J in range(rc.shape[1]):
        rc[I, J, 0] = 0.0
        rc[I, J, 1] = 0.0
        rc[I, J, 2] = 0.0
    for i in range(2 * I, min(2 * I + 2, h)):
        for j in range(w):
            if diag[i, j] == 0.0:
                continue
            a0, a1, a2 = apply_at(diag, we, ws, x, i, j)
            J = j >> 1
            rc[I, J, 0] += b[i, j, 0] - a0
            rc[I, J, 1] += b[i, j, 1] - a1
            rc[I, J, 2] += b[i, j, 2] - a2


@njit(**PJIT)
def _residual_restrict(diag, we, ws, x, b, rc):
    """rc = P^T (b - A x): the residual summed over each 2x2 aggregate."""
    for I in prange(rc.shape[0]):
        _residual_restrict_row(diag, we, ws, x, b, rc, I)


@njit(**PJIT)
def _matvec_dot(diag, we, ws, p, q, pq):
    """q = A p and pq[c] = <p, q> per channel (fixed summation order)."""
    h, w = diag.shape
    part = np.zeros((h, 3), np.float64)
    for i in prange(h):
        t0 = 0.0
        t1 = 0.0
        t2 = 0.0
        for j in range(w):
            if diag[i, j] == 0.0:
                q[i, j, 0] = 0.0
                q[i, j, 1] = 0.0
                q[i, j, 2] = 0.0
                continue
            a0, a1, a2 = apply_at(diag, we, ws, p, i, j)
            q[i, j, 0] = a0
            q[i, j, 1] = a1
            q[i, j, 2] = a2
            t0 += np.float64(p[i, j, 0]) * a0
            t1 += np.float64(p[i, j, 1]) * a1
            t2 += np.float64(p[i, j, 2]) * a2
        part[i, 0] = t0
        part[i, 1] = t1
        part[i, 2] = t2
    for c in range(3):
        pq[c] = 0.0
    for i in range(h):
        for c in range(3):
            pq[c] += part[i, c]


@njit(**PJIT)
def _cg_update(v, r, p, q, a, rr):
    """v += a p; r -= a q; rr = <r, r> per channel (fixed summation order)."""
    h, w = v.shape[0], v.shape[1]
    a32 = np.empty(3, np.float32)
    for c in range(3):
        a32[c] = a[c]
    part = np.zeros((h, 3), np.float64)
    for i in prange(h):
        for j in range(w):
            for c in range(3):
                v[i, j, c] += a32[c] * p[i, j, c]
                rv = r[i, j, c] - a32[c] * q[i, j, c]
                r[i, j, c] = rv
                part[i, c] += np.float64(rv) * np.float64(rv)
    for c in range(3):
        rr[c] = 0.0
    for i in range(h):
        for c in range(3):
            rr[c] += part[i, c]


@njit(inline="always", **JIT)
def _prolong_add_row(xc, x, diag, alpha, i):
    I = i // 2
    for j in range(diag.shape[1]):
        if diag[i, j] == 0.0:
            continue
        J = j // 2
        x[i, j, 0] += alpha * xc[I, J, 0]
        x[i, j, 1] += alpha * xc[I, J, 1]
        x[i, j, 2] += alpha * xc[I, J, 2]


@njit(**PJIT)
def _prolong_add(xc, x, diag, alpha):
    for i in prange(diag.shape[0]):
        _prolong_add_row(xc, x, diag, alpha, i)


# serial twins of the V-cycle kernels for small levels (one compiled call per V-cycle
# below ``SERIAL_CELLS`` instead of a parallel launch per kernel): every cell is
# computed from the same neighbours as in the parallel kernels, so the bits are the same


SERIAL_CELLS = 1 << 15  # levels with fewer cells run their whole V-cycle serially


@njit(**JIT)
def _jacobi_start_serial(diag, x, b, color):
    for i in range(diag.shape[0]):
        _jacobi_start_row(diag, x, b, color, i)


@njit(**JIT)
def _residual_restrict_serial(diag, we, ws, x, b, rc):
    for I in range(rc.shape[0]):
        _residual_restrict_row(diag, we, ws, x, b, rc, I)


@njit(**JIT)
def _prolong_add_serial(xc, x, diag, alpha):
    for i in range(diag.shape[0]):
        _prolong_add_row(xc, x, diag, alpha, i)


@njit(inline="always", **JIT)
def _level2(flat, shapes, offsets, l):
    """Level ``l``'s (h, w) array in a flat buffer of levels (``_Hierarchy``: one after another)."""
    h, w = shapes[l, 0], shapes[l, 1]
    return flat[offsets[l]:offsets[l] + h * w].reshape((h, w))


@njit(inline="always", **JIT)
def _level3(flat, shapes, offsets, l):
    """Level ``l``'s (h, w, 3) array in a flat buffer of levels."""
    h, w = shapes[l, 0], shapes[l, 1]
    return flat[3 * offsets[l]:3 * offsets[l] + 3 * h * w].reshape((h, w, 3))


@njit(**JIT)
def _vcycle_serial(diags, wes, wss, xs, bs, shapes, offsets, sweeps, coarse_sweeps):
    """``_Hierarchy.vcycle`` from the first serial level down, on one thread: the same kernels
    in the same order. The serial levels lie one after another in flat buffers (level l at
    ``offsets[l]`` cells, of shape ``shapes[l]``; ``xs``, ``bs`` three values a cell): the
    right-hand side of the first in ``bs``, the result in ``xs``."""
    last = shapes.shape[0] - 1
    red, black = np.int64(0), np.int64(1)  # not literals: one signature of _smooth_serial for both
    for l in range(0, last):
        d, e, sw = _level2(diags, shapes, offsets, l), _level2(wes, shapes, offsets, l), _level2(wss, shapes, offsets, l)
        x, b = _level3(xs, shapes, offsets, l), _level3(bs, shapes, offsets, l)
        _jacobi_start_serial(d, x, b, red)
        _smooth_serial(d, e, sw, x, b, black)
        for _ in range(sweeps - 1):
            _smooth_serial(d, e, sw, x, b, red)
            _smooth_serial(d, e, sw, x, b, black)
        _residual_restrict_serial(d, e, sw, x, b, _level3(bs, shapes, offsets, l + 1))
    _coarse_solve(_level2(diags, shapes, offsets, last), _level2(wes, shapes, offsets, last),
                  _level2(wss, shapes, offsets, last), _level3(xs, shapes, offsets, last),
                  _level3(bs, shapes, offsets, last), coarse_sweeps)
    for l in range(last - 1, -1, -1):
        d, e, sw = _level2(diags, shapes, offsets, l), _level2(wes, shapes, offsets, l), _level2(wss, shapes, offsets, l)
        x, b = _level3(xs, shapes, offsets, l), _level3(bs, shapes, offsets, l)
        _prolong_add_serial(_level3(xs, shapes, offsets, l + 1), x, d, 1.0)
        for _ in range(sweeps):
            _smooth_serial(d, e, sw, x, b, black)
            _smooth_serial(d, e, sw, x, b, red)


@njit(**PJIT)
def _dot3(a, b, out):
    h, w = a.shape[0], a.shape[1]
    part = np.zeros((h, 3), np.float64)
    for i in prange(h):
        for j in range(w):
            for c in range(3):
                part[i, c] += np.float64(a[i, j, c]) * np.float64(b[i, j, c])
    for c in range(3):
        out[c] = 0.0
    for i in range(h):  # fixed summation order: same result for any thread count
        for c in range(3):
            out[c] += part[i, c]


@njit(**PJIT)
def _xpby3(z, beta, p):
    """p = z + beta[c] * p."""
    h, w = z.shape[0], z.shape[1]
    b0 = np.float32(beta[0])
    b1 = np.float32(beta[1])
    b2 = np.float32(beta[2])
    for i in prange(h):
        for j in range(w):
            p[i, j, 0] = z[i, j, 0] + b0 * p[i, j, 0]
            p[i, j, 1] = z[i, j, 1] + b1 * p[i, j, 1]
            p[i, j, 2] = z[i, j, 2] + b2 * p[i, j, 2]


# ---------------------------------------------------------------------------
# multigrid-preconditioned conjugate gradients


class _Hierarchy:
    """Operators and work arrays of every level, finest first.

    With piecewise-constant aggregation the Galerkin coarse Laplacian is about twice the
    rediscretized one in free regions; dividing it by ``alpha`` near 2 restores the scale
    (the over-correction of Braess 1995), while a screening term's mass is exact.
    """

    def __init__(self, fixed: np.ndarray, *, screen: float = 0.0, coarsest: int = 4, alpha: float = 1.9):
        # the finest level's 0/1 weights are not stored: empty arrays, read from the diagonal
        # (``stencil.edge``; one float32 signature per kernel for every level)
        diag, we8, ws8 = fine_operator(fixed, np.float32(screen))
        stored = (diag, we8, ws8) if diag.size < SERIAL_CELLS else None  # the finest level in the serial buffers
        del we8, ws8
        we = ws = np.zeros((0, 0), np.float32)
        mass = np.where(diag > 0, np.float32(screen), np.float32(0.0)).astype(np.float32)
        ops = [(diag, we, ws)]
        while min(ops[-1][0].shape) > coarsest:
            diag, we, ws, mass = _coarsen(diag, we, ws, mass, np.float32(alpha))
            ops.append((diag, we, ws))
        self.ops = ops
        # from the first level below SERIAL_CELLS down, one serial call: those levels lie one
        # after another in flat buffers (one signature whatever their count; x and b of a
        # serial level are views of its buffers)
        self.serial_from = k0 = next((k for k, op in enumerate(ops) if op[0].size < SERIAL_CELLS), len(ops))
        full = [stored] + ops[1:] if k0 == 0 else ops  # the serial kernels read stored weights
        del stored
        # the finest level's x and b are the caller's (``vcycle`` from level 0 writes into the
        # x it is given): work arrays from level 1 down only (a whole frame's two buffers less)
        self.x = [None] + [np.zeros(op[0].shape + (3,), np.float32) for op in ops[1:k0]]
        self.b = [None] + [np.zeros(op[0].shape + (3,), np.float32) for op in ops[1:k0]]
        if k0 == 0:
            self.x, self.b = [], []
        if k0 < len(ops):
            shapes = np.array([op[0].shape for op in ops[k0:]], np.int64)
            offsets = np.concatenate([[0], np.cumsum(shapes[:, 0] * shapes[:, 1])]).astype(np.int64)
            flat = [np.concatenate([op[i].ravel() for op in full[k0:]]).astype(np.float32, copy=False)
                    for i in range(3)]
            xs, bs = np.zeros(3 * offsets[-1], np.float32), np.zeros(3 * offsets[-1], np.float32)
            for (h, w), o in zip(shapes, offsets):
                self.x.append(xs[3 * o:3 * (o + h * w)].reshape(h, w, 3))
                self.b.append(bs[3 * o:3 * (o + h * w)].reshape(h, w, 3))
            self.serial = (*flat, xs, bs, shapes, offsets[:-1].copy())

    def vcycle(self, b: np.ndarray, x: np.ndarray, *, sweeps: int = 1, coarse_sweeps: int = 30,
               level: int = 0) -> None:
        """Approximately solve A x = b from x = 0; symmetric (red-black before, black-red
        after), so it can precondition conjugate gradients."""
        diag, we, ws = self.ops[level]
        if level >= self.serial_from:
            if b is not self.b[level]:  # self.b / self.x of a serial level are views of its buffers
                self.b[level][...] = b
            _vcycle_serial(*self.serial, sweeps, coarse_sweeps)
            if x is not self.x[level]:
                x[...] = self.x[level]
            return
        if level == len(self.ops) - 1:
            _coarse_solve(diag, we, ws, x, b, coarse_sweeps)
            return
        _jacobi_start(diag, x, b, 0)  # the first red half-sweep, from x = 0
        _smooth(diag, we, ws, x, b, 1)
        for _ in range(sweeps - 1):
            _smooth(diag, we, ws, x, b, 0)
            _smooth(diag, we, ws, x, b, 1)
        bc = self.b[level + 1]
        xc = self.x[level + 1]
        _residual_restrict(diag, we, ws, x, b, bc)
        self.vcycle(bc, xc, sweeps=sweeps, coarse_sweeps=coarse_sweeps, level=level + 1)
        _prolong_add(xc, x, diag, 1.0)
        for _ in range(sweeps):
            _smooth(diag, we, ws, x, b, 1)
            _smooth(diag, we, ws, x, b, 0)


def solve_system(fixed: np.ndarray, b: np.ndarray, *, screen: float = 0.0, tol: float, max_iter: int,
                 sweeps: int = 1, alpha: float = 1.9, overwrite_b: bool = False) -> tuple[np.ndarray, dict]:
    """Solve A v = b for three channels with multigrid-preconditioned conjugate gradients.

    A is the graph Laplacian of the 4-connected grid restricted to the free (not
    ``fixed``) pixels: diagonal = number of in-image neighbours, -1 per free neighbour.
    ``screen`` is added to the diagonal (screened Poisson). Unless it is positive, every
    connected set of free pixels must touch a fixed pixel (A is then SPD).

    Stops when every channel's residual norm is at most ``tol`` times its initial norm.
    Returns v (M, N, 3) float32 (zero on fixed pixels) and {"iterations", "residual"}.

    Memory: four frame-sized (M, N, 3) float32 arrays besides the operators (v, the
    residual, p, and one buffer for both the preconditioned residual z and A p: each is
    dead when the other is written), three when ``overwrite_b`` (a float32 C-contiguous
    ``b`` the caller no longer needs becomes the residual). The numbers are the same
    either way.
    """
    hier = _Hierarchy(np.ascontiguousarray(fixed, dtype=np.bool_), screen=screen, alpha=alpha)
    diag = hier.ops[0][0]
    own = overwrite_b and isinstance(b, np.ndarray) and b.dtype == np.float32 and b.flags.c_contiguous
    b = np.ascontiguousarray(b, dtype=np.float32)
    shape = b.shape
    v = np.zeros(shape, np.float32)
    r = b if own else np.empty(shape, np.float32)
    _residual(diag, None, None, v, b, r)  # r = b with the fixed entries zeroed (in place: each cell reads only its own b)
    del b
    rr = np.zeros(3)
    _dot3(r, r, rr)
    r0 = np.sqrt(rr)
    if np.all(r0 == 0.0):
        return v, {"iterations": 0, "residual": 0.0}
    target = tol * r0
    zq = np.empty(shape, np.float32)  # z = M^-1 r, then q = A p (z is dead once p is updated)
    hier.vcycle(r, zq, sweeps=sweeps)
    p = zq.copy()
    rz = np.zeros(3)
    _dot3(r, zq, rz)
    pq = np.zeros(3)
    it = 0
    res = r0
    while it < max_iter:
        it += 1
        _matvec_dot(diag, None, None, p, zq, pq)  # the finest level's weights, typed as read from diag
        a = np.where(pq > 0, rz / np.where(pq > 0, pq, 1.0), 0.0)
        _cg_update(v, r, p, zq, a, rr)
        res = np.sqrt(rr)
        if np.all(res <= target):
            break
        hier.vcycle(r, zq, sweeps=sweeps)  # writes every cell of zq (a Jacobi start from zero)
        rz_new = np.zeros(3)
        _dot3(r, zq, rz_new)
        beta = np.where(rz > 0, rz_new / np.where(rz > 0, rz, 1.0), 0.0)
        rz = rz_new
        _xpby3(zq, beta, p)
    rel = float(np.max(np.where(r0 > 0, res / np.where(r0 > 0, r0, 1.0), 0.0)))
    return v, {"iterations": it, "residual": rel}
