"""BTF stacks: capture, checks, alignment, view-consistent synthesis and its measures.

Neubeck, Zalesny and Van Gool, "Viewpoint consistent texture synthesis" (3DPVT 2004).
A BTF stack is one plate: views ``v{n}.R/G/B`` of one planar sample, each rectified to
the same plane (``meta["btf"]["plane"]``, world height; ``pixel`` world units per pixel),
described by ``meta["views"]`` = ``[{"slant", "tilt", "light"}]`` (degrees; the light's
direction of travel). Views lie on a regular grid: one frontal view (slant 0) and, for
each slant k·Δ (k = 1..m), the same tilts. Synthesis adds ``v{n}.sx/sy``: each output
pixel's source in the input views, the same map the measures read.

Shared by the nodes BtfRender, BtfRead, BtfAlign, BtfSynth and bench/bench_btf.py.
"""
from __future__ import annotations

import math

import numpy as np

from proxyshade.errors import NodeInputError
from proxyshade.plate import Plate

GRID_TOL = 1e-6  # degrees


# ---------------------------------------------------------------- views and stacks

def view_grid(slant_step: float, slant_max: float, tilts) -> list[dict]:
    """The frontal view, then for each slant k·``slant_step`` up to ``slant_max`` every tilt."""
    views = [{"slant": 0.0, "tilt": 0.0}]
    m = int(math.floor(slant_max / slant_step + 1e-9))
    for k in range(1, m + 1):
        for t in tilts:
            views.append({"slant": float(k * slant_step), "tilt": float(t)})
    return views


def check_views(views: list[dict], field: str = "views") -> dict:
    """The grid of ``views`` (``{"step", "slants", "tilts", "index": {(k, t): n}}``) or a
    one-line ``NodeInputError`` naming ``field``: a slant outside [0°, 90°), no frontal
    view, slants not multiples of one step, slants missing a tilt the others have."""
    if not views:
        raise NodeInputError(f"{field}: the stack has no views; give at least a frontal view")
    for n, v in enumerate(views):
        s, t = v.get("slant"), v.get("tilt")
        if not all(isinstance(x, (int, float)) and math.isfinite(x) for x in (s, t)):
            raise NodeInputError(f"{field}[{n}]: slant and tilt must be numbers (degrees), got {s!r}, {t!r}")
        if not 0.0 <= s < 90.0:
            raise NodeInputError(f"{field}[{n}]: slant {s:g}° is outside [0°, 90°); a view at 90° or more sees "
                                 "the sample edge-on or from below: drop it")
    frontal = [n for n, v in enumerate(views) if abs(v["slant"]) <= GRID_TOL]
    if len(frontal) != 1:
        raise NodeInputError(f"{field}: the stack has {len(frontal)} frontal views (slant 0°); it needs exactly "
                             "one: add a view at slant 0 (or drop the duplicates)")
    slants = sorted({round(v["slant"], 6) for v in views if v["slant"] > GRID_TOL})
    index = {(0, 0.0): frontal[0]}
    if not slants:
        return {"step": 0.0, "slants": [0.0], "tilts": [], "index": index}
    step = slants[0]
    for k, s in enumerate(slants, 1):
        if abs(s - k * step) > 1e-4:
            raise NodeInputError(f"{field}: slants {', '.join(f'{x:g}' for x in slants)} are off a regular grid "
                                 f"({s:g}° is not {k} × {step:g}°); "
                                 "give slants 0, Δ, 2Δ, ... with no gaps")
    tilts = sorted({round(v["tilt"], 6) for v in views if v["slant"] > GRID_TOL})
    for n, v in enumerate(views):
        if n == frontal[0]:
            continue
        key = (int(round(v["slant"] / step)), round(v["tilt"], 6))
        if key in index:
            raise NodeInputError(f"{field}[{n}]: slant {v['slant']}°, tilt {v['tilt']}° is given twice; drop one")
        index[key] = n
    for k in range(1, len(slants) + 1):
        missing = [t for t in tilts if (k, t) not in index]
        if missing:
            raise NodeInputError(f"{field}: views are off a regular grid: slant {k * step:g}° has no view at tilt "
                                 f"{missing[0]:g}° (the tilts are {', '.join(f'{x:g}' for x in tilts)}); add it or drop that tilt everywhere")
    return {"step": step, "slants": [0.0] + slants, "tilts": tilts, "index": index}


def grid_edges(views: list[dict]) -> np.ndarray:
    """(E, 2) pairs of neighbouring views on the grid sharing a lighting direction: the
    same tilt at neighbouring slants (slant 1 with the frontal view) and neighbouring
    tilts at one slant; views without a ``light`` count as sharing it."""
    g = check_views(views)
    idx, tilts, edges = g["index"], g["tilts"], []
    for k in range(1, len(g["slants"])):
        for a, t in enumerate(tilts):
            here = idx[(k, t)]
            edges.append((idx[(k - 1, t)] if k > 1 else idx[(0, 0.0)], here))
            if a + 1 < len(tilts):
                edges.append((here, idx[(k, tilts[a + 1])]))
    edges = [(a, b) for a, b in edges if _same_light(views[a], views[b])]
    return np.array(edges, np.int64).reshape(-1, 2)


