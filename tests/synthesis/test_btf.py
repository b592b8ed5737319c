"""synthesis/btf: a terrain's own parametrization (arc length along its grid) against a
plain loop, and the level count the support's synthesis picks."""
import math

import numpy as np
import pytest

from proxyshade.synthesis import btf


def _grid(rng, nx, nz, slope=0.0):
    xs = np.sort(rng.random(nx)) * 3 - 1
    zs = np.sort(rng.random(nz)) * 2 + 0.5
    X, Z = np.meshgrid(xs, zs)
    Y = rng.random(X.shape) * 0.3 + slope * X
    return xs, zs, np.stack([X, Y, Z], -1)


def test_grid_surface_is_the_arc_length_along_rows_and_columns(rng=np.random.default_rng(4)):
    xs, zs, G = _grid(rng, 5, 4)
    pts = G.reshape(-1, 3)[rng.permutation(20)]  # the mesh's point order does not matter
    gx, gz, U, V = btf.grid_surface(pts)
    np.testing.assert_allclose(gx, xs)
    np.testing.assert_allclose(gz, zs)
    for i in range(4):
        for j in range(5):
            u = xs[0] + sum(math.dist(G[i, k], G[i, k + 1]) for k in range(j))
            v = zs[0] + sum(math.dist(G[k, j], G[k + 1, j]) for k in range(i))
            assert U[i, j] == pytest.approx(u, abs=1e-9) and V[i, j] == pytest.approx(v, abs=1e-9)


def test_grid_uv_is_bilinear_and_planar_on_a_flat_grid():
    rng = np.random.default_rng(5)
    xs, zs, G = _grid(rng, 6, 5)
    G[..., 1] = 0.2  # flat: U, V are x, z, so the coordinates are the planar ones
    grid = btf.grid_surface(G.reshape(-1, 3))
    P = np.stack([rng.uniform(xs[0], xs[-1], 50), np.full(50, 0.2), rng.uniform(zs[0], zs[-1], 50)], -1)
    u, v = btf.grid_uv(P, grid, (0.1, -0.2), 0.05)
    pu, pv = btf.planar_uv(P, (0.1, -0.2), 0.05)
    np.testing.assert_allclose(u, pu, atol=1e-9)
    np.testing.assert_allclose(v, pv, atol=1e-9)


def test_grid_uv_follows_a_slope():
    """A plane rising at 30° along x: the texture coordinate grows by 1/cos 30° per unit of x
    (planar: 1), so a texel keeps its size on the slope."""
    xs = np.linspace(0, 2, 9)
    zs = np.linspace(0, 1, 3)
    X, Z = np.meshgrid(xs, zs)
    G = np.stack([X, X * math.tan(math.radians(30)), Z], -1)
    grid = btf.grid_surface(G.reshape(-1, 3))
    P = np.array([[0.5, 0.0, 0.3], [1.7, 0.0, 0.6]])
    u, v = btf.grid_uv(P, grid, (0.0, 0.0), 1.0)
    np.testing.assert_allclose(u + 0.5, P[:, 0] / math.cos(math.radians(30)), atol=1e-12)
    np.testing.assert_allclose(v + 0.5, P[:, 2], atol=1e-12)


def test_grid_surface_refuses_a_mesh_off_a_grid():
    rng = np.random.default_rng(6)
    assert btf.grid_surface(rng.random((12, 3))) is None
    _, _, G = _grid(rng, 4, 3)
    assert btf.grid_surface(G.reshape(-1, 3)[:-1]) is None


@pytest.mark.parametrize("shape,radius,want", [((126, 126), 3, 5), ((96, 200), 3, 4), ((24, 24), 2, 3),
                                               ((10, 10), 3, 1)])
def test_auto_levels_is_the_most_that_fit(shape, radius, want):
    n = btf.auto_levels(shape, radius)
    assert n == want
    btf.check_synthesis_size(shape, radius, n)  # fits
    if n < btf.MOST_LEVELS:
        with pytest.raises(Exception, match="smaller than the disk"):
            btf.check_synthesis_size(shape, radius, n + 1)


def naive_hits(heights, qay, qax, slant, tilt, plane, pixel, wrap):
    """surface_hits per pixel: walk s down from above the highest point, stop at the first
    surface column the ray is under."""
    H, W = qay.shape
    t = math.tan(math.radians(slant))
    d = (math.cos(math.radians(tilt)), math.sin(math.radians(tilt)))
    iy, ix = qay.copy(), qax.copy()
    top = int(math.ceil((heights.max() - plane) * t / pixel)) + 1
    bottom = int(math.floor((heights.min() - plane) * t / pixel)) - 1
    for i in range(H):
        for j in range(W):
            for s in range(top, bottom - 1, -1):
                r, c = round(i + s * d[1]), round(j + s * d[0])
                r, c = (r % H, c % W) if wrap else (min(max(r, 0), H - 1), min(max(c, 0), W - 1))
                y, x = qay[r, c], qax[r, c]
                if heights[y, x] >= plane + s * pixel / t:
                    iy[i, j] = min(max(round(y - s * d[1]), 0), heights.shape[0] - 1)
                    ix[i, j] = min(max(round(x - s * d[0]), 0), heights.shape[1] - 1)
                    break
    return iy, ix


