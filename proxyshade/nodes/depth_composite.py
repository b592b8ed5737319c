"""CG over the synthesized scene by per-pixel depth.

Reference: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010.

Bonneel et al. 2010, §7: "3D CG elements can be integrated with the synthesized elements
using the extended depth and the same camera as the proxy image". The synthesized plate's
Z follows the detailed, synthesized silhouettes, so a CG object behind a synthesized rock
is hidden exactly where the rock's texture is.
"""
from __future__ import annotations

import lazy_loader

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate

np = lazy_loader.load("numpy")  # on first use: a fully cached run never loads numpy

_COLOUR = ("R", "G", "B")


def depth_over(front_rgb, front_a, back_rgb, back_a):
    """Premultiplied ``front over back``: ``(f + (1 - fa) b, fa + (1 - fa) ba)``."""
    k = (1.0 - front_a)[..., None]
    return front_rgb + k * back_rgb, front_a + (1.0 - front_a) * back_a


class DepthComposite(Node):
    """Composite a CG render (premultiplied R,G,B,A, Z, object.id) with the synthesized scene.

    Per pixel the nearer layer goes over the other (CG is nearer where
    ``Z_cg <= Z_scene + bias`` and it has coverage). Colour and alpha are the
    premultiplied over; ``Z``, ``object.id``, ``label.id`` and every channel both plates
    carry (P, N, ...) come from the layer that covers the pixel (the front one when its
    alpha is at least 0.5, else the back one): ``label.id`` is 0 where CG covers.
    ``object.id``: where the scene covers, the scene's own (its proxy prims, 0 when it has
    no ``object.id``); where CG covers, the CG id shifted past the scene's largest id.
    Metadata: the scene's, with ``objects`` = the scene's table followed by the CG's
    (shifted ids, ``"cg": true``).
    """

    version = 1
    scene = Input("synthesized plate: R,G,B, Z (A optional, 1 when absent), label.id, P, ...",
                  channels=("R", "G", "B", "Z"), fix="connect the synthesized plate (Poisson or ShadowMap)")
    cg = Input("CG render: premultiplied R,G,B,A, Z (inf where empty), object.id", channels=("R", "G", "B", "A", "Z"),
               fix="connect CgRender's output")
    bias = Param(float, 0.0, doc="depth bias: CG wins where Z_cg <= Z_scene + bias (ties go to CG)")

    def compute(self, ctx) -> Plate:
        scene: Plate = ctx.scene
        cg: Plate = ctx.cg
        if scene.shape != cg.shape:
            raise ctx.error(f"cg plate is {cg.width}x{cg.height} but scene is {scene.width}x{scene.height}; "
                            "render the CG with the proxy's camera and resolution")
        zs = scene["Z"].astype(np.float64)
        zc = cg["Z"].astype(np.float64)
        ac = np.clip(cg["A"].astype(np.float64), 0.0, 1.0)
        a_s = np.clip(scene["A"].astype(np.float64), 0.0, 1.0) if "A" in scene else np.ones(scene.shape)
        cg_front = (ac > 0) & (zc <= zs + ctx.p.bias)
        rs, rc = scene.layer(_COLOUR, np.float64), cg.layer(_COLOUR, np.float64)
        over_c, a_c = depth_over(rc, ac, rs, a_s)  # CG in front
        over_s, a_s2 = depth_over(rs, a_s, rc, ac)  # scene in front
        rgb = np.where(cg_front[..., None], over_c, over_s)
        alpha = np.where(cg_front, a_c, a_s2)
        # which layer owns the pixel's ids and geometry
        cg_owns = np.where(cg_front, ac >= 0.5, (a_s < 0.5) & (ac >= 0.5))
        out = {c: rgb[..., i].astype(np.float32) for i, c in enumerate(_COLOUR)}
        out["A"] = alpha.astype(np.float32)
        out["Z"] = np.where(cg_owns, cg["Z"], scene["Z"]).astype(np.float32)
        # object ids: the scene's (proxy prims, when it carries them), then CG ids past them
        scene_objs = list(scene.meta.get("objects") or []) if "object.id" in scene else []
        s_oid = scene["object.id"] if "object.id" in scene else np.zeros(scene.shape, np.uint32)
        offset = max([int(o["id"]) for o in scene_objs] + [int(s_oid.max()) if s_oid.size else 0])
        c_oid = cg["object.id"].astype(np.uint32) if "object.id" in cg else np.zeros(scene.shape, np.uint32)
        c_oid = np.where(c_oid > 0, c_oid + np.uint32(offset), 0).astype(np.uint32)
        out["object.id"] = np.where(cg_owns, c_oid, s_oid).astype(np.uint32)
        if "label.id" in scene:
            out["label.id"] = np.where(cg_owns, 0, scene["label.id"]).astype(np.uint32)
        for n in scene.names():
            if n in out or n not in cg:
                continue
            a = scene[n]
            out[n] = np.where(cg_owns, cg[n].astype(a.dtype, copy=False), a)
        cg_objs = [dict(o, id=int(o["id"]) + offset, cg=True) for o in cg.meta.get("objects") or []]
        return scene.with_channels(out, {"objects": scene_objs + cg_objs})
