"""Reproject on hand-made camera moves over the analytic wall/ball scene."""
import numpy as np
import pytest
from scipy import ndimage

from proxyshade.errors import NodeInputError
from proxyshade.graph.plate import Plate
from proxyshade.graph.testing import run_node
from proxyshade.kernels.lookup import lookup
from proxyshade.kernels import reproject as kr
from proxyshade.kernels import temporal as kt
from proxyshade.synthesis.temporal import FLAG, patch_thresholds
from tests.nodes._temporal import camera, render, state_plate, toy_source

EXACT = {"spread": 0.0, "fill_radius": 0, "min_patch_area": 0, "min_patch_width": 0.0}  # one threshold for all
# patches; disoccluded pixels not continued; fragments kept


def step(proxy_n, proxy_0, prev, frame=2, **params):
    cd = run_node("ConsistentDepth", {}, {"proxy": proxy_n, "guide": proxy_0, "ref_proxy": proxy_0}, frame=frame)
    return run_node("Reproject", params, {"depth": cd, "prev": prev, "source": toy_source()}, frame=frame)


def with_distortion(plate: Plate, d: np.ndarray) -> Plate:
    return plate.with_channels({"distortion": d.astype(np.float32), "flag": np.zeros(plate.shape, np.uint32)})


@pytest.mark.parametrize("colour", ["map", "bilinear"])
def test_translation_over_a_plane_copies_pixels_and_has_no_distortion(colour):
    # a wall facing the camera, the camera sliding along it: 40 px focal * 0.5 / 20 = exactly 1 px per frame
    cams = [camera(pos=(0.5 * k, 0, 0), frame=k + 1) for k in range(5)]
    renders = [render(c, sphere=None) for c in cams]
    prev = with_distortion(state_plate(renders[0]), np.zeros((64, 64)))
    first = prev
    for k in range(1, 5):
        out = step(renders[k], renders[0], prev, frame=k + 1, colour=colour, threshold=0.05, **EXACT)
        flag = out["flag"]
        assert not (flag == FLAG["distorted"]).any()
        assert np.abs(out["distortion"]).max() < 1e-5  # the carried map is still a translation: J = I
        # the column that entered on the right is disoccluded (dilated by 2), nothing else
        assert (flag[:, -1] == FLAG["disoccluded"]).all() and not flag[:, :-3].any()
        # kept pixels: the previous frame one pixel to the right, exactly (map: through the map)
        keep = flag == 0
        np.testing.assert_allclose(out.rgb()[:, :-3], prev.rgb()[:, 1:-2], atol=1e-6)
        np.testing.assert_array_equal(out["source.x"][keep], np.roll(prev["source.x"], -1, axis=1)[keep])
        np.testing.assert_array_equal(out["patch.id"][keep], np.roll(prev["patch.id"], -1, axis=1)[keep])
        # what a later stage would resynthesize stands in for it here: shift the first frame
        prev = out.with_channels({c: np.roll(first[c], -k, axis=1) for c in ("R", "G", "B", "source.x", "source.y",
                                                                               "patch.id")})
        prev = prev.with_channels({"flag": np.zeros((64, 64), np.uint32)})


def test_continued_pixels_join_the_solve_with_solve_continued():
    """A pan disoccludes a column on the right; with ``fill_radius`` it continues its
    neighbour's patch (kept, flag 0). ``solve_continued`` flags exactly those pixels 4 (map
    kept, Poisson redone): the same map, the plain source through it, no carried
    correction; every other pixel as without it."""
    cams = [camera(pos=(0.5 * k, 0, 0), frame=k + 1) for k in range(2)]
    r0, r1 = (render(c, sphere=None) for c in cams)
    prev = with_distortion(state_plate(r0), np.zeros((64, 64)))
    prev = prev.with_channels({f"correction.{c}": np.full((64, 64), 0.05, np.float32) for c in "RGB"})
    params = dict(EXACT, fill_radius=6)
    a = step(r1, r0, prev, **params)
    b = step(r1, r0, prev, solve_continued=True, **params)
    cont = (a["extension"] > 0) & (a["flag"] == 0)
    assert cont[:, -1].all()
    four = cont & (b["flag"] == FLAG["reanchored"])
    assert four.sum() >= cont.sum() - 2  # the column's two ends: too few flags around them (isolated, dropped)
    np.testing.assert_array_equal(b["flag"][~four], a["flag"][~four])
    for c in ("source.x", "source.y", "patch.id"):
        np.testing.assert_array_equal(b[c], a[c])
    np.testing.assert_array_equal(b["correction.R"][four], 0.0)
    np.testing.assert_allclose(a["correction.R"][cont], 0.05)
    plain = lookup(toy_source().rgb(), b["source.x"], b["source.y"], filter="lanczos4")
    np.testing.assert_allclose(b.rgb()[four], plain[four], atol=1e-6)
    np.testing.assert_allclose(a.rgb()[four], plain[four] + 0.05, atol=1e-6)


