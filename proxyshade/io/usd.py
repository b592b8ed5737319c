"""USD scenes: stages, cameras, proxy and CG prims with their labels, the distant light.

Conventions: numpy matrices here act on column vectors (``p_cam = V @ [p, 1]``); USD's
Gf matrices act on row vectors and are transposed on the way in. Camera space is USD's:
x right, y up, the camera looks down −z. Pixel (row i, column j) has its centre at
(j + 0.5, i + 0.5); a camera-space point projects to column ``cx + fx·x/d`` and row
``cy − fy·y/d`` with d = −z. The aperture is conformed to the output aspect by keeping
the horizontal aperture (the vertical one follows), as Maya's horizontal gate fit does.

Texture labels use USD's own schema, ``UsdSemantics.LabelsAPI`` applied with the
instance name ``texture`` (``semantics:labels:texture = ["water"]``), inherited by
descendants. CG prims (composited, not synthesized) carry ``bool proxyshade:cg = true``.
"""
from __future__ import annotations

import functools
import hashlib
import math
import re
import threading
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdSemantics

from proxyshade.errors import UserError
from proxyshade.io.camera import CameraInfo  # noqa: F401 - where it was; io.camera loads no USD

LABEL_INSTANCE = "texture"
CG_ATTR = "proxyshade:cg"


def load_plugins() -> None:
    """Load every USD plugin now. USD loads a plugin's library when a stage first needs it,
    with the GIL released, and the library's initialisers take the GIL again while they hold
    the dynamic loader's lock: a C++ library on another thread holding the GIL and waiting
    for that lock (OpenImageIO, OpenEXR) deadlocked the process. The engine calls this on the
    main thread before any node or cache-writer thread starts, for a run that computes a
    node reading USD (about 20 ms)."""
    from pxr import Plug

    Plug.Registry().LoadAllPlugins() if hasattr(Plug.Registry(), "LoadAllPlugins") else [
        p.Load() for p in Plug.Registry().GetAllPlugins()]


_DIAGNOSTICS = None  # USD's warnings, collected instead of printed (UsdUtils.CoalescingDiagnosticDelegate)
_DIAGNOSTICS_LOCK = threading.Lock()


def _collect_diagnostics() -> None:
    """From now on USD's warnings and status messages are collected, not printed to stderr as
    C++ text ("Warning: in _ReportErrors at line 3326 of .../stage.cpp -- ..."): ``usd_warnings``
    turns them into one-line Python warnings. Errors still raise (``tf_message``)."""
    global _DIAGNOSTICS
    with _DIAGNOSTICS_LOCK:
        if _DIAGNOSTICS is None:
            from pxr import UsdUtils

            _DIAGNOSTICS = UsdUtils.CoalescingDiagnosticDelegate()


def diagnostic_line(commentary: str) -> str:
    """A USD diagnostic's text as one line: no C++ namespaces, no object addresses."""
    text = re.sub(r"pxrInternal_v\w+?__pxrReserved__::", "", str(commentary))
    text = re.sub(r"\s*<0x[0-9a-fA-F]+>", "", text)
    return " ".join(text.split())


def usd_warnings(where: str | Path) -> list[str]:
    """The USD warnings collected since the last call, each issued as one Python warning
    ``'<where>: USD: <message>'`` (the CLI prints it as one ``warning:`` line); returns them."""
    _collect_diagnostics()
    with _DIAGNOSTICS_LOCK:
        taken = _DIAGNOSTICS.TakeUncoalescedDiagnostics()
    from pxr import Tf

    lines = [f"{where}: USD: {diagnostic_line(d.commentary)}" for d in taken
             if d.diagnosticCode != Tf.TF_DIAGNOSTIC_STATUS_TYPE]  # status lines are chatter
    for line in dict.fromkeys(lines):
        warnings.warn(line, stacklevel=2)
    return lines


def open_stage(path: str | Path) -> Usd.Stage:
    path = Path(path)
    if not path.is_file():
        raise UserError(f"{path}: no such USD file; check the scene path")
    _collect_diagnostics()
    try:
        loaded = Sdf.Layer.Find(str(path))
        if loaded:  # USD keeps layers it has opened: re-read what is on disk now
            loaded.Reload(force=True)
        stage = Usd.Stage.Open(str(path))
    except Exception as e:  # noqa: BLE001 - pxr raises Tf errors
        usd_warnings(path)
        raise UserError(f"{path}: cannot open USD stage: {tf_message(e)}; fix the file") from None
    usd_warnings(path)
    if stage is None:
        raise UserError(f"{path}: cannot open USD stage")
    return stage


