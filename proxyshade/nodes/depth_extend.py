"""DepthExtend: the proxy depth carried out to the detailed guide's new borders.

Bonneel et al. 2010, §4.3 and §7: where the detailed guide keeps the proxy's label the
proxy depth stays; elsewhere a pixel takes the depth of the closest pixel having the same
label both in the proxy and in the detailed guide, found by jump flooding
(``proxyshade.kernels.jfa``). World positions are recomputed from the extended depth
through the proxy's camera, so ``P`` matches ``Z`` at every pixel.
"""
from __future__ import annotations

import numpy as np

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate


def extend_depth(proxy_labels: np.ndarray, guide_labels: np.ndarray, z: np.ndarray, *, penalty: float = 1024.0
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Extended depth (H, W) float32 and the flat index of the pixel each depth came from."""
    from proxyshade.kernels.jfa import jump_flood

    keep = proxy_labels == guide_labels
    src = jump_flood(keep, guide_labels, proxy_labels, penalty=penalty)
    flat = z.reshape(-1)
    out = np.where(src >= 0, flat[np.maximum(src, 0)], np.inf).astype(np.float32)
    out[keep] = z[keep]
    return out, src


class DepthExtend(Node):
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

    def compute(self, ctx) -> Plate:
        from proxyshade.io.usd import CameraInfo

        proxy, guide = ctx.proxy, ctx.guide
        if proxy.shape != guide.shape:
            raise ctx.error(f"guide is {guide.width}x{guide.height} but proxy is {proxy.width}x{proxy.height}; "
                            "synthesize the guide at the proxy's size")
        z = proxy["Z"].astype(np.float32)
        if np.isnan(z).any():
            raise ctx.error("proxy Z has NaN values; re-render the proxy")
        ext, src = extend_depth(proxy["label.id"], guide["label.id"], z, penalty=ctx.p.penalty)
        ch = {"Z": ext, "depth.src": (src + 1).astype(np.uint32)}
        cam = proxy.meta.get("camera")
        if cam:
            c = CameraInfo.from_meta(cam)
            cols, rows = c.pixel_grid()
            finite = np.isfinite(ext)
            P = c.unproject(cols, rows, np.where(finite, ext, 1.0))
            for k, a in enumerate("XYZ"):
                ch[f"P.{a}"] = np.where(finite, P[..., k], 0.0).astype(np.float32)
        elif all(f"P.{a}" in proxy for a in "XYZ"):
            # no camera to unproject with: P of the pixel the depth came from
            flat = np.maximum(src, 0).reshape(-1)
            for a in "XYZ":
                pa = proxy[f"P.{a}"].astype(np.float32)
                ch[f"P.{a}"] = np.where(src >= 0, pa.reshape(-1)[flat].reshape(pa.shape), pa).astype(np.float32)
        # normals and object ids follow the depth: those of the pixel it came from
        flat = np.maximum(src, 0).reshape(-1)
        for c in ("N.X", "N.Y", "N.Z", "object.id"):
            if c in proxy:
                a = proxy[c]
                ch[c] = np.where(src >= 0, a.reshape(-1)[flat].reshape(a.shape), a).astype(a.dtype, copy=False)
        return guide.with_channels(ch, meta={"camera": cam} if cam else None)
