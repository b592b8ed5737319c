"""Fog node: identity at depth 0, the exact exponential law, height falloff vs. quadrature."""
import numpy as np
import pytest
from scipy.integrate import quad

from proxyshade.errors import NodeInputError
from proxyshade.graph.plate import Plate
from proxyshade.graph.testing import run_node
from proxyshade.kernels import fog as kfog

FOG = [0.6, 0.7, 0.8]


def plate(z, rng, **extra):
    h, w = z.shape
    rgb = rng.random((3, h, w), dtype=np.float32)
    ch = {"R": rgb[0], "G": rgb[1], "B": rgb[2], "Z": z.astype(np.float32)}
    ch.update(extra.pop("channels", {}))
    return Plate(ch, extra)


@pytest.mark.parametrize("params", [{}, {"density": 3.0}, {"density": 0.5, "height_falloff": 0.3, "camera_height": 2.0,
                                                           "base_height": -1.0}])
def test_depth_zero_changes_nothing(params):
    rng = np.random.default_rng(0)
    z = np.zeros((6, 7))
    py = rng.normal(size=z.shape).astype(np.float32)
    p = plate(z, rng, channels={"P.X": py, "P.Y": py, "P.Z": py})
    out = run_node("Fog", dict(params, colour=FOG), {"image": p})
    for c in "RGB":
        assert np.array_equal(out[c], p[c])


def test_uniform_fog_follows_exponential_law():
    rng = np.random.default_rng(1)
    z = np.linspace(0, 400, 40 * 5).reshape(40, 5)
    p = plate(z, rng)
    dens = 0.05
    out = run_node("Fog", {"colour": FOG, "density": dens}, {"image": p})
    t = np.exp(-dens * z.astype(np.float32).astype(np.float64))
    for i, c in enumerate("RGB"):
        want = p[c] * t + FOG[i] * (1 - t)
        np.testing.assert_allclose(out[c], want, rtol=0, atol=2e-7)
        err = np.abs(out[c] - FOG[i]).ravel()
        assert err[-1] < 1e-6  # 400 units at 0.05 -> T = 2e-9
        # distance to the fog colour shrinks exactly by T
        np.testing.assert_allclose(err, np.abs(p[c] - FOG[i]).ravel() * t.ravel(), atol=2e-7)


def test_sky_gets_sky_amount_and_alpha_scales_fog():
    rng = np.random.default_rng(2)
    z = np.array([[np.inf, 10.0], [np.inf, 10.0]])
    a = np.array([[1, 0.5], [1, 0.5]], np.float32)
    p = plate(z, rng, channels={"A": a})
    out = run_node("Fog", {"colour": FOG, "density": 0.1, "sky": 0.25}, {"image": p})
    np.testing.assert_allclose(out["R"][0, 0], p["R"][0, 0] * 0.75 + FOG[0] * 0.25, atol=1e-7)
    t = np.exp(-1.0)
    np.testing.assert_allclose(out["G"][0, 1], p["G"][0, 1] * t + FOG[1] * (1 - t) * 0.5, atol=1e-7)
    assert np.array_equal(out["A"], a)


def test_height_falloff_matches_quadrature_along_rays():
    rng = np.random.default_rng(3)
    cam = np.array([1.0, 5.0, -2.0])
    pts = rng.uniform(-20, 20, (4, 5, 3))
    pts[..., 1] = rng.uniform(-3, 12, (4, 5))
    pts[0, 0, 1] = cam[1]  # horizontal ray (the series branch)
    ch = {f"P.{a}": pts[..., i].astype(np.float32) for i, a in enumerate("XYZ")}
    z = np.linalg.norm(pts - cam, axis=-1)
    p = plate(z, rng, channels=ch, camera={"position": cam.tolist()}, up_axis="Y")
    dens, k, base = 0.08, 0.35, 1.5
    out = run_node("Fog", {"colour": FOG, "density": dens, "height_falloff": k, "base_height": base,
                           "distance": "range"}, {"image": p})
    p32 = pts.astype(np.float32).astype(np.float64)
    for iy in range(4):
        for ix in range(5):
            q = p32[iy, ix]
            d = np.linalg.norm(q - cam)
            tau, _ = quad(lambda s: dens * np.exp(-k * (cam[1] + s / d * (q[1] - cam[1]) - base)), 0, d,
                          epsabs=1e-12, epsrel=1e-12)
            t = np.exp(-tau)
            np.testing.assert_allclose(out["R"][iy, ix], p["R"][iy, ix] * t + FOG[0] * (1 - t), atol=2e-6)


def test_up_axis_z_from_meta_and_matrix_camera():
    rng = np.random.default_rng(4)
    m = np.eye(4)
    m[3, :3] = [0, 0, 3.0]  # USD row-vector camera-to-world: camera at z = 3
    pz = np.full((2, 3), 0.0, np.float32)
    p = plate(np.full((2, 3), 5.0), rng, channels={"P.X": pz, "P.Y": pz + 100, "P.Z": pz},
              camera={"camera_to_world": m.tolist()}, up_axis="Z")
    out = run_node("Fog", {"colour": FOG, "density": 0.2, "height_falloff": 0.5}, {"image": p})
    tau = float(kfog.optical_depth(5.0, 3.0, 0.0, 0.2, 0.5))
    t = np.exp(-tau)
    np.testing.assert_allclose(out["B"], p["B"] * t + FOG[2] * (1 - t), atol=1e-6)


def test_height_falloff_without_p_is_one_line_error():
    p = plate(np.ones((2, 2)), np.random.default_rng(5))
    with pytest.raises(NodeInputError, match="need P.X, P.Y, P.Z") as e:
        run_node("Fog", {"height_falloff": 0.1}, {"image": p})
    assert "\n" not in str(e.value)


def test_missing_depth_is_error():
    with pytest.raises(NodeInputError, match="input 'image' has no channel Z; Fog needs R, G, B, Z there"):
        run_node("Fog", {}, {"image": Plate({c: np.zeros((1, 1), np.float32) for c in "RGB"})})


def test_camera_position_from_camera_info_meta():
    """The proxy's meta camera (CameraInfo.to_meta: column-vector camera_to_world)."""
    from proxyshade.nodes.fog import camera_position

    m = np.eye(4)
    m[:3, :3] = [[0, 0, 1], [0, 1, 0], [-1, 0, 0]]
    m[:3, 3] = [4.0, 9.0, -2.0]
    assert camera_position({"camera": {"camera_to_world": m.tolist()}}).tolist() == [4.0, 9.0, -2.0]
    assert camera_position({"camera": {"camera_to_world": m.T.tolist()}}).tolist() == [4.0, 9.0, -2.0]
    assert camera_position({}) is None
