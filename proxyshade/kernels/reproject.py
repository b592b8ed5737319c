"""Reprojection kernels for temporal coherence (Bonneel et al. 2010, §6.1–6.2).

Pixels are moved between two pinhole cameras in *inverse depth*: a pixel centre
(col, row) with depth Z is the homogeneous camera-space point X = (x, y, −1, w) with
x = (col − cx)/fx, y = −(row − cy)/fy and w = 1/Z. Points at infinity (the sky, Z = inf)
are w = 0 and move by the rotation alone, so they need no special case. ``M`` is the
4×4 rigid transform from the first camera's space to the second's
(``relative_matrix``); then X' = M X lands at column cx' + fx'·X'x/(−X'z), row
cy' − fy'·X'y/(−X'z) with inverse depth X'w/(−X'z) (perspective-correct: inverse depth
is affine in screen space on a plane). Pixel (row i, column j) has its centre at
(j + 0.5, i + 0.5), as in ``kernels.raster``.

* ``grid_corners`` / ``splat_grid``: the frame-0 grid of §6.1, each pixel a small quad,
  edges cut at label boundaries and depth jumps, rasterized into another camera with a
  z-buffer (serial, so ties always go to the lower frame-0 pixel index).
* ``transfer``: where each pixel of one camera lands in another.
* ``gather_prev``: the previous frame's state at those positions (depth/label test,
  coordinates bilinear inside one patch, nearest across seams).
* ``surface_jacobian_det``: det J of the reprojected coordinates with differences taken
  only on one surface (same label, continuous depth).
* ``fill_from_neighbours``: pixels left without a previous value continue a neighbour's
  patch translation.

Pure functions of arrays; no I/O; deterministic for any thread count.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import JIT, PJIT
from proxyshade.kernels.lookup import _lanczos_colour, _range4, _tap_start
from proxyshade.kernels.pinhole import _world, intrinsics  # noqa: F401 (intrinsics: kr.intrinsics)
from proxyshade.kernels.raster import bin_rows_parallel
from proxyshade.kernels.temporal import _on_label, jacobian_det


# Records the carry's kernels take (issue 40: no long positional lists). The kernels receive
# them as plain tuples (``tuple(record)``) and unpack them in field order: the kernel
# manifest (graph.warmup) writes argument types as evaluable numba reprs, which a named
# tuple's type is not.


class Landing(NamedTuple):
    """Where each pixel of one camera lands in another (``transfer``): column ``u``, row
    ``v``, inverse depth ``q`` there (float64) and ``ok`` (bool), all (H, W)."""
    u: np.ndarray
    v: np.ndarray
    q: np.ndarray
    ok: np.ndarray


class PrevState(NamedTuple):
    """The previous frame's synthesis state a carry reads, all (H', W'): inverse depth
    ``w`` (float64), ``label`` and ``patch`` (uint32), ``sx``, ``sy`` (float32), the
    residual's planes ``r0, r1, r2`` (float32: the Poisson correction or the colours)
    and ``scalar`` (float32, carried like the residual: the extension count)."""
    w: np.ndarray
    label: np.ndarray
    patch: np.ndarray
    sx: np.ndarray
    sy: np.ndarray
    r0: np.ndarray
    r1: np.ndarray
    r2: np.ndarray
    scalar: np.ndarray


class FirstPositions(NamedTuple):
    """``first_positions``: ``ok`` (bool), the first frame's ``patch`` (uint32) and that
    patch's translation continued to the exact position, ``sx``, ``sy`` (float64)."""
    ok: np.ndarray
    patch: np.ndarray
    sx: np.ndarray
    sy: np.ndarray


class Carried(NamedTuple):
    """``gather_prev``'s per-pixel state of the current frame: ``sx``, ``sy`` (float32),
    ``patch`` (uint32), ``res`` (H, W, 3) and ``scalar`` (float32)."""
    sx: np.ndarray
    sy: np.ndarray
    patch: np.ndarray
    res: np.ndarray
    scalar: np.ndarray


def relative_matrix(cam_from, cam_to) -> np.ndarray:
    """4×4 transform from ``cam_from``'s camera space to ``cam_to``'s."""
    return np.ascontiguousarray(np.linalg.inv(cam_to.camera_to_world) @ cam_from.camera_to_world, np.float64)


@njit(**PJIT)
def _inverse_depth(Z, out):
    h, w = Z.shape
    for i in prange(h):
        for j in range(w):
            z = np.float64(Z[i, j])
            out[i, j] = 0.0 if np.isinf(z) else 1.0 / z


def inverse_depth(Z: np.ndarray) -> np.ndarray:
    """1/Z as float64 (0 where Z is inf); NaN stays NaN."""
    Z = np.asarray(Z)
    if Z.ndim == 2 and Z.dtype in (np.float32, np.float64):  # one parallel pass, the same numbers
        out = np.empty(Z.shape, np.float64)
        _inverse_depth(np.ascontiguousarray(Z), out)
        return out
    Z = np.asarray(Z, np.float64)
    with np.errstate(divide="ignore"):
        return np.where(np.isinf(Z), 0.0, 1.0 / Z)


@njit(**JIT)
def _xfer(col, row, w, M, k0, k1, near):
    """(col, row, inverse depth) in camera 0 -> (col, row, inverse depth, ok) in camera 1."""
    x = (col - k0[2]) / k0[0]
    y = -(row - k0[3]) / k0[1]
    X = M[0, 0] * x + M[0, 1] * y - M[0, 2] + M[0, 3] * w
    Y = M[1, 0] * x + M[1, 1] * y - M[1, 2] + M[1, 3] * w
    Zc = M[2, 0] * x + M[2, 1] * y - M[2, 2] + M[2, 3] * w
    d = -Zc
    if d <= 0.0 or d <= near * w:
        return 0.0, 0.0, 0.0, False
    return k1[2] + k1[0] * X / d, k1[3] - k1[1] * Y / d, w / d, True


@njit(**PJIT)
def transfer(w, M, k0, k1, near):
    """Where every pixel centre of camera 0 (inverse depth ``w``, (H, W)) lands in camera 1.

    Returns u (column), v (row), inverse depth in camera 1, all (H, W) float64, and ok
    (bool: finite input, in front of camera 1's near plane). ``_xfer``'s arithmetic, with
    the camera-0 ray of each column and row computed once."""
    h, wd = w.shape
    u = np.zeros((h, wd), np.float64)
    v = np.zeros((h, wd), np.float64)
    q = np.zeros((h, wd), np.float64)
    ok = np.zeros((h, wd), np.bool_)
    xs = np.empty(wd, np.float64)
    for j in range(wd):
        xs[j] = ((j + 0.5) - k0[2]) / k0[0]
    m00, m01, m02, m03 = M[0, 0], M[0, 1], M[0, 2], M[0, 3]
    m10, m11, m12, m13 = M[1, 0], M[1, 1], M[1, 2], M[1, 3]
    m20, m21, m22, m23 = M[2, 0], M[2, 1], M[2, 2], M[2, 3]
    for i in prange(h):
        y = -((i + 0.5) - k0[3]) / k0[1]
        for j in range(wd):
            wij = w[i, j]
            if not np.isfinite(wij):
                continue
            x = xs[j]
            X = m00 * x + m01 * y - m02 + m03 * wij
            Y = m10 * x + m11 * y - m12 + m13 * wij
            d = -(m20 * x + m21 * y - m22 + m23 * wij)
            if d <= 0.0 or d <= near * wij:
                continue
            u[i, j] = k1[2] + k1[0] * X / d
            v[i, j] = k1[3] - k1[1] * Y / d
            q[i, j] = wij / d
            ok[i, j] = True
    return u, v, q, ok


