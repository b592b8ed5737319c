"""A z-buffer triangle rasterizer for perspective and orthographic cameras.

Triangles come in camera space (x right, y up, looking down −z, as USD and OpenGL) with
pinhole intrinsics in pixels; they are clipped against the near plane, snapped to 1/256
pixel and scan-converted with exact integer edge functions, sampling pixel centres with a
top-left-style tie rule: of two triangles sharing an edge, exactly one owns the pixels on
it, so closed meshes have no cracks and no double coverage. Depth and barycentrics are
perspective-correct. Each output pixel keeps the nearest triangle (ties: the lower id),
so results do not depend on the thread count.

Outputs per pixel: depth (distance along the view axis, inf where empty), the triangle
id (−1 where empty) and the barycentric coordinates with respect to the triangle's own
three vertices, to interpolate any vertex attribute (world position, normal, uv).

The same kernel serves the proxy render, CG renders and shadow maps (``ortho=True``:
x, y map linearly to pixels and depth is −z).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import JIT, PJIT

SUB = 256  # sub-pixel steps per pixel (8 bits)
BAND = 16  # rows per parallel work unit


class Camera(NamedTuple):
    """Intrinsics in pixels (``rasterize``'s ``fx``, ``fy``, ``cx``, ``cy``, ``ortho``) and
    the image size."""

    fx: float
    fy: float
    cx: float
    cy: float
    ortho: bool
    width: int
    height: int


class ScreenTris(NamedTuple):
    """Screen triangles of ``_setup``: fixed-point vertices ``xy`` (N, 3, 2), depths ``dep``
    (N, 3), barycentrics ``bar`` (N, 3, 3) w.r.t. the source triangle, its id ``src`` (N,)
    and the rows ``r0``..``r1`` (N,) it may cover."""

    xy: np.ndarray
    dep: np.ndarray
    bar: np.ndarray
    src: np.ndarray
    r0: np.ndarray
    r1: np.ndarray


def _planes(cam, near):
    """Clip planes (5, 4) (n, d) with n·p + d >= 0 inside: near, then the image widened by a
    guard band of one image size on each side (keeps fixed-point coordinates small)."""
    fx, fy, cx, cy, ortho, width, height = cam
    gx = float(width)
    gy = float(height)
    pl = np.zeros((5, 4), np.float64)
    pl[0, 2] = -1.0
    pl[0, 3] = -near
    if ortho:
        pl[1, 0] = fx
        pl[1, 3] = cx + gx
        pl[2, 0] = -fx
        pl[2, 3] = width + gx - cx
        pl[3, 1] = -fy
        pl[3, 3] = cy + gy
        pl[4, 1] = fy
        pl[4, 3] = height + gy - cy
    else:
        pl[1, 0] = fx
        pl[1, 2] = -(cx + gx)
        pl[2, 0] = -fx
        pl[2, 2] = -(width + gx - cx)
        pl[3, 1] = -fy
        pl[3, 2] = -(cy + gy)
        pl[4, 1] = fy
        pl[4, 2] = -(height + gy - cy)
    return pl


@njit(**JIT)
def _clip(planes, poly, bary, tmp, tbar):
    """Sutherland-Hodgman clip of the triangle in ``poly[:3]`` (camera space) by ``planes``;
    writes the polygon (up to 8 vertices) into ``poly`` and each vertex's barycentrics
    w.r.t. the triangle into ``bary``; returns its size. Scalar loops only (no array
    temporaries: each one is code to compile)."""
    n = 3
    for k in range(3):
        for m in range(3):
            bary[k, m] = 1.0 if k == m else 0.0
    for q in range(planes.shape[0]):
        m = 0
        for k in range(n):
            k1 = (k + 1) % n
            da = planes[q, 0] * poly[k, 0] + planes[q, 1] * poly[k, 1] + planes[q, 2] * poly[k, 2] + planes[q, 3]
            db = planes[q, 0] * poly[k1, 0] + planes[q, 1] * poly[k1, 1] + planes[q, 2] * poly[k1, 2] + planes[q, 3]
            if da >= 0:
                for c in range(3):
                    tmp[m, c] = poly[k, c]
                    tbar[m, c] = bary[k, c]
                m += 1
            if (da >= 0) != (db >= 0):
                # computed from the same end whichever way the edge is walked, so a shared
                # edge clips to the same point in both triangles (no cracks at the near plane)
                a_first = poly[k, 0] < poly[k1, 0] or (poly[k, 0] == poly[k1, 0] and (
                    poly[k, 1] < poly[k1, 1] or (poly[k, 1] == poly[k1, 1] and poly[k, 2] < poly[k1, 2])))
                if a_first:
                    u, v, t = k, k1, da / (da - db)
                else:
                    u, v, t = k1, k, db / (db - da)
                for c in range(3):
                    tmp[m, c] = poly[u, c] + t * (poly[v, c] - poly[u, c])
                    tbar[m, c] = bary[u, c] + t * (bary[v, c] - bary[u, c])
                m += 1
        n = m
        if n < 3:
            return 0
        for k in range(n):
            for c in range(3):
                poly[k, c] = tmp[k, c]
                bary[k, c] = tbar[k, c]
    return n


@njit(**JIT)
def _polygon(points, tris, ti, planes, cam, scratch, sx, sy, sd):
    """Source triangle ``ti`` clipped by ``planes`` and projected: returns the polygon's
    size n; its vertices' fixed-point screen positions in ``sx``, ``sy`` and depths in
    ``sd`` (n,), their barycentrics w.r.t. the triangle in ``scratch[1]``
    (``scratch``: (4, 9, 3) of the caller's)."""
    fx, fy, cx, cy, ortho = cam.fx, cam.fy, cam.cx, cam.cy, cam.ortho
    inside = True  # the common case: no plane cuts the triangle, no clipping needed
    for k in range(3):
        v = tris[ti, k]
        for c in range(3):
            scratch[0, k, c] = points[v, c]
        for q in range(planes.shape[0]):
            if (planes[q, 0] * points[v, 0] + planes[q, 1] * points[v, 1] + planes[q, 2] * points[v, 2]
                    + planes[q, 3] < 0):
                inside = False
    if inside:
        n = 3
        for k in range(3):
            for m in range(3):
                scratch[1, k, m] = 1.0 if k == m else 0.0
    else:
        n = _clip(planes, scratch[0], scratch[1], scratch[2], scratch[3])
    for k in range(n):  # camera space -> (column, row, depth)
        x, y, z = scratch[0, k, 0], scratch[0, k, 1], scratch[0, k, 2]
        if ortho:
            c, r, d = cx + fx * x, cy - fy * y, -z
        else:
            d = -z
            c, r = cx + fx * x / d, cy - fy * y / d
        sx[k] = np.int64(np.floor(c * SUB + 0.5))
        sy[k] = np.int64(np.floor(r * SUB + 0.5))
        sd[k] = d
    return n


@njit(**JIT)
def _setup_pass(points, tris, planes, cam, write, counts, xy, dep, bar, src, r0, r1):
    """The source triangles fanned into the screen triangles that may cover a pixel
    centre: without ``write`` how many each yields in ``counts[ti + 1]``; with it those
    triangles written from slot ``counts[ti]`` on into ``xy``, ``dep``, ``bar``, ``src``,
    ``r0``, ``r1`` (``ScreenTris``' fields)."""
    scratch = np.empty((4, 9, 3), np.float64)
    sx = np.empty(9, np.int64)
    sy = np.empty(9, np.int64)
    sd = np.empty(9, np.float64)
    width, height = cam.width, cam.height
    for ti in range(tris.shape[0]):
        if write and counts[ti + 1] == counts[ti]:
            continue
        n = _polygon(points, tris, ti, planes, cam, scratch, sx, sy, sd)
        kept = 0
        for f in range(1, n - 1):
            lo = min(sy[0], min(sy[f], sy[f + 1]))
            hi = max(sy[0], max(sy[f], sy[f + 1]))
            clo = min(sx[0], min(sx[f], sx[f + 1]))
            chi = max(sx[0], max(sx[f], sx[f + 1]))
            # rows whose centres (i + 0.5) may lie inside: (i*SUB + SUB/2) in [lo, hi]
            a = (lo - SUB // 2 + SUB - 1) // SUB
            b = (hi - SUB // 2) // SUB
            ca = (clo - SUB // 2 + SUB - 1) // SUB
            cb = (chi - SUB // 2) // SUB
            if b < 0 or a > height - 1 or cb < 0 or ca > width - 1 or a > b or ca > cb:
                continue
            if write:
                o = counts[ti] + kept
                for q in range(3):
                    v = 0 if q == 0 else f + q - 1
                    xy[o, q, 0] = sx[v]
                    xy[o, q, 1] = sy[v]
                    dep[o, q] = sd[v]
                    for m in range(3):
                        bar[o, q, m] = scratch[1, v, m]
                src[o] = ti
                r0[o] = max(a, 0)
                r1[o] = min(b, height - 1)
            kept += 1
        if not write:
            counts[ti + 1] = kept


def _setup(points, tris, cam, near):
    """Clip and project every triangle; fan the clipped polygons into screen triangles.

    Two passes over the triangles (``_setup_pass``), serial: the first counts the screen
    triangles each source triangle yields (after clipping, dropping those that cover no
    pixel centre), the second writes them at offsets from the prefix sum, in (source id,
    fan) order. Per screen triangle: fixed-point vertices (3, 2), depths (3,), barycentrics
    w.r.t. the source triangle (3, 3), source id and the rows it may cover
    (``ScreenTris``). Serial: 16 ms for the lake's 62k triangles on one thread, a tenth of
    the raster, where a parallel pass took about a second more to compile.
    """
    t = tris.shape[0]
    planes = _planes(cam, near)
    counts = np.zeros(t + 1, np.int64)
    none = ScreenTris(np.empty((0, 3, 2), np.int64), np.empty((0, 3), np.float64), np.empty((0, 3, 3), np.float64),
                      np.empty(0, np.int64), np.empty(0, np.int64), np.empty(0, np.int64))
    _setup_pass(points=points, tris=tris, planes=planes, cam=cam, write=False, counts=counts, **none._asdict())
    np.cumsum(counts, out=counts)
    total = int(counts[t])
    out = ScreenTris(np.empty((total, 3, 2), np.int64), np.empty((total, 3), np.float64),
                     np.empty((total, 3, 3), np.float64), np.empty(total, np.int64), np.empty(total, np.int64),
                     np.empty(total, np.int64))
    _setup_pass(points=points, tris=tris, planes=planes, cam=cam, write=True, counts=counts, **out._asdict())
    return out


@njit(**JIT)
def _owns(ax, ay, bx, by):
    """Tie rule for pixel centres exactly on edge a->b: antisymmetric in the edge's
    direction, so of two triangles sharing the edge exactly one includes those pixels."""
    dy = by - ay
    dx = bx - ax
    return dy > 0 or (dy == 0 and dx < 0)


@njit(**PJIT)
def _raster_bands(xy, dep, bar, src, r0, r1, width, height, band_start, band_list, depth, tid, bary, count):
    """Each band of ``BAND`` rows scan-converts its listed screen triangles (``ScreenTris``'
    fields ``xy`` to ``r1``) into the nearest-triangle ``depth``, ``tid``, ``bary`` and the
    coverage ``count``."""
    nb = band_start.shape[0] - 1
    stride = 8  # band order 0, 8, 16, ..., 1, 9, ...: each thread's chunk spans the whole image
    per = (nb + stride - 1) // stride
    for k in prange(per * stride):
        b = (k % per) * stride + k // per
        if b >= nb:
            continue
        for q in range(band_start[b], band_start[b + 1]):
            s = band_list[q]
            x0, y0 = xy[s, 0, 0], xy[s, 0, 1]
            x1, y1 = xy[s, 1, 0], xy[s, 1, 1]
            x2, y2 = xy[s, 2, 0], xy[s, 2, 1]
            area = (x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0)
            if area == 0:
                continue
            if area < 0:  # make the winding positive; the triangle is the same set
                x1, y1, x2, y2 = x2, y2, x1, y1
                v1, v2 = 2, 1
                area = -area
            else:
                v1, v2 = 1, 2
            o0 = _owns(x1, y1, x2, y2)
            o1 = _owns(x2, y2, x0, y0)
            o2 = _owns(x0, y0, x1, y1)
            xmin = min(x0, min(x1, x2))
            xmax = max(x0, max(x1, x2))
            c0 = max((xmin - SUB // 2 + SUB - 1) // SUB, 0)
            c1 = min((xmax - SUB // 2) // SUB, width - 1)
            rs = max(r0[s], b * BAND)
            re = min(r1[s], min((b + 1) * BAND, height) - 1)
            d0 = dep[s, 0]
            d1 = dep[s, v1]
            d2 = dep[s, v2]
            # edge functions stepped exactly in integers along the row
            dx0 = -(y2 - y1) * SUB
            dx1 = -(y0 - y2) * SUB
            dx2 = -(y1 - y0) * SUB
            px0 = c0 * SUB + SUB // 2
            for i in range(rs, re + 1):
                py = i * SUB + SUB // 2
                e0 = (x2 - x1) * (py - y1) - (y2 - y1) * (px0 - x1) - dx0
                e1 = (x0 - x2) * (py - y2) - (y0 - y2) * (px0 - x2) - dx1
                e2 = (x1 - x0) * (py - y0) - (y1 - y0) * (px0 - x0) - dx2
                for j in range(c0, c1 + 1):
                    e0 += dx0
                    e1 += dx1
                    e2 += dx2
                    if e0 < 0 or e1 < 0 or e2 < 0:
                        continue
                    if (e0 == 0 and not o0) or (e1 == 0 and not o1) or (e2 == 0 and not o2):
                        continue
                    l0 = e0 / area
                    l1 = e1 / area
                    l2 = e2 / area
                    iz = l0 / d0 + l1 / d1 + l2 / d2
                    z = 1.0 / iz
                    count[i, j] += 1
                    if z < depth[i, j] or (z == depth[i, j] and src[s] < tid[i, j]):
                        depth[i, j] = z
                        tid[i, j] = src[s]
                        for m in range(3):
                            bary[i, j, m] = (l0 * bar[s, 0, m] / d0 + l1 * bar[s, v1, m] / d1
                                             + l2 * bar[s, v2, m] / d2) * z


def rasterize(points: np.ndarray, tris: np.ndarray, *, width: int, height: int, fx: float, fy: float,
              cx: float, cy: float, near: float = 1e-3, ortho: bool = False):
    """Rasterize triangles given in camera space.

    Parameters
    ----------
    points : (V, 3) float
        Camera-space vertex positions (x right, y up, the camera looks down −z).
    tris : (T, 3) int
        Vertex indices of each triangle (either winding; nothing is culled), each in
        0..V − 1 (``io.usd`` checks a scene's).
    width, height : int
        Image size in pixels.
    fx, fy, cx, cy : float
        Pixel = (cx + fx·x/d, cy − fy·y/d) with d = −z (perspective), or
        (cx + fx·x, cy − fy·y) with ``ortho``. Pixel (row i, column j) has its centre at
        (j + 0.5, i + 0.5).
    near : float
        Near clipping distance (perspective) or minimum −z (orthographic).

    Returns
    -------
    depth : (H, W) float32, inf where empty
    tri : (H, W) int32, −1 where empty
    bary : (H, W, 3) float32 barycentrics w.r.t. the triangle's vertices
    count : (H, W) int32, how many triangles cover each pixel centre (depth ignored)
    """
    points = np.ascontiguousarray(points, dtype=np.float64)
    tris = np.ascontiguousarray(tris, dtype=np.int64)
    depth = np.full((height, width), np.inf, np.float64)
    tid = np.full((height, width), -1, np.int32)
    bary = np.zeros((height, width, 3), np.float32)
    count = np.zeros((height, width), np.int32)
    if tris.shape[0] == 0:
        return depth.astype(np.float32), tid, bary, count
    cam = Camera(float(fx), float(fy), float(cx), float(cy), bool(ortho), int(width), int(height))
    st = _setup(points, tris, cam, float(near))
    nb = (height + BAND - 1) // BAND
    band_start, band_list = bin_rows(st.r0, st.r1, nb, BAND)  # serial: 0.3 ms for the lake
    _raster_bands(**st._asdict(), width=width, height=height, band_start=band_start, band_list=band_list, depth=depth,
                  tid=tid, bary=bary, count=count)
    return depth.astype(np.float32), tid, bary, count


BIN_CHUNKS = 16  # item chunks of bin_rows_parallel (fixed: the list does not depend on threads)


@njit(**PJIT)
def _bin_count(r0, r1, band, cnt):
    nchunk = cnt.shape[0]
    n = r0.shape[0]
    step = (n + nchunk - 1) // nchunk
    for c in prange(nchunk):
        for s in range(c * step, min(n, (c + 1) * step)):
            if r0[s] <= r1[s]:
                for b in range(r0[s] // band, r1[s] // band + 1):
                    cnt[c, b] += 1


@njit(**PJIT)
def _bin_fill(r0, r1, band, off, out):
    nchunk = off.shape[0]
    n = r0.shape[0]
    step = (n + nchunk - 1) // nchunk
    for c in prange(nchunk):
        pos = off[c].copy()
        for s in range(c * step, min(n, (c + 1) * step)):
            if r0[s] <= r1[s]:
                for b in range(r0[s] // band, r1[s] // band + 1):
                    out[pos[b]] = s
                    pos[b] += 1


def bin_rows_parallel(r0, r1, nb, band):
    """``bin_rows`` in parallel: items counted and listed by fixed chunks of the index
    range, each chunk's items placed after the earlier chunks' in every band, so the
    lists are ``bin_rows``' exactly."""
    cnt = np.zeros((BIN_CHUNKS, nb), np.int64)
    _bin_count(r0, r1, band, cnt)
    start = np.zeros(nb + 1, np.int64)
    np.cumsum(cnt.sum(axis=0), out=start[1:])
    off = start[:-1][None, :] + np.cumsum(cnt, axis=0) - cnt  # chunk c's first slot in each band
    out = np.empty(int(start[-1]), np.int64)
    _bin_fill(r0, r1, band, np.ascontiguousarray(off), out)
    return start, out


@njit(**JIT)
def bin_rows(r0, r1, nb, band):
    """Items spanning rows r0[s]..r1[s] listed per band of ``band`` rows, in increasing
    index order (items with r0 > r1 are skipped): (band starts (nb + 1,), item list)."""
    cnt = np.zeros(nb + 1, np.int64)
    for s in range(r0.shape[0]):
        if r0[s] <= r1[s]:
            for b in range(r0[s] // band, r1[s] // band + 1):
                cnt[b + 1] += 1
    for b in range(nb):
        cnt[b + 1] += cnt[b]
    fill = cnt[:-1].copy()
    out = np.empty(cnt[nb], np.int64)
    for s in range(r0.shape[0]):
        if r0[s] <= r1[s]:
            for b in range(r0[s] // band, r1[s] // band + 1):
                out[fill[b]] = s
                fill[b] += 1
    return cnt, out


@njit(**PJIT)
def _interpolate(attr, tris, tri, bary, empty, normalize, planar, out):
    """``interpolate``'s loop: ``out`` (H, W, C), or with ``planar`` (C, H, W) (each
    attribute's plane contiguous: a plate's channels without a copy each)."""
    h, w = tri.shape
    c = attr.shape[1]
    for i in prange(h):
        for j in range(w):
            t = tri[i, j]
            if t < 0:
                for m in range(c):
                    if planar:
                        out[m, i, j] = empty
                    else:
                        out[i, j, m] = empty
                continue
            a, b, d = tris[t, 0], tris[t, 1], tris[t, 2]
            n2 = 0.0
            for m in range(c):
                v = attr[a, m] * bary[i, j, 0] + attr[b, m] * bary[i, j, 1] + attr[d, m] * bary[i, j, 2]
                if planar:
                    out[m, i, j] = v
                else:
                    out[i, j, m] = v
                n2 += v * v
            if normalize and n2 > 0.0:
                inv = 1.0 / np.sqrt(n2)
                for m in range(c):
                    if planar:
                        out[m, i, j] *= inv
                    else:
                        out[i, j, m] *= inv


def interpolate(attr: np.ndarray, tris: np.ndarray, tri: np.ndarray, bary: np.ndarray, empty: float = 0.0,
                normalize: bool = False, planar: bool = False) -> np.ndarray:
    """Per-pixel value (H, W, C) float32 of a per-vertex attribute (V, C), from
    ``rasterize``'s ``tri`` and ``bary``; ``empty`` where no triangle covers the pixel.
    ``normalize`` makes each interpolated vector unit length (normals). ``planar``: the
    same numbers as (C, H, W), each component's plane contiguous."""
    attr = np.ascontiguousarray(attr, dtype=np.float64)
    if attr.ndim == 1:
        attr = attr[:, None]
    shape = (attr.shape[1],) + tri.shape if planar else tri.shape + (attr.shape[1],)
    out = np.empty(shape, np.float32)
    _interpolate(attr, np.ascontiguousarray(tris, dtype=np.int64), tri, bary, float(empty), bool(normalize),
                 bool(planar), out)
    return out
