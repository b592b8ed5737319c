"""ExemplarAtlas: pack 1..8 annotated exemplars into one atlas plate.

Risser, Han, Dahyot and Grinspun (SIGGRAPH 2010, structured image hybrids) synthesize from several roughly aligned
exemplars at once; the state points into this atlas. Layer:
``proxyshade.synthesis.hybrid.pack_atlas``.
"""
from __future__ import annotations

from proxyshade.graph.node import Node, Param
from proxyshade.synthesis.params import source_input

SLOTS = tuple(f"exemplar{k}" for k in range(1, 9))


class ExemplarAtlas(Node):
    """Pack up to 8 SourceRead plates (connected to ``exemplar1`` .. ``exemplar8``, in that
    order) side by side, each centre-cropped to the box aspect and resampled to ``size``.

    Output: ``R,G,B`` (linear float32), ``label.id`` (uint32, the shared table's ids),
    ``exemplar.id`` (uint32, 1..n: which exemplar a pixel belongs to); ``meta["labels"]``
    the shared label table, ``meta["atlas"]`` the boxes (id, input, x, y, w, h, source).
    ``source.x/y`` are not written: they stay source-pixel coordinates of a synthesis.
    All exemplars must share one label table (names and ids).
    """

    version = 2  # 2: split
    exemplar1 = source_input("annotated exemplar 1 (SourceRead)", optional=True)
    exemplar2 = source_input("annotated exemplar 2", optional=True)
    exemplar3 = source_input("annotated exemplar 3", optional=True)
    exemplar4 = source_input("annotated exemplar 4", optional=True)
    exemplar5 = source_input("annotated exemplar 5", optional=True)
    exemplar6 = source_input("annotated exemplar 6", optional=True)
    exemplar7 = source_input("annotated exemplar 7", optional=True)
    exemplar8 = source_input("annotated exemplar 8", optional=True)
    size = Param(list, [256, 256], length=2, doc="[width, height] of each exemplar's box in the atlas")
    split = Param(int, 1, min=1, max=8, doc="each connected source holds this many exemplars side by side "
                                             "(a bundled set as one strip, samples/hybrids): cut it into them")

    def compute(self, ctx):
        from proxyshade.synthesis.hybrid import pack_atlas, split_plate

        size = ctx.p.size
        if not all(isinstance(v, int) and not isinstance(v, bool) and v >= 1 for v in size):
            raise ctx.error(f"size: expected [width, height] of positive integers, got {size}; write e.g. [256, 256]")
        plates = [(k, getattr(ctx, k)) for k in SLOTS if getattr(ctx, k) is not None]
        if ctx.p.split > 1:
            plates = [part for k, p in plates for part in split_plate(k, p, ctx.p.split)]
        out = pack_atlas(plates, (size[1], size[0]))
        ctx.note(f"{len(plates)} exemplars at {size[0]}x{size[1]}")
        return out

