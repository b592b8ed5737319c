"""Local resynthesis of a carried frame (Bonneel et al. 2010, §6.3): the first frame's
steps run again, restricted to the pixels Reproject flagged.

"In areas flagged for resynthesis due to excessive distortion, texture synthesis is
initialized with the existing distorted pixel colors. In the remaining areas flagged for
resynthesis, floodfill is used. The rest of the texture synthesis process remains the
same, except the Poisson solve being restricted to the newly synthesized areas with
Dirichlet boundary conditions in order to avoid global changes in the image."

At the synthesis size (output / ``factor``) a pixel is active when any of its output
pixels is flagged; ``patches.fill_patches(mask=...)`` covers the active pixels flagged
disoccluded or newly occluded (the others keep the carried coordinates: distorted areas
start from their distorted map), ``patches.correct_map(mask=...)`` corrects all active
pixels with the unflagged ones as fixed context, then ``patches.magnify_map`` writes the
map into the flagged output pixels only and ``blend.blend_regions`` solves the Poisson
equation on the flagged pixels. Unflagged pixels keep Reproject's colours and map exactly.
"""
from __future__ import annotations

import time
from types import SimpleNamespace
from typing import Callable

import numpy as np

from proxyshade.plate import Plate
from proxyshade.kernels.correct import downsample_mask
from proxyshade.kernels.lookup import lookup_many
from proxyshade.kernels import temporal as kt
from proxyshade.kernels.random import mix_seed
from proxyshade.synthesis import labels as L
from proxyshade.synthesis.blend import blend_regions, poisson_regions
from proxyshade.synthesis.exemplar import levels_for, synthesis_setup
from proxyshade.synthesis.grain import source_colours
from proxyshade.synthesis.memo import kept
from proxyshade.synthesis.params import Correction, FloodFill, PoissonSolve
from proxyshade.synthesis.patches import correct_map, fill_patches, magnify_map, repair_map, similarity_sets
from proxyshade.synthesis.temporal import CORRECTION, FLAG, rising_after

KEPT = 0xFFFFFFFF  # the patch id the restricted solve gives every kept pixel with kept_as_one
APART = 0x80000000  # or-ed into flagged pixels' patch ids with flagged_apart (ids stay below it)
SYNTHESIZED = ("R", "G", "B", "source.x", "source.y", "patch.id")  # what the resynthesis writes
def exemplar_similarity(source: Plate, setup, corr: SimpleNamespace, *, seed: int, memo=None) -> list:
    """``patches.similarity_sets`` of the exemplar, kept in ``memo``: they depend on the
    source, the exemplar's geometry (factor, scale, levels), its features' parameters and
    the search's, not on the frame or the window, so within one run they are searched once
    per source (and an interactive loop that reads the same source back finds them)."""
    parts = (source, setup.table, setup.factor, setup.scale, len(setup.levels), corr.max_distance, corr.interior, corr.use_rgb,
             corr.k, corr.knn_iterations, corr.w, corr.height_weight, seed)
    return kept(memo, "resynthesis.similarity_sets", parts, lambda: similarity_sets(setup, corr, seed=seed))


def source_table(source: Plate, memo=None) -> np.ndarray:
    """``labels.source_table``, kept in ``memo`` for the frames that pass the same source."""
    ids = tuple(int(t["id"]) for t in source.meta.get("labels") or ())
    return kept(memo, "resynthesis.source_table", (source["label.id"], ids), lambda: L.source_table(source), size=4)


