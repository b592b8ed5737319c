"""Resynthesize: texture synthesis restricted to the pixels Reproject flagged (paper §6.3).

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
from proxyshade.synthesis.params import Correction, FloodFill, PoissonSolve, source_input


class Resynthesize(FloodFill, Correction, PoissonSolve, Progressive, Node):
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
    extend_correction = Param(bool, False,
                              doc="continue the kept pixels' carried correction (the first frame's layout and "
                                  "seam corrections) onto the flagged pixels before the solve, as the harmonic "
                                  "function with their values, so a redone region keeps the tone around it instead "
                                  "of the plain source's (farm's water); off by default: the continuation crosses "
                                  "label borders and raises lake's water (docs/temporal.md)")
    kept_as_one = Param(bool, False,
                        doc="the restricted solve sees every kept pixel as one patch: between two kept pixels their "
                            "own difference, an edge touching a flagged pixel the source's gradient (inside a patch "
                            "too: a re-anchored region keeps no step of the carried correction at its border); "
                            "false: the patch ids as they are (kept pixels' seams in the solve blended again)")
    solve_margin = Param(int, 0, min=0, max=64,
                         doc="kept pixels within this many pixels of a flagged one are solved too, their own "
                             "differences kept (only a smooth change): a thin flagged band between two kept regions "
                             "spreads their mismatch over the ring instead of into its few seams, which the next "
                             "frames carry (the gradient creep, docs/temporal.md); 0: the flagged pixels only")
    sor_thickness = Param(float, 32.0, min=0.0,
                          doc="restricted-Poisson regions at most this thick (2 x area / perimeter, pixels) are "
                              "solved by SOR on their own pixels, not by multigrid in a window around them (the "
                              "same system, to the solver's tol); 0: only regions in small boxes")

    def compute(self, ctx) -> Plate:
        from proxyshade.synthesis.resynthesis import resynthesize, resynthesize_update

        if ctx.previous is not None and ctx.p.solve:
            prev = ctx.previous
            out = resynthesize_update(prev.plate, prev.inputs.get("image"), ctx.image, ctx.source,
                                      prev.inputs.get("source"), ctx.p, ctx.frame, note=ctx.note, memo=ctx.memo,
                                      tiles=ctx.tiles)
            if out is not None:
                return out
        return resynthesize(ctx.image, ctx.source, ctx.p, ctx.frame, note=ctx.note, memo=ctx.memo, tiles=ctx.tiles)
