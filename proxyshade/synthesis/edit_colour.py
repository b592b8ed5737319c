"""The colour synthesis of a progressive edit (Bonneel et al. 2010, §7): the first frame's
steps on the whole frame, then, after an edit, on the changed region only
(``resynthesis.resynthesize``, as for the flagged pixels of a camera move). Kept apart
from ``synthesis.edit`` so the guide and depth nodes do not depend on the patch steps."""
from __future__ import annotations

from types import SimpleNamespace
from typing import Callable

import numpy as np

from proxyshade.graph.plate import Plate
from proxyshade.synthesis.exemplar import provenance
from proxyshade.synthesis.resynthesis import resynthesize
from proxyshade.synthesis.temporal import FLAG

WINDOW = 64  # output pixels of context around the region of an update (resynthesis.synthesis_window)
THIN = 32     # an update's Poisson regions at most this thick are solved by SOR (blend.poisson_regions)
GEOMETRY = ("Z", "P.X", "P.Y", "P.Z", "N.X", "N.Y", "N.Z", "object.id")  # follow the depth input as they are


def edit_synthesis(guide: Plate, source: Plate, p, *, previous: Plate | None, region: np.ndarray | None,
                   note: Callable[[str], None] = lambda s: None, timings: dict | None = None) -> Plate:
    """The synthesized frame for the detailed ``guide`` (labels, and depth AOVs passed on):
    without ``previous``, every pixel synthesized (the first frame's steps on the whole
    frame); with it, only ``region``'s pixels (the others keep ``previous``'s colours, map
    and ids bit for bit). ``p``: the ``FloodFill``, ``Correction`` and ``PoissonSolve``
    parameters, ``factor``, ``scale``, ``seed``."""
    H, W = guide.shape
    geometry = {c: guide[c] for c in GEOMETRY if c in guide}
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
    q = dict(vars(p), solve=True, sor_thickness=None if previous is None else THIN)
    out = resynthesize(img, source, SimpleNamespace(**q), 0, note=note, timings=timings,
                       window=None if previous is None else WINDOW)
    info = dict(out.meta.get("resynthesis", {}))
    meta = dict(out.meta)
    meta.pop("resynthesis", None)
    meta["edit"] = {"pixels": int(region.sum()), "share": float(region.mean()),
                    "synthesis_pixels": int(info.get("synthesis_pixels", 0)), "whole": previous is None}
    return Plate({c: out[c] for c in out.names() if c != "flag"}, meta)