@pytest.mark.parametrize("slant,tilt,wrap", [(60.0, 0.0, False), (70.0, 135.0, True), (40.0, 270.0, False)])
def test_surface_hits_match_a_plain_ray_walk(slant, tilt, wrap):
    rng = np.random.default_rng(9)
    heights = rng.random((14, 15)) * 0.05
    qay = rng.integers(0, 14, (12, 13)).astype(np.int64)
    qax = rng.integers(0, 15, (12, 13)).astype(np.int64)
    got = btf.surface_hits(heights, qay, qax, slant, tilt, 0.02, 0.01, wrap=wrap)
    want = naive_hits(heights, qay, qax, slant, tilt, 0.02, 0.01, wrap)
    assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])


def test_surface_hits_see_what_a_render_of_the_sample_sees():
    """The geometry against the renderer: with the input's own sources (the synthesized
    surface is the sample), the hit of a 70° view is the surface point a 70° render of the
    sample's heights meets: its height is the rendered one, to within the height one step
    of s spans (pixel / tan θ)."""
    from proxyshade.io import usd
    from tests.nodes._btf import SCENE

    stage = usd.open_stage(SCENE)
    prims = [q for q in usd.scene_prims(stage, 1) if not q.cg and q.kind == "mesh"]
    pts, tris, nrm, _ = usd.world_meshes(prims)
    size, window, plane = 64, 1.2, 0.04
    pixel = window / size
    for tilt in (0.0, 225.0):
        frontal, steep = btf.height_views(pts, tris, nrm, [{"slant": 0.0, "tilt": 0.0}, {"slant": 70.0, "tilt": tilt}],
                                          size=size, window=window, plane=plane)
        qy, qx = np.mgrid[0:size, 0:size]
        iy, ix = btf.surface_hits(frontal, qy, qx, 70.0, tilt, plane, pixel, wrap=False)
        m = 12  # away from the borders, where the walk leaves the window (clamped)
        inner = (slice(m, -m), slice(m, -m))
        assert np.array_equal(iy[inner], qy[inner]) and np.array_equal(ix[inner], qx[inner])  # one patch: its own input
        # the height of the point hit: walk again and read the column's height
        s_hit = np.full((size, size), np.nan)
        t = math.tan(math.radians(70.0))
        d = (math.cos(math.radians(tilt)), math.sin(math.radians(tilt)))
        for s in range(int(math.ceil((frontal.max() - plane) * t / pixel)) + 1, -40, -1):
            r = np.clip(np.rint(qy + s * d[1]).astype(int), 0, size - 1)
            c = np.clip(np.rint(qx + s * d[0]).astype(int), 0, size - 1)
            hit = np.isnan(s_hit) & (frontal[r, c] >= plane + s * pixel / t)
            s_hit[hit] = frontal[r, c][hit]
        err = np.abs(s_hit - steep)[inner]
        assert np.nanmedian(err) < pixel / t and np.nanpercentile(err, 80) < 2 * pixel / t


def _shifted_stack(rng, height, plane=0.1, pixel=0.01, size=40):
    """A flat textured sample at ``height``: the frontal view a smooth random texture, each
    other view the same texture moved by the parallax of that height (a whole number of
    pixels), as a view rectified to ``plane`` shows it."""
    from proxyshade.kernels.btf import plane_shift

    big = rng.random((size + 40, size + 40, 3))
    big = (big + np.roll(big, 1, 0) + np.roll(big, 1, 1)) / 3
    views = btf.view_grid(10, 30, [0, 90])
    imgs = []
    for v in views:
        dx, dy = plane_shift(v["slant"], v["tilt"], height - plane, pixel)
        # a point at column j appears at j + dx: the view at column j shows the texture at j - dx
        ox, oy = int(round(-dx)), int(round(-dy))
        imgs.append(big[20 + oy:20 + oy + size, 20 + ox:20 + ox + size])
    return views, np.stack(imgs).astype(np.float32), plane, pixel


@pytest.mark.parametrize("height", [0.1, 0.13, 0.07])
def test_estimated_heights_find_a_flat_sample(height):
    views, imgs, plane, pixel = _shifted_stack(np.random.default_rng(3), height)
    est = btf.estimate_heights(imgs, views, 0, pixel, plane)
    per_height = np.abs(btf.parallax_shifts(views, pixel)).max()
    m = 12  # away from the borders, where the shifted views read outside
    err = np.abs(est[m:-m, m:-m] - height)
    assert np.median(err) <= btf.SWEEP_STEP / per_height
    assert (err <= 2 * btf.SWEEP_STEP / per_height).mean() > 0.95


def test_cast_sources_of_a_flat_sample_at_the_plane_are_the_support_sources():
    rng = np.random.default_rng(2)
    views = btf.view_grid(10, 70, [0, 45, 90])
    qay = rng.integers(0, 30, (20, 24)).astype(np.int64)
    qax = rng.integers(0, 30, (20, 24)).astype(np.int64)
    qy, qx = btf.cast_sources(np.full((30, 30), 0.25), qay, qax, views, 0.25, 0.01, wrap=True)
    assert all(np.array_equal(qy[n], qay) and np.array_equal(qx[n], qax) for n in range(len(views)))
    # raised above the plane, a steep view reads the patchwork shifted: it differs
    qy, qx = btf.cast_sources(np.full((30, 30), 0.35), qay, qax, views, 0.25, 0.01, wrap=True)
    assert not np.array_equal(qx[-3], qax)

