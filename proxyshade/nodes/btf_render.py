"""BtfRender: a synthetic BTF capture of a USD heightfield.

Neubeck, Zalesny and Van Gool, "Viewpoint consistent texture synthesis" (3DPVT 2004): a
BTF stack is "aligned images of one planar sample from many view directions" (slant
0°–70° step 5°, tilts 0°–90° step 15° in the paper). Real BTF data being out of reach,
this node photographs the scene's heightfield orthographically from that grid, Lambert-
shaded by the scene's sun (fixed: the camera moves, not the light) with shadow-mapped
self-shadows. Layer: ``proxyshade.synthesis.btf.render_views``.
"""
from __future__ import annotations

from pathlib import Path

from proxyshade.graph.node import Node, Param
from proxyshade.graph.plate import Plate


class BtfRender(Node):
    """Render a BTF stack of the scene's (non-CG) meshes: one view per grid direction.

    Views: the frontal one, then for each slant ``slant_step``, 2·``slant_step``, ... up to
    ``slant_max`` every tilt of ``tilts`` (degrees, tilt from +x toward +z). Each view is
    ``size``² pixels over a ``window``-wide square of the sample around ``centre`` (x, z),
    rectified to the plane y = ``plane`` (what a marker on the sample holder gives), so a
    point at height y drifts by (y − plane)·tan(slant) toward the tilt. Albedo from the
    height (``height``) or scikit-image's CC0 ``gravel``/``grass`` stretched over the mesh.

    Output: ``v{n}.R/G/B`` (linear), ``meta['views']`` = [{slant, tilt, light}],
    ``meta['btf']`` = {pixel, plane, origin, heights: [min, max] of the mesh}.
    """

    version = 1
    scene = Param(Path, doc="USD stage with a heightfield mesh and a UsdLux.DistantLight")
    slant_step = Param(float, 5.0, min=0.5, max=89.0, doc="slant grid step (degrees)")
    slant_max = Param(float, 70.0, min=0.0, max=89.0, doc="largest slant (degrees, below 90)")
    tilts = Param(list, [0, 15, 30, 45, 60, 75, 90], doc="tilts of every slanted view (degrees)")
    size = Param(int, 128, min=16, max=2048, doc="pixels per view side")
    window = Param(float, 1.2, min=1e-6, doc="world width of the sample each view shows")
    centre = Param(list, [0.0, 0.0], length=2, doc="world (x, z) of the window's centre")
    plane = Param(float, 0.0, doc="height of the plane the views are rectified to")
    albedo = Param(str, "height", choices=("height", "gravel", "grass"), doc="albedo source")
    ambient = Param(float, 0.15, min=0.0, doc="ambient term (fraction of the albedo)")
    shadow_size = Param(int, 1024, min=16, max=8192, doc="shadow-map texels per side")
    bias = Param(float, 0.004, min=0.0, doc="shadow depth tolerance in world units")

    def key_extra(self, frame, graph_dir):
        """What the capture sees: the scene's meshes and its sun, from every file the stage
        composes (sublayers, references); kept by ``keys.node_memo`` with those files, so
        USD is loaded only when one of them changes."""
        from proxyshade.graph import keys
        from proxyshade.graph.node import resolve_path

        path = resolve_path(self.params["scene"], graph_dir)
        if not path.is_file():
            return "missing"
        return keys.node_memo(self, [str(path), frame], lambda: self._scene_digest(path, frame))

    @staticmethod
    def _scene_digest(path: Path, frame: int):
        from proxyshade.graph import keys
        from proxyshade.io import usd

        try:
            stage = usd.open_stage(path)
            prims = [(q.path, q.digest) for q in usd.scene_prims(stage, frame) if not q.cg]
            light = usd.distant_light(stage, frame)
        except Exception as e:  # noqa: BLE001 - compute reports it properly
            return f"error: {e}", None
        return keys.digest([prims, light]), usd.dependencies(stage)

    def compute(self, ctx) -> Plate:
        import numpy as np

        from proxyshade.errors import UserError
        from proxyshade.io import usd
        from proxyshade.synthesis import btf

        p = ctx.p
        if not all(isinstance(t, (int, float)) and not isinstance(t, bool) for t in p.tilts) or not p.tilts:
            raise ctx.error(f"tilts {p.tilts} must be a non-empty list of numbers (degrees)")
        try:
            stage = usd.open_stage(ctx.path(p.scene))
        except UserError as e:
            raise ctx.error(str(e)) from None
        prims = sorted((q for q in usd.scene_prims(stage, ctx.frame) if not q.cg and q.kind == "mesh"),
                       key=lambda q: q.path)
        if not prims:
            raise ctx.error(f"scene {p.scene} has no heightfield mesh; give a scene with a terrain "
                            "(e.g. samples/scenes/btf_bumps.usda)")
        light = usd.distant_light(stage, ctx.frame)
        if light is None:
            raise ctx.error(f"scene {p.scene} has no UsdLux.DistantLight; add a light (the sun) to the scene")
        views = btf.view_grid(p.slant_step, p.slant_max, p.tilts)
        btf.check_views(views, "tilts")
        pts, tris, nrm, _ = usd.world_meshes(prims)
        if p.albedo == "height":
            alb = btf.height_albedo(pts)
        else:
            from proxyshade.io.images import read_u8
            from proxyshade.io.source import srgb_to_linear

            tex = srgb_to_linear(read_u8(Path(__file__).resolve().parents[2] / "samples/textures" / f"{p.albedo}.png"))
            lo, hi = pts[:, [0, 2]].min(0), pts[:, [0, 2]].max(0)
            alb = btf.texture_albedo(pts, tex, (lo, hi))
        imgs = btf.render_views(pts, tris, nrm, light, views, size=p.size, window=p.window, centre=p.centre,
                                plane=p.plane, ambient=p.ambient, albedo=alb, shadow_size=p.shadow_size, bias=p.bias)
        for v in views:
            v["light"] = [float(x) for x in light["direction"]]
        pix = p.window / p.size
        meta = {"pixel": pix, "plane": float(p.plane),
                "origin": [float(p.centre[0] - p.window / 2), float(p.centre[1] - p.window / 2)],
                "heights": [float(pts[:, 1].min()), float(pts[:, 1].max())]}
        ctx.note(f"{len(views)} views of {p.size}² at {pix:.4g} world units per pixel; heights "
                 f"{meta['heights'][0]:.4g}..{meta['heights'][1]:.4g}")
        return btf.stack_plate(np.asarray(imgs), views, meta)
