"""BtfSynth: view-consistent synthesis of a larger BTF stack.

Neubeck, Zalesny and Van Gool, "Viewpoint consistent texture synthesis" (3DPVT 2004):
the support view is synthesized first (confidence-weighted sequential synthesis, eq. 3,
coarse to fine), then every other view given it, with the distance
Σ w‖B′ − B‖² + c(1 − w)‖A′ − A‖², so all views show the same new surface. Layer:
``proxyshade.synthesis.btf.synthesize_stack``; kernels ``proxyshade.kernels.btf``.
"""
from __future__ import annotations

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate


class BtfSynth(Node):
    """Synthesize a ``size`` stack from an aligned BTF stack (BtfAlign's output).

    ``mode``: ``sequential`` (the paper: support, then the others given it, in parallel
    over views, each view sequential), ``independent`` (every view on its own) or
    ``columns`` (every view copies the support's sources). ``support``: the view index of
    the support (default: the frontal view). Radii: ``radius`` for the support (3 or 4 in
    the paper), ``radius_other`` for the others (2). ``T`` visits per pixel from w = 0
    (w += 1/T), ``levels`` of the multigrid (the disk scaled by 2 per level; default: as
    many as the input allows, up to 5: the coarse levels keep the support's patches as large
    as a bump's footprint in the steepest views, so no seam cuts a bump into a sliver).
    ``parallax`` (on): the other views start from, and are held to, the support's surface
    as each of them sees it: the sample's heights from a plane sweep of the views, the
    view's rays cast through the support's patchwork (where a ray passes a seam it shows the
    patch beyond it), instead of the support's sources at the same pixel (the paper's,
    which at steep slants shows bumps cut by the support's seams as shards). Needs the
    frontal view as support.
    ``tile``: synthesize on a torus (disk neighbours wrap around the borders), so the stack
    repeats without a seam when a surface is shaded from it (BtfShade wraps).

    Output: ``v{n}.R/G/B`` synthesized and ``v{n}.sx/sy`` (the input pixel each output
    pixel copies, column and row), the input's ``meta['views']`` and ``meta['btf']``.
    """

    version = 1
    stack = Input("aligned BTF stack (v{n}.R/G/B, meta views)", fix="connect BtfAlign (or BtfRender/BtfRead)")
    size = Param(list, [256, 256], length=2, doc="output width, height")
    mode = Param(str, "sequential", choices=("sequential", "independent", "columns"), doc="how views are made")
    support = Param(int, None, optional=True, min=0, doc="support view index (default: the frontal view)")
    radius = Param(int, 3, min=1, max=8, doc="disk radius of the support view")
    radius_other = Param(int, 2, min=1, max=8, doc="disk radius of the other views")
    T = Param(int, 4, min=2, max=64, doc="visits per pixel (w += 1/T)")
    levels = Param(int, None, optional=True, min=1, max=6,
                   doc="multigrid levels (default: the most, up to 5, the input allows)")
    tile = Param(bool, True, doc="the stack tiles without a seam (the output wraps around its borders)")
    parallax = Param(bool, True, doc="other views start from the support's surface cast along their direction")
    c = Param(float, 0.25, min=0.0, doc="weight of the support term for the other views")
    seed = Param(int, 0, doc="seed of the visiting order and the initial map")

    def compute(self, ctx) -> Plate:
        import numpy as np

        from proxyshade.synthesis import btf

        p = ctx.p
        if not all(isinstance(v, int) and not isinstance(v, bool) and v > 0 for v in p.size):
            raise ctx.error(f"size {p.size} must be two positive integers [width, height]")
        views, imgs = btf.stack_arrays(ctx.stack)
        support = btf.check_views(views)["index"][(0, 0.0)] if p.support is None else p.support
        if support >= len(views):
            raise ctx.error(f"support {support} is not a view of the stack (it has {len(views)}); give 0..{len(views) - 1}")
        levels = btf.auto_levels(imgs.shape[1:3], max(p.radius, p.radius_other)) if p.levels is None else p.levels
        btf.check_synthesis_size(imgs.shape[1:3], max(p.radius, p.radius_other), levels)
        W, H = p.size
        bm = ctx.stack.meta["btf"]
        geometry = (btf.stack_geometry(imgs, views, support, float(bm.get("pixel", 1.0)), float(bm.get("plane", 0.0)))
                    if p.parallax and views[support]["slant"] == 0.0 else None)
        qy, qx = btf.synthesize_stack(imgs, support, (H, W), mode=p.mode, radius=p.radius,
                                      radius_other=p.radius_other, T=p.T, levels=levels, c=p.c, seed=p.seed,
                                      wrap=p.tile, geometry=geometry)
        out = btf.gather_stack(imgs, qy, qx)
        extra = {}
        for n in range(len(views)):
            extra[f"v{n}.sx"] = qx[n].astype(np.float32)
            extra[f"v{n}.sy"] = qy[n].astype(np.float32)
        ec = btf.consistency_error(imgs, support, qy, qx)
        es = btf.seam_error(imgs, qy, qx)
        others = [n for n in range(len(views)) if n != support]
        meta = dict(ctx.stack.meta["btf"], support=support, mode=p.mode, input_size=[imgs.shape[2], imgs.shape[1]],
                    levels=levels, tile=bool(p.tile), parallax=geometry is not None)
        if others:
            ctx.note(f"{len(views)} views {W}x{H} ({p.mode}); other views: E_c {ec[others].mean():.4f}, "
                     f"E_s {es[others].mean():.4f}")
        return btf.stack_plate(out, views, meta, extra)
