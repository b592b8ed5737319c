"""ProxyRender: depth, areas, labels by name, errors, keys."""
from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdSemantics, Vt

from proxyshade.errors import UserError
from proxyshade.graph.graph import Graph
from proxyshade.graph.plate import Plate
from proxyshade.graph.testing import run_node

TABLE = [{"name": "sky", "id": 2, "color": "#ffffff"}, {"name": "water", "id": 3, "color": "#0000ff"},
         {"name": "tree", "id": 4, "color": "#ff331f"}]
SRC = Plate({"label.id": np.zeros((2, 2), np.uint32)}, {"labels": TABLE})


def make_stage(path: Path, *, plane_z=None, sphere=None, label="water", timed=True, focal=50.0):
    s = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(s, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(s, 1.0)
    if timed:
        s.SetStartTimeCode(1)
        s.SetEndTimeCode(10)
    w = UsdGeom.Xform.Define(s, "/World")
    s.SetDefaultPrim(w.GetPrim())
    c = UsdGeom.Camera.Define(s, "/World/Cam")
    c.CreateFocalLengthAttr(focal)
    c.CreateHorizontalApertureAttr(36)
    c.CreateVerticalApertureAttr(36)
    c.CreateClippingRangeAttr(Gf.Vec2f(0.1, 1000))
    if plane_z is not None:
        m = UsdGeom.Mesh.Define(s, "/World/Plane")
        m.CreatePointsAttr([(-100, -100, -plane_z), (100, -100, -plane_z), (100, 100, -plane_z), (-100, 100, -plane_z)])
        m.CreateFaceVertexCountsAttr([4])
        m.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
        UsdSemantics.LabelsAPI.Apply(m.GetPrim(), "texture").CreateLabelsAttr().Set(Vt.TokenArray([label]))
    if sphere is not None:
        sp = UsdGeom.Sphere.Define(s, "/World/Ball")
        sp.CreateRadiusAttr(sphere[1])
        sp.AddTranslateOp().Set(Gf.Vec3d(0, 0, -sphere[0]))
        UsdSemantics.LabelsAPI.Apply(sp.GetPrim(), "texture").CreateLabelsAttr().Set(Vt.TokenArray(["tree"]))
    s.Save()
    return path


def test_plane_depth_exact(tmp_path):
    scene = make_stage(tmp_path / "p.usda", plane_z=12.5)
    p = run_node("ProxyRender", {"scene": str(scene), "resolution": [64, 48]}, {"source": SRC})
    assert np.all(np.abs(p["Z"] - 12.5) / 12.5 < 1e-4)
    assert np.all(p["label.id"] == 3) and p["label.id"].dtype == np.uint32
    np.testing.assert_allclose(p["P.Z"], -12.5, atol=1e-4)
    np.testing.assert_allclose(p["N.Z"], 1.0, atol=1e-6)


def test_sphere_area_matches_projected_disc(tmp_path):
    d, r, f = 20.0, 3.0, 50.0
    scene = make_stage(tmp_path / "s.usda", sphere=(d, r), focal=f)
    W = 400
    p = run_node("ProxyRender", {"scene": str(scene), "resolution": [W, W]}, {"source": SRC})
    fpx = W * f / 36.0
    disc = np.pi * (fpx * r / np.sqrt(d * d - r * r)) ** 2  # on-axis sphere: a disc of radius f·r/sqrt(d²−r²)
    area = (p["label.id"] == 4).sum()
    assert abs(area - disc) / disc < 0.01
    assert (p["label.id"][p["Z"] == np.inf] == 2).all()  # background is the sky label
    assert p.meta["objects"] == [{"id": 1, "name": "/World/Ball", "label": "tree"}]
    assert set(np.unique(p["object.id"])) == {0, 1}


def test_unknown_label_lists_both_sets(tmp_path):
    scene = make_stage(tmp_path / "u.usda", plane_z=5, label="lava")
    with pytest.raises(UserError, match=r"scene label\(s\) lava not in the source's table; scene labels: lava, sky; source labels: sky, tree, water"):
        run_node("ProxyRender", {"scene": str(scene), "resolution": [8, 8]}, {"source": SRC}, name="proxy")


def test_missing_camera_and_untimed_stage(tmp_path):
    scene = make_stage(tmp_path / "c.usda", plane_z=5)
    with pytest.raises(UserError, match="no camera at /World/Other; cameras in the stage: /World/Cam"):
        run_node("ProxyRender", {"scene": str(scene), "camera": "/World/Other", "resolution": [8, 8]}, {"source": SRC})
    static = make_stage(tmp_path / "st.usda", plane_z=5, timed=False)
    with pytest.raises(UserError, match="no time samples .* frame 10 was asked"):
        run_node("ProxyRender", {"scene": str(static), "resolution": [8, 8]}, {"source": SRC}, frame=10)


def graph_for(tmp_path, scene):
    g = Graph(graph_dir=tmp_path, frames=(1, 3), cache=tmp_path / "cache")
    src = tmp_path / "src.exr"
    from proxyshade.io.exr import write_plate
    write_plate(src, SRC)
    g.add("src", "ExrRead", {"path": str(src)})
    g.add("proxy", "ProxyRender", {"scene": str(scene), "resolution": [16, 16]}, {"source": "src"})
    return g


def test_key_follows_scene_content_not_file_touches(tmp_path):
    scene = make_stage(tmp_path / "k.usda", plane_z=5)
    g = graph_for(tmp_path, scene)
    g.run([1])
    import os
    os.utime(scene)  # a touch changes nothing
    assert graph_for(tmp_path, scene).run([1]).computed == set()
    text = scene.read_text().replace("(-100, -100, -5)", "(-100, -100, -6)")
    scene.write_text(text)
    r = graph_for(tmp_path, scene).run([1])
    assert r.computed == {"proxy"} and "new scene content" in r.rows("proxy")[0].reason
    s = Usd.Stage.Open(str(scene))
    s.GetPrimAtPath("/World").SetDocumentation("an unrelated edit")
    s.Save()
    assert graph_for(tmp_path, scene).run([1]).computed == set()


def test_a_watch_watches_the_scene(tmp_path):
    """``run --watch`` re-runs when a file a node reads changes: the proxy's scene is one
    (its parameter is a string, keyed through the USD it composes), beside the Path ones."""
    scene = make_stage(tmp_path / "w.usda", plane_z=5)
    assert scene.resolve() in {p.resolve() for p in graph_for(tmp_path, scene).input_files([1])}


ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("scene,source", [("lake", "renoir"), ("cliffs", "monet"), ("farm", "creek")])
def test_sample_scenes_render_their_labels(scene, source):
    src = run_node("SourceRead", {"table": f"samples/{source}/source.yaml"}, graph_dir=ROOT)
    p = run_node("ProxyRender", {"scene": f"samples/scenes/{scene}.usda", "resolution": [96, 96]}, {"source": src},
                 graph_dir=ROOT, frame=24)
    names = {t["id"]: t["name"] for t in src.meta["labels"]}
    present = {names[i] for i in np.unique(p["label.id"])}
    expected = {"lake": {"sky", "vegetation", "water", "tree"}, "cliffs": {"sky", "cliff", "sea", "grass", "rock"},
                "farm": {"sky", "vegetation", "water", "tree"}}[scene]
    assert present == expected


@pytest.mark.parametrize("centre,r", [((0.0, 0.0, -20.0), 3.0), ((14.0, 14.0, -15.0), 2.0), ((0.0, 12.0, -12.0), 2.5)])
def test_sphere_silhouette_error_under_half_a_pixel(centre, r):
    """Pixels whose coverage differs from the exact sphere lie within 0.5 px of its true
    silhouette (wide angle, off axis: the projected outline is an ellipse)."""
    from proxyshade.io import usd
    from proxyshade.nodes.proxy_render import render_prims

    s = Usd.Stage.CreateInMemory()
    c = UsdGeom.Camera.Define(s, "/Cam")
    c.CreateFocalLengthAttr(14.0)
    c.CreateHorizontalApertureAttr(36)
    c.CreateVerticalApertureAttr(36)
    sp = UsdGeom.Sphere.Define(s, "/S")
    sp.CreateRadiusAttr(r)
    sp.AddTranslateOp().Set(Gf.Vec3d(*centre))
    cam = usd.camera_at(s, None, 1, 256, 256)
    _, idx, _, _ = render_prims(usd.scene_prims(s, 1), cam)
    C = np.array(centre)
    d = np.linalg.norm(C)
    cols, rows = cam.pixel_grid()
    v = np.stack([(cols - cam.cx) / cam.fx, -(rows - cam.cy) / cam.fy, -np.ones_like(cols)], -1)
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    exact = v @ (C / d) >= np.sqrt(1 - (r / d) ** 2)  # the pixel's ray hits the sphere
    bad = exact != (idx >= 0)
    assert exact.sum() > 500 and bad.sum() < 0.05 * exact.sum()
    # the true silhouette: the circle where the view cone touches the sphere, projected
    u = C / d
    a = np.cross(u, [0.0, 1.0, 0.0])
    a /= np.linalg.norm(a)
    b = np.cross(u, a)
    t = np.linspace(0, 2 * np.pi, 8000)[:, None]
    ring = C * (1 - r * r / d / d) + r * np.sqrt(1 - r * r / d / d) * (np.cos(t) * a + np.sin(t) * b)
    pc, pr, _ = cam.project(ring)
    dist = np.hypot(cols[bad][:, None] - pc[None], rows[bad][:, None] - pr[None]).min(1)
    assert np.max(dist, initial=0.0) < 0.5


@pytest.mark.parametrize("res", [[0, 100], [-5, 100], [100, 20000], [100.5, 100]])
def test_bad_resolution_is_a_one_line_error(res):
    from proxyshade.errors import NodeInputError, ParamError

    src = run_node("SourceRead", {"table": "samples/renoir/source.yaml"}, graph_dir=ROOT)
    with pytest.raises((NodeInputError, ParamError), match=r"resolution|expected") as e:
        run_node("ProxyRender", {"scene": "samples/scenes/lake.usda", "resolution": res}, {"source": src},
                 graph_dir=ROOT)
    assert "\n" not in str(e.value)


def test_format_names_a_delivery_resolution():
    src = run_node("SourceRead", {"table": "samples/renoir/source.yaml"}, graph_dir=ROOT)
    p = run_node("ProxyRender", {"scene": "samples/scenes/lake.usda", "format": "2k_scope"}, {"source": src},
                 graph_dir=ROOT)
    assert p.shape == (858, 2048)
    g = Graph.load(ROOT / "graphs" / "first_frame.yaml", variables={"format": "hd"})
    assert g.nodes["proxy"].params["format"] == "hd"
    assert Graph.load(ROOT / "graphs" / "first_frame.yaml").nodes["proxy"].params["format"] is None


def test_null_height_keeps_the_cameras_film_aspect():
    from pxr import Usd, UsdGeom

    src = run_node("SourceRead", {"table": "samples/renoir/source.yaml"}, graph_dir=ROOT)
    stage = Usd.Stage.Open(str(ROOT / "samples" / "scenes" / "lake.usda"))
    cam = next(UsdGeom.Camera(p) for p in stage.Traverse() if p.IsA(UsdGeom.Camera))
    aspect = cam.GetVerticalApertureAttr().Get(1) / cam.GetHorizontalApertureAttr().Get(1)
    p = run_node("ProxyRender", {"scene": "samples/scenes/lake.usda", "resolution": [300, None]}, {"source": src},
                 graph_dir=ROOT)
    assert p.shape == (round(300 * aspect), 300)
