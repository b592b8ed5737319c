"""DepthExtend: the proxy depth carried out to the detailed guide's new borders.

Reference: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010.

Bonneel et al. 2010, §4.3 and §7: where the detailed guide keeps the proxy's label the
proxy depth stays; elsewhere a pixel takes the depth of the closest pixel having the same
label both in the proxy and in the detailed guide, found by jump flooding
(``proxyshade.kernels.jfa``). World positions are recomputed from the extended depth
through the proxy's camera, so ``P`` matches ``Z`` at every pixel.
"""
from __future__ import annotations

from proxyshade.graph.node import Input, Node, Param, Progressive
from proxyshade.graph.plate import Plate


class DepthExtend(Progressive, Node):
    """Extend the proxy depth ``Z`` to the detailed guide (``guide``'s ``label.id``).

    Output: the guide plate with ``Z`` and ``P.X/P.Y/P.Z`` replaced by the extended ones
    (``Z`` stays inf where the extended label has no depth, the sky; ``P`` unprojected
    from ``Z`` through meta["camera"], or without a camera copied from the pixel the depth
    came from), ``N.X/Y/Z`` and ``object.id`` (when the proxy has them) of the pixel the
    depth came from, and ``depth.src``
    (uint32: 1 + the flat index of the pixel the depth came from).
    """

    version = 2
    proxy = Input("ProxyRender plate: label.id, Z, camera metadata", channels=("label.id", "Z"))
    guide = Input("the detailed guide (GuideSynth): label.id at the proxy's size", channels=("label.id",))
    penalty = Param(float, 1024.0, min=0.0,
                    doc="added to the squared distance (pixels²) of a seed with another label: 1024 prefers "
                        "a same-label seed up to 32 pixels further away")

    dilate = Param(int, 8, min=0, max=256, doc="progressive: pixels around a changed proxy or guide pixel whose "
                                              "depth is recomputed")

    def compute(self, ctx) -> Plate:
        from proxyshade.synthesis.depth import depth_plate

        proxy, guide, p = ctx.proxy, ctx.guide, ctx.p
        region = None
        if ctx.previous is not None:  # the edit kernels are loaded only for a progressive update
            from proxyshade.synthesis.edit import changed_region

            region = changed_region(ctx.previous.inputs, {"proxy": proxy, "guide": guide},
                                    {"proxy": ("label.id", "Z"), "guide": ("label.id",)}, p.dilate)
            if region is not None:
                ctx.note(f"progressive: {int(region.sum())} of {region.size} pixels recomputed")
        return depth_plate(proxy, guide, penalty=p.penalty, region=region,
                           previous=ctx.previous.plate if region is not None else None)
