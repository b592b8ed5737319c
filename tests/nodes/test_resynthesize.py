"""Resynthesize: restricted synthesis of flagged pixels, and the coherence of whole sample moves."""
import numpy as np
import pytest

from proxyshade.errors import NodeInputError
from proxyshade.graph.testing import run_node
from proxyshade.kernels.lookup import lookup
from proxyshade.synthesis.grain import source_colours
from proxyshade.synthesis.temporal import FLAG
from tests.nodes._temporal import SCENES, coherence_metrics, first_frame, proxy, source

SIZE = 128


def carried(scene="lake"):
    """A 'Reproject output' over the first frame: its map and colours, no flags yet."""
    f0 = first_frame(scene, SIZE)
    return f0.with_channels({"flag": np.zeros(f0.shape, np.uint32), "distortion": np.zeros(f0.shape, np.float32)})


def resynth(img, scene="lake", frame=2, **params):
    return run_node("Resynthesize", params, {"image": img, "source": source(SCENES[scene])}, frame=frame)


def test_nothing_flagged_passes_through():
    img = carried()
    out = resynth(img)
    for c in img.names():
        np.testing.assert_array_equal(out[c], img[c])


def test_flagged_pixels_are_resynthesized_and_the_rest_kept_exactly():
    img = carried()
    flag = np.zeros(img.shape, np.uint32)
    flag[40:72, 30:70] = FLAG["disoccluded"]
    flag[90:100, 90:110] = FLAG["newly_occluded"]
    img = img.with_channels({"flag": flag})
    out = resynth(img, solve=False)
    keep = flag == 0
    for c in ("R", "G", "B", "source.x", "source.y", "patch.id", "label.id"):
        np.testing.assert_array_equal(out[c][keep], img[c][keep])
    new = ~keep
    assert out["patch.id"][new].min() > img["patch.id"].max()
    # flood fill grew new patches (it may pick the carried copy again: 0.41-0.59 of the
    # pixels move, 10th-90th percentile over 40 seeds)
    assert (out["source.x"][new] != img["source.x"][new]).mean() > 0.3
    src = source("renoir")
    fidelity = (lookup(src["label.id"], out["source.x"], out["source.y"]) == out["label.id"])[new].mean()
    assert fidelity > 0.99
    assert "grain" in img.meta  # the first frame's table: new pixels read the graded source, as the first frame did
    rgb = lookup(source_colours(src, img.meta), out["source.x"], out["source.y"])
    np.testing.assert_allclose(out.rgb()[new], rgb[new], atol=1e-6)  # f∘s before the solve


def test_distorted_areas_start_from_their_own_map():
    img = carried()
    flag = np.zeros(img.shape, np.uint32)
    flag[32:64, 32:64] = FLAG["distorted"]
    flag[80:112, 32:64] = FLAG["disoccluded"]
    img = img.with_channels({"flag": flag})
    out = resynth(img, solve=False, passes=0, passes_finest=0)  # no correction: the initial map only
    d = flag == FLAG["distorted"]
    f = flag == FLAG["disoccluded"]
    same_d = (np.abs(out["source.x"] - img["source.x"]) < 1e-3)[d].mean()
    same_f = (np.abs(out["source.x"] - img["source.x"]) < 1e-3)[f].mean()
    # the synthesis-size map is read back from the output's, whose seams Magnify moved off
    # the factor-pixel grid: the blocks those seams cross come back on the grid (~16 % here)
    assert same_d > 0.75 and same_f < 0.25


def test_restricted_solve_equals_the_poisson_node_with_keep():
    img = carried()
    flag = np.zeros(img.shape, np.uint32)
    flag[20:50, 10:60] = FLAG["disoccluded"]
    flag[100:128, 0:30] = FLAG["distorted"]
    img = img.with_channels({"flag": flag})
    solved = resynth(img)
    unsolved = resynth(img, solve=False)
    src = source("renoir")  # the source the frames read: graded by the first frame's grain table
    rgb = source_colours(src, img.meta)
    graded = src.with_channels({"R": rgb[..., 0].copy(), "G": rgb[..., 1].copy(), "B": rgb[..., 2].copy()})
    ref = run_node("Poisson", {"layout": False}, {"image": unsolved, "keep": unsolved, "source": graded})
    np.testing.assert_allclose(solved.rgb(), ref.rgb(), atol=1e-4)
    keep = flag == 0
    np.testing.assert_array_equal(solved.rgb()[keep], img.rgb()[keep])


