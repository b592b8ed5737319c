"""Kernels of an edit's progressive update (``synthesis.edit``, ``synthesis.depth``): the
difference of two renders in one pass, and the depth's world positions of a region's
pixels only (the same numbers as ``reproject.unproject`` gives them on the frame)."""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import JIT, PJIT
from proxyshade.kernels.pinhole import _world


@njit(**PJIT)
def mark_differences(a, b, out, lo, hi):
    """``out[i, j] |= a[i, j] != b[i, j]`` (NaN equal to NaN), and per row the first
    (``lo``) and last (``hi``) differing column, both updated (start them at the row's
    width and −1): the bounding box without another pass over the frame."""
    h, w = a.shape
    for i in prange(h):
        first = lo[i]
        last = hi[i]
        for j in range(w):
            x = a[i, j]
            y = b[i, j]
            if x != y and not (x != x and y != y):
                out[i, j] = True
                if j < first:
                    first = j
                last = max(last, j)
        lo[i] = first
        hi[i] = last


@njit(inline="always", **JIT)
def _extended(z, src, i, j):
    """The extended depth of window pixel (i, j): ``z`` (the window's proxy depth) at its
    seed ``src`` (window-flat), inf without one (``depth.extend_depth``'s value: a pixel
    whose label the guide kept is its own seed)."""
    s = src[i, j]
    if s < 0:
        return np.float32(np.inf)
    w = z.shape[1]
    return z[s // w, s % w]


@njit(**PJIT)
def paste_depth(sel, z, src, r0, c0, W, Z, dsrc):
    """At the pixels of ``sel`` (a window of the frame at (``r0``, ``c0``)): ``Z`` takes
    the extended depth (``_extended``) and ``dsrc`` 1 + the frame-flat index of its seed
    (``src``: window-flat, −1 for none, then 0)."""
    h, w = sel.shape
    for i in prange(h):
        for j in range(w):
            if sel[i, j]:
                s = src[i, j]
                Z[r0 + i, c0 + j] = _extended(z, src, i, j)
                if s >= 0:
                    dsrc[r0 + i, c0 + j] = (r0 + s // w) * W + c0 + s % w + 1
                else:
                    dsrc[r0 + i, c0 + j] = 0


@njit(**PJIT)
def paste_unproject(sel, z, src, r0, c0, C, k, PX, PY, PZ):
    """At the pixels of ``sel`` (a window at (``r0``, ``c0``)): the world position of the
    frame's pixel centre at the extended depth (``_extended``; 0 where not finite):
    ``reproject.unproject``'s numbers, bit for bit."""
    h, w = sel.shape
    for i in prange(h):
        for j in range(w):
            if sel[i, j]:
                e = _extended(z, src, i, j)
                if np.isfinite(e):
                    PX[r0 + i, c0 + j] = _world(e, r0 + i, c0 + j, C, k, 0)
                    PY[r0 + i, c0 + j] = _world(e, r0 + i, c0 + j, C, k, 1)
                    PZ[r0 + i, c0 + j] = _world(e, r0 + i, c0 + j, C, k, 2)
                else:
                    PX[r0 + i, c0 + j] = 0.0
                    PY[r0 + i, c0 + j] = 0.0
                    PZ[r0 + i, c0 + j] = 0.0


@njit(**PJIT)
def paste_follow(sel, src, r0, c0, a, out):
    """At the pixels of ``sel`` (a window at (``r0``, ``c0``)): ``a``'s value at the
    pixel the depth came from (``src``, window-flat), or at the pixel itself without one."""
    h, w = sel.shape
    for i in prange(h):
        for j in range(w):
            if sel[i, j]:
                s = src[i, j]
                if s >= 0:
                    out[r0 + i, c0 + j] = a[r0 + s // w, c0 + s % w]
                else:
                    out[r0 + i, c0 + j] = a[r0 + i, c0 + j]
