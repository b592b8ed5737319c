"""BtfSheet: a BTF stack laid out as one picture (a contact sheet), for Preview.

Reference: A. Neubeck, A. Zalesny, L. Van Gool, "Viewpoint Consistent Texture Synthesis",
3DPVT 2004."""
from __future__ import annotations

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate


class BtfSheet(Node):
    """Tile the views of a stack into one R,G,B plate: a row per slant (the frontal view
    first, alone), a column per tilt, ``gap`` black pixels between cells. ``crop`` keeps the
    top-left ``crop``² pixels of each view at 100% (0: whole views)."""

    version = 1
    stack = Input("BTF stack (v{n}.R/G/B, meta views)", fix="connect BtfRender, BtfRead, BtfAlign or BtfSynth")
    gap = Param(int, 2, min=0, max=64, doc="black pixels between views")
    crop = Param(int, 0, min=0, doc="top-left pixels of each view to show (0: all)")

    def compute(self, ctx) -> Plate:
        from proxyshade.synthesis import btf

        views, imgs = btf.stack_arrays(ctx.stack)
        c = ctx.p.crop or max(imgs.shape[1:3])
        sheet = btf.contact_sheet(imgs[:, :c, :c], views, gap=ctx.p.gap)
        return Plate({c: sheet[..., i] for i, c in enumerate("RGB")}, {"views": views})
