"""Relighting a synthesized frame from another photo of the same view (Bonneel et al.
2010, §8: "the same synthesis can be re-applied to a time-lapse series").

Reference: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010.

The synthesis state of a frame is its coordinate map into the source (``source.x/y``)
and its patches (``patch.id``). Every colour is read through the map
(``kernels.lookup``), so the map made on one photo reads any other photo of the same
view, pixel for pixel: no new matching. The seams are blended again with the Poisson
solve over the whole frame (``blend.blend_frame``), with the other photo's gradients
across seams.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from proxyshade.errors import NodeInputError
from proxyshade.plate import Plate
from proxyshade.kernels.lookup import lookup
from proxyshade.synthesis.blend import blend_frame
from proxyshade.synthesis.exemplar import provenance
from proxyshade.synthesis.grain import source_colours
from proxyshade.synthesis.temporal import CORRECTION


def relight(img: Plate, photo: Plate, solve: SimpleNamespace, *, filter: str = "auto",
            memo=None) -> tuple[Plate, dict]:
    """``img`` (a synthesized frame: ``source.x/y``, ``patch.id``, ``label.id``) with its
    ``R,G,B`` read from ``photo`` (a SourceRead plate of another photo of the view)
    through its map and Poisson-blended over the whole frame (``solve``: the
    ``PoissonSolve`` parameters). ``filter``: the lookup's reconstruction; ``auto`` is the
    one the frame was read with (a camera move's ``temporal.filter``, else bilinear, as
    Magnify). Every other channel passes through; the stale Poisson correction of a camera
    move is dropped. Returns the plate and the solve's info."""
    sx, sy = img["source.x"], img["source.y"]
    ph, pw = photo.shape
    size = img.meta.get("source", {}).get("size") if isinstance(img.meta.get("source"), dict) else None
    if size and list(size) != [pw, ph]:
        raise NodeInputError(f"the frame's map was made on a {size[0]}x{size[1]} photo but this one is {pw}x{ph}; "
                             "relight with a photo of the same view at the same size (an entry of the source's "
                             "'images')")
    if float(sx.max()) > pw - 0.5 or float(sy.max()) > ph - 0.5 or float(min(sx.min(), sy.min())) < -0.5:
        raise NodeInputError(f"the frame's map reads outside this {pw}x{ph} photo; relight with a photo of the "
                             "same view at the size the frame was synthesized from")
    if filter == "auto":
        filter = img.meta.get("temporal", {}).get("filter", "bilinear")
    rgb = source_colours(photo, img.meta, memo)  # graded by the frame's grain table, as the frame read its source
    scale = float(img.meta.get("synthesis", {}).get("scale", 1.0))
    labels = img["label.id"] if "label.id" in img else None
    if solve.label_dirichlet and labels is None:
        raise NodeInputError("the frame has no label.id for the label-boundary condition; relight a synthesized "
                             "frame (Poisson's or Resynthesize's output) or set label_dirichlet: false")
    u, info = blend_frame(lookup(rgb, sx, sy, filter=filter), img["patch.id"], labels, solve, source_rgb=rgb,
                          sx=sx, sy=sy, scale=scale,
                          source_labels=photo["label.id"] if solve.layout and "label.id" in photo else None)
    meta = dict(img.meta)
    meta["source"] = provenance(photo)["source"]
    meta["relight"] = {"photo": photo.meta.get("source", {}).get("photo"), "filter": filter,
                       "iterations": int(info["iterations"]), "residual": float(info["residual"])}
    out = img.with_channels({"R": u[..., 0].copy(), "G": u[..., 1].copy(), "B": u[..., 2].copy()}, meta=meta,
                            drop=tuple(c for c in CORRECTION if c in img))
    return out, info