def test_continue_tail_stops_continuation_on_the_labels_rare_looks():
    """With ``continue_tail`` a disoccluded pixel continues its neighbour's patch only onto
    a source pixel outside its label's luminance tails (``typical_labels``); where the
    continuation would read a rare look the pixel is flagged disoccluded (resynthesized).
    Every other pixel is as without it."""
    from proxyshade.synthesis.temporal import RARE, typical_labels

    cams = [camera(pos=(0.5 * k, 0, 0), frame=k + 1) for k in range(2)]
    r0, r1 = (render(c, sphere=None) for c in cams)
    prev = with_distortion(state_plate(r0), np.zeros((64, 64)))
    params = dict(EXACT, fill_radius=6)
    a = step(r1, r0, prev, **params)
    b = step(r1, r0, prev, continue_tail=0.25, **params)
    typ = typical_labels(toy_source(), 0.25)
    hs, ws = typ.shape

    def rare(p, m):
        c = np.clip(np.floor(np.clip(p["source.x"][m], 0, ws - 1) + 0.5), 0, ws - 1).astype(int)
        r = np.clip(np.floor(np.clip(p["source.y"][m], 0, hs - 1) + 0.5), 0, hs - 1).astype(int)
        return typ[r, c] == RARE

    cont_a = (a["extension"] > 0) & (a["flag"] == 0)
    cont_b = (b["extension"] > 0) & (b["flag"] == 0)
    on_rare = np.zeros((64, 64), bool)
    on_rare[cont_a] = rare(a, cont_a)
    assert 5 < on_rare.sum() < cont_a.sum()  # the toy source's tails are hit, not everywhere
    assert not rare(b, cont_b).any()
    assert (b["flag"][on_rare] == FLAG["disoccluded"]).all()
    # the new flags are dilated by 2 px (``dilate``): beyond that every pixel is as without the option
    near = ndimage.binary_dilation(on_rare, np.ones((5, 5), bool))
    assert not (cont_b & ~cont_a).any() and (cont_b == cont_a)[~near].all()
    assert (b["flag"] == a["flag"])[~near].all()
    for c in ("source.x", "source.y", "patch.id"):
        np.testing.assert_array_equal(b[c][cont_b], a[c][cont_b])
    # continue_other: another neighbour's patch may be continued there, never onto a rare look (one
    # patch here: every neighbour continues to the same position; the choice: tests/kernels/test_reproject)
    o = step(r1, r0, prev, continue_tail=0.25, continue_other=True, **params)
    cont_o = (o["extension"] > 0) & (o["flag"] == 0)
    assert not rare(o, cont_o).any() and not (cont_b & ~cont_o).any()


