"""Correct: k-coherent pixel correction of the patch map, coarse to fine.

Reference: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010.

Bonneel et al. 2010, §5 step 2 (after Lefebvre and Hoppe 2005): the PatchInit map is
taken down to the coarsest level (``coarse_size``, 32 by default) and refined up to the
synthesis size with correction passes (5 per level, 3 at the finest), the metric of
eq. 1 augmented with colour, candidates rejected when already used in the 9×9 window or
when a non-coherent neighbour uses an exemplar pixel within the level's radius. Layer:
``proxyshade.synthesis.patches.correct_map``; kernels ``proxyshade.kernels.correct``.
"""
from __future__ import annotations

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate
from proxyshade.synthesis.params import Correction, source_input


class Correct(Correction, Node):
    """Refine a synthesis-size coordinate map (PatchInit's) by k-coherent correction.

    Output: the same channels as the input (``source.x/y``, ``patch.id`` recomputed as
    4-connected regions of one translation, ``R,G,B`` looked up again, ``label.id``).
    """

    version = 2
    init = Input("synthesis-size map from PatchInit: source.x/y, label.id", channels=("source.x", "source.y", "label.id"),
                 finite=("source.x", "source.y"), fix="connect PatchInit's output")
    source = source_input("annotated source (SourceRead), the one PatchInit used")
    seed = Param(int, 0, doc="seed of the similarity-set search")
    near_copy = Param(int, 4, min=0, max=64,
                      doc="smallest near-copy radius in exemplar pixels at every level, at most 1/16 of the "
                          "exemplar's shorter side and the mean use of an exemplar pixel: a candidate within it of the position a non-coherent pixel "
                          "of its 9x9 window uses is rejected (the `radius` rule's own where larger). Keeps seams "
                          "from joining copies of nearly the same source spot, which magnified pile onto a few "
                          "source pixels (docs/formats.md); 0 = the `radius` rule alone")

    rare_budget = Param(float, 0.0, min=0.0,
                        doc="copies of a label's rare look (its rare_tail darkest and brightest source pixels: "
                            "tents on a plain, bushes along a field) allowed at the synthesis size, where an "
                            "even draw over the label would copy it more (a frame larger than the photo): "
                            "candidates on it pay 1 + their window's over-use; 0 = off")
    rare_tail = Param(float, 0.1, min=0.001, max=0.5,
                      doc="the shares of a label's darkest and brightest source pixels (at least 0.15 in luma from "
                          "its median) that make its rare look, for rare_budget")
    copy_spacing = Param(float, 0.0, min=0.0, max=2.0,
                         doc="in a frame of more than twice the photo's area (HD, 4K from a 1024-wide photo), the "
                             "least distance on the frame between two non-coherent copies of one source spot, as a "
                             "share of the spacing an even spread of the label's copies gives (the square root of "
                             "its source area): copies of a bush or a tent spread out instead of clustering; "
                             "0 = off")

    def compute(self, ctx) -> Plate:
        from proxyshade.synthesis import labels as L
        from proxyshade.synthesis.exemplar import SYNTH_CHANNELS, synthesis_setup
        from proxyshade.synthesis.patches import correct_map, patch_ids

        p, init, source = ctx.p, ctx.init, ctx.source
        syn = init.meta.get("synthesis")
        if not isinstance(syn, dict) or "factor" not in syn or "scale" not in syn:
            raise ctx.error("input 'init' has no synthesis metadata (factor, scale); connect PatchInit's output")
        table = L.source_table(source)
        tgt = L.dense_guide(init["label.id"], table, "init")
        setup = synthesis_setup(source, tgt, table, factor=int(syn["factor"]), scale=float(syn["scale"]),
                                coarse_size=p.coarse_size, max_distance=p.max_distance, interior=p.interior, with_rgb=p.use_rgb)
        coords, stats, rep = correct_map(setup, setup.from_source(init["source.x"], init["source.y"]), Correction.of(p),
                                    seed=p.seed, near_copy=p.near_copy, tiles=ctx.tiles,
                                    rare_budget=p.rare_budget, rare_tail=p.rare_tail,
                                    copy_spacing=p.copy_spacing)
        patch, npatch = patch_ids(coords)
        changed = sum(s["changed"] for s in stats)
        ctx.note(f"{len(stats)} levels, {changed} pixel updates, {npatch} patches; "
                 f"{rep['wrong']} label mismatches repaired")
        extra = {k: v for k, v in syn.items() if k not in ("factor", "scale", "exemplar_factor", "exemplar")}
        extra.update(patches=npatch, corrected=True)
        out = setup.plate(coords, patch, source, extra)
        return out.with_channels({c: init[c] for c in init.names() if c not in SYNTH_CHANNELS})
