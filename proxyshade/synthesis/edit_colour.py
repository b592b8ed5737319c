"""The colour synthesis of a progressive edit (Bonneel et al. 2010, §7): the first frame's
steps on the whole frame, then, after an edit, on the changed region only
(``resynthesis.resynthesize``, as for the flagged pixels of a camera move). Kept apart
from ``synthesis.edit`` so the guide and depth nodes do not depend on the patch steps.

Reference: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010."""
from __future__ import annotations

from types import SimpleNamespace
from typing import Callable

import numpy as np

from proxyshade.plate import Plate
from proxyshade.synthesis.exemplar import provenance
from proxyshade.synthesis.params import RestrictedSolve
from proxyshade.synthesis.resynthesis import (SYNTHESIZED, frame_window, paste_window, resynthesize,
                                              resynthesize_window)
from proxyshade.synthesis.temporal import CORRECTION, FLAG

WINDOW = 64  # output pixels of context around the region of an update (resynthesis.synthesis_window)
THIN = 32     # an update's Poisson regions at most this thick are solved by SOR (blend.poisson_regions)
GEOMETRY = ("Z", "P.X", "P.Y", "P.Z", "N.X", "N.Y", "N.Z", "object.id")  # follow the depth input as they are


def edit_synthesis(guide: Plate, source: Plate, p, *, previous: Plate | None, region: np.ndarray | None,
                   note: Callable[[str], None] = lambda s: None, timings: dict | None = None, memo=None,
                   tiles=None) -> Plate:
    """The synthesized frame for the detailed ``guide`` (labels, and depth AOVs passed on):
    without ``previous``, every pixel synthesized (the first frame's steps on the whole
    frame); with it, only ``region``'s pixels (the others keep ``previous``'s colours, map
    and ids bit for bit). ``p``: ``params.EditSynthesis.of(node_p, "seed")``
    (or its ``defaults()`` with a ``seed``); ``memo``, ``tiles``: as ``resynthesize``'s."""
    H, W = guide.shape
    geometry = {c: guide[c] for c in GEOMETRY if c in guide}
    if previous is not None:
        out = _update(guide, source, p, previous, region, geometry, note, timings, memo, tiles)
        if out is not None:
            return out
    if previous is None:
        region = np.ones((H, W), bool)
        zero = np.zeros((H, W), np.float32)
        meta = provenance(source)
        meta.update({k: guide.meta[k] for k in ("camera", "up_axis", "objects") if k in guide.meta})
        meta["synthesis"] = {"factor": p.factor, "scale": p.scale}
        img = Plate({"R": zero, "G": zero, "B": zero, "source.x": zero, "source.y": zero,
                     "patch.id": np.zeros((H, W), np.uint32)}, meta)
    else:
        img = previous
    flag = np.where(region, np.uint32(FLAG["disoccluded"]), np.uint32(0)).astype(np.uint32)
    img = img.with_channels(dict(geometry, **{"label.id": guide["label.id"].astype(np.uint32), "flag": flag}))
    q = {**vars(RestrictedSolve.defaults()), **vars(p), "solve": True,
         "sor_thickness": None if previous is None else THIN}
    out = resynthesize(img, source, SimpleNamespace(**q), 0, note=note, timings=timings,
                       window=None if previous is None else WINDOW, memo=memo, tiles=tiles)
    info = dict(out.meta.get("resynthesis", {}))
    meta = dict(out.meta)
    meta.pop("resynthesis", None)
    meta["edit"] = {"pixels": int(region.sum()), "share": float(region.mean()),
                    "synthesis_pixels": int(info.get("synthesis_pixels", 0)), "whole": previous is None}
    return Plate({c: out[c] for c in out.names() if c != "flag"}, meta)


def _update(guide: Plate, source: Plate, p, previous: Plate, region: np.ndarray, geometry: dict,
            note: Callable[[str], None], timings: dict | None, memo=None, tiles=None) -> Plate | None:
    """``edit_synthesis`` after an edit, on the region's window only: the window
    (``resynthesis.synthesis_window``) is cut out of ``previous`` and ``guide`` directly
    and the synthesized channels pasted back, the same pixels as ``resynthesize(window=)``
    on a whole-frame flag plane gives (no whole-frame plane is built, compared or copied
    but the synthesized channels' new arrays). None where that path is not taken (nothing
    in the region, or a window of most of the frame: the whole-frame path then)."""
    H, W = guide.shape
    if not region.any():
        return None
    win = frame_window(previous.meta, p, region, WINDOW)
    if win is None:
        return None
    sel = region[win]
    crop = {c: np.ascontiguousarray(previous[c][win]) for c in SYNTHESIZED + CORRECTION if c in previous}
    crop["label.id"] = np.ascontiguousarray(guide["label.id"][win], np.uint32)
    crop["flag"] = np.where(sel, np.uint32(FLAG["disoccluded"]), np.uint32(0)).astype(np.uint32)
    q = SimpleNamespace(**{**vars(RestrictedSolve.defaults()), **vars(p), "solve": True, "sor_thickness": THIN})
    sub = resynthesize_window(Plate(crop, dict(previous.meta)), source, q, 0, frame_shape=(H, W),
                              patch_base=int(previous["patch.id"].max()) + 1, note=note, timings=timings, memo=memo,
                              tiles=tiles)
    ch = dict(previous.channels)
    ch.update(geometry)
    label = guide["label.id"]
    ch["label.id"] = label if label.dtype == np.uint32 else label.astype(np.uint32)
    ch.update(paste_window(previous, sub, win, skip=("label.id", "flag")))
    for c in CORRECTION:  # read but not written (no solve's correction without the last one's)
        if c in crop and c not in sub.names():
            ch.pop(c, None)
    info = dict(sub.meta.get("resynthesis", {}))
    meta = dict(sub.meta)
    meta.pop("resynthesis", None)
    meta.update({k: guide.meta[k] for k in ("camera", "up_axis", "objects") if k in guide.meta})  # the edited scene's
    n = int(sel.sum())
    meta["edit"] = {"pixels": n, "share": n / (H * W), "synthesis_pixels": int(info.get("synthesis_pixels", 0)),
                    "whole": False}
    return Plate(ch, meta)
