"""HybridSynth: one structured image hybrid per frame from an exemplar atlas.

E. Risser, C. Han, R. Dahyot and E. Grinspun, "Synthesizing Structured Image Hybrids"
(SIGGRAPH 2010): coarse to
fine, the pointers into the exemplars are upsampled, jittered among candidates whose
neighbourhoods match (structure-preserving jitter, threshold ``J``) and corrected
(Lefebvre and Hoppe 2005). Layer: ``proxyshade.synthesis.hybrid``; kernels
``proxyshade.kernels.hybrid``.
"""
from __future__ import annotations

from proxyshade.graph.node import Input, Node, Param


class HybridSynth(Node):
    """A hybrid of the atlas's exemplars, seeded by the frame (``--frames 1-8``: 8 hybrids).

    Output, an annotated source for PatchInit/Correct/Magnify/Poisson: ``R,G,B`` and
    ``label.id`` looked up at the pointers, ``exemplar.id`` (which exemplar each pixel
    came from), ``atlas.x/y`` (the pointer: atlas column and row), the atlas's label table
    in ``meta["labels"]``. The analysis (Gaussian stack, PCA, candidate sets) is computed once per
    atlas and kept in memory for the run.
    """

    # 5: ramp_cell (the ramp dithered); 4: level_weights, ramp, symmetric; 3: the Gaussian stack and the finer
    # levels, each scaled (and J 0.1 by default); 2: candidates from the coarser, per-level scaled descriptor
    version = 5
    time_dependent = True
    atlas = Input("exemplar atlas: R,G,B, label.id, exemplar.id and meta['atlas']",
                  channels=("R", "G", "B", "label.id", "exemplar.id"), finite=("R", "G", "B"),
                  dtype={"label.id": "uint32", "exemplar.id": "uint32"}, fix="connect an ExemplarAtlas node")
    J = Param(float, 0.1, min=0.0, max=1.0, doc="jitter threshold: 0 keeps the best match, 1 any candidate "
                                                 "(0.3: more mixing, regions break into blotches)")
    weights = Param(list, [], doc="one weight >= 0 per exemplar biasing the mix (d_i / weight); empty: all 1")
    level_weights = Param(list, [], doc="per-level weights, coarsest level first: a list of rows, one weight >= 0 "
                                        "per exemplar (e.g. [[1, 0], [0, 1]]: exemplar 1's layout, exemplar 2's "
                                        "detail); the last row repeats for the finer levels; empty: all 1")
    ramp = Param(list, [], doc="a per-pixel weight map: a smooth transition across the output through these "
                               "exemplars (1-based, e.g. [1, 2]: all 1 at the left, all 2 at the right); others "
                               "weigh 0; empty: none")
    ramp_axis = Param(str, "x", choices=("x", "y"), doc="the ramp's direction: x left to right, y top to bottom")
    ramp_cell = Param(int, 8, min=0, max=512, doc="the ramp's patch size in pixels: each pixel prefers one exemplar, "
                                                  "drawn by a noise this smooth against the ramp's weights, so each "
                                                  "exemplar's share follows its weight across the output; 0: the "
                                                  "plain weights (a narrow switch)")
    symmetric = Param(bool, False, doc="mirror the left half onto the right at every level (symmetric exemplars, "
                                       "e.g. aligned faces)")
    size = Param(list, None, optional=True, length=2, doc="[width, height] of the hybrid; default the exemplar size")
    levels = Param(int, 6, min=1, max=12, doc="synthesis levels (coarsest spacing 2^(levels-1))")
    descriptor_levels = Param(int, 8, min=1, max=12, doc="L: successive finer levels (each scaled to unit RMS) concatenated in the candidates' descriptor")
    candidates = Param(int, 2, min=1, max=4, doc="candidates per exemplar and pixel")
    jitter_levels = Param(int, None, optional=True, min=1, max=12,
                          doc="jitter only the finest this many levels (less variation; default: every level)")
    passes = Param(int, 2, min=0, max=8, doc="correction passes per level")
    coherence = Param(float, 0.3, min=0.0, max=1.0, doc="cost factor of the coherent candidates in the correction "
                                                        "(1: none; lower copies larger pieces: sharper, less mixed)")
    iterations = Param(int, 4, min=1, max=16, doc="PatchMatch iterations of the candidate search (finest level)")

    def compute(self, ctx):
        import numpy as np

        from proxyshade.synthesis import hybrid as H

        p, atlas = ctx.p, ctx.atlas
        nb, bh, bw = H.atlas_boxes(atlas)
        H.check_levels(p.levels, bh, bw)
        w = H.check_weights(p.weights, nb)
        lw = H.check_level_weights(p.level_weights, nb)
        ramp = H.check_ramp(p.ramp, nb)
        if p.size is not None:
            if not all(isinstance(v, int) and not isinstance(v, bool) and v >= 1 for v in p.size):
                raise ctx.error(f"size: expected [width, height] of positive integers, got {p.size}; write e.g. [256, 256]")
            shape = (p.size[1], p.size[0])
        else:
            shape = (bh, bw)
        an = H.analysis_of(atlas, bw, levels=p.levels, descriptor_levels=p.descriptor_levels, q=p.candidates,
                           iterations=p.iterations, memo=ctx.memo)
        wmap = (H.ramp_weights(shape, ramp, nb, axis=1 if p.ramp_axis == "x" else 0, cell=p.ramp_cell, seed=ctx.frame)
                if ramp else None)
        coords = H.synthesize(an, shape, jitter_threshold=p.J, seed=ctx.frame, weights=w, passes=p.passes,
                         jitter_levels=p.jitter_levels, level_weights=lw, weight_map=wmap, symmetric=p.symmetric,
                         coherence=p.coherence)
        out = H.hybrid_plate(atlas, coords, {"J": p.J, "seed": ctx.frame, "weights": [float(v) for v in w],
                                        "level_weights": [] if lw is None else lw.tolist(),
                                        "ramp": [e + 1 for e in ramp], "ramp_cell": p.ramp_cell,
                                        "symmetric": bool(p.symmetric),
                                        "coherence": p.coherence})
        share = np.bincount(coords[..., 1].ravel() // bw, minlength=nb) / coords[..., 0].size
        ctx.note(f"hybrid {shape[1]}x{shape[0]} from {nb} exemplars (shares "
                 + ", ".join(f"{s:.0%}" for s in share) + f"); analysis {an.seconds:.1f} s")
        return out
