"""BtfShade: a labelled surface of a shot shaded from a synthesized BTF stack.

Neubeck, Zalesny and Van Gool, "Viewpoint consistent texture synthesis" (3DPVT 2004):
the stack's views all show one surface, so a surface shaded per pixel from the view
nearest its view direction shows the same bumps from every angle of a camera move. Layer:
``proxyshade.synthesis.btf.shade_surface``; kernel ``proxyshade.kernels.btf.shade_views``.
"""
from __future__ import annotations

import lazy_loader

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate

np = lazy_loader.load("numpy")  # on first use: a fully cached run never loads numpy


class BtfShade(Node):
    """Shade the pixels of ``label`` in a proxy render from a BTF stack (BtfSynth's output).

    Per pixel: texture coordinates from ``P`` (``scale`` world units per stack pixel, default
    the stack's own ``pixel``: the sample's true size; ``origin`` the world (x, z) of the
    stack's corner; the stack tiles the surface, seamlessly when BtfSynth's ``tile`` is on)
    by ``uv``: ``planar`` along Y, or ``terrain``: the labelled heightfield mesh's own grid,
    by arc length along its rows and columns (a texel keeps its size up a slope),
    and the direction toward the camera in the surface frame (``N`` up, world +X projected
    onto the surface as tilt 0°): bilinear between the four views around that (slant, tilt)
    on the stack's grid, each view read bilinearly. Directions beyond the grid take its
    nearest views (slant beyond the largest, a tilt outside the captured arc); the note
    says how many pixels. The light is the stack's: the views are used as they were lit.

    ``label``: a scene label (the proxy's ``meta['objects']``, through ``object.id``) or a
    source label (``label.id``). Output: ``R,G,B`` (``background`` elsewhere), ``A`` (1 on
    the label), the proxy's ``Z``, ``P``, ``N``, ``label.id``, ``object.id``, and
    ``btf.slant``/``btf.tilt`` (degrees), ``btf.u``/``btf.v`` (texture coordinates).
    """

    version = 1
    stack = Input("synthesized BTF stack (v{n}.R/G/B, meta views and btf)", fix="connect a BtfSynth node")
    proxy = Input("proxy render with world positions, normals and labels",
                  channels=("P.X", "P.Y", "P.Z", "N.X", "N.Y", "N.Z", "label.id", "object.id"),
                  finite=("P.X", "P.Y", "P.Z", "N.X", "N.Y", "N.Z"), fix="connect a ProxyRender node")
    label = Param(str, doc="the label to shade: a scene label (e.g. bumps) or a source label")
    scale = Param(float, None, optional=True, min=1e-9, doc="world units per stack pixel (default: the stack's pixel)")
    origin = Param(list, [0.0, 0.0], length=2, doc="world (x, z) of the stack's pixel corner (0, 0)")
    uv = Param(str, "planar", choices=("planar", "terrain"),
               doc="texture coordinates: planar along Y, or the terrain mesh's own grid (arc length)")
    background = Param(list, [0.0, 0.0, 0.0], length=3, doc="linear RGB of the pixels off the label")

    def compute(self, ctx) -> Plate:
        from proxyshade.io.usd import CameraInfo
        from proxyshade.synthesis import btf

        p = ctx.p
        views, imgs = btf.stack_arrays(ctx.stack)
        proxy = ctx.proxy
        if "camera" not in proxy.meta:
            raise ctx.error("proxy: the plate has no meta['camera']; connect a ProxyRender node")
        for name, val in (("origin", p.origin), ("background", p.background)):
            if not all(isinstance(x, (int, float)) and not isinstance(x, bool) and np.isfinite(x) for x in val):
                raise ctx.error(f"{name} {val} must be numbers")
        mask = self._mask(ctx, proxy, p.label)
        eye = CameraInfo.from_meta(proxy.meta["camera"]).position
        P = np.stack([proxy[f"P.{a}"] for a in "XYZ"], -1)
        N = np.stack([proxy[f"N.{a}"] for a in "XYZ"], -1)
        slant, tilt = btf.surface_directions(P, N, eye)
        scale = float(p.scale if p.scale is not None else ctx.stack.meta["btf"].get("pixel", 1.0))
        if p.uv == "terrain":
            u, v = self._terrain_uv(ctx, proxy, P, mask, p.origin, scale)
        else:
            u, v = btf.planar_uv(P, p.origin, scale)
        rgb = btf.shade_surface(imgs, views, (u, v), slant, tilt, mask)
        rgb[~mask] = np.asarray(p.background, np.float32)
        out = btf.outside_grid(views, slant, tilt) & mask
        if not mask.any():
            ctx.warn(f"label {p.label!r} is not in view; nothing is shaded")
        else:
            ctx.note(f"{int(mask.sum())} pixels of {p.label!r}; slant {slant[mask].min():.1f}–{slant[mask].max():.1f}°; "
                     f"{100.0 * out.sum() / mask.sum():.1f}% outside the stack's views (nearest views used)")
        ch = {c: np.ascontiguousarray(rgb[..., i]) for i, c in enumerate("RGB")}
        ch["A"] = mask.astype(np.float32)
        for name in ("Z", "P.X", "P.Y", "P.Z", "N.X", "N.Y", "N.Z", "label.id", "object.id"):
            if name in proxy:
                ch[name] = proxy[name]
        for name, a in (("btf.slant", slant), ("btf.tilt", tilt), ("btf.u", u), ("btf.v", v)):
            ch[name] = np.where(mask, a, 0.0).astype(np.float32)
        meta = {k: proxy.meta[k] for k in ("labels", "camera", "scene", "objects") if k in proxy.meta}
        meta["btf"] = dict(ctx.stack.meta["btf"], label=p.label, scale=scale)
        return Plate(ch, meta)

    @staticmethod
    def _terrain_uv(ctx, proxy, P, mask, origin, scale):
        """Texture coordinates from the labelled meshes' own grids (``synthesis.btf.grid_uv``),
        per object of the label."""
        from proxyshade.errors import UserError
        from proxyshade.io import usd
        from proxyshade.synthesis import btf

        label = ctx.p.label
        objs = {o["name"]: int(o["id"]) for o in proxy.meta.get("objects", []) if o.get("label") == label}
        if not objs or "scene" not in proxy.meta:
            raise ctx.error(f"uv: terrain needs a scene label with its meshes (proxy meta['objects'], "
                            f"meta['scene']); {label!r} is not one: use uv: planar")
        try:
            stage = usd.open_stage(proxy.meta["scene"])
        except UserError as e:
            raise ctx.error(str(e)) from None
        u = np.zeros(mask.shape)
        v = np.zeros(mask.shape)
        for prim in usd.scene_prims(stage, ctx.frame):
            if prim.path not in objs:
                continue
            grid = btf.grid_surface(usd.world_mesh(prim)[0]) if prim.kind == "mesh" else None
            if grid is None:
                raise ctx.error(f"uv: terrain: {prim.path} (label {label!r}) is not a heightfield grid (points on "
                                "a regular x-z grid, as the scene builder's terrains); use uv: planar")
            on = mask & (proxy["object.id"] == objs[prim.path])
            u[on], v[on] = btf.grid_uv(P[on], grid, origin, scale)
        return u, v

    @staticmethod
    def _mask(ctx, proxy, label):
        objs = [int(o["id"]) for o in proxy.meta.get("objects", []) if o.get("label") == label]
        if objs:
            return np.isin(proxy["object.id"], np.array(objs, np.uint32))
        table = {t["name"]: int(t["id"]) for t in proxy.meta.get("labels", [])}
        if label in table:
            return proxy["label.id"] == table[label]
        known = sorted({o.get("label") for o in proxy.meta.get("objects", []) if o.get("label")} | set(table))
        raise ctx.error(f"label {label!r} is neither a scene label nor a source label of the proxy; "
                        f"give one of: {', '.join(known) or '(none)'}")
