"""ExemplarAtlas: exemplars packed side by side, labels travel, bad inputs stop with one line."""
import shutil
from pathlib import Path

import numpy as np
import pytest

from proxyshade.cli import main
from proxyshade.errors import UserError
from proxyshade.graph.plate import Plate
from proxyshade.graph.testing import run_node

ROOT = Path(__file__).resolve().parents[2]
TABLE = [{"name": "a", "id": 1, "color": "#000000"}, {"name": "b", "id": 2, "color": "#ffffff"}]


def plate(rgb, ids, table=TABLE):
    return Plate({"R": rgb[..., 0], "G": rgb[..., 1], "B": rgb[..., 2], "label.id": ids.astype(np.uint32)},
                 {"labels": table, "source": {"table": "x.yaml"}})


def test_boxes_hold_the_centre_crop_box_filtered_and_its_majority_labels():
    rng = np.random.default_rng(0)
    rgb = rng.random((8, 12, 3)).astype(np.float32)
    ids = rng.integers(1, 3, (8, 12))
    other = rng.random((4, 4, 3)).astype(np.float32)
    out = run_node("ExemplarAtlas", {"size": [4, 4]},
                   {"exemplar1": plate(rgb, ids), "exemplar3": plate(other, np.ones((4, 4)))})
    assert out.shape == (4, 8) and out["label.id"].dtype == np.uint32 and out["exemplar.id"].dtype == np.uint32
    # 8x12 -> 4x4: factor 2 on the centred 8x8 crop (columns 2..9)
    for i in range(4):
        for j in range(4):
            block = rgb[2 * i:2 * i + 2, 2 + 2 * j:4 + 2 * j]
            np.testing.assert_allclose(out["G"][i, j], block[..., 1].mean(), rtol=1e-5)
            votes = np.bincount(ids[2 * i:2 * i + 2, 2 + 2 * j:4 + 2 * j].ravel(), minlength=3)
            want = 1 if votes[1] >= votes[2] else 2  # ties: the smaller index
            assert out["label.id"][i, j] == want
    np.testing.assert_array_equal(out["R"][:, 4:], other[..., 0])  # same size: copied as is
    assert out["exemplar.id"][:, :4].tolist() == [[1] * 4] * 4 and out["exemplar.id"][:, 4:].tolist() == [[2] * 4] * 4
    assert out.meta["labels"] == TABLE
    assert [(b["id"], b["input"], b["x"], b["y"], b["w"], b["h"]) for b in out.meta["atlas"]] == \
        [(1, "exemplar1", 0, 0, 4, 4), (2, "exemplar3", 4, 0, 4, 4)]
    assert "source.x" not in out and "source.y" not in out


def test_renoir_and_creek_share_their_labels_in_one_atlas():
    a = run_node("SourceRead", {"table": "samples/renoir/source.yaml"}, graph_dir=ROOT)
    b = run_node("SourceRead", {"table": "samples/creek/source.yaml"}, graph_dir=ROOT)
    out = run_node("ExemplarAtlas", {"size": [64, 48]}, {"exemplar1": a, "exemplar2": b})
    assert out.shape == (48, 128)
    for k in (0, 1):
        box = out["label.id"][:, 64 * k:64 * (k + 1)]
        assert set(np.unique(box)) == {1, 2, 3, 4}
        assert (box[:8] == 2).mean() > 0.5  # sky stays on top in both
    assert out.meta["atlas"][1]["source"]["table"].endswith("creek/source.yaml")


def test_no_exemplar_and_nan_are_one_line_errors():
    with pytest.raises(UserError, match=r"atlas: no exemplar connected; connect 1 to 8 SourceRead"):
        run_node("ExemplarAtlas", {}, {}, name="atlas")
    rgb = np.zeros((8, 8, 3), np.float32)
    rgb[2, 3, 1] = np.nan
    with pytest.raises(UserError, match=r"channel G has 1 NaN/Inf pixel\(s\), first at x=3 y=2"):
        run_node("ExemplarAtlas", {}, {"exemplar1": plate(rgb, np.ones((8, 8)))}, name="atlas")