def _same_light(a: dict, b: dict) -> bool:
    la, lb = a.get("light"), b.get("light")
    return la is None or lb is None or bool(np.allclose(la, lb, atol=1e-6))


def stack_arrays(plate: Plate, field: str = "stack") -> tuple[list[dict], np.ndarray]:
    """(views, (V, H, W, 3) float32 images) of a stack plate; one-line errors for a plate
    that is not one (no ``meta['views']``, a view's channels missing, NaN or Inf)."""
    views = plate.meta.get("views")
    if not isinstance(views, list) or not isinstance(plate.meta.get("btf"), dict):
        raise NodeInputError(f"{field}: the plate has no meta['views'] / meta['btf']; connect a BtfRender or "
                             "BtfRead node")
    check_views(views, f"{field} views")
    imgs = np.empty((len(views),) + plate.shape + (3,), np.float32)
    for n in range(len(views)):
        for c, ch in enumerate("RGB"):
            name = f"v{n}.{ch}"
            if name not in plate:
                raise NodeInputError(f"{field}: channel {name} is missing for view {n}; connect a BtfRender or "
                                     "BtfRead stack")
            imgs[n, ..., c] = plate[name]
    bad = ~np.isfinite(imgs)
    if bad.any():
        n, y, x, _ = np.argwhere(bad)[0]
        raise NodeInputError(f"{field}: view {n} has {int(bad.sum())} NaN/Inf value(s), first at x={x} y={y}; "
                             "clean the images (clamp or inpaint them)")
    return views, imgs


def stack_plate(images: np.ndarray, views: list[dict], btf: dict, extra: dict | None = None) -> Plate:
    """The stack plate of (V, H, W, 3) ``images`` (plus ``extra`` channels)."""
    ch = {}
    for n in range(images.shape[0]):
        for c, name in enumerate("RGB"):
            ch[f"v{n}.{name}"] = np.ascontiguousarray(images[n, ..., c], np.float32)
    ch.update(extra or {})
    return Plate(ch, {"views": [dict(v) for v in views], "btf": dict(btf)})


# ---------------------------------------------------------------- capture

def view_direction(slant: float, tilt: float) -> np.ndarray:
    """Unit vector from the sample toward a camera at ``slant``, ``tilt`` (degrees; Y up,
    tilt measured from +x toward +z)."""
    s, t = math.radians(slant), math.radians(tilt)
    return np.array([math.sin(s) * math.cos(t), math.cos(s), math.sin(s) * math.sin(t)])


def render_views(points, tris, normals, light: dict, views: list[dict], *, size: int, window: float,
                 centre=(0.0, 0.0), plane: float = 0.0, ambient: float, albedo: np.ndarray,
                 shadow_size: int, bias: float) -> np.ndarray:
    """(V, size, size, 3) float32 orthographic views of a Y-up heightfield mesh, each
    rectified to the plane y = ``plane``: pixel (row i, column j) shows what the view ray
    through plane point (x0 + (j + ½)p, plane, z0 + (i + ½)p) meets first (p =
    ``window`` / ``size``). Lambert, ``albedo`` (V,) per vertex RGB (N, 3), lit by the
    distant ``light`` with percentage-closer shadows (``kernels.shadow``) and an ambient
    term. An oblique projection is affine, so ``raster.rasterize(..., ortho=True)`` of the
    sheared points is exact."""
    from proxyshade.kernels import raster, shadow

    points = np.asarray(points, np.float64)
    L = np.asarray(light["direction"], np.float64)
    E = np.asarray(light.get("color", (1, 1, 1)), np.float64) * float(light.get("intensity", 1.0))
    proj = shadow.ortho_light_projection(L, points, shadow_size)
    m = proj["world_to_cam"]
    ldepth, _, _, _ = raster.rasterize(points @ m[:, :3].T + m[:, 3], tris, width=shadow_size, height=shadow_size,
                                       fx=proj["fx"], fy=proj["fy"], cx=proj["cx"], cy=proj["cy"], near=0.5,
                                       ortho=True)
    p = window / size
    x0, z0 = centre[0] - window / 2, centre[1] - window / 2
    out = np.zeros((len(views), size, size, 3), np.float32)
    for n, v in enumerate(views):
        t = math.tan(math.radians(v["slant"]))
        ct, st = math.cos(math.radians(v["tilt"])), math.sin(math.radians(v["tilt"]))
        lift = points[:, 1] - plane
        d = points @ view_direction(v["slant"], v["tilt"])
        cam = np.column_stack([points[:, 0] - lift * t * ct, -(points[:, 2] - lift * t * st), d - (d.max() + 1.0)])
        _, tri, bary, _ = raster.rasterize(cam, tris, width=size, height=size, fx=1 / p, fy=1 / p, cx=-x0 / p,
                                           cy=-z0 / p, near=0.5, ortho=True)
        cover = tri >= 0
        P = raster.interpolate(points, tris, tri, bary, empty=np.nan).astype(np.float64)
        N = raster.interpolate(normals, tris, tri, bary, normalize=True).astype(np.float64)
        N[N[..., 1] < 0] *= -1.0
        s = shadow.pcf_shadow(P, proj["world_to_map"], ldepth, radius=1, bias=bias).astype(np.float64)
        a = raster.interpolate(albedo, tris, tri, bary).astype(np.float64)
        cos = np.clip(-(N @ L), 0.0, None) * (1.0 - s)
        rgb = a * (ambient + cos[..., None] * E / np.pi)
        out[n] = np.where(cover[..., None], rgb, 0.0)
    return out


