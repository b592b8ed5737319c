"""ProxyRender: the proxy guide and proxy depth of a USD scene through its camera.

Reference: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010.

"An image of texture category labels is obtained by rendering the 3D proxy geometry into
a proxy guide, with no lighting computation and with the appropriate texture label
associated with each component of the proxy ... A proxy depth map is created at the same
time." (Bonneel et al. 2010, §3.)
"""
from __future__ import annotations

import hashlib
from pathlib import Path

import lazy_loader

from proxyshade.graph import keys
from proxyshade.graph.node import Input, Node, Param, resolve_path
from proxyshade.graph.plate import Plate

np = lazy_loader.load("numpy")  # on first use: a fully cached run never loads numpy

# USD (pxr) and the kernels (numba) are imported where a render or a key reads a scene:
# a cached run loads neither


_STAGES: dict[str, tuple[str, object]] = {}  # path -> (content hash, stage)


def open_cached(path: Path):
    """The stage at ``path``, reopened only when the file's content changes. One stage per
    path: USD keeps one layer per path in the process, so a stage kept for an earlier content
    (a scene edited, then the edit undone) would show the layer as last reloaded."""
    from proxyshade.io import usd

    if not path.is_file():
        return usd.open_stage(path)  # raises the one-line error
    content = hashlib.sha256(path.read_bytes()).hexdigest()
    got = _STAGES.get(str(path))
    if got is None or got[0] != content:
        got = _STAGES[str(path)] = (content, usd.open_stage(path))
    return got[1]


def render_prims(prims: list, cam, *, max_error_px: float = 0.25, planar: bool = False):
    """Rasterize prims through ``cam``: (depth, prim index (−1 empty), P, N) per pixel; P and
    N (H, W, 3), or with ``planar`` (3, H, W) (each component's plane contiguous)."""
    from proxyshade.io import usd
    from proxyshade.kernels.raster import interpolate, rasterize

    P, T, N, owner = usd.world_meshes(prims, cam, max_error_px)
    pc = cam.to_camera(P)
    depth, tri, bary, _ = rasterize(pc, T, width=cam.width, height=cam.height, fx=cam.fx, fy=cam.fy,
                                    cx=cam.cx, cy=cam.cy, near=cam.near)
    # one gather: the empty pixels' triangle −1 reads the appended −1
    prim_idx = np.append(np.asarray(owner, np.int64).astype(np.int32), np.int32(-1))[tri]
    wpos = interpolate(P, T, tri, bary, planar=planar)
    nrm = interpolate(N, T, tri, bary, normalize=True, planar=planar)
    return depth, prim_idx, wpos, nrm


MAX_SIDE = 16384  # pixels per side: 16K is beyond any delivery format
FORMATS = {  # delivery formats: name -> [width, height]
    "1k": [1024, 1024], "hd": [1920, 1080], "2k": [2048, 1080], "2k_scope": [2048, 858], "2k_flat": [1998, 1080],
    "uhd": [3840, 2160], "4k": [4096, 2160],
}


