"""Progressive update after an edit of the proxy (Bonneel et al. 2010, §7): "the guide,
depth and colour are recomputed only in the region the edit changed".

Reference: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010.

A progressive node (``graph.node.Progressive``) gets its last result and the inputs it was
computed from (``ctx.previous``); ``changed_region`` diffs those inputs against this run's
and dilates the difference; the node then recomputes that region only and keeps every
other pixel of its last result bit for bit:

* the detailed guide (``update_guide``): the guidance synthesis re-run on a window around
  the changed proxy labels, its correction masked to the region (the rest of the window
  is the previous guide's state, as context), pasted inside the region;
* the depth (``synthesis.depth.depth_plate`` with a region): jump flooding on a window;
* the colours (``edit_colour.edit_synthesis``): the first frame's steps restricted to the region
  (``resynthesis.resynthesize``: flood fill, correction, magnification, restricted
  Poisson solve), as for the flagged pixels of a camera move.

For the first frame the region is in the first frame's camera already: the proxy renders
are diffed there.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from proxyshade.plate import Plate
from proxyshade.kernels import edit as kedit
from proxyshade.kernels import temporal as kt
from proxyshade.kernels.temporal import dilate
from proxyshade.synthesis.blend import group_boxes
from proxyshade.synthesis.guide import synthesize_guide


def _comparable(x: np.ndarray) -> np.ndarray:
    """A channel as ``mark_differences`` compares it: float16 widened to float32 (exact: the
    same pairs compare equal; numba has no float16), contiguous."""
    return np.ascontiguousarray(x, np.float32 if x.dtype == np.float16 else None)


def changed_region(before: dict[str, Plate], after: dict[str, Plate], channels: dict[str, tuple[str, ...]],
                   radius: int) -> np.ndarray | None:
    """Pixels where any of ``channels`` (input name -> channel names) differs between the
    ``before`` and ``after`` plates (bit for bit; NaN equal to NaN), dilated by ``radius``
    pixels (square), on the first input's pixel grid. None (recompute whole) when a plate
    is missing, the first input changed size, or another input of another size (the
    source) changed at all."""
    diff = lo = hi = None
    for name, names in channels.items():
        a, b = before.get(name), after.get(name)
        if a is None or b is None or a.shape != b.shape:
            return None
        # one pass per channel: the difference and each row's first and last differing column
        same_grid = diff is not None and a.shape == diff.shape
        d = diff if same_grid else np.zeros(a.shape, bool)
        first = lo if same_grid else np.full(a.shape[0], a.shape[1], np.int64)
        last = hi if same_grid else np.full(a.shape[0], -1, np.int64)
        for c in names:
            if (c in a) != (c in b):
                return None
            if c in a:
                kedit.mark_differences(_comparable(a[c]), _comparable(b[c]), d, first, last)
        if diff is None:
            diff, lo, hi = d, first, last
        elif not same_grid and (last >= 0).any():
            return None
    if diff is None:
        return None
    rows = np.flatnonzero(hi >= 0)
    if radius <= 0 or not len(rows):
        return diff
    cols = (int(lo[rows].min()), int(hi[rows].max()))
    # the dilation of the difference's box (grown by the radius) only: the same pixels
    radius = int(radius)
    H, W = diff.shape
    r0, r1 = max(0, rows[0] - radius), min(H, rows[-1] + 1 + radius)
    c0, c1 = max(0, cols[0] - radius), min(W, cols[1] + 1 + radius)
    out = np.zeros((H, W), np.bool_)
    out[r0:r1, c0:c1] = dilate(np.ascontiguousarray(diff[r0:r1, c0:c1]), radius)
    return out


def _span(lo: int, hi: int, size: int, limit: int, step: int = 1, slack: int = 0) -> tuple[int, int]:
    """[a, a + size) covering [lo, hi) as centred as the limit [0, limit) allows, ``a`` a
    multiple of ``step`` (the frame's synthesis pixels) where that still covers
    [lo, hi − ``slack``) (the context's end may be lost, not the region)."""
    a = max(0, min(limit - size, (lo + hi - size) // 2))
    if a % step and a // step * step + size >= hi - slack:
        a = a // step * step
    return a, a + size


def _window_of(comp: np.ndarray, origin: tuple[int, int], r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
    """Rows r0..r1, columns c0..c1 of the frame's component ids, from ``comp``, the ids on
    the region's box at ``origin`` (0 elsewhere)."""
    R0, C0 = origin
    out = np.zeros((r1 - r0, c1 - c0), comp.dtype)
    a0, a1 = max(r0, R0), min(r1, R0 + comp.shape[0])
    b0, b1 = max(c0, C0), min(c1, C0 + comp.shape[1])
    if a0 < a1 and b0 < b1:
        out[a0 - r0:a1 - r0, b0 - c0:b1 - c0] = comp[a0 - R0:a1 - R0, b0 - C0:b1 - C0]
    return out


def update_guide(prev: Plate, region: np.ndarray, proxy: Plate, source: Plate, gp: SimpleNamespace, *,
                 context: int, memo=None) -> tuple[Plate, dict]:
    """The detailed guide ``prev`` updated inside ``region`` for the edited ``proxy``.

    The region's 4-connected parts are grouped into windows (``blend.group_boxes``: boxes
    grown by ``context`` output pixels, merged when they overlap or when one window costs
    little more than two), and the guidance synthesis (``gp``: the ``Guidance``
    parameters) runs on each window (its sides multiples of the synthesis's block, the long
    one ``magnify`` × a power of two, so it is synthesized with the frame's magnification
    and levels; or, when that power of two would reach the frame, the frame's long side
    and ``size``: a band across the frame; the window's origin on the frame's synthesis
    grid); its labels and source positions replace ``prev``'s inside the region. A window
    that cannot lie on the frame's synthesis grid (a region as long as its window, off the
    grid) is synthesized afresh, without ``prev`` (``info["fresh"]`` counts them).
    The synthesis on a window is the masked correction (``synthesize_guide`` with
    ``previous``): the window's state is ``prev``'s, the region's blocks are initialized
    with the new labels (``prev``'s coordinates where their label still is the target's)
    and corrected with the rest as fixed context, at every level (§7: "we initialize
    flagged areas with the new labels and perform correction passes"), so labels change
    where the proxy's did, not across the whole region.
    Every other pixel keeps ``prev``'s labels and positions; the other channels are the new
    proxy's. A window that would be as large as the frame is the frame's (masked)
    synthesis, still pasted inside the region only."""
    H, W = proxy.shape
    g = prev.meta.get("guide", {})
    f = int(g.get("magnify", 1))
    levels = int(np.log2(gp.size // gp.start)) + 1
    block = f * 2 ** (levels - 1)
    out = {c: prev[c].copy() for c in ("label.id", "source.x", "source.y")}
    # the region's parts, found on its bounding box (the same ids, in scan order, and boxes)
    rows, cols = np.flatnonzero(region.any(1)), np.flatnonzero(region.any(0))
    R0, C0 = (int(rows[0]), int(cols[0])) if len(rows) else (0, 0)
    R1, C1 = (int(rows[-1]) + 1, int(cols[-1]) + 1) if len(rows) else (0, 0)
    comp, boxes = kt.components4(np.ascontiguousarray(region[R0:R1, C0:C1], np.bool_))
    boxes = boxes + np.array([R0, R0, C0, C0], np.int64)
    info = {"windows": [], "window_pixels": 0, "region": int(region.sum()), "whole": False, "fresh": 0}
    for r0, r1, c0, c1, ids in group_boxes(boxes, (H, W), margin=context, slack=(4 * context) ** 2):
        long_side, size = f * gp.start, None
        while long_side < max(r1 - r0, c1 - c0):
            long_side *= 2
        if long_side >= max(H, W):  # past the frame: the frame's long side, synthesized with its size and levels
            long_side, size = max(H, W), gp.size
        hh = long_side if r1 - r0 >= c1 - c0 else -(-(r1 - r0) // block) * block
        ww = long_side if c1 - c0 > r1 - r0 else -(-(c1 - c0) // block) * block
        crop_long = max(min(hh, H), min(ww, W))
        whole = size is not None and 2 ** round(np.log2(crop_long / gp.size)) != f  # would magnify otherwise
        if whole or (hh >= H and ww >= W):  # the window is the frame: the masked synthesis of the frame
            sub, _ = synthesize_guide(proxy, source, gp, previous=prev, active=region, memo=memo)
            r0, r1, c0, c1 = 0, H, 0, W
            info["whole"] = True
        else:
            r0, r1 = _span(r0, r1, min(hh, H), H, f, context)
            c0, c1 = _span(c0, c1, min(ww, W), W, f, context)
            win = (slice(r0, r1), slice(c0, c1))
            crop = Plate({"label.id": np.ascontiguousarray(proxy["label.id"][win])},
                         {"labels": proxy.meta.get("labels", [])})
            before = Plate({c: np.ascontiguousarray(prev[c][win]) for c in ("source.x", "source.y")})
            cw = _window_of(comp, (R0, C0), r0, r1, c0, c1)
            sel = np.isin(cw, ids) if len(ids) > 1 else cw == ids[0]  # this window's parts only
            # the previous guide is this window's state where it is not synthesized again
            # (aligned with the frame's synthesis pixels, as _span places the window)
            aligned = r0 % f == 0 and c0 % f == 0
            info["fresh"] += not aligned  # synthesized afresh, then pasted inside the region only
            sub, _ = synthesize_guide(crop, source, SimpleNamespace(**dict(vars(gp), size=size or long_side // f)),
                                      previous=before if aligned else None, active=sel if aligned else None,
                                      memo=memo)
        win = (slice(r0, r1), slice(c0, c1))
        if info["whole"]:
            sel = region
        for c in out:
            np.copyto(out[c][win], sub[c], where=sel, casting="unsafe")  # one pass, no gathered copies
        info["windows"].append([int(c1 - c0), int(r1 - r0)])
        info["window_pixels"] += int((r1 - r0) * (c1 - c0))
        if info["whole"]:
            break
    return proxy.with_channels(out, meta={"labels": prev.meta.get("labels"), "guide": g}), info
