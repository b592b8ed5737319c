"""Temporal coherence of the synthesis state (Bonneel et al. 2010, §6): the first
frame's grid carried to later frames (§6.1, ConsistentDepth) and the previous frame's
coordinate map carried into this one, with its flags (§6.2, Reproject): distortion of the
carried map, re-anchoring of distorted patches, continuation of fragments and
disocclusions, cleaning of the flags.

Reference: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010.

Flags (uint32 ``flag``): 0 kept, 1 disoccluded, 2 newly occluded, 3 distorted
(resynthesized), 4 re-anchored (the new map kept; only the Poisson solve is redone).
``CORRECTION`` is the carried Poisson correction: the colour minus the source through
the map. Kernels: ``proxyshade.kernels.reproject``, ``proxyshade.kernels.temporal``.
"""
from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np

from proxyshade.errors import NodeInputError
from proxyshade.plate import Plate
from proxyshade.io.camera import CameraInfo
from proxyshade.io.colourlib import srgb_encoding_table
from proxyshade.kernels import reproject as kr
from proxyshade.kernels import temporal as kt
from proxyshade.kernels.layout import LUMA
from proxyshade.kernels.lookup import FLAT2, FLAT4, lookup, padded_rgb
from proxyshade.kernels.random import uniform_field
from proxyshade.synthesis.grain import source_colours
from proxyshade.synthesis.memo import kept

from proxyshade.synthesis.state import CATEGORY, CATEGORY_C, CORRECTION, FLAG, GEOMETRY, STATE  # noqa: F401


FLAG_CODES = kt.FlagCodes(np.uint32(FLAG["disoccluded"]), np.uint32(FLAG["newly_occluded"]),
                          np.uint32(FLAG["distorted"]), np.uint32(FLAG["reanchored"]))


def patch_thresholds(patch: np.ndarray, threshold: float, spread: float, seed: int) -> np.ndarray:
    """Each pixel's distortion threshold: its patch's, uniform in [(1 − spread)·threshold,
    threshold], hashed from the patch id and the seed (the same for the patch's whole
    life, so it is flagged once, whole, when its deviation crosses it)."""
    if spread <= 0:
        return np.full(patch.shape, threshold, np.float32)
    u = uniform_field(seed, np.ascontiguousarray(patch, np.uint32))
    return (threshold * (1.0 - spread * u)).astype(np.float32, copy=False)


def reanchor_distorted(have, patch, D, sx, sy, scale, threshold, spread, seed, magnify=0.0, lab=None):
    """Patches whose mean map deviation crosses their threshold (``patch_thresholds``),
    whole, and their maps re-anchored: a patch's map becomes the plain copy (a
    translation at the synthesis scale) through its mean position and mean source
    position, so its texture stays where it was near its middle and the distortion is
    gone. With ``magnify`` > 0 (and ``lab``) also the patches whose mean smaller singular
    value of J / scale (``kt.map_stretch_patches``) lies below 1 − their threshold
    (``patch_thresholds`` of ``magnify``): a map that magnifies the source blurs it on
    screen long before ‖J − I‖ reaches ``threshold``. Returns (distorted (H, W) bool, sx, sy)."""
    if not have.any():
        return np.zeros(have.shape, bool), sx, sy
    ids = np.ascontiguousarray(patch, np.uint32)  # the kernels index by it as it is (no int64 copy)
    n = int(ids.max()) + 1
    have_c = np.ascontiguousarray(have, np.bool_)
    mean_d = kt.patch_mean(have_c, ids, np.ascontiguousarray(D, np.float32), n)
    ids_all = np.arange(n, dtype=np.uint32)[None]
    bad = mean_d > patch_thresholds(ids_all, threshold, spread, seed)[0]
    if magnify > 0 and lab is not None:
        S = kt.map_stretch_patches(np.ascontiguousarray(sx, np.float32), np.ascontiguousarray(sy, np.float32), have_c,
                                   ids, np.ascontiguousarray(lab, np.uint32), float(scale))
        S[np.asarray(lab) == NO_MAGNIFY] = 1.0  # labels left out (carry's magnify_gate): no magnification
        mean_s = kt.patch_mean(have_c, ids, S, n)
        bad |= (1.0 - mean_s) > patch_thresholds(ids_all, magnify, spread, seed)[0]
    bad[0] = False  # patch 0: no patch
    distorted = kt.in_ids(np.ascontiguousarray(have, np.bool_), ids, bad)
    if not distorted.any():
        return distorted, sx, sy
    sx = np.array(sx, np.float32)
    sy = np.array(sy, np.float32)
    kt.reanchor(distorted, ids, sx, sy, float(scale), n)  # the means in scan order, as np.bincount sums
    return distorted, sx, sy


