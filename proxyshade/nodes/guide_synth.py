"""GuideSynth: a detailed label guide synthesized from the proxy guide and the source's labels.

Reference: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010.

Bonneel et al. 2010, §4: the rendered proxy guide has smooth, unnatural borders; k-coherent
label synthesis (``proxyshade.kernels.guide``) with the Chamfer metric and a voting stack
transfers the source label map's border structure onto it. "To synthesize a 256×256
guide, we start the synthesis at the 64×64 level ... We use 5×5 neighborhoods and k = 5
coherent matches ... We do not use the jittering step."
"""
from __future__ import annotations

from proxyshade.graph.node import Input, Node, Param, Progressive
from proxyshade.graph.plate import Plate
from proxyshade.synthesis.params import Guidance


class GuideSynth(Guidance, Progressive, Node):
    """Synthesize a detailed ``label.id`` from ``proxy``'s guide and ``source``'s label map.

    Output: the proxy plate with ``label.id`` replaced by the detailed guide at the proxy's
    size (synthesized at ``size``, magnified through the source coordinates so borders keep
    the source map's full-resolution detail), and ``source.x/source.y`` (the source pixel
    each guide pixel came from). Metadata ``guide`` records the synthesis settings.
    """

    version = 2
    proxy = Input("ProxyRender plate (label.id at the output size)", channels=("label.id",))
    source = Input("SourceRead plate (label.id and its label table)", channels=("label.id",))

    dilate = Param(int, 16, min=0, max=256, doc="progressive: output pixels around a changed proxy label that are "
                                               "synthesized again")
    context = Param(int, 32, min=0, max=1024, doc="progressive: output pixels of proxy around those synthesized with them")

    def compute(self, ctx) -> Plate:
        from proxyshade.synthesis.guide import synthesize_guide

        prev = ctx.previous
        if prev is not None:  # the edit kernels are loaded only for a progressive update
            from proxyshade.synthesis.edit import changed_region, update_guide

            region = changed_region(prev.inputs, {"proxy": ctx.proxy, "source": ctx.source},
                                    {"proxy": ("label.id",), "source": ("label.id",)}, ctx.p.dilate)
            if region is not None and not region.any():
                ctx.note("progressive: no proxy label changed")
                return ctx.proxy.with_channels({c: prev.plate[c] for c in ("label.id", "source.x", "source.y")},
                                               meta={k: prev.plate.meta[k] for k in ("labels", "guide")})
            if region is not None:
                plate, info = update_guide(prev.plate, region, ctx.proxy, ctx.source, Guidance.of(ctx.p),
                                           context=ctx.p.context, memo=ctx.memo)
                ctx.note(f"progressive: {info['region']} pixels changed, synthesized on window(s) "
                         + ", ".join(f"{w}x{h}" for w, h in info["windows"]) + (" (the whole frame)" if info["whole"] else ""))
                return plate
        plate, note = synthesize_guide(ctx.proxy, ctx.source, Guidance.of(ctx.p), memo=ctx.memo)
        ctx.note(note)
        return plate
