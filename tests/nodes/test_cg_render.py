"""CgRender: CG prims through the camera with the proxy rasterizer and Lambert shading."""
import warnings

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdSemantics, Vt

from proxyshade.errors import NodeInputError
from proxyshade.graph.plate import Plate
from proxyshade.graph.testing import run_node

CUBE_PTS = [(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
CUBE_FACES = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]


def aim(xf: UsdGeom.Xformable, direction) -> None:
    """Rotate a light so that its -Z axis points along ``direction``."""
    rot = Gf.Rotation(Gf.Vec3d(0, 0, -1), Gf.Vec3d(*[float(v) for v in direction]))
    xf.AddTransformOp().Set(Gf.Matrix4d().SetRotate(rot))


def mesh(stage, path, points, faces, *, color=(0.5, 0.5, 0.5), cg=True, label=None, translate=None, scale=None):
    m = UsdGeom.Mesh.Define(stage, path)
    m.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in points]))
    m.CreateFaceVertexCountsAttr([len(f) for f in faces])
    m.CreateFaceVertexIndicesAttr([i for f in faces for i in f])
    m.CreateDisplayColorAttr([Gf.Vec3f(*color)])
    if translate is not None:
        m.AddTranslateOp().Set(Gf.Vec3d(*translate))
    if scale is not None:
        m.AddScaleOp().Set(Gf.Vec3f(*scale))
    if cg:
        m.GetPrim().CreateAttribute("proxyshade:cg", Sdf.ValueTypeNames.Bool).Set(True)
    if label:
        UsdSemantics.LabelsAPI.Apply(m.GetPrim(), "texture").CreateLabelsAttr([label])
    return m


