"""An edit of the first frame carried through a camera move (graphs/edit_move.yaml): after a
terrain stroke raises an island in the lake, the re-run of the move updates each later frame
only where the edit reaches it (the first frame's changed pixels reprojected into that
frame's camera, and the pixels whose proxy changed), keeps every other pixel's synthesis bit
for bit, resynthesizes few pixels, and the edited shot keeps the shot-quality bars (issue
#10: seams <= 1.5x the first frame's, detail >= 0.9)."""
from pathlib import Path

import numpy as np
import pytest

from proxyshade.graph.graph import Graph
from proxyshade.kernels import quality as Q
from proxyshade.kernels import reproject as kr
from proxyshade.kernels.temporal import dilate
from proxyshade.scene.edit import add_stroke
from proxyshade.synthesis.state import CORRECTION
from proxyshade.synthesis.temporal import ZTOL, camera_of
from tests.nodes._edit import island_edit

ROOT = Path(__file__).resolve().parents[2]
R, N = 128, 4
SET = [f"proxy.resolution=[{R},{R}]", f"guide.size={R // 4}", f"guide.start={R // 16}"]
STATE = ("R", "G", "B", "source.x", "source.y", "patch.id", "label.id")
NODES = ("proxy", "cd", "reproject", "final")


def run(d):
    g = Graph.load(ROOT / "graphs" / "edit_move.yaml", cache=d / "cache", overrides=SET,
                   variables={"scene": str(d / "lake.usda"), "out": str(d / "out")})
    report = g.run(frames=list(range(1, N + 1)))
    return report, {f: {k: g.value(k, f) for k in NODES} for f in range(1, N + 1)}, g


def differs(a, b, channels):
    out = np.zeros(a.shape, bool)
    for c in channels:
        x, y = a[c], b[c]
        out |= ~((x == y) | (np.isnan(x) & np.isnan(y))) if x.dtype.kind == "f" else x != y
    return out


@pytest.fixture(scope="module")
def moved(tmp_path_factory):
    return island_edit(tmp_path_factory.mktemp("edit_move"), run)


def footprint(moved, f):
    """Frame f's pixels whose surface point lies, in the first frame's camera, on a pixel
    whose synthesis the edit changed there, and those whose proxy label or depth changed."""
    b, a = moved["before"], moved["after"]
    f1 = differs(b[1]["final"], a[1]["final"], STATE)
    cam1, camf = camera_of("first", a[1]["final"]), camera_of("frame", a[f]["cd"])
    u, v, _, ok = kr.transfer(kr.inverse_depth(a[f]["cd"]["Z"]), kr.relative_matrix(camf, cam1), kr.intrinsics(camf),
                              kr.intrinsics(cam1), cam1.near)
    ii, jj = np.nonzero(ok)
    c, r = np.floor(u[ii, jj]).astype(int), np.floor(v[ii, jj]).astype(int)
    inside = (c >= 0) & (r >= 0) & (c < R) & (r < R)
    fp = np.zeros((R, R), bool)
    fp[ii[inside], jj[inside]] = f1[r[inside], c[inside]]
    p0, p1 = b[f]["proxy"], a[f]["proxy"]
    with np.errstate(invalid="ignore"):
        dz = ~((p0["Z"] == p1["Z"]) | (np.abs(p1["Z"] - p0["Z"]) <= ZTOL * np.minimum(np.abs(p0["Z"]), np.abs(p1["Z"]))))
    return fp | (p0["label.id"] != p1["label.id"]) | dz


def test_outside_the_reprojected_footprint_the_synthesis_is_unchanged(moved):
    b, a, g = moved["before"], moved["after"], moved["graph"]
    p = g.nodes["reproject"].params
    margin = p["fill_radius"] + p["isolated_radius"] + p["dilate"] + 3  # temporal.carry_margin
    for f in range(2, N + 1):
        changed = differs(b[f]["final"], a[f]["final"], STATE)
        fp = footprint(moved, f)
        assert 0 < fp.sum() < 0.3 * fp.size
        assert changed.sum() > 0.5 * fp.sum()  # the edit is carried into the frame
        # margins: the first frame's (EditSynth's dilation) and the carry's, around the footprint
        assert not (changed & ~dilate(np.ascontiguousarray(fp), margin + g.nodes["first"].params["dilate"])).any(), f
        # this frame's geometry is the edited proxy's everywhere, as in a whole run
        for c in ("Z", "category"):
            assert np.array_equal(a[f]["final"][c], a[f]["cd"][c], equal_nan=True)


def test_the_update_recomputes_only_what_the_edit_reaches(moved):
    upd = moved["update"]
    for node in ("reproject", "final"):
        rows = [r for r in upd.rows(node) if r.frame > 1]
        assert len(rows) == N - 1 and all("progressive" in r.reason for r in rows)
    b, a = moved["before"], moved["after"]
    for f in range(2, N + 1):
        e = a[f]["reproject"].meta["temporal"]["edit"]
        assert 0 < e["share"] < 0.5  # the carry's region: the footprint and its margins
        rs = a[f]["final"].meta["resynthesis"]
        flagged = int((a[f]["reproject"]["flag"] > 0).sum())
        state = STATE + ("flag",) + tuple(c for c in CORRECTION if c in a[f]["reproject"])
        assert rs["edit"]["pixels"] == differs(b[f]["reproject"], a[f]["reproject"], state).sum()
        assert rs["pixels"] <= flagged and rs["pixels"] < 0.1 * R * R  # few resynthesized
    # the cache serves the same history again: nothing recomputed
    assert run(moved["dir"])[0].computed == set()


def test_a_frame_the_edit_does_not_reach_keeps_its_result(moved):
    """A stroke out of view changes no pixel of any frame: every frame's synthesis is kept
    whole."""
    d = moved["dir"]
    add_stroke(d / "lake.yaml", "Ground", (0, 55), 3.0, 2.0)  # behind the camera
    r, plates, _ = run(d)
    for f in range(1, N + 1):
        for c in plates[f]["final"].names():
            assert np.array_equal(plates[f]["final"][c], moved["after"][f]["final"][c], equal_nan=True), (f, c)
    assert {"reproject", "final"} <= r.computed  # the scene changed: run again, progressively
    notes = " ".join(r.notes)
    assert "does not reach" in notes


def test_the_edited_shot_keeps_the_shot_quality_bars(moved):
    a = moved["after"]
    f1 = a[1]["final"]
    s0 = Q.seam_share(f1["source.x"], f1["source.y"], f1["label.id"])
    d0 = Q.detail(f1.rgb(), f1["label.id"])
    for f in range(2, N + 1):
        fin = a[f]["final"]
        assert Q.seam_share(fin["source.x"], fin["source.y"], fin["label.id"]) <= 1.5 * s0
        assert Q.detail(fin.rgb(), fin["label.id"]) >= 0.9 * d0
