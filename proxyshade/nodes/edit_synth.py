"""EditSynth: the first frame's colour synthesis, updated only where an edit changed the
detailed guide (Bonneel et al. 2010, §7, progressive update).

Reference: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010.

Its first run synthesizes the whole frame (flood fill, correction, magnification, Poisson:
the first frame's steps, run as the restricted steps of ``synthesis.resynthesis`` with
every pixel in the region); a later run after an edit of the proxy (the engine hands it
its last result and the guide it was made from, ``graph.node.Progressive``) diffs the
guide's labels, dilates the difference and synthesizes only that region again, every other
pixel kept bit for bit. Layer: ``proxyshade.synthesis.edit_colour``.
"""
from __future__ import annotations

from proxyshade.graph.node import Input, Node, Param, Progressive
from proxyshade.graph.plate import Plate
from proxyshade.synthesis.params import EditSynthesis, source_input


class EditSynth(EditSynthesis, Progressive, Node):
    """The synthesized frame of a detailed guide, updated progressively after edits.

    Output at the guide's size: ``R,G,B``, ``label.id``, ``source.x/y``, ``patch.id`` and
    the guide's ``Z``, ``P.*``, ``N.*``, ``object.id``; metadata ``edit`` (pixels and
    share synthesized, synthesis pixels, whole frame or not).
    """

    version = 1
    guide = Input("detailed guide with depth (DepthExtend): label.id, optionally Z, P, N, object.id",
                  channels=("label.id",), dtype={"label.id": "uint32"}, fix="connect DepthExtend's output")
    source = source_input()
    progressive = Param(bool, True, doc="after an edit, synthesize only where the guide's labels changed")
    seed = Param(int, 0, doc="seed of the flood fill and of the similarity sets")
    dilate = Param(int, 8, min=0, max=256, doc="output pixels around a changed guide label that are synthesized again")

    def compute(self, ctx) -> Plate:
        from proxyshade.synthesis.edit import changed_region
        from proxyshade.synthesis.edit_colour import edit_synthesis

        prev, region = ctx.previous, None
        if prev is not None:
            region = changed_region(prev.inputs, {"guide": ctx.guide, "source": ctx.source},
                                    {"guide": ("label.id",), "source": ("R", "G", "B", "label.id")}, ctx.p.dilate)
        out = edit_synthesis(ctx.guide, ctx.source, EditSynthesis.of(ctx.p, "seed"),
                             previous=prev.plate if region is not None else None, region=region, note=ctx.note,
                             memo=ctx.memo, tiles=ctx.tiles)
        e = out.meta["edit"]
        ctx.note(f"{'whole frame' if e['whole'] else 'progressive'}: {e['pixels']} pixels ({100 * e['share']:.2f}%) "
                 f"synthesized, {e['synthesis_pixels']} synthesis pixels")
        return out
