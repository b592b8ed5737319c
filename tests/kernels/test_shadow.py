"""Shadow-map PCF against a slow reference; the light frame and orthographic framing."""
import numpy as np
import pytest

from proxyshade.kernels import shadow


def naive_pcf(P, m, dm, radius, bias):
    out = np.zeros(P.shape[:2])
    for y in range(P.shape[0]):
        for x in range(P.shape[1]):
            p = P[y, x].astype(np.float64)
            if not np.all(np.isfinite(p)):
                continue
            c, r, d = m @ np.append(p, 1.0)
            total = 0.0
            for oy in range(-radius, radius + 1):
                for ox in range(-radius, radius + 1):
                    tc, tr = c + ox, r + oy
                    c0, r0 = int(np.floor(tc)), int(np.floor(tr))
                    for rr, wr in ((r0, 1 - (tr - r0)), (r0 + 1, tr - r0)):
                        for cc, wc in ((c0, 1 - (tc - c0)), (c0 + 1, tc - c0)):
                            inside = 0 <= rr < dm.shape[0] and 0 <= cc < dm.shape[1]
                            occ = inside and dm[rr, cc] < d - bias
                            total += wr * wc * occ
            out[y, x] = total / (2 * radius + 1) ** 2
    return out


@pytest.mark.parametrize("radius,bias", [(0, 0.0), (1, 0.05), (2, 0.0)])
def test_pcf_matches_reference(radius, bias):
    rng = np.random.default_rng(radius)
    P = rng.uniform(-1, 1, (9, 8, 3))
    P[0, 0] = np.inf
    m = rng.normal(size=(3, 4)) * 3
    m[:2, 3] += 6
    dm = rng.uniform(-4, 4, (12, 11))
    dm[rng.random(dm.shape) < 0.3] = np.inf
    got = shadow.pcf_shadow(P, m, dm, radius=radius, bias=bias)
    np.testing.assert_allclose(got, naive_pcf(P, m, dm, radius, bias), atol=1e-6)
    assert got[0, 0] == 0


def test_pcf_deterministic_across_threads():
    import numba
    rng = np.random.default_rng(7)
    P = rng.uniform(-1, 1, (40, 30, 3))
    m = rng.normal(size=(3, 4)) * 5
    dm = rng.uniform(-4, 4, (16, 16))
    a = shadow.pcf_shadow(P, m, dm, radius=1)
    old = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        b = shadow.pcf_shadow(P, m, dm, radius=1)
    finally:
        numba.set_num_threads(old)
    assert np.array_equal(a, b)


@pytest.mark.parametrize("direction", [(0, -1, 0), (0.3, -1, 0.2), (1, 0, 0), (0, 0, -1)])
def test_light_frame_is_orthonormal_right_handed(direction):
    f = shadow.light_frame(direction)
    np.testing.assert_allclose(f @ f.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(f) == pytest.approx(1.0)
    np.testing.assert_allclose(f[2], np.asarray(direction) / np.linalg.norm(direction))


def test_ortho_projection_frames_points_and_matches_rasterizer_convention():
    rng = np.random.default_rng(3)
    pts = rng.uniform(-5, 5, (50, 3))
    d = np.array([0.2, -1, 0.1])
    pr = shadow.ortho_light_projection(d, pts, 64)
    h = np.c_[pts, np.ones(50)]
    cr = h @ pr["world_to_map"].T
    assert cr[:, :2].min() > -0.5 and cr[:, :2].max() < 63.5
    l = d / np.linalg.norm(d)
    # depth grows along the light direction, one unit per world unit, and is >= 1
    np.testing.assert_allclose(np.diff(cr[:, 2]), np.diff(pts @ l))
    assert cr[:, 2].min() == pytest.approx(1.0)
    # the rasterizer's projection of light-camera points (centres at +0.5) is world_to_map
    cam = h @ pr["world_to_cam"].T
    col = pr["cx"] + pr["fx"] * cam[:, 0] - 0.5
    row = pr["cy"] - pr["fy"] * cam[:, 1] - 0.5
    np.testing.assert_allclose(np.c_[col, row, -cam[:, 2]], cr, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(pr["world_to_map"][0, :3]) * pr["texel"], 1.0)


def test_flat_occluder_shadows_its_footprint():
    """A square occluder above the z=0 plane, light straight down: hard edges with radius 0."""
    n = 32
    m = np.zeros((3, 4))
    m[0, 0] = m[1, 1] = n / 2.0  # x, y in [-1, 1] -> map [0, 32]
    m[0, 3] = m[1, 3] = n / 2.0 - 0.5
    m[2, 2] = -1.0  # light travels along -z: depth = -z
    dm = np.full((n, n), np.inf)
    dm[8:24, 8:24] = -1.0  # occluder at z = 1
    ys, xs = np.mgrid[0:20, 0:20]
    P = np.stack([(xs + 0.5) / 10 - 1, (ys + 0.5) / 10 - 1, np.zeros(xs.shape)], -1)
    s = shadow.pcf_shadow(P, m, dm, radius=0)
    inside = (np.abs(P[..., 0]) < 0.5 - 1 / n) & (np.abs(P[..., 1]) < 0.5 - 1 / n)
    outside = (np.abs(P[..., 0]) > 0.5 + 1 / n) | (np.abs(P[..., 1]) > 0.5 + 1 / n)
    assert np.all(s[inside] == 1) and np.all(s[outside] == 0)
