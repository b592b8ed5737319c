"""The edit layer: changed regions, and the guide updated on a window around them."""
from types import SimpleNamespace

import numpy as np

from proxyshade.graph.plate import Plate
from proxyshade.synthesis.edit import changed_region, update_guide
from proxyshade.synthesis.guide import synthesize_guide
from proxyshade.synthesis.params import Guidance
from tests.nodes import _synthesis as T


def test_changed_region_is_the_dilated_difference():
    a = Plate({"label.id": np.zeros((32, 32), np.uint32), "Z": np.full((32, 32), np.inf, np.float32)})
    lab = a["label.id"].copy()
    lab[10, 12] = 3
    z = a["Z"].copy()
    z[20, 5] = 1.0
    b = Plate({"label.id": lab, "Z": z})
    r = changed_region({"p": a}, {"p": b}, {"p": ("label.id",)}, 2)
    assert r.sum() == 25 and r[8:13, 10:15].all()
    r = changed_region({"p": a}, {"p": b}, {"p": ("label.id", "Z")}, 0)
    assert r.sum() == 2 and r[10, 12] and r[20, 5]  # inf == inf: unchanged
    assert not changed_region({"p": a}, {"p": a}, {"p": ("label.id", "Z")}, 3).any()
    # an input of another size (the source) that changed at all: recompute whole
    s0 = Plate({"label.id": np.zeros((8, 8), np.uint32)})
    s1 = Plate({"label.id": np.ones((8, 8), np.uint32)})
    assert changed_region({"p": a, "s": s0}, {"p": b, "s": s1}, {"p": ("label.id",), "s": ("label.id",)}, 1) is None
    assert changed_region({"p": a, "s": s0}, {"p": b, "s": s0}, {"p": ("label.id",), "s": ("label.id",)}, 0).sum() == 1


def painted(rows, cols):
    """renoir's 512² guide and the same proxy with water painted into ``rows, cols``:
    (source, proxy, parameters, the guide before, the edited proxy, water's id)."""
    src = T.source("renoir")
    proxy = T.guide("renoir", (512, 512))
    gp = SimpleNamespace(**dict(vars(Guidance.defaults()), size=128, start=32, seed=2))
    prev, _ = synthesize_guide(proxy, src, gp)
    lab = proxy["label.id"].copy()
    water = int(next(t["id"] for t in src.meta["labels"] if t["name"] == "water"))
    lab[rows, cols] = water
    return src, proxy, gp, prev, proxy.with_channels({"label.id": lab}), water


def test_a_masked_guide_synthesis_with_nothing_active_is_the_last_guide():
    """``synthesize_guide(previous=, active=)`` with no active pixel reads the last guide's
    state back (source positions to exemplar coordinates, block by block) and leaves it: the
    last guide, bit for bit."""
    src, proxy, gp, prev, _, _ = painted(slice(0, 0), slice(0, 0))
    out, _ = synthesize_guide(proxy, src, gp, previous=prev, active=np.zeros(proxy["label.id"].shape, bool))
    for c in ("label.id", "source.x", "source.y"):
        assert np.array_equal(out[c], prev[c]), c


def test_update_guide_synthesizes_a_window_and_keeps_the_rest():
    src, proxy, gp, prev, edited, water = painted(slice(300, 340), slice(200, 260))  # a pond
    region = changed_region({"proxy": proxy}, {"proxy": edited}, {"proxy": ("label.id",)}, 16)
    out, info = update_guide(prev, region, edited, src, gp, context=32)
    assert not info["whole"] and info["window_pixels"] < 0.3 * region.size
    for c in ("label.id", "source.x", "source.y"):
        assert np.array_equal(out[c][~region], prev[c][~region])
    # inside, the pond is there about as well as a whole synthesis of the edited proxy puts it
    whole, _ = synthesize_guide(edited, src, gp)
    pond = np.zeros(region.shape, bool)
    pond[300:340, 200:260] = True
    assert (out["label.id"][pond] == water).mean() > 0.8
    assert (out["label.id"][pond] == water).mean() >= (whole["label.id"][pond] == water).mean() - 0.1
    # the correction is masked to the region with the last guide as context: away from the pond the
    # region keeps its labels and many of its source positions (about half on this guide; a fresh
    # synthesis of the window, as before the masked correction, kept none)
    far = region & ~changed_region({"p": proxy}, {"p": edited}, {"p": ("label.id",)}, 6)
    kept = (out["source.x"][far] == prev["source.x"][far]) & (out["source.y"][far] == prev["source.y"][far])
    assert kept.mean() > 0.3 and (out["label.id"][far] == prev["label.id"][far]).mean() > 0.9


