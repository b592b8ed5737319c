"""Progressive update after an edit of the proxy (graphs/edit.yaml): a terrain stroke raises
an island in the lake; the re-run recomputes the changed region only and keeps every other
pixel of the last result bit for bit."""
from types import SimpleNamespace
from pathlib import Path

import numpy as np
import pytest

from proxyshade.graph.graph import Graph
from proxyshade.io.source import load_source
from proxyshade.kernels.lookup import lookup
from proxyshade.kernels.temporal import dilate
from proxyshade.synthesis.guide import synthesize_guide
from proxyshade.synthesis.params import Guidance
from tests.nodes._edit import island_edit

ROOT = Path(__file__).resolve().parents[2]
R = 256
SET = [f"proxy.resolution=[{R},{R}]", f"guide.size={R // 2}", f"guide.start={R // 8}"]
MAPPED = ("R", "G", "B", "source.x", "source.y", "patch.id", "label.id")


def run(d):
    g = Graph.load(ROOT / "graphs" / "edit.yaml", cache=d / "cache", overrides=SET,
                   variables={"scene": str(d / "lake.usda"), "out": str(d / "out")})
    report = g.run(frames=[1])
    return report, {k: g.value(k, 1) for k in ("proxy", "guide", "depth", "final")}, g


def differs(a, b):
    return ~((a == b) | (np.isnan(a) & np.isnan(b))) if a.dtype.kind == "f" else a != b


@pytest.fixture(scope="module")
def edited(tmp_path_factory):
    return island_edit(tmp_path_factory.mktemp("edit"), run)


def test_outside_the_dilated_footprint_every_pixel_is_unchanged(edited):
    b, a, g = edited["before"], edited["after"], edited["graph"]
    lab = differs(b["proxy"]["label.id"], a["proxy"]["label.id"])
    geo = lab | differs(b["proxy"]["Z"], a["proxy"]["Z"])
    assert 0 < lab.sum() < 0.05 * lab.size
    # the footprint: the proxy renders' difference, dilated by the guide's and the colour's margins
    # (and the depth's, for the geometry AOVs)
    margin = g.nodes["guide"].params["dilate"] + g.nodes["final"].params["dilate"]
    colour_fp = dilate(np.ascontiguousarray(lab), margin)
    all_fp = dilate(np.ascontiguousarray(geo), margin + g.nodes["depth"].params["dilate"])
    fb, fa = b["final"], a["final"]
    assert set(fb.names()) == set(fa.names())
    changed_colour = np.zeros(lab.shape, bool)
    for c in MAPPED:
        changed_colour |= differs(fb[c], fa[c])
    assert not (changed_colour & ~colour_fp).any()
    for c in fb.names():
        assert not (differs(fb[c], fa[c]) & ~all_fp).any(), c
    assert changed_colour.sum() > lab.sum()  # the island and the band around it were synthesized


def test_inside_the_footprint_pixels_follow_the_new_proxy_labels(edited):
    b, a = edited["before"], edited["after"]
    lab = differs(b["proxy"]["label.id"], a["proxy"]["label.id"])
    new = a["proxy"]["label.id"]
    # the detailed guide takes the new proxy labels where they changed as well as a whole synthesis
    # of the edited proxy does (the detailed guide moves label borders by design, §4)
    g = edited["graph"]
    whole, _ = synthesize_guide(a["proxy"], load_source(ROOT / "samples" / "renoir" / "source.yaml"),
                                Guidance.of(SimpleNamespace(**g.nodes["guide"].params)))
    agree = (a["guide"]["label.id"][lab] == new[lab]).mean()
    assert agree >= (whole["label.id"][lab] == new[lab]).mean() - 0.1
    assert (a["final"]["label.id"] == a["guide"]["label.id"]).all()
    # and the colours there come from source pixels of that label, through the one lookup
    src = load_source(ROOT / "samples" / "renoir" / "source.yaml")
    fa = a["final"]
    through = lookup(src["label.id"], fa["source.x"], fa["source.y"])
    assert (through[lab] == fa["label.id"][lab]).mean() > 0.95


def test_the_update_recomputes_less_than_the_frame(edited):
    first, update = edited["first"], edited["update"]
    for node in ("guide", "depth", "final"):
        assert "progressive" in update.rows(node)[0].reason
    fm, um = edited["before"]["final"].meta["edit"], edited["after"]["final"].meta["edit"]
    assert fm["whole"] and fm["share"] == 1.0
    assert not um["whole"] and 0 < um["share"] < 0.1
    assert um["synthesis_pixels"] < 0.1 * fm["synthesis_pixels"]
    notes = " ".join(update.notes)
    assert "progressive" in notes and "window" in notes
    # the cache serves the same history again: nothing recomputed
    assert run(edited["dir"])[0].computed == set()