def test_creep_gate_continues_into_the_solve_only_where_the_gradient_rose():
    """With ``creep_gate`` Reproject measures each label's mean display-luma gradient in
    ``prev`` over the first frame's (meta ``temporal.gradient``, bench_shot's grad) and lists
    the labels above the gate (``rising``); ``solve_continued`` flags continued pixels 4 only
    there. A first frame of half the previous frame's contrast: the wall's ratio is about 2,
    rising, flags as ungated; of twice its contrast: about 0.5, flags as without
    ``solve_continued``."""
    from proxyshade.io.colourlib import colour_science
    from proxyshade.kernels import quality as Q

    cams = [camera(pos=(0.5 * k, 0, 0), frame=k + 1) for k in range(2)]
    r0, r1 = (render(c, sphere=None) for c in cams)
    prev = with_distortion(state_plate(r0), np.zeros((64, 64)))
    prev = prev.with_channels({f"correction.{c}": np.full((64, 64), 0.05, np.float32) for c in "RGB"})
    params = dict(EXACT, fill_radius=6)
    cd = run_node("ConsistentDepth", {}, {"proxy": r1, "guide": r0, "ref_proxy": r0}, frame=2)

    def run(first, **kw):
        return run_node("Reproject", dict(params, **kw), {"depth": cd, "prev": prev, "first": first,
                                                          "source": toy_source()}, frame=2)

    def luma_grad(pl):
        enc = np.clip(colour_science().cctf_encoding(np.clip(pl.rgb().astype(np.float64), 0, None),
                                                     function="sRGB"), 0, 1)
        return Q.gradient_magnitude(Q.luma(enc), pl["label.id"] == 1)

    mean = prev.rgb().mean((0, 1))
    flat = prev.with_channels({c: (mean[k] + 0.5 * (prev[c] - mean[k])).astype(np.float32)
                               for k, c in enumerate("RGB")})
    steep = prev.with_channels({c: (mean[k] + 2.0 * (prev[c] - mean[k])).astype(np.float32)
                                for k, c in enumerate("RGB")})
    off, ungated = run(flat), run(flat, solve_continued=True)
    assert "gradient" not in off.meta["temporal"]  # no gate: nothing measured
    rose = run(flat, solve_continued=True, creep_gate=1.05)
    fell = run(steep, solve_continued=True, creep_gate=1.05)
    for out, first in ((rose, flat), (fell, steep)):
        assert out.meta["temporal"]["gradient"]["1"] == pytest.approx(luma_grad(prev) / luma_grad(first), rel=1e-5)
    assert rose.meta["temporal"]["gradient"]["1"] > 1.5 and rose.meta["temporal"]["rising"] == [1]
    assert fell.meta["temporal"]["gradient"]["1"] < 0.7 and fell.meta["temporal"]["rising"] == []
    assert (ungated["flag"] == FLAG["reanchored"]).sum() > (off["flag"] == FLAG["reanchored"]).sum() + 40
    np.testing.assert_array_equal(rose["flag"], ungated["flag"])
    np.testing.assert_array_equal(fell["flag"], off["flag"])


def deviation(plate: Plate, mask: np.ndarray) -> np.ndarray:
    return kt.map_deviation(plate["source.x"], plate["source.y"], mask,
                            kr.patch_links(mask, plate["patch.id"], plate["label.id"]), 1.0)


def test_zoom_is_measured_on_the_carried_map_and_reanchored_past_the_threshold():
    p0 = render(camera(f=40.0), sphere=None)
    p1 = render(camera(f=44.0, frame=2), sphere=None)
    prev = with_distortion(state_plate(p0), np.zeros((64, 64)))
    out = step(p1, p0, prev, threshold=10.0, **EXACT)
    expected = np.sqrt(2) * (1 - 40.0 / 44.0)  # the map steps 40/44 source pixels per pixel: ||J - I|| = sqrt(2)(1 - s)
    inner = (slice(4, -4), slice(4, -4))
    interior = deviation(out, np.ones((64, 64), bool))[inner] > 0  # patch borders aside
    np.testing.assert_allclose(out["distortion"][inner][interior], expected, rtol=1e-3)
    assert not out["flag"].any()
    # past the threshold whole patches are flagged; those whose copy still fits the source
    # labels are re-anchored: a plain translation again (J = I), resynthesis left for the rest
    out = step(p1, p0, prev, threshold=0.1, cut_threshold=1.0, **EXACT)
    flag = out["flag"]
    assert ((flag[inner] == FLAG["reanchored"]) | (flag[inner] == FLAG["distorted"])).all()
    assert (flag == FLAG["reanchored"]).mean() > 0.5
    re = flag == FLAG["reanchored"]
    assert deviation(out, re).max() < 1e-4