def test_resolved_region_keeps_the_correction_around_it():
    """Re-anchored pixels (flag 4: map kept, Poisson redone) in a frame whose kept pixels
    carry a correction (colour = source through the map + correction, here a constant
    offset, as a layout move of the first frame leaves): the region is solved as it would
    be on the plain source, plus the offset, so it neither steps at its border nor fades
    to the uncorrected source inside (the solve is linear; a constant is its own harmonic
    continuation). Without ``extend_correction`` the regions come back
    0.05 off."""
    src = source("renoir")
    base = carried()
    rgb = lookup(source_colours(src, base.meta), base["source.x"], base["source.y"])
    flag = np.zeros(base.shape, np.uint32)
    flag[40:72, 30:70] = FLAG["reanchored"]
    flag[96:120, 80:120] = FLAG["reanchored"]
    offset = np.array([0.03, 0.02, 0.05], np.float32)
    plates = []
    kept = flag == 0
    for c in (np.zeros(3, np.float32), offset):  # as Reproject leaves it: flagged pixels the plain source
        ch = {k: (rgb[..., i] + c[i] * kept).astype(np.float32) for i, k in enumerate("RGB")}
        ch.update({f"correction.{k}": (c[i] * kept).astype(np.float32) for i, k in enumerate("RGB")})
        img = base.with_channels(dict(ch, flag=flag))
        plates.append(resynth(img, extend_correction=True))
    for zero, off in [plates]:
        new = (flag != 0) & (zero.rgb() > 0).all(-1)  # the solve floors negative values at 0 (not linear there)
        np.testing.assert_allclose((off.rgb() - zero.rgb())[new], np.broadcast_to(offset, (new.sum(), 3)), atol=1e-3)
        # the correction carried to the next frame holds the offset too
        np.testing.assert_allclose(np.stack([off[f"correction.{k}"] - zero[f"correction.{k}"] for k in "RGB"], -1)[new],
                                   np.broadcast_to(offset, (new.sum(), 3)), atol=1e-3)


