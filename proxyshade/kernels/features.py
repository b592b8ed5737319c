"""Neighbourhood features of fast guided synthesis (Bonneel et al. 2010, §5).

A pixel is described by its 5×5 neighbourhood of

* distances to the closest label contour (``kernels.distance``, after Lefebvre and Hoppe
  2006), compared with the L2 norm,
* label ids, compared with the symmetric Chamfer distance (``kernels.chamfer``),
* colours (correction passes only), compared with the L2 norm,
* the pixel's relative height in its label's vertical run (``label_heights``: 0 at the
  run's top, 1 at its bottom; a sky from the frame's top to the horizon), its difference
  times a weight added to the L2 norm: the large-scale layout inside a label (a sky
  darker at the top, haze toward the horizon) is matched, not only the contours.

The source side is an *exemplar*: the source photo resampled so that one exemplar pixel
is one synthesis pixel, with, per synthesis level, a stack (full exemplar resolution,
blurred colours, voted labels, neighbourhoods sampled every ``h`` pixels; Lefebvre and
Hoppe 2005). The target side (the guide) is a pyramid: level ``l`` has the guide's
labels voted down by ``h``. Coordinates of the synthesis state are always exemplar
pixels of the finest level, at every level.

Labels are dense indices 0..n-1 here (the plates' ids map through the source's label
table); colours are features ``255 * sRGB(linear)``, so that the paper's Chamfer weight
(w = 90, one L∞ pixel) weighs like a third of a full 8-bit colour step on one pixel.

References
----------
C. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis. Proxy-guided texture synthesis
for rendering natural scenes. VMV 2010.
S. Lefebvre, H. Hoppe. Parallel controllable texture synthesis. SIGGRAPH 2005.
S. Lefebvre, H. Hoppe. Appearance-space texture synthesis. SIGGRAPH 2006.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from proxyshade.kernels._config import JIT
from proxyshade.kernels.chamfer import chamfer_masks  # noqa: F401  (re-exported for the synthesis kernels)
from proxyshade.kernels.chamfer import masks_from_windows
from proxyshade.kernels.distance import contour_distance
from proxyshade.kernels.voting import vote_pyramid, vote_stack  # noqa: F401  (vote_pyramid re-exported)

NB = 5  # neighbourhood side
NB2 = NB * NB


# ---------------------------------------------------------------------------
# resampling the source to the exemplar


def _area_resample(img, oh, ow, f, out):
    """Box-filter ``img`` (H, W, C) by the (possibly fractional) factor f to (oh, ow, C):
    exemplar pixel (i, j) averages the source area [i f, (i + 1) f) x [j f, (j + 1) f)."""
    _area_resample_rows(img, oh, ow, f, out, 0, oh)


@njit(**JIT)
def _area_resample_rows(img, oh, ow, f, out, r0, r1):
    """``_area_resample``'s rows r0..r1."""
    h, w, c = img.shape
    for i in range(r0, r1):
        y0 = i * f
        y1 = (i + 1) * f
        acc = np.zeros(c)
        for j in range(ow):
            x0 = j * f
            x1 = (j + 1) * f
            for k in range(c):
                acc[k] = 0.0
            tot = 0.0
            for y in range(int(np.floor(y0)), min(int(np.ceil(y1)), h)):
                wy = min(y + 1.0, y1) - max(float(y), y0)
                if wy <= 0:
                    continue
                for x in range(int(np.floor(x0)), min(int(np.ceil(x1)), w)):
                    wx = min(x + 1.0, x1) - max(float(x), x0)
                    if wx <= 0:
                        continue
                    wgt = wy * wx
                    tot += wgt
                    for k in range(c):
                        acc[k] += wgt * img[y, x, k]
            for k in range(c):
                out[i, j, k] = acc[k] / tot


