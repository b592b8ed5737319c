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
    assert out.meta["objects"] == [{"name": "/World/Car", "id": 4}]
    assert out.meta["labels"] == scene.meta["labels"]


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
