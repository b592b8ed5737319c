"""Relight: a synthesized frame re-applied to another photo of the same view.

Reference: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010.

Bonneel et al. 2010, §8 (time-lapse): the frame's map (``source.x/y``, ``patch.id``)
reads the other photo through the same lookup, and the Poisson solve blends the seams
over the whole frame with that photo's gradients; no new matching, so a series of photos
of one view (noon, dusk, night: ``images`` in the source table, ``SourceRead.photo``)
gives a series of frames with the same texture layout. Layer:
``proxyshade.synthesis.relight``.
"""
from __future__ import annotations

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate
from proxyshade.synthesis.params import PoissonSolve, source_input


class Relight(PoissonSolve, Node):
    """``image``'s colours read from ``source`` (another photo of the view the frame was
    synthesized from) through its map, then Poisson-blended over the whole frame.

    Output: ``image`` with ``R,G,B`` replaced (every other channel passes through, a
    camera move's ``correction.*`` dropped); metadata ``source`` (the photo read) and
    ``relight`` (photo name, filter, the solve's iterations and residual). With the photo
    the frame was made from, a first frame is reproduced bit for bit.
    """

    version = 1
    image = Input("a synthesized frame (Poisson's or Resynthesize's output): source.x/y, patch.id, label.id",
                  channels=("source.x", "source.y", "patch.id"), finite=("source.x", "source.y"),
                  fix="connect the final synthesized frame")
    source = source_input("the other photo of the view (SourceRead with photo: ...)")
    filter = Param(str, "auto", choices=("auto", "bilinear", "lanczos3", "lanczos4"),
                   doc="reconstruction of the photo at the map's positions; auto: the frame's own (bilinear for "
                       "a first frame, the camera move's filter for later frames)")

    def compute(self, ctx) -> Plate:
        from proxyshade.synthesis.relight import relight

        out, info = relight(ctx.image, ctx.source, PoissonSolve.of(ctx.p), filter=ctx.p.filter, memo=ctx.memo)
        ctx.note(f"relit from {out.meta['source'].get('image', '?')}: {info['iterations']} iterations, "
                 f"relative residual {info['residual']:.1e}")
        return out
