"""GuideSynth: a detailed label guide synthesized from the proxy guide and the source's labels.

Bonneel et al. 2010, §4: the rendered proxy guide has smooth, unnatural borders; k-coherent
label synthesis (``proxyshade.kernels.guide``) with the Chamfer metric and a voting stack
transfers the source label map's border structure onto it. "To synthesize a 256×256
guide, we start the synthesis at the 64×64 level ... We use 5×5 neighborhoods and k = 5
coherent matches ... We do not use the jittering step."
"""
from __future__ import annotations

from proxyshade.graph.node import Input, Node
from proxyshade.graph.plate import Plate
from proxyshade.synthesis.params import Guidance


class GuideSynth(Guidance, Node):
    """Synthesize a detailed ``label.id`` from ``proxy``'s guide and ``source``'s label map.

    Output: the proxy plate with ``label.id`` replaced by the detailed guide at the proxy's
    size (synthesized at ``size``, magnified through the source coordinates so borders keep
    the source map's full-resolution detail), and ``source.x/source.y`` (the source pixel
    each guide pixel came from). Metadata ``guide`` records the synthesis settings.
    """

    version = 2
    proxy = Input("ProxyRender plate (label.id at the output size)", channels=("label.id",))
    source = Input("SourceRead plate (label.id and its label table)", channels=("label.id",))

    def compute(self, ctx) -> Plate:
        from proxyshade.synthesis.guide import synthesize_guide

        plate, note = synthesize_guide(ctx.proxy, ctx.source, Guidance.of(ctx.p))
        ctx.note(note)
        return plate