def test_magnify_threshold_reanchors_a_zoom_in_not_a_zoom_out():
    """``magnify_threshold``: a patch whose carried map magnifies the source (zoom in: the map
    steps 40/44 source pixels per pixel, smaller singular value 0.909) is re-anchored once
    1 - 0.909 passes its threshold, though ||J - I|| (0.129) is under ``threshold``; the zoom out
    (44/40: it minifies) is not."""
    p0 = render(camera(f=40.0), sphere=None)
    p1 = render(camera(f=44.0, frame=2), sphere=None)
    prev = with_distortion(state_plate(p0), np.zeros((64, 64)))
    inner = (slice(4, -4), slice(4, -4))
    off = step(p1, p0, prev, threshold=0.35, cut_threshold=1.0, **EXACT)
    assert not off["flag"].any()
    on = step(p1, p0, prev, threshold=0.35, magnify_threshold=0.08, cut_threshold=1.0, **EXACT)
    re = on["flag"] == FLAG["reanchored"]
    assert ((on["flag"][inner] == FLAG["reanchored"]) | (on["flag"][inner] == FLAG["distorted"])).all()
    assert re.mean() > 0.5 and deviation(on, re).max() < 1e-4
    high = step(p1, p0, prev, threshold=0.35, magnify_threshold=0.1, cut_threshold=1.0, **EXACT)
    assert not high["flag"].any()  # 1 - 0.909 under the threshold
    # the zoom out
    back = with_distortion(state_plate(p1), np.zeros((64, 64)))
    out = step(p0, p1, back, threshold=0.35, magnify_threshold=0.02, cut_threshold=1.0, **EXACT)
    assert not np.isin(out["flag"], (FLAG["reanchored"], FLAG["distorted"])).any()


def test_magnify_gate_reanchors_magnified_patches_only_on_labels_whose_gradient_fell():
    """``magnify_gate``: the zoom in of the test above re-anchors (``magnify_threshold``) only
    when the first frame has twice the previous frame's contrast (every label's gradient ratio
    about 0.5, under the gate), as ungated; with half its contrast (ratio about 2) nothing."""
    p0 = render(camera(f=40.0), sphere=None)
    p1 = render(camera(f=44.0, frame=2), sphere=None)
    prev = with_distortion(state_plate(p0), np.zeros((64, 64)))
    cd = run_node("ConsistentDepth", {}, {"proxy": p1, "guide": p0, "ref_proxy": p0}, frame=2)
    mean = prev.rgb().mean((0, 1))

    def first(gain):
        return prev.with_channels({c: (mean[k] + gain * (prev[c] - mean[k])).astype(np.float32)
                                   for k, c in enumerate("RGB")})

    def run(f, **kw):
        return run_node("Reproject", dict(EXACT, threshold=0.35, magnify_threshold=0.08, cut_threshold=1.0, **kw),
                        {"depth": cd, "prev": prev, "first": f, "source": toy_source()}, frame=2)

    ungated = run(first(2.0))
    assert (ungated["flag"] == FLAG["reanchored"]).mean() > 0.5
    np.testing.assert_array_equal(run(first(2.0), magnify_gate=0.95)["flag"], ungated["flag"])
    assert not run(first(0.5), magnify_gate=0.95)["flag"].any()


def test_continue_tail_resynthesizes_reanchored_copies_on_rare_looks():
    """With ``continue_tail`` a re-anchored copy (a zoom past the threshold) keeps its new map
    (flag 4) only on source pixels outside its label's luminance tails; on a rare look it is
    flagged distorted (resynthesized). Pixels not re-anchored are as without the option."""
    from proxyshade.synthesis.temporal import RARE, typical_labels

    p0 = render(camera(f=40.0), sphere=None)
    p1 = render(camera(f=44.0, frame=2), sphere=None)
    prev = with_distortion(state_plate(p0), np.zeros((64, 64)))
    a = step(p1, p0, prev, threshold=0.1, cut_threshold=1.0, **EXACT)
    b = step(p1, p0, prev, threshold=0.1, cut_threshold=1.0, continue_tail=0.25, **EXACT)
    typ = typical_labels(toy_source(), 0.25)
    hs, ws = typ.shape
    re = a["flag"] == FLAG["reanchored"]
    c = np.floor(np.clip(a["source.x"], 0, ws - 1) + 0.5).astype(int)
    r = np.floor(np.clip(a["source.y"], 0, hs - 1) + 0.5).astype(int)
    rare = re & (typ[r, c] == RARE)
    assert 10 < rare.sum() < re.sum() // 2
    assert (b["flag"][rare] == FLAG["distorted"]).all()
    np.testing.assert_array_equal(b["flag"][~rare], a["flag"][~rare])


