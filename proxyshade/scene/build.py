"""Build a USD proxy scene from a small YAML description (terrains, spheres, CG objects,
cameras, a distant light), reproducibly: the same YAML writes the same ``.usda``.

    name: lake
    frames: [1, 48]
    fps: 24
    background: sky
    terrains:  [{name: Ground, label: vegetation, cells: [128, 128], extent: [[-60, -60], [60, 60]],
                 strokes: [{centre: [10, -20], radius: 8, amount: 6}]}]
    spheres:   [{name: Trees, label: tree, path: [[0, 2, -30], [20, 2, -35]], radius: [3, 2], count: 6}]
    cg:        [{name: House, kind: house, position: [5, 0, -10], size: [4, 3, 5], color: [0.7, 0.3, 0.2]}]
    cameras:   [{name: Camera, focal_length: 35, move: orbit, centre: [0, 0, 0], radius: 40, height: 8,
                 start_deg: 0, end_deg: 20}]
    light:     {name: Sun, elevation: 40, azimuth: 30, intensity: 3}
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdSemantics, Vt

from proxyshade.errors import UserError
from proxyshade.io import yamlfile
from proxyshade.io.usd import CG_ATTR, LABEL_INSTANCE, validate
from proxyshade.scene import camera as camera_tool
from proxyshade.scene.spheres import along_path
from proxyshade.scene.terrain import Terrain


def _gf(M: np.ndarray) -> Gf.Matrix4d:
    return Gf.Matrix4d(np.asarray(M, float).T.tolist())  # column-vector -> Gf row-vector


def set_label(prim: Usd.Prim, label: str) -> None:
    UsdSemantics.LabelsAPI.Apply(prim, LABEL_INSTANCE).CreateLabelsAttr().Set(Vt.TokenArray([label]))


def _house(size) -> tuple[np.ndarray, list, list]:
    """A box with a gabled roof, base centred on the origin."""
    w, h, d = (float(v) / 2 for v in size)
    h *= 2
    roof = h * 1.45
    pts = [(-w, 0, -d), (w, 0, -d), (w, 0, d), (-w, 0, d), (-w, h, -d), (w, h, -d), (w, h, d), (-w, h, d),
           (-w, roof, 0), (w, roof, 0)]
    faces = [(0, 1, 2, 3), (0, 4, 5, 1), (1, 5, 6, 2), (2, 6, 7, 3), (3, 7, 4, 0),
             (4, 8, 9, 5), (6, 9, 8, 7), (4, 7, 8), (5, 9, 6)]
    # winding: outward normals
    counts = [len(f) for f in faces]
    idx = [i for f in faces for i in f[::-1]]
    return np.array(pts), counts, idx


def _box(size) -> tuple[np.ndarray, list, list]:
    w, h, d = (float(v) / 2 for v in size)
    pts = [(-w, 0, -d), (w, 0, -d), (w, 0, d), (-w, 0, d), (-w, 2 * h, -d), (w, 2 * h, -d), (w, 2 * h, d), (-w, 2 * h, d)]
    faces = [(0, 1, 2, 3), (0, 4, 5, 1), (1, 5, 6, 2), (2, 6, 7, 3), (3, 7, 4, 0), (4, 7, 6, 5)]
    return np.array(pts), [4] * 6, [i for f in faces for i in f[::-1]]


def _mesh(stage, path, pts, counts, idx, color=None) -> Usd.Prim:
    m = UsdGeom.Mesh.Define(stage, path)
    m.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(pts, np.float32)))
    m.CreateFaceVertexCountsAttr(Vt.IntArray([int(c) for c in counts]))
    m.CreateFaceVertexIndicesAttr(Vt.IntArray([int(i) for i in idx]))
    m.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    pts = np.asarray(pts, np.float32)
    m.CreateExtentAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, pts.min(0))), Gf.Vec3f(*map(float, pts.max(0)))]))
    if color is not None:
        m.CreateDisplayColorAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, color))]))
    return m.GetPrim()


def build_stage(spec: dict, where: str = "scene") -> Usd.Stage:
    """A USD stage (in memory) from a scene description dict.

    A malformed description is a one-line ``UserError`` naming the entry (``terrains[1]
    (Ground)``) and what is wrong with it.
    """
    if not isinstance(spec, dict):
        raise UserError(f"{where}: expected a mapping with terrains, spheres, cg, cameras, light")
    _check_limits(spec, where)
    at = ["top level"]
    try:
        return _build(spec, where, at)
    except KeyError as e:
        raise UserError(f"{where}: {at[0]}: missing field {e.args[0]!r}") from None
    except (ValueError, TypeError, IndexError, AttributeError) as e:
        raise UserError(f"{where}: {at[0]}: {e}") from None
    except RuntimeError as e:  # pxr Tf errors, e.g. a name that is not a valid prim name
        lines = [ln.strip() for ln in str(e).splitlines() if ln.strip()]
        raise UserError(f"{where}: {at[0]}: {lines[-1] if lines else e}") from None


MAX_FRAMES = 100_000  # frames of a scene's time range
MAX_CELLS = 4096  # terrain cells along one side (a 4096x4096 grid: 16.8M cells)
MAX_COUNT = 10_000  # spheres along one path


def _check_limits(spec: dict, where: str) -> None:
    """Before anything is built: no NaN or infinite number anywhere in the description, a frame
    range, terrain grids and sphere counts within what can be built (a huge one exhausted memory
    or ran for hours). One-line ``UserError``s naming the field."""
    def walk(v, path):
        if isinstance(v, float) and not math.isfinite(v):
            raise UserError(f"{where}: {path}: {v} is not a finite number; give a number")
        if isinstance(v, dict):
            for k, x in v.items():
                walk(x, f"{path}.{k}" if path else str(k))
        elif isinstance(v, list):
            for i, x in enumerate(v):
                walk(x, f"{path}[{i}]")

    walk(spec, "")

    def ints(v, n, path, lo, hi, fix):
        vals = v if isinstance(v, list) else [v]
        if len(vals) != n or not all(isinstance(x, int) and not isinstance(x, bool) and lo <= x <= hi for x in vals):
            raise UserError(f"{where}: {path}: expected {n if n > 1 else 'an'} integer{'s' if n > 1 else ''} from {lo} "
                            f"to {hi}, got {yamlfile.short(v, 80)}; {fix}")

    if "frames" in spec:
        f = spec["frames"]
        ints(f, 2, "frames", -10**9, 10**9, "write frames: [1, 48]")
        if not 0 <= f[1] - f[0] < MAX_FRAMES:
            raise UserError(f"{where}: frames: {f[0]}-{f[1]} is not a range of 1 to {MAX_FRAMES} frames; write "
                            "frames: [first, last]")
    for i, t in enumerate(spec.get("terrains") or []):
        if isinstance(t, dict) and "cells" in t:
            ints(t["cells"], 2, f"terrains[{i}].cells", 1, MAX_CELLS, "a terrain of [128, 128] cells is plenty")
    for i, s in enumerate(spec.get("spheres") or []):
        if isinstance(s, dict) and "count" in s:
            ints(s["count"], 1, f"spheres[{i}].count", 1, MAX_COUNT, "give fewer spheres")
        if isinstance(s, dict) and "radius" in s:
            r = s["radius"] if isinstance(s["radius"], list) else [s["radius"]]
            if not all(isinstance(x, (int, float)) and not isinstance(x, bool) and x > 0 for x in r):
                raise UserError(f"{where}: spheres[{i}].radius: expected a number > 0 or a list of them, got "
                                f"{yamlfile.short(s['radius'], 80)}")


def _name(d: dict, default: str | None = None) -> str:
    name = d.get("name", default) if default is not None else d["name"]
    if not (isinstance(name, str) and Sdf.Path.IsValidIdentifier(name)):
        raise ValueError(f"name {name!r} is not a valid prim name; use letters, digits and underscores "
                         "(not starting with a digit)")
    return name


def _build(spec: dict, where: str, at: list) -> Usd.Stage:
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, float(spec.get("meters_per_unit", 1.0)))
    lo, hi = spec.get("frames", [1, 48])
    stage.SetStartTimeCode(lo)
    stage.SetEndTimeCode(hi)
    stage.SetTimeCodesPerSecond(float(spec.get("fps", 24)))
    stage.SetFramesPerSecond(float(spec.get("fps", 24)))
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    world.GetPrim().SetCustomDataByKey("proxyshade:background", spec.get("background", "sky"))
    UsdGeom.Scope.Define(stage, "/World/Proxy")
    for i, t in enumerate(spec.get("terrains") or []):
        at[0] = f"terrains[{i}] ({t.get('name', '?')})"
        _name(t)
        ter = Terrain.from_dict(t)
        pts, counts, idx = ter.mesh()
        prim = _mesh(stage, f"/World/Proxy/{t['name']}", pts, counts, idx)
        prim.SetCustomDataByKey("proxyshade:strokes", len(ter.strokes))
        set_label(prim, t["label"])
    for i, s in enumerate(spec.get("spheres") or []):
        at[0] = f"spheres[{i}] ({s.get('name', '?')})"
        _name(s)
        group = UsdGeom.Xform.Define(stage, f"/World/Proxy/{s['name']}")
        set_label(group.GetPrim(), s["label"])
        if "arch" in s:
            from proxyshade.scene.spheres import arch

            a = s["arch"]
            centres, radii = arch(a["left"], a["right"], a["height"], s["radius"], s["count"])
        else:
            centres, radii = along_path(s["path"], s["radius"], s["count"])
        for k, (c, r) in enumerate(zip(centres, radii)):
            sp = UsdGeom.Sphere.Define(stage, f"/World/Proxy/{s['name']}/S{k:03d}")
            sp.CreateRadiusAttr(float(r))
            sp.CreateExtentAttr(Vt.Vec3fArray([Gf.Vec3f(-float(r)), Gf.Vec3f(float(r))]))
            sp.AddTranslateOp().Set(Gf.Vec3d(*map(float, c)))
    if spec.get("cg"):
        cg = UsdGeom.Scope.Define(stage, "/World/CG")
        cg.GetPrim().CreateAttribute(CG_ATTR, Sdf.ValueTypeNames.Bool, custom=True).Set(True)
        for i, o in enumerate(spec["cg"]):
            at[0] = f"cg[{i}] ({o.get('name', '?')})"
            _name(o)
            kind = o.get("kind", "box")
            if kind not in ("house", "box"):
                raise UserError(f"{where}: cg.{o['name']}.kind: {kind!r} is not valid; valid kinds are house, box")
            pts, counts, idx = (_house if kind == "house" else _box)(o.get("size", [2, 2, 2]))
            prim = _mesh(stage, f"/World/CG/{o['name']}", pts, counts, idx, o.get("color", [0.6, 0.6, 0.6]))
            x = UsdGeom.Xformable(prim)
            x.AddTranslateOp().Set(Gf.Vec3d(*map(float, o.get("position", [0, 0, 0]))))
            x.AddRotateYOp().Set(float(o.get("rotate_y", 0.0)))
    for i, c in enumerate(spec.get("cameras") or []):
        at[0] = f"cameras[{i}] ({c.get('name', '?')})"
        _name(c)
        cam = UsdGeom.Camera.Define(stage, f"/World/{c['name']}")
        cam.CreateFocalLengthAttr(float(c.get("focal_length", 35.0)))
        cam.CreateHorizontalApertureAttr(float(c.get("horizontal_aperture", 36.0)))
        cam.CreateVerticalApertureAttr(float(c.get("vertical_aperture", 36.0)))
        cam.CreateClippingRangeAttr(Gf.Vec2f(*map(float, c.get("clipping", [0.1, 10000.0]))))
        op = cam.AddTransformOp()
        for f, M in camera_tool.from_dict(c, (lo, hi)).items():
            op.Set(_gf(M), Usd.TimeCode(f))
    if spec.get("light"):
        at[0] = "light"
        _name(spec["light"], "Sun")
        L = spec["light"]
        light = UsdLux.DistantLight.Define(stage, f"/World/{L.get('name', 'Sun')}")
        light.CreateIntensityAttr(float(L.get("intensity", 3.0)))
        light.CreateAngleAttr(float(L.get("angle", 0.53)))
        light.CreateColorAttr(Gf.Vec3f(*map(float, L.get("color", [1.0, 0.95, 0.9]))))
        x = UsdGeom.Xformable(light.GetPrim())
        # the light shines down its −z: rotate so −z points along the sun's rays
        x.AddRotateYOp().Set(float(L.get("azimuth", 30.0)))
        x.AddRotateXOp().Set(-float(L.get("elevation", 45.0)))
    at[0] = "top level"
    errors = validate(stage)
    if errors:
        raise UserError(f"{where}: the built stage fails UsdValidation: {errors[0]}")
    return stage


def build_file(spec_path: str | Path, out_path: str | Path | None = None) -> Path:
    """Build ``spec_path`` (YAML) into ``out_path`` (default: same name, .usda), atomically."""
    spec_path = Path(spec_path)
    spec = yamlfile.load(spec_path, what="scene description")
    out = Path(out_path) if out_path else spec_path.with_suffix(".usda")
    stage = build_stage(spec, where=str(spec_path))
    return write_usda(stage, out)


def write_usda(stage: Usd.Stage, out: str | Path) -> Path:
    """Write the stage's root layer as text to ``out``, atomically (temporary name, rename)."""
    out = Path(out)
    tmp = out.with_name(f".{out.name}.tmp.usda")
    tmp.write_text(stage.GetRootLayer().ExportToString())
    tmp.replace(out)
    return out
