"""Exact Euclidean distance of every pixel to the nearest label contour.

The feature maps of fast guided synthesis (Bonneel et al. 2010, §5, after Lefebvre and
Hoppe 2006) hold, for each pixel, the distance to the closest contour of the label map;
the paper computes it with Danielsson's approximate transform. Here it is exact: a
contour pixel is one with a 4-neighbour of another label, and the distance of a pixel
is the Euclidean distance (between pixel centres) to the nearest contour pixel, computed
with the separable lower-envelope transform of Felzenszwalb and Huttenlocher.

References
----------
P. Felzenszwalb, D. Huttenlocher. Distance Transforms of Sampled Functions. Theory of
Computing 8, 2012.
P.-E. Danielsson. Euclidean distance mapping. CGIP 14, 1980.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from proxyshade.kernels._config import JIT

_BIG = np.int64(1) << np.int64(60)  # "no site": larger than any squared distance on a grid


@njit(**JIT)
def _contour_mask(labels):
    h, w = labels.shape
    out = np.zeros((h, w), np.bool_)
    for i in range(h):  # serial: a few milliseconds a frame (a parallel loop compiles 1 s slower)
        for j in range(w):
            v = labels[i, j]
            if (i > 0 and labels[i - 1, j] != v) or (i + 1 < h and labels[i + 1, j] != v) \
                    or (j > 0 and labels[i, j - 1] != v) or (j + 1 < w and labels[i, j + 1] != v):
                out[i, j] = True
    return out


def _edt_sq(sites):
    """Exact squared Euclidean distance (int64) to the nearest True pixel of ``sites``
    (``_BIG`` where there is none), from the nearest-site transform (``_nearest_site``,
    the kernel ``nearest_site`` calls: one compile serves both)."""
    return _dist_sq(_nearest_site(sites))


# serial: about 0.1 ms a call at the synthesis size; inside a parallel kernel calling
# _nearest_site it compiled 1.5 s longer
@njit(**JIT)
def _dist_sq(near):
    h, w = near.shape[0], near.shape[1]
    d = np.empty((h, w), np.int64)
    for i in range(h):
        for j in range(w):
            r = near[i, j, 0]
            if r < 0:
                d[i, j] = _BIG
            else:
                c = near[i, j, 1]
                d[i, j] = (i - r) * (i - r) + (j - c) * (j - c)
    return d


# serial: 0.01 ms a call; a parallel loop compiled 0.3 s longer
@njit(**JIT)
def _sqrt_clamped(d2, cap, out):
    h, w = d2.shape
    for i in range(h):
        for j in range(w):
            x = d2[i, j]
            if x >= _BIG:
                out[i, j] = cap
            else:
                r = np.sqrt(np.float64(x))
                out[i, j] = r if r < cap else cap


def _as_int32(labels: np.ndarray) -> np.ndarray:
    """uint32 ids seen as int32 (the same bits: equal stays equal), so label ids and dense
    indices share one compiled signature."""
    labels = np.ascontiguousarray(labels)
    return labels.view(np.int32) if labels.dtype == np.uint32 else labels


def contour_mask(labels: np.ndarray) -> np.ndarray:
    """(H, W) bool: pixels with a 4-neighbour of a different label."""
    return _contour_mask(_as_int32(labels))


def squared_distance(sites: np.ndarray) -> np.ndarray:
    """(H, W) int64 exact squared distance to the nearest True pixel of ``sites``.

    Pixels are at integer centres; with no site at all every entry is ``2**60``.
    """
    return _edt_sq(np.ascontiguousarray(sites, dtype=np.bool_))


def contour_distance(labels: np.ndarray, *, max_distance: float | None = None) -> np.ndarray:
    """Exact Euclidean distance of each pixel to the nearest label contour.

    Parameters
    ----------
    labels : (M, N) integer ndarray
        Label ids.
    max_distance : float, optional
        Clamp distances above this value (also the value everywhere when the map has
        a single label). Without it such a map is all ``inf``.

    Returns
    -------
    (M, N) float32 ndarray
        0 on contour pixels (those with a 4-neighbour of another label).
    """
    labels = _as_int32(labels)
    if labels.ndim != 2:
        raise ValueError(f"labels must be 2-D (M, N), got shape {labels.shape}")
    d2 = _edt_sq(_contour_mask(labels))
    out = np.empty(labels.shape, np.float32)
    cap = np.inf if max_distance is None else float(max_distance)
    _sqrt_clamped(d2, cap, out)
    return out


@njit(**JIT)
def _envelope_1d_arg(f, n, out, arg, v, z):
    """Squared distance transform of one line: out[q] = min_p (q - p)^2 + f[p], and in
    ``arg`` the minimizing site (the first on ties; −1 when there is none).

    ``f`` holds integers (``_BIG`` where there is no site). Sites are the finite
    entries; with none, ``out`` is all ``_BIG``. Parabola intersections are compared as
    exact rationals: s = ((f[q] + q²) − (f[p] + p²)) / (2q − 2p), kept as (num, den)
    pairs in ``z`` (z[0] = −1/0 marks −infinity).
    """
    k = -1
    for q in range(n):
        if f[q] >= _BIG:
            continue
        fq = f[q] + q * q
        while k >= 0:
            p = v[k]
            num = fq - (f[p] + p * p)
            den = 2 * (q - p)
            if num * z[2 * k + 1] <= z[2 * k] * den:
                k -= 1
            else:
                break
        k += 1
        v[k] = q
        if k == 0:
            z[0] = -1
            z[1] = 0
        else:
            p = v[k - 1]
            z[2 * k] = fq - (f[p] + p * p)
            z[2 * k + 1] = 2 * (q - p)
    if k < 0:
        for q in range(n):
            out[q] = _BIG
            arg[q] = -1
        return
    j = 0
    for q in range(n):
        while j < k and z[2 * (j + 1)] <= q * z[2 * (j + 1) + 1]:
            j += 1
        p = v[j]
        out[q] = (q - p) * (q - p) + f[p]
        arg[q] = p


@njit(**JIT)
def _nearest_site_columns(sites, g, gi, c0, c1):
    """Columns c0..c1 of the first pass: each column's squared distance to its nearest
    site in ``g`` and that site's row in ``gi``."""
    h = sites.shape[0]
    for j in range(c0, c1):
        f = np.empty(h, np.int64)
        out = np.empty(h, np.int64)
        arg = np.empty(h, np.int64)
        v = np.empty(h, np.int64)
        z = np.empty(2 * h + 2, np.int64)
        for i in range(h):
            f[i] = 0 if sites[i, j] else _BIG
        _envelope_1d_arg(f, h, out, arg, v, z)
        for i in range(h):
            g[i, j] = out[i]
            gi[i, j] = arg[i]