def make_stage(path, *, light_dir=(0.0, -0.6, -0.8), intensity=2.0, cam_z=10.0, cube=None, quad=True):
    """A camera at (0, 0, cam_z) looking down -z, a CG quad at z = 0 facing it (colour
    (0.8, 0.4, 0.2)), a labelled non-CG backdrop at z = -5, optionally a CG cube."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.Xform.Define(stage, "/World")
    cam = UsdGeom.Camera.Define(stage, "/World/Camera")
    cam.CreateFocalLengthAttr(50.0)
    cam.CreateHorizontalApertureAttr(36.0)
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.1, 1000))
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 0, cam_z))
    if quad:
        mesh(stage, "/World/Quad", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [(0, 1, 2, 3)],
             color=(0.8, 0.4, 0.2))
    mesh(stage, "/World/Backdrop", [(-50, -50, -5), (50, -50, -5), (50, 50, -5), (-50, 50, -5)], [(0, 1, 2, 3)],
         cg=False, label="sky")
    if cube is not None:
        mesh(stage, "/World/Cube", CUBE_PTS, CUBE_FACES, color=(0.2, 0.3, 0.9), **cube)
    if light_dir is not None:
        light = UsdLux.DistantLight.Define(stage, "/World/Sun")
        light.CreateIntensityAttr(intensity)
        aim(light, light_dir)
    stage.GetRootLayer().Save()
    return path


def test_quad_depth_coverage_ids_and_lambert(tmp_path):
    scene = make_stage(tmp_path / "s.usda")
    out = run_node("CgRender", {"scene": str(scene), "resolution": [96, 64], "ambient": 0.1})
    cover = out["A"] > 0
    assert set(np.unique(out["object.id"])) == {0, 1}
    assert np.array_equal(cover, out["object.id"] == 1)
    assert out.meta["objects"] == [{"name": "/World/Quad", "id": 1}]
    # the backdrop (not CG) is not rendered; the quad's depth is exact
    assert np.all(np.isinf(out["Z"][~cover]))
    np.testing.assert_allclose(out["Z"][cover], 10.0, rtol=1e-6)
    # coverage = the projected square: pixel centres inside |x|, |y| < fx * 1 / 10
    fx = 96 * 50 / 36
    cols, rows = np.meshgrid(np.arange(96) + 0.5, np.arange(64) + 0.5)
    inside = (np.abs(cols - 48) < fx / 10) & (np.abs(rows - 32) < fx / 10)
    assert np.array_equal(cover, inside)
    # Lambert: the face normal is +z, the light travels along (0, -0.6, -0.8): cos = 0.8
    shade = 0.1 + 2.0 * 0.8 / np.pi
    for c, alb in zip("RGB", (0.8, 0.4, 0.2)):
        np.testing.assert_allclose(out[c][cover], alb * shade, rtol=1e-6)
        assert np.all(out[c][~cover] == 0)
    np.testing.assert_allclose(out["N.Z"][cover], 1.0, atol=1e-6)
    np.testing.assert_allclose(out["P.Z"][cover], 0.0, atol=1e-6)
    assert out.meta["light"]["path"] == "/World/Sun"
    brighter = run_node("CgRender", {"scene": str(scene), "resolution": [96, 64], "ambient": 0.1, "exposure": 1.0})
    np.testing.assert_allclose(brighter["G"], 2 * out["G"], rtol=1e-6)


def test_camera_from_proxy_plate_meta(tmp_path):
    from proxyshade.io import usd

    scene = make_stage(tmp_path / "s.usda")
    cam = usd.camera_at(usd.open_stage(scene), None, 1, 40, 30)
    proxy = Plate({"Z": np.zeros((30, 40), np.float32)}, {"camera": cam.to_meta()})
    out = run_node("CgRender", {"scene": str(scene)}, {"proxy": proxy})
    assert out.shape == (30, 40)
    a = run_node("CgRender", {"scene": str(scene), "resolution": [40, 30]})
    assert all(np.array_equal(out[n], a[n]) for n in out.names())


def test_no_light_warns_naming_the_missing_prim_and_uses_headlight(tmp_path):
    scene = make_stage(tmp_path / "s.usda", light_dir=None)
    with pytest.warns(UserWarning, match="CG prims \\(/World/Quad\\) but no UsdLux.DistantLight"):
        out = run_node("CgRender", {"scene": str(scene), "resolution": [48, 32], "ambient": 0.0})
    cover = out["A"] > 0
    np.testing.assert_allclose(out["R"][cover], 0.8, rtol=1e-6)  # headlight: cos = 1


def test_winding_does_not_change_shading(tmp_path):
    a = make_stage(tmp_path / "a.usda")
    out_a = run_node("CgRender", {"scene": str(a), "resolution": [48, 32]})
    stage = Usd.Stage.Open(str(a))
    m = UsdGeom.Mesh(stage.GetPrimAtPath("/World/Quad"))
    m.GetFaceVertexIndicesAttr().Set([3, 2, 1, 0])
    stage.GetRootLayer().Export(str(tmp_path / "b.usda"))
    out_b = run_node("CgRender", {"scene": str(tmp_path / "b.usda"), "resolution": [48, 32]})
    for n in ("R", "G", "B", "A", "Z", "N.Z", "object.id"):
        np.testing.assert_allclose(out_a[n], out_b[n], rtol=1e-6)


def test_bad_camera_is_one_line_error(tmp_path):
    scene = make_stage(tmp_path / "s.usda")
    with pytest.raises(NodeInputError, match="no camera at /World/Nope; cameras in the stage: /World/Camera") as e:
        run_node("CgRender", {"scene": str(scene), "camera": "/World/Nope", "resolution": [8, 8]})
    assert "\n" not in str(e.value)


def test_polygon_meshes_shade_flat(tmp_path):
    """A cube with shared vertices: its front face has one colour (face normal +z)."""
    scene = make_stage(tmp_path / "s.usda", quad=False, cube={"translate": (0, 0, 0)})
    out = run_node("CgRender", {"scene": str(scene), "resolution": [64, 48], "ambient": 0.1})
    cover = out["A"] > 0
    assert cover.sum() > 100
    np.testing.assert_allclose(out["B"][cover], 0.9 * (0.1 + 2.0 * 0.8 / np.pi), rtol=1e-5)
    np.testing.assert_allclose(out["N.Z"][cover], 1.0, atol=1e-6)
