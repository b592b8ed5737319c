"""Modulative shadow mapping with percentage-closer filtering.

Williams 1978, "Casting curved shadows on curved surfaces" (shadow maps); Reeves, Salesin
and Cook 1987, "Rendering antialiased shadows with depth maps" (percentage-closer
filtering). Bonneel et al. 2010, §7 use "simple modulative shadow mapping using the
extended depth map" to let CG elements shadow the synthesized scene.

A shadow map is an (S, T) depth image of the occluders seen from the light; a world
point maps to map coordinates ``(col, row, depth) = M @ (x, y, z, 1)`` with a 3x4
affine ``M`` (an orthographic light for a distant light), pixel centres at integer
coordinates. A point is occluded by a texel when the texel's depth is below the point's
depth minus ``bias``. PCF averages that binary test over (2r+1)^2 taps one texel apart,
each tap bilinearly weighted over its 4 texels, so shadow edges are soft and vary
continuously with the point. Pure functions on arrays; rows run in parallel, each
writing only its own output row.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import JIT, PJIT


@njit(**JIT)
def _occluded(depth_map, r, c, d, bias):  # pragma: no cover - compiled
    if r < 0 or c < 0 or r >= depth_map.shape[0] or c >= depth_map.shape[1]:
        return 0.0
    return 1.0 if depth_map[r, c] < d - bias else 0.0


@njit(**PJIT)
def _pcf(px, py, pz, m, depth_map, radius, bias, out):  # pragma: no cover - compiled
    h, w = px.shape
    ntap = (2 * radius + 1) * (2 * radius + 1)
    for y in prange(h):
        for x in range(w):
            X, Y, Z = np.float64(px[y, x]), np.float64(py[y, x]), np.float64(pz[y, x])
            if not (np.isfinite(X) and np.isfinite(Y) and np.isfinite(Z)):
                out[y, x] = 0.0
                continue
            fc = m[0, 0] * X + m[0, 1] * Y + m[0, 2] * Z + m[0, 3]
            fr = m[1, 0] * X + m[1, 1] * Y + m[1, 2] * Z + m[1, 3]
            d = m[2, 0] * X + m[2, 1] * Y + m[2, 2] * Z + m[2, 3]
            acc = 0.0
            for oy in range(-radius, radius + 1):
                for ox in range(-radius, radius + 1):
                    tc = fc + ox
                    tr = fr + oy
                    c0 = int(np.floor(tc))
                    r0 = int(np.floor(tr))
                    wc = tc - c0
                    wr = tr - r0
                    acc += ((1 - wr) * ((1 - wc) * _occluded(depth_map, r0, c0, d, bias)
                                        + wc * _occluded(depth_map, r0, c0 + 1, d, bias))
                            + wr * ((1 - wc) * _occluded(depth_map, r0 + 1, c0, d, bias)
                                    + wc * _occluded(depth_map, r0 + 1, c0 + 1, d, bias)))
            out[y, x] = acc / ntap


def pcf_shadow(P: np.ndarray, world_to_map: np.ndarray, depth_map: np.ndarray, *, radius: int = 1,
               bias: float = 0.0) -> np.ndarray:
    """Fraction of each point in shadow, by percentage-closer filtering.

    Parameters
    ----------
    P : (M, N, 3) ndarray
        World positions; non-finite entries (sky) are never shadowed.
    world_to_map : (3, 4) ndarray
        Affine map from world to (column, row, depth) in shadow-map pixels.
    depth_map : (S, T) ndarray
        Occluder depth per texel (inf where empty).
    radius : int
        PCF taps span ``2*radius + 1`` texels per axis (0 = bilinear test only).
    bias : float
        Depth tolerance in depth units.

    Returns
    -------
    (M, N) float32 ndarray in [0, 1].
    """
    P = np.asarray(P)
    px, py, pz = (np.ascontiguousarray(P[..., i], dtype=np.float64) for i in range(3))
    m = np.ascontiguousarray(world_to_map, dtype=np.float64).reshape(3, 4)
    dm = np.ascontiguousarray(depth_map, dtype=np.float64)
    out = np.zeros(px.shape, np.float64)
    _pcf(px, py, pz, m, dm, int(radius), float(bias), out)
    return out.astype(np.float32)


def light_frame(direction) -> np.ndarray:
    """(3, 3) orthonormal rows ``u, v, l`` with ``l`` the unit direction light travels.

    ``u`` and ``v`` span the plane the light looks at; the frame is right-handed and a
    deterministic function of ``direction``.
    """
    l = np.asarray(direction, np.float64).reshape(3)
    n = np.linalg.norm(l)
    if not np.isfinite(n) or n == 0:
        raise ValueError(f"light direction {direction!r} has no length")
    l = l / n
    helper = np.array([0.0, 1.0, 0.0]) if abs(l[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    u = np.cross(helper, l)
    u /= np.linalg.norm(u)
    v = np.cross(l, u)
    return np.stack([u, v, l])


def ortho_light_projection(direction, points: np.ndarray, size: int, *, margin: float = 0.02) -> dict:
    """An orthographic light view that frames ``points`` in a ``size`` x ``size`` map.

    The light camera looks along ``direction`` (x = u, y = v, z = -l of ``light_frame``,
    origin at the points' centre in u, v and one unit before the nearest point along l),
    in the conventions of ``proxyshade.kernels.raster.rasterize(..., ortho=True)``.

    Returns a dict with
    ``world_to_cam`` (3, 4): world -> light-camera space, to feed the rasterizer;
    ``fx``, ``fy``, ``cx``, ``cy``: its intrinsics (pixels per world unit, centre);
    ``world_to_map`` (3, 4): world -> (column, row, depth) with pixel centres at integers
    and depth = the rasterizer's depth (distance along l past the origin), for ``pcf_shadow``;
    ``texel``: the texel size in world units.
    """
    frame = light_frame(direction)
    pts = np.asarray(points, np.float64).reshape(-1, 3)
    if not len(pts):
        raise ValueError("no points to frame")
    uvl = pts @ frame.T
    lo, hi = uvl.min(0), uvl.max(0)
    extent = float(max(hi[0] - lo[0], hi[1] - lo[1], 1e-9)) * (1 + 2 * margin)
    uc, vc = 0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])
    d0 = lo[2] - 1.0
    texel = extent / size
    w2c = np.zeros((3, 4))
    w2c[0, :3], w2c[0, 3] = frame[0], -uc
    w2c[1, :3], w2c[1, 3] = frame[1], -vc
    w2c[2, :3], w2c[2, 3] = -frame[2], d0
    f = 1.0 / texel
    c = size / 2.0
    w2m = np.zeros((3, 4))
    w2m[0] = f * w2c[0]
    w2m[0, 3] += c - 0.5
    w2m[1] = -f * w2c[1]
    w2m[1, 3] += c - 0.5
    w2m[2] = -w2c[2]
    return {"world_to_cam": w2c, "fx": f, "fy": f, "cx": c, "cy": c, "world_to_map": w2m, "texel": texel}
