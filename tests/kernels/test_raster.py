"""The rasterizer against a slow per-pixel reference, and its watertightness."""
import numpy as np
import pytest

from proxyshade.kernels.raster import SUB, interpolate, rasterize


def ref_rasterize(points, tris, w, h, fx, fy, cx, cy):
    """Obvious reference (no clipping: all points in front): every pixel centre against
    every triangle with the same fixed-point edge functions and tie rule."""
    depth = np.full((h, w), np.inf)
    tid = np.full((h, w), -1)
    for t, (a, b, c) in enumerate(tris):
        P = []
        for v in (a, b, c):
            x, y, z = points[v]
            d = -z
            P.append((int(np.floor((cx + fx * x / d) * SUB + 0.5)), int(np.floor((cy - fy * y / d) * SUB + 0.5)), d))
        (x0, y0, d0), (x1, y1, d1), (x2, y2, d2) = P
        area = (x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0)
        if area == 0:
            continue
        if area < 0:
            (x1, y1, d1), (x2, y2, d2) = (x2, y2, d2), (x1, y1, d1)
            area = -area

        def owns(ax, ay, bx, by):
            return by - ay > 0 or (by - ay == 0 and bx - ax < 0)
        for i in range(h):
            for j in range(w):
                px, py = j * SUB + SUB // 2, i * SUB + SUB // 2
                e = [(x2 - x1) * (py - y1) - (y2 - y1) * (px - x1),
                     (x0 - x2) * (py - y2) - (y0 - y2) * (px - x2),
                     (x1 - x0) * (py - y0) - (y1 - y0) * (px - x0)]
                own = [owns(x1, y1, x2, y2), owns(x2, y2, x0, y0), owns(x0, y0, x1, y1)]
                if any(v < 0 or (v == 0 and not o) for v, o in zip(e, own)):
                    continue
                l = [v / area for v in e]
                z = 1.0 / (l[0] / d0 + l[1] / d1 + l[2] / d2)
                if z < depth[i, j] or (z == depth[i, j] and t < tid[i, j]):
                    depth[i, j], tid[i, j] = z, t
    return depth, tid


@pytest.mark.parametrize("seed", range(4))
def test_matches_reference_on_random_triangles(seed):
    rng = np.random.default_rng(seed)
    n = 12
    pts = np.column_stack([rng.uniform(-1.5, 1.5, 3 * n), rng.uniform(-1.5, 1.5, 3 * n), rng.uniform(-6, -2, 3 * n)])
    tris = np.arange(3 * n).reshape(n, 3)
    w, h = 23, 17
    depth, tid, bary, count = rasterize(pts, tris, width=w, height=h, fx=12.0, fy=12.0, cx=w / 2, cy=h / 2)
    rd, rt = ref_rasterize(pts, tris, w, h, 12.0, 12.0, w / 2, h / 2)
    assert np.array_equal(tid, rt)
    np.testing.assert_allclose(depth, rd.astype(np.float32), rtol=1e-6)
    # barycentrics reproduce camera-space depth: sum b_k * z_k == -depth (perspective-correct)
    zc = interpolate(-pts[:, 2:3], tris, tid, bary)[..., 0]
    m = tid >= 0
    np.testing.assert_allclose(zc[m], depth[m], rtol=1e-5)


def grid_mesh(n, z=-3.0, jitter=0.0, seed=0):
    """A plane of n×n cells (2 triangles each) covering more than the view."""
    rng = np.random.default_rng(seed)
    ys, xs = np.mgrid[0:n + 1, 0:n + 1]
    pts = np.column_stack([xs.ravel() / n * 8 - 4, ys.ravel() / n * 8 - 4, np.full(xs.size, z)]).astype(float)
    inner = (xs.ravel() % n != 0) & (ys.ravel() % n != 0)
    pts[inner, :2] += rng.uniform(-jitter, jitter, (inner.sum(), 2))
    if jitter:  # move vertices along their view rays: a bumpy surface that never folds on screen
        s = rng.uniform(0.8, 1.3, len(pts))
        pts *= s[:, None]
    tris = []
    for i in range(n):
        for j in range(n):
            a, b, c, d = i * (n + 1) + j, i * (n + 1) + j + 1, (i + 1) * (n + 1) + j, (i + 1) * (n + 1) + j + 1
            tris += [(a, b, d), (a, d, c)] if (i + j) % 2 else [(a, b, c), (b, d, c)]
    return pts, np.array(tris)


