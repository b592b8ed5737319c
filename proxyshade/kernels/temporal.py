"""Temporal coherence kernels: distortion of reprojected coordinates and flag clean-up.

Bonneel et al. 2010, §6.2: "We compute the determinant of the Jacobian J of the
reprojected pixel coordinates ... D = ||det(J) − 1|| which we accumulate across frames.
If D becomes greater than a given threshold, D is reset to 0 and the pixel is flagged for
resynthesis. We perturb D with random noise to avoid a coherent wave ... We remove these
isolated pixels in 5×5 neighborhoods. We dilate remaining flagged regions."

Here the distortion is read off the carried coordinate map itself (``map_deviation``:
‖J − I‖, which also sees shear), and the noise is one threshold per patch
(``kernels.random.uniform_field`` of its id) rather than a per-frame perturbation.

Pure functions on arrays. Randomness is a hash of (seed, row, column), never a global
generator, so serial and parallel runs agree bit for bit.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import JIT, PJIT


LEFT, RIGHT, UP, DOWN = 1, 2, 4, 8  # neighbour-link bits


@njit(**PJIT)
def neighbour_links(valid):
    """uint8 per pixel: which 4-neighbours a difference may use (LEFT, RIGHT, UP, DOWN
    bits): here, the valid neighbours of valid pixels."""
    h, w = valid.shape
    out = np.zeros((h, w), np.uint8)
    for i in prange(h):
        for j in range(w):
            if not valid[i, j]:
                continue
            m = 0
            if j > 0 and valid[i, j - 1]:
                m |= LEFT
            if j < w - 1 and valid[i, j + 1]:
                m |= RIGHT
            if i > 0 and valid[i - 1, j]:
                m |= UP
            if i < h - 1 and valid[i + 1, j]:
                m |= DOWN
            out[i, j] = m
    return out


@njit(**JIT)
def _partials(u, v, links, i, j):
    """Central (or one-sided) differences of u, v at (i, j) along the linked neighbours:
    (has x, has y, du/dx, dv/dx, du/dy, dv/dy)."""
    m = links[i, j]
    jl = j - 1 if m & LEFT else j
    jr = j + 1 if m & RIGHT else j
    iu = i - 1 if m & UP else i
    idn = i + 1 if m & DOWN else i
    dux = dvx = duy = dvy = 0.0
    if jr != jl:
        dux = (u[i, jr] - u[i, jl]) / (jr - jl)
        dvx = (v[i, jr] - v[i, jl]) / (jr - jl)
    if idn != iu:
        duy = (u[idn, j] - u[iu, j]) / (idn - iu)
        dvy = (v[idn, j] - v[iu, j]) / (idn - iu)
    return jr != jl, idn != iu, dux, dvx, duy, dvy


@njit(**PJIT)
def _jacobian_det(u, v, valid, links):
    h, w = u.shape
    out = np.ones((h, w), np.float64)
    for i0 in prange(h):
        i = np.int64(i0)  # prange indices are unsigned: keep index arithmetic signed
        for j in range(w):
            if not valid[i, j]:
                continue
            hx, hy, dux, dvx, duy, dvy = _partials(u, v, links, i, j)
            if hx and hy:
                out[i, j] = dux * dvy - duy * dvx
    return out


def jacobian_det(u, v, valid, links=None):
    """det J of the map (row, col) -> (u, v) by central differences, one-sided where a
    neighbour may not be used (``links``, default ``neighbour_links(valid)``); 1 where a
    pixel is invalid or has no usable neighbour along an axis. (H, W) float64.

    J = [[du/dx, du/dy], [dv/dx, dv/dy]] with x = column, y = row.
    """
    valid = np.ascontiguousarray(valid, dtype=np.bool_)
    if links is None:
        links = neighbour_links(valid)
    return _jacobian_det(u, v, valid, links)


@njit(inline="always", **JIT)
def _deviation(sx, sy, i, j, jl, jr, iu, idn, scale):
    """|J / scale − I| at (i, j), J by differences over columns ``jl``..``jr`` and rows
    ``iu``..``idn`` (central over 2 pixels, one-sided over 1, none over 0), in float64. A
    difference over 2 pixels is halved by a product (exact, as the division by 2 is)."""
    a = 0.0
    c = 0.0
    b = 0.0
    d = 0.0
    if jr != jl:
        hx = 0.5 if jr - jl == 2 else 1.0
        a = (np.float64(sx[i, jr]) - np.float64(sx[i, jl])) * hx / scale - 1.0
        c = (np.float64(sy[i, jr]) - np.float64(sy[i, jl])) * hx / scale
    if idn != iu:
        hy = 0.5 if idn - iu == 2 else 1.0
        b = (np.float64(sx[idn, j]) - np.float64(sx[iu, j])) * hy / scale
        d = (np.float64(sy[idn, j]) - np.float64(sy[iu, j])) * hy / scale - 1.0
    return np.sqrt(a * a + b * b + c * c + d * d)


@njit(**PJIT)
def _map_deviation(sx, sy, valid, links, scale):
    h, w = sx.shape
    out = np.zeros((h, w), np.float32)
    for i0 in prange(h):
        i = np.int64(i0)
        for j in range(w):
            if not valid[i, j]:
                continue
            # _partials inlined (the same differences; twice as fast as the tuple call)
            m = links[i, j]
            jl = j - 1 if m & LEFT else j
            jr = j + 1 if m & RIGHT else j
            iu = i - 1 if m & UP else i
            idn = i + 1 if m & DOWN else i
            out[i, j] = _deviation(sx, sy, i, j, jl, jr, iu, idn, scale)
    return out


def map_deviation(sx, sy, valid, links, scale):
    """How far a coordinate map has drifted from a plain copy of the source, per pixel.

    J = ∂(source.x, source.y)/∂(column, row) / ``scale`` by central differences over the
    linked neighbours (``reproject.patch_links``: one patch, one label); a fresh synthesis has
    J = I (a translated copy at the synthesis scale). Returns ‖J − I‖_F (float32, 0
    where invalid; an axis without a linked neighbour counts as undistorted): a zoom by
    s gives √2·|s − 1|, a rotation by θ 2√2·sin(θ/2), a shear k gives k; a map that has
    torn inside one patch gives a large value. Unlike det J accumulated frame by frame it
    sees shear and anisotropic stretch (det 1) and does not drift.
    """
    return _map_deviation(np.ascontiguousarray(sx, np.float64), np.ascontiguousarray(sy, np.float64),
                          np.ascontiguousarray(valid, np.bool_), links, float(scale))


@njit(**PJIT)
def _dilate_rows(src, dst, radius):
    """``dst[i, j]`` true where ``src`` has a true value within ``radius`` columns on row i
    (the rows in parallel: a transposed view gives the columns)."""
    h, w = src.shape
    for i in prange(h):
        last = -radius - 1  # last set column seen
        for j in range(w):
            if src[i, j]:
                last = j
            if j - last <= radius:
                dst[i, j] = True
        nxt = w + radius + 1
        for j in range(w - 1, -1, -1):
            if src[i, j]:
                nxt = j
            if nxt - j <= radius:
                dst[i, j] = True


def dilate(flags, radius):
    """Square dilation by ``radius`` pixels (separable: rows, then columns)."""
    flags = np.ascontiguousarray(flags, np.bool_)
    tmp = np.zeros(flags.shape, np.bool_)
    _dilate_rows(flags, tmp, int(radius))
    out = np.zeros(flags.shape, np.bool_)
    _dilate_rows(tmp.T, out.T, int(radius))
    return out


@njit(**JIT)
def components4(mask):
    """4-connected components of ``mask``: (labels (H, W) int64, 0 outside, 1.. in scan
    order of each component's first pixel; bounding boxes (n, 4) int64 as row0, row1,
    col0, col1 inclusive)."""
    h, w = mask.shape
    lab = np.zeros((h, w), np.int64)
    boxes = np.zeros((16, 4), np.int64)
    stack = np.empty(h * w, np.int64)
    n = 0
    for i0 in range(h):
        for j0 in range(w):
            if not mask[i0, j0] or lab[i0, j0] != 0:
                continue
            n += 1
            if n > boxes.shape[0]:
                nb = np.zeros((boxes.shape[0] * 2, 4), np.int64)
                nb[:boxes.shape[0]] = boxes
                boxes = nb
            boxes[n - 1, 0] = i0
            boxes[n - 1, 1] = i0
            boxes[n - 1, 2] = j0
            boxes[n - 1, 3] = j0
            lab[i0, j0] = n
            top = 0
            stack[top] = i0 * w + j0
            top += 1
            while top > 0:
                top -= 1
                s = stack[top]
                i = s // w
                j = s - i * w
                boxes[n - 1, 0] = min(boxes[n - 1, 0], i)
                boxes[n - 1, 1] = max(boxes[n - 1, 1], i)
                boxes[n - 1, 2] = min(boxes[n - 1, 2], j)
                boxes[n - 1, 3] = max(boxes[n - 1, 3], j)
                for d in range(4):
                    a = i + (1 if d == 0 else (-1 if d == 1 else 0))
                    b = j + (1 if d == 2 else (-1 if d == 3 else 0))
                    if a >= 0 and b >= 0 and a < h and b < w and mask[a, b] and lab[a, b] == 0:
                        lab[a, b] = n
                        stack[top] = a * w + b
                        top += 1
    return lab, boxes[:n].copy()


@njit(**PJIT)
def keep_carried(flag, reanchored, D, ext, sx, sy, patch, rgb, res, correct):
    """What a carried pixel keeps, by its flag (0: kept whole; ``reanchored``: its new map,
    not its old correction; any other: nothing, resynthesized), in one pass.

    With ``correct`` (the colour is the source read through the map plus the carried
    correction ``res``): colour = ``rgb`` + ``res`` where kept whole, ``rgb`` where
    re-anchored; without, colour = ``res`` (the previous colour) where kept. Returns
    planar R, G, B, source.x, source.y, patch.id, distortion (kept whole only),
    extension and the three correction planes (0 where not kept whole), all (H, W)."""
    h, w = flag.shape
    R = np.empty((h, w), np.float32)  # every element written below (no zeroing pass first)
    G = np.empty((h, w), np.float32)
    B = np.empty((h, w), np.float32)
    osx = np.empty((h, w), np.float32)
    osy = np.empty((h, w), np.float32)
    opatch = np.empty((h, w), np.uint32)
    oD = np.empty((h, w), np.float32)
    oext = np.empty((h, w), np.float32)
    c0 = np.empty((h, w), np.float32)
    c1 = np.empty((h, w), np.float32)
    c2 = np.empty((h, w), np.float32)
    z = np.float32(0.0)
    for i in prange(h):
        for j in range(w):
            f = flag[i, j]
            if f != 0 and f != reanchored:
                R[i, j] = G[i, j] = B[i, j] = z
                osx[i, j] = osy[i, j] = oD[i, j] = oext[i, j] = z
                opatch[i, j] = 0
                c0[i, j] = c1[i, j] = c2[i, j] = z
                continue
            osx[i, j] = sx[i, j]
            osy[i, j] = sy[i, j]
            opatch[i, j] = patch[i, j]
            oext[i, j] = ext[i, j]
            if not correct:
                R[i, j] = res[i, j, 0]
                G[i, j] = res[i, j, 1]
                B[i, j] = res[i, j, 2]
                c0[i, j] = c1[i, j] = c2[i, j] = z
            elif f == 0:
                c0[i, j] = res[i, j, 0]
                c1[i, j] = res[i, j, 1]
                c2[i, j] = res[i, j, 2]
                R[i, j] = rgb[i, j, 0] + res[i, j, 0]
                G[i, j] = rgb[i, j, 1] + res[i, j, 1]
                B[i, j] = rgb[i, j, 2] + res[i, j, 2]
            else:  # + 0: the dropped correction (-0.0 reads as 0.0, as it did with it)
                R[i, j] = rgb[i, j, 0] + np.float32(0.0)
                G[i, j] = rgb[i, j, 1] + np.float32(0.0)
                B[i, j] = rgb[i, j, 2] + np.float32(0.0)
                c0[i, j] = c1[i, j] = c2[i, j] = z
            oD[i, j] = D[i, j] if f == 0 else z
    return R, G, B, osx, osy, opatch, oD, oext, c0, c1, c2


@njit(**JIT)
def area_perimeter(have, ids, n):
    """Per id < n over the ``have`` pixels: area (pixels) and perimeter (edges to a pixel
    of another id, a pixel not in ``have`` or the image border), both int64 (n,)."""
    h, w = ids.shape
    area = np.zeros(n, np.int64)
    per = np.zeros(n, np.int64)
    for i in range(h):
        for j in range(w):
            if not have[i, j]:
                continue
            p = ids[i, j]
            area[p] += 1
            for k in range(4):
                a = i + (k == 2) - (k == 3)
                b = j + (k == 0) - (k == 1)
                if a < 0 or a >= h or b < 0 or b >= w or not have[a, b] or ids[a, b] != p:
                    per[p] += 1
    return area, per


@njit(**JIT)
def patch_mean(have, ids, values, n):
    """Mean of ``values`` per id < n over the ``have`` pixels (summed in scan order, as
    ``np.bincount`` does; 0 for ids with none), float64 (n,)."""
    h, w = ids.shape
    s = np.zeros(n, np.float64)
    c = np.zeros(n, np.float64)
    for i in range(h):
        for j in range(w):
            if have[i, j]:
                s[ids[i, j]] += values[i, j]
                c[ids[i, j]] += 1.0
    for k in range(n):
        s[k] /= max(c[k], 1.0)
    return s


@njit(**PJIT)
def in_ids(have, ids, chosen):
    """``have`` pixels whose id is chosen (``chosen`` (n,) bool; ids >= n are not)."""
    h, w = ids.shape
    n = chosen.shape[0]
    out = np.zeros((h, w), np.bool_)
    for i in prange(h):
        for j in range(w):
            p = ids[i, j]
            out[i, j] = have[i, j] and p < n and chosen[p]
    return out


@njit(**PJIT)
def merge_redo(redo, sx_new, sy_new, patch_new, base, sx, sy, patch):
    """The new map where ``redo`` (its patch ids moved past the carried ones by ``base``),
    the carried one elsewhere: (source.x, source.y float32, patch.id uint32)."""
    h, w = redo.shape
    osx = np.empty((h, w), np.float32)
    osy = np.empty((h, w), np.float32)
    op = np.empty((h, w), np.uint32)
    for i in prange(h):
        for j in range(w):
            if redo[i, j]:
                osx[i, j] = sx_new[i, j]
                osy[i, j] = sy_new[i, j]
                op[i, j] = patch_new[i, j] + base
            else:
                osx[i, j] = sx[i, j]
                osy[i, j] = sy[i, j]
                op[i, j] = patch[i, j]
    return osx, osy, op


@njit(**PJIT)
def colour_planes(rgb, flagged, before, c0, c1, c2, correct):
    """Planar R, G, B of ``rgb`` (H, W, 3) and, with ``correct``, the carried correction
    updated by the solve: ``rgb`` − ``before`` on ``flagged`` pixels, the old planes
    (c0, c1, c2) elsewhere (empty planes without ``correct``)."""
    h, w = rgb.shape[0], rgb.shape[1]
    R = np.empty((h, w), np.float32)
    G = np.empty((h, w), np.float32)
    B = np.empty((h, w), np.float32)
    n = h if correct else 0
    o0 = np.empty((n, w), np.float32)
    o1 = np.empty((n, w), np.float32)
    o2 = np.empty((n, w), np.float32)
    for i in prange(h):
        for j in range(w):
            R[i, j] = rgb[i, j, 0]
            G[i, j] = rgb[i, j, 1]
            B[i, j] = rgb[i, j, 2]
            if correct:
                if flagged[i, j]:
                    o0[i, j] = rgb[i, j, 0] - before[i, j, 0]
                    o1[i, j] = rgb[i, j, 1] - before[i, j, 1]
                    o2[i, j] = rgb[i, j, 2] - before[i, j, 2]
                else:
                    o0[i, j] = c0[i, j]
                    o1[i, j] = c1[i, j]
                    o2[i, j] = c2[i, j]
    return R, G, B, o0, o1, o2


@njit(inline="always", **JIT)
def _label_at(src_lab, x, y):
    """``lookup``'s nearest source pixel's label at (x, y) (float32, clamped to the source)."""
    hs, ws = src_lab.shape
    c = min(int(np.floor(min(max(np.float64(x), 0.0), ws - 1.0) + 0.5)), ws - 1)
    r = min(int(np.floor(min(max(np.float64(y), 0.0), hs - 1.0) + 0.5)), hs - 1)
    return src_lab[r, c]


@njit(inline="always", **JIT)
def _on_label(src_lab, x, y, L):
    """(x, y) inside the source (no clamped, smeared edge pixel) on a pixel of label L."""
    hs, ws = src_lab.shape
    return x >= 0 and y >= 0 and x <= ws - 1 and y <= hs - 1 and _label_at(src_lab, x, y) == L


@njit(**PJIT)
def fits_label(src_lab, sx, sy, lab, mask):
    """Pixels of ``mask`` whose source position (``sx``, ``sy``, float32) lies inside the
    source on a pixel of their label ``lab``, in one pass."""
    h, w = mask.shape
    out = np.zeros((h, w), np.bool_)
    for i in prange(h):
        for j in range(w):
            if mask[i, j]:
                out[i, j] = _on_label(src_lab, sx[i, j], sy[i, j], lab[i, j])
    return out


@njit(inline="always", **JIT)
def _stray(src_lab, x, y, L, m):
    """(x, y) off label L (``_on_label``'s complement) and, with ``m`` > 0, so are the
    positions ``m`` source pixels to its right, left, below and above (float32 sums, as
    numpy adds a float32 to a float32 array): well off its label, not on the border the
    first frame's own copies touch."""
    if _on_label(src_lab, x, y, L):
        return False
    z = np.float32(0.0)
    return not (m > 0 and (_on_label(src_lab, x + m, y + z, L) or _on_label(src_lab, x - m, y + z, L)
                           or _on_label(src_lab, x + z, y + m, L) or _on_label(src_lab, x + z, y - m, L)))


@njit(**PJIT)
def snap_to_label(src_lab, sx, sy, lab, mask, m):
    """In place on ``sx``, ``sy`` (float32): each ``mask`` pixel whose source position is off
    its label (``_on_label``) but on it ``m`` source pixels to its right, left, below or above
    (the first that is, in that order; ``_stray``'s test) moved along that axis onto the
    nearest position of that on-label source pixel (its half-pixel border, clamped inside the
    source): at most ``m`` pixels, so a patch's texture stays put, but its nearest source pixel
    is its own label's. Returns the (H, W) bool mask of the pixels moved."""
    h, w = mask.shape
    hs, ws = src_lab.shape
    moved = np.zeros((h, w), np.bool_)
    z = np.float32(0.0)
    half = np.float32(0.5)
    for i in prange(h):
        for j in range(w):
            if not mask[i, j]:
                continue
            x = sx[i, j]
            y = sy[i, j]
            L = lab[i, j]
            if m <= 0 or _on_label(src_lab, x, y, L):
                continue
            for d in range(4):
                dx = m if d == 0 else (-m if d == 1 else z)
                dy = m if d == 2 else (-m if d == 3 else z)
                if not _on_label(src_lab, x + dx, y + dy, L):
                    continue
                if d < 2:
                    c = np.float32(np.floor(np.float64(x + dx) + 0.5))
                    if d == 0:  # the pixel to the right: its left border (rounds up onto it)
                        x = max(c - half, z)
                    else:  # to the left: just below its right border
                        x = min(np.nextafter(c + half, np.float32(-np.inf)), np.float32(ws - 1))
                else:
                    r = np.float32(np.floor(np.float64(y + dy) + 0.5))
                    if d == 2:
                        y = max(r - half, z)
                    else:
                        y = min(np.nextafter(r + half, np.float32(-np.inf)), np.float32(hs - 1))
                sx[i, j] = x
                sy[i, j] = y
                moved[i, j] = True
                break
    return moved


@njit(inline="always", **JIT)
def _patch_neighbours(valid, patch, lab, i, j):
    """The columns left and right and the rows above and below (i, j) that are linked to it
    (valid, one patch and label), each (i, j)'s own where its neighbour is not: the
    differences of ``_deviation`` and ``_smaller_stretch``."""
    h, w = valid.shape
    P = patch[i, j]
    L = lab[i, j]
    jl = j - 1 if j > 0 and valid[i, j - 1] and lab[i, j - 1] == L and patch[i, j - 1] == P else j
    jr = j + 1 if j < w - 1 and valid[i, j + 1] and lab[i, j + 1] == L and patch[i, j + 1] == P else j
    iu = i - 1 if i > 0 and valid[i - 1, j] and lab[i - 1, j] == L and patch[i - 1, j] == P else i
    idn = i + 1 if i < h - 1 and valid[i + 1, j] and lab[i + 1, j] == L and patch[i + 1, j] == P else i
    return jl, jr, iu, idn


@njit(**PJIT)
def map_deviation_patches(sx, sy, valid, patch, lab, scale):
    """``map_deviation(sx, sy, valid, reproject.patch_links(valid, patch, lab), scale)`` in
    one pass on the float32 maps: the links (valid neighbours of one patch and label) taken
    on the fly, the differences in float64 as there (bit for bit the same)."""
    h, w = sx.shape
    out = np.zeros((h, w), np.float32)
    for i0 in prange(h):
        i = np.int64(i0)
        for j in range(w):
            if not valid[i, j]:
                continue
            jl, jr, iu, idn = _patch_neighbours(valid, patch, lab, i, j)
            out[i, j] = _deviation(sx, sy, i, j, jl, jr, iu, idn, scale)
    return out


@njit(inline="always", **JIT)
def _smaller_stretch(sx, sy, i, j, jl, jr, iu, idn, scale):
    """The smaller singular value of J / scale at (i, j), J by the differences of
    ``_deviation`` (an axis without a neighbour counts as undistorted: its column of J is
    the identity's), in float64."""
    a = 1.0
    c = 0.0
    b = 0.0
    d = 1.0
    if jr != jl:
        hx = 0.5 if jr - jl == 2 else 1.0
        a = (np.float64(sx[i, jr]) - np.float64(sx[i, jl])) * hx / scale
        c = (np.float64(sy[i, jr]) - np.float64(sy[i, jl])) * hx / scale
    if idn != iu:
        hy = 0.5 if idn - iu == 2 else 1.0
        b = (np.float64(sx[idn, j]) - np.float64(sx[iu, j])) * hy / scale
        d = (np.float64(sy[idn, j]) - np.float64(sy[iu, j])) * hy / scale
    s = a * a + b * b + c * c + d * d
    det = a * d - b * c
    disc = s * s - 4.0 * det * det
    r = np.sqrt(disc) if disc > 0.0 else 0.0
    lo = 0.5 * (s - r)
    return np.sqrt(lo) if lo > 0.0 else 0.0


@njit(**PJIT)
def map_stretch_patches(sx, sy, valid, patch, lab, scale):
    """The smaller singular value of the carried map's J / scale per pixel (float32, 0
    where not ``valid``), J by the differences of ``map_deviation_patches`` (linked
    neighbours: valid, one patch and label): below 1 the map magnifies the source along
    some direction (a zoom in by s gives 1 / s), whatever it does along the other."""
    h, w = sx.shape
    out = np.zeros((h, w), np.float32)
    for i0 in prange(h):
        i = np.int64(i0)
        for j in range(w):
            if not valid[i, j]:
                continue
            jl, jr, iu, idn = _patch_neighbours(valid, patch, lab, i, j)
            out[i, j] = _smaller_stretch(sx, sy, i, j, jl, jr, iu, idn, scale)
    return out


@njit(**PJIT)
def clean_flags(raw, radius, min_neighbours, dilate, have, stray, disoccluded, newly, distorted):
    """The flags cleaned in one pass (the carry's
    fix-ups): a flag with fewer than ``min_neighbours`` other flags in its
    (2·radius+1)² window is dropped (none dropped when
    ``min_neighbours`` <= 0); a pixel left unflagged takes ``newly`` when a kept flag
    ``newly`` lies within ``dilate`` pixels (square, ``dilate``'s), else ``disoccluded``
    when a kept ``disoccluded`` does; then, still unflagged, ``disoccluded`` where not
    ``have`` and ``distorted`` where ``stray``. Returns the flags (uint32) and their
    counts per value 0..4 (int64 (5,); values above 4 are not counted)."""
    h, w = raw.shape
    kept = np.empty((h, w), np.uint32)
    for i in prange(h):
        for j in range(w):
            f = raw[i, j]
            if f != 0 and min_neighbours > 0:
                n = 0
                for a in range(max(0, i - radius), min(h, i + radius + 1)):
                    for b in range(max(0, j - radius), min(w, j + radius + 1)):
                        if raw[a, b] != 0:
                            n += 1
                if n - 1 < min_neighbours:
                    f = 0
            kept[i, j] = f
    # bit 1: a kept ``disoccluded`` within ``dilate`` columns, bit 2: a kept ``newly``
    near = np.zeros((h, w), np.uint8)
    if dilate > 0:
        for i in prange(h):
            last1 = -dilate - 1
            last2 = -dilate - 1
            for j in range(w):
                if kept[i, j] == disoccluded:
                    last1 = j
                elif kept[i, j] == newly:
                    last2 = j
                m = 0
                if j - last1 <= dilate:
                    m |= 1
                if j - last2 <= dilate:
                    m |= 2
                near[i, j] = m
            nxt1 = w + dilate + 1
            nxt2 = w + dilate + 1
            for j in range(w - 1, -1, -1):
                if kept[i, j] == disoccluded:
                    nxt1 = j
                elif kept[i, j] == newly:
                    nxt2 = j
                m = near[i, j]
                if nxt1 - j <= dilate:
                    m |= 1
                if nxt2 - j <= dilate:
                    m |= 2
                near[i, j] = m
    out = np.empty((h, w), np.uint32)
    nt = 64
    counts = np.zeros((nt, 5), np.int64)
    step = (h + nt - 1) // nt
    for t in prange(nt):
        acc = np.zeros(w, np.uint8)
        for i in range(t * step, min(h, (t + 1) * step)):
            if dilate > 0:  # the rows within ``dilate``: their bits or-ed, row by row
                acc[:] = 0
                for a in range(max(0, i - dilate), min(h, i + dilate + 1)):
                    for j in range(w):
                        acc[j] |= near[a, j]
            for j in range(w):
                f = kept[i, j]
                if f == 0 and dilate > 0:
                    m = acc[j]
                    if m & 2:
                        f = newly
                    elif m & 1:
                        f = disoccluded
                if f == 0:
                    if not have[i, j]:
                        f = disoccluded
                    elif stray[i, j]:
                        f = distorted
                out[i, j] = f
                if f < 5:
                    counts[t, f] += 1
    total = np.zeros(5, np.int64)
    for t in range(nt):
        for v in range(5):
            total[v] += counts[t, v]
    return out, total


@njit(**PJIT)
def continue_filled(filled, valid, ext, src_lab, sx, sy, lab, extend_frames):
    """The continued (filled) pixels of a carry: their frames of continuation ``ext``
    counted up by one (in place, float32), and those still continued: on their label in
    the source (``fits_label``) and continued for at most ``extend_frames`` frames.
    Returns (still continued, ``valid`` or still continued), (H, W) bool."""
    h, w = filled.shape
    keep = np.empty((h, w), np.bool_)
    have = np.empty((h, w), np.bool_)
    one = np.float32(1.0)
    for i in prange(h):
        for j in range(w):
            k = False
            if filled[i, j]:
                ext[i, j] = ext[i, j] + one
                k = _on_label(src_lab, sx[i, j], sy[i, j], lab[i, j]) and ext[i, j] <= extend_frames
            keep[i, j] = k
            have[i, j] = valid[i, j] or k
    return keep, have


class FlagCodes(NamedTuple):
    """The flag values ``flag_reasons`` writes (uint32; passed as a plain tuple, see
    ``reproject.Landing``)."""
    disoccluded: np.uint32
    newly: np.uint32
    distorted: np.uint32
    reanchored: np.uint32


@njit(**PJIT)
def flag_reasons(have, absorbed, distorted, src_lab, sx, sy, lab, margin, cat, cat_c, land, prev_lab, codes):
    """A carry's raw flags, in one pass, each pixel by the last that applies (``codes``:
    ``FlagCodes``; ``land``: ``reproject.Landing`` into the previous camera, its u, v and ok): ``reanchored``
    where ``absorbed``; where ``distorted``, ``reanchored`` if its (re-anchored) source
    position is on its label (``fits_label``) else ``dist_flag``; ``dist_flag`` where a kept
    pixel (``have``, none of those) is off its label (``_stray`` with ``margin``:
    *stray*); ``disoccluded`` where not ``have``; ``newly`` where ConsistentDepth's category
    is ``cat_c`` (``ok``) and the pixel lands (``u``, ``v``) outside the previous image or
    on a pixel of another label. Returns (raw
    flags uint32, stray bool)."""
    u, v, _, ok = land
    disoccluded, newly, dist_flag, reanchored = codes
    h, w = have.shape
    hp, wp = prev_lab.shape
    raw = np.empty((h, w), np.uint32)
    stray = np.empty((h, w), np.bool_)
    m = np.float32(margin)
    for i in prange(h):
        for j in range(w):
            r = np.uint32(0)
            s = False
            L = lab[i, j]
            if absorbed[i, j]:
                r = reanchored
            if distorted[i, j]:
                r = reanchored if _on_label(src_lab, sx[i, j], sy[i, j], L) else dist_flag
            if have[i, j] and r == 0:
                s = _stray(src_lab, sx[i, j], sy[i, j], L, m)
                if s:
                    r = dist_flag
            if not have[i, j]:
                r = disoccluded
            if cat[i, j] == cat_c and ok[i, j]:
                c = int(np.floor(u[i, j]))
                rr = int(np.floor(v[i, j]))
                if not (c >= 0 and rr >= 0 and c < wp and rr < hp) or prev_lab[rr, c] != L:
                    r = newly
            raw[i, j] = r
            stray[i, j] = s
    return raw, stray


@njit(**JIT)
def reanchor(distorted, ids, sx, sy, scale, n):
    """The re-anchored map of the ``distorted`` pixels, in place on ``sx``, ``sy``
    (float32): each patch's plain copy through its mean position and mean source
    position, sx = mean sx + (column − mean column) · scale (likewise sy), the means
    summed in scan order in float64 (``np.bincount``'s numbers)."""
    h, w = distorted.shape
    c = np.zeros(n, np.float64)
    mi = np.zeros(n, np.float64)
    mj = np.zeros(n, np.float64)
    mx = np.zeros(n, np.float64)
    my = np.zeros(n, np.float64)
    for i in range(h):
        for j in range(w):
            if distorted[i, j]:
                p = ids[i, j]
                c[p] += 1.0
                mi[p] += np.float64(i)
                mj[p] += np.float64(j)
                mx[p] += np.float64(sx[i, j])
                my[p] += np.float64(sy[i, j])
    for p in range(n):
        k = max(c[p], 1.0)
        mi[p] /= k
        mj[p] /= k
        mx[p] /= k
        my[p] /= k
    for i in range(h):
        for j in range(w):
            if distorted[i, j]:
                p = ids[i, j]
                sx[i, j] = mx[p] + (j - mj[p]) * scale
                sy[i, j] = my[p] + (i - mi[p]) * scale


ENCODE_STEPS = 4096  # intervals of the encoding's table: linear interpolation in t = √v within 1e-6 of it


@njit(inline="always", **JIT)
def _display(v, table):
    """sRGB encoding of a linear value, clipped to [0, 1]: the linear segment exactly, the
    power segment interpolated in ``table`` (the encoding of t², t at ``ENCODE_STEPS`` + 1
    even steps in [0, 1]: ``io.colourlib.srgb_encoding_table``) at √v, where it is smooth
    (no pow per pixel)."""
    if v <= 0.0031308:
        return 12.92 * v if v > 0.0 else 0.0
    if v >= 1.0:
        return 1.0
    x = np.sqrt(v) * (len(table) - 1)
    k = min(int(x), len(table) - 2)
    f = x - k
    return table[k] + f * (table[k + 1] - table[k])


@njit(**PJIT)
def _label_gradients(rgb, lab, n, table):
    """``label_gradients`` with the encoding's table."""
    h, w = lab.shape
    lum = np.empty((h, w), np.float64)
    for i in prange(h):
        for j in range(w):
            lum[i, j] = (0.2126 * _display(rgb[i, j, 0], table) + 0.7152 * _display(rgb[i, j, 1], table)
                         + 0.0722 * _display(rgb[i, j, 2], table))
    rs = np.zeros((max(h - 1, 0), n), np.float64)
    rc = np.zeros((max(h - 1, 0), n), np.int64)
    for i in prange(h - 1):
        for j in range(w - 1):
            L = lab[i, j]
            if L >= n or lab[i, j + 1] != L or lab[i + 1, j] != L:
                continue
            dx = lum[i, j + 1] - lum[i, j]
            dy = lum[i + 1, j] - lum[i, j]
            rs[i, L] += np.sqrt(dx * dx + dy * dy)
            rc[i, L] += 1
    s = np.zeros(n, np.float64)
    c = np.zeros(n, np.int64)
    for i in range(h - 1):
        for L in range(n):
            s[L] += rs[i, L]
            c[L] += rc[i, L]
    return s, c


def label_gradients(rgb, lab, n, table):
    """Per label id < ``n``: (sum, count) of the display luma's gradient magnitude
    √(dx² + dy²) (forward differences; luma: Rec. 709 weights on sRGB-encoded values) over
    the pixels whose right and lower neighbours have their label: ``quality.gradient_magnitude``
    of each label at once (bench_shot's grad, kept in the carried state against the creep).
    Summed per row, then the rows in order: the same numbers with any thread count.
    ``table``: colour-science's sRGB encoding tabulated (``_display``)."""
    return _label_gradients(rgb, lab, n, table)