def test_a_window_off_the_synthesis_grid_is_synthesized_afresh_and_pasted_inside_the_region():
    """No context and a region exactly as long as its window (128 rows from row 301, off
    the guide's 4 px synthesis grid): the window cannot be placed on the grid and still
    hold the region, so it is synthesized without the last guide; the labels still follow
    the edit inside the region and nothing outside it changes."""
    src, proxy, gp, prev, edited, water = painted(slice(301, 429), slice(201, 261))
    region = changed_region({"proxy": proxy}, {"proxy": edited}, {"proxy": ("label.id",)}, 0)
    out, info = update_guide(prev, region, edited, src, gp, context=0)
    assert info["fresh"] >= 1 and not info["whole"]
    for c in ("label.id", "source.x", "source.y"):
        assert np.array_equal(out[c][~region], prev[c][~region])
    assert (out["label.id"][region] == water).mean() > 0.85


def test_a_band_across_the_frame_is_synthesized_on_a_band_not_the_whole_frame():
    """A shoreline moved across the whole width: the window is the frame's width but only
    the band's height, synthesized at the frame's magnification."""
    src, proxy, gp, prev, edited, water = painted(slice(300, 316), slice(4, 508))  # a band across the frame
    region = changed_region({"proxy": proxy}, {"proxy": edited}, {"proxy": ("label.id",)}, 8)
    out, info = update_guide(prev, region, edited, src, gp, context=16)
    assert not info["whole"] and info["windows"][0][0] == 512 and info["windows"][0][1] < 128
    for c in ("label.id", "source.x", "source.y"):
        assert np.array_equal(out[c][~region], prev[c][~region])
    band = np.zeros(region.shape, bool)
    band[302:314, 8:504] = True
    assert (out["label.id"][band] == water).mean() > 0.8


def test_the_synthesis_window_holds_the_region_and_its_context_on_the_coarsest_grid():
    from proxyshade.synthesis.resynthesis import synthesis_window

    flagged = np.zeros((256, 320), bool)
    flagged[100:130, 40:90] = True
    r0, r1, c0, c1 = synthesis_window(flagged, 4, 3, margin=20)
    assert (r0, c0) == (80, 16) and (r1, c1) == (160, 112)  # box ± 20, out to multiples of 4 x 2^2
    assert synthesis_window(flagged, 4, 3, margin=200) is None  # most of the frame: the frame itself


def test_a_windowed_resynthesis_keeps_every_other_pixel_and_numbers_new_patches_above_the_frames():
    from types import SimpleNamespace

    from proxyshade.nodes.resynthesize import Resynthesize
    from proxyshade.synthesis.resynthesis import resynthesize
    from tests.nodes import _temporal as TT

    rp = TT.run_move("lake", [1, 2], size=128)[1]["reproject"]
    flag = np.zeros(rp.shape, np.uint32)
    flag[60:80, 30:60] = 1  # a block to redo, far from the frame's edges
    img = rp.with_channels({"flag": flag})
    p = SimpleNamespace(**Resynthesize.validate_params({"seed": 1}))
    out = resynthesize(img, TT.source("renoir"), p, 2, window=16)
    assert out.meta["resynthesis"]["window"][0] < 128  # a window, not the frame
    keep = flag == 0
    for c in ("R", "G", "B", "source.x", "source.y", "patch.id"):
        assert np.array_equal(out[c][keep], img[c][keep]), c
    assert (out["patch.id"][~keep] > img["patch.id"].max()).all()


