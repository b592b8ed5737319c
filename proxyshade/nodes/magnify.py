"""Magnify: upsample the synthesized patches to the output size (no correction).

Bonneel et al. 2010, §5 step 3: "a synthesis magnification to the resolution of the
input image ... by upsampling patches without correction passes". Each synthesis pixel
becomes ``factor``×``factor`` output pixels reading the source at full detail along its
patch's translation; pixels whose source label differs from the detailed guide's are
moved onto the right label (``proxyshade.kernels.magnify``). Colours are looked up
through the map (``proxyshade.kernels.lookup``).
"""
from __future__ import annotations

import numpy as np

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate
from proxyshade.kernels import features as kf
from proxyshade.kernels import magnify as kmag
from proxyshade.kernels import patch as kpatch
from proxyshade.kernels.lookup import lookup
from proxyshade.nodes.patch_init import check_finite, dense_guide, provenance, require, source_table

DEPTH_CHANNELS = ("Z", "P.X", "P.Y", "P.Z")


def working_labels(source_dense: np.ndarray, scale: float, n: int) -> np.ndarray:
    """Source labels on the output-scale grid (source / scale), dense."""
    if scale == 1.0:
        return np.ascontiguousarray(source_dense, np.int32)
    _, lab = kf.build_exemplar(np.zeros(source_dense.shape + (3,), np.float32), source_dense, scale, n)
    return lab


class Magnify(Node):
    """Synthesis-size map -> output-size plate: ``R,G,B`` (linear, looked up in the
    source), ``label.id`` (the detailed guide), ``source.x/y``, ``patch.id``, and ``Z``
    (and ``P.X/Y/Z``) from ``depth`` when connected. Metadata: the label table and the
    source's photo and label-map paths (provenance of every pixel)."""

    version = 1
    synth = Input("synthesis-size map: Correct's (or PatchInit's) output")
    source = Input("annotated source (SourceRead)")
    guide = Input("detailed guide at output size: label.id")
    depth = Input("extended depth (DepthExtend): Z and optionally P.X/P.Y/P.Z", optional=True)
    repair = Param(bool, True, doc="move pixels whose source label differs from the guide's onto the right label")

    def compute(self, ctx) -> Plate:
        synth = require(ctx, ctx.synth, "synth", ["source.x", "source.y"], "Correct's output")
        source = require(ctx, ctx.source, "source", ["R", "G", "B", "label.id"], "a SourceRead node")
        guide = require(ctx, ctx.guide, "guide", ["label.id"], "the detailed guide (GuideSynth)")
        check_finite(ctx, source, "source", ["R", "G", "B"])
        check_finite(ctx, synth, "synth", ["source.x", "source.y"])
        syn = synth.meta.get("synthesis")
        if not isinstance(syn, dict) or "factor" not in syn:
            raise ctx.error("input 'synth' has no synthesis metadata; connect Correct's or PatchInit's output")
        f, scale, F = int(syn["factor"]), float(syn["scale"]), float(syn["exemplar_factor"])
        Ho, Wo = guide.shape
        Ht, Wt = synth.shape
        if (Ht - 1) * f >= Ho or Ht * f < Ho or (Wt - 1) * f >= Wo or Wt * f < Wo:
            raise ctx.error(f"guide is {Wo}x{Ho} but synth is {Wt}x{Ht} at factor {f}; connect the guide PatchInit used")
        table = source_table(ctx, source)
        g = dense_guide(ctx, guide["label.id"], table)
        n = len(table)
        # exemplar (row, column) -> output-scale source grid
        ex_c = np.floor((synth["source.x"].astype(np.float64) + 0.5) / F - 0.5 + 0.5).astype(np.int32)
        ex_r = np.floor((synth["source.y"].astype(np.float64) + 0.5) / F - 0.5 + 0.5).astype(np.int32)
        Sw = kmag.magnify(np.stack([ex_r, ex_c], -1), f, (Ho, Wo))
        src_dense, _ = kf.dense_labels(source["label.id"], table)
        wl = working_labels(src_dense, scale, n)
        rep = {"wrong": 0}
        if ctx.p.repair:
            Sw, rep = kmag.repair_labels(Sw, g, wl)
            ctx.note(f"{rep['wrong']} pixels landed on another label: {rep['extended']} continued a neighbour's "
                     f"patch, {rep['nearest']} took the nearest right-label source pixel")
        patch, npatch = kpatch.offset_components(Sw)
        sx = ((Sw[..., 1].astype(np.float64) + 0.5) * scale - 0.5).astype(np.float32)
        sy = ((Sw[..., 0].astype(np.float64) + 0.5) * scale - 0.5).astype(np.float32)
        rgb = lookup(source.rgb(), sx, sy)
        ch = {"R": rgb[..., 0].copy(), "G": rgb[..., 1].copy(), "B": rgb[..., 2].copy(),
              "label.id": guide["label.id"].astype(np.uint32), "source.x": sx, "source.y": sy,
              "patch.id": patch}
        if ctx.depth is not None:
            check_finite(ctx, ctx.depth, "depth", ["Z"], allow_inf=True)
            if ctx.depth.shape != (Ho, Wo):
                raise ctx.error(f"depth is {ctx.depth.shape[1]}x{ctx.depth.shape[0]}, guide {Wo}x{Ho}; "
                                "connect DepthExtend's output for this guide")
            for c in DEPTH_CHANNELS:
                if c in ctx.depth:
                    ch[c] = ctx.depth[c].astype(np.float32)
        meta = provenance(source)
        meta["synthesis"] = dict(syn, patches=npatch, magnified=True, repaired=int(rep["wrong"]))
        for k in ("camera", "up_axis", "objects"):
            for pl in (ctx.depth, guide):
                if pl is not None and k in pl.meta:
                    meta[k] = pl.meta[k]
                    break
        return Plate(ch, meta)
