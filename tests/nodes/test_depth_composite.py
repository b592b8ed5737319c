"""DepthComposite on hand-made two-depth cases: CG hidden behind, shown in front."""
import numpy as np
import pytest

from proxyshade.errors import NodeInputError
from proxyshade.graph.plate import Plate
from proxyshade.graph.testing import run_node

H, W = 8, 10


def scene_plate():
    """A 'rock' at depth 2 in the left half (ragged edge), ground at depth 10, sky (inf) on top row."""
    z = np.full((H, W), 10.0, np.float32)
    rock = np.zeros((H, W), bool)
    for y in range(H):
        rock[y, : 3 + (y % 3)] = True  # detailed silhouette
    z[rock] = 2.0
    z[0] = np.inf
    lab = np.where(rock, 2, 1).astype(np.uint32)
    lab[0] = 3
    ones = np.ones((H, W), np.float32)
    px = np.full((H, W), 7.0, np.float32)
    return Plate({"R": 0.2 * ones, "G": 0.4 * ones, "B": 0.6 * ones, "Z": z, "label.id": lab, "P.X": px},
                 {"labels": [{"name": "ground", "id": 1}, {"name": "rock", "id": 2}, {"name": "sky", "id": 3}]}), rock


def cg_plate(depth, alpha=1.0):
    """A CG box covering columns 1..6 of rows 2..6 at one depth, premultiplied."""
    cov = np.zeros((H, W), np.float32)
    cov[2:7, 1:7] = alpha
    z = np.where(cov > 0, np.float32(depth), np.float32(np.inf)).astype(np.float32)
    oid = (cov > 0).astype(np.uint32) * 4
    return Plate({"R": 0.9 * cov, "G": 0.1 * cov, "B": 0.0 * cov, "A": cov, "Z": z, "object.id": oid,
                  "P.X": np.full((H, W), -1.0, np.float32)},
                 {"objects": [{"name": "/World/Car", "id": 4}]}), cov > 0


def test_cg_between_rock_and_ground_is_hidden_by_rock_silhouette():
    scene, rock = scene_plate()
    cg, box = cg_plate(5.0)
    out = run_node("DepthComposite", {}, {"scene": scene, "cg": cg})
    visible = box & ~rock
    assert visible.any() and (box & rock).any()
    np.testing.assert_array_equal(out["R"], np.where(visible, 0.9, 0.2).astype(np.float32))
    np.testing.assert_array_equal(out["Z"], np.where(visible, 5.0, scene["Z"]).astype(np.float32))
    np.testing.assert_array_equal(out["object.id"], np.where(visible, 4, 0))
    np.testing.assert_array_equal(out["label.id"], np.where(visible, 0, scene["label.id"]))
    np.testing.assert_array_equal(out["P.X"], np.where(visible, -1.0, 7.0).astype(np.float32))
    assert np.all(out["A"] == 1)
    assert out.meta["objects"] == [{"name": "/World/Car", "id": 4, "cg": True}]
    assert out.meta["labels"] == scene.meta["labels"]


def test_scene_object_ids_kept_and_cg_ids_shifted_past_them():
    scene, rock = scene_plate()
    scene = scene.with_channels({"object.id": np.where(rock, 2, 1).astype(np.uint32)},
                                {"objects": [{"name": "/World/Ground", "id": 1, "label": "ground"},
                                             {"name": "/World/Rock", "id": 2, "label": "rock"}]})
    cg, box = cg_plate(5.0)
    out = run_node("DepthComposite", {}, {"scene": scene, "cg": cg})
    visible = box & ~rock
    np.testing.assert_array_equal(out["object.id"], np.where(visible, 6, scene["object.id"]))
    assert [o["name"] for o in out.meta["objects"]] == ["/World/Ground", "/World/Rock", "/World/Car"]
    assert out.meta["objects"][2]["id"] == 6
    crypto = run_node("Cryptomatte", {}, {"image": out})
    from tests.nodes.test_cryptomatte import decode
    assert np.array_equal(decode(crypto, "CryptoObject", "/World/Car"), visible.astype(float))
    assert np.array_equal(decode(crypto, "CryptoObject", "/World/Rock"), rock.astype(float))


def test_cg_in_front_of_everything_covers_rock():
    scene, _ = scene_plate()
    cg, box = cg_plate(1.0)
    out = run_node("DepthComposite", {}, {"scene": scene, "cg": cg})
    np.testing.assert_array_equal(out["G"], np.where(box, 0.1, 0.4).astype(np.float32))
    np.testing.assert_array_equal(out["object.id"], np.where(box, 4, 0))


def test_cg_behind_everything_is_invisible():
    scene, _ = scene_plate()
    cg, box = cg_plate(50.0)
    out = run_node("DepthComposite", {}, {"scene": scene, "cg": cg})
    for c in "RGB":
        assert np.array_equal(out[c], scene[c])
    assert not out["object.id"].any()