# serial: 0.5 ms a call (label pyramids); a parallel loop compiled 0.6 s longer
@njit(**JIT)
def _mode_resample(lab, oh, ow, f, n, out):
    """Majority label over the source pixels whose centres fall in each exemplar pixel's
    area (ties: the smaller index); the nearest pixel when no centre falls inside."""
    h, w = lab.shape
    for i in range(oh):
        cnt = np.zeros(n, np.int64)
        for j in range(ow):
            cnt[:] = 0
            ya = int(np.ceil(i * f - 0.5))
            yb = int(np.ceil((i + 1) * f - 0.5))
            xa = int(np.ceil(j * f - 0.5))
            xb = int(np.ceil((j + 1) * f - 0.5))
            tot = 0
            for y in range(max(ya, 0), min(yb, h)):
                for x in range(max(xa, 0), min(xb, w)):
                    cnt[lab[y, x]] += 1
                    tot += 1
            if tot == 0:
                y = min(max(int(np.floor((i + 0.5) * f)), 0), h - 1)
                x = min(max(int(np.floor((j + 0.5) * f)), 0), w - 1)
                out[i, j] = lab[y, x]
                continue
            best = 0
            for k in range(1, n):
                if cnt[k] > cnt[best]:
                    best = k
            out[i, j] = best