@njit(**JIT)
def same_surface(wa, wb, tol):
    """Two inverse depths on one surface: |wa − wb| ≤ tol · max (both 0: the sky)."""
    m = wa if wa > wb else wb
    return abs(wa - wb) <= tol * m


@njit(**JIT)
def _connected(w, lab, i, j, a, b, tol):
    h, wd = w.shape
    if a < 0 or b < 0 or a >= h or b >= wd:
        return False
    if not np.isfinite(w[a, b]) or lab[a, b] != lab[i, j]:
        return False
    return same_surface(w[i, j], w[a, b], tol)


@njit(**PJIT)
def _links(w, lab, tol):
    """Grid edges kept (not cut), uint8 (H, W, 4): to the right, down, down-right, and
    from (i, j+1) down-left to (i+1, j)."""
    h, wd = w.shape
    out = np.zeros((h, wd, 4), np.uint8)
    for i0 in prange(h):
        i = np.int64(i0)
        for j in range(wd):
            out[i, j, 0] = _connected(w, lab, i, j, i, j + 1, tol)
            out[i, j, 1] = _connected(w, lab, i, j, i + 1, j, tol)
            out[i, j, 2] = _connected(w, lab, i, j, i + 1, j + 1, tol)
            if j + 1 < wd and np.isfinite(w[i, j + 1]):
                out[i, j, 3] = _connected(w, lab, i, j + 1, i + 1, j, tol)
    return out


