"""Resynthesize: texture synthesis restricted to the pixels Reproject flagged (paper §6.3).

Reference: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010.

The first frame's steps (flood fill, correction, magnification, Poisson) run again on the
flagged pixels only, with the unflagged ones as fixed context and Dirichlet values; see
``proxyshade.synthesis.resynthesis`` for how. Unflagged pixels keep Reproject's colours
and map exactly. With ``solve: false``, follow with ``Poisson`` with ``keep`` = this plate
(mask channel ``flag``) for the restricted solve.

Progressive (``progressive: true``, after an edit of the first frame, Bonneel et al. 2010,
§7): pixels whose input is the same as in the last run keep that run's result bit for bit;
the changed ones take the new input and those flagged are resynthesized with the rest as
context (``resynthesis.resynthesize_update``).
"""
from __future__ import annotations

from proxyshade.graph.node import Input, Node, Param, Progressive
from proxyshade.graph.plate import Plate
from proxyshade.synthesis.params import Resynthesis, source_input


class Resynthesize(Resynthesis, Progressive, Node):
    """Flagged pixels resynthesized with the first-frame steps; the rest kept.

    Output at the input's size: the input's channels with ``R,G,B`` (the source through
    the new map), ``source.x/y`` and ``patch.id`` (new ids above the carried ones)
    replaced where ``flag`` is non-zero; metadata ``resynthesis`` (pixel counts).
    """

    version = 1
    time_dependent = True  # seeds vary per frame
    image = Input("Reproject's output: flag, label.id, source.x/y, patch.id, R,G,B",
                  channels=("flag", "label.id", "source.x", "source.y", "patch.id", "R", "G", "B"),
                  finite=("source.x", "source.y", "R", "G", "B"), fix="connect Reproject's output")
    source = source_input("annotated source (SourceRead), the one of the first frame")
    factor = Param(int, None, min=1, max=64, doc="output pixels per synthesis pixel (default: the first frame's)")
    scale = Param(float, None, min=0.01, max=100.0, doc="source pixels per output pixel (default: the first frame's)")
    seed = Param(int, 0, doc="seed of the flood fill (combined with the frame number) and of the similarity sets")
    solve = Param(bool, True, doc="finish with the restricted Poisson solve (Dirichlet outside the flagged pixels); "
                                  "false leaves it to a Poisson node with keep")

    def compute(self, ctx) -> Plate:
        from proxyshade.synthesis.resynthesis import resynthesize, resynthesize_update

        p = Resynthesis.of(ctx.p, "factor", "scale", "seed", "solve")
        if ctx.previous is not None and p.solve:
            prev = ctx.previous
            out = resynthesize_update(prev.plate, prev.inputs.get("image"), ctx.image, ctx.source,
                                      prev.inputs.get("source"), p, ctx.frame, note=ctx.note, memo=ctx.memo,
                                      tiles=ctx.tiles)
            if out is not None:
                return out
        return resynthesize(ctx.image, ctx.source, p, ctx.frame, note=ctx.note, memo=ctx.memo, tiles=ctx.tiles)
