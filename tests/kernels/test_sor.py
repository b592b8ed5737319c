"""kernels.sor's region sweeps against a plain serial reference (the per-sweep ``_sor_run``)."""
import numpy as np
import pytest
from numba import njit

from proxyshade.kernels import sor
from proxyshade.kernels._config import JIT


@njit(**JIT)
def _sor_run(nb, dl, bl, omega, lo, hi, vl):
    """The plain update: 1 / the diagonal taken at every update (``kernels.sor`` takes it once
    a region), the same arithmetic otherwise, compiled with the kernels' flags."""
    for k in range(lo, hi):
        n0 = 0.0
        n1 = 0.0
        n2 = 0.0
        for m in range(4):
            q = nb[k, m]
            if q >= 0:
                n0 += vl[q, 0]
                n1 += vl[q, 1]
                n2 += vl[q, 2]
        inv = 1.0 / dl[k]
        o = omega[k]
        vl[k, 0] += o * ((bl[k, 0] + n0) * inv - vl[k, 0])
        vl[k, 1] += o * ((bl[k, 1] + n1) * inv - vl[k, 1])
        vl[k, 2] += o * ((bl[k, 2] + n2) * inv - vl[k, 2])


def _reference_regions(starts, mids, nb, dl, bl, omega, vl, tol, check, max_sweeps):
    """``_sor_regions`` written plainly: each region in turn, ``_sor_run`` (1 / diagonal taken
    at every update) for its red then black entries, ``check`` sweeps between residual checks."""
    r0 = np.zeros(3)
    r = np.zeros(3)
    for k in range(len(starts) - 1):
        lo, hi = starts[k], starts[k + 1]
        sor._run_residual(nb, dl, bl, lo, hi, vl, r0)
        if np.all(r0 == 0.0):
            continue
        s = 0
        while s < max_sweeps:
            for _ in range(check):
                _sor_run(nb, dl, bl, omega, lo, mids[k], vl)
                _sor_run(nb, dl, bl, omega, mids[k], hi, vl)
            s += check
            sor._run_residual(nb, dl, bl, lo, hi, vl, r)
            if all(r0[c] <= 0.0 or np.sqrt(r[c] / r0[c]) <= tol for c in range(3)):
                break


@pytest.mark.parametrize("threads", [1, 3])
def test_sor_regions_match_plain_sweeps_bit_for_bit(threads):
    rng = np.random.default_rng(4)
    h, w = 30, 40
    free = np.zeros((h, w), bool)
    free[2:4, 1:35] = True  # a thin band
    free[8:24, 4:20] = True  # a square
    free[9:28, 24:39] = rng.random((19, 15)) < 0.85  # a ragged blob
    free[27, 2] = True  # a single pixel
    from scipy.ndimage import label as cc

    comp, _ = cc(free)
    rows, cols = np.nonzero(free)
    region = comp[rows, cols]
    omega = sor.sor_omega(np.full(len(rows), 9.0), np.full(len(rows), 9.0)) - rng.uniform(0, 0.2, len(rows))
    b = rng.normal(0, 1, (h, w, 3)).astype(np.float32)
    got, info = sor.solve_sor_regions(~free, b, rows, cols, omega, region, screen=0.01, tol=1e-6, threads=threads)
    assert info["iterations"] > 8  # the regions took several checks

    diag, _, _ = sor.fine_operator(np.ascontiguousarray(~free), np.float32(0.01))
    order, om, starts, mids, _, _, _, _ = sor._sor_plan(rows.astype(np.int64), cols.astype(np.int64), omega, region,
                                                        threads)
    ii, jj = np.ascontiguousarray(rows[order]), np.ascontiguousarray(cols[order])
    nb = sor._list_neighbours(ii, jj, h, w)
    vl = np.zeros((len(rows), 3), np.float32)
    _reference_regions(starts, mids, nb, np.ascontiguousarray(diag[ii, jj]), np.ascontiguousarray(b[ii, jj]), om, vl,
                       1e-6, 8, 2000)
    ref = np.zeros_like(b)
    ref[ii, jj] = vl
    assert np.any(ref != 0)
    np.testing.assert_array_equal(got, ref)