def test_solve_margin_spreads_a_thin_regions_mismatch_over_its_kept_ring():
    """A 2-px flagged band between two kept regions whose levels disagree (one side carries
    a correction of +0.1, as a frame's layout leaves): the restricted solve alone must put
    the whole step into the band's few edges; with ``solve_margin`` the kept pixels within
    it are solved too (their own colour differences as guidance), so the step spreads over
    the ring. Kept pixels beyond the margin stay bit for bit, the ring changes smoothly
    (its texture kept), and its carried correction still equals colour minus source."""
    src = source("renoir")
    base = carried()
    rgb = lookup(source_colours(src, base.meta), base["source.x"], base["source.y"])
    lab = base["label.id"]
    rows = slice(24, 104)
    flag = np.zeros(base.shape, np.uint32)
    flag[rows, 63:65] = FLAG["disoccluded"]
    corr = np.zeros(base.shape + (3,), np.float32)
    corr[:, 65:] = 0.1
    kept = flag == 0
    ch = {c: (rgb[..., i] + corr[..., i] * kept).astype(np.float32) for i, c in enumerate("RGB")}
    ch.update({f"correction.{c}": (corr[..., i] * kept).astype(np.float32) for i, c in enumerate("RGB")})
    img = base.with_channels(dict(ch, flag=flag))
    plain, wide = resynth(img, kept_as_one=True), resynth(img, kept_as_one=True, solve_margin=8)
    on = lab[rows, 60:69].min(1) == lab[rows, 60:69].max(1)  # rows where the band and both sides share a label
    assert on.mean() > 0.5
    lum = [o.rgb().mean(-1)[rows][on] for o in (plain, wide)]
    step = [float((u[:, 65] - u[:, 62]).mean()) for u in lum]  # across the band: 0.1 + the source's own step
    np.testing.assert_array_equal(plain.rgb()[kept], img.rgb()[kept])  # Dirichlet: the band takes it all
    assert step[0] - step[1] > 0.03
    far = kept.copy()
    far[:, 63 - 9:65 + 9] = False
    for c in ("R", "G", "B", "source.x", "source.y", "patch.id", "correction.R"):
        np.testing.assert_array_equal(wide[c][far], img[c][far])
    ring = kept & ~far
    change = (wide.rgb() - img.rgb()).mean(-1)
    assert change[rows, 62][on].mean() > 0.01 and change[rows, 65][on].mean() < -0.01  # the ring took part of it
    both = ring[:, 1:] & ring[:, :-1] & (lab[:, 1:] == lab[:, :-1])
    d = np.abs(np.diff(change, axis=1))[both]
    assert d.max() < 0.05 and d.mean() < 0.01  # no step inside the ring: a smooth change, its texture kept
    np.testing.assert_array_equal(wide["source.x"][ring], img["source.x"][ring])
    back = np.stack([wide[f"correction.{c}"] for c in "RGB"], -1) + rgb
    np.testing.assert_allclose(back[ring], wide.rgb()[ring], atol=1e-5)
    # Reproject's creep gate (meta temporal.rising): the ring only on the labels listed
    def gated(rising):
        meta = {"temporal": dict(img.meta.get("temporal", {}), rising=rising)}
        return resynth(img.with_channels(meta=meta), kept_as_one=True, solve_margin=8)

    every = [int(k) for k in np.unique(lab)]
    same = lambda a, b: all(np.array_equal(a[c], b[c]) for c in b.names())  # noqa: E731 (meta differs)
    assert same(gated(every), wide)
    band = int(np.bincount(lab[rows, 63:65][on].ravel()).argmax())  # the band's main label
    others = gated([k for k in every if k != band])
    mine = kept & (lab == band)
    np.testing.assert_array_equal(others.rgb()[mine], img.rgb()[mine])  # its kept pixels not freed
    assert not np.array_equal(others.rgb()[kept], img.rgb()[kept])  # the other labels' rings were
    assert same(gated([]), resynth(img))  # nothing creeping: neither remedy
    # gate_result: a label that the previous frame did not show rising but this frame's result
    # does (its gradient over the first frame's above the gate) is solved again with the remedies
    from proxyshade.synthesis.temporal import label_ratios

    plain_result = gated([])
    g = label_ratios(plain_result.rgb(), lab, {k: 1.0 for k in every})  # the result's own mean gradients

    def after(ratio):
        first = {str(k): (g[k] / ratio if k == band else 10 * g[k]) for k in g}
        meta = {"temporal": dict(img.meta.get("temporal", {}), rising=[], gate=1.05, first_gradient=first)}
        return resynth(img.with_channels(meta=meta), kept_as_one=True, solve_margin=8, gate_result=True)

    assert same(after(1.2), gated([band]))
    assert same(after(1.0), plain_result)


