"""Poisson gradient transfer: multigrid-preconditioned CG against a direct sparse solve."""
import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from proxyshade.kernels import poisson, sor
from proxyshade.kernels.distance import contour_mask
from proxyshade.synthesis.params import PoissonSolve

SOLVE = dict(tol=PoissonSolve.tol.default, max_iter=PoissonSolve.max_iter.default)  # the node's defaults


def direct_solve(colors, patch, labels, fixed=None, values=None, gx=None, gy=None, screen=0.0):
    """The discrete problem written out pixel by pixel in u (not the correction), solved
    with spsolve. Floating components get their first pixel pinned, then their mean
    set to the mean of colors."""
    h, w, _ = colors.shape
    fx = contour_mask(labels) if labels is not None else np.zeros((h, w), bool)
    val = colors.astype(np.float64).copy()
    if fixed is not None:
        fx = fx | fixed
        if values is not None:
            only = fixed & ~(contour_mask(labels) if labels is not None else np.zeros((h, w), bool))
            val[only] = values[only]
    # components of free pixels (scipy) to find floating ones
    from scipy.ndimage import label as cc
    comp, n = cc(~fx)
    pinned = fx.copy()
    floating = []
    for c in range(1, n + 1):
        m = comp == c
        grown = np.zeros_like(m)
        grown[1:] |= m[:-1]; grown[:-1] |= m[1:]; grown[:, 1:] |= m[:, :-1]; grown[:, :-1] |= m[:, 1:]
        if not (grown & fx).any() and screen == 0:
            first = np.flatnonzero(m.reshape(-1))[0]
            pinned.reshape(-1)[first] = True
            floating.append(m)
    free = ~pinned
    idx = -np.ones((h, w), int)
    idx[free] = np.arange(free.sum())
    rows, cols, data = [], [], []
    rhs = np.zeros((free.sum(), 3))
    for i in range(h):
        for j in range(w):
            if not free[i, j]:
                continue
            k = idx[i, j]
            rows.append(k); cols.append(k); data.append(screen)  # λ (u - f): f moves to rhs
            rhs[k] += screen * colors[i, j]
            for ii, jj in ((i - 1, j), (i + 1, j), (i, j - 1), (i, j + 1)):
                if not (0 <= ii < h and 0 <= jj < w):
                    continue
                rows.append(k); cols.append(k); data.append(1.0)
                if patch[ii, jj] == patch[i, j]:
                    rhs[k] += colors[i, j] - colors[ii, jj]
                elif gx is not None:  # wanted u_p - u_q across the seam
                    if ii == i - 1:
                        rhs[k] += gy[ii, jj]
                    elif ii == i + 1:
                        rhs[k] -= gy[i, j]
                    elif jj == j - 1:
                        rhs[k] += gx[ii, jj]
                    else:
                        rhs[k] -= gx[i, j]
                if free[ii, jj]:
                    rows.append(k); cols.append(idx[ii, jj]); data.append(-1.0)
                else:
                    rhs[k] += val[ii, jj]
    A = sp.csc_matrix((data, (rows, cols)), shape=(free.sum(),) * 2)
    u = val.copy()
    u[free] = spla.spsolve(A, rhs)
    for m in floating:
        u[m] += colors[m].mean(0) - u[m].mean(0)
    return u


def random_case(rng, h, w, nlab=3, npatch=12):
    ci, cj = rng.uniform(0, h, 5), rng.uniform(0, w, 5)
    ii, jj = np.mgrid[0:h, 0:w]
    labels = ((ii[..., None] - ci) ** 2 + (jj[..., None] - cj) ** 2).argmin(-1) % nlab + 1
    pi, pj = rng.uniform(0, h, npatch), rng.uniform(0, w, npatch)
    patch = (np.abs(ii[..., None] - pi) + np.abs(jj[..., None] - pj)).argmin(-1)
    colors = rng.random((h, w, 3)).astype(np.float32) * 0.3 + patch[..., None] * 0.05 % 0.7
    return colors.astype(np.float32), patch.astype(np.uint32), labels.astype(np.uint32)


def rel_err(u, ref):
    return np.linalg.norm(u - ref) / np.linalg.norm(ref)


@pytest.mark.parametrize("seed,h,w", [(0, 31, 40), (1, 64, 64), (2, 17, 53), (3, 50, 33)])
def test_matches_direct_solve(seed, h, w):
    rng = np.random.default_rng(seed)
    colors, patch, labels = random_case(rng, h, w)
    u, info = poisson.poisson_transfer(colors, patch, labels, **SOLVE)
    ref = direct_solve(colors, patch, labels)
    assert rel_err(u, ref) <= 1e-4, info
    # label boundaries are left as they were
    edge = contour_mask(labels)
    assert np.array_equal(u[edge], colors[edge])