def height_views(points, tris, normals, views: list[dict], *, size: int, window: float, centre=(0.0, 0.0),
                 plane: float = 0.0) -> np.ndarray:
    """(V, size, size) float32: ``render_views`` of the world height instead of a colour
    (what each pixel's ray meets first, at which height; 0 where it meets nothing): the
    sample's known heights, for the shard measure (``surface_hits``)."""
    pts = np.asarray(points, np.float64)
    out = render_views(pts, tris, normals, {"direction": [0.0, -1.0, 0.0], "intensity": 0.0}, views, size=size,
                       window=window, centre=centre, plane=plane, ambient=1.0, albedo=np.repeat(pts[:, 1:2], 3, 1),
                       shadow_size=16, bias=0.0)
    return out[..., 0]


def height_albedo(points: np.ndarray, low=(0.16, 0.12, 0.09), high=(0.62, 0.52, 0.40)) -> np.ndarray:
    """(V, 3) albedo ramping from ``low`` at the lowest vertex to ``high`` at the highest."""
    y = points[:, 1]
    t = (y - y.min()) / max(float(y.max() - y.min()), 1e-12)
    return np.asarray(low)[None] + t[:, None] * (np.asarray(high) - np.asarray(low))[None]


def texture_albedo(points: np.ndarray, texture: np.ndarray, extent) -> np.ndarray:
    """(V, 3) albedo from a linear (H, W, 3) ``texture`` stretched over ``extent``
    ((x0, z0), (x1, z1)), read bilinearly (``kernels.lookup``)."""
    from proxyshade.kernels.lookup import lookup

    (ex0, ez0), (ex1, ez1) = extent
    h, w = texture.shape[:2]
    sx = ((points[:, 0] - ex0) / (ex1 - ex0) * w - 0.5)[None]
    sy = ((points[:, 2] - ez0) / (ez1 - ez0) * h - 0.5)[None]
    return lookup(texture, sx, sy)[0].astype(np.float64)


# ---------------------------------------------------------------- alignment

def rectify(images: np.ndarray, views: list[dict], dh: float, pixel: float, *, filter: str = "lanczos3") -> np.ndarray:
    """The views (rectified to one plane) rectified to the parallel plane ``dh`` higher:
    each view read through ``kernels.btf.plane_shift`` with ``kernels.lookup``."""
    from proxyshade.kernels.btf import plane_shift
    from proxyshade.kernels.lookup import lookup

    V, H, W = images.shape[:3]
    rows, cols = np.mgrid[0:H, 0:W].astype(np.float64)
    out = np.empty_like(images)
    for n, v in enumerate(views):
        dx, dy = plane_shift(v["slant"], v["tilt"], dh, pixel)
        out[n] = lookup(images[n], cols + dx, rows + dy, filter=filter)
    return out


def max_shift(views: list[dict], dh: float, pixel: float) -> int:
    """The largest shift in whole pixels (rounded up) any view reads at for plane offset ``dh``."""
    return int(math.ceil(max(abs(math.tan(math.radians(v["slant"]))) for v in views) * abs(dh) / pixel))


def alignment_costs(images: np.ndarray, views: list[dict], pixel: float, offsets) -> np.ndarray:
    """For each plane offset, the mean over neighbouring views of the grid (``grid_edges``)
    of their mean Euclidean intensity distance, over the crop no view reads outside of
    for any of the offsets. (len(offsets),) float64."""
    from proxyshade.kernels.btf import edge_distance

    edges = grid_edges(views)
    V, H, W = images.shape[:3]
    mg = max(max_shift(views, dh, pixel) for dh in offsets) + 3
    if 2 * mg >= min(H, W):
        raise NodeInputError(f"the plane search shifts views by up to {mg} pixels, more than half the {W}x{H} "
                             "views; narrow the search range")
    if not len(edges):
        raise NodeInputError("views: alignment needs neighbouring views lit from one direction; add slanted views "
                             "with the frontal view's light")
    costs = np.empty(len(offsets))
    for k, dh in enumerate(offsets):
        rect = rectify(images, views, float(dh), pixel)
        costs[k] = float(edge_distance(rect, edges, mg, H - mg, mg, W - mg).mean())
    return costs


# ---------------------------------------------------------------- synthesis

def check_synthesis_size(shape, radius: int, levels: int, field: str = "stack") -> None:
    """One-line error when an (H, W) input is smaller than the disk at the coarsest level."""
    d = 2 * radius * 2 ** (levels - 1) + 1
    if min(shape) < d:
        raise NodeInputError(f"{field}: the {shape[1]}x{shape[0]} views are smaller than the disk at the coarsest "
                             f"level ({d} pixels across: radius {radius} × 2^{levels - 1}); use fewer levels, a "
                             "smaller radius or larger views")


MOST_LEVELS = 5


def auto_levels(shape, radius: int, most: int = MOST_LEVELS) -> int:
    """The most multigrid levels (up to ``most``) whose coarsest disk (2·radius·2^(l−1) + 1
    pixels across) fits the (H, W) input: the coarse levels keep the support's patches as
    large as a bump's footprint in the steepest views (fewer seams cutting a bump, which a
    grazing view shows as a sliver)."""
    n = 1
    while n < most and 2 * radius * 2 ** n + 1 <= min(shape):
        n += 1
    return n