@njit(**JIT)
def _nearest_site_rows(g, gi, res, r0, r1):
    """Rows r0..r1 of the second pass: along each row, the nearest of the columns' sites."""
    w = g.shape[1]
    for i in range(r0, r1):
        f = np.empty(w, np.int64)
        out = np.empty(w, np.int64)
        arg = np.empty(w, np.int64)
        v = np.empty(w, np.int64)
        z = np.empty(2 * w + 2, np.int64)
        for j in range(w):
            f[j] = g[i, j]
        _envelope_1d_arg(f, w, out, arg, v, z)
        for j in range(w):
            c = arg[j]
            if c < 0:
                res[i, j, 0] = -1
                res[i, j, 1] = -1
            else:
                res[i, j, 0] = gi[i, c]
                res[i, j, 1] = c


def _nearest_site(sites):
    """The exact two-pass transform (columns, then rows); serial (tens of milliseconds a
    frame: the parallel loops compiled 1.2 s longer)."""
    h, w = sites.shape
    g = np.empty((h, w), np.int64)
    gi = np.empty((h, w), np.int64)
    _nearest_site_columns(sites, g, gi, 0, w)
    res = np.empty((h, w, 2), np.int32)
    _nearest_site_rows(g, gi, res, 0, h)
    return res


def nearest_site(sites: np.ndarray) -> np.ndarray:
    """(M, N, 2) int32 (row, column) of a nearest True pixel of ``sites`` (Euclidean,
    exact; among equally near sites, one of them), -1 where there is none."""
    return _nearest_site(np.ascontiguousarray(sites, dtype=np.bool_))