def test_seam_gradients_match_direct_solve():
    rng = np.random.default_rng(11)
    colors, patch, labels = random_case(rng, 45, 38)
    gx = rng.normal(0, 0.05, (45, 38, 3)).astype(np.float32)
    gy = rng.normal(0, 0.05, (45, 38, 3)).astype(np.float32)
    u, _ = poisson.poisson_transfer(colors, patch, labels, seam_gx=gx, seam_gy=gy, **SOLVE)
    ref = direct_solve(colors, patch, labels, gx=gx, gy=gy)
    assert rel_err(u, ref) <= 1e-4
    # the same gradients made inside the transfer (``seam_gradients``: dropped before the
    # solve): the same bits; colors and the gradients' arrays are left as they were
    keep = colors.copy(), gx.copy(), gy.copy()
    u2, _ = poisson.poisson_transfer(colors, patch, labels, seam_gradients=lambda: (gx, gy), **SOLVE)
    assert np.array_equal(u2.view(np.uint32), u.view(np.uint32))
    assert all(np.array_equal(a, b) for a, b in zip((colors, gx, gy), keep))
    with pytest.raises(ValueError, match="not both"):
        poisson.poisson_transfer(colors, patch, labels, seam_gx=gx, seam_gradients=lambda: (gx, gy), **SOLVE)


def test_seam_gradients_from_source():
    """A map made of two patches that both read a linear ramp: the source gradient is
    kept across the seam, so Poisson reproduces the ramp's slope there."""
    src = np.tile(np.linspace(0, 1, 64, dtype=np.float32)[None, :, None], (8, 1, 3))
    sx = np.tile(np.arange(30, dtype=np.float32), (8, 1))
    sx[:, 15:] += 20  # second patch jumps 20 source pixels to the right
    sy = np.tile(np.arange(8, dtype=np.float32)[:, None], (1, 30))
    gx, gy = poisson.seam_gradients(src, sx, sy)
    step = 1 / 63
    assert np.allclose(gx[:, :-1, 0], step, atol=1e-6)
    assert np.allclose(gy[:-1], 0, atol=1e-6)
    from proxyshade.kernels.lookup import lookup
    f = lookup(src, sx, sy)
    patch = (sx > sx[:, :1] + np.arange(30)).astype(np.uint32)
    fixed = np.zeros((8, 30), bool)
    fixed[:, 0] = True
    u, _ = poisson.poisson_transfer(f, patch, None, fixed=fixed, seam_gx=gx, seam_gy=gy, **SOLVE)
    assert np.allclose(np.diff(u[..., 0], axis=1), step, atol=1e-5)


