"""Shadows of CG prims on the synthesized scene by modulative shadow mapping.

Reference: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010.

Bonneel et al. 2010, §7: CG elements "can then cast shadows into the scene by simple
modulative shadow mapping using the extended depth map". The occluders' depth is
rendered from the scene's UsdLux.DistantLight through an orthographic projection with the
proxy rasterizer; every synthesized pixel's world position ``P`` (from the extended
depth) is tested against it with percentage-closer filtering (``proxyshade.kernels.shadow``).
"""
from __future__ import annotations

from pathlib import Path

import lazy_loader

from proxyshade.errors import UserError
from proxyshade.graph import keys
from proxyshade.graph.node import Input, Node, Param, resolve_path
from proxyshade.graph.plate import Plate

np = lazy_loader.load("numpy")  # on first use: a fully cached run never loads numpy


def light_depth_map(prims: list, direction, size: int) -> tuple[np.ndarray, dict]:
    """(size, size) occluder depth of ``prims`` seen from a distant light, and its projection
    (see ``shadow.ortho_light_projection``)."""
    from proxyshade.io import usd
    from proxyshade.kernels import raster, shadow

    wp, tris, _, _ = usd.world_meshes(prims)
    proj = shadow.ortho_light_projection(direction, wp, size)
    m = proj["world_to_cam"]
    cam_pts = wp @ m[:, :3].T + m[:, 3]
    depth, _, _, _ = raster.rasterize(cam_pts, tris, width=size, height=size, fx=proj["fx"], fy=proj["fy"],
                                      cx=proj["cx"], cy=proj["cy"], near=0.5, ortho=True)
    return depth, proj


class ShadowMap(Node):
    """Darken the synthesized plate where the scene's CG prims block the distant light.

    Each pixel's colour is multiplied by ``1 - (1 - factor) * s`` where ``s`` in [0, 1] is
    the fraction of PCF taps in shadow (``(2 radius + 1)^2`` taps one texel apart, each
    bilinearly weighted: soft edges about ``2 radius + 1`` texels wide). The shadow map is
    ``size`` x ``size`` texels framing the CG prims as seen from the light. Pixels with no
    finite ``P`` or ``Z`` (sky) are never shadowed. Adds the AOV ``shadow`` (= ``s``) and
    ``meta['light']``. CG prims but no DistantLight: shadows are skipped with a warning
    naming the missing prim; no CG prims: the plate passes through (``shadow`` = 0).
    """

    version = 1
    time_dependent = True
    image = Input("synthesized plate with R,G,B and world position P.X/P.Y/P.Z",
                  channels=("R", "G", "B", "P.X", "P.Y", "P.Z"),
                  fix="connect the synthesized plate with its world position (Magnify with DepthExtend's depth)")
    scene = Param(Path, doc="USD stage with CG prims (proxyshade:cg) and a UsdLux.DistantLight")
    factor = Param(float, 0.35, min=0.0, max=1.0, doc="colour multiplier in full shadow")
    size = Param(int, 1024, min=16, max=8192, doc="shadow-map texels per side")
    radius = Param(int, 1, min=0, max=16, doc="PCF radius in texels (0: bilinear test only)")
    bias = Param(float, 0.0, min=0.0, doc="depth tolerance in world units along the light")

    def key_extra(self, frame, graph_dir):
        path = resolve_path(self.params["scene"], graph_dir, frame)

        def scene_digest():
            from proxyshade.io import usd

            return usd.cg_digest(path, frame)

        return keys.node_memo(self, [str(path), frame], scene_digest)  # USD loaded only when the scene changes

    def compute(self, ctx) -> Plate:
        from proxyshade.io import usd
        from proxyshade.kernels import shadow

        img: Plate = ctx.image
        p = ctx.p
        try:
            stage = usd.open_stage(ctx.path(p.scene))
            usd.check_frame(stage, ctx.frame)
        except UserError as e:
            raise ctx.error(str(e)) from None
        prims = sorted((q for q in usd.scene_prims(stage, ctx.frame) if q.cg), key=lambda q: q.path)
        light = usd.distant_light(stage, ctx.frame)
        none = np.zeros(img.shape, np.float32)
        if not prims:
            ctx.note("the scene has no CG prims (bool proxyshade:cg = true); nothing casts a shadow")
            return img.with_channels({"shadow": none}, {"light": light})
        if light is None:
            ctx.warn(usd.no_light_message(prims, "shadows skipped"))
            return img.with_channels({"shadow": none}, {"light": None})
        depth, proj = light_depth_map(prims, light["direction"], p.size)
        P = img.layer(["P.X", "P.Y", "P.Z"], np.float64)
        if "Z" in img:  # renders leave P at 0 where nothing is (Z = inf): never a receiver
            P[~np.isfinite(img["Z"])] = np.nan
        s = shadow.pcf_shadow(P, proj["world_to_map"], depth, radius=p.radius, bias=p.bias)
        mult = (1.0 - (1.0 - p.factor) * s.astype(np.float64))
        out = {c: (img[c].astype(np.float64) * mult).astype(np.float32) for c in ("R", "G", "B")}
        out["shadow"] = s
        ctx.note(f"shadow map {p.size}x{p.size}, texel {proj['texel']:.4g} world units, "
                 f"{int((s > 0.5).sum())} pixels in shadow")
        return img.with_channels(out, {"light": light})