def test_partial_alpha_is_premultiplied_over():
    scene, rock = scene_plate()
    cg, box = cg_plate(5.0, alpha=0.25)
    out = run_node("DepthComposite", {}, {"scene": scene, "cg": cg})
    visible = box & ~rock
    want = np.where(visible, 0.9 * 0.25 + 0.75 * 0.2, 0.2)
    np.testing.assert_allclose(out["R"], want, atol=1e-7)
    assert not out["object.id"].any()  # coverage below one half: the scene owns the ids


def test_sky_pixels_take_cg():
    scene, _ = scene_plate()
    cg, _ = cg_plate(5.0)
    cg.channels["A"][0, 3] = 1.0
    cg.channels["Z"][0, 3] = 1000.0
    cg.channels["R"][0, 3] = 0.5
    cg.channels["object.id"][0, 3] = 4
    out = run_node("DepthComposite", {}, {"scene": scene, "cg": cg})
    assert out["R"][0, 3] == np.float32(0.5) and out["object.id"][0, 3] == 4 and out["Z"][0, 3] == 1000


def test_size_mismatch_is_one_line_error():
    scene, _ = scene_plate()
    cg = Plate({c: np.zeros((4, 4), np.float32) for c in ("R", "G", "B", "A", "Z")})
    with pytest.raises(NodeInputError, match="cg plate is 4x4 but scene is 10x8") as e:
        run_node("DepthComposite", {}, {"scene": scene, "cg": cg})
    assert "\n" not in str(e.value)


def test_pipeline_cg_render_shadow_composite_fog_cryptomatte_exr(tmp_path):
    """CgRender + ShadowMap + DepthComposite + LabelGrade + Fog + Cryptomatte on a ground plane
    'synthesized' through the same camera, written to EXR and listed by oiiotool."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    from proxyshade.io import usd
    from proxyshade.io.exr import write_plate
    from tests.nodes.test_cg_render import make_stage
    from tests.nodes.test_cryptomatte import decode

    scene = make_stage(tmp_path / "s.usda", light_dir=(0.5, -1.0, -0.3), quad=False,
                       cube={"translate": (0.0, -1.0, 0.0), "scale": (0.5, 0.5, 0.5)})
    cam = usd.camera_at(usd.open_stage(scene), None, 1, 64, 48)
    col, row = cam.pixel_grid()
    dy = -(row - cam.cy) / cam.fy  # ray direction (x, dy, -1) in camera space = world here
    ground = dy < 0
    t = np.where(ground, -2.0 / np.where(ground, dy, -1), np.inf)  # ground plane y = -2
    P = cam.unproject(col, row, np.where(ground, t, 1.0))
    P[~ground] = np.inf
    rgb = np.full(cam.height * cam.width, 0.5, np.float32).reshape(cam.height, cam.width)
    synth = Plate({"R": rgb, "G": rgb, "B": rgb, "Z": t.astype(np.float32),
                   "label.id": np.where(ground, 1, 2).astype(np.uint32),
                   **{f"P.{a}": P[..., i].astype(np.float32) for i, a in enumerate("XYZ")}},
                  {"labels": [{"name": "grass", "id": 1, "color": "#00ff00"}, {"name": "sky", "id": 2, "color": "#0000ff"}],
                   "camera": cam.to_meta()})
    cg = run_node("CgRender", {"scene": str(scene)}, {"proxy": synth})
    shadowed = run_node("ShadowMap", {"scene": str(scene), "size": 256, "factor": 0.3}, {"image": synth})
    assert (shadowed["shadow"][ground] > 0.5).sum() > 5 and not shadowed["shadow"][~ground].any()
    comp = run_node("DepthComposite", {}, {"scene": shadowed, "cg": cg})
    box = cg["A"] > 0
    assert box.sum() > 20 and np.array_equal(comp["object.id"] > 0, box)  # cube in front of the ground
    np.testing.assert_array_equal(comp["R"][box], cg["R"][box])
    graded = run_node("LabelGrade", {"label": "sky", "temperature": 9000.0}, {"image": comp})
    fogged = run_node("Fog", {"density": 0.01}, {"image": graded})
    final = run_node("Cryptomatte", {}, {"image": fogged})
    assert np.array_equal(decode(final, "CryptoObject", "/World/Cube"), box.astype(float))
    assert np.array_equal(decode(final, "CryptoLabel", "grass"), (ground & ~box).astype(float))
    path = write_plate(tmp_path / "comp.exr", final)
    oiiotool = Path(sys.executable).parent / "oiiotool"
    info = subprocess.run([str(oiiotool), "--info", "-v", str(path)], capture_output=True, text=True, check=True).stdout
    for n, a in final.channels.items():
        assert f"{n} ({ {'float32': 'float', 'uint32': 'uint', 'float16': 'half'}[str(a.dtype)] })" in info
    assert info.count("cryptomatte/") >= 8
    json.loads(final.meta[[k for k in final.meta if k.endswith("/manifest")][0]])