def test_shear_with_unit_determinant_is_seen():
    # a map sheared by k has det J = 1 (what the paper's det J never flags) but ||J - I|| = k
    i, j = np.mgrid[0:32, 0:32].astype(np.float64)
    valid = np.ones((32, 32), bool)
    links = kr.patch_links(valid, np.ones((32, 32), np.uint32), np.ones((32, 32), np.uint32))
    np.testing.assert_allclose(kt.jacobian_det(j + 0.3 * i, i, valid), 1.0, atol=1e-12)
    np.testing.assert_allclose(kt.map_deviation(j + 0.3 * i, i, valid, links, 1.0), 0.3, atol=1e-6)


def test_moving_ball_flags_exactly_the_newly_occluded_ring():
    cam0, cam1 = camera(), camera(frame=2)
    p0 = render(cam0, sphere=(0.0, 0.0, -10.0))
    p1 = render(cam1, sphere=(1.5, 0.0, -10.0))
    prev = with_distortion(state_plate(p0), np.zeros((64, 64)))
    out = step(p1, p0, prev, dilate=0, min_neighbours=0, **EXACT)
    ring = (p1["label.id"] == 2) & (p0["label.id"] == 1)
    np.testing.assert_array_equal(out["flag"] == FLAG["newly_occluded"], ring)
    # the wall the ball uncovered has no previous pixel: disoccluded
    uncovered = (p1["label.id"] == 1) & (p0["label.id"] == 2)
    assert (out["flag"][uncovered] == FLAG["disoccluded"]).all()
    # the rest of the wall is kept
    assert not out["flag"][(p1["label.id"] == 1) & (p0["label.id"] == 1)].any()


def test_first_frame_passes_the_full_synthesis_through():
    p0 = render(camera(), sphere=(0.0, 0.0, -10.0))
    first = state_plate(p0)
    cd = run_node("ConsistentDepth", {}, {"proxy": p0, "guide": p0, "ref_proxy": p0}, frame=1)
    out = run_node("Reproject", {}, {"depth": cd, "prev": None, "first": first, "source": toy_source()}, frame=1)
    assert not out["flag"].any()
    for c in ("R", "G", "B", "source.x", "source.y", "patch.id", "label.id"):
        np.testing.assert_array_equal(out[c], first[c])
    assert out["distortion"].max() < 0.5 * 0.5 + 1e-6 and out["category"].dtype == np.uint32
    out = run_node("Reproject", {}, {"depth": cd, "prev": None, "source": toy_source()}, frame=1)
    assert (out["flag"] == FLAG["disoccluded"]).all()


def test_camera_cut_flags_the_whole_frame():
    p0 = render(camera(), sphere=None)
    p1 = render(camera(yaw=1.2, frame=2), sphere=(0.0, 0.0, -10.0))  # another view: nothing carries over
    prev = state_plate(p0)
    out = step(p1, p0, prev)
    assert out.meta["temporal"]["cut"] and (out["flag"] == FLAG["disoccluded"]).all()
    out = step(p1, p0, prev, cut_threshold=1.0)
    assert not out.meta["temporal"]["cut"] and out["flag"].any()


def test_deterministic_and_seeded_per_patch():
    p0 = render(camera(), sphere=(0.0, 0.0, -10.0))
    p1 = render(camera(f=44.0, frame=2), sphere=(0.0, 0.0, -10.0))
    prev = with_distortion(state_plate(p0), np.zeros((64, 64)))
    a = step(p1, p0, prev, threshold=0.2)
    assert a.equals(step(p1, p0, prev, threshold=0.2))
    # each patch has one threshold in [(1 - spread) t, t], the same wherever the patch is
    ids = np.repeat(np.arange(200, dtype=np.uint32)[None], 3, axis=0)
    t1, t2 = patch_thresholds(ids, 0.2, 0.5, 0), patch_thresholds(ids, 0.2, 0.5, 1)
    assert (t1 == t1[0]).all() and (t1 >= 0.1 - 1e-7).all() and (t1 <= 0.2).all() and np.ptp(t1) > 0.08
    assert not np.array_equal(t1, t2)