def patch_width(have: np.ndarray, ids: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(area, width) of each patch id < n over the ``have`` pixels: width = 2 × area /
    perimeter (edges to another patch, an unkept pixel or the image border): a strip's
    width, half a square's side."""
    ids = np.ascontiguousarray(ids)
    if ids.dtype not in (np.uint32, np.int64):
        ids = ids.astype(np.int64)
    area, per = kt.area_perimeter(np.ascontiguousarray(have, np.bool_), ids, int(n))
    return area, 2.0 * area / np.maximum(per.astype(np.float64), 1.0)


def absorb_fragments(have, patch, lab, sx, sy, scale, min_area, src_lab, min_width=0.0):
    """Patches smaller than ``min_area`` pixels or thinner than ``min_width`` (slivers left
    by continuation, patches that shrank or were sheared thin on screen) continue the
    neighbouring patch they touch most, with its
    translation at the contact, where the continued copy stays on their label inside the
    source: one copy where there were two seams. Returns (absorbed (H, W) bool, sx, sy,
    patch)."""
    none = np.zeros(have.shape, bool)
    if min_area <= 1:
        return none, sx, sy, patch
    ids = np.ascontiguousarray(patch, np.uint32)  # indexed as it is (no int64 copy of the frame)
    n = int(ids.max()) + 1
    area, width = patch_width(have, ids, n)
    frag = (area < min_area) | (width < min_width)
    small = kt.in_ids(np.ascontiguousarray(have, np.bool_), ids, frag & (np.arange(n) != 0))  # not patch 0
    if not small.any():
        return none, sx, sy, patch
    H, W = have.shape
    ii, jj = np.divmod(np.flatnonzero(small), W)  # np.nonzero's, from one flat index pass
    pairs = []
    for di, dj in ((0, 1), (0, -1), (1, 0), (-1, 0)):
        a, b = ii + di, jj + dj
        inside = (a >= 0) & (a < H) & (b >= 0) & (b < W)
        a, b, i0, j0 = a[inside], b[inside], ii[inside], jj[inside]
        ok = have[a, b] & (lab[a, b] == lab[i0, j0]) & (ids[a, b] != ids[i0, j0]) & ~frag[ids[a, b]]
        pairs.append(np.stack([ids[i0[ok], j0[ok]].astype(np.int64), ids[a[ok], b[ok]].astype(np.int64), a[ok], b[ok]],
                              1))
    pairs = np.concatenate(pairs)
    if not len(pairs):
        return none, sx, sy, patch
    # per small patch: the neighbour with the most contacts (ties: the lower id), and its
    # translation at the first contact pixel in scan order
    order = np.lexsort((pairs[:, 2] * W + pairs[:, 3], pairs[:, 1], pairs[:, 0]))
    pairs = pairs[order]
    key = pairs[:, 0] * n + pairs[:, 1]
    uk, first, count = np.unique(key, return_index=True, return_counts=True)
    small_id, target = uk // n, uk % n
    best = np.lexsort((target, -count, small_id))
    keep = np.ones(len(best), bool)
    keep[1:] = small_id[best][1:] != small_id[best][:-1]
    best = best[keep]
    src = pairs[first[best]]
    ox = np.full(n, np.nan)
    oy = np.full(n, np.nan)
    tg = np.zeros(n, np.int64)
    ox[src[:, 0]] = sx[src[:, 2], src[:, 3]] - src[:, 3] * scale
    oy[src[:, 0]] = sy[src[:, 2], src[:, 3]] - src[:, 2] * scale
    tg[src[:, 0]] = src[:, 1]
    pid = ids[ii, jj].astype(np.int64)
    go = ~np.isnan(ox[pid])
    ii, jj, pid = ii[go], jj[go], pid[go]
    nx = (ox[pid] + jj * scale).astype(np.float32)
    ny = (oy[pid] + ii * scale).astype(np.float32)
    # the moved pixels only (kt.fits_label's test on their list)
    fits = kt.fits_label(np.ascontiguousarray(src_lab, np.uint32), nx[None], ny[None],
                         np.ascontiguousarray(lab[ii, jj], np.uint32)[None], np.ones((1, len(ii)), np.bool_))[0]
    # all or nothing per patch: a half-absorbed fragment would leave a seam inside it
    bad = np.bincount(pid, weights=~fits, minlength=n) > 0
    ok = ~bad[pid]
    ia, ja = ii[ok], jj[ok]
    absorbed = np.zeros(have.shape, bool)
    absorbed[ia, ja] = True
    sx = np.array(sx, np.float32)
    sy = np.array(sy, np.float32)
    sx[ia, ja] = nx[ok]
    sy[ia, ja] = ny[ok]
    patch = patch.copy()
    patch[ia, ja] = tg[pid[ok]].astype(np.uint32)
    return absorbed, sx, sy, patch



class Frame0:
    """What the first frame contributes to every later frame: inverse depth, grid corners,
    which pixels the frame-0 proxy hid (``occluded``) and which lay on it (``on_proxy``)."""

    def __init__(self, Z0, lab0, Zp0, cut_tol: float, tol: float):
        self.w0 = kr.inverse_depth(Z0)
        self.cw = kr.grid_corners(self.w0, np.ascontiguousarray(lab0, np.uint32), cut_tol)
        self.keep = np.isfinite(self.w0)
        if Zp0 is not None:
            wp0 = kr.inverse_depth(Zp0)
            self.occluded = wp0 > self.w0 * (1.0 + tol)  # the proxy was in front of the guide's surface
            self.on_proxy = np.abs(wp0 - self.w0) <= tol * np.maximum(wp0, self.w0)
        else:
            self.occluded = np.zeros(self.w0.shape, bool)
            self.on_proxy = np.ones(self.w0.shape, bool)


def frame0_grid(Z0: np.ndarray, lab0: np.ndarray, Zp0: np.ndarray | None, cut_tol: float, tol: float,
                memo=None) -> Frame0:
    """``Frame0`` of the first frame's plates. It depends on the first frame only: within one
    run every later frame passes the same plates, so it is kept in ``memo`` (``synthesis.memo``)
    instead of being rebuilt each frame."""
    return kept(memo, "temporal.frame0_grid", (Z0, lab0, Zp0, float(cut_tol), float(tol)),
                lambda: Frame0(Z0, lab0, Zp0, cut_tol, tol))


def camera_of(name: str, *plates) -> CameraInfo:
    """The camera in the first plate's metadata that has one (a ProxyRender's)."""
    for p in plates:
        if p is not None and isinstance(p.meta.get("camera"), dict):
            return CameraInfo.from_meta(p.meta["camera"])
    raise NodeInputError(f"input '{name}' has no camera in its metadata (meta['camera']); connect a plate derived "
                         "from ProxyRender (GuideSynth, DepthExtend and Magnify pass it on)")


def carry(cd: Plate, prev: Plate | None, first: Plate | None, source: Plate, p, *, frame: int, first_frame: int,
          note=lambda s: None, window: tuple[int, int, int, int] | None = None, memo=None) -> Plate:
    """The previous frame's synthesis state ``prev`` carried into the camera of ``cd``
    (this frame's ConsistentDepth), with its flags; at the first frame (no ``prev``) the
    ``first`` plate with no flags, or everything flagged without one. ``p``: the
    ``Carry`` parameters. See ``nodes.reproject`` for the channels.

    ``window`` (row0, row1, col0, col1): only that part of the frame is carried (a plate of
    its size; ``carry_update`` pastes it): pixels near the window's edge, patch-level
    decisions of patches it cuts and the camera-cut test see the window only."""
    offset = None
    if window is not None and prev is not None:
        r0, r1, c0, c1 = window
        cd = Plate({c: np.ascontiguousarray(cd[c][r0:r1, c0:c1]) for c in cd.names()}, cd.meta)
        offset = np.array([0.0, 0.0, c0, r0])
    H, W = cd.shape
    cat = cd["category"] if "category" in cd else np.zeros((H, W), np.uint32)
    geo = {c: cd[c] for c in GEOMETRY if c in cd}
    geo["category"] = cat.astype(np.uint32, copy=False)
    if prev is None:
        return _first_frame(cd, first, geo, frame, first_frame, note)
    cam1 = camera_of("depth", cd)
    cam0 = camera_of("prev", prev)
    if (cam0.width, cam0.height) != (prev.width, prev.height):
        raise NodeInputError(f"prev's camera is {cam0.width}x{cam0.height}, the plate {prev.width}x{prev.height}")
    scale = float(prev.meta.get("synthesis", {}).get("scale", 1.0))
    tol = p.depth_tolerance
    w1 = kr.inverse_depth(cd["Z"])
    lab = np.ascontiguousarray(cd["label.id"], np.uint32)
    k1 = kr.intrinsics(cam1) if offset is None else kr.intrinsics(cam1) - offset  # the window's principal point
    u, v, q, ok = kr.transfer(w1, kr.relative_matrix(cam1, cam0), k1, kr.intrinsics(cam0), cam0.near)
    src_rgb = source_colours(source, prev.meta, memo)  # graded by the first frame's grain table, if any
    if p.colour == "map" and all(c in prev for c in CORRECTION):
        # carried by Resynthesize: no second read of the source (its planes as they are)
        planes = [np.ascontiguousarray(prev[c], np.float32) for c in CORRECTION]
    else:
        if p.colour == "map":
            prev_res = prev.rgb() - lookup(src_rgb, prev["source.x"], prev["source.y"], filter=p.filter)
        else:
            prev_res = prev.rgb()
        planes = [np.ascontiguousarray(prev_res[..., k], np.float32) for k in range(3)]
    prev_ext = prev["extension"].astype(np.float32, copy=False) if "extension" in prev else np.zeros(prev.shape, np.float32)
    land = kr.Landing(u, v, q, ok)
    state = kr.PrevState(kr.inverse_depth(prev["Z"]), np.ascontiguousarray(prev["label.id"], np.uint32),
                         np.ascontiguousarray(prev["patch.id"], np.uint32),
                         prev["source.x"].astype(np.float32, copy=False),
                         prev["source.y"].astype(np.float32, copy=False), *planes, prev_ext)
    sharpen = p.colour == "map" and p.correction_filter != "bilinear"
    table = FLAT4 if p.correction_filter == "flat4" else FLAT2
    a = table.shape[1] // 2
    uniform = kr.uniform_windows(state.patch, state.label, a - 1, a) if sharpen else np.zeros((0, 0), np.bool_)
    # the bilinear residual is not gathered where sharpen_residual reads it again (gather_prev_planes' sharp)
    valid, sx, sy, patch, res, ext = kr.gather_prev_planes(tuple(land), lab, tuple(state), tol, scale, uniform, a)
    if sharpen:
        # the correction's fine detail kept inside patches (bilinear would blur it away frame after frame)
        kr.sharpen_residual(tuple(land), valid, uniform, np.stack(planes, -1), table, res)
    if getattr(p, "anchor", False) and first is not None and first is not prev and "patch.id" in first:
        anchor_first_seams(cd, first, k1=k1, w1=w1, lab=lab, land=land, valid=valid, prev=state, tol=tol,
                           scale=scale, out=kr.Carried(sx, sy, patch, res, ext))
    # disoccluded pixels continue the patch of a kept neighbour of their label when the
    # continued source position still has that label: no new seam, nothing to redo
    have = valid
    filled = None
    src_lab = np.ascontiguousarray(source["label.id"], np.uint32)
    # continuation stops on the label's rare looks (continue_tail): a patch extruded past where the
    # synthesis placed it reads source pixels no match chose (clumps in the water, flecks in the sky);
    # re-anchored copies and absorbed fragments on them are resynthesized (below)
    cont_lab = typical_labels(source, p.continue_tail, memo) if p.continue_tail > 0 else src_lab
    if p.fill_radius > 0 and not valid.all():
        # in place: it writes only the unkept pixels and reads only kept ones (gather_prev's fresh arrays)
        carried = kr.Carried(sx, sy, patch, res, ext)
        sx, sy, patch, res, ext, filled = kr.fill_from_neighbours_into(
            ~valid, valid, lab, carried, radius=p.fill_radius, scale=scale, out=carried,
            src_lab=cont_lab if p.continue_tail > 0 and p.continue_other else NO_LABELS)
        # a patch continued frame after frame would extrude its borders into streaks:
        # past extend_frames the continued band is flood-filled afresh instead (ext counted up in place)
        filled, have = kt.continue_filled(filled, valid, ext, cont_lab, sx, sy, lab, float(p.extend_frames))
    D = kt.map_deviation_patches(sx, sy, np.ascontiguousarray(have, np.bool_), patch, lab, float(scale))
    magnify = float(getattr(p, "magnify_threshold", 0.0))
    mag_lab = lab
    if magnify > 0 and getattr(p, "magnify_gate", 0.0) > 0 and first is not None:
        # only on the labels whose gradient has fallen under magnify_gate x the first frame's (a magnified
        # texture blurs: a label whose gradient holds is left to its own re-anchoring)
        fallen = [k for k, r in gradient_ratios(prev, first, memo).items() if r < p.magnify_gate]
        mag_lab = np.where(np.isin(lab, np.asarray(fallen, np.uint32)), lab, NO_MAGNIFY).astype(np.uint32)
    distorted, sx, sy = reanchor_distorted(have, patch, D, sx, sy, scale, p.threshold, p.spread, p.seed,
                                           magnify, mag_lab)
    absorbed, sx, sy, patch = absorb_fragments(have, patch, lab, sx, sy, scale, p.min_patch_area, src_lab,
                                               p.min_patch_width)
    # raw flags in one pass (temporal.flag_reasons): re-anchored patches and absorbed fragments
    # (distorted where the re-anchored copy leaves its label); a kept pixel whose carried source
    # position has left its label ("stray": a patch growing on screen carries its map past its
    # label's border in the source, sky reading the cliff) no longer shows its label's texture:
    # resynthesized, however few there are (stray); disoccluded; newly occluded
    ratios = gradient_ratios(prev, first, memo) if p.creep_gate > 0 and first is not None else None
    rising = None if ratios is None else sorted(k for k, r in ratios.items() if r > p.creep_gate)
    if p.solve_continued and filled is not None:
        if rising is not None:  # only where the label's gradient rose
            filled = filled & np.isin(lab, np.asarray(rising, np.uint32))
        absorbed = absorbed | filled  # continued pixels: map kept, Poisson redone (flag 4)
    if p.snap_to_label:
        # a kept pixel carried up to half a source pixel off its label (the nearest previous pixel's translation
        # continued past a patch's edge at the label's border) reads the next label's pixel there: a fringe of
        # the mountain along the sky's silhouette that later frames carry inward; moved back onto its label
        kt.snap_to_label(src_lab, sx, sy, lab, np.ascontiguousarray(have & ~absorbed & ~distorted, np.bool_),
                         np.float32(STRAY_MARGIN))
    raw, stray = kt.flag_reasons(have=np.ascontiguousarray(have, np.bool_), absorbed=absorbed, distorted=distorted,
                                 src_lab=src_lab, sx=sx, sy=sy, lab=lab, margin=STRAY_MARGIN,
                                 cat=np.ascontiguousarray(cat, np.uint32), cat_c=np.uint32(CATEGORY_C),
                                 land=tuple(land), prev_lab=state.label, codes=tuple(FLAG_CODES))
    if p.stranded_fringe > 0:
        # a kept pixel that reads its label's fringe in the source (a source pixel next to another label: the sky
        # darkened by the mountain beside it) belongs at its label's border on screen; one left more than
        # stranded_fringe pixels inside its label (the silhouette moved on by parallax) is a dark fleck floating in
        # the sky: resynthesized, as a stray pixel (distorted even where clean_flags drops it as isolated)
        strand = stranded_pixels(source, sx, sy, lab, have & ~absorbed & ~distorted & (raw == 0),
                                 int(p.stranded_fringe), memo, float(getattr(p, "stranded_tail", 0.0)),
                                 float(getattr(p, "stranded_ratio", 0.0)))
        raw[strand] = FLAG["distorted"]
        stray |= strand
    if p.continue_tail > 0:
        # re-anchored copies and absorbed fragments extend a map too: on a rare look, resynthesized
        moved = (absorbed | distorted) & (raw == FLAG["reanchored"])
        if moved.any():
            rare = kt.fits_label(src_lab, sx, sy, lab, moved) & ~kt.fits_label(cont_lab, sx, sy, lab, moved)
            raw[rare] = FLAG["distorted"]
            stray |= rare  # distorted even where clean_flags drops it as isolated
    # clean_flags, then unflagged pixels with nothing to carry (dropped as isolated) disoccluded,
    # off their label distorted, and the counts per flag, in one pass
    flag, nflag = kt.clean_flags(raw, int(p.isolated_radius), int(p.min_neighbours), int(p.dilate),
                                 np.ascontiguousarray(have, np.bool_), stray, FLAG["disoccluded"],
                                 FLAG["newly_occluded"], FLAG["distorted"])
    share = float(flag.size - nflag[0]) / flag.size
    cut = share > p.cut_threshold
    if cut:
        note(f"camera cut: {100 * share:.1f}% of the frame flagged (> {100 * p.cut_threshold:.0f}%); "
             "full synthesis of this frame")
        flag[:] = FLAG["disoccluded"]
        nflag = np.bincount(flag.ravel(), minlength=max(FLAG.values()) + 1)
    # re-anchored patches keep their (new) map; their old Poisson correction no longer fits
    keep = (flag == 0) | (flag == FLAG["reanchored"])
    correct = p.colour == "map"
    rgb = lookup(src_rgb, sx, sy, filter=p.filter, mask=keep, padded=padded_colours(src_rgb, memo)
                 ) if correct else res
    R, G, B, sx, sy, patch, D, ext, *corr = kt.keep_carried(
        flag, FLAG["reanchored"], D.astype(np.float32, copy=False), ext, sx, sy, patch, rgb, res, correct)
    n = nflag / flag.size
    counts = {k: float(n[v]) for k, v in FLAG.items() if v}
    note(f"flagged {100 * share:.2f}%: " + ", ".join(f"{k} {100 * s:.2f}%" for k, s in counts.items()))
    ch = {"R": R, "G": G, "B": B, "source.x": sx, "source.y": sy, "patch.id": patch, "distortion": D,
          "extension": ext, "flag": flag}
    if correct:
        ch.update(zip(CORRECTION, corr))
    ch.update(geo)
    meta = _carried_meta(prev, cd)
    meta["temporal"] = dict(counts, flagged=float(flag.size - nflag[0]) / flag.size, cut=bool(cut), frame=int(frame),
                            filter=p.filter)
    if ratios is not None:
        meta["temporal"].update(gradient={str(k): round(r, 6) for k, r in ratios.items()}, rising=rising,
                                gate=float(p.creep_gate), first_gradient={str(k): g for k, g in
                                                                          first_gradients(first, memo).items()})
    return Plate(ch, meta)


def padded_colours(src_rgb: np.ndarray, memo=None) -> np.ndarray | None:
    """``lookup.padded_rgb`` of ``src_rgb`` (the colours ``source_colours`` gives), kept in
    ``memo`` for the frames of a run (the carry's source read pads the same colours every
    frame); None without a memo (``lookup`` pads them itself)."""
    if memo is None:
        return None
    return kept(memo, "temporal.padded_colours", (src_rgb,), lambda: padded_rgb(src_rgb), size=1)


STRAY_MARGIN = 0.5  # source pixels: a kept pixel off its label by more is resynthesized (flag_reasons' stray)
NO_MAGNIFY = np.uint32(0xFFFFFFFE)  # reanchor_distorted's label of pixels left out of the magnification test
NO_LABELS = np.zeros((0, 0), np.uint32)  # kr.fill_from_neighbours_into: any neighbour of the label
RARE = np.uint32(0xFFFFFFFF)  # typical_labels' id of a label's rare looks (no label has it)


def typical_labels(source: Plate, tail: float, memo=None) -> np.ndarray:
    """The source's ``label.id`` with each label's rare looks set to ``RARE``: its pixels
    whose linear luminance (Rec. 709 weights) lies in the label's lowest or highest ``tail``
    share (``np.quantile``, per label). A patch continued into a disocclusion reads source
    pixels beyond where the synthesis placed it; on these it would copy a look the label
    rarely has (a dark trunk in the vegetation, a rock in the water) that no neighbourhood
    match chose, so there the continuation stops and the pixel is resynthesized."""
    def compute():
        lab = np.ascontiguousarray(source["label.id"], np.uint32)
        lum = source.rgb().astype(np.float64) @ np.asarray(LUMA, np.float64)
        out = lab.copy()
        for k in np.unique(lab):
            m = lab == k
            lo, hi = np.quantile(lum[m], [tail, 1.0 - tail])
            out[m & ((lum < lo) | (lum > hi))] = RARE
        return out

    return kept(memo, "temporal.typical_labels", (source["R"], source["G"], source["B"], source["label.id"], tail),
                compute, size=1)


def source_fringe(source: Plate, memo=None) -> np.ndarray:
    """(Hs, Ws) bool: the source pixels with another label among their 8 neighbours (a label's
    fringe in the photo, where its look mixes with the next label's); kept in ``memo``."""
    def compute():
        from scipy import ndimage

        lab = np.asarray(source["label.id"])
        return ndimage.minimum_filter(lab, 3, mode="nearest") != ndimage.maximum_filter(lab, 3, mode="nearest")

    return kept(memo, "temporal.source_fringe", (source["label.id"],), compute, size=1)


def rare_fringe(source: Plate, tail: float, ratio: float = 0.0, memo=None) -> np.ndarray:
    """(Hs, Ws) bool: ``source_fringe``'s pixels that are also rare looks of their label
    (``typical_labels(source, tail)``: luminance in the label's lowest or highest ``tail``);
    with ``ratio`` > 0 only on the labels whose fringe pixels are rare at least ``ratio`` times
    as often as their other pixels (a fringe with a look of its own: a sky darkened by the
    mountain beside it, not a thin label that is its fringe's look throughout); kept in ``memo``."""
    def compute():
        fringe = source_fringe(source, memo)
        rare = typical_labels(source, tail, memo) == RARE
        out = fringe & rare
        if ratio > 0:
            lab = np.asarray(source["label.id"]).ravel()
            n = int(lab.max()) + 1
            fr = fringe.ravel()
            nf = np.bincount(lab[fr], minlength=n)
            ni = np.bincount(lab[~fr], minlength=n)
            rf = np.bincount(lab[out.ravel()], minlength=n)
            ri = np.bincount(lab[rare.ravel() & ~fr], minlength=n)
            # rf / nf >= ratio * ri / ni, without dividing (a label with no inside, all fringe: left out)
            on = (nf > 0) & (rf * np.maximum(ni, 1) >= ratio * ri * nf) & (ni > 0)
            out &= on[np.asarray(source["label.id"])]
        return out

    return kept(memo, "temporal.rare_fringe", (source["R"], source["G"], source["B"], source["label.id"], tail, ratio),
                compute, size=1)


def stranded_pixels(source: Plate, sx: np.ndarray, sy: np.ndarray, lab: np.ndarray, mask: np.ndarray, d: int,
                    memo=None, tail: float = 0.0, ratio: float = 0.0) -> np.ndarray:
    """(H, W) bool: the ``mask`` pixels whose nearest source pixel (``lookup``'s, rounded) is on
    their label's fringe in the source (``source_fringe``) while no pixel of another label lies
    within ``d`` pixels of them on screen (a (2d + 1)² window): a fringe look stranded inside
    its label. With ``tail`` > 0 only fringe pixels that are rare looks of their label, and with
    ``ratio`` > 0 only on the labels whose fringe has a look of its own (``rare_fringe``): a
    fringe pixel that looks like the rest of its label is no fleck."""
    from scipy import ndimage

    if d <= 0 or not mask.any():
        return np.zeros(mask.shape, bool)
    fringe = source_fringe(source, memo) if tail <= 0 else rare_fringe(source, tail, ratio, memo)
    inner = ndimage.minimum_filter(lab, 2 * d + 1, mode="nearest") == ndimage.maximum_filter(lab, 2 * d + 1,
                                                                                            mode="nearest")
    return mask & inner & lookup(fringe, sx, sy)  # a bool image is read at the nearest pixel


def gradient_sums(rgb: np.ndarray, label: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``kt.label_gradients`` of a frame's linear colours: per label id, (sum, count)."""
    lab = np.ascontiguousarray(label, np.uint32)
    return kt.label_gradients(np.ascontiguousarray(rgb, np.float32), lab, int(lab.max()) + 1,
                              srgb_encoding_table(kt.ENCODE_STEPS))


def first_gradients(first: Plate, memo=None) -> dict[int, float]:
    """Per label id with at least 64 interior pixels: the first frame's mean display-luma
    gradient (``gradient_ratios``' denominator; kept in ``memo``)."""
    s1, c1 = kept(memo, "temporal.first_gradients", (first["R"], first["G"], first["B"], first["label.id"]),
                  lambda: gradient_sums(first.rgb(), first["label.id"]), size=1)
    return {k: float(s1[k] / c1[k]) for k in range(len(s1)) if c1[k] >= 64 and s1[k] > 0}


def gradient_ratios(prev: Plate, first: Plate, memo=None) -> dict[int, float]:
    """Per label id: the mean display-luma gradient magnitude of ``prev`` (the previous final
    frame) over the first frame's (``kt.label_gradients``, bench_shot's grad): above 1 the
    label's texture has crept (seams made and carried, docs/temporal.md); labels with fewer
    than 64 interior pixels in either frame are left out. The first frame's sums are kept
    in ``memo``."""
    return label_ratios(prev.rgb(), prev["label.id"], first_gradients(first, memo))


def label_ratios(rgb: np.ndarray, label: np.ndarray, first: dict[int, float]) -> dict[int, float]:
    """Per label id of ``first`` (``first_gradients``) with at least 64 interior pixels here:
    the frame's mean display-luma gradient over the first frame's."""
    sn, cn = gradient_sums(rgb, label)
    return {k: float((sn[k] / cn[k]) / g) for k, g in first.items() if k < len(sn) and cn[k] >= 64}


def rising_after(rgb: np.ndarray, label: np.ndarray, temporal: dict) -> list[int]:
    """The labels that ``rgb`` (a frame's result) shows above Reproject's ``creep_gate`` over
    the first frame's gradient (``meta["temporal"]``: ``gate``, ``first_gradient``) and that
    Reproject did not find rising from the previous frame: the gate on this frame's result,
    a frame earlier than the previous frame's (Resynthesize's ``gate_result``)."""
    gate = float(temporal.get("gate") or 0.0)
    first = {int(k): float(v) for k, v in (temporal.get("first_gradient") or {}).items()}
    if gate <= 0 or not first:
        return []
    done = set(temporal.get("rising") or ())
    return sorted(k for k, r in label_ratios(rgb, label, first).items() if r > gate and k not in done)


def anchor_first_seams(cd: Plate, first: Plate, *, k1: np.ndarray, w1: np.ndarray, lab: np.ndarray,
                       land: kr.Landing, valid: np.ndarray, prev: kr.PrevState, tol: float, scale: float,
                       out: kr.Carried) -> None:
    """``kr.anchor_seams`` in place on ``gather_prev``'s outputs ``out``: seams between patches
    of the first frame's synthesis (``first``) stay where the first frame has them instead of
    being rounded anew from the previous frame's each frame (docs/temporal.md, "Seams
    anchored to the first frame"). ``k1``, ``w1``, ``lab``: this frame's intrinsics (of the
    window), inverse depth and labels; ``land``, ``valid``, ``prev``: ``gather_prev``'s."""
    if not isinstance(first.meta.get("camera"), dict):
        return
    camf = camera_of("first", first)
    if (camf.width, camf.height) != (first.width, first.height):
        return
    uf, vf, qf, okf = kr.transfer(w1, kr.relative_matrix(camera_of("depth", cd), camf), k1, kr.intrinsics(camf),
                                  camf.near)
    wf = kr.inverse_depth(first["Z"]) if "Z" in first else np.zeros(first.shape, np.float64)
    if "Z" not in first:
        qf = np.zeros_like(qf)  # no depth: the label alone decides
    fp = kr.FirstPositions(*kr.first_positions(
        uf, vf, qf, okf, lab=lab, first_w=wf, first_lab=np.ascontiguousarray(first["label.id"], np.uint32),
        first_patch=np.ascontiguousarray(first["patch.id"], np.uint32),
        first_sx=first["source.x"].astype(np.float32, copy=False),
        first_sy=first["source.y"].astype(np.float32, copy=False), tol=tol, scale=scale))
    kr.anchor_seams(tuple(land), valid, lab, tuple(prev), tuple(fp), tol, scale, 0.01 * max(scale, 1.0), tuple(out))


def _carried_meta(state: Plate, cd: Plate) -> dict:
    meta = dict(state.meta)
    for k in ("camera", "up_axis", "objects", "scene", "background"):
        if k in cd.meta:
            meta[k] = cd.meta[k]
    return meta


def _first_frame(cd: Plate, first: Plate | None, geo: dict, frame: int, first_frame: int, note) -> Plate:
    H, W = cd.shape
    if first is None:
        if frame != first_frame:
            note("no previous frame and no 'first' plate: full synthesis of this frame")
        z = np.zeros((H, W), np.float32)
        ch = {"R": z, "G": z, "B": z, "source.x": z, "source.y": z, "patch.id": np.zeros((H, W), np.uint32),
              "distortion": z, "extension": z, "flag": np.full((H, W), FLAG["disoccluded"], np.uint32)}
        ch.update(geo)
        meta = dict(cd.meta)
        meta["temporal"] = dict(flagged=1.0, cut=True, frame=int(frame))
        return Plate(ch, meta)
    if first.shape != (H, W):
        raise NodeInputError(f"first is {first.width}x{first.height}, depth {W}x{H}; connect plates of one resolution")
    ch = {c: first[c] for c in STATE}
    ch["distortion"] = np.zeros((H, W), np.float32)
    ch["extension"] = np.zeros((H, W), np.float32)
    ch["flag"] = np.zeros((H, W), np.uint32)
    ch.update({k: v for k, v in geo.items() if k != "label.id"})
    ch.update({c: first[c] for c in GEOMETRY if c in first})
    meta = _carried_meta(first, cd)
    meta["temporal"] = dict(flagged=0.0, cut=False, frame=int(frame))
    return Plate(ch, meta)


def carry_margin(p) -> int:
    """Pixels around a changed input pixel whose carry can change: the neighbours' patch
    continued into a disocclusion (``fill_radius``), the map's deviation (1), the isolated-
    flag window and the flags' dilation (``isolated_radius``, ``dilate``), the bilinear
    gather (1), and 1 to spare."""
    return int(p.fill_radius) + int(p.isolated_radius) + int(p.dilate) + 3


ZTOL = 1e-3  # relative depth change under which ConsistentDepth's pixel counts as the same for an update


def _carried(prev: Plate) -> tuple[str, ...]:
    """The previous frame's channels the carry reads."""
    return tuple(c for c in STATE + ("Z", "extension") + CORRECTION if c in prev)


def carry_update(old: Plate, old_inputs: dict, cd: Plate, prev: Plate | None, first: Plate | None, source: Plate, p,
                 *, frame: int, first_frame: int, note=lambda s: None, memo=None) -> tuple[Plate, np.ndarray] | None:
    """Reproject after an edit of the first frame (Bonneel et al. 2010, §7, carried
    through a camera move): ``old`` is this frame's last carry, made from ``old_inputs``
    (``depth``, ``prev``, ``source``). The pixels the edit reaches here are those whose
    ConsistentDepth changed (label, category, or depth by more than ``ZTOL`` relative: the
    rebuilt proxy's depth moves by float noise far from a stroke) and those that read a
    changed pixel of the previous final frame (its changed pixels reprojected into this
    frame's camera), grown by ``carry_margin``; they take the carry of this run's inputs,
    every other pixel keeps ``old``'s state bit for bit. This frame's geometry (``GEOMETRY``,
    ``category``) is ConsistentDepth's everywhere, as in a whole carry.
    Returns (plate, the region), or None where the carry is computed whole (the first
    frame, an input of another size or with other channels, a changed source)."""
    from proxyshade.synthesis.edit import changed_region

    b_cd, b_prev = old_inputs.get("depth"), old_inputs.get("prev")
    if prev is None or b_cd is None or b_prev is None or set(b_cd.names()) != set(cd.names()) \
            or set(b_prev.names()) != set(prev.names()) or old.shape != cd.shape or b_cd.shape != cd.shape:
        return None
    if "source" in old_inputs:
        same = changed_region({"s": old_inputs["source"]}, {"s": source}, {"s": ("R", "G", "B", "label.id")}, 0)
        if same is None or same.any():
            return None
    dcd = changed_region({"d": b_cd}, {"d": cd}, {"d": ("label.id", "category")}, 0)
    dprev = changed_region({"p": b_prev}, {"p": prev}, {"p": _carried(prev)}, 0)
    if dcd is None or dprev is None:
        return None
    z0, z1 = b_cd["Z"], cd["Z"]
    reach = dcd
    zi = np.flatnonzero(z0 != z1)  # then, of those, the ones that moved by more than ZTOL (inf: both inf, or a change)
    if len(zi):
        a, b = z0.reshape(-1)[zi], z1.reshape(-1)[zi]
        with np.errstate(invalid="ignore"):
            moved = ~(np.abs(b - a) <= ZTOL * np.minimum(np.abs(a), np.abs(b)))
        reach.reshape(-1)[zi[moved]] = True
    if dprev.any():
        cam1, cam0 = camera_of("depth", cd), camera_of("prev", prev)
        u, v, q, ok = kr.transfer(kr.inverse_depth(cd["Z"]), kr.relative_matrix(cam1, cam0), kr.intrinsics(cam1),
                                  kr.intrinsics(cam0), cam0.near)
        near = kt.dilate(np.ascontiguousarray(dprev), 1)  # the bilinear gather's 2x2 footprint
        rows, cols = np.nonzero(near.any(1))[0], np.nonzero(near.any(0))[0]
        # only the pixels that land in the changed pixels' box are looked up
        with np.errstate(invalid="ignore"):
            box = ok & (u >= cols[0]) & (u < cols[-1] + 1) & (v >= rows[0]) & (v < rows[-1] + 1)
        ii, jj = np.nonzero(box)
        hit = near[np.floor(v[ii, jj]).astype(np.int64), np.floor(u[ii, jj]).astype(np.int64)]
        reach[ii[hit], jj[hit]] = True
    geometry = tuple(c for c in GEOMETRY if c in cd) + ("category",)
    if not reach.any():
        note("progressive: the edit does not reach this frame")
        return old.with_channels({c: cd[c] if c in cd else old[c] for c in geometry}), reach
    if old.meta.get("temporal", {}).get("cut"):
        return None  # the last run's frame was a camera cut: carried whole again
    m = carry_margin(p)
    region = kt.dilate(np.ascontiguousarray(reach), m)
    H, W = cd.shape
    rows, cols = np.nonzero(region.any(1))[0], np.nonzero(region.any(0))[0]
    r0, r1 = max(0, rows[0] - m), min(H, rows[-1] + 1 + m)
    c0, c1 = max(0, cols[0] - m), min(W, cols[-1] + 1 + m)
    win = (slice(r0, r1), slice(c0, c1))
    # the carry of the region's window (its pixels' whole neighbourhoods), the camera cut decided on the frame below
    new = carry(cd, prev, first, source, SimpleNamespace(**dict(vars(p), cut_threshold=1.0)), frame=frame,
                first_frame=first_frame, window=(r0, r1, c0, c1), memo=memo)
    if set(new.names()) != set(old.names()):
        return None
    sel = region[win]
    ch = {}
    for name in new.names():
        if name in geometry:
            ch[name] = cd[name] if name in cd else old[name]
            continue
        a = old[name].copy()
        a[win][sel] = new[name][sel]
        ch[name] = a
    flag = ch["flag"]
    if (flag > 0).mean() > p.cut_threshold:
        note("progressive: the edit makes this frame a camera cut: carried whole")
        return None
    n = np.bincount(flag.ravel(), minlength=max(FLAG.values()) + 1) / flag.size
    meta = dict(new.meta)
    meta["temporal"] = dict(new.meta["temporal"], **{k: float(n[v]) for k, v in FLAG.items() if v},
                            flagged=float((flag > 0).mean()), edit={"pixels": int(region.sum()),
                                                                    "share": float(region.mean())})
    note(f"progressive: {int(region.sum())} pixels ({100 * region.mean():.2f}%) carried again where the edit "
         f"reaches this frame")
    return Plate(ch, meta), region
