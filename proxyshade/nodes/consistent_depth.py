"""ConsistentDepth: the frame-0 detailed guide and extended depth carried to frame N.

Reference: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010.

Bonneel et al. 2010, §6.1: "We first create a mesh, which consists of a grid with each
pixel of the initial frame as a separate small quad. We cut the edges of the grid at
label boundaries or when a large depth gradient is detected ... We project this grid into
the screen space coordinate system of current frame N. Note that the proxy is also
present in the scene, and can occlude the grid." Pixels are then of four kinds:

====  =====  ================================================  =====================
code  paper  pixel                                             label and depth from
====  =====  ================================================  =====================
1     A      covered by the grid, not occluded by the proxy    the grid
2     B      grid occluded by the proxy, occluded at frame 0   the grid
3     C      grid occluded by the proxy, visible at frame 0    the proxy (frame N)
4     D      not covered by the grid                           the proxy (frame N)
====  =====  ================================================  =====================

"Occluded at frame 0" means the detailed guide showed a surface behind the frame-0 proxy
there (the guide's detail overrides the proxy, e.g. sky or mountain between tree
spheres); those pixels keep the guide's decision. Layer: ``proxyshade.synthesis.temporal``
(the frame-0 grid); kernels ``proxyshade.kernels.reproject``.
"""
from __future__ import annotations

import lazy_loader

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate
from proxyshade.synthesis.params import SameSurface
from proxyshade.synthesis.state import CATEGORY

np = lazy_loader.load("numpy")  # on first use: a fully cached run never loads numpy


