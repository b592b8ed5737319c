"""Correct: k-coherent pixel correction of the patch map, coarse to fine.

Bonneel et al. 2010, §5 step 2 (after Lefebvre and Hoppe 2005): the PatchInit map is
taken down to the coarsest level (``coarse_size``, 32 by default) and refined up to the
synthesis size with correction passes (5 per level, 3 at the finest), the metric of
eq. 1 augmented with colour, candidates rejected when already used in the 9×9 window or
when a non-coherent neighbour uses an exemplar pixel within the level's radius. Kernels:
``proxyshade.kernels.correct``.
"""
from __future__ import annotations

import numpy as np

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate
from proxyshade.kernels import correct as kcorrect
from proxyshade.kernels import patch as kpatch
from proxyshade.kernels.magnify import repair_labels
from proxyshade.nodes.patch_init import (SYNTH_CHANNELS, check_finite, dense_guide, require, setup,
                                         source_table)


class Correct(Node):
    """Refine a synthesis-size coordinate map (PatchInit's) by k-coherent correction.

    Output: the same channels as the input (``source.x/y``, ``patch.id`` recomputed as
    4-connected regions of one translation, ``R,G,B`` looked up again, ``label.id``).
    """

    version = 1
    init = Input("synthesis-size map from PatchInit: source.x/y, label.id")
    source = Input("annotated source (SourceRead), the one PatchInit used")
    passes = Param(int, 5, min=0, doc="correction passes per level (each four parity sub-passes)")
    passes_finest = Param(int, 3, min=0, doc="correction passes at the synthesis size")
    coarse_size = Param(int, 32, min=4, doc="long edge of the coarsest level where correction starts")
    k = Param(int, 2, min=0, max=16, doc="similarity set size (k-coherence); 0 = coherent candidates only")
    kappa = Param(float, 0.0, min=0.0, doc="penalty (x 1 + kappa) on similarity-set candidates; favours coherence")
    knn_iterations = Param(int, 2, min=0, doc="PatchMatch iterations for the similarity sets")
    w = Param(float, 90.0, min=0.0, doc="weight of the Chamfer distance")
    max_distance = Param(float, 8.0, min=0.0, optional=True, doc="clamp contour distances (level pixels)")
    use_rgb = Param(bool, True, doc="add the colour neighbourhood to the metric (the paper does)")
    radius = Param(str, "spacing", choices=("spacing", "level"),
                   doc="near-copy radius: one level pixel (spacing h) or 2^l exemplar pixels at level l")
    seed = Param(int, 0, doc="seed of the similarity-set search")

    def compute(self, ctx) -> Plate:
        p = ctx.p
        init = require(ctx, ctx.init, "init", ["source.x", "source.y", "label.id"], "PatchInit's output")
        source = require(ctx, ctx.source, "source", ["R", "G", "B", "label.id"], "a SourceRead node")
        check_finite(ctx, source, "source", ["R", "G", "B"])
        check_finite(ctx, init, "init", ["source.x", "source.y"])
        syn = init.meta.get("synthesis")
        if not isinstance(syn, dict) or "factor" not in syn or "scale" not in syn:
            raise ctx.error("input 'init' has no synthesis metadata (factor, scale); connect PatchInit's output")
        table = source_table(ctx, source)
        tgt = dense_guide(ctx, init["label.id"], table, "init")
        st = setup(ctx, source, tgt, table, factor=int(syn["factor"]), scale=float(syn["scale"]),
                   coarse_size=p.coarse_size, max_distance=p.max_distance, with_rgb=p.use_rgb)
        S0 = st.from_source(init["source.x"], init["source.y"])
        S, stats = kcorrect.synthesize(st.levels, S0, passes=p.passes, passes_finest=p.passes_finest, k=p.k, w=p.w,
                                       seed=p.seed, knn_iterations=p.knn_iterations, use_rgb=p.use_rgb,
                                       kappa=p.kappa, radius_rule=p.radius)
        S, rep = repair_labels(S, tgt, st.ex_lab)
        patch, npatch = kpatch.offset_components(S)
        changed = sum(s["changed"] for s in stats)
        ctx.note(f"{len(stats)} levels, {changed} pixel updates, {npatch} patches; "
                 f"{rep['wrong']} label mismatches repaired")
        extra = {k: v for k, v in syn.items() if k not in ("factor", "scale", "exemplar_factor", "exemplar")}
        extra.update(patches=npatch, corrected=True)
        out = st.plate(S, patch, source, extra)
        return out.with_channels({c: init[c] for c in init.names() if c not in SYNTH_CHANNELS})
