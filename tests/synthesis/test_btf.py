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