class ConsistentDepth(SameSurface, Node):
    """Project the frame-0 grid (detailed labels + extended depth) into this frame's camera.

    Output at the proxy's size: ``label.id``, ``Z`` (inf where nothing), ``P.X/Y/Z``
    (world position), ``category`` (uint32: 1 A, 2 B, 3 C, 4 D; see the module doc),
    ``N.X/Y/Z`` and ``object.id`` passed through from the proxy; metadata from the proxy
    (camera of this frame, labels) plus ``consistent_depth`` (category counts).
    """

    version = 1
    proxy = Input("this frame's ProxyRender: label.id, Z, camera", channels=("label.id", "Z"), finite=("Z",),
                  inf_ok=("Z",), fix="connect this frame's ProxyRender")
    guide = Input("the detailed guide at the first frame (GuideSynth at frame: first): label.id; its Z, if any, "
                  "is the frame-0 proxy depth unless ref_proxy is connected", channels=("label.id",),
                  fix="connect GuideSynth at frame: first")
    depth = Input("extended depth at the first frame (DepthExtend at frame: first): Z; default the guide's Z",
                  optional=True, channels=("Z",), finite=("Z",), inf_ok=("Z",),
                  fix="connect DepthExtend at frame: first")
    ref_proxy = Input("the ProxyRender at the first frame (frame: first), for 'occluded at frame 0'", optional=True)
    cut_tolerance = Param(float, 0.1, min=0.0, max=10.0,
                          doc="cut the grid between neighbours whose inverse depths differ by more (relative)")
    max_extent = Param(float, 64.0, min=1.0, doc="skip grid quads larger than this many pixels in frame N")
    stale = Param(bool, True, doc="leave to the proxy the pixels where the grid drawn lay on the proxy at frame 0 "
                                  "and floats in front of it now (moving proxy objects)")
    stale_tolerance = Param(float, 0.25, min=0.0,
                            doc="relative inverse depth by which a grid pixel must be in front of the proxy to be stale "
                                "(quads at grazing silhouettes are drawn up to ~10% off)")

    def compute(self, ctx) -> Plate:
        from proxyshade.kernels import reproject as kr
        from proxyshade.synthesis.temporal import camera_of, frame0_grid

        p = ctx.p
        proxy, guide = ctx.proxy, ctx.guide
        depth = ctx.depth if ctx.depth is not None else guide
        if "Z" not in depth:
            raise ctx.error("input 'depth' is not connected and the guide has no Z; connect DepthExtend at "
                            "frame: first (or a guide with Z)")
        if depth.shape != guide.shape:
            raise ctx.error(f"depth is {depth.width}x{depth.height}, guide {guide.width}x{guide.height}; connect the "
                            "DepthExtend of this guide")
        if ctx.depth is None and np.isnan(depth["Z"]).any():  # a connected depth and the proxy: checked by the engine
            raise ctx.error("the guide's Z has NaN pixels; fix the upstream render (inf marks empty pixels)")
        cam1 = camera_of("proxy", proxy)
        cam0 = camera_of("depth", ctx.depth, guide, ctx.ref_proxy)
        if (cam1.width, cam1.height) != (proxy.width, proxy.height):
            raise ctx.error(f"proxy's camera is {cam1.width}x{cam1.height} but the plate {proxy.width}x{proxy.height}")
        if (cam0.width, cam0.height) != (guide.width, guide.height):
            raise ctx.error(f"the first frame's camera is {cam0.width}x{cam0.height} but the guide "
                            f"{guide.width}x{guide.height}; connect plates of one render")
        tol = p.depth_tolerance
        rp = ctx.ref_proxy if ctx.ref_proxy is not None else (guide if "Z" in guide and guide is not depth else None)
        if rp is not None and rp.shape != guide.shape:
            raise ctx.error("ref_proxy and guide differ in size; connect the first frame's ProxyRender")
        f0 = frame0_grid(depth["Z"], guide["label.id"], rp["Z"] if rp is not None else None, p.cut_tolerance, tol,
                         memo=ctx.memo)
        cw, keep, occluded0, on_proxy0 = f0.cw, f0.keep, f0.occluded, f0.on_proxy
        lab0 = np.ascontiguousarray(guide["label.id"], np.uint32)
        k0, k1 = kr.intrinsics(cam0), kr.intrinsics(cam1)
        M = kr.relative_matrix(cam0, cam1)
        wp1 = kr.inverse_depth(proxy["Z"])
        wg, src = kr.splat_grid(cw, keep, M, k0, k1, cam1.near, cam1.height, cam1.width, p.max_extent)
        stale = (kr.stale_winners(wg, src, wp1, on_proxy0, keep, p.stale_tolerance) if p.stale
                 else np.zeros(keep.shape, bool))
        zero = np.zeros(proxy.shape, np.float32)
        base = [np.ascontiguousarray(proxy[c], np.float32) if c in proxy else zero for c in ("P.X", "P.Y", "P.Z")]
        cat, label, Z, X, Y, Zw, gone = kr.classify(
            src=src, wg=wg, wp1=wp1, stale=stale, occluded0=np.ascontiguousarray(occluded0, np.bool_), lab0=lab0,
            plab=np.ascontiguousarray(proxy["label.id"], np.uint32), pZ=np.ascontiguousarray(proxy["Z"], np.float32),
            pX=base[0], pY=base[1], pZw=base[2], C=np.ascontiguousarray(cam1.camera_to_world, np.float64), k=k1,
            tol=float(tol))
        if gone.any() and self._moved(kr, stale, wg, src, wp1, on_proxy0, keep):
            ctx.note(f"{int(gone.sum())} pixels of stale grid (on the proxy at the first frame, in front of it "
                     "now: a moving object) left to the proxy")
        ch = {"label.id": label, "Z": Z, "category": cat, "P.X": X, "P.Y": Y, "P.Z": Zw}
        for c in ("N.X", "N.Y", "N.Z", "object.id"):
            if c in proxy:
                ch[c] = proxy[c]
        n = np.bincount(cat.ravel(), minlength=len(CATEGORY) + 1)
        counts = {k: int(n[v]) for k, v in CATEGORY.items()}
        ctx.note("categories " + ", ".join(f"{k} {100.0 * n / cat.size:.1f}%" for k, n in counts.items()))
        meta = dict(proxy.meta)
        meta["consistent_depth"] = {"categories": counts, "first_frame": cam0.frame}
        return Plate(ch, meta)

    def _moved(self, kr, stale, wg, src, wp1, on_proxy0, keep) -> bool:
        """Whether the stale grid drawn comes from a moving object: some of it floats in front
        of every proxy pixel of its 3x3 window. A static scene's stale pixels are a
        silhouette's quads drawn a pixel onto the background behind them (9-53 a frame at
        256² over the bundled camera moves, which move nothing but the camera): no note."""
        # a pixel stale in its 3x3 window is stale at its own pixel: only those are tested (on_proxy0 & stale,
        # the same result; the window's 9 reads skipped on every other pixel)
        # stale_winners marks only frame-0 pixels drawn here (a src value): any of them is drawn (no src[src >= 0]
        # gather of the frame's 8 MiB)
        moved = stale & kr.stale_winners(wg, src, wp1, on_proxy0 & stale, keep, self.params["stale_tolerance"],
                                         radius=1)
        return bool(moved.any())