def synthesize_view(image: np.ndarray, size, *, radius: int, T: int, levels: int, seed: int, wrap: bool = False):
    """One view on its own, coarse to fine: (qy, qx) int64 sources (H, W) and the visit
    counts per level (list, coarsest first).

    Level l synthesizes every 2^l-th output pixel with the disk scaled up by 2^l in the
    input (its neighbours are the level's own pixels; a neighbour at offset o proposes
    its source − o·2^l). The coarsest level starts from a random permutation of the
    input's pixels (the output's histogram is the input's when the sizes divide) at
    w = 0; each finer level inherits the sources of the coarser one (pixel p from
    p // 2, shifted by the remainder) at w = ½. With ``wrap`` every level's output is a
    torus (the result tiles without a seam; exactly when the size is a multiple of
    2^(levels − 1))."""
    from proxyshade.kernels.btf import disk, gather, no_support, synth_level
    from proxyshade.kernels.random import mix_seed, permutation

    H, W = size
    h, w = image.shape[:2]
    check_synthesis_size((h, w), radius, levels)
    image = np.ascontiguousarray(image, np.float32)
    alone = no_support()
    visits = []
    qy = qx = None
    for lv in range(levels - 1, -1, -1):
        s = 2 ** lv
        Hl, Wl = -(-H // s), -(-W // s)
        if qy is None:
            perm = permutation(mix_seed(seed, 1), h * w)
            src = perm[np.arange(Hl * Wl) % (h * w)]
            qy, qx = (src // w).reshape(Hl, Wl), (src % w).reshape(Hl, Wl)
            k0 = 0
        else:
            rows, cols = np.mgrid[0:Hl, 0:Wl]
            qy = np.clip(qy[rows // 2, cols // 2] + (rows % 2) * s, 0, h - 1)
            qx = np.clip(qx[rows // 2, cols // 2] + (cols % 2) * s, 0, w - 1)
            k0 = T // 2
        qy, qx = np.ascontiguousarray(qy, np.int64), np.ascontiguousarray(qx, np.int64)
        k = np.full((Hl, Wl), k0, np.int64)
        vis = np.zeros((Hl, Wl), np.int64)
        synth_level(inp=image, out=gather(image, qy, qx), qy=qy, qx=qx, k=k, T=int(T), dk=disk(radius, 1, s, wrap),
                    seed=mix_seed(seed, 2), level=lv, sup=alone, visits=vis)
        visits.append(vis)
    return qy, qx, visits


SWEEP_TAU = 0.003  # truncation of the squared RGB distance per view (an occluded view costs no more)
SWEEP_RADIUS = 2  # the costs are summed over (2r + 1)² pixels before the least is taken
SWEEP_REACH = 1 / 3  # the heights tried move the steepest view by up to this share of the views' width
SWEEP_STEP = 0.5  # pixels the steepest view moves between two heights tried


def parallax_shifts(views: list[dict], pixel: float) -> np.ndarray:
    """(V, 2) float64: the pixels (column, row) a point moves in each view (rectified to
    the plane) per world unit of height above the plane (``kernels.btf.plane_shift``)."""
    from proxyshade.kernels.btf import plane_shift

    return np.array([plane_shift(v["slant"], v["tilt"], 1.0, pixel) for v in views], np.float64).reshape(-1, 2)


def box_sum(a: np.ndarray, r: int) -> np.ndarray:
    """(M, h, w): the sum of each (2r + 1)² window of every slice (edge pixels repeated)."""
    k = 2 * r + 1
    c = np.pad(np.pad(a, ((0, 0), (r, r), (r, r)), mode="edge").cumsum(1).cumsum(2), ((0, 0), (1, 0), (1, 0)))
    return c[:, k:, k:] - c[:, :-k, k:] - c[:, k:, :-k] + c[:, :-k, :-k]


def estimate_heights(images: np.ndarray, views: list[dict], support: int, pixel: float, plane: float) -> np.ndarray:
    """(h, w) float64: the world height of the sample at each pixel of the ``support`` view
    (the frontal one), from the views themselves: a plane sweep (``kernels.btf.
    sweep_costs``) over heights that move the steepest view up to ``SWEEP_REACH`` of the
    views' width either side of the plane, ``SWEEP_STEP`` pixels apart, against the views
    lit like the support (a Lambert sample looks the same from every view where it is not
    hidden; a hidden point costs at most ``SWEEP_TAU`` per view); the costs summed over
    ``SWEEP_RADIUS`` windows, the least taken. No other view lit alike: the plane."""
    from proxyshade.kernels.btf import sweep_costs

    h, w = images.shape[1:3]
    sel = [n for n, v in enumerate(views) if n == support or (v["slant"] > GRID_TOL and _same_light(v, views[support]))]
    if len(sel) < 2:
        return np.full((h, w), float(plane))
    shifts = parallax_shifts([views[n] for n in sel], pixel)
    per_height = float(np.abs(shifts).max())  # pixels per world unit, steepest view
    reach = SWEEP_REACH * min(h, w)
    M = 2 * int(math.ceil(reach / SWEEP_STEP)) + 1
    offsets = np.linspace(-reach / per_height, reach / per_height, M)
    cost = np.empty((M, h, w), np.float32)
    sweep_costs(np.ascontiguousarray(images[sel], np.float32), sel.index(support), shifts, offsets, SWEEP_TAU, cost)
    best = np.argmin(box_sum(cost.astype(np.float64), SWEEP_RADIUS), 0)
    return plane + offsets[best]


def stack_geometry(images: np.ndarray, views: list[dict], support: int, pixel: float, plane: float) -> dict:
    """What ``synthesize_stack`` casts the other views through: {views, pixel, plane,
    heights} with the sample's heights at the support view's pixels (``estimate_heights``)."""
    return {"views": views, "pixel": float(pixel), "plane": float(plane),
            "heights": estimate_heights(images, views, support, pixel, plane)}


def cast_sources(heights: np.ndarray, qay: np.ndarray, qax: np.ndarray, views: list[dict], plane: float,
                 pixel: float, *, wrap: bool) -> tuple[np.ndarray, np.ndarray]:
    """(qy, qx), each (V, H, W) int64: for every view, the input pixel that shows what the
    support's synthesized surface (the sample at the support's sources ``qay``, ``qax``,
    at ``heights``) shows at each output pixel from that view's direction
    (``surface_hits``); the support's sources themselves at slant 0."""
    QY = np.empty((len(views),) + qay.shape, np.int64)
    QX = np.empty_like(QY)
    for n, v in enumerate(views):
        QY[n], QX[n] = surface_hits(heights, qay, qax, v["slant"], v["tilt"], plane, pixel, wrap=wrap)
    return QY, QX


def synthesize_others(images: np.ndarray, support: int, qay: np.ndarray, qax: np.ndarray, *, radius: int, T: int,
                      c: float, seed: int, wrap: bool = False, cast=None):
    """Every view but ``support`` given the support's sources: (qy, qx, visits), each
    (V, H, W) int64 (the support's own entries are its sources, visits 0). ``cast``: the
    support's sources as each view sees them (``cast_sources``), the start and the support
    term of that view; None: the support's sources at the same pixel (the paper)."""
    from proxyshade.kernels.btf import Support, disk, gather, synth_others
    from proxyshade.kernels.random import mix_seed

    images = np.ascontiguousarray(images, np.float32)
    V = images.shape[0]
    others = [n for n in range(V) if n != support]
    H, W = qay.shape
    inp_a = images[support]
    if cast is None:
        cy, cx = np.repeat(qay[None], len(others), 0), np.repeat(qax[None], len(others), 0)
        out_a = np.repeat(gather(inp_a, qay, qax)[None], len(others), 0)
    else:
        cy, cx = np.ascontiguousarray(cast[0][others]), np.ascontiguousarray(cast[1][others])
        out_a = np.stack([gather(inp_a, cy[n], cx[n]) for n in range(len(others))])
    qy = np.zeros((len(others), H, W), np.int64)
    qx = np.zeros_like(qy)
    vis = np.zeros_like(qy)
    seeds = np.array([mix_seed(seed, 3, n) for n in others], np.int64)
    synth_others(np.ascontiguousarray(images[others]), Support(out_a, inp_a, cy, cx, float(c), True), int(T),
                 int(T) // 2, disk(radius, wrap=wrap), seeds, qy, qx, vis)
    QY = np.empty((V, H, W), np.int64)
    QX = np.empty_like(QY)
    VIS = np.zeros_like(QY)
    QY[support], QX[support] = qay, qax
    QY[others], QX[others], VIS[others] = qy, qx, vis
    return QY, QX, VIS


MODES = ("sequential", "independent", "columns")


def synthesize_stack(images: np.ndarray, support: int, size, *, mode: str = "sequential", radius: int = 3,
                     radius_other: int = 2, T: int = 4, levels: int | None = None, c: float = 0.25, seed: int = 0,
                     wrap: bool = False, geometry: dict | None = None):
    """Sources (qy, qx) (V, H, W) int64 of a synthesized stack.

    ``sequential`` (the paper): the support view, then every other view given it
    (``synthesize_others``). ``independent``: every view on its own, like the support.
    ``columns``: every view copies the support's sources (whole columns of the stack).
    ``levels`` None: ``auto_levels``. ``wrap``: the stack tiles without a seam.
    ``geometry`` (``stack_geometry``): sequential views start from the support's surface
    as each view sees it, cast through the sample's heights (``cast_sources``; a frontal
    support only); None: from the support's sources at the same pixel."""
    if levels is None:
        levels = auto_levels(images.shape[1:3], radius)
    if mode not in MODES:
        raise NodeInputError(f"mode {mode!r} is not valid; valid modes are {', '.join(MODES)}")
    V = images.shape[0]
    check_synthesis_size(images.shape[1:3], radius, levels)
    qay, qax, _ = synthesize_view(images[support], size, radius=radius, T=T, levels=levels, seed=seed, wrap=wrap)
    if mode == "sequential":
        cast = None
        g = geometry
        if g is not None and g["views"][support]["slant"] <= GRID_TOL:
            cast = cast_sources(g["heights"], qay, qax, g["views"], g["plane"], g["pixel"], wrap=wrap)
        qy, qx, _ = synthesize_others(images, support, qay, qax, radius=radius_other, T=T, c=c, seed=seed, wrap=wrap,
                                      cast=cast)
        return qy, qx
    qy = np.repeat(qay[None], V, 0)
    qx = np.repeat(qax[None], V, 0)
    if mode == "independent":
        from proxyshade.kernels.random import mix_seed

        for n in range(V):
            if n != support:
                qy[n], qx[n], _ = synthesize_view(images[n], size, radius=radius, T=T, levels=levels,
                                                  seed=mix_seed(seed, 4, n), wrap=wrap)
    return qy, qx


def gather_stack(images: np.ndarray, qy: np.ndarray, qx: np.ndarray) -> np.ndarray:
    """(V, H, W, 3): each view's input at its own sources."""
    from proxyshade.kernels.btf import gather

    return np.stack([gather(np.ascontiguousarray(images[n], np.float32), qy[n], qx[n])
                     for n in range(images.shape[0])])


# ---------------------------------------------------------------- shading a surface

def shade_grid(views: list[dict]):
    """The stack's grid for ``kernels.btf.shade_views``: a ``ShadeGrid`` (table (K + 1, nt)
    int64, step, tilts (nt,) sorted in [0°, 360°), spans (nt,) bool). ``spans[j]``: the arc from tilt j
    to the next one (cyclically) is interpolated across; only the largest arc, when it is
    larger than every other one, is unsampled (a grid of tilts 0–90° covers one quadrant;
    tilts evenly around the circle cover it all)."""
    g = check_views(views)
    tilts = sorted({t % 360.0 for t in g["tilts"]}) or [0.0]
    K = len(g["slants"]) - 1
    table = np.empty((K + 1, len(tilts)), np.int64)
    table[0] = g["index"][(0, 0.0)]
    by_mod = {}
    for (k, t), n in g["index"].items():
        if k > 0:
            by_mod[(k, t % 360.0)] = n
    for k in range(1, K + 1):
        for j, t in enumerate(tilts):
            table[k, j] = by_mod[(k, t)]
    gaps = np.array([(tilts[(j + 1) % len(tilts)] - tilts[j]) % 360.0 or 360.0 for j in range(len(tilts))])
    spans = np.ones(len(tilts), np.bool_)
    if len(tilts) > 1:
        big = int(np.argmax(gaps))
        if gaps[big] > np.delete(gaps, big).max() + 1e-6:
            spans[big] = False
    from proxyshade.kernels.btf import ShadeGrid

    return ShadeGrid(table, float(g["step"]), np.array(tilts, np.float64), spans)


def surface_directions(P: np.ndarray, N: np.ndarray, eye) -> tuple[np.ndarray, np.ndarray]:
    """(slant, tilt) in degrees, (H, W) float64, of the direction from each surface point
    ``P`` toward the camera at ``eye``, in the surface frame of the stack: y along the
    normal ``N``, x along world +X projected onto the tangent plane (world +Z where the
    normal is along X), z = x × y (so a Y-up plane's frame is the world's, as BtfRender
    captures it: tilt from +x toward +z)."""
    P = np.asarray(P, np.float64)
    N = np.asarray(N, np.float64)
    N = N / np.maximum(np.linalg.norm(N, axis=-1, keepdims=True), 1e-12)
    d = np.asarray(eye, np.float64) - P
    d /= np.maximum(np.linalg.norm(d, axis=-1, keepdims=True), 1e-12)
    ref = np.zeros_like(N)
    along_x = np.abs(N[..., 0]) > 0.99
    ref[..., 0] = ~along_x
    ref[..., 2] = along_x
    ex = ref - (ref * N).sum(-1, keepdims=True) * N
    ex /= np.maximum(np.linalg.norm(ex, axis=-1, keepdims=True), 1e-12)
    ez = np.cross(ex, N)
    cos = np.clip((d * N).sum(-1), -1.0, 1.0)
    slant = np.degrees(np.arccos(cos))
    tilt = np.degrees(np.arctan2((d * ez).sum(-1), (d * ex).sum(-1)))
    return slant, tilt


def planar_uv(P: np.ndarray, origin, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """Texture coordinates (column, row) of world points by the planar parametrization
    along Y: column = (x − origin x) / ``scale`` − ½, row = (z − origin z) / ``scale`` − ½
    (``scale`` world units per stack pixel; pixel centres at integers)."""
    P = np.asarray(P, np.float64)
    return (P[..., 0] - origin[0]) / scale - 0.5, (P[..., 2] - origin[1]) / scale - 0.5


def grid_surface(points: np.ndarray):
    """A heightfield mesh's own parametrization: ``(xs, zs, U, V)`` for world ``points`` (N,
    3) laid on a regular x–z grid (every x of ``xs`` with every z of ``zs``; a terrain of
    the scene builder), or None for another mesh. U, V (nz, nx) are arc lengths along the
    grid's rows and columns, from its first column and row (offset by the first x and z,
    so a flat grid's U, V are its x, z): the texture keeps its size up a slope, where the
    planar parametrization stretches it by 1/cos of the slope."""
    P = np.asarray(points, np.float64)
    xs, xi = np.unique(np.round(P[:, 0], 9), return_inverse=True)
    zs, zi = np.unique(np.round(P[:, 2], 9), return_inverse=True)
    if len(xs) < 2 or len(zs) < 2 or len(xs) * len(zs) != len(P):
        return None
    G = np.full((len(zs), len(xs), 3), np.nan)
    G[zi.ravel(), xi.ravel()] = P
    if np.isnan(G).any():
        return None
    du = np.linalg.norm(np.diff(G, axis=1), axis=-1)
    dv = np.linalg.norm(np.diff(G, axis=0), axis=-1)
    U = xs[0] + np.concatenate([np.zeros((len(zs), 1)), np.cumsum(du, 1)], 1)
    V = zs[0] + np.concatenate([np.zeros((1, len(xs))), np.cumsum(dv, 0)], 0)
    return xs, zs, U, V


def grid_uv(P: np.ndarray, grid, origin, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """Texture coordinates (column, row) of world points ``P`` (..., 3) on a ``grid_surface``:
    its U, V read bilinearly at the points' (x, z), then as ``planar_uv``: (U − origin x) /
    ``scale`` − ½, (V − origin z) / ``scale`` − ½."""
    xs, zs, U, V = grid
    P = np.asarray(P, np.float64)
    fx = np.interp(P[..., 0], xs, np.arange(len(xs), dtype=np.float64))
    fz = np.interp(P[..., 2], zs, np.arange(len(zs), dtype=np.float64))
    x0 = np.clip(np.floor(fx).astype(np.int64), 0, len(xs) - 2)
    z0 = np.clip(np.floor(fz).astype(np.int64), 0, len(zs) - 2)
    a, b = fx - x0, fz - z0

    def bil(M):
        return ((1 - b) * ((1 - a) * M[z0, x0] + a * M[z0, x0 + 1])
                + b * ((1 - a) * M[z0 + 1, x0] + a * M[z0 + 1, x0 + 1]))

    return (bil(U) - origin[0]) / scale - 0.5, (bil(V) - origin[1]) / scale - 0.5


def shade_surface(images: np.ndarray, views: list[dict], uv, slant: np.ndarray, tilt: np.ndarray,
                  mask: np.ndarray) -> np.ndarray:
    """(H, W, 3) float32: the pixels of ``mask`` shaded from the stack (``kernels.btf.
    shade_views``): bilinear between the four views around each pixel's (slant, tilt),
    each read bilinearly at its texture coordinates ``uv`` (wrapped); 0 elsewhere."""
    from proxyshade.kernels.btf import shade_views

    out = np.zeros(mask.shape + (3,), np.float32)
    shade_views(np.ascontiguousarray(images, np.float32), shade_grid(views),
                np.ascontiguousarray(uv[0], np.float64), np.ascontiguousarray(uv[1], np.float64),
                np.ascontiguousarray(slant, np.float64), np.ascontiguousarray(tilt, np.float64),
                np.ascontiguousarray(mask, np.bool_), out)
    return out


def outside_grid(views: list[dict], slant: np.ndarray, tilt: np.ndarray) -> np.ndarray:
    """Where a direction lies outside the captured ones: slant beyond the largest, or
    (at a slant > 0) a tilt in the grid's unsampled arc (``shade_grid``)."""
    table, step, tilts, spans = shade_grid(views)
    far = slant > (table.shape[0] - 1) * step + 1e-6
    if spans.all():
        return far
    j = int(np.argmin(spans))
    lo, hi = tilts[j], tilts[(j + 1) % len(tilts)]
    phi = np.mod(tilt, 360.0)
    gap = (phi > lo) & (phi < hi) if hi > lo else (phi > lo) | (phi < hi)
    return far | (gap & (slant > 1e-6))


# ---------------------------------------------------------------- measures

def consistency_error(images: np.ndarray, support: int, qy: np.ndarray, qx: np.ndarray) -> np.ndarray:
    """E_c per view: mean ‖A(q_v(p)) − A′(p)‖, A the support's input, A′ its synthesis,
    q_v the input position copied into view v (0 for views that copy the support's)."""
    A = images[support].astype(np.float64)
    Ap = A[qy[support], qx[support]]
    return np.array([np.sqrt(((A[qy[n], qx[n]] - Ap) ** 2).sum(-1)).mean() for n in range(len(qy))])


def seam_error(images: np.ndarray, qy: np.ndarray, qx: np.ndarray) -> np.ndarray:
    """E_s per view: the mean colour jump ‖B′(p) − B′(p′)‖ over 4-neighbour edges (p, p′)
    whose sources are not neighbours the same way (q(p′) − q(p) ≠ p′ − p); 0 with no seam."""
    out = np.zeros(len(qy))
    for n in range(len(qy)):
        B = images[n].astype(np.float64)[qy[n], qx[n]]
        jumps = []
        for ax in (0, 1):
            dy, dx = (1, 0) if ax == 0 else (0, 1)
            a = (slice(None, -1), slice(None)) if ax == 0 else (slice(None), slice(None, -1))
            b = (slice(1, None), slice(None)) if ax == 0 else (slice(None), slice(1, None))
            seam = (qy[n][b] - qy[n][a] != dy) | (qx[n][b] - qx[n][a] != dx)
            jumps.append(np.sqrt(((B[b] - B[a]) ** 2).sum(-1))[seam])
        j = np.concatenate(jumps)
        out[n] = j.mean() if j.size else 0.0
    return out


def tile_jumps(image: np.ndarray) -> tuple[float, float]:
    """(border, interior): the mean colour jump ‖B(p) − B(p′)‖ of an (H, W, 3) tile over the
    4-neighbour edges its repeats add (last column to first, last row to first) and over
    its own edges. A tile that repeats without a seam has border ≈ interior."""
    B = np.asarray(image, np.float64)
    border = np.concatenate([np.linalg.norm(B[:, -1] - B[:, 0], axis=-1), np.linalg.norm(B[-1] - B[0], axis=-1)])
    inner = np.concatenate([np.linalg.norm(np.diff(B, axis=1), axis=-1).ravel(),
                            np.linalg.norm(np.diff(B, axis=0), axis=-1).ravel()])
    return float(border.mean()), float(inner.mean())


LUMA = np.array([0.2126, 0.7152, 0.0722])


def luma_range3(image: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(luminance, lo, hi) of an (h, w, 3) image: lo/hi the least and largest luminance over
    each pixel's 3×3 neighbourhood (edge pixels repeated)."""
    lum = np.asarray(image, np.float64) @ LUMA
    h, w = lum.shape
    pad = np.pad(lum, 1, mode="edge")
    win = np.stack([pad[dy:dy + h, dx:dx + w] for dy in range(3) for dx in range(3)])
    return lum, win.min(0), win.max(0)


def local_spread(images) -> float:
    """The median over views and pixels of the 3×3 luminance spread (hi − lo) of input
    views: how much a pixel's luminance varies within one pixel of misregistration. The
    shard margin: a synthesized pixel that far off the range it should lie in is not a
    resampling or alignment error."""
    return float(np.median([np.median(hi - lo) for _, lo, hi in (luma_range3(im) for im in images)]))


def surface_hits(heights: np.ndarray, qay: np.ndarray, qax: np.ndarray, slant: float, tilt: float, plane: float,
                 pixel: float, *, wrap: bool) -> tuple[np.ndarray, np.ndarray]:
    """(iy, ix), each (H, W) int64: the input pixel of the view at ``slant``, ``tilt`` that
    shows what the synthesized view should show at each output pixel, for a sample of
    known ``heights`` (h, w: world height of each pixel of the support's input).

    The synthesized surface is the input's at the support's sources: at output pixel X the
    input point q_A(X), at height heights[q_A(X)]. The view's ray through plane point p
    meets height y above X = p + s·(cos φ, sin φ), s = (y − plane)·tan θ / ``pixel``; it is
    cast from the highest s down and stops at the first X whose surface reaches the ray.
    That surface point appears in the input view at q_A(X) − s·(cos φ, sin φ). Inside one
    patch of the support that is q_A(p) for every s: the view copies its own input there.
    ``wrap``: the output tiles (X wraps around), else X is clamped to it."""
    H, W = qay.shape
    h, w = heights.shape
    t = math.tan(math.radians(slant))
    ct, st = math.cos(math.radians(tilt)), math.sin(math.radians(tilt))
    rows, cols = np.mgrid[0:H, 0:W]
    iy, ix = qay.astype(np.int64).copy(), qax.astype(np.int64).copy()
    if t < 1e-9:
        return iy, ix
    found = np.zeros((H, W), np.bool_)
    lo, hi = float(heights.min()), float(heights.max())
    for s in range(int(math.ceil((hi - plane) * t / pixel)) + 1, int(math.floor((lo - plane) * t / pixel)) - 2, -1):
        r = np.rint(rows + s * st).astype(np.int64)
        c = np.rint(cols + s * ct).astype(np.int64)
        r, c = (r % H, c % W) if wrap else (np.clip(r, 0, H - 1), np.clip(c, 0, W - 1))
        y, x = qay[r, c], qax[r, c]
        hit = ~found & (heights[y, x] >= plane + s * pixel / t)
        iy[hit] = np.clip(np.rint(y - s * st).astype(np.int64), 0, h - 1)[hit]
        ix[hit] = np.clip(np.rint(x - s * ct).astype(np.int64), 0, w - 1)[hit]
        found |= hit
    return iy, ix


def shard_mask(lum: np.ndarray, lo: np.ndarray, hi: np.ndarray, margin: float) -> np.ndarray:
    """Where ``lum`` lies outside [lo − margin, hi + margin]: the shards."""
    return (lum > hi + margin) | (lum < lo - margin)


def contact_sheet(images: np.ndarray, views: list[dict], *, gap: int = 2) -> np.ndarray:
    """(rows, cols, 3) float32 picture of a stack: a row per slant, a column per tilt (the
    frontal view alone in the first row), ``gap`` black pixels between cells."""
    g = check_views(views)
    V, H, W = images.shape[:3]
    ncol = max(len(g["tilts"]), 1)
    nrow = len(g["slants"])
    out = np.zeros((nrow * H + (nrow - 1) * gap, ncol * W + (ncol - 1) * gap, 3), np.float32)
    for (k, t), n in g["index"].items():
        c = 0 if k == 0 else g["tilts"].index(t)
        out[k * (H + gap):k * (H + gap) + H, c * (W + gap):c * (W + gap) + W] = images[n]
    return out