@njit(**JIT)
def _box_mean_1d(a, i, j, k, h, di, dj):
    """Mean of the h values of channel k along (di, dj) = (0, 1) (a row) or (1, 0) (a column),
    offsets -h/2 .. h - h/2 - 1 from (i, j), clamped at the borders."""
    H, W = a.shape[0], a.shape[1]
    s = 0.0
    for d in range(-(h // 2), h - h // 2):
        s += a[min(max(i + d * di, 0), H - 1), min(max(j + d * dj, 0), W - 1), k]
    return s / h


# serial: 0.2 ms a call at the synthesis size; two parallel loops compiled 1 s longer
@njit(**JIT)
def _box_blur_centred(img, h, out):
    """Mean over the h x h block anchored so that its centre is at the pixel (h even:
    offsets -h/2 .. h/2 - 1), clamped at the borders; separable: rows, then columns."""
    H, W, C = img.shape
    tmp = np.empty_like(img)
    for i in range(H):
        for j in range(W):
            for k in range(C):
                tmp[i, j, k] = _box_mean_1d(img, i, j, k, h, 0, 1)
    for i in range(H):
        for j in range(W):
            for k in range(C):
                out[i, j, k] = _box_mean_1d(tmp, i, j, k, h, 1, 0)


def srgb_features(rgb_linear: np.ndarray) -> np.ndarray:
    """(…, 3) linear colour -> float32 feature colour 255 * sRGB-encoded."""
    x = np.clip(np.asarray(rgb_linear, np.float64), 0.0, None)
    enc = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)
    return (255.0 * enc).astype(np.float32)


def dense_labels(ids: np.ndarray, table_ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Map label ids to dense indices 0..n-1 of ``table_ids``; also returns a bool mask
    of pixels whose id is not in the table."""
    table_ids = np.asarray(table_ids, dtype=np.int64)
    order = np.argsort(table_ids)
    sorted_ids = table_ids[order]
    flat = np.asarray(ids, dtype=np.int64)
    pos = np.searchsorted(sorted_ids, flat)
    pos_c = np.clip(pos, 0, len(sorted_ids) - 1)
    missing = sorted_ids[pos_c] != flat
    dense = order[pos_c].astype(np.int32)
    dense[missing] = 0
    return dense, missing


# ---------------------------------------------------------------------------
# levels


class Metric(NamedTuple):
    """The weights of eq. 1 with the height term: ``w`` the Chamfer distance's,
    ``height_weight`` the relative heights' (``label_heights``; 0 = the paper's eq. 1)."""

    w: float
    height_weight: float


class Level(NamedTuple):
    """One synthesis level: exemplar stack level and guide pyramid level (a named tuple:
    the synthesis kernels take it whole, numba reads its fields).

    h : stack spacing (exemplar pixels per level pixel).
    src_lab, src_dist, src_rgb : (He, We) int32, (He, We) float32, (He, We, 3) float32.
    src_masks : (He, We, n) uint32 Chamfer label masks of the 5x5 window, spacing h.
    tgt_lab, tgt_dist : (Ht, Wt) guide pyramid level; tgt_masks (Ht, Wt, n).
    src_height, tgt_height : (He, We), (Ht, Wt) float32 ``label_heights`` of the two sides.
    """

    h: int
    src_lab: np.ndarray
    src_dist: np.ndarray
    src_rgb: np.ndarray
    src_masks: np.ndarray
    tgt_lab: np.ndarray
    tgt_dist: np.ndarray
    tgt_masks: np.ndarray
    src_height: np.ndarray
    tgt_height: np.ndarray


@njit(**JIT)
def _heights(lab, out, length, c0, c1):
    H, W = lab.shape
    for j in range(c0, c1):
        i0 = 0
        while i0 < H:
            i1 = i0
            while i1 + 1 < H and lab[i1 + 1, j] == lab[i0, j]:
                i1 += 1
            n = i1 - i0
            for i in range(i0, i1 + 1):
                out[i, j] = (i - i0) / n if n > 0 else 0.5
                length[i, j] = n + 1
            i0 = i1 + 1


def label_heights(lab: np.ndarray, *, lengths: bool = False):
    """(H, W) float32: each pixel's relative height in its vertical run of one label
    (the pixels of its column between two other labels or the image border): 0 at the
    run's top, 1 at its bottom, 0.5 for a run of one pixel. With ``lengths`` also the
    run's length in pixels ((H, W) int32)."""
    out = np.empty(lab.shape, np.float32)
    n = np.empty(lab.shape, np.int32)
    _heights(np.ascontiguousarray(lab, np.int32), out, n, 0, lab.shape[1])
    return (out, n) if lengths else out


@njit(**JIT)
def _windows(lab, h, out, r0, r1):
    """(H, W, 25) int32: the labels of each pixel's 5x5 window with spacing h, clamped (rows
    r0..r1)."""
    H, W = lab.shape
    for i in range(r0, r1):
        for j in range(W):
            k = 0
            for di in range(-2, 3):
                ii = min(max(i + di * h, 0), H - 1)
                for dj in range(-2, 3):
                    jj = min(max(j + dj * h, 0), W - 1)
                    out[i, j, k] = lab[ii, jj]
                    k += 1


def window_masks(lab: np.ndarray, h: int, n: int) -> np.ndarray:
    """(H, W, n) uint32 per-label bit masks of each pixel's 5x5 window (spacing h)."""
    win = np.empty(lab.shape + (NB2,), np.int32)
    _windows(np.ascontiguousarray(lab, dtype=np.int32), h, win, 0, lab.shape[0])
    return masks_from_windows(win, n)


def build_exemplar(rgb: np.ndarray, lab: np.ndarray, f: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Source (M, N, 3) linear colour and (M, N) dense labels -> exemplar at 1/f."""
    hs, ws = lab.shape
    oh, ow = int(np.floor(hs / f + 1e-9)), int(np.floor(ws / f + 1e-9))
    ex_rgb = np.empty((oh, ow, 3), np.float32)
    ex_lab = np.empty((oh, ow), np.int32)
    if f == 1.0:
        ex_rgb[...] = rgb
        ex_lab[...] = lab
    else:
        _area_resample(np.ascontiguousarray(rgb, np.float32), oh, ow, float(f), ex_rgb)
        _mode_resample(np.ascontiguousarray(lab, np.int32), oh, ow, float(f), n, ex_lab)
    return ex_rgb, ex_lab


def interior_caps(lab: np.ndarray, dist: np.ndarray, n: int, max_distance: float | None,
                  interior: float) -> np.ndarray:
    """(n,) float32 per-label clamp of contour distances: ``max_distance`` (None: none),
    and at most the distance that an ``interior`` share of the label's exemplar pixels
    reach (0: no such clamp): a region of the guide wider than its source region then
    matches that whole share of it as "interior", not only the source region's deepest
    middle."""
    cap = np.full(n, np.float32(max_distance) if max_distance is not None else np.float32(1e6), np.float32)
    if interior > 0:
        for l in np.unique(lab):
            d = dist[lab == l]
            cap[l] = min(cap[l], max(np.float32(1.0), np.quantile(d, 1.0 - interior)))
    return cap


def build_levels(ex_rgb: np.ndarray, ex_lab: np.ndarray, tgt_lab: np.ndarray, n: int, nlevels: int, *,
                 max_distance: float | None = None, with_rgb: bool = True, finest_only: bool = False,
                 interior: float = 0.0) -> list[Level]:
    """Exemplar stack and guide pyramid, coarsest level first (only the finest with
    ``finest_only``: then the list has one level).

    ``tgt_lab`` is the guide at the finest synthesis size (dense labels). Level ``l``
    (0 = coarsest) has spacing ``h = 2 ** (nlevels - 1 - l)``; distances are in level
    pixels (exemplar distances divided by h) and clamped at ``max_distance`` and, per label,
    by ``interior_caps``.
    """
    feat = srgb_features(ex_rgb) if with_rgb else np.zeros(ex_lab.shape + (3,), np.float32)
    if finest_only:
        src_stack = [None] * (nlevels - 1) + [np.ascontiguousarray(ex_lab, np.int32)]
        tgt_pyr = [None] * (nlevels - 1) + [np.ascontiguousarray(tgt_lab, np.int32)]
    else:
        src_stack = vote_stack(ex_lab, nlevels, n)
        tgt_pyr = vote_pyramid(tgt_lab, nlevels, n)
    levels = []
    for l in range(nlevels - 1 if finest_only else 0, nlevels):
        h = 2 ** (nlevels - 1 - l)
        s_lab = np.ascontiguousarray(src_stack[l], np.int32)
        t_lab = np.ascontiguousarray(tgt_pyr[l], np.int32)
        s_dist = contour_distance(s_lab, max_distance=None) / np.float32(h)
        t_dist = contour_distance(t_lab, max_distance=None)
        cap = interior_caps(s_lab, s_dist, n, max_distance, interior)
        s_dist = np.minimum(s_dist, cap[s_lab]).astype(np.float32)
        t_dist = np.minimum(t_dist, cap[t_lab]).astype(np.float32)
        if h == 1 or not with_rgb:
            s_rgb = feat
        else:
            s_rgb = np.empty_like(feat)
            _box_blur_centred(feat, h, s_rgb)
        levels.append(Level(h, s_lab, s_dist, s_rgb, window_masks(s_lab, h, n), t_lab, t_dist,
                            window_masks(t_lab, 1, n), label_heights(s_lab), label_heights(t_lab)))
    return levels


# ---------------------------------------------------------------------------
# distances between a target pixel and an exemplar pixel


@njit(**JIT)
def gather_target(tgt_dist, i, j, outD):
    """The 25 contour distances of target pixel (i, j)'s window (clamped)."""
    H, W = tgt_dist.shape
    k = 0
    for di in range(-2, 3):
        ii = min(max(i + di, 0), H - 1)
        for dj in range(-2, 3):
            jj = min(max(j + dj, 0), W - 1)
            outD[k] = tgt_dist[ii, jj]
            k += 1


@njit(**JIT)
def dist_sq_contour(src_dist, h, y, x, target_dist, bound):
    """Sum of squared differences of contour distances between exemplar window at
    (y, x) (spacing h, clamped) and ``target_dist``; stops early once above ``bound``."""
    H, W = src_dist.shape
    s = 0.0
    k = 0
    for di in range(-2, 3):
        yy = min(max(y + di * h, 0), H - 1)
        for dj in range(-2, 3):
            xx = min(max(x + dj * h, 0), W - 1)
            d = src_dist[yy, xx] - target_dist[k]
            s += d * d
            k += 1
        if s > bound:
            return s
    return s


@njit(inline="always", **JIT)
def height_sq(src_height, y, x, target_height, weight):
    """(weight × (height of exemplar (y, x) − target_height))²: the height term of the metrics."""
    d = weight * (np.float64(src_height[y, x]) - target_height)
    return d * d


@njit(**JIT)
def dist_sq_rgb(src_rgb, h, y, x, target_rgb, bound):
    """Sum of squared feature-colour differences (exemplar window vs ``target_rgb`` (25, 3))."""
    H, W, _ = src_rgb.shape
    s = 0.0
    k = 0
    for di in range(-2, 3):
        yy = min(max(y + di * h, 0), H - 1)
        for dj in range(-2, 3):
            xx = min(max(x + dj * h, 0), W - 1)
            for c in range(3):
                d = src_rgb[yy, xx, c] - target_rgb[k, c]
                s += d * d
            k += 1
        if s > bound:
            return s
    return s
