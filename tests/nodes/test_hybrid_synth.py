"""HybridSynth: labels travel with colour, the frame is the seed, weights bias the mix,
bad inputs stop with one line, 1 and 2 threads write identical EXRs."""
import shutil
from pathlib import Path

import numpy as np
import pytest

from proxyshade.cli import main
from proxyshade.errors import UserError
from proxyshade.graph.testing import run_node

ROOT = Path(__file__).resolve().parents[2]
SMALL = {"levels": 4, "iterations": 2}  # 64² exemplars: coarsest spacing 8 spans 33 px


@pytest.fixture(scope="module")
def atlas():
    a = run_node("SourceRead", {"table": "samples/renoir/source.yaml"}, graph_dir=ROOT)
    b = run_node("SourceRead", {"table": "samples/creek/source.yaml"}, graph_dir=ROOT)
    return run_node("ExemplarAtlas", {"size": [64, 64]}, {"exemplar1": a, "exemplar2": b})


def test_labels_and_colour_travel_with_the_pointers(atlas):
    out = run_node("HybridSynth", SMALL, {"atlas": atlas}, frame=3)
    assert out.shape == (64, 64) and out["label.id"].dtype == np.uint32 and out["exemplar.id"].dtype == np.uint32
    x, y = out["atlas.x"].astype(int), out["atlas.y"].astype(int)
    for c in ("R", "G", "B", "label.id", "exemplar.id"):
        np.testing.assert_array_equal(out[c], atlas[c][y, x])
    np.testing.assert_array_equal(out["exemplar.id"], x // 64 + 1)
    assert set(np.unique(out["exemplar.id"])) == {1, 2}  # a hybrid: both exemplars
    assert out.meta["labels"] == atlas.meta["labels"]
    assert (out["label.id"][:8] == 2).mean() > 0.6  # the layout: sky stays on top
    # it reads as a source for the synthesis nodes
    from proxyshade.synthesis.params import source_input
    assert source_input().problem(out, "PatchInit") is None


def test_the_frame_is_the_seed_and_weights_bias_the_mix(atlas):
    a = run_node("HybridSynth", SMALL, {"atlas": atlas}, frame=1)
    again = run_node("HybridSynth", SMALL, {"atlas": atlas}, frame=1)
    b = run_node("HybridSynth", SMALL, {"atlas": atlas}, frame=2)
    np.testing.assert_array_equal(a["atlas.x"], again["atlas.x"])
    assert (a["atlas.x"] != b["atlas.x"]).mean() > 0.2
    only2 = run_node("HybridSynth", dict(SMALL, weights=[0, 1]), {"atlas": atlas}, frame=1)
    assert (only2["exemplar.id"] == 2).all()
    shares = [(run_node("HybridSynth", dict(SMALL, weights=w), {"atlas": atlas}, frame=1)["exemplar.id"] == 1).mean()
              for w in ([1, 4], [4, 1])]
    assert shares[0] < shares[1]


def test_a_ramp_goes_from_one_exemplar_to_the_other_in_mixed_patches(atlas):
    kw = dict(SMALL, size=[256, 64], ramp=[1, 2])
    out = {cell: run_node("HybridSynth", dict(kw, ramp_cell=cell), {"atlas": atlas}, frame=1)["exemplar.id"]
           for cell in (0, 8)}
    for e in out.values():
        assert (e[:, :32] == 1).mean() > 0.8 and (e[:, -32:] == 2).mean() > 0.8
    share = {c: np.array([(e[:, a:a + 32] == 2).mean() for a in range(0, 256, 32)]) for c, e in out.items()}
    want = (np.arange(8) + 0.5) / 8
    assert np.abs(share[8] - want).mean() < np.abs(share[0] - want).mean()
    mid = out[8][:, 96:160]
    assert 0.2 < (mid == 2).mean() < 0.8  # the middle mixes both


def test_J_and_jitter_levels_set_the_variation(atlas):
    def diff(J, jl=None):
        a = run_node("HybridSynth", dict(SMALL, J=J, jitter_levels=jl), {"atlas": atlas}, frame=1)
        b = run_node("HybridSynth", dict(SMALL, J=J, jitter_levels=jl), {"atlas": atlas}, frame=2)
        return ((np.abs(a["atlas.x"] - b["atlas.x"]) > 2) | (np.abs(a["atlas.y"] - b["atlas.y"]) > 2)).mean()
    assert diff(0.0) == 0.0 and 0.0 < diff(0.05, 1) < diff(1.0)


def _graph(tmp_path, atlas_params="size: [48, 48]", hybrid_params="levels: 3"):
    for s in ("renoir", "creek", "monet"):
        shutil.copytree(ROOT / "samples" / s, tmp_path / "samples" / s)
    g = tmp_path / "g.yaml"
    g.write_text("format: proxyshade/1\nframes: 1-1\nnodes:\n"
                 "  r: {type: SourceRead, params: {table: samples/renoir/source.yaml}}\n"
                 "  c: {type: SourceRead, params: {table: samples/creek/source.yaml}}\n"
                 f"  atlas: {{type: ExemplarAtlas, inputs: {{exemplar1: r, exemplar2: c}}, params: {{{atlas_params}}}}}\n"
                 f"  hyb: {{type: HybridSynth, inputs: {{atlas: atlas}}, params: {{{hybrid_params}}}}}\n"
                 "  write: {type: ExrWrite, inputs: {image: hyb}, params: {path: out/h.####.exr}}\n")
    return g


@pytest.mark.parametrize("params,expect", [
    ("levels: 3, weights: [-1, 1]", "hyb@1: weights: [-1, 1] holds a negative or non-finite value; use weights >= 0"),
    ("levels: 3, weights: [0, 0]", "hyb@1: weights: all zero; give at least one exemplar a positive weight"),
    ("levels: 3, weights: [.nan, 1]", "hyb@1: weights: [nan, 1] holds a negative or non-finite value"),
    ("levels: 3, weights: [1]", "hyb@1: weights: 1 given for 2 exemplars; give one per exemplar"),
    ("levels: 5", "hyb@1: the exemplars are 48x48, too small for a 5x5 neighbourhood at the coarsest of 5 levels "
                  "(spacing 16 spans 65 px); lower levels to 4 or raise ExemplarAtlas size"),
])
def test_bad_input_exits_2_with_one_line(tmp_path, capsys, params, expect):
    g = _graph(tmp_path, hybrid_params=params)
    assert main(["run", str(g), "-q", "--cache", str(tmp_path / "cache")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and expect in err, err


def test_nan_atlas_is_refused(atlas):
    bad = atlas.with_channels({"G": np.where(np.arange(atlas["G"].size).reshape(atlas.shape) == 5, np.nan,
                                             atlas["G"]).astype(np.float32)})
    with pytest.raises(UserError, match=r"hyb: .*channel G has 1 NaN/Inf pixel\(s\), first at x=5 y=0"):
        run_node("HybridSynth", SMALL, {"atlas": bad}, name="hyb")


def test_exr_is_bit_identical_with_1_and_2_threads(tmp_path):
    g = _graph(tmp_path)
    outs = []
    for t in (1, 2):
        assert main(["run", str(g), "-q", "--cache", str(tmp_path / f"cache{t}"), "--threads", str(t)]) == 0
        outs.append((tmp_path / "out" / "h.0001.exr").read_bytes())
    assert outs[0] == outs[1]