def test_map_colour_keeps_the_poisson_correction():
    p0 = render(camera(), sphere=None)
    p1 = render(camera(pos=(0.5, 0, 0), frame=2), sphere=None)
    prev = state_plate(p0)
    smooth = np.linspace(0, 0.1, 64, dtype=np.float32)[None, :] * np.ones((64, 1), np.float32)
    prev = prev.with_channels({"R": prev["R"] + smooth})  # a smooth correction added by the Poisson solve
    out = step(p1, p0, prev, filter="bilinear", **EXACT)
    keep = out["flag"] == 0
    base = lookup(toy_source().rgb(), out["source.x"], out["source.y"])
    np.testing.assert_allclose((out["R"] - base[..., 0])[keep], np.roll(smooth, -1, axis=1)[keep], atol=1e-6)


def test_bad_inputs():
    p0 = render(camera(), sphere=None)
    cd = run_node("ConsistentDepth", {}, {"proxy": p0, "guide": p0}, frame=2)
    with pytest.raises(NodeInputError, match="prev"):
        run_node("Reproject", {}, {"depth": cd, "prev": Plate({"R": p0["Z"]}), "source": toy_source()}, frame=2)
    with pytest.raises(NodeInputError, match="source"):
        run_node("Reproject", {}, {"depth": cd, "prev": state_plate(p0), "source": None}, frame=2)


def test_correction_filter_flat_keeps_more_of_the_corrections_fine_detail_over_frames():
    # the camera slides half a pixel a frame along the wall; the previous frame's Poisson correction
    # holds fine detail (period 5 px: a first-frame solve that damped the copied texture holds the
    # opposite of its finest detail). Bilinear keeps cos(pi / 5) = 0.81 of it at each half-pixel step
    # (0.43 after four); flat4 more (its response is 0.96-1.0 there; clamped to the 4x4 pixels' range, the
    # peaks between samples are flattened), and never more than there was (the clamp: no ringing that grows)
    cams = [camera(pos=(0.25 * k, 0, 0), frame=k + 1) for k in range(5)]
    renders = [render(c, sphere=None) for c in cams]
    jj = np.arange(64, dtype=np.float32)
    detail = (0.02 * np.cos(2 * np.pi * jj / 5.0))[None, :] * np.ones((64, 1), np.float32)
    # 2 px moved by four half-pixel steps: the detail where the texture is now, in patch interiors
    # (the state plate's patches are 30 columns wide; 4 px from every seam; not the entering columns)
    j = np.arange(64)
    interior = ((j + 2) % 30 >= 5) & ((j + 2) % 30 <= 24) & (j < 56)
    want = 0.02 * np.cos(2 * np.pi * (j + 2) / 5.0)[interior]
    kept = {}
    for cfilter in ("bilinear", "flat4", "flat2"):
        prev = state_plate(renders[0])
        prev = prev.with_channels({"R": prev["R"] + detail})
        for k in range(1, 5):
            out = step(renders[k], renders[0], prev, frame=k + 1, correction_filter=cfilter, **EXACT)
            prev = out.with_channels({"flag": np.zeros((64, 64), np.uint32)})
        got = out["correction.R"][8:56][:, interior]
        kept[cfilter] = float((got * want).sum() / (want * want).sum() / got.shape[0])  # share left, in phase
        assert np.abs(out["correction.R"]).max() <= 0.02 + 1e-6
        # the rows are the same (a horizontal slide): the detail is where the texture moved, not smeared
        assert np.ptp(got, axis=0).max() < 1e-6
    assert kept["bilinear"] < 0.45
    for sharp in ("flat4", "flat2"):
        assert kept[sharp] > 0.6 and kept[sharp] > 1.4 * kept["bilinear"], kept


