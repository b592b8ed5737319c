"""CG render: the scene's CG prims through the frame's camera, Lambert-shaded by the
scene's distant light, for compositing with the synthesized frame.

Reference: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010.

Bonneel et al. 2010, §7: "3D CG elements can be integrated with the synthesized elements
using the extended depth and the same camera as the proxy image at any given frame."
The prims are rasterized with the proxy rasterizer (``proxyshade.kernels.raster``).
"""
from __future__ import annotations

from pathlib import Path

import lazy_loader

from proxyshade.errors import UserError
from proxyshade.graph import keys
from proxyshade.graph.node import Input, Node, Param, resolve_path
from proxyshade.graph.plate import Plate

np = lazy_loader.load("numpy")  # on first use: a fully cached run never loads numpy


def lambert(albedo: np.ndarray, normal: np.ndarray, light: dict, ambient: float) -> np.ndarray:
    """``albedo * (ambient + E * max(0, N . -L) / pi)`` per pixel; (..., 3) arrays.

    The Lambertian BRDF ``albedo / pi`` under a distant light of irradiance ``E`` (its
    colour times its intensity) travelling along ``L = light['direction']``, plus an
    ambient term as a fraction of the albedo.
    """
    d = np.asarray(light["direction"], np.float64)
    e = np.asarray(light.get("color", (1, 1, 1)), np.float64) * float(light.get("intensity", 1.0))
    cos = np.clip(-(normal @ d), 0.0, None)
    return albedo * (ambient + cos[..., None] * e / np.pi)


def stage_and_camera(ctx):
    """The node's stage and the frame's camera: the ``proxy`` input's meta camera when it
    has one, else the ``camera``/``resolution`` params. Bad input -> one-line node error."""
    from proxyshade.io import usd

    res = ctx.p.resolution
    if not all(isinstance(v, int) and not isinstance(v, bool) and v > 0 for v in res):
        raise ctx.error(f"resolution {res} must be two positive integers [width, height]")
    try:
        stage = usd.open_stage(ctx.path(ctx.p.scene))
        proxy = ctx.inputs.get("proxy")
        if proxy is not None and isinstance(proxy.meta.get("camera"), dict):
            usd.check_frame(stage, ctx.frame)
            cam = usd.CameraInfo.from_meta(proxy.meta["camera"])
        else:
            cam = usd.camera_at(stage, ctx.p.camera, ctx.frame, int(res[0]), int(res[1]))
    except UserError as e:
        raise ctx.error(str(e)) from None
    return stage, cam


class CgRender(Node):
    """Render the CG prims (``proxyshade:cg = true``) of a USD scene through the frame's camera.

    The camera is the one in the ``proxy`` plate's metadata when connected (so the CG
    lines up with the synthesized frame), else ``camera``/``resolution``. Shading is Lambert
    with each prim's displayColor: ``2**exposure * displayColor * (ambient + E * max(0,
    N . -L) / pi)`` with ``E`` the DistantLight's colour times intensity and ``L`` its
    direction of travel (its -Z axis); polygon meshes shade flat (face normals), spheres
    smooth; normals face the camera (meshes of either winding
    shade the same). Without a DistantLight a headlight along the view direction with
    ``E = pi`` (a surface facing it shows its displayColor) is used, with a warning.

    Output: premultiplied ``R,G,B`` and ``A`` (1 where a CG prim covers the pixel centre),
    ``Z`` (camera depth, inf where empty), ``N.X/N.Y/N.Z``, ``P.X/P.Y/P.Z`` (world),
    ``object.id`` (1.. in prim path order, 0 = none); metadata ``objects`` (``[{name,
    id}]``), ``camera`` and ``light``.
    """

    version = 1
    time_dependent = True
    proxy = Input("optional plate whose meta['camera'] gives the camera and resolution", optional=True)
    scene = Param(Path, doc="USD stage with CG prims and a UsdLux.DistantLight")
    camera = Param(str, None, optional=True, doc="camera prim path (default: the first) when no proxy input")
    resolution = Param(list, [960, 540], length=2, doc="width, height when no proxy input")
    ambient = Param(float, 0.15, min=0.0, doc="ambient term (fraction of displayColor)")
    exposure = Param(float, 0.0, min=-16.0, max=16.0, doc="stops, to balance the CG against the plate")

    def key_extra(self, frame, graph_dir):
        path = resolve_path(self.params["scene"], graph_dir, frame)

        def scene_digest():
            from proxyshade.io import usd

            return usd.cg_digest(path, frame)

        return keys.node_memo(self, [str(path), frame], scene_digest)  # USD loaded only when the scene changes

    def compute(self, ctx) -> Plate:
        from proxyshade.io import usd

        stage, cam = stage_and_camera(ctx)
        prims = sorted((p for p in usd.scene_prims(stage, ctx.frame) if p.cg), key=lambda p: p.path)
        light = usd.distant_light(stage, ctx.frame)
        if not prims:
            ctx.note("the scene has no CG prims (bool proxyshade:cg = true); the CG plate is empty")
        elif light is None:
            ctx.warn(usd.no_light_message(prims, "CG prims are lit by a headlight"))
        return render_cg(prims, cam, light, ambient=ctx.p.ambient, exposure=ctx.p.exposure)


