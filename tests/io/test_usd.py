"""USD reading: cameras against Gf.Frustum, labels, frames, errors."""
import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdSemantics, Vt

from proxyshade.errors import UserError
from proxyshade.io import usd as U


def stage_with_camera(offsets=(0.0, 0.0), timed=True):
    s = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(s, UsdGeom.Tokens.y)
    if timed:
        s.SetStartTimeCode(1)
        s.SetEndTimeCode(24)
    c = UsdGeom.Camera.Define(s, "/Cam")
    c.CreateFocalLengthAttr(35)
    c.CreateHorizontalApertureAttr(36)
    c.CreateVerticalApertureAttr(24)
    c.CreateHorizontalApertureOffsetAttr(offsets[0])
    c.CreateVerticalApertureOffsetAttr(offsets[1])
    x = UsdGeom.Xformable(c)
    x.AddTranslateOp().Set(Gf.Vec3d(1, 2, 10))
    x.AddRotateXYZOp().Set(Gf.Vec3f(-10, 20, 5))
    return s


@pytest.mark.parametrize("offsets", [(0.0, 0.0), (3.0, -2.0)])
def test_projection_matches_gf_frustum(offsets):
    s = stage_with_camera(offsets)
    cam = U.camera_at(s, "/Cam", 1, 320, 200)
    fr = U.gf_frustum(cam, s)
    V, P = fr.ComputeViewMatrix(), fr.ComputeProjectionMatrix()
    pts = np.random.default_rng(0).uniform(-3, 3, (20, 3))
    col, row, d = cam.project(pts)
    for p, c, r in zip(pts, col, row):
        q = P.Transform(V.Transform(Gf.Vec3d(*p)))
        assert c == pytest.approx((q[0] + 1) / 2 * 320, abs=1e-6)
        assert r == pytest.approx((1 - q[1]) / 2 * 200, abs=1e-6)
    back = cam.unproject(col, row, d)
    np.testing.assert_allclose(back, pts, atol=1e-9)
    assert CameraRoundTrip(cam)


def CameraRoundTrip(cam):
    c2 = U.CameraInfo.from_meta(cam.to_meta())
    return np.allclose(c2.camera_to_world, cam.camera_to_world) and c2.fx == cam.fx and c2.cy == cam.cy


def test_missing_camera_names_the_cameras():
    with pytest.raises(UserError, match=r"no camera at /Nope; cameras in the stage: /Cam"):
        U.camera_at(stage_with_camera(), "/Nope", 1, 10, 10)


def test_frames_outside_time_range_are_errors():
    with pytest.raises(UserError, match="frame 30 is outside the stage's time range 1-24"):
        U.camera_at(stage_with_camera(), "/Cam", 30, 10, 10)
    static = stage_with_camera(timed=False)
    U.camera_at(static, "/Cam", 1, 10, 10)
    with pytest.raises(UserError, match="the stage has no time samples .* frame 10 was asked"):
        U.camera_at(static, "/Cam", 10, 10, 10)


def test_labels_are_inherited_and_cg_marked():
    s = Usd.Stage.CreateInMemory()
    g = UsdGeom.Xform.Define(s, "/G")
    UsdSemantics.LabelsAPI.Apply(g.GetPrim(), "texture").CreateLabelsAttr().Set(Vt.TokenArray(["tree"]))
    UsdGeom.Sphere.Define(s, "/G/S").CreateRadiusAttr(2.0)
    m = UsdGeom.Sphere.Define(s, "/CG/Ball")
    m.GetPrim().GetParent().CreateAttribute(U.CG_ATTR, __import__("pxr").Sdf.ValueTypeNames.Bool, custom=True).Set(True)
    prims = {p.path: p for p in U.scene_prims(s, 1)}
    assert prims["/G/S"].label == "tree" and not prims["/G/S"].cg
    assert prims["/CG/Ball"].cg and prims["/CG/Ball"].label is None


def test_sphere_tessellation_bound():
    for r in (3.0, 40.0, 300.0):
        n = U.sphere_segments(r, 0.25)
        assert r * (1 - np.cos(np.sqrt(2) * np.pi / n)) <= 0.25  # deepest face point, triangles of a 2π/n grid
        pts, tris = U.sphere_mesh(n)
        a, b, c = pts[tris[:, 0]], pts[tris[:, 1]], pts[tris[:, 2]]
        nrm = np.cross(b - a, c - a)
        nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
        assert (np.einsum("ij,ij->i", nrm, a) > 0).all()  # wound outwards
        plane = np.abs(np.einsum("ij,ij->i", nrm, a))  # distance of each face plane from the centre
        assert r * (1 - plane.min()) <= 0.25 + 1e-9