def test_gate_result_solves_again_only_the_regions_of_the_labels_it_adds():
    """``gate_result``'s second solve (a label the result shows rising) redoes only the
    regions of freed pixels in or beside that label: each region is its own problem, so the
    result is the full second solve's (``rising`` listing the label from the start), and a
    flagged region of another label keeps the first solve's colours bit for bit."""
    from proxyshade.synthesis.temporal import label_ratios

    base = carried()
    lab = base["label.id"]
    counts = np.bincount(lab.ravel())
    a, b = (int(k) for k in np.argsort(counts)[::-1][:2])  # the two largest labels
    flag = np.zeros(base.shape, np.uint32)
    corr = np.zeros(base.shape + (3,), np.float32)
    for k, v in ((a, 0.1), (b, -0.08)):
        ii, jj = np.nonzero(lab == k)
        i, j = int(np.median(ii)), int(np.median(jj))
        box = (slice(max(i - 6, 0), i + 6), slice(max(j - 2, 0), j + 2))
        flag[box] = np.where(lab[box] == k, FLAG["disoccluded"], 0)
        corr[box[0], box[1].stop:box[1].stop + 20] = v
    kept = flag == 0
    rgb = lookup(source_colours(source("renoir"), base.meta), base["source.x"], base["source.y"])
    ch = {c: (rgb[..., i] + corr[..., i] * kept).astype(np.float32) for i, c in enumerate("RGB")}
    ch.update({f"correction.{c}": (corr[..., i] * kept).astype(np.float32) for i, c in enumerate("RGB")})
    img = base.with_channels(dict(ch, flag=flag))
    every = [int(k) for k in np.unique(lab)]

    def run(rising, first=None, **p):
        t = dict(img.meta.get("temporal", {}), rising=rising)
        if first is not None:
            t.update(gate=1.05, first_gradient=first)
        return resynth(img.with_channels(meta={"temporal": t}), flagged_apart=True, solve_margin=8, **p)

    plain = run([])
    g = label_ratios(plain.rgb(), lab, {k: 1.0 for k in every})
    after = run([], {str(k): (g[k] / 1.2 if k == a else 10 * g[k]) for k in g}, gate_result=True)
    assert after.meta["resynthesis"]["gated_after"] == [a]
    full = run([a])
    np.testing.assert_allclose(after.rgb(), full.rgb(), atol=2e-6)
    near_b = (lab == b) & ~kept
    np.testing.assert_array_equal(after.rgb()[near_b], plain.rgb()[near_b])
    assert not np.array_equal(after.rgb()[(lab == a) & ~kept], plain.rgb()[(lab == a) & ~kept])


def test_deterministic_per_frame_seed():
    img = carried()
    flag = np.zeros(img.shape, np.uint32)
    flag[40:72, 30:70] = FLAG["disoccluded"]
    img = img.with_channels({"flag": flag})
    a, b = resynth(img, frame=3), resynth(img, frame=3)
    assert a.equals(b)
    c = resynth(img, frame=4)
    assert not np.array_equal(a["source.x"], c["source.x"])


def test_bad_inputs():
    with pytest.raises(NodeInputError, match="Reproject"):
        resynth(first_frame("lake", SIZE))  # no flag channel


@pytest.mark.parametrize("scene", ["lake", "cliffs", "farm"])
def test_sample_move_is_coherent_and_resynthesizes_little(scene):
    # the warp of the measure reconstructs the previous frame as the renderer reads the
    # source (Lanczos-4): a bilinear warp would itself blur a sharp frame and count that
    m = coherence_metrics(scene, range(1, 7), SIZE, filters=("lanczos4",), detail=True)
    print(scene, m["median_share"], m["ratio"], m["coherent"], m["independent"])
    assert m["median_share"] <= 0.10
    assert m["ratio"]["lanczos4"] <= 0.10


def test_camera_move_graph_reuses_earlier_frames(tmp_path):
    """graphs/camera_move.yaml at 64²: frame 3 alone computes frames 1-2 on the way, the first
    frame's synthesis runs once, a re-run is all cache, frame 4 then only adds frame 4."""
    from pathlib import Path

    from proxyshade.graph.graph import Graph

    graph = Path(__file__).resolve().parents[2] / "graphs" / "camera_move.yaml"

    def load():
        return Graph.load(graph, cache=tmp_path / "cache",
                          overrides=["proxy.resolution=[64,64]", "guide.size=32", "guide.start=16"],
                          variables={"out": str(tmp_path / "out")})

    r = load().run([3])
    done = {(x.node, x.frame) for x in r.runs if x.status == "computed"}
    assert {("final", 1), ("final", 2), ("final", 3), ("write", 3), ("init", 1)} <= done
    assert {("guide", 1), ("depth", 1), ("first", 1)} <= done
    assert not any(n in ("guide", "depth", "init", "correct", "magnify", "first") and f != 1 for n, f in done)
    assert ("write", 2) not in done and (tmp_path / "out" / "lake_renoir" / "frame.0003.exr").is_file()
    r = load().run([3])
    assert not r.computed
    r = load().run([4])
    assert {(x.node, x.frame) for x in r.runs if x.status == "computed"} == {
        (n, 4) for n in ("proxy", "cd", "reproject", "final", "crypto", "write", "preview", "flags", "labels", "movie")}
    import OpenEXR

    with OpenEXR.File(str(tmp_path / "out" / "lake_renoir" / "frame.0004.exr")) as f:
        names = set(f.channels())
    assert {"flag", "distortion", "category"} <= names


