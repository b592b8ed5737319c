"""BtfAlign: rectify a BTF stack to the plane that makes neighbouring views agree.

Neubeck, Zalesny and Van Gool (3DPVT 2004): "choosing the alignment plane which minimizes
the average Euclidean distance between the intensities of neighboring views sharing the
same lighting direction … with respect to the four neighboring camera positions", tried
over "several plane positions". Layer: ``proxyshade.synthesis.btf.alignment_costs`` and
``rectify`` (``kernels.lookup``); kernel ``proxyshade.kernels.btf.edge_distance``.
"""
from __future__ import annotations

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate


class BtfAlign(Node):
    """Rectify a BTF stack to the plane that makes neighbouring views agree.

    Tries ``steps`` planes parallel to the stack's, from ``-search`` to ``+search`` times
    the views' width (world units) around it; keep the one with the least mean distance
    between neighbouring views of the grid and rectify every view to it (``filter``),
    cropped by the largest shift (no view reads past its border).

    Output: the rectified ``v{n}.R/G/B``; ``meta['btf']['plane']`` the chosen plane's height,
    ``meta['align']`` = {heights, costs} of every plane tried.
    """

    version = 1
    stack = Input("BTF stack (v{n}.R/G/B, meta views)", fix="connect a BtfRender or BtfRead node")
    search = Param(float, 0.1, min=0.0, max=0.5, doc="search half-range as a fraction of the views' width")
    steps = Param(int, 41, min=1, max=1001, doc="planes tried")
    filter = Param(str, "lanczos3", choices=("bilinear", "lanczos3", "lanczos4"), doc="resampling of the views")

    def compute(self, ctx) -> Plate:
        import numpy as np

        from proxyshade.synthesis import btf

        views, imgs = btf.stack_arrays(ctx.stack)
        meta = ctx.stack.meta["btf"]
        pixel, plane = float(meta.get("pixel", 1.0)), float(meta.get("plane", 0.0))
        half = ctx.p.search * imgs.shape[2] * pixel
        offsets = np.linspace(-half, half, ctx.p.steps) if ctx.p.steps > 1 else np.zeros(1)
        costs = btf.alignment_costs(imgs, views, pixel, offsets)
        best = int(np.argmin(costs))
        rect = btf.rectify(imgs, views, float(offsets[best]), pixel, filter=ctx.p.filter)
        m = btf.max_shift(views, float(offsets[best]), pixel) + 1
        rect = rect[:, m:imgs.shape[1] - m, m:imgs.shape[2] - m]
        chosen = plane + float(offsets[best])
        ctx.note(f"plane {chosen:.4g} (offset {offsets[best]:+.4g}, {best + 1} of {len(offsets)}); mean neighbour "
                 f"distance {costs[best]:.4f} against {costs.max():.4f} at worst")
        origin = [float(o) + m * pixel for o in meta.get("origin", (0.0, 0.0))]
        out_meta = dict(meta, plane=chosen, origin=origin)
        plate = btf.stack_plate(rect, views, out_meta)
        plate.meta["align"] = {"heights": [plane + float(o) for o in offsets], "costs": [float(c) for c in costs]}
        return plate
