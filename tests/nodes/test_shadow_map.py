"""ShadowMap: a CG cube above a synthesized plane shadows its analytic projection."""
import numpy as np
import pytest
from scipy.spatial import Delaunay

from proxyshade.errors import NodeInputError
from proxyshade.graph.plate import Plate
from proxyshade.graph.testing import run_node
from tests.nodes.test_cg_render import CUBE_PTS, make_stage

LIGHT = np.array([0.4, -1.0, 0.25])
CUBE = {"translate": (0.5, 2.0, -0.3), "scale": (0.6, 0.5, 0.8)}


def ground_plate(n=200, half=5.0, shift=(0.0, 0.0)):
    """A synthesized plane y = 0 seen from above: P on a regular x, z grid; sky on row 0."""
    xs = np.linspace(-half, half, n) + shift[0]
    zs = np.linspace(-half, half, n) + shift[1]
    X, Z = np.meshgrid(xs, zs)
    px, py, pz = X.astype(np.float32), np.zeros_like(X, np.float32), Z.astype(np.float32)
    py[0] = np.inf
    z = np.full((n, n), 10, np.float32)
    z[-1] = np.inf  # sky with a stale P inside the footprint: Z = inf says nothing is there
    px[-1], py[-1], pz[-1] = 1.3, 0.0, 0.2
    rgb = np.full((n, n), 0.6, np.float32)
    lab = np.ones((n, n), np.uint32)
    return Plate({"R": rgb, "G": rgb * 0.5, "B": rgb * 0.25, "Z": z,
                  "P.X": px, "P.Y": py, "P.Z": pz, "label.id": lab}, {"labels": [{"name": "grass", "id": 1}]})


def analytic_footprint(plate):
    corners = np.array(CUBE_PTS, float) * CUBE["scale"] + CUBE["translate"]
    l = LIGHT / np.linalg.norm(LIGHT)
    proj = corners - (corners[:, 1:2] / l[1]) * l  # along the light onto y = 0
    hull = Delaunay(proj[:, [0, 2]])
    pts = np.stack([plate["P.X"].ravel(), plate["P.Z"].ravel()], -1)
    surface = np.isfinite(plate["Z"]) & np.isfinite(plate["P.Y"])
    return (hull.find_simplex(pts) >= 0).reshape(plate.shape) & surface


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    return make_stage(tmp_path_factory.mktemp("shadow") / "cube.usda", light_dir=LIGHT, quad=False, cube=CUBE)


def iou(a, b):
    return (a & b).sum() / (a | b).sum()


@pytest.mark.parametrize("radius", [0, 1, 2])
def test_cube_shadow_matches_analytic_projection(scene, radius):
    plate = ground_plate()
    out = run_node("ShadowMap", {"scene": str(scene), "size": 512, "radius": radius, "factor": 0.3},
                   {"image": plate})
    want = analytic_footprint(plate)
    got = out["shadow"] >= 0.5
    assert want.sum() > 500
    assert iou(got, want) >= 0.95
    full = out["shadow"] == 1
    np.testing.assert_allclose(out["R"][full], 0.6 * 0.3, rtol=1e-6)
    lit = out["shadow"] == 0
    assert np.array_equal(out["G"][lit], plate["G"][lit])
    assert not out["shadow"][0].any() and not out["shadow"][-1].any()  # sky
    assert out.meta["light"]["path"] == "/World/Sun"


def test_soft_edges_with_pcf(scene):
    plate = ground_plate()
    hard = run_node("ShadowMap", {"scene": str(scene), "size": 256, "radius": 0}, {"image": plate})["shadow"]
    soft = run_node("ShadowMap", {"scene": str(scene), "size": 256, "radius": 3}, {"image": plate})["shadow"]
    partial = lambda s: ((s > 0.02) & (s < 0.98)).sum()  # noqa: E731
    assert partial(soft) > 2 * partial(hard)


def test_shadow_stays_on_the_ground_when_the_view_moves(scene):
    """The same world points, seen in other pixels (a camera move), get the same shadow."""
    a = ground_plate()
    sh = np.roll(a.layer(["P.X", "P.Y", "P.Z"]), (7, -11), axis=(0, 1))
    b = a.with_channels({f"P.{c}": np.ascontiguousarray(sh[..., i]) for i, c in enumerate("XYZ")})
    b.channels["Z"] = np.roll(a["Z"], (7, -11), axis=(0, 1))
    sa = run_node("ShadowMap", {"scene": str(scene), "size": 256}, {"image": a})["shadow"]
    sb = run_node("ShadowMap", {"scene": str(scene), "size": 256}, {"image": b})["shadow"]
    assert np.array_equal(np.roll(sa, (7, -11), axis=(0, 1)), sb)


def test_no_light_skips_shadows_with_warning_naming_the_prim(tmp_path):
    scene = make_stage(tmp_path / "nolight.usda", light_dir=None, quad=False, cube=CUBE)
    plate = ground_plate(40)
    with pytest.warns(UserWarning, match=r"CG prims \(/World/Cube\) but no UsdLux.DistantLight prim; shadows skipped"):
        out = run_node("ShadowMap", {"scene": str(scene)}, {"image": plate})
    assert np.array_equal(out["R"], plate["R"]) and not out["shadow"].any()


def test_no_cg_passes_through(tmp_path):
    scene = make_stage(tmp_path / "nocg.usda", quad=False)
    plate = ground_plate(40)
    out = run_node("ShadowMap", {"scene": str(scene)}, {"image": plate})
    assert np.array_equal(out["R"], plate["R"]) and not out["shadow"].any()


def test_missing_world_position_is_one_line_error(scene):
    plate = ground_plate(20).select(["R", "G", "B", "Z"])
    with pytest.raises(NodeInputError, match="input 'image' has no channel P.X, P.Y, P.Z; ShadowMap needs") as e:
        run_node("ShadowMap", {"scene": str(scene)}, {"image": plate})
    assert "\n" not in str(e.value)