def dependencies(stage: Usd.Stage) -> dict | None:
    """What USD data read from the stage depends on, for ``keys.memo``: the files its
    composition read (root layer, sublayers, references, payloads, clips), the USD
    library's version and the asset search path; None when the stage has composition
    errors (a missing reference: a file appearing later would change the stage)."""
    if stage.GetCompositionErrors():
        return None
    files = sorted({layer.realPath for layer in stage.GetUsedLayers() if not layer.anonymous and layer.realPath})
    return {"files": files, "packages": ["usd-core"], "env": ["PXR_AR_DEFAULT_SEARCH_PATH"]}


def tf_message(e: BaseException) -> str:
    """A pxr (Tf) error as one line: USD's own messages ('file.usda:8:3: parse error ...'), without
    the C++ function, source file and namespace of each."""
    text = str(e)
    msgs = re.findall(r"in file \S+ : '(.*?)'\s*(?=\n\s*Error in |$)", text, re.S)
    msgs = [re.sub(r"pxrInternal_v\w+?__pxrReserved__::", "", m) for m in msgs] or [text]
    return "; ".join(" ".join(m.split()) for m in msgs)


def stage_name(stage: Usd.Stage) -> str:
    return stage.GetRootLayer().identifier


def up_axis(stage: Usd.Stage) -> str:
    """The stage's up axis, 'Y' or 'Z'."""
    return str(UsdGeom.GetStageUpAxis(stage))


def check_frame(stage: Usd.Stage, frame: int) -> None:
    """A frame outside the stage's authored time range is bad input (a static stage has frame 1)."""
    if not stage.HasAuthoredTimeCodeRange():
        if frame != 1:
            raise UserError(f"{stage_name(stage)}: the stage has no time samples (no startTimeCode/endTimeCode) "
                            f"but frame {frame} was asked; author a time range or render frame 1")
        return
    lo, hi = stage.GetStartTimeCode(), stage.GetEndTimeCode()
    if not lo <= frame <= hi:
        raise UserError(f"{stage_name(stage)}: frame {frame} is outside the stage's time range "
                        f"{lo:g}-{hi:g}; render a frame inside it or extend endTimeCode")


def _np(m: Gf.Matrix4d) -> np.ndarray:
    return np.array(m, dtype=np.float64).T  # Gf is row-vector; ours are column-vector


def cameras(stage: Usd.Stage) -> list[str]:
    return [str(p.GetPath()) for p in stage.Traverse() if p.IsA(UsdGeom.Camera)]


def film_aspect(stage: Usd.Stage, path: str | None, frame: int) -> float:
    """Height over width of the camera's film back (vertical over horizontal aperture) at
    ``frame``: the aspect its author framed."""
    known = cameras(stage)
    path = path or (known[0] if known else None)
    prim = stage.GetPrimAtPath(path) if path and Sdf.Path.IsValidPathString(path) else None
    if prim is None or not prim.IsValid() or not prim.IsA(UsdGeom.Camera):
        raise UserError(f"{stage_name(stage)}: no camera at {path}; cameras in the stage: {', '.join(known) or 'none'}")
    gcam = UsdGeom.Camera(prim).GetCamera(Usd.TimeCode(frame))
    _check_camera(stage, path, frame, gcam)
    return gcam.verticalAperture / gcam.horizontalAperture


def _check_camera(stage: Usd.Stage, path: str, frame: int, gcam: Gf.Camera) -> None:
    """One-line errors for camera values no projection can use: a focal length or aperture
    that is not a finite number > 0, a clipping range that is not 0 < near < far, a transform
    or aperture offset that is not finite."""
    where = f"{stage_name(stage)}: camera {path} at frame {frame}"
    for name, v, fix in (("focalLength", gcam.focalLength, "a focal length > 0 (mm)"),
                         ("horizontalAperture", gcam.horizontalAperture, "an aperture > 0 (mm)"),
                         ("verticalAperture", gcam.verticalAperture, "an aperture > 0 (mm)")):
        if not (math.isfinite(v) and v > 0):
            raise UserError(f"{where}: {name} is {v:g}; give {fix}")
    for name, v in (("horizontalApertureOffset", gcam.horizontalApertureOffset),
                    ("verticalApertureOffset", gcam.verticalApertureOffset)):
        if not math.isfinite(v):
            raise UserError(f"{where}: {name} is {v:g}; give a finite offset (mm), usually 0")
    near, far = gcam.clippingRange.min, gcam.clippingRange.max
    if not (math.isfinite(near) and near > 0 and far > near):  # far may be inf
        raise UserError(f"{where}: clippingRange is ({near:g}, {far:g}); give 0 < near < far, e.g. (0.1, 10000)")
    if not np.isfinite(np.array(gcam.transform, dtype=np.float64)).all():
        raise UserError(f"{where}: its transform (position or rotation) holds a NaN or infinite value; fix the "
                        "camera's xformOps")