def test_sphere_mesh_is_the_ring_by_ring_triangle_list():
    """The triangles in the loop's order: per meridian the north then the south cap's, then
    per ring band and meridian the quad's two (a reference written as loops)."""
    for seg in (8, 13, 40):
        pts, tris = U.sphere_mesh(seg)
        n = max(8, seg)
        rings = max(4, n // 2)
        r = lambda i, j: 1 + i * n + (j % n)  # noqa: E731
        want = []
        for j in range(n):
            want += [(0, r(0, j + 1), r(0, j)), (len(pts) - 1, r(rings - 2, j), r(rings - 2, j + 1))]
        for i in range(rings - 2):
            for j in range(n):
                want += [(r(i, j), r(i, j + 1), r(i + 1, j + 1)), (r(i, j), r(i + 1, j + 1), r(i + 1, j))]
        assert tris.dtype == np.int64 and [tuple(t) for t in tris.tolist()] == want
        assert pts.dtype == np.float64 and len(pts) == 2 + (rings - 1) * n


def test_unreadable_stage(tmp_path):
    bad = tmp_path / "bad.usda"
    bad.write_text("#usda 1.0\n(\n garbage")
    with pytest.raises(UserError, match="bad.usda: cannot open USD stage"):
        U.open_stage(bad)
    with pytest.raises(UserError, match="none.usda: no such USD file"):
        U.open_stage(tmp_path / "none.usda")


@pytest.mark.parametrize("offsets", [(0.0, 0.0), (3.0, -2.0)])
def test_meta_projection_is_gf_frustums_and_rebuilds_the_camera(offsets):
    s = stage_with_camera(offsets)
    UsdGeom.Camera(s.GetPrimAtPath("/Cam")).CreateClippingRangeAttr(Gf.Vec2f(0.5, 300))
    cam = U.camera_at(s, "/Cam", 1, 320, 200)
    fr = U.gf_frustum(cam, s)
    meta = cam.to_meta()
    np.testing.assert_allclose(np.array(meta["projection"]), np.array(fr.ComputeProjectionMatrix()).T, atol=1e-12)
    np.testing.assert_allclose(np.array(meta["world_to_camera"]), np.array(fr.ComputeViewMatrix()).T, atol=1e-12)
    # clip -> NDC -> pixels from the meta matrices alone agrees with project()
    pts = np.random.default_rng(1).uniform(-3, 3, (10, 3))
    clip = np.c_[pts, np.ones(10)] @ (np.array(meta["projection"]) @ np.array(meta["world_to_camera"])).T
    ndc = clip[:, :3] / clip[:, 3:]
    col, row, _ = U.CameraInfo.from_meta(meta).project(pts)
    np.testing.assert_allclose((ndc[:, 0] + 1) / 2 * 320, col, atol=1e-9)
    np.testing.assert_allclose((1 - ndc[:, 1]) / 2 * 200, row, atol=1e-9)
    np.testing.assert_allclose(meta["position"], [1, 2, 10], atol=1e-12)


def test_orthographic_camera_is_a_one_line_error():
    s = stage_with_camera()
    UsdGeom.Camera(s.GetPrimAtPath("/Cam")).CreateProjectionAttr(UsdGeom.Tokens.orthographic)
    with pytest.raises(UserError, match="camera /Cam is orthographic") as e:
        U.camera_at(s, "/Cam", 1, 10, 10)
    assert "\n" not in str(e.value)


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_vertex_normal_sums_are_np_add_at_bit_for_bit(dtype):
    """The faces' vectors summed per vertex as np.add.at sums them, in the same order: the
    same bits (shared vertices, a vertex used by no face, repeated faces)."""
    rng = np.random.default_rng(3)
    for v, t in ((7, 12), (200, 900), (1, 1)):
        pts = rng.normal(size=(v, 3)).astype(dtype) * 10.0 ** rng.integers(-3, 4, size=(v, 1))
        tris = rng.integers(0, max(v - 1, 1), size=(t, 3)).astype(np.int64)
        fn = np.cross(pts[tris[:, 1]] - pts[tris[:, 0]], pts[tris[:, 2]] - pts[tris[:, 0]])
        want = np.zeros_like(pts)
        for k in range(3):
            np.add.at(want, tris[:, k], fn)
        got = U.vertex_normal_sums(pts, tris, fn)
        assert got.dtype == want.dtype and got.shape == want.shape
        assert got.tobytes() == want.tobytes()