def test_flagged_apart_solves_like_kept_as_one_but_blends_the_rings_seams_again():
    """A re-anchored region (flag 4: map kept, plain source) inside kept pixels that carry
    a correction of +0.1. ``flagged_apart`` and ``kept_as_one`` both give the region's
    border the source's gradient (no 0.1 step kept there): without a ring the same solve,
    bit for bit. With ``solve_margin`` the kept pixels' differences stay as they are under
    ``kept_as_one``, while ``flagged_apart`` keeps their patch ids: the ring's seams are
    blended again, their jumps fall."""
    src = source("renoir")
    base = carried()
    rgb = lookup(source_colours(src, base.meta), base["source.x"], base["source.y"])
    flag = np.zeros(base.shape, np.uint32)
    flag[40:80, 40:80] = FLAG["reanchored"]
    kept = flag == 0
    rng = np.random.default_rng(2)
    corr = np.where(kept[..., None], 0.1, 0.0).astype(np.float32)
    patch = base["patch.id"]
    jump = rng.uniform(-0.05, 0.05, (int(patch.max()) + 1, 3)).astype(np.float32)[patch]  # seams' jumps per patch
    corr = corr + jump * kept[..., None]
    ch = {c: (rgb[..., i] + corr[..., i]).astype(np.float32) for i, c in enumerate("RGB")}
    ch.update({f"correction.{c}": corr[..., i].copy() for i, c in enumerate("RGB")})
    img = base.with_channels(dict(ch, flag=flag))
    one, apart = resynth(img, kept_as_one=True), resynth(img, flagged_apart=True)
    for c in ("R", "G", "B"):
        np.testing.assert_array_equal(apart[c], one[c])
    inner = np.zeros(base.shape, bool)
    inner[41:79, 41:79] = True
    assert abs(float((one.rgb() - rgb)[inner].mean())) < 0.05  # near the plain source: no 0.1 carried in
    plain = resynth(img)  # the patch ids as they are: the correction's step kept at the border
    step = lambda o: float(((o.rgb() - rgb)[40:80, 40] - (o.rgb() - rgb)[40:80, 39]).mean())  # noqa: E731
    assert step(plain) < -0.04 and abs(step(one)) < 0.02  # off the plain source across the border: 0.1 / none

    one, apart = resynth(img, kept_as_one=True, solve_margin=6), resynth(img, flagged_apart=True, solve_margin=6)
    ring = np.zeros(base.shape, bool)
    ring[34:86, 34:86] = True
    ring &= kept
    lab = base["label.id"]
    lum = lambda pl: pl.rgb().mean(-1)  # noqa: E731
    seams = ring[:, 1:] & ring[:, :-1] & (patch[:, 1:] != patch[:, :-1]) & (lab[:, 1:] == lab[:, :-1])
    assert seams.sum() > 10
    d = {k: np.abs(np.diff(lum(o), axis=1))[seams].mean() for k, o in (("in", img), ("one", one), ("apart", apart))}
    assert abs(d["one"] - d["in"]) < 0.1 * d["in"]  # kept_as_one: the seams' jumps as they came
    assert d["apart"] < 0.8 * d["one"]
