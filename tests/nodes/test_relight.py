"""Relight: a synthesized frame re-applied to other photos of the same view (a time-lapse
series made here from two differently graded copies of a bundled photo)."""
from pathlib import Path

import numpy as np
import pytest

from proxyshade.errors import UserError
from proxyshade.graph.testing import run_node
from proxyshade.io.images import read_u8, write_png
from proxyshade.io.source import load_source
from proxyshade.kernels.lookup import lookup
from tests.nodes import _synthesis as T

ROOT = Path(__file__).resolve().parents[2]
SHAPE = (192, 192)
# two grades of one photo, in 8-bit sRGB: a cool late morning and a warm, darker dusk
GRADES = {"morning": (0.95, 1.0, 1.05), "dusk": (1.0, 0.62, 0.38)}


def frame(src):
    """The first frame (PatchInit -> Correct -> Magnify -> Poisson) of renoir's layout, from ``src``."""
    g = T.guide("renoir", SHAPE)
    init = run_node("PatchInit", {"seed": 3}, {"guide": g, "source": src})
    cor = run_node("Correct", {"seed": 3}, {"init": init, "source": src})
    mag = run_node("Magnify", {}, {"synth": cor, "source": src, "guide": g})
    return run_node("Poisson", {}, {"image": mag, "source": src})


@pytest.fixture(scope="module")
def series(tmp_path_factory):
    """A source table whose ``image`` is the morning grade and whose ``images`` list both grades."""
    d = tmp_path_factory.mktemp("timelapse")
    photo = read_u8(ROOT / "samples/renoir/style.png").astype(np.float64)
    for name, gain in GRADES.items():
        write_png(d / f"{name}.png", np.clip(np.rint(photo * np.array(gain)), 0, 255).astype(np.uint8))
    table = (ROOT / "samples/renoir/source.yaml").read_text()
    table = table.replace("image: style.png", "image: morning.png\nimages: {morning: morning.png, dusk: dusk.png}")
    table = table.replace("labels_map: style_mask.png", f"labels_map: {ROOT / 'samples/renoir/style_mask.png'}")
    table = table.replace("layout: target_mask.png", "")
    (d / "source.yaml").write_text(table)
    return d / "source.yaml"


def test_same_photo_reproduces_the_first_frame_bit_for_bit():
    """Relight reads the photo through the map with Magnify's lookup and runs the Poisson
    node's whole-frame solve on the same arrays: the same photo gives the same frame
    exactly (the solver is deterministic), not merely within its tolerance."""
    src = T.source("renoir")
    f0 = frame(src)
    out = run_node("Relight", {}, {"image": f0, "source": src})
    assert out.names() == f0.names()
    for c in f0.names():
        assert np.array_equal(out[c], f0[c]), c


def test_time_lapse_reuses_the_map_and_follows_the_second_grade(series):
    morning = run_node("SourceRead", {"table": str(series)})
    dusk = run_node("SourceRead", {"table": str(series), "photo": "dusk"})
    assert np.array_equal(morning["label.id"], dusk["label.id"])
    assert dusk.meta["source"]["image"].endswith("dusk.png") and dusk.meta["source"]["photo"] == "dusk"
    f0 = frame(morning)
    relit = run_node("Relight", {}, {"image": f0, "source": dusk})
    # the map is reused as it is: no new matching
    for c in ("source.x", "source.y", "patch.id", "label.id"):
        assert np.array_equal(relit[c], f0[c]), c
    # the colours are the dusk photo's through that map (the solve only blends seams) ...
    through = lookup(dusk.rgb(), f0["source.x"], f0["source.y"])
    blend = np.abs(f0.rgb() - lookup(morning.rgb(), f0["source.x"], f0["source.y"])).mean()
    assert np.abs(relit.rgb() - through).mean() < 1.5 * blend  # measured 0.015 vs the morning frame's 0.025
    assert np.abs(relit.rgb() - f0.rgb()).mean() > 5 * np.abs(relit.rgb() - through).mean()
    # ... so the frame's colour balance moves as the photo's does, channel by channel
    ratio_frame = relit.rgb().reshape(-1, 3).mean(0) / f0.rgb().reshape(-1, 3).mean(0)
    ratio_photo = dusk.rgb().reshape(-1, 3).mean(0) / morning.rgb().reshape(-1, 3).mean(0)
    np.testing.assert_allclose(ratio_frame, ratio_photo, rtol=0.1)
    assert ratio_frame[2] < 0.5 * ratio_frame[0]  # warm: blue falls far more than red
    # and relighting back with the morning photo gives the original frame exactly
    back = run_node("Relight", {}, {"image": relit, "source": morning})
    for c in ("R", "G", "B"):
        assert np.array_equal(back[c], f0[c])


def test_unknown_photo_and_wrong_size_are_one_line_errors(series, tmp_path):
    with pytest.raises(UserError, match=r"source.yaml: images.noon: no such photo .*morning, dusk"):
        run_node("SourceRead", {"table": str(series), "photo": "noon"})
    small = tmp_path / "small.png"
    write_png(small, np.zeros((16, 16, 3), np.uint8))
    bad = tmp_path / "source.yaml"
    bad.write_text(series.read_text().replace("dusk: dusk.png", f"dusk: {small}"))
    with pytest.raises(UserError, match=r"labels_map is .* but images.dusk is 16x16"):
        load_source(bad, photo="dusk")
    src = T.source("renoir")
    f0 = frame(src)
    other = T.source("monet")
    with pytest.raises(UserError, match=r"relight: .*photo .* same view"):
        run_node("Relight", {}, {"image": f0, "source": other}, name="relight")
