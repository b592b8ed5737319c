"""Fog over the whole composite: exponential fog by depth with an exponential height falloff.

Reference: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010.

Bonneel et al. 2010, §7: the layered representation with extended depth allows
"compositing effects such as fog". The model and its closed form are in
``proxyshade.kernels.fog``.
"""
from __future__ import annotations

import lazy_loader

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate

np = lazy_loader.load("numpy")  # on first use: a fully cached run never loads numpy

AXES = {"X": 0, "Y": 1, "Z": 2}


def camera_position(meta: dict) -> np.ndarray | None:
    """The camera's world position from ``meta["camera"]``, or None.

    Accepts ``position`` (or ``eye``), or a 4x4 camera-to-world matrix under
    ``camera_to_world``/``cam_to_world``/``transform`` in USD's row-vector convention
    (translation in the last row) or the column-vector one (translation in the last column).
    """
    cam = meta.get("camera")
    if not isinstance(cam, dict):
        return None
    for k in ("position", "eye"):
        if k in cam:
            return np.asarray(cam[k], np.float64).reshape(3)
    for k in ("camera_to_world", "cam_to_world", "transform"):
        if k in cam:
            m = np.asarray(cam[k], np.float64).reshape(4, 4)
            if np.allclose(m[:3, 3], 0) and m[3, 3] == 1:
                return m[3, :3].copy()
            return m[:3, 3].copy()
    return None


def up_axis(meta: dict, choice: str) -> str:
    """'X', 'Y' or 'Z': ``choice`` unless 'auto', then the scene's (meta up_axis) or 'Y'."""
    if choice != "auto":
        return choice
    cam = meta.get("camera") if isinstance(meta.get("camera"), dict) else {}
    ax = str(meta.get("up_axis") or cam.get("up_axis") or "Y").upper()
    return ax if ax in AXES else "Y"


class Fog(Node):
    """Exponential height fog by depth over a composite (R,G,B[,A], Z[, P]).

    Transmittance ``T = exp(-tau)``: uniform fog (``height_falloff = 0``) has
    ``tau = density * d``; with a falloff the density is ``density * exp(-falloff *
    (height - base_height))`` integrated along the ray from the camera to the point
    (needs ``P.<up>`` and the camera position in ``meta["camera"]``). ``d`` is the depth
    ``Z`` (``distance: depth``) or the Euclidean distance camera->P (``distance: range``).
    Pixels with infinite depth (sky) get ``sky`` as their fog amount ``1 - T``. Colour
    becomes ``rgb*T + colour*(1 - T)`` (times A where the plate has alpha).
    """

    version = 1
    image = Input("composite with R,G,B, Z (P.X/P.Y/P.Z for height falloff or range)", channels=("R", "G", "B", "Z"))
    colour = Param(list, [0.62, 0.68, 0.75], length=3, doc="linear fog colour")
    density = Param(float, 0.02, min=0.0, doc="extinction per world unit at base_height")
    height_falloff = Param(float, 0.0, min=0.0, doc="per world unit; 0 = uniform fog")
    base_height = Param(float, 0.0, doc="height (along the up axis) where density applies")
    sky = Param(float, 1.0, min=0.0, max=1.0, doc="fog amount where Z is inf (1 = fog colour)")
    distance = Param(str, "depth", choices=("depth", "range"), doc="Z, or |P - camera|")
    up_axis = Param(str, "auto", choices=("auto", "X", "Y", "Z"), doc="auto: meta up_axis, else Y")
    camera_height = Param(float, None, optional=True,
                          doc="camera height along the up axis; default from meta camera")

    def compute(self, ctx) -> Plate:
        from proxyshade.kernels import fog as kfog

        img: Plate = ctx.image
        p = ctx.p
        try:
            colour = [float(c) for c in p.colour]
        except (TypeError, ValueError):
            raise ctx.error(f"colour {p.colour!r} is not three numbers; write e.g. [0.6, 0.7, 0.8]") from None
        z = img["Z"].astype(np.float64)
        sky = ~np.isfinite(z)
        need_p = p.distance == "range" or p.height_falloff > 0
        axis = up_axis(img.meta, p.up_axis)
        cam = camera_position(img.meta)
        if need_p:
            missing = [n for n in ("P.X", "P.Y", "P.Z") if n not in img]
            if missing:
                raise ctx.error(f"height falloff and distance 'range' need {', '.join(missing)}; "
                                "set height_falloff: 0 and distance: depth, or feed a plate with P")
            if cam is None and (p.distance == "range" or p.camera_height is None):
                raise ctx.error("no camera position in meta['camera'] (position or camera_to_world); "
                                "set camera_height and distance: depth, or feed the proxy's plate metadata")
        zf = np.where(sky, 0.0, z)
        if p.distance == "range":
            pw = img.layer(["P.X", "P.Y", "P.Z"], np.float64)
            d = np.linalg.norm(pw - cam.reshape(1, 1, 3), axis=-1)
            d = np.where(sky | ~np.isfinite(d), 0.0, d)
        else:
            d = zf
        if p.height_falloff > 0:
            y0 = p.camera_height if p.camera_height is not None else float(cam[AXES[axis]])
            y1 = img[f"P.{axis}"].astype(np.float64)
            y1 = np.where(np.isfinite(y1), y1, y0)
            tau = kfog.optical_depth(d, y0 - p.base_height, y1 - p.base_height, p.density, p.height_falloff)
        else:
            tau = kfog.optical_depth(d, 0.0, 0.0, p.density, 0.0)
        alpha = img["A"].astype(np.float64) if "A" in img else None
        rgb = img.layer("RGB", np.float64)
        out = kfog.apply_fog(rgb, tau, colour, alpha=alpha, sky=sky, sky_amount=p.sky)
        return img.with_channels({"R": out[..., 0].copy(), "G": out[..., 1].copy(), "B": out[..., 2].copy()})
