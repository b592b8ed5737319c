"""SourceRead: linear colour, snapped labels, clear errors."""
import shutil
from pathlib import Path

import numpy as np
import pytest

from proxyshade.errors import UserError
from proxyshade.graph.testing import run_node
from proxyshade.io.images import read_u8
from proxyshade.io.source import snap_labels, srgb_to_linear

ROOT = Path(__file__).resolve().parents[2]


def test_reads_linear_colour_and_exact_palette_labels():
    p = run_node("SourceRead", {"table": "samples/monet/source.yaml"}, graph_dir=ROOT)
    assert p["label.id"].dtype == np.uint32 and p["R"].dtype == np.float32
    rgb8 = read_u8(ROOT / "samples/monet/style.png")
    # sRGB decode: 0.5 display is ~0.214 linear, and the plate matches colour-science's decoding
    np.testing.assert_allclose(p["G"], srgb_to_linear(rgb8)[..., 1])
    assert abs(float(srgb_to_linear(np.array([[[128, 128, 128]]], np.uint8))[0, 0, 0]) - 0.2158605) < 1e-6
    names = {t["id"]: t["name"] for t in p.meta["labels"]}
    shares = {names[i]: (p["label.id"] == i).mean() for i in names}
    assert abs(shares["sky"] - 0.38) < 0.01 and abs(shares["cliff"] - 0.27) < 0.01  # the README's shares
    assert set(np.unique(p["label.id"])) <= set(names)


def test_jpeg_map_is_snapped_and_counted():
    p = run_node("SourceRead", {"table": "samples/creek/source.yaml"}, graph_dir=ROOT)
    s = p.meta["snap"]
    assert s["snapped"] > 0.05 * s["pixels"]  # JPEG noise
    assert 0 < s["far"] < 0.01 * s["pixels"]
    assert set(np.unique(p["label.id"])) == {1, 2, 3, 4}


def test_snap_picks_the_nearest_table_colour():
    table = [{"id": 1, "color": "#000000"}, {"id": 2, "color": "#ffffff"}]
    img = np.array([[[10, 10, 10], [250, 240, 255], [128, 128, 128]]], np.uint8)
    ids, snapped, far = snap_labels(img, table, far_distance=100)
    assert ids.tolist() == [[1, 2, 2]] and snapped == 3 and far == 1


def test_snap_matches_a_per_pixel_nearest_colour_search():
    """Against the obvious loop: each pixel's nearest table colour (first on ties), its squared
    distance counted as snapped (> 0) and far (> far_distance²)."""
    rng = np.random.default_rng(3)
    table = [{"id": int(i), "color": "#%02x%02x%02x" % tuple(int(v) for v in rng.integers(0, 256, 3))}
             for i in rng.choice(1000, 6, replace=False) + 1]
    pal = np.array([[int(t["color"][k:k + 2], 16) for k in (1, 3, 5)] for t in table])
    near = pal[rng.integers(0, len(pal), (9, 11))] + rng.integers(-30, 31, (9, 11, 3))
    img = np.clip(np.where(rng.random((9, 11, 1)) < 0.2, rng.integers(0, 256, (9, 11, 3)), near), 0, 255).astype(np.uint8)
    ids, snapped, far = snap_labels(img, table, far_distance=60)
    want, n_snap, n_far = np.zeros(img.shape[:2], np.uint32), 0, 0
    for y in range(img.shape[0]):
        for x in range(img.shape[1]):
            d2 = [int(((img[y, x].astype(int) - c) ** 2).sum()) for c in pal]
            k = int(np.argmin(d2))
            want[y, x] = table[k]["id"]
            n_snap += d2[k] > 0
            n_far += d2[k] > 60 ** 2
    assert ids.dtype == np.uint32 and (ids == want).all() and (snapped, far) == (n_snap, n_far)


def test_far_colours_fail_with_a_clear_error(tmp_path):
    shutil.copytree(ROOT / "samples" / "monet", tmp_path / "monet")
    table = tmp_path / "monet" / "source.yaml"
    text = table.read_text().replace('rock:  {id: 5, color: "#c00000"}\n', "")
    table.write_text(text)  # rock (7%) is now far... only if its colour is far from the rest
    with pytest.raises(UserError, match=r"src: style_mask.png: .* of pixels are further than 40 .*add the missing colours"):
        run_node("SourceRead", {"table": str(table), "far_distance": 40.0}, name="src")


def test_bad_table_errors_name_file_and_field(tmp_path):
    t = tmp_path / "source.yaml"
    t.write_text("image: a.png\nlabels_map: b.png\nlabels: {sky: {id: 0, color: '#ffffff'}}\n")
    with pytest.raises(UserError, match=r"source.yaml: labels.sky.id: expected an int from 1 to 4294967295"):
        run_node("SourceRead", {"table": str(t)})
    t.write_text("image: a.png\nlabels: {}\n")
    with pytest.raises(UserError, match=r"source.yaml: labels_map: missing"):
        run_node("SourceRead", {"table": str(t)})