@pytest.mark.parametrize("seed", range(3))
def test_no_cracks_no_double_coverage_on_a_closed_surface(seed):
    pts, tris = grid_mesh(9, jitter=0.3, seed=seed)
    depth, tid, bary, count = rasterize(pts, tris, width=64, height=48, fx=40, fy=40, cx=32, cy=24)
    assert (count == 1).all()  # every pixel exactly once


def test_near_plane_clipping_keeps_the_surface_watertight():
    # a ground plane under the camera, extending behind it: must be clipped, not dropped
    n = 16
    ys, xs = np.mgrid[0:n + 1, 0:n + 1]
    pts = np.column_stack([xs.ravel() - n / 2, np.full(xs.size, -1.0), -(ys.ravel() - 4.0)]).astype(float)
    tris = np.array([(i * (n + 1) + j, i * (n + 1) + j + 1, (i + 1) * (n + 1) + j + 1) for i in range(n) for j in range(n)]
                    + [(i * (n + 1) + j, (i + 1) * (n + 1) + j + 1, (i + 1) * (n + 1) + j) for i in range(n) for j in range(n)])
    depth, tid, bary, count = rasterize(pts, tris, width=40, height=30, fx=20, fy=20, cx=20, cy=15, near=0.05)
    # the far edge (depth 12) projects to row 15 + 20/12 = 16.67: rows from 17 down are ground
    assert (count[17:, :] == 1).all()
    assert (count[:17, :] == 0).all()


def test_plane_depth_exact():
    pts = np.array([[-50, -50, -7.25], [50, -50, -7.25], [50, 50, -7.25], [-50, 50, -7.25]], float)
    depth, tid, _, _ = rasterize(pts, np.array([[0, 1, 2], [0, 2, 3]]), width=32, height=32, fx=30, fy=30, cx=16, cy=16)
    assert np.all(np.abs(depth - 7.25) / 7.25 < 1e-6)


def test_orthographic_mode():
    pts = np.array([[-1, -1, -2], [1, -1, -2], [0, 1, -4]], float)
    depth, tid, _, _ = rasterize(pts, np.array([[0, 1, 2]]), width=20, height=20, fx=10, fy=10, cx=10, cy=10, ortho=True)
    assert tid[2, 1] == -1 and tid[15, 10] == 0 and tid[5, 10] == 0
    assert depth[15, 10] < depth[5, 10]  # linear depth in ortho: lower rows nearer


def test_threads_give_identical_results():
    import numba

    pts, tris = grid_mesh(7, jitter=0.3, seed=5)
    outs = []
    for t in (1, 2):
        numba.set_num_threads(t)
        outs.append(rasterize(pts, tris, width=50, height=70, fx=40, fy=40, cx=25, cy=35))
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    for a, b in zip(*outs):
        assert np.array_equal(a, b)


@pytest.mark.parametrize("n", [0, 5, 1000])
def test_bin_rows_parallel_lists_what_bin_rows_lists(n):
    from proxyshade.kernels.raster import bin_rows, bin_rows_parallel

    rng = np.random.default_rng(n)
    r0 = rng.integers(0, 100, n).astype(np.int32)
    r1 = (r0 + rng.integers(-3, 20, n)).clip(max=99).astype(np.int32)  # some r0 > r1: skipped
    want = bin_rows(r0, r1, 13, 8)
    got = bin_rows_parallel(r0, r1, 13, 8)
    assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])


@pytest.mark.parametrize("normalize", [False, True])
def test_planar_interpolation_is_the_interleaved_one_by_plane(normalize):
    """ProxyRender's planar output (each component a contiguous plate channel) holds the
    interleaved output's numbers, bit for bit, the empty pixels' value included."""
    rng = np.random.default_rng(7)
    n = 10
    pts = np.column_stack([rng.uniform(-1.5, 1.5, 3 * n), rng.uniform(-1.5, 1.5, 3 * n), rng.uniform(-6, -2, 3 * n)])
    tris = np.arange(3 * n).reshape(n, 3)
    _, tid, bary, _ = rasterize(pts, tris, width=19, height=13, fx=10.0, fy=10.0, cx=9.5, cy=6.5)
    attr = rng.normal(size=(3 * n, 3))
    a = interpolate(attr, tris, tid, bary, empty=-2.0, normalize=normalize)
    p = interpolate(attr, tris, tid, bary, empty=-2.0, normalize=normalize, planar=True)
    assert (tid < 0).any() and (tid >= 0).any()
    assert p.shape == (3,) + tid.shape and all(p[k].flags.c_contiguous for k in range(3))
    assert np.array_equal(np.moveaxis(p, 0, -1), a)