def test_snap_to_label_moves_kept_pixels_half_off_their_label_back_onto_it():
    """A kept pixel carried up to half a source pixel past its label's border in the source
    (here a column of the wall's map pushed to x = 31.6: the toy source's label 2 begins at
    column 32) is not stray (kept, flag 0) but reads the other label's nearest pixel; with
    ``snap_to_label`` it is moved onto its own label's last column (x just under 31.5) and
    its colour read there, every other pixel as without it."""
    r0, r1 = render(camera(frame=1), sphere=None), render(camera(frame=2), sphere=None)
    prev = with_distortion(state_plate(r0), np.zeros((64, 64)))
    sx = prev["source.x"].copy()
    off = (prev["label.id"] == 1) & (sx == 29.0)
    sx[off] = 31.6
    prev = prev.with_channels({"source.x": sx})
    params = dict(EXACT, threshold=10.0, colour="map", filter="bilinear")
    a = step(r1, r0, prev, **params)
    b = step(r1, r0, prev, snap_to_label=True, **params)
    src = toy_source()
    assert off.sum() > 20 and (a["flag"][off] == 0).all() and (b["flag"][off] == 0).all()
    np.testing.assert_array_equal(a["source.x"][off], np.float32(31.6))
    assert (src["label.id"][0, 32] == 2) and kt.fits_label(src["label.id"], b["source.x"], b["source.y"],
                                                           b["label.id"], off)[off].all()
    np.testing.assert_array_equal(b["source.x"][off], np.nextafter(np.float32(31.5), np.float32(0)))
    np.testing.assert_allclose(b.rgb()[off], lookup(src.rgb(), b["source.x"], b["source.y"], filter="bilinear")[off]
                               + np.stack([b[f"correction.{c}"] for c in "RGB"], -1)[off], atol=1e-6)
    for c in ("source.x", "source.y", "patch.id", "flag", "R"):
        np.testing.assert_array_equal(b[c][~off], a[c][~off])


def test_camera_move_stores_no_reproject_entry_and_a_rerun_recomputes_only_what_it_must(tmp_path):
    """graphs/camera_move.yaml at 64², frames 1-3: Reproject's plates are not stored (its frame's
    Resynthesize is their one reader); an edit of a late node recomputes that node alone; a
    final frame lost from the cache (or forced) is computed again through Reproject, bit for bit."""
    import json
    from pathlib import Path

    from proxyshade.graph.graph import Graph

    graph = Path(__file__).resolve().parents[2] / "graphs" / "camera_move.yaml"
    cache = tmp_path / "cache"

    def load(*sets):
        return Graph.load(graph, cache=cache, overrides=["proxy.resolution=[64,64]", "guide.size=32", "guide.start=16",
                                                         *sets], variables={"out": str(tmp_path / "out")})

    def computed(r):
        return {(x.node, x.frame) for x in r.runs if x.status == "computed"}

    def finals():
        g = load()
        return {f: {c: g.value("final", f)[c].tobytes() for c in g.value("final", f).names()} for f in (1, 2, 3)}

    r = load().run([1, 2, 3])
    assert {("reproject", f) for f in (1, 2, 3)} <= computed(r)
    records = [json.loads(p.read_text()) for p in cache.glob("??/*.json")]
    stored = {(rec["node"], rec["frame"]) for rec in records if not rec.get("sink")}
    assert {("final", f) for f in (1, 2, 3)} | {("cd", f) for f in (1, 2, 3)} <= stored
    assert not any(n == "reproject" for n, _ in stored)
    before = finals()
    assert not load().run([1, 2, 3]).computed  # all cache: Reproject is not needed
    # an edit of a late node: that node alone
    assert computed(load("flags.exposure=1").run([1, 2, 3])) == {("flags", f) for f in (1, 2, 3)}
    # final@2's entry lost: final@2 again, from Reproject computed again (final@3 is still stored)
    (entry,) = [p for p in cache.glob("??/*.json")
                if (rec := json.loads(p.read_text())).get("node") == "final" and rec.get("frame") == 2]
    entry.unlink()
    entry.with_suffix(".exr").unlink()
    assert computed(load().run([1, 2, 3])) == {("reproject", 2), ("final", 2)}
    assert finals() == before
    # forced: every final frame again, each from its Reproject, the same bits
    assert {("reproject", 2), ("reproject", 3), ("final", 3)} <= computed(load().run([1, 2, 3], force=("final",)))
    assert finals() == before