def test_the_colour_similarity_sets_are_found_again_for_a_source_read_back(monkeypatch):
    """Each re-run of an edit loop reads the source back from the cache (new arrays, same
    content): the exemplar's similarity sets are not searched again."""
    from types import SimpleNamespace

    from proxyshade.nodes.resynthesize import Resynthesize
    from proxyshade.graph.memo import Memo, RunMemo
    from proxyshade.synthesis import resynthesis as RS
    from tests.nodes import _temporal as TT

    rp = TT.run_move("lake", [1, 2], size=128)[1]["reproject"]
    flag = np.zeros(rp.shape, np.uint32)
    flag[60:80, 30:60] = 1
    img = rp.with_channels({"flag": flag})
    p = SimpleNamespace(**Resynthesize.validate_params({"seed": 3}))
    src = TT.source("renoir")
    memo = RunMemo(Memo())  # the engine's (graph.memo): kept by content, not by the arrays
    first = RS.resynthesize(img, src, p, 2, memo=memo)
    searched = []
    monkeypatch.setattr(RS, "similarity_sets", lambda *a, **k: searched.append(1))
    again = Plate({c: src[c].copy() for c in src.names()}, dict(src.meta))
    out = RS.resynthesize(img, again, p, 2, memo=memo)
    assert not searched
    assert all(np.array_equal(out[c], first[c]) for c in ("R", "G", "B", "source.x", "source.y", "patch.id"))


def test_changed_region_matches_numpy_on_random_plates():
    """The one-pass difference (``kernels.edit.mark_differences``) against numpy's: NaN equal
    to NaN, float16 channels too, several channels and inputs of one grid, the dilation of
    the box."""
    from proxyshade.kernels.temporal import dilate

    rng = np.random.default_rng(5)
    for trial in range(6):
        h, w = rng.integers(5, 40, 2)
        z0 = rng.random((h, w)).astype(np.float32)
        z0[rng.random((h, w)) < 0.2] = np.nan
        z1 = z0.copy()
        k = rng.random((h, w)) < 0.05 * trial
        z1[k] = rng.choice([np.nan, 0.5, np.inf], k.sum()).astype(np.float32)
        l0 = rng.integers(0, 4, (h, w)).astype(np.uint32)
        l1 = np.where(rng.random((h, w)) < 0.03, 7, l0).astype(np.uint32)
        g0 = rng.integers(0, 3, (h, w)).astype(np.uint32)
        g1 = np.where(rng.random((h, w)) < 0.02, 9, g0).astype(np.uint32)
        n0 = rng.random((h, w)).astype(np.float16)  # a half channel (N.X in a plate), one value changed
        n1 = n0.copy()
        n1[trial % h, trial % w] += np.float16(0.25)
        a, b = Plate({"label.id": l0, "Z": z0, "N.X": n0}), Plate({"label.id": l1, "Z": z1, "N.X": n1})
        ga, gb = Plate({"label.id": g0}), Plate({"label.id": g1})
        ref = (l0 != l1) | ((z0 != z1) & ~(np.isnan(z0) & np.isnan(z1))) | (g0 != g1) | (n0 != n1)
        for radius in (0, 1, 3):
            got = changed_region({"p": a, "g": ga}, {"p": b, "g": gb},
                                 {"p": ("label.id", "Z", "N.X"), "g": ("label.id",)}, radius)
            want = dilate(ref, radius) if radius else ref
            assert np.array_equal(got, want), (trial, radius)