def block_sample(a: np.ndarray, f: int, shape: tuple[int, int]) -> np.ndarray:
    """The output pixel at the middle of each f×f block (clamped at the border)."""
    rows = np.minimum(np.arange(shape[0]) * f + f // 2, a.shape[0] - 1)
    cols = np.minimum(np.arange(shape[1]) * f + f // 2, a.shape[1] - 1)
    return np.ascontiguousarray(a[rows][:, cols])


def synthesis_window(flagged: np.ndarray, f: int, nlev: int, margin: int) -> tuple[int, int, int, int] | None:
    """The window (row0, row1, col0, col1) of the output frame a restricted synthesis of
    ``flagged`` runs on: the flagged pixels' bounding box grown by ``margin`` output pixels
    of context, its corners on the grid of the coarsest level (``f`` × 2^(nlev − 1) output
    pixels, or the frame's edge), so the window's synthesis pixels and levels are those of
    the frame. None when the window would cover most of the frame (no gain)."""
    H, W = flagged.shape
    rows, cols = np.nonzero(flagged.any(1))[0], np.nonzero(flagged.any(0))[0]
    b = f * 2 ** (nlev - 1)
    r0, c0 = max(0, rows[0] - margin) // b * b, max(0, cols[0] - margin) // b * b
    r1, c1 = min(H, -(-(rows[-1] + 1 + margin) // b) * b), min(W, -(-(cols[-1] + 1 + margin) // b) * b)
    if (r1 - r0) * (c1 - c0) > 0.75 * H * W:
        return None
    return int(r0), int(r1), int(c0), int(c1)


def resynthesize(img: Plate, source: Plate, p, frame: int, *, note: Callable[[str], None] = lambda s: None,
                 timings: dict | None = None, window: int | None = None, memo=None, tiles=None) -> Plate:
    """The flagged pixels of Reproject's plate ``img`` resynthesized. ``p``: the
    parameters (``FloodFill``, ``Correction``, ``PoissonSolve`` groups, ``factor``,
    ``scale``, ``seed``, ``solve``); per-stage seconds are added to ``timings`` (features,
    flood fill, corrections, magnify, Poisson) for the bench.

    With ``window`` (output pixels of context), every step runs on a window of the frame
    around the flagged pixels (``synthesis_window``) instead of the whole frame, with the
    frame's number of levels and new patch ids above the frame's: the unflagged pixels
    are the same, the flagged ones differ from a whole-frame run only by what the window
    leaves out (the correction's over-use statistics count the window's pixels, the flood
    fill's random draws are the window's). The edit path (``edit_colour``) uses it.
    ``memo``: the run's memo (``synthesis.memo``); ``tiles``: the executor's row-band runner
    of the correction (``patches.correct_map``)."""
    if window is not None:
        out = _windowed(img, source, p, frame, note, timings, int(window), memo, tiles)
        if out is not None:
            return out
    return _resynthesize(img, source, p, frame, note=note, timings=timings, memo=memo, tiles=tiles)


def paste_window(frame: Plate, sub: Plate, win: tuple[slice, slice], *, skip=()) -> dict:
    """The channels of ``sub`` (a window ``win`` of ``frame``'s run) pasted into copies of
    ``frame``'s, except ``skip``; a channel ``frame`` lacks (or has in another type), such
    as the Poisson correction, is zero outside the window."""
    out = {}
    for c in sub.names():
        if c in skip:
            continue
        if c in frame and frame[c].dtype == sub[c].dtype:
            a = frame[c].copy()
        else:
            a = np.zeros(frame.shape, sub[c].dtype)
        a[win] = sub[c]
        out[c] = a
    return out


def frame_levels(meta: dict, p, shape: tuple[int, int]) -> tuple[int, int]:
    """(factor, synthesis levels) of a frame of ``shape``: ``p.factor`` or the synthesis'."""
    syn = meta.get("synthesis", {}) if isinstance(meta.get("synthesis"), dict) else {}
    f = p.factor if p.factor is not None else int(syn.get("factor", 4))
    H, W = shape
    return f, levels_for(max(-(-H // f), -(-W // f)), p.coarse_size)


def frame_window(meta: dict, p, region: np.ndarray, margin: int) -> tuple[slice, slice] | None:
    """``synthesis_window`` of ``region`` on the frame's levels (``frame_levels``), as
    slices; None for a window of most of the frame."""
    f, nlev = frame_levels(meta, p, region.shape)
    box = synthesis_window(region, f, nlev, margin)
    if box is None:
        return None
    r0, r1, c0, c1 = box
    return slice(r0, r1), slice(c0, c1)


def _windowed(img: Plate, source: Plate, p, frame: int, note, timings, margin: int, memo=None,
              tiles=None) -> Plate | None:
    """``resynthesize`` on ``synthesis_window``'s window, pasted into the frame; None when
    there is no gain (nothing flagged or a window of most of the frame)."""
    flagged = img["flag"] != 0
    if not flagged.any():
        return None
    H, W = img.shape
    win = frame_window(img.meta, p, flagged, margin)
    if win is None:
        return None
    read = SYNTHESIZED + CORRECTION + ("flag", "label.id")  # what _resynthesize reads; the rest passes through
    crop = Plate({c: np.ascontiguousarray(img[c][win]) for c in read if c in img}, dict(img.meta))
    sub = resynthesize_window(crop, source, p, frame, frame_shape=(H, W), patch_base=int(img["patch.id"].max()) + 1,
                              note=note, timings=timings, memo=memo, tiles=tiles)
    unchanged = [c for c in sub.names() if c in img and img[c].dtype == sub[c].dtype
                 and np.array_equal(img[c][win], sub[c])]  # flag, label.id: img's arrays
    out = paste_window(img, sub, win, skip=unchanged)
    meta = dict(sub.meta)
    info = dict(meta.get("resynthesis", {}))
    info.update(share=info.get("pixels", 0) / (H * W), window=[win[1].stop - win[1].start, win[0].stop - win[0].start])
    meta["resynthesis"] = info
    dropped = [c for c in img.names() if c not in sub.names() and c in read]  # CORRECTION without the solve
    return img.with_channels(out, meta=meta, drop=dropped)


def resynthesize_window(crop: Plate, source: Plate, p, frame: int, *, frame_shape: tuple[int, int], patch_base: int,
                        note: Callable[[str], None] = lambda s: None, timings: dict | None = None, memo=None,
                        tiles=None) -> Plate:
    """``_windowed``'s run on a window its caller cut out of the frame already (``crop``:
    the channels ``_resynthesize`` reads, the window's corners on ``synthesis_window``'s
    grid): the same levels as the frame of ``frame_shape`` (its coarsest level as many
    halvings below the window's long side), new patch ids from ``patch_base``. For a caller
    that has the region's box without a whole-frame flag plane (``edit_colour``)."""
    f, nlev = frame_levels(crop.meta, p, frame_shape)
    long_win = max(-(-crop.shape[0] // f), -(-crop.shape[1] // f))
    coarse = long_win / 2 ** (nlev - 1) if nlev > 1 else max(long_win, p.coarse_size)
    q = SimpleNamespace(**dict(vars(p), coarse_size=coarse))
    return _resynthesize(crop, source, q, frame, note=note, timings=timings, patch_base=patch_base, memo=memo,
                         tiles=tiles)


def _resynthesize(img: Plate, source: Plate, p, frame: int, *, note: Callable[[str], None] = lambda s: None,
                  timings: dict | None = None, patch_base: int | None = None, memo=None, tiles=None) -> Plate:
    tm = timings if timings is not None else {}
    t = time.perf_counter()

    def lap(name):
        nonlocal t
        now = time.perf_counter()
        tm[name] = tm.get(name, 0.0) + now - t
        t = now

    flag = img["flag"]
    flagged = flag != 0
    nflag = int(flagged.sum())
    if nflag == 0:
        note("nothing flagged")
        return img.with_channels(meta={"resynthesis": {"pixels": 0, "share": 0.0}})
    syn = img.meta.get("synthesis", {}) if isinstance(img.meta.get("synthesis"), dict) else {}
    f = p.factor if p.factor is not None else int(syn.get("factor", 4))
    scale = p.scale if p.scale is not None else float(syn.get("scale", 1.0))
    redo = flagged & (flag != FLAG["reanchored"])  # re-anchored patches keep their map: Poisson only
    sx, sy, patch, rgb = img["source.x"], img["source.y"], img["patch.id"], img.rgb()
    info = {"pixels": nflag, "share": nflag / flagged.size, "resynthesized": int(redo.sum()),
            "synthesis_pixels": 0, "flood_filled": 0, "patches": 0, "repaired": 0}
    ex_factor = syn.get("exemplar_factor")
    filt = img.meta.get("temporal", {}).get("filter", "bilinear")  # Reproject's, so kept and new pixels match
    if redo.any():
        sx, sy, patch, ex_factor = _synthesize(img, source, p, redo, f=f, scale=scale, seed=mix_seed(p.seed, frame),
                                               info=info, lap=lap, filt=filt, rgb=rgb, patch_base=patch_base,
                                               memo=memo, tiles=tiles)
    lap("magnify")
    out = {}
    before = rgb
    free = flagged  # the pixels whose colour the solve may change
    correct = False
    if p.solve:
        if p.extend_correction and all(c in img for c in CORRECTION):
            rgb = rgb + extended_correction(img, flagged, PoissonSolve.of(p), p.sor_thickness or None)
        creeping = creeping_labels(img)
        unsolved, unfreed = rgb, before
        rgb, free, before, pinfo = restricted_solve(img, source, p, unsolved, unfreed, flagged, creeping=creeping, sx=sx,
                                                    sy=sy, patch=patch, scale=scale, filt=filt, memo=memo)
        later = rising_after(rgb, img["label.id"], img.meta.get("temporal") or {}) if p.gate_result else []
        if later and creeping is not None:
            # labels the result shows creeping: solved again with the remedies (the gate on this frame),
            # only the regions that reach them (every other region is the same problem as before)
            newly = np.isin(img["label.id"], np.asarray(later, np.uint32))
            first_rgb = rgb
            rgb, free, before, pinfo = restricted_solve(img, source, p, unsolved, unfreed, flagged,
                                                        creeping=creeping | newly, sx=sx, sy=sy, patch=patch,
                                                        scale=scale, filt=filt, memo=memo, only=newly)
            rgb = np.where(pinfo["solved"][..., None], rgb, first_rgb)
            info["gated_after"] = later
        # flagged pixels were the source through the map: the correction adds the solve's change
        correct = all(c in img for c in CORRECTION)
        note(f"Poisson on {pinfo['windows']} windows ({pinfo['window_pixels']} px), at most "
             f"{pinfo['iterations']} iterations, residual {pinfo['residual']:.1e}")
    old = [np.ascontiguousarray(img[c], np.float32) if correct else np.zeros((0, 0), np.float32) for c in CORRECTION]
    R, G, B, *corr = kt.colour_planes(np.ascontiguousarray(rgb, np.float32), np.ascontiguousarray(free),
                                      np.ascontiguousarray(before, np.float32), *old, correct)
    if correct:
        out.update(zip(CORRECTION, corr))
    lap("Poisson")
    note(f"flagged {100 * info['share']:.2f}% ({nflag} px; {info['resynthesized']} resynthesized, "
         f"{info['synthesis_pixels']} synthesis px, {info['flood_filled']} flood-filled)")
    meta = dict(img.meta)
    meta["resynthesis"] = info
    meta["synthesis"] = dict(syn, factor=f, scale=scale, exemplar_factor=ex_factor)
    out.update({"R": R, "G": G, "B": B, "source.x": sx, "source.y": sy, "patch.id": patch})
    # without the solve here the correction is a later Poisson node's: drop it rather than carry it stale
    return img.with_channels(out, meta=meta, drop=() if p.solve else CORRECTION)


def restricted_solve(img: Plate, source: Plate, p, rgb: np.ndarray, before: np.ndarray, flagged: np.ndarray, *,
                     creeping: np.ndarray | None, sx: np.ndarray, sy: np.ndarray, patch: np.ndarray, scale: float,
                     filt: str, memo=None, only: np.ndarray | None = None):
    """The restricted Poisson solve of ``rgb`` on the ``flagged`` pixels, with the
    ``RestrictedSolve`` remedies on the ``creeping`` pixels (None: everywhere). Returns
    (colours, the pixels it freed, ``before`` with the ring's source colours, the solve's info,
    whose ``solved`` is the (H, W) mask of the pixels solved). With ``only`` ((H, W) bool) just
    the 4-connected regions of freed pixels that contain or touch one of those pixels are solved (the
    rest keep ``rgb``): each region is its own problem, so a second solve that changed the
    remedies on ``only`` alone need not redo the others."""
    free, before = solve_ring(img, flagged, before, int(p.solve_margin), creeping)
    solved = free
    if only is not None:
        comp, _ = kt.components4(np.ascontiguousarray(free, np.bool_))
        hit = np.zeros(int(comp.max()) + 1, bool)
        hit[comp[free & kt.dilate(np.ascontiguousarray(only, np.bool_), 1)]] = True  # touching one: its edges' ids
        hit[0] = False
        solved = hit[comp]
    # kept_as_one: between two kept pixels the solve keeps their own difference (a ring pixel's
    # seams are not blended again, a flag-4 region does not keep the correction's step at its
    # border); an edge touching a flagged pixel takes the source's gradient
    ids = patch
    if p.kept_as_one:
        own = flagged if creeping is None else flagged | ~creeping
        ids = np.where(own, patch, np.uint32(KEPT)).astype(np.uint32, copy=False)
    elif p.flagged_apart:
        # flagged pixels in a patch of their own: the source's gradient to every kept neighbour,
        # the kept pixels' seams (the ring's) blended again
        apart = flagged if creeping is None else flagged & creeping
        ids = np.where(apart, patch | np.uint32(APART), patch).astype(np.uint32, copy=False)
    out, pinfo = blend_regions(rgb, ids, img["label.id"], solved, PoissonSolve.of(p),
                               source_rgb=source_colours(source, img.meta, memo), sx=sx, sy=sy, scale=scale,
                               filter=filt, thin=p.sor_thickness or None)
    pinfo["solved"] = solved
    return out, free, before, pinfo


def creeping_labels(img: Plate) -> np.ndarray | None:
    """(H, W) bool: the pixels of the labels Reproject found creeping (``meta["temporal"]
    ["rising"]``, its ``creep_gate``), which alone take ``kept_as_one``, ``flagged_apart`` and
    ``solve_margin``;
    None without that list (everywhere)."""
    rising = img.meta.get("temporal", {}).get("rising") if isinstance(img.meta.get("temporal"), dict) else None
    if rising is None:
        return None
    return np.isin(img["label.id"], np.asarray(rising, np.uint32))


def solve_ring(img: Plate, flagged: np.ndarray, before: np.ndarray, margin: int,
               where: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The pixels the restricted solve frees: the ``flagged`` ones and, with ``margin`` > 0 and
    a carried correction, the kept pixels within ``margin`` pixels of them (a square
    dilation; only those in ``where`` when given). Returns (free, before): ``before`` (the
    colours the correction is measured from, (H, W, 3)) with those kept pixels' source
    through their map (colour − correction), so their correction after the solve is again
    colour − source."""
    if margin <= 0 or not all(c in img for c in CORRECTION) or (where is not None and not where.any()):
        return flagged, before
    free = kt.dilate(flagged, margin)
    ring = free & ~flagged
    if where is not None:
        ring &= where
        free = flagged | ring
    before = np.array(before, np.float32)
    before[ring] -= np.stack([img[c][ring] for c in CORRECTION], -1)
    return free, before


def extended_correction(img: Plate, flagged: np.ndarray, solve, thin: float | None) -> np.ndarray:
    """The kept pixels' carried correction (``CORRECTION``) continued onto the ``flagged``
    pixels as the harmonic function with those values around them (one restricted solve,
    no data term), (H, W, 3) float32, 0 on kept pixels. Every edge is a seam of target
    gradient 0 (each pixel its own patch id), so the solve's guidance is zero everywhere."""
    corr = np.stack([np.where(flagged, np.float32(0.0), img[c]) for c in CORRECTION], -1).astype(np.float32)
    ids = np.arange(flagged.size, dtype=np.uint32).reshape(flagged.shape)
    ext, _ = poisson_regions(corr, ids, None, flagged, tol=solve.tol, max_iter=solve.max_iter, thin=thin)
    ext[~flagged] = 0.0
    return ext


def _synthesize(img: Plate, source: Plate, p, redo: np.ndarray, *, f: int, scale: float, seed: int, info: dict, lap,
                filt: str, rgb: np.ndarray, patch_base: int | None = None, memo=None, tiles=None):
    """The first frame's steps on the pixels in ``redo``; the rest keep the carried map.
    The ``redo`` pixels of ``rgb`` (the carried colours, (H, W, 3)) take the source
    through their new map, in place. Returns source.x, source.y, patch.id and the
    exemplar factor."""
    flag = img["flag"]
    table = source_table(source, memo)
    n = len(table)
    H, W = img.shape
    g = L.dense_guide(img["label.id"], table, "image")
    tgt = L.guide_at_synthesis(g, f, n)
    setup = synthesis_setup(source, tgt, table, factor=f, scale=scale, coarse_size=p.coarse_size, max_distance=p.max_distance,
                            interior=p.interior, with_rgb=p.use_rgb)
    shape = tgt.shape
    lap("features")
    active = downsample_mask(redo, f, shape)
    fresh = downsample_mask((flag == FLAG["disoccluded"]) | (flag == FLAG["newly_occluded"]), f, shape)
    coords = setup.from_source(block_sample(img["source.x"], f, shape), block_sample(img["source.y"], f, shape))
    patch_s = block_sample(img["patch.id"], f, shape).astype(np.int64, copy=False)
    npatch = 0
    if fresh.any():
        coords, patch_s, npatch = fill_patches(setup, FloodFill.of(p), seed=seed, mask=fresh, coords=coords, patch=patch_s)
    lap("flood fill")
    corr = Correction.of(p)
    if p.passes > 0 or p.passes_finest > 0:
        coords, _, _ = correct_map(setup, coords, corr, seed=p.seed, mask=active, tiles=tiles,
                                   similarity=exemplar_similarity(source, setup, corr, seed=p.seed, memo=memo))
    else:
        coords, _ = repair_map(setup, coords)
    lap("corrections")
    # magnify to the output size and repair labels against the detailed labels; only redo
    # pixels take the new map: the others are told the label they land on (nothing to repair)
    wl = L.source_working_labels(source, table, scale, memo)
    sx_new, sy_new, new_patch, _, rep = magnify_map(coords, f, (H, W), scale=scale, target=g, labels=wl, only=redo,
                                                    memo=memo)
    base = np.uint32(int(img["patch.id"].max()) + 1 if patch_base is None else patch_base)
    sx, sy, patch = kt.merge_redo(np.ascontiguousarray(redo, np.bool_), sx_new, sy_new,
                                  np.ascontiguousarray(new_patch, np.uint32), base,
                                  np.ascontiguousarray(img["source.x"], np.float32),
                                  np.ascontiguousarray(img["source.y"], np.float32),
                                  np.ascontiguousarray(img["patch.id"], np.uint32))
    at = np.flatnonzero(redo)  # np.nonzero's pixels, as flat indices (one pass)
    if rgb.flags.c_contiguous:  # written through a flat view
        rgb.reshape(-1, 3)[at] = lookup_many(source_colours(source, img.meta, memo), sx.reshape(-1)[at],
                                             sy.reshape(-1)[at], filt)
    else:
        ii, jj = np.divmod(at, W)
        rgb[ii, jj] = lookup_many(source_colours(source, img.meta, memo), sx[ii, jj], sy[ii, jj], filt)
    info.update(synthesis_pixels=int(active.sum()), flood_filled=int(fresh.sum()), patches=int(npatch),
                repaired=int(rep["wrong"]))
    return sx, sy, patch, setup.ex_factor


def resynthesize_update(old: Plate, old_image: Plate | None, img: Plate, source: Plate, old_source: Plate | None, p,
                        frame: int, *, note: Callable[[str], None] = lambda s: None, window: int = 64,
                        memo=None, tiles=None) -> Plate | None:
    """Resynthesize after an edit of the first frame (Bonneel et al. 2010, §7, carried
    through a camera move): ``old`` is this frame's last result, made from ``old_image``.
    Pixels whose input (Reproject's state: ``SYNTHESIZED``, label, flag, correction) is the
    same as then keep ``old``'s values bit for bit (the channels passed through, this frame's
    geometry, are the new input's); the changed ones take the new input's, and those of them that are flagged are
    resynthesized (on a window around them, ``window`` pixels of context) with every other
    pixel as fixed context and Dirichlet values. None where it is done whole (another size,
    other channels, another source)."""
    from proxyshade.synthesis.edit import changed_region

    if old_image is None or set(old_image.names()) != set(img.names()) or old.shape != img.shape:
        return None
    if old_source is not None:
        same = changed_region({"s": old_source}, {"s": source}, {"s": ("R", "G", "B", "label.id")}, 0)
        if same is None or same.any():
            return None
    synth = tuple(c for c in SYNTHESIZED + CORRECTION + ("label.id", "flag") if c in img)
    diff = changed_region({"i": old_image}, {"i": img}, {"i": synth}, 0)
    if diff is None or any(c not in old for c in img.names()):
        return None
    passed = {c: img[c] for c in img.names() if c not in synth}  # this frame's geometry and Reproject's AOVs
    if not diff.any():
        note("progressive: the edit does not reach this frame")
        return old.with_channels(passed)
    ch = dict(passed)
    for c in synth:
        a = old[c].copy()
        a[diff] = img[c][diff]
        ch[c] = a
    flag = ch["flag"]
    ch["flag"] = np.where(diff, flag, np.uint32(0)).astype(np.uint32)
    out = resynthesize(Plate(ch, dict(img.meta)), source, p, frame, note=note, window=window, memo=memo, tiles=tiles)
    info = dict(out.meta.get("resynthesis", {}))
    info["edit"] = {"pixels": int(diff.sum()), "share": float(diff.mean())}
    note(f"progressive: {int(diff.sum())} pixels ({100 * diff.mean():.2f}%) changed by the edit, "
         f"{info.get('pixels', 0)} of them resynthesized")
    return out.with_channels({"flag": flag}, meta={"resynthesis": info})