def camera_at(stage: Usd.Stage, path: str | None, frame: int, width: int, height: int) -> CameraInfo:
    """The camera at ``frame`` (the first camera when ``path`` is None), conformed to W×H."""
    known = cameras(stage)
    if path is None:
        if not known:
            raise UserError(f"{stage_name(stage)}: the stage has no camera; add a UsdGeom.Camera prim")
        path = known[0]
    prim = stage.GetPrimAtPath(path) if Sdf.Path.IsValidPathString(path) else None
    if prim is None or not prim.IsValid() or not prim.IsA(UsdGeom.Camera):
        raise UserError(f"{stage_name(stage)}: no camera at {path}; cameras in the stage: {', '.join(known) or 'none'}")
    check_frame(stage, frame)
    gcam = UsdGeom.Camera(prim).GetCamera(Usd.TimeCode(frame))
    _check_camera(stage, path, frame, gcam)
    if gcam.projection != Gf.Camera.Perspective:
        raise UserError(f"{stage_name(stage)}: camera {path} is orthographic; ProxyRender needs a perspective "
                        "camera (projection = \"perspective\")")
    ha = gcam.horizontalAperture
    va = ha * height / width  # keep the horizontal aperture
    fx = width * gcam.focalLength / ha
    fy = height * gcam.focalLength / va
    cx = width / 2.0 - width * gcam.horizontalApertureOffset / ha  # the window moves, the image moves back
    cy = height / 2.0 + height * gcam.verticalApertureOffset / va
    near, far = gcam.clippingRange.min, gcam.clippingRange.max
    return CameraInfo(path=str(path), frame=frame, width=width, height=height, fx=fx, fy=fy, cx=cx, cy=cy, near=near,
                      far=far, camera_to_world=_np(gcam.transform))


def gf_frustum(cam: CameraInfo, stage: Usd.Stage) -> Gf.Frustum:
    """USD's own frustum for the camera (tests compare projections against it)."""
    prim = stage.GetPrimAtPath(cam.path)
    gcam = UsdGeom.Camera(prim).GetCamera(Usd.TimeCode(cam.frame))
    gcam.verticalAperture = gcam.horizontalAperture * cam.height / cam.width
    return gcam.frustum


# -- prims ------------------------------------------------------------------
def texture_label(prim: Usd.Prim, time: Usd.TimeCode) -> str | None:
    """The prim's texture label, inherited from the nearest labelled ancestor."""
    p = prim
    while p and p.IsValid() and not p.IsPseudoRoot():
        if p.HasAPI(UsdSemantics.LabelsAPI, LABEL_INSTANCE):
            vals = UsdSemantics.LabelsAPI(p, LABEL_INSTANCE).GetLabelsAttr().Get(time)
            if vals:
                return str(vals[0])
        p = p.GetParent()
    return None


def is_cg(prim: Usd.Prim) -> bool:
    p = prim
    while p and p.IsValid() and not p.IsPseudoRoot():
        a = p.GetAttribute(CG_ATTR)
        if a and a.HasAuthoredValue() and a.Get():
            return True
        p = p.GetParent()
    return False


@dataclass
class ScenePrim:
    """A renderable prim at one frame: a triangle mesh in local space or a sphere."""

    path: str
    kind: str  # "mesh" | "sphere"
    label: str | None
    cg: bool
    local_to_world: np.ndarray
    points: np.ndarray | None = None  # (V, 3) local, meshes
    tris: np.ndarray | None = None  # (T, 3)
    radius: float = 0.0  # spheres
    color: tuple[float, float, float] = (0.5, 0.5, 0.5)
    digest: str = field(default="", repr=False)