def test_a_depth_update_gives_the_numbers_of_the_frames_unprojection():
    """``depth_plate`` on a region: outside it the last result's arrays, inside the window's
    jump flooding with the frame's unprojection (``reproject.unproject`` on the whole frame,
    as before the region path wrote the region's pixels only) and the followed channels of
    the pixel each depth came from."""
    from pathlib import Path

    from proxyshade.graph.testing import run_node
    from proxyshade.io.usd import CameraInfo
    from proxyshade.kernels.reproject import intrinsics, unproject
    from proxyshade.synthesis.depth import FOLLOW, box, depth_plate
    from tests.kernels.test_jfa import extend_depth

    root = Path(__file__).resolve().parents[2]
    src = run_node("SourceRead", {"table": "samples/renoir/source.yaml"}, graph_dir=root)
    proxy = run_node("ProxyRender", {"scene": "samples/scenes/lake.usda", "resolution": [128, 128]}, {"source": src},
                     graph_dir=root)
    rng = np.random.default_rng(2)
    lab = proxy["label.id"].copy()
    g0 = proxy.with_channels({"label.id": lab})
    prev = depth_plate(proxy, g0, penalty=1024.0)
    lab2 = lab.copy()
    lab2[60:70, 40:52] = lab[75, 10]  # a block relabelled
    guide = proxy.with_channels({"label.id": lab2})
    region = np.zeros(lab.shape, bool)
    region[56:74, 36:56] = True
    region[30:100, 20:110] |= rng.random((70, 90)) < 0.02  # scattered pixels too (the window inside the frame)
    out = depth_plate(proxy, guide, penalty=1024.0, region=region, previous=prev, margin=8)
    r0, r1, c0, c1 = box(region, 8)
    assert r0 > 0 and c0 > 0 and r1 < 128 and c1 < 128
    win = (slice(r0, r1), slice(c0, c1))
    ext, s = extend_depth(proxy["label.id"][win], lab2[win], np.ascontiguousarray(proxy["Z"][win]), penalty=1024.0)
    H, W = lab.shape
    s = np.where(s >= 0, (r0 + s // (c1 - c0)) * W + c0 + s % (c1 - c0), -1)
    zf = np.full((H, W), np.inf, np.float32)
    zf[win] = ext
    cam = CameraInfo.from_meta(proxy.meta["camera"])
    P = unproject(zf, np.ascontiguousarray(cam.camera_to_world, np.float64), intrinsics(cam))
    want = {"Z": zf, "depth.src": np.zeros((H, W), np.uint32), **{f"P.{a}": P[..., k] for k, a in enumerate("XYZ")}}
    want["depth.src"][win] = (s + 1).astype(np.uint32)
    for name in FOLLOW:
        if name in proxy:
            a = proxy[name]
            want[name] = a.copy()
            want[name][win] = np.where(s >= 0, a.reshape(-1)[np.maximum(s, 0)], a[win])
    for c, v in want.items():
        assert out[c].dtype == prev[c].dtype, c
        assert np.array_equal(out[c][~region].view(np.uint32), prev[c][~region].view(np.uint32)), c
        assert np.array_equal(out[c][region].view(np.uint32), v[region].astype(prev[c].dtype).view(np.uint32)), c
    # the whole frame (no region): the same written-out reference over the frame
    whole = depth_plate(proxy, guide, penalty=1024.0)
    ext, s = extend_depth(proxy["label.id"], lab2, np.ascontiguousarray(proxy["Z"]), penalty=1024.0)
    P = unproject(ext, np.ascontiguousarray(cam.camera_to_world, np.float64), intrinsics(cam))
    want = {"Z": ext, "depth.src": (s + 1).astype(np.uint32), **{f"P.{a}": P[..., k] for k, a in enumerate("XYZ")}}
    for name in FOLLOW:
        if name in proxy:
            want[name] = np.where(s >= 0, proxy[name].reshape(-1)[np.maximum(s, 0)], proxy[name])
    for c, v in want.items():
        assert np.array_equal(whole[c].view(np.uint32), v.astype(prev[c].dtype).view(np.uint32)), c


def test_a_source_read_back_finds_the_last_runs_results_and_another_content_does_not(monkeypatch):
    """The engine reads the source back from its cache at each run (new arrays, same content):
    the guide's per-source results (similarity sets, exemplar levels) are found in the memo,
    keyed by content, and not searched again; another content is not mistaken for it."""
    from proxyshade.graph.memo import Memo, RunMemo
    from proxyshade.kernels import guide as kg

    src, proxy, gp, prev, edited, water = painted(slice(300, 320), slice(200, 230))
    region = changed_region({"proxy": proxy}, {"proxy": edited}, {"proxy": ("label.id",)}, 8)
    memo = RunMemo(Memo())
    first, _ = update_guide(prev, region, edited, src, gp, context=16, memo=memo)
    again = Plate({c: src[c].copy() for c in src.names()}, dict(src.meta))
    searched = []
    real = kg.similarity_sets
    monkeypatch.setattr(kg, "similarity_sets", lambda *a, **k: searched.append(1) or real(*a, **k))
    out, _ = update_guide(prev, region, edited, again, gp, context=16, memo=memo)
    assert not searched and memo.hits > 0
    assert all(np.array_equal(out[c], first[c]) for c in ("label.id", "source.x", "source.y"))
    lab = again["label.id"].copy()
    lab[:8, :8] = next(int(i) for i in np.unique(lab) if i != lab[0, 0])  # a corner of another label
    other = again.with_channels({"label.id": lab})
    hits = memo.hits
    update_guide(prev, region, edited, other, gp, context=16, memo=memo)
    assert searched and memo.hits == hits  # another label map: nothing of the source's is found