@pytest.mark.parametrize("step", [1.0, 0.375])
def test_seam_gradients_at_seams_equal_the_full_map(step):
    """The whole-frame solve reads the seam gradients only where they cross a seam, so it
    computes them there only (``seam_gradients_at``): bit for bit the full map's values on
    every seam edge, zero elsewhere."""
    rng = np.random.default_rng(13)
    src = rng.random((40, 50, 3), dtype=np.float32)
    h, w = 23, 31
    patch = (np.arange(h)[:, None] // 5 * 7 + np.arange(w)[None, :] // 6).astype(np.uint32)
    off = rng.uniform(0, 30, (int(patch.max()) + 1, 2)).astype(np.float32)
    sx = (np.arange(w, dtype=np.float32)[None, :] * step + off[patch, 0]).astype(np.float32)
    sy = (np.arange(h, dtype=np.float32)[:, None] * step + off[patch, 1]).astype(np.float32)
    gx, gy = poisson.seam_gradients(src, sx, sy, step)
    ax, ay = poisson.seam_gradients_at(src, sx, sy, patch, np.ones((h, w), bool), step)
    ex = np.zeros((h, w), bool)
    ex[:, :-1] = patch[:, :-1] != patch[:, 1:]
    ey = np.zeros((h, w), bool)
    ey[:-1] = patch[:-1] != patch[1:]
    assert ex.any() and ey.any()
    assert np.array_equal(ax[ex], gx[ex]) and np.array_equal(ay[ey], gy[ey])
    assert not ax[~ex].any() and not ay[~ey].any()


@pytest.mark.parametrize("screen", [0.01, 0.5])
def test_screened_matches_direct_solve(screen):
    rng = np.random.default_rng(12)
    colors, patch, labels = random_case(rng, 41, 47)
    u, _ = poisson.poisson_transfer(colors, patch, labels, screen=screen, **SOLVE)
    ref = direct_solve(colors, patch, labels, screen=screen)
    assert rel_err(u, ref) <= 1e-4
    # a single label (no Dirichlet pixel) is well posed once screened
    one = np.ones_like(labels)
    u, info = poisson.poisson_transfer(colors, patch, one, screen=screen, **SOLVE)
    assert info["floating"] == 0
    assert rel_err(u, direct_solve(colors, patch, one, screen=screen)) <= 1e-4


def test_single_label_floating_mean():
    rng = np.random.default_rng(4)
    colors, patch, _ = random_case(rng, 40, 37)
    labels = np.ones((40, 37), np.uint32)
    u, info = poisson.poisson_transfer(colors, patch, labels, **SOLVE)
    assert info["floating"] == 1
    ref = direct_solve(colors, patch, labels)
    assert rel_err(u, ref) <= 1e-4
    assert np.allclose(u.mean((0, 1)), colors.mean((0, 1)), atol=1e-5)


def test_fixed_mask_and_values():
    rng = np.random.default_rng(6)
    colors, patch, labels = random_case(rng, 48, 48)
    fixed = np.ones((48, 48), bool)
    fixed[10:30, 12:40] = False  # only this window is re-solved
    values = rng.random((48, 48, 3)).astype(np.float32)
    u, _ = poisson.poisson_transfer(colors, patch, labels, fixed=fixed, values=values, **SOLVE)
    ref = direct_solve(colors, patch, labels, fixed=fixed, values=values)
    assert rel_err(u, ref) <= 1e-4
    outside = fixed & ~contour_mask(labels)
    assert np.array_equal(u[outside], values[outside])


def test_one_patch_is_identity():
    """With a single patch the source gradients are the image's: nothing changes."""
    rng = np.random.default_rng(7)
    colors = rng.random((30, 30, 3)).astype(np.float32)
    labels = np.ones((30, 30), np.uint32)
    labels[:, 20:] = 2
    u, _ = poisson.poisson_transfer(colors, np.zeros((30, 30), np.uint32), labels, **SOLVE)
    assert np.abs(u - colors).max() < 1e-5


def test_seam_is_blended():
    """Two patches, one constant 0.2 and one 0.8, between fixed ends: the jump spreads."""
    colors = np.zeros((8, 40, 3), np.float32)
    colors[:, :20] = 0.2
    colors[:, 20:] = 0.8
    patch = np.zeros((8, 40), np.uint32)
    patch[:, 20:] = 1
    fixed = np.zeros((8, 40), bool)
    fixed[:, 0] = fixed[:, -1] = True
    u, _ = poisson.poisson_transfer(colors, patch, None, fixed=fixed, **SOLVE)
    # linear ramp from 0.2 to 0.8
    assert np.allclose(u[3, :, 0], np.linspace(0.2, 0.8, 40), atol=1e-4)


def test_deterministic_across_threads():
    import numba
    rng = np.random.default_rng(8)
    colors, patch, labels = random_case(rng, 90, 70)
    a, _ = poisson.poisson_transfer(colors, patch, labels, **SOLVE)
    numba.set_num_threads(1)
    try:
        b, _ = poisson.poisson_transfer(colors, patch, labels, **SOLVE)
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    assert np.array_equal(a, b)


def _sor_case(rng, h=40, w=60):
    """Free regions of different widths (a thin band, a square, a blob crossing a patch
    seam, a single pixel) separated by fixed pixels, and the direct solve of each."""
    colors, patch, labels = random_case(rng, h, w, nlab=1)
    free = np.zeros((h, w), bool)
    free[3:5, 2:50] = True
    free[10:30, 5:25] = True
    free[12:35, 32:55] = (rng.random((23, 23)) < 0.9)
    free[37, 10] = True
    fixed = ~free
    gx, gy = rng.normal(0, 0.1, (2, h, w, 3)).astype(np.float32)
    ref = direct_solve(colors, patch, None, fixed=fixed, values=colors, gx=gx, gy=gy, screen=0.01)
    b = poisson.rhs(colors, patch, fixed, gx, gy)
    from scipy.ndimage import label as cc
    comp, _ = cc(free)
    rows, cols = np.nonzero(free)
    return colors, ref, fixed, b, rows, cols, comp[rows, cols]


def test_sor_regions_match_direct_solve():
    rng = np.random.default_rng(21)
    colors, ref, fixed, b, rows, cols, region = _sor_case(rng)
    omega = sor.sor_omega(np.full(len(rows), 8.0), np.full(len(rows), 8.0))
    v, info = sor.solve_sor_regions(fixed, b, rows, cols, omega, region, screen=0.01, tol=1e-6)
    u = colors.astype(np.float64) + v
    np.testing.assert_allclose(u[rows, cols], ref[rows, cols], atol=1e-5)
    assert np.all(v[fixed] == 0)
    # each region stops on its own: the mean sweeps per pixel are below the most sweeps
    assert info["sweeps"] < info["iterations"] and info["residual"] <= 1e-6
    # the same answer as the one-list solve to the tolerance
    w1, _ = sor.solve_sor(fixed, b, rows, cols, omega, screen=0.01, tol=1e-6)
    np.testing.assert_allclose(v, w1, atol=1e-5)


def test_sor_regions_do_not_depend_on_threads_or_balance():
    import numba
    rng = np.random.default_rng(22)
    _, _, fixed, b, rows, cols, region = _sor_case(rng)
    omega = sor.sor_omega(np.full(len(rows), 12.0), np.full(len(rows), 12.0))
    a, _ = sor.solve_sor_regions(fixed, b, rows, cols, omega, region, screen=0.01, tol=1e-5, threads=2)
    c, _ = sor.solve_sor_regions(fixed, b, rows, cols, omega, region, screen=0.01, tol=1e-5, threads=5)
    numba.set_num_threads(1)
    try:
        d, _ = sor.solve_sor_regions(fixed, b, rows, cols, omega, region, screen=0.01, tol=1e-5, threads=1)
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    assert np.array_equal(a, c) and np.array_equal(a, d)


@pytest.mark.parametrize("step,filt", [(1.0, "lanczos4"), (0.375, "bilinear")])
def test_sor_at_is_the_frame_sized_solve_bit_for_bit(step, filt):
    """``solve_sor_at`` builds the right-hand side, seam gradients and operator at the
    listed pixels only: the same numbers, bit for bit, as ``seam_gradients_at`` + ``rhs``
    + ``solve_sor_regions`` over the frame (regions touching the border, crossing patch
    seams, between fixed pixels), with any thread count; without a source, zero seam
    gradients."""
    import numba
    from scipy.ndimage import label as cc

    rng = np.random.default_rng(31)
    h, w = 37, 53
    src = rng.random((40, 60, 3), dtype=np.float32)
    patch = (np.arange(h)[:, None] // 5 * 11 + np.arange(w)[None, :] // 7).astype(np.uint32)
    off = rng.uniform(0, 30, (int(patch.max()) + 1, 2)).astype(np.float32)
    jitter = rng.uniform(-.3, .3, (2, h, w))
    sx = (np.arange(w, dtype=np.float32)[None, :] * step + off[patch, 0] + jitter[0]).astype(np.float32)
    sy = (np.arange(h, dtype=np.float32)[:, None] * step + off[patch, 1] + jitter[1]).astype(np.float32)
    colors = rng.random((h, w, 3), dtype=np.float32)
    free = rng.random((h, w)) < 0.55
    free[0, :] = True  # a region along the border
    free[20:30, 10:40] = True
    fixed = ~free
    comp, _ = cc(free)
    rows, cols = np.nonzero(free)
    region = (comp[rows, cols] - 1) * 3 + 2  # ids with gaps (the large components' left out)
    omega = sor.sor_omega(np.full(len(rows), 6.0), np.full(len(rows), 6.0)) - rng.uniform(0, .2, len(rows))
    for source in (src, None):
        if source is not None:
            gx, gy = poisson.seam_gradients_at(source, sx, sy, patch, free, step, filter=filt)
        else:
            gx = gy = np.zeros((h, w, 3), np.float32)
        b = poisson.rhs(colors, patch, fixed, gx, gy)
        ref, rinfo = sor.solve_sor_regions(fixed, b, rows, cols, omega, region, screen=0.01, tol=1e-6)
        seams = None if source is None else sor.Seams(source, sx, sy, step, filt)
        got, info = sor.solve_sor_at(colors, patch, rows, cols, omega, region, seams=seams, screen=0.01, tol=1e-6)
        assert np.array_equal(got.view(np.uint32), ref[rows, cols].view(np.uint32)) and info == rinfo
        assert np.abs(got).max() > 1e-3
        numba.set_num_threads(1)
        try:
            one, _ = sor.solve_sor_at(colors, patch, rows, cols, omega, region, seams=seams, screen=0.01, tol=1e-6,
                                      threads=1)
        finally:
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        assert np.array_equal(one, got)