def triangulate(counts: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """Fan-triangulate polygons given by face vertex counts and indices -> (T, 3)."""
    counts = np.asarray(counts, np.int64)
    indices = np.asarray(indices, np.int64)
    if len(counts) and (counts == counts[0]).all() and counts[0] >= 3:  # all n-gons: vectorised fan
        n = int(counts[0])
        f = indices.reshape(-1, n)
        return np.stack([np.column_stack([f[:, 0], f[:, k], f[:, k + 1]]) for k in range(1, n - 1)], 1).reshape(-1, 3)
    out = []
    start = 0
    for c in counts:
        for k in range(1, c - 1):
            out.append((indices[start], indices[start + k], indices[start + k + 1]))
        start += c
    return np.array(out, np.int64).reshape(-1, 3)


def _checked_faces(stage: Usd.Stage, prim: Usd.Prim, frame: int, points: np.ndarray, counts: np.ndarray,
                   idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A mesh's face vertex counts and indices, checked against its points: every face has 3 or
    more vertices, the counts add up to the indices, every index names a point and every point
    is finite (a NaN point dropped the whole mesh). One-line errors naming the prim."""
    where = f"{stage_name(stage)}: mesh {prim.GetPath()} at frame {frame}"
    counts, idx = counts.astype(np.int64).ravel(), idx.astype(np.int64).ravel()
    if counts.size and counts.min() < 3:
        f = int(np.argmax(counts < 3))
        raise UserError(f"{where}: face {f} has {counts[f]} vertices; every face needs 3 or more (faceVertexCounts)")
    if int(counts.sum()) != idx.size:
        raise UserError(f"{where}: faceVertexCounts add up to {int(counts.sum())} but faceVertexIndices has "
                        f"{idx.size}; make them agree")
    bad = np.flatnonzero((idx < 0) | (idx >= len(points)))
    if bad.size:
        raise UserError(f"{where}: faceVertexIndices[{bad[0]}] is {idx[bad[0]]}, outside the {len(points)} points; "
                        f"give indices 0..{len(points) - 1}")
    nan = np.flatnonzero(~np.isfinite(points).all(axis=1))
    if nan.size:
        raise UserError(f"{where}: points[{nan[0]}] is {tuple(float(v) for v in points[nan[0]])} ({nan.size} point(s) not finite); "
                        "fix the mesh's points")
    return counts, idx


def scene_prims(stage: Usd.Stage, frame: int) -> list[ScenePrim]:
    """Every mesh and sphere of the stage at ``frame`` with labels, CG flag and transforms."""
    t = Usd.TimeCode(frame)
    cache = UsdGeom.XformCache(t)
    out = []
    for prim in stage.Traverse():
        if not prim.IsA(UsdGeom.Gprim):
            continue
        img = UsdGeom.Imageable(prim)
        if img.ComputeVisibility(t) == UsdGeom.Tokens.invisible:
            continue
        m = _np(cache.GetLocalToWorldTransform(prim))
        if not np.isfinite(m).all():
            raise UserError(f"{stage_name(stage)}: {prim.GetPath()} at frame {frame}: its transform holds a NaN or "
                            "infinite value; fix its xformOps (or its parents')")
        color = (0.5, 0.5, 0.5)
        dc = UsdGeom.Gprim(prim).GetDisplayColorAttr().Get(t)
        if dc:
            color = tuple(float(v) for v in dc[0])
        rec = ScenePrim(str(prim.GetPath()), "", texture_label(prim, t), is_cg(prim), m, color=color)
        h = hashlib.sha256(m.tobytes())
        if prim.IsA(UsdGeom.Mesh):
            mesh = UsdGeom.Mesh(prim)
            pts = mesh.GetPointsAttr().Get(t)
            counts = mesh.GetFaceVertexCountsAttr().Get(t)
            idx = mesh.GetFaceVertexIndicesAttr().Get(t)
            if pts is None or counts is None or idx is None:
                continue
            rec.kind = "mesh"
            rec.points = np.array(pts, np.float64).reshape(-1, 3)
            rec.tris = triangulate(*_checked_faces(stage, prim, frame, rec.points, np.array(counts), np.array(idx)))
            h.update(rec.points.tobytes())
            h.update(rec.tris.tobytes())
        elif prim.IsA(UsdGeom.Sphere):
            rec.kind = "sphere"
            rec.radius = float(UsdGeom.Sphere(prim).GetRadiusAttr().Get(t))
            if not (math.isfinite(rec.radius) and rec.radius > 0):
                raise UserError(f"{stage_name(stage)}: sphere {prim.GetPath()} at frame {frame}: radius is "
                                f"{rec.radius:g}; give a radius > 0")
            h.update(np.float64(rec.radius).tobytes())
        else:
            continue
        h.update(repr((rec.label, rec.cg, rec.color)).encode())
        rec.digest = h.hexdigest()
        out.append(rec)
    usd_warnings(stage_name(stage))
    return out


@functools.lru_cache(maxsize=64)
def sphere_mesh(segments: int) -> tuple[np.ndarray, np.ndarray]:
    """A unit UV sphere: ``segments`` around, segments/2 from pole to pole -> (points, tris)."""
    n = max(8, int(segments))
    rings = max(4, n // 2)
    th = np.linspace(0, np.pi, rings + 1)[1:-1]
    ph = np.linspace(0, 2 * np.pi, n, endpoint=False)
    T, P = np.meshgrid(th, ph, indexing="ij")
    body = np.column_stack([(np.sin(T) * np.cos(P)).ravel(), np.cos(T).ravel(), (np.sin(T) * np.sin(P)).ravel()])
    pts = np.vstack([[0, 1, 0], body, [0, -1, 0]])
    j = np.arange(n)
    i = np.arange(rings - 2)[:, None]
    r = lambda i, j: 1 + i * n + (j % n)  # noqa: E731 - the vertex of ring i, meridian j
    # per meridian j the north cap's triangle, then the south's; then per ring band i and
    # meridian j the quad's two triangles
    caps = np.stack([np.stack([np.zeros_like(j), r(0, j + 1), r(0, j)], -1),
                     np.stack([np.full_like(j, len(pts) - 1), r(rings - 2, j), r(rings - 2, j + 1)], -1)], 1)
    band = np.stack([np.stack([r(i, j), r(i, j + 1), r(i + 1, j + 1)], -1),
                     np.stack([r(i, j), r(i + 1, j + 1), r(i + 1, j)], -1)], 2)
    pts = pts.astype(np.float64)
    tris = np.concatenate([caps.reshape(-1, 3), band.reshape(-1, 3)]).astype(np.int64)
    pts.flags.writeable = False  # shared by the cache
    tris.flags.writeable = False
    return pts, tris


def sphere_segments(radius_px: float, max_error_px: float = 0.25, cap: int = 512) -> int:
    """Segments around for ``sphere_mesh`` so no face sinks more than ``max_error_px`` below
    the sphere: a face spans 2π/n by 2π/n, its triangles have an angular circumradius of
    √2·π/n and their planes lie r·(1 − cos(√2·π/n)) inside the sphere at most."""
    if radius_px <= max_error_px:
        return 8
    n = int(np.ceil(np.sqrt(2.0) * np.pi / np.arccos(max(1.0 - max_error_px / radius_px, -1.0))))
    return int(min(max(n + (n % 2), 8), cap))


def vertex_normal_sums(pts: np.ndarray, tris: np.ndarray, fn: np.ndarray) -> np.ndarray:
    """(V, 3) sums of the face vectors ``fn`` (T, 3) over the faces at each vertex, in the order
    ``np.add.at(out, tris[:, k], fn)`` for k = 0, 1, 2 adds them: the same bits. For float64,
    ``np.bincount`` per coordinate (its loop adds in input order, in float64) in place of
    ``np.add.at`` (lake's terrain, 32768 faces: 9.2 -> 1.0 ms CPU a frame)."""
    out = np.zeros((len(pts), 3), fn.dtype)
    if fn.dtype != np.float64:
        for k in range(3):
            np.add.at(out, tris[:, k], fn)
        return out
    idx = np.ascontiguousarray(tris.T).reshape(-1)  # tris[:, 0], then tris[:, 1], then tris[:, 2]
    for c in range(3):
        out[:, c] = np.bincount(idx, weights=np.tile(fn[:, c], 3), minlength=len(pts))
    return out


def world_mesh(prim: ScenePrim, cam: CameraInfo | None = None, max_error_px: float = 0.25
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World-space (points, tris, vertex normals) of a prim; spheres are tessellated for
    ``cam`` so the silhouette error stays under ``max_error_px``."""
    M = prim.local_to_world
    if prim.kind == "sphere":
        scale = float(np.cbrt(abs(np.linalg.det(M[:3, :3]))))
        centre = M[:3, 3]
        r_world = prim.radius * scale
        if cam is not None:
            cc = cam.to_camera(centre)
            d = max(float(-cc[2]) - r_world, cam.near)
            # off the axis by θ, image distances grow by up to 1/cos θ in the radial direction
            stretch = float(np.sqrt(1.0 + (cc[0] ** 2 + cc[1] ** 2) / d ** 2))
            n = sphere_segments(max(cam.fx, cam.fy) * r_world * stretch / d, max_error_px)
        else:
            n = 64
        unit, tris = sphere_mesh(n)
        pts = unit * prim.radius
        normals = unit @ np.linalg.inv(M[:3, :3])  # inverse-transpose, row-vector form
    else:
        pts, tris = prim.points, prim.tris
        a, b, c = pts[tris[:, 0]], pts[tris[:, 1]], pts[tris[:, 2]]
        normals = vertex_normal_sums(pts, tris, np.cross(b - a, c - a))
        normals = normals @ np.linalg.inv(M[:3, :3])
    wp = pts @ M[:3, :3].T + M[:3, 3]
    nn = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = normals / np.where(nn > 0, nn, 1.0)
    return wp, tris, normals


def world_meshes(prims: list, cam: CameraInfo | None = None, max_error_px: float = 0.25
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """All ``prims`` as one world-space triangle list: (points, tris, vertex normals, the
    index into ``prims`` of each triangle's prim). Spheres are tessellated for ``cam``."""
    pts, tris, nrm, owner = [], [], [], []
    base = 0
    for k, prim in enumerate(prims):
        p, t, n = world_mesh(prim, cam, max_error_px)
        pts.append(p)
        tris.append(t + base)
        nrm.append(n)
        owner.append(np.full(len(t), k, np.int64))
        base += len(p)
    if not pts:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64), np.zeros((0, 3)), np.zeros(0, np.int64)
    return np.vstack(pts), np.vstack(tris), np.vstack(nrm), np.concatenate(owner)


def distant_light(stage: Usd.Stage, frame: int) -> dict | None:
    """The first UsdLux.DistantLight: its path, world direction of travel (unit), colour,
    intensity and angle; None when the stage has none."""
    t = Usd.TimeCode(frame)
    for prim in stage.Traverse():
        if prim.IsA(UsdLux.DistantLight):
            light = UsdLux.DistantLight(prim)
            M = _np(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(t))
            d = M[:3, :3] @ np.array([0.0, 0.0, -1.0])  # lights shine down their −z
            d /= np.linalg.norm(d)
            return {"path": str(prim.GetPath()), "direction": d.tolist(),
                    "color": list(light.GetColorAttr().Get(t) or (1, 1, 1)),
                    "intensity": float(light.GetIntensityAttr().Get(t) or 1.0),
                    "angle": float(light.GetAngleAttr().Get(t) or 0.53)}
    return None


def validate(stage: Usd.Stage) -> list[str]:
    """UsdValidation errors of the stage (all registered validators), as strings."""
    from pxr import UsdValidation

    reg = UsdValidation.ValidationRegistry()
    ctx = UsdValidation.ValidationContext(reg.GetOrLoadAllValidators())
    return [f"{e.GetName()}: {e.GetMessage()}" for e in ctx.Validate(stage)
            if e.GetType() == UsdValidation.ValidationErrorType.Error]


def cg_digest(path: Path, frame: int, *, cg_only: bool = True) -> tuple[str | None, dict | None]:
    """A digest of what a CG render or shadow sees at ``frame`` (CG prims, light, cameras)
    and the stage's ``dependencies`` (None, None when the stage cannot be read)."""
    try:
        stage = open_stage(path)
        prims = scene_prims(stage, frame)
        light = distant_light(stage, frame)
        h = hashlib.sha256()
        for p in prims:
            if p.cg or not cg_only:
                h.update(p.digest.encode())
        h.update(repr(light).encode())
        for c in cameras(stage):
            m = UsdGeom.Camera(stage.GetPrimAtPath(c)).GetCamera(Usd.TimeCode(frame))
            h.update(repr((c, m.focalLength, m.horizontalAperture, m.horizontalApertureOffset,
                           m.verticalApertureOffset, m.clippingRange, m.transform)).encode())
        return h.hexdigest(), dependencies(stage)
    except Exception:  # noqa: BLE001 - reported properly by compute
        return None, None


def no_light_message(prims: list, what: str) -> str:
    """The warning for CG prims without a UsdLux.DistantLight: the prims, what happens, the fix."""
    names = ", ".join(p.path for p in prims[:4]) + (" ..." if len(prims) > 4 else "")
    return (f"the scene has CG prims ({names}) but no UsdLux.DistantLight prim; {what}. "
            "Add a DistantLight to the stage")