class ProxyRender(Node):
    """Rasterize the scene's proxy prims (not the CG ones) at the frame through the camera.

    Outputs ``label.id`` (the source table's ids; empty pixels get the background label),
    ``Z`` (camera depth, inf where empty), ``P.X/Y/Z`` (world position), ``N.X/Y/Z``
    (world normal), ``object.id`` (1 + prim index; names in metadata ``objects``), and
    metadata ``labels``, ``camera`` (see ``proxyshade.io.usd.CameraInfo.to_meta``; rebuild it
    with ``CameraInfo.from_meta``), ``scene``, ``background``, ``up_axis``.
    """

    version = 1
    time_dependent = True
    source = Input("the annotated source (its label table names the labels)")
    scene = Param(str, doc="USD scene (.usda/.usd); relative to the graph file")
    camera = Param(str, None, doc="camera prim path (default: the first camera)")
    resolution = Param(list, [1024, 1024], length=2,
                       doc="[width, height] in pixels (unless format is set); [width, null]: the height that keeps "
                           "the camera's film aspect")
    format = Param(str, None, choices=tuple(FORMATS),
                   doc="a delivery format instead of resolution: " + ", ".join(f"{k} {v[0]}x{v[1]}" for k, v in FORMATS.items()))
    background = Param(str, None, doc="label of empty pixels (default: the scene's, else 'sky')")
    max_error_px = Param(float, 0.25, min=0.01, doc="sphere silhouette error bound in pixels")
    labels = Param(dict, {}, doc="scene label -> source label, for scene labels the source lacks "
                                 "(e.g. {sand: rock}: render sand with the photo's rock)")

    @staticmethod
    def _size(params: dict, stage, frame: int) -> list:
        from proxyshade.io import usd

        if params.get("format"):
            return FORMATS[params["format"]]
        w, h = params["resolution"]
        if h is None and isinstance(w, int) and not isinstance(w, bool):
            h = max(1, int(round(w * usd.film_aspect(stage, params["camera"], frame))))
        return [w, h]

    def _scene_path(self, graph_dir: Path) -> Path:
        return resolve_path(self.params["scene"], graph_dir)

    def read_files(self, frame: int, graph_dir: Path) -> list[Path]:
        """The scene's root layer too (``run --watch`` re-runs after ``proxyshade scene stroke``)."""
        return super().read_files(frame, graph_dir) + [self._scene_path(graph_dir)]

    def key_extra(self, frame, graph_dir):
        """What the render sees at this frame: camera, and each proxy prim's data (kept
        with the scene's files by ``keys.node_memo``: USD is loaded only when they change)."""
        path = self._scene_path(graph_dir)
        if not path.is_file():
            return "missing"
        return keys.node_memo(self, [str(path), frame], lambda: self._scene_digest(path, frame))

    def _scene_digest(self, path: Path, frame: int) -> tuple[str, dict | None]:
        from proxyshade.io import usd

        try:
            stage = open_cached(path)
            w, h = self._size(self.params, stage, frame)
            cam = usd.camera_at(stage, self.params["camera"], frame, int(w), int(h))
            prims = [(p.path, p.digest) for p in usd.scene_prims(stage, frame) if not p.cg]
            bg = stage.GetDefaultPrim().GetCustomDataByKey("proxyshade:background") if stage.GetDefaultPrim() else None
        except Exception as e:  # noqa: BLE001 - compute reports it properly
            return f"error: {e}", None
        return keys.digest([cam.to_meta(), prims, bg]), usd.dependencies(stage)

    def compute(self, ctx) -> Plate:
        from proxyshade.io import usd

        path = self._scene_path(ctx.graph_dir)
        stage = open_cached(path)
        w, h = self._size(ctx.params, stage, ctx.frame)
        if not (isinstance(w, int) and isinstance(h, int) and 0 < w <= MAX_SIDE and 0 < h <= MAX_SIDE):
            raise ctx.error(f"resolution {ctx.p.resolution} must be two integers [width, height] from 1 to {MAX_SIDE} "
                            "(or [width, null]: the camera's aspect), e.g. [1920, 1080]")
        cam = usd.camera_at(stage, ctx.p.camera, ctx.frame, w, h)
        prims = [p for p in usd.scene_prims(stage, ctx.frame) if not p.cg]
        table = {t["name"]: int(t["id"]) for t in ctx.source.meta.get("labels", [])}
        if not table:
            raise ctx.error("the source plate has no label table (meta 'labels'); connect a SourceRead")
        bg = ctx.p.background
        if bg is None:
            dp = stage.GetDefaultPrim()
            bg = (dp.GetCustomDataByKey("proxyshade:background") if dp else None) or "sky"
        scene_labels = sorted({p.label for p in prims if p.label} | {bg})
        unlabelled = [p.path for p in prims if not p.label]
        if unlabelled:
            raise ctx.error(f"{path.name}: prim {unlabelled[0]} has no texture label; apply "
                            f"UsdSemantics.LabelsAPI:texture (labels: {', '.join(sorted(table))})")
        mapping = ctx.p.labels
        bad = {k: v for k, v in mapping.items() if not isinstance(v, str) or v not in table}
        if bad:
            k, v = next(iter(bad.items()))
            raise ctx.error(f"labels: {k}: {v!r} is not a label of the source; source labels: "
                            f"{', '.join(sorted(table))}")
        unused = sorted(set(mapping) - set(scene_labels))
        if unused:
            ctx.warn(f"labels: {', '.join(unused)} not in the scene (its labels: {', '.join(scene_labels)}); "
                     "the mapping of those does nothing")
        missing = [lab for lab in scene_labels if mapping.get(lab, lab) not in table]
        if missing:
            raise ctx.error(f"{path.name}: scene label(s) {', '.join(missing)} not in the source's table; "
                            f"scene labels: {', '.join(scene_labels)}; source labels: {', '.join(sorted(table))}; "
                            f"map them with the labels parameter, e.g. {{{missing[0]}: {sorted(table)[0]}}}")
        depth, prim_idx, wpos, nrm = render_prims(prims, cam, max_error_px=ctx.p.max_error_px, planar=True)
        if not prims:
            ctx.warn(f"{path.name}: the scene has no proxy prims (labelled meshes or spheres not marked CG), so the "
                     f"render is all '{bg}'; add labelled geometry")
        elif not (prim_idx >= 0).any():
            ctx.warn(f"{path.name}: no proxy prim is in view of the camera at frame {ctx.frame}, so the render is all "
                     f"'{bg}'; check the camera")
        lab_of_prim = np.array([table[mapping.get(p.label, p.label)] for p in prims] + [table[mapping.get(bg, bg)]],
                               np.uint32)
        label = lab_of_prim[prim_idx]  # empty (−1): the last, the background's
        ch = {
            "label.id": label,
            "Z": depth,
            "object.id": (prim_idx + 1).view(np.uint32),  # >= 0: the same bits
        }
        for k, a in enumerate("XYZ"):
            ch[f"P.{a}"] = wpos[k]  # planar: each a contiguous plane (no copy)
            ch[f"N.{a}"] = nrm[k]
        meta = {
            "labels": ctx.source.meta["labels"],
            "camera": cam.to_meta(),
            "scene": str(path),
            "background": bg,
            "up_axis": usd.up_axis(stage),
            "objects": [{"id": i + 1, "name": p.path, "label": p.label} for i, p in enumerate(prims)],
        }
        return Plate(ch, meta)