def _graph(tmp_path, nodes: str) -> Path:
    for s in ("renoir", "monet", "creek"):
        shutil.copytree(ROOT / "samples" / s, tmp_path / "samples" / s)
    g = tmp_path / "g.yaml"
    g.write_text("format: proxyshade/1\nframes: 1-1\nnodes:\n"
                 "  r: {type: SourceRead, params: {table: samples/renoir/source.yaml}}\n"
                 "  m: {type: SourceRead, params: {table: samples/monet/source.yaml}}\n"
                 "  c: {type: SourceRead, params: {table: samples/creek/source.yaml}}\n" + nodes)
    return g


def test_cli_exits_2_on_disagreeing_tables_and_a_ninth_exemplar(tmp_path, capsys):
    g = _graph(tmp_path, "  atlas: {type: ExemplarAtlas, inputs: {exemplar1: r, exemplar2: m}, params: {size: [32, 32]}}\n")
    assert main(["run", str(g), "-q", "--cache", str(tmp_path / "cache")]) == 2
    err = "\n".join(ln for ln in capsys.readouterr().err.strip().splitlines()
                    if not ln.startswith(("compiling the numba kernels", "kernels compiled in")))  # a first run's progress
    assert err.count("\n") == 0
    assert "atlas" in err and "input 'exemplar2': its label table" in err and "give every exemplar the same label" in err
    ins = ", ".join(f"exemplar{k}: c" for k in range(1, 10))
    g = _graph(tmp_path / "b", f"  atlas: {{type: ExemplarAtlas, inputs: {{{ins}}}}}\n")
    assert main(["run", str(g), "-q", "--cache", str(tmp_path / "cache")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "ExemplarAtlas has no input 'exemplar9'" in err and "exemplar8" in err


def annotated(rgb, ids, light):
    return plate(rgb, ids).with_channels({"ann.light": light.astype(np.float32)})


def test_annotations_travel_box_filtered_and_an_atlas_feeds_annotated_synthesis():
    rng = np.random.default_rng(4)
    n = 48
    light = np.tile(np.linspace(0, 1, n), (n, 1))
    a = annotated((rng.random((n, n, 3)) * light[..., None]).astype(np.float32), np.ones((n, n)), light)
    b = annotated(rng.random((2 * n, 2 * n, 3)).astype(np.float32), np.ones((2 * n, 2 * n)),
                  np.tile(np.linspace(0, 1, 2 * n), (2 * n, 1)))
    atlas = run_node("ExemplarAtlas", {"size": [n, n]}, {"exemplar1": a, "exemplar2": b})
    np.testing.assert_allclose(atlas["ann.light"][:, :n], light, atol=1e-6)  # same size: as is
    box = b["ann.light"].reshape(n, 2, n, 2).mean((1, 3))  # 2x: 2x2 box means
    np.testing.assert_allclose(atlas["ann.light"][:, n:], box, atol=1e-5)
    tgt = Plate({"ann.light": np.tile(np.linspace(0, 1, 32), (32, 1)).T.astype(np.float32).copy()}, {})
    out = run_node("AnnotatedSynth", dict(levels=2, em=1, iterations=3, bandwidth=0.3),
                   {"source": atlas, "target": tgt})
    sx = out["source.x"]
    assert not np.any((sx > n - 3) & (sx < n + 2))  # no patch straddles the two boxes
    with pytest.raises(UserError, match=r"^atlas: input 'exemplar2': its annotations \(none\) differ"):
        run_node("ExemplarAtlas", {"size": [n, n]}, {"exemplar1": a, "exemplar2": plate(np.zeros((n, n, 3), np.float32),
                                                                                    np.ones((n, n)))}, name="atlas")