def render_cg(prims: list, cam, light: dict | None, *, ambient: float, exposure: float = 0.0) -> Plate:
    """The CG plate of ``prims`` seen by ``cam`` (a ``usd.CameraInfo``); see ``CgRender``."""
    from proxyshade.io import usd
    from proxyshade.kernels import raster

    h, w = cam.height, cam.width
    wp, tris, nrm, owner = usd.world_meshes(prims, cam)
    depth, tri, bary, _ = raster.rasterize(cam.to_camera(wp), tris, width=w, height=h, fx=cam.fx, fy=cam.fy,
                                           cx=cam.cx, cy=cam.cy, near=cam.near)
    cover = tri >= 0
    P = raster.interpolate(wp, tris, tri, bary).astype(np.float64)
    # spheres shade smooth (interpolated vertex normals); polygon meshes flat (face normals)
    smooth_tri = np.array([prims[k].kind == "sphere" for k in owner], bool) if len(owner) else np.zeros(0, bool)
    face_n = np.cross(wp[tris[:, 1]] - wp[tris[:, 0]], wp[tris[:, 2]] - wp[tris[:, 0]]) if len(tris) else nrm[:0]
    N = raster.interpolate(nrm, tris, tri, bary).astype(np.float64)
    flat = cover & ~smooth_tri[np.maximum(tri, 0)] if len(tris) else cover
    N[flat] = face_n[tri[flat]]
    nn = np.linalg.norm(N, axis=-1, keepdims=True)
    N = np.where(nn > 0, N / np.where(nn > 0, nn, 1), 0.0)
    view = P - cam.position
    N = np.where((np.sum(N * view, -1) > 0)[..., None], -N, N)  # face the camera
    oid = np.zeros((h, w), np.uint32)
    oid[cover] = (owner[tri[cover]] + 1).astype(np.uint32)
    albedo = np.zeros((h, w, 3))
    colors = np.array([p.color for p in prims], np.float64).reshape(-1, 3)
    albedo[cover] = colors[oid[cover] - 1]
    if light is None:
        vd = cam.camera_to_world[:3, :3] @ np.array([0.0, 0.0, -1.0])
        light_used = {"direction": vd.tolist(), "color": [1.0, 1.0, 1.0], "intensity": np.pi}
    else:
        light_used = light
    rgb = np.where(cover[..., None], lambert(albedo, N, light_used, ambient) * 2.0 ** exposure, 0.0)
    ch = {c: rgb[..., i].astype(np.float32) for i, c in enumerate("RGB")}
    ch["A"] = cover.astype(np.float32)
    ch["Z"] = depth.astype(np.float32)
    for i, a in enumerate("XYZ"):
        ch[f"N.{a}"] = np.where(cover, N[..., i], 0.0).astype(np.float32)
        ch[f"P.{a}"] = np.where(cover, P[..., i], np.inf).astype(np.float32)
    ch["object.id"] = oid
    meta = {"objects": [{"name": p.path, "id": k + 1} for k, p in enumerate(prims)],
            "camera": cam.to_meta(), "light": light}
    return Plate(ch, meta)