@njit(**PJIT)
def grid_corners(w, lab, tol):
    """Inverse depth at the four corners of every pixel's quad, (H, W, 4) float64 in the
    order top-left, top-right, bottom-left, bottom-right (NaN where ``w`` is NaN).

    Two 4-neighbours (or diagonal neighbours) are *connected* when they share a label
    and ``same_surface`` holds: otherwise the grid edge between them is cut. Each pixel
    extrapolates its inverse depth to a corner with its own gradient (central
    differences over connected neighbours, one-sided or zero without them); a corner's
    value is the mean of the extrapolations of the pixels around it connected to the
    pixel, so uncut quads share their corners exactly (watertight; exact on planes).
    """
    h, wd = w.shape
    L = _links(w, lab, tol)
    gx = np.zeros((h, wd), np.float64)
    gy = np.zeros((h, wd), np.float64)
    for i0 in prange(h):
        i = np.int64(i0)  # prange indices are unsigned: keep index arithmetic signed
        for j in range(wd):
            if not np.isfinite(w[i, j]):
                continue
            l = j > 0 and L[i, j - 1, 0] == 1
            r = L[i, j, 0] == 1
            if l and r:
                gx[i, j] = (w[i, j + 1] - w[i, j - 1]) * 0.5
            elif l:
                gx[i, j] = w[i, j] - w[i, j - 1]
            elif r:
                gx[i, j] = w[i, j + 1] - w[i, j]
            t = i > 0 and L[i - 1, j, 1] == 1
            bo = L[i, j, 1] == 1
            if t and bo:
                gy[i, j] = (w[i + 1, j] - w[i - 1, j]) * 0.5
            elif t:
                gy[i, j] = w[i, j] - w[i - 1, j]
            elif bo:
                gy[i, j] = w[i + 1, j] - w[i, j]
    out = np.full((h, wd, 4), np.nan, np.float64)
    # corner (ci, cj) sits between pixels (ci-1, cj-1) (k=0), (ci-1, cj) (1), (ci, cj-1) (2), (ci, cj) (3)
    for ci0 in prange(h + 1):
        ci = np.int64(ci0)
        e = np.zeros(4, np.float64)
        inside = np.zeros(4, np.bool_)
        con = np.zeros((4, 4), np.bool_)
        for cj in range(wd + 1):
            for k in range(4):
                a = ci - 1 + k // 2
                b = cj - 1 + k % 2
                inside[k] = a >= 0 and b >= 0 and a < h and b < wd and np.isfinite(w[a, b])
                if inside[k]:
                    e[k] = w[a, b] + (cj - (b + 0.5)) * gx[a, b] + (ci - (a + 0.5)) * gy[a, b]
            for k in range(4):
                for m in range(4):
                    con[k, m] = k == m and inside[k]
            if inside[0]:
                con[0, 1] = inside[1] and L[ci - 1, cj - 1, 0] == 1
                con[0, 2] = inside[2] and L[ci - 1, cj - 1, 1] == 1
                con[0, 3] = inside[3] and L[ci - 1, cj - 1, 2] == 1
            if inside[1]:
                con[1, 3] = inside[3] and L[ci - 1, cj, 1] == 1
                con[1, 2] = inside[2] and L[ci - 1, cj - 1, 3] == 1
            if inside[2]:
                con[2, 3] = inside[3] and L[ci, cj - 1, 0] == 1
            for k in range(4):
                for m in range(k + 1, 4):
                    con[m, k] = con[k, m]
            for k in range(4):
                if not inside[k]:
                    continue
                s = 0.0
                n = 0
                for m in range(4):
                    if con[k, m]:
                        s += e[m]
                        n += 1
                val = s / n
                # the corner is corner 3 - k of pixel k
                out[ci - 1 + k // 2, cj - 1 + k % 2, 3 - k] = val if val > 0.0 else 0.0
    return out


@njit(**JIT)
def _edge(ax, ay, bx, by, px, py):
    return (bx - ax) * (py - ay) - (by - ay) * (px - ax)


@njit(**JIT)
def _tri(P, a, b, c, px, py):
    """Barycentrics of (px, py) in triangle a, b, c of P ((4, 3): col, row, w), or -1."""
    area = _edge(P[a, 0], P[a, 1], P[b, 0], P[b, 1], P[c, 0], P[c, 1])
    if area == 0.0:
        return -1.0, 0.0, 0.0
    l0 = _edge(P[b, 0], P[b, 1], P[c, 0], P[c, 1], px, py) / area
    l1 = _edge(P[c, 0], P[c, 1], P[a, 0], P[a, 1], px, py) / area
    l2 = _edge(P[a, 0], P[a, 1], P[b, 0], P[b, 1], px, py) / area
    if l0 < 0.0 or l1 < 0.0 or l2 < 0.0:
        return -1.0, 0.0, 0.0
    return l0, l1, l2


@njit(**JIT)
def _tri_area(P, a, b, c, area, px, py):
    """``_tri`` with the triangle's ``area`` (its ``_edge``) given, stopping at the first
    negative barycentric: the same numbers where it is inside, -1 elsewhere."""
    if area == 0.0:
        return -1.0, 0.0, 0.0
    l0 = _edge(P[b, 0], P[b, 1], P[c, 0], P[c, 1], px, py) / area
    if l0 < 0.0:
        return -1.0, 0.0, 0.0
    l1 = _edge(P[c, 0], P[c, 1], P[a, 0], P[a, 1], px, py) / area
    if l1 < 0.0:
        return -1.0, 0.0, 0.0
    l2 = _edge(P[a, 0], P[a, 1], P[b, 0], P[b, 1], px, py) / area
    if l2 < 0.0:
        return -1.0, 0.0, 0.0
    return l0, l1, l2


def affine_transfer(M, k0) -> np.ndarray:
    """(3, 4) A with camera-1 homogeneous X = A · (col, row, 1, w) for a camera-0 pixel
    position (col, row) at inverse depth w (``_xfer`` without the divisions)."""
    fx, fy, cx, cy = (float(v) for v in k0)
    R = np.asarray(M, np.float64)[:3]
    A = np.empty((3, 4), np.float64)
    A[:, 0] = R[:, 0] / fx
    A[:, 1] = -R[:, 1] / fy
    A[:, 2] = -R[:, 0] * cx / fx + R[:, 1] * cy / fy - R[:, 2]
    A[:, 3] = R[:, 3]
    return A


@njit(inline="always", **JIT)
def _corner(cw, i, j, k, wk, A, k1, near, P):
    """Project corner k of quad (i, j) (inverse depth ``wk``) into P[k]; False when it is
    behind the camera or nearer than the near plane."""
    col = j + (1.0 if k % 2 == 1 else 0.0)
    row = i + (1.0 if k >= 2 else 0.0)
    X = A[0, 0] * col + A[0, 1] * row + A[0, 2] + A[0, 3] * wk
    Y = A[1, 0] * col + A[1, 1] * row + A[1, 2] + A[1, 3] * wk
    d = -(A[2, 0] * col + A[2, 1] * row + A[2, 2] + A[2, 3] * wk)
    if d <= 0.0 or d <= near * wk:
        return False
    r = 1.0 / d
    P[k, 0] = k1[2] + k1[0] * X * r
    P[k, 1] = k1[3] - k1[1] * Y * r
    P[k, 2] = wk * r
    return True


@njit(**JIT)
def _quad(cw, i, j, A, k1, near, P):
    """Project quad (i, j)'s corners into P (4, 3); False when a corner is unusable."""
    for k in range(4):
        wk = cw[i, j, k]
        if not np.isfinite(wk) or not _corner(cw, i, j, k, wk, A, k1, near, P):
            return False
    return True


@njit(**JIT)
def _quad_after(cw, i, j, A, k1, near, P, prev):
    """``_quad`` of quad (i, j) when ``prev`` holds the projected corners of quad (i, j − 1)
    (``_quad`` was True for it): its right corners are this quad's left ones wherever the
    corner depths are equal (an uncut grid edge), the same numbers without recomputing."""
    for k in range(4):
        wk = cw[i, j, k]
        if not np.isfinite(wk):
            return False
        if k % 2 == 0 and wk == cw[i, j - 1, k + 1]:  # same grid point, same depth
            P[k, 0] = prev[k + 1, 0]
            P[k, 1] = prev[k + 1, 1]
            P[k, 2] = prev[k + 1, 2]
        elif not _corner(cw, i, j, k, wk, A, k1, near, P):
            return False
    return True


@njit(**PJIT)
def _quad_rows(cw, keep, A, k1, near, height, width, max_extent):
    """Pixel-row range each quad covers in camera 1 (r0 > r1 when it draws nothing)."""
    h0, w0 = keep.shape
    r0 = np.zeros((h0, w0), np.int32)
    r1 = np.full((h0, w0), -1, np.int32)
    for i in prange(h0):
        cur = np.zeros((4, 3), np.float64)
        prev = np.zeros((4, 3), np.float64)
        have = False  # prev holds quad (i, j - 1), projected
        for j in range(w0):
            if not keep[i, j]:
                have = False
                continue
            ok = _quad_after(cw, i, j, A, k1, near, cur, prev) if have else _quad(cw, i, j, A, k1, near, cur)
            prev, cur = cur, prev  # prev: this quad's corners from here on
            have = ok
            if not ok:
                continue
            P = prev
            xmin = min(min(P[0, 0], P[1, 0]), min(P[2, 0], P[3, 0]))
            xmax = max(max(P[0, 0], P[1, 0]), max(P[2, 0], P[3, 0]))
            ymin = min(min(P[0, 1], P[1, 1]), min(P[2, 1], P[3, 1]))
            ymax = max(max(P[0, 1], P[1, 1]), max(P[2, 1], P[3, 1]))
            if xmax - xmin > max_extent or ymax - ymin > max_extent:
                continue
            if xmax < 0.0 or xmin > width or ymax < 0.0 or ymin > height:
                continue
            a = max(0, int(np.ceil(ymin - 0.5)))
            b = min(height - 1, int(np.floor(ymax - 0.5)))
            if a <= b:
                r0[i, j] = a
                r1[i, j] = b
    return r0.ravel(), r1.ravel()


@njit(**PJIT)
def _splat_bands(cw, A, k1, near, height, width, band, start, lst, zbuf, src):
    h0, w0 = cw.shape[0], cw.shape[1]
    nb = start.shape[0] - 1
    for bi in prange(nb):
        cur = np.zeros((4, 3), np.float64)
        prev = np.zeros((4, 3), np.float64)
        y0 = bi * band
        y1 = min(height, y0 + band) - 1
        last = -2  # the quad whose corners prev holds (every listed quad projects)
        for t in range(start[bi], start[bi + 1]):
            s = lst[t]
            i = s // w0
            j = s - i * w0
            if s == last + 1 and j > 0:
                _quad_after(cw, i, j, A, k1, near, cur, prev)
            else:
                _quad(cw, i, j, A, k1, near, cur)
            prev, cur = cur, prev
            last = s
            P = prev
            xmin = min(min(P[0, 0], P[1, 0]), min(P[2, 0], P[3, 0]))
            xmax = max(max(P[0, 0], P[1, 0]), max(P[2, 0], P[3, 0]))
            ymin = min(min(P[0, 1], P[1, 1]), min(P[2, 1], P[3, 1]))
            ymax = max(max(P[0, 1], P[1, 1]), max(P[2, 1], P[3, 1]))
            c0 = max(0, int(np.ceil(xmin - 0.5)))
            c1 = min(width - 1, int(np.floor(xmax - 0.5)))
            r0 = max(y0, int(np.ceil(ymin - 0.5)))
            r1 = min(y1, int(np.floor(ymax - 0.5)))
            # _tri of the two triangles (TL, TR, BR) and (TL, BR, BL), their areas once per quad
            a1 = _edge(P[0, 0], P[0, 1], P[1, 0], P[1, 1], P[3, 0], P[3, 1])
            a2 = _edge(P[0, 0], P[0, 1], P[3, 0], P[3, 1], P[2, 0], P[2, 1])
            for r in range(r0, r1 + 1):
                py = r + 0.5
                for c in range(c0, c1 + 1):
                    px = c + 0.5
                    l0, l1, l2 = _tri_area(P, 0, 1, 3, a1, px, py)
                    if l0 >= 0.0:
                        q = l0 * P[0, 2] + l1 * P[1, 2] + l2 * P[3, 2]
                    else:
                        l0, l1, l2 = _tri_area(P, 0, 3, 2, a2, px, py)
                        if l0 < 0.0:
                            continue
                        q = l0 * P[0, 2] + l1 * P[3, 2] + l2 * P[2, 2]
                    if q > zbuf[r, c]:
                        zbuf[r, c] = q
                        src[r, c] = s


SPLAT_BAND = 8  # output rows per parallel work unit of splat_grid


def splat_grid(cw, keep, M, k0, k1, near, height, width, max_extent):
    """Rasterize the frame-0 grid into camera 1.

    cw : (H0, W0, 4) corner inverse depths (``grid_corners``); keep : (H0, W0) bool, the
    quads to draw; M : camera 0 -> camera 1 (``relative_matrix``); k0, k1 : intrinsics
    (fx, fy, cx, cy); quads wider or taller than ``max_extent`` pixels in camera 1 are
    skipped (grazing or behind the near plane).

    Each quad is two triangles (TL, TR, BR) and (TL, BR, BL); a pixel centre inside one
    (edges inclusive) takes the interpolated inverse depth; the nearest wins, ties keep
    the lower frame-0 index (each band of output rows draws its quads in index order, so
    the result does not depend on the thread count). Returns (inverse depth (H, W)
    float64, −1 where uncovered; source index (H, W) int64 = row·W0 + column of the
    frame-0 pixel, −1 where uncovered).
    """
    cw = np.ascontiguousarray(cw, np.float64)
    keep = np.ascontiguousarray(keep, np.bool_)
    M = np.ascontiguousarray(M, np.float64)
    k0 = np.ascontiguousarray(k0, np.float64)
    k1 = np.ascontiguousarray(k1, np.float64)
    A = affine_transfer(M, k0)
    r0, r1 = _quad_rows(cw, keep, A, k1, float(near), int(height), int(width), float(max_extent))
    nb = (int(height) + SPLAT_BAND - 1) // SPLAT_BAND
    start, lst = bin_rows_parallel(r0, r1, nb, SPLAT_BAND)
    zbuf = np.full((int(height), int(width)), -1.0, np.float64)
    src = np.full((int(height), int(width)), -1, np.int64)
    _splat_bands(cw, A, k1, near=float(near), height=int(height), width=int(width), band=SPLAT_BAND, start=start,
                 lst=lst, zbuf=zbuf, src=src)
    return zbuf, src


@njit(**PJIT)
def _stale(wg, src, wp1, on_proxy, tol, w0, radius, out):
    h, wd = wg.shape
    for i in prange(h):
        for j in range(wd):
            s = src[i, j]
            if s < 0:
                continue
            a = s // w0
            b = s - a * w0
            if not on_proxy[a, b]:
                continue
            m = 0.0
            for r in range(max(0, i - radius), min(h, i + radius + 1)):
                for c in range(max(0, j - radius), min(wd, j + radius + 1)):
                    if wp1[r, c] > m:
                        m = wp1[r, c]
            if wg[i, j] > m * (1.0 + tol) and wg[i, j] > 0.0:
                out[a, b] = True


def stale_winners(wg, src, wp1, on_proxy, keep, tol, radius=0):
    """Frame-0 pixels drawn in camera 1 (``splat_grid``'s wg, src) that lay on the proxy at
    frame 0 (``on_proxy``) but now float in front of every proxy pixel of the
    (2·radius+1)² window around where they are drawn, by more than ``tol`` (the object
    under them moved). In a static scene there are none but for quads drawn a little past
    a silhouette (radius 1 tolerates those). (H0, W0) bool."""
    out = np.zeros(on_proxy.shape, np.bool_)
    _stale(wg, src, wp1, np.ascontiguousarray(on_proxy, np.bool_), float(tol), on_proxy.shape[1], int(radius), out)
    return out & keep


@njit(**JIT)
def gather_prev(u, v, q, ok, lab, prev_w, prev_lab, prev_patch, prev_sx, prev_sy, prev_res, prev_d, tol, scale):
    """The previous frame's state where each current pixel lands.

    u, v, q, ok : ``transfer`` of the current pixels into the previous camera; lab : current
    labels. A pixel is *valid* when it lands inside the previous image on a pixel of its
    label whose inverse depth agrees (``same_surface``). Then: source coordinates bilinear
    when the 2×2 previous pixels around the position are all valid and in one patch,
    else the nearest pixel's translation continued to the position (``scale`` source
    pixels per pixel; 0 snaps to the nearest pixel's coordinates); patch id nearest; residual (H, W, 3) and distortion
    bilinear over the valid ones among the 2×2 in the nearest pixel's patch (weights
    renormalised: the residual, a Poisson correction, jumps across seams).

    Returns valid (bool), sx, sy (float32), patch (uint32), residual (float32 ×3),
    distortion (float32), all (H, W). ``gather_prev_planes`` with the residual's planes."""
    return gather_prev_planes((u, v, q, ok), lab, (prev_w, prev_lab, prev_patch, prev_sx, prev_sy, prev_res[:, :, 0],
                                                   prev_res[:, :, 1], prev_res[:, :, 2], prev_d), tol, scale,
                              np.zeros((0, 0), np.bool_), 0)


@njit(inline="always", **JIT)
def _sharpened(x, y, uniform, a, hp, wp):
    """Whether ``sharpen_residual`` reads the residual again at a valid pixel landing at
    (x, y) of the previous frame (``uniform``: its ``uniform_windows``; taps 2a × 2a)."""
    c0 = int(np.floor(x - 0.5))
    r0 = int(np.floor(y - 0.5))
    return not (c0 < a - 1 or r0 < a - 1 or c0 + a >= wp or r0 + a >= hp or not uniform[r0, c0])


@njit(**PJIT)
def gather_prev_planes(land, lab, prev, tol, scale, sharp, a):
    """``gather_prev`` on records: ``land`` (``Landing``: ``transfer`` into the previous
    camera), the current labels ``lab`` and ``prev`` (``PrevState``: the residual as
    three (H, W) planes, a plate's ``correction.R/G/B`` as they are, no (H, W, 3) stack;
    ``scalar`` the plane carried as the distortion). Returns valid, sx, sy, patch,
    residual, scalar (``gather_prev``'s). ``sharp`` (not empty): the ``uniform`` of a
    ``sharpen_residual`` with taps 2``a`` × 2``a`` that follows: the residual is left
    unwritten at the pixels it reads again (``_sharpened``), the rest as without."""
    u, v, q, ok = land
    sharpen = sharp.size > 0
    prev_w, prev_lab, prev_patch, prev_sx, prev_sy, pr0, pr1, pr2, prev_d = prev
    h, wd = u.shape
    hp, wp = prev_w.shape
    valid = np.empty((h, wd), np.bool_)  # every element written (no zeroing pass first)
    sx = np.empty((h, wd), np.float32)
    sy = np.empty((h, wd), np.float32)
    patch = np.empty((h, wd), np.uint32)
    res = np.empty((h, wd, 3), np.float32)
    dist = np.empty((h, wd), np.float32)
    z = np.float32(0.0)
    for i in prange(h):
        for j in range(wd):
            x = u[i, j]
            y = v[i, j]
            hit = ok[i, j] and x >= 0.0 and y >= 0.0 and x < wp and y < hp
            cn = rn = 0
            if hit:
                cn = min(wp - 1, int(np.floor(x)))
                rn = min(hp - 1, int(np.floor(y)))
                hit = prev_lab[rn, cn] == lab[i, j] and same_surface(q[i, j], prev_w[rn, cn], tol)
            if not hit:
                valid[i, j] = False
                sx[i, j] = sy[i, j] = dist[i, j] = z
                res[i, j, 0] = res[i, j, 1] = res[i, j, 2] = z
                patch[i, j] = 0
                continue
            L = lab[i, j]
            valid[i, j] = True
            pn = prev_patch[rn, cn]
            patch[i, j] = pn
            fx = x - 0.5
            fy = y - 0.5
            c0 = int(np.floor(fx))
            r0 = int(np.floor(fy))
            ax = fx - c0
            ay = fy - r0
            wsum = 0.0
            same = True
            bsx = 0.0
            bsy = 0.0
            r0_ = 0.0
            r1_ = 0.0
            r2_ = 0.0
            dd = 0.0
            skip = sharpen and _sharpened(np.float64(x), np.float64(y), sharp, a, hp, wp)
            for t in range(4):
                rr = r0 + (1 if t >= 2 else 0)
                cc = c0 + (1 if t % 2 == 1 else 0)
                wt = (ay if t >= 2 else 1.0 - ay) * (ax if t % 2 == 1 else 1.0 - ax)
                rr = min(max(rr, 0), hp - 1)
                cc = min(max(cc, 0), wp - 1)
                if prev_lab[rr, cc] != L or not same_surface(q[i, j], prev_w[rr, cc], tol):
                    same = False
                    continue
                if prev_patch[rr, cc] != pn:
                    same = False
                bsx += wt * prev_sx[rr, cc]
                bsy += wt * prev_sy[rr, cc]
                if prev_patch[rr, cc] != pn:
                    continue  # the correction jumps at seams (it cancels the seam): not across them
                if not skip:
                    r0_ += wt * pr0[rr, cc]
                    r1_ += wt * pr1[rr, cc]
                    r2_ += wt * pr2[rr, cc]
                dd += wt * prev_d[rr, cc]
                wsum += wt
            if same:
                sx[i, j] = bsx
                sy[i, j] = bsy
            else:
                sx[i, j] = prev_sx[rn, cn] + (x - (cn + 0.5)) * scale
                sy[i, j] = prev_sy[rn, cn] + (y - (rn + 0.5)) * scale
            if wsum > 0.0:
                if not skip:
                    res[i, j, 0] = r0_ / wsum
                    res[i, j, 1] = r1_ / wsum
                    res[i, j, 2] = r2_ / wsum
                dist[i, j] = dd / wsum
            else:
                if not skip:
                    res[i, j, 0] = pr0[rn, cn]
                    res[i, j, 1] = pr1[rn, cn]
                    res[i, j, 2] = pr2[rn, cn]
                dist[i, j] = prev_d[rn, cn]
    return valid, sx, sy, patch, res, dist


@njit(**PJIT)
def surface_links(w, lab, valid, tol):
    """Neighbour links (``temporal.LEFT`` ... bits) to neighbours that are valid, have the
    pixel's label and lie on its surface (``same_surface`` on the inverse depths ``w``)."""
    h, wd = valid.shape
    out = np.zeros((h, wd), np.uint8)
    for i0 in prange(h):
        i = np.int64(i0)
        for j in range(wd):
            if not valid[i, j]:
                continue
            m = 0
            for b in range(4):
                a = i + (b == 3) - (b == 2)
                c = j + (b == 1) - (b == 0)
                if 0 <= a < h and 0 <= c < wd and valid[a, c] and lab[a, c] == lab[i, j] \
                        and same_surface(w[a, c], w[i, j], tol):
                    m |= 1 << b
            out[i, j] = m
    return out


def patch_links(valid, patch, lab):
    """Neighbour links to valid neighbours in the same patch with the same label: the
    neighbours a coordinate map is continuous with (``surface_links`` with the patch id
    as the 'depth' and no tolerance: equal ids)."""
    return surface_links(np.asarray(patch, np.float64), np.ascontiguousarray(lab, np.uint32),
                         np.ascontiguousarray(valid, np.bool_), 0.0)


def surface_jacobian_det(u, v, w, lab, valid, tol):
    """det J of the reprojected coordinates, differences taken only across neighbours on the
    pixel's surface (``surface_links``): one-sided next to silhouettes and label borders."""
    return jacobian_det(u, v, valid, surface_links(w, lab, valid, tol))


@njit(**JIT)  # the loop is fill_from_neighbours_into's (parallel)
def fill_from_neighbours(need, have, lab, state, radius, scale, src_lab):
    """Give pixels in ``need`` the state (``Carried``: sx, sy, patch, res and ``scalar``, the
    distance) of the nearest pixel in ``have`` with their label (square rings up to
    ``radius``, first found in scan order of the ring), continuing its patch translation
    (source coordinates moved by the offset × ``scale``). With a non-empty ``src_lab`` (the
    source's labels, uint32) only a neighbour whose continued position lands on a source
    pixel of the pixel's label (``temporal._on_label``) is taken: the next one in that order
    when the nearest's does not. Reads only ``have`` pixels, so the result does not depend
    on the order. Returns new arrays (sx, sy, patch, res, scalar) and the mask of pixels
    filled."""
    out = Carried(state.sx.copy(), state.sy.copy(), state.patch.copy(), state.res.copy(), state.scalar.copy())
    return fill_from_neighbours_into(need, have, lab, state, radius, scale, out=out, src_lab=src_lab)


@njit(**PJIT)
def fill_from_neighbours_into(need, have, lab, state, radius, scale, out, src_lab):
    """``fill_from_neighbours`` writing into ``out`` (``Carried``: copies of ``state``, or
    ``state`` itself when ``need`` and ``have`` are disjoint: it writes only ``need`` pixels
    and reads only ``have`` ones). Returns out's arrays and the mask of pixels filled."""
    sx, sy, patch, res, dist = state.sx, state.sy, state.patch, state.res, state.scalar
    osx, osy, opatch, ores, odist = out.sx, out.sy, out.patch, out.res, out.scalar
    h, wd = need.shape
    check = src_lab.size > 0
    filled = np.zeros((h, wd), np.bool_)
    for i0 in prange(h):
        i = np.int64(i0)
        for j in range(wd):
            if not need[i, j]:
                continue
            done = False
            for r in range(1, radius + 1):
                for a in range(i - r, i + r + 1):
                    if a < 0 or a >= h:
                        continue
                    step = 1 if a == i - r or a == i + r else 2 * r
                    for b in range(j - r, j + r + 1, step):
                        if b < 0 or b >= wd or not have[a, b] or lab[a, b] != lab[i, j]:
                            continue
                        x = sx[a, b] + (j - b) * scale
                        y = sy[a, b] + (i - a) * scale
                        if check and not _on_label(src_lab, np.float32(x), np.float32(y), lab[i, j]):
                            continue
                        osx[i, j] = x
                        osy[i, j] = y
                        opatch[i, j] = patch[a, b]
                        ores[i, j, 0] = res[a, b, 0]
                        ores[i, j, 1] = res[a, b, 1]
                        ores[i, j, 2] = res[a, b, 2]
                        odist[i, j] = dist[a, b]
                        filled[i, j] = True
                        done = True
                        break
                    if done:
                        break
                if done:
                    break
    return osx, osy, opatch, ores, odist, filled


@njit(**PJIT)
def unproject(Z, C, k):
    """World position (H, W, 3) float32 of each pixel centre at camera depth ``Z`` (0 where
    Z is not finite); C : camera-to-world 4×4, k : intrinsics (fx, fy, cx, cy)."""
    h, wd = Z.shape
    out = np.zeros((h, wd, 3), np.float32)
    for i in prange(h):
        for j in range(wd):
            z = Z[i, j]
            if not np.isfinite(z):
                continue
            for m in range(3):
                out[i, j, m] = _world(z, i, j, C, k, m)
    return out


@njit(**PJIT)
def classify(src, wg, wp1, stale, occluded0, lab0, plab, pZ, pX, pY, pZw, C, k, tol):
    """ConsistentDepth's pixel kinds and what each takes, in one pass.

    src, wg : ``splat_grid`` (frame-0 index and inverse depth of the grid drawn, −1 where
    none); wp1 : this frame's proxy inverse depth; stale : (H0, W0) bool, grid pixels
    left to the proxy (``stale_winners``); occluded0 : (H0, W0) bool, hidden by the
    frame-0 proxy; lab0 : (H0, W0) frame-0 labels; plab, pZ, pX, pY, pZw : the proxy's
    labels, depth and world position; C, k : this camera (``unproject``).

    A pixel is covered where the grid is drawn and not stale; covered and not behind the
    proxy (wp1 <= wg (1 + tol)) is A (1); behind it, B (2) where frame 0 hid it too, else
    C (3); not covered is D (4). A and B take the grid's label and depth (1 / wg) and the
    world position of that depth; C and D the proxy's. Returns category (uint32),
    label (uint32), Z (float32), P.X, P.Y, P.Z (float32) and per row the count of stale
    pixels dropped."""
    h, wd = src.shape
    w0 = lab0.shape[1]
    cat = np.empty((h, wd), np.uint32)
    label = np.empty((h, wd), np.uint32)
    Z = np.empty((h, wd), np.float32)
    X = np.empty((h, wd), np.float32)
    Y = np.empty((h, wd), np.float32)
    W = np.empty((h, wd), np.float32)
    gone = np.zeros(h, np.int64)
    for i in prange(h):
        for j in range(wd):
            s = src[i, j]
            c = 4
            a = 0
            b = 0
            if s >= 0:
                a = s // w0
                b = s - a * w0
                if stale[a, b]:
                    gone[i] += 1
                elif wp1[i, j] > wg[i, j] * (1.0 + tol):
                    c = 2 if occluded0[a, b] else 3
                else:
                    c = 1
            cat[i, j] = c
            if c <= 2:
                label[i, j] = lab0[a, b]
                z = np.float32(1.0 / wg[i, j]) if wg[i, j] > 0 else np.float32(np.inf)
                Z[i, j] = z
                if np.isfinite(z):
                    X[i, j] = _world(z, i, j, C, k, 0)
                    Y[i, j] = _world(z, i, j, C, k, 1)
                    W[i, j] = _world(z, i, j, C, k, 2)
                    continue
            else:
                label[i, j] = plab[i, j]
                Z[i, j] = pZ[i, j]
            X[i, j] = pX[i, j]
            Y[i, j] = pY[i, j]
            W[i, j] = pZw[i, j]
    return cat, label, Z, X, Y, W, gone


@njit(**JIT)
def _keys(t):
    """Keys' cubic convolution weights (a = -0.5, Catmull-Rom) for taps -1, 0, 1, 2 at fraction t."""
    t2 = t * t
    t3 = t2 * t
    return (-0.5 * t3 + t2 - 0.5 * t, 1.5 * t3 - 2.5 * t2 + 1.0, -1.5 * t3 + 2.0 * t2 + 0.5 * t, 0.5 * t3 - 0.5 * t2)


@njit(**PJIT)
def _cubic(img, x, y, out):
    h, w, c = img.shape
    for i in prange(x.shape[0]):
        for j in range(x.shape[1]):
            fx = np.floor(x[i, j])
            fy = np.floor(y[i, j])
            wx = _keys(x[i, j] - fx)
            wy = _keys(y[i, j] - fy)
            for m in range(c):
                acc = 0.0
                for a in range(4):
                    r = min(max(int(fy) - 1 + a, 0), h - 1)
                    row = 0.0
                    for b in range(4):
                        cc = min(max(int(fx) - 1 + b, 0), w - 1)
                        row += wx[b] * img[r, cc, m]
                    acc += wy[a] * row
                out[i, j, m] = acc


def warp_previous(prev_image: np.ndarray, u: np.ndarray, v: np.ndarray, filter: str = "bilinear") -> np.ndarray:
    """The previous frame's image (H', W', C) read where each current pixel lands
    (``transfer``'s u, v: pixel-centre convention, pixel (i, j) at j + 0.5), bilinear
    or Lanczos (``kernels.lookup``), or with Keys' cubic convolution (``filter="cubic"``):
    the sharper filters blur less of what is measured. Clamped at the border."""
    from proxyshade.kernels.lookup import lookup

    img = np.ascontiguousarray(prev_image, np.float32)
    x = np.ascontiguousarray(u - 0.5, np.float64)
    y = np.ascontiguousarray(v - 0.5, np.float64)
    if filter in ("bilinear", "lanczos3", "lanczos4", "flat4"):
        return lookup(img, x.astype(np.float32), y.astype(np.float32), filter=filter)
    if filter != "cubic":
        raise ValueError(f"filter {filter!r}: use 'bilinear', 'lanczos3', 'lanczos4', 'flat4' or 'cubic'")
    out = np.empty(x.shape + (img.shape[2],), np.float32)
    _cubic(img, x, y, out)
    return out


def warp_error(current: np.ndarray, prev_image: np.ndarray, u: np.ndarray, v: np.ndarray, mask: np.ndarray,
               filter: str = "bilinear") -> float:
    """Temporal warp error: mean |I_N − warp(I_N−1)| over ``mask`` (all channels)."""
    if not mask.any():
        return 0.0
    diff = np.abs(np.asarray(current, np.float32) - warp_previous(prev_image, u, v, filter))
    return float(diff[mask].mean())


@njit(**PJIT)
def first_positions(uf, vf, qf, okf, lab, first_w, first_lab, first_patch, first_sx, first_sy, tol, scale):
    """Where each current pixel lies in the first frame's synthesis (``transfer`` into the
    first camera: ``uf, vf, qf, okf``): the patch of the first-frame pixel it lands on and
    that patch's translation continued to the exact position (``scale`` source pixels per
    pixel), where that pixel has its label and lies on its surface. Returns ok (bool),
    patch (uint32), sx, sy (float64), all (H, W)."""
    h, wd = uf.shape
    hf, wf = first_lab.shape
    ok = np.zeros((h, wd), np.bool_)
    patch = np.zeros((h, wd), np.uint32)
    sx = np.zeros((h, wd), np.float64)
    sy = np.zeros((h, wd), np.float64)
    for i in prange(h):
        for j in range(wd):
            x = uf[i, j]
            y = vf[i, j]
            if not (okf[i, j] and x >= 0.0 and y >= 0.0 and x < wf and y < hf):
                continue
            cn = min(wf - 1, int(np.floor(x)))
            rn = min(hf - 1, int(np.floor(y)))
            if first_lab[rn, cn] != lab[i, j] or not same_surface(qf[i, j], first_w[rn, cn], tol):
                continue
            ok[i, j] = True
            patch[i, j] = first_patch[rn, cn]
            sx[i, j] = first_sx[rn, cn] + (x - (cn + 0.5)) * scale
            sy[i, j] = first_sy[rn, cn] + (y - (rn + 0.5)) * scale
    return ok, patch, sx, sy


@njit(**PJIT)
def anchor_seams(land, valid, lab, prev, first, tol, scale, match, out):
    """Seams between first-frame patches kept where the first frame had them, in place on
    ``gather_prev``'s outputs ``out`` (``Carried``: sx, sy, patch, res, scalar), from
    ``land`` (``Landing`` into the previous camera), ``valid`` and ``lab`` (the current
    pixels'), ``prev`` (``PrevState``) and ``first`` (``FirstPositions``).

    ``gather_prev`` gives a pixel whose 2×2 previous pixels straddle a seam the patch of
    the nearest one: the seam is rounded to this frame's pixel grid, from the previous
    frame's rounded seam, so over a shot it walks off the texture the first frame's
    synthesis fitted it to (a random walk of ±½ pixel a frame). Here such a pixel takes
    instead the patch the first frame has at its exact position (``first_positions``:
    ``fok, fpatch, fsx, fsy``) when one of its valid 2×2 previous pixels (its label, its
    surface) has that patch with the same translation (continued positions within
    ``match`` source pixels): the seam is rounded once, from the first frame. Its source
    position is that pixel's translation continued; residual and distortion are bilinear
    over the 2×2 pixels of that patch (renormalised), as in ``gather_prev``. Pixels whose
    first-frame patch is gone (resynthesized, re-anchored) are left as they are."""
    u, v, q, _ = land
    prev_w, prev_lab, prev_patch, prev_sx, prev_sy, pr0, pr1, pr2, prev_d = prev
    fok, fpatch, fsx, fsy = first
    sx, sy, patch, res, dist = out
    h, wd = u.shape
    hp, wp = prev_w.shape
    for i in prange(h):
        for j in range(wd):
            if not valid[i, j] or not fok[i, j] or patch[i, j] == fpatch[i, j]:
                continue
            L = lab[i, j]
            pf = fpatch[i, j]
            x = u[i, j]
            y = v[i, j]
            c0 = int(np.floor(x - 0.5))
            r0 = int(np.floor(y - 0.5))
            ax = x - 0.5 - c0
            ay = y - 0.5 - r0
            found = False
            bx = 0.0
            by = 0.0
            n0 = n1 = n2 = nd = 0.0
            wsum = 0.0
            a0 = 0.0
            a1 = 0.0
            a2 = 0.0
            dd = 0.0
            for t in range(4):
                rr = min(max(r0 + (1 if t >= 2 else 0), 0), hp - 1)
                cc = min(max(c0 + (1 if t % 2 == 1 else 0), 0), wp - 1)
                if prev_patch[rr, cc] != pf or prev_lab[rr, cc] != L or not same_surface(q[i, j], prev_w[rr, cc], tol):
                    continue
                ex = prev_sx[rr, cc] + (x - (cc + 0.5)) * scale
                ey = prev_sy[rr, cc] + (y - (rr + 0.5)) * scale
                if abs(ex - fsx[i, j]) > match or abs(ey - fsy[i, j]) > match:
                    continue
                if not found:
                    found = True
                    bx = ex
                    by = ey
                    n0 = pr0[rr, cc]
                    n1 = pr1[rr, cc]
                    n2 = pr2[rr, cc]
                    nd = prev_d[rr, cc]
                wt = (ay if t >= 2 else 1.0 - ay) * (ax if t % 2 == 1 else 1.0 - ax)
                a0 += wt * pr0[rr, cc]
                a1 += wt * pr1[rr, cc]
                a2 += wt * pr2[rr, cc]
                dd += wt * prev_d[rr, cc]
                wsum += wt
            if not found:
                continue
            patch[i, j] = pf
            sx[i, j] = bx
            sy[i, j] = by
            if wsum <= 0.0:  # the matching taps have weight 0 (a pixel centre): the first one's values
                a0, a1, a2, dd, wsum = n0, n1, n2, nd, 1.0
            res[i, j, 0] = a0 / wsum
            res[i, j, 1] = a1 / wsum
            res[i, j, 2] = a2 / wsum
            dist[i, j] = dd / wsum


@njit(**PJIT)
def uniform_windows(patch, lab, before, after):
    """(H, W) bool: the pixels (r, c) whose window of rows r − ``before`` … r + ``after`` and
    columns c − ``before`` … c + ``after`` lies inside the image with every pixel of the same
    ``patch`` and ``lab`` as (r, c): where an 8×8 read (``before`` 3, ``after`` 4) whose first
    tap's floor is (r, c) stays inside one patch. Runs along rows, then columns (O(H W))."""
    h, w = patch.shape
    row_ok = np.zeros((h, w), np.bool_)
    for r in prange(h):
        run = 0
        for c in range(w):  # run of equal pixels ending at c
            run = run + 1 if c > 0 and patch[r, c] == patch[r, c - 1] and lab[r, c] == lab[r, c - 1] else 1
            # the pixel run - 1 left of c ... c: the window of the pixel c - after ends at c
            k = c - after
            if k >= 0 and run >= before + after + 1:
                row_ok[r, k] = True
    out = np.zeros((h, w), np.bool_)
    for c in prange(w):
        run = 0
        for r in range(h):
            same = r > 0 and row_ok[r - 1, c] and patch[r, c] == patch[r - 1, c] and lab[r, c] == lab[r - 1, c]
            run = run + 1 if row_ok[r, c] and same else (1 if row_ok[r, c] else 0)
            k = r - after
            if k >= 0 and run >= before + after + 1:
                out[k, c] = True
    return out


@njit(**PJIT)
def sharpen_residual(land, valid, uniform, prev_res, table, res):
    """``gather_prev``'s residual ``res`` ((H, W, 3), in place) read again from the previous
    frame's residual ``prev_res`` ((H', W', 3)) with the 2a × 2a taps of ``table`` (per phase,
    ``lookup``'s flat weights: ``FLAT4`` a = 4, ``FLAT2`` a = 2) and clamped to the 4×4
    pixels' range (``lookup``'s own tap read and range: ``_lanczos_colour``, ``_range4``), at
    the ``valid`` pixels whose taps all lie in one patch and label of the previous frame
    (``uniform``: ``uniform_windows(patch, label, a − 1, a)`` of the previous frame);
    elsewhere (near a seam, where the correction jumps) it is left bilinear. The bilinear
    carry halves the correction's finest detail at half a pixel, and frame after frame it is
    gone: the first frame's Poisson damps the copied texture (its correction holds the
    opposite of the texture's finest detail), so the carried frames gain gradient
    (docs/temporal.md, "Gradient creep")."""
    u, v = land[0], land[1]
    h, w = u.shape
    hp, wp = prev_res.shape[0], prev_res.shape[1]
    bins = table.shape[0] - 1
    n = table.shape[1]
    a = n // 2
    for i in prange(h):
        for j in range(w):
            if not valid[i, j]:
                continue
            x = np.float64(u[i, j]) - 0.5  # lookup's convention: pixel centres at integers
            y = np.float64(v[i, j]) - 0.5
            c0 = int(np.floor(x))
            rr0 = int(np.floor(y))
            if c0 < a - 1 or rr0 < a - 1 or c0 + a >= wp or rr0 + a >= hp or not uniform[rr0, c0]:
                continue
            xs, bx = _tap_start(x, wp, bins, a)
            ys, by = _tap_start(y, hp, bins, a)
            if a < 2:  # the 4x4 range reaches past the taps
                s0, s1, s2 = _lanczos_colour(prev_res, xs, ys, bx, by, table, True)
                lo, hi = _range4(prev_res, x, y, 0)
                res[i, j, 0] = min(max(s0, lo), hi)
                lo, hi = _range4(prev_res, x, y, 1)
                res[i, j, 1] = min(max(s1, lo), hi)
                lo, hi = _range4(prev_res, x, y, 2)
                res[i, j, 2] = min(max(s2, lo), hi)
                continue
            # _lanczos_colour's sums (inside: no clamping) and _range4's 4x4 range in one pass over the
            # taps: the taps lie inside (checked above), so _range4's pixels are taps a - 2 ... a + 1
            s0 = s1 = s2 = 0.0
            lo0 = lo1 = lo2 = np.inf
            hi0 = hi1 = hi2 = -np.inf
            if n == 4:  # FLAT2: the taps are the 4x4 range; fixed trip counts
                for r in range(4):
                    yy = ys + r
                    t0 = t1 = t2 = 0.0
                    for t in range(4):
                        wx = table[bx, t]
                        v0 = prev_res[yy, xs + t, 0]
                        v1 = prev_res[yy, xs + t, 1]
                        v2 = prev_res[yy, xs + t, 2]
                        t0 += wx * v0
                        t1 += wx * v1
                        t2 += wx * v2
                        lo0 = min(lo0, v0)
                        hi0 = max(hi0, v0)
                        lo1 = min(lo1, v1)
                        hi1 = max(hi1, v1)
                        lo2 = min(lo2, v2)
                        hi2 = max(hi2, v2)
                    wy = table[by, r]
                    s0 += wy * t0
                    s1 += wy * t1
                    s2 += wy * t2
                res[i, j, 0] = min(max(s0, lo0), hi0)
                res[i, j, 1] = min(max(s1, lo1), hi1)
                res[i, j, 2] = min(max(s2, lo2), hi2)
                continue
            for r in range(n):
                yy = ys + r
                t0 = t1 = t2 = 0.0
                for t in range(n):
                    wx = table[bx, t]
                    t0 += wx * prev_res[yy, xs + t, 0]
                    t1 += wx * prev_res[yy, xs + t, 1]
                    t2 += wx * prev_res[yy, xs + t, 2]
                wy = table[by, r]
                s0 += wy * t0
                s1 += wy * t1
                s2 += wy * t2
                if a - 2 <= r <= a + 1:
                    for t in range(a - 2, a + 2):
                        v0 = prev_res[yy, xs + t, 0]
                        v1 = prev_res[yy, xs + t, 1]
                        v2 = prev_res[yy, xs + t, 2]
                        lo0 = min(lo0, v0)
                        hi0 = max(hi0, v0)
                        lo1 = min(lo1, v1)
                        hi1 = max(hi1, v1)
                        lo2 = min(lo2, v2)
                        hi2 = max(hi2, v2)
            res[i, j, 0] = min(max(s0, lo0), hi0)
            res[i, j, 1] = min(max(s1, lo1), hi1)
            res[i, j, 2] = min(max(s2, lo2), hi2)
