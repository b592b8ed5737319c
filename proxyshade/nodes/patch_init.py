"""PatchInit: cover the detailed guide with source patches by flood fill.

Reference: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010.

Bonneel et al. 2010, §5 step 1: at the synthesis resolution (the guide divided by
``factor``, typically 1024 → 256), random uncovered guide pixels seed patches whose best
source match under eq. 1 (contour-distance neighbourhoods + w · Chamfer) is grown by a
flood fill in both images. Layer: ``proxyshade.synthesis.patches.fill_patches``; kernels
``proxyshade.kernels.patch``, features in ``proxyshade.kernels.features``.

The synthesis state is a coordinate map into the source (``source.x/y`` in full-size
source pixels) and ``patch.id``; colours are looked up through it
(``proxyshade.kernels.lookup``).
"""
from __future__ import annotations

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate
from proxyshade.synthesis.params import CoarseLevel, FloodFill, SynthesisGrid, source_input

class PatchInit(FloodFill, SynthesisGrid, CoarseLevel, Node):
    """Cover the guide with source patches grown by flood fill (Bonneel et al. 2010, §5).

    Output at the synthesis size (guide / factor): ``source.x/y`` (float32 source
    pixels), ``patch.id``, ``label.id`` (the guide voted down), ``R,G,B`` looked up in
    the exemplar; metadata: the label table, the source paths and ``synthesis``
    (factor, scale, exemplar size, patch count).
    """

    version = 1
    guide = Input("detailed guide at output size: label.id (GuideSynth or DepthExtend)", channels=("label.id",),
                  fix="connect the detailed guide (GuideSynth)")
    source = source_input()
    seed = Param(int, 0, doc="order of the patch seeds")

    def compute(self, ctx) -> Plate:
        from proxyshade.synthesis import labels as L
        from proxyshade.synthesis.exemplar import synthesis_setup
        from proxyshade.synthesis.patches import fill_patches

        p, guide, source = ctx.p, ctx.guide, ctx.source
        table = L.source_table(source)
        tgt = L.guide_at_synthesis(L.dense_guide(guide["label.id"], table), p.factor, len(table))
        setup = synthesis_setup(source, tgt, table, factor=p.factor, scale=p.scale, coarse_size=p.coarse_size,
                                max_distance=p.max_distance, interior=p.interior, with_rgb=False, finest_only=True)
        coords, patch, npatch = fill_patches(setup, FloodFill.of(p), seed=p.seed)
        ctx.note(f"{npatch} patches over {tgt.shape[1]}x{tgt.shape[0]} synthesis pixels "
                 f"(exemplar {setup.ex_lab.shape[1]}x{setup.ex_lab.shape[0]})")
        return setup.plate(coords, patch, source, {"output": list(guide.shape), "patches": int(npatch),
                                           "max_distance": p.max_distance, "coarse_size": p.coarse_size})
