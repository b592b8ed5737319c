"""Measures of a synthesized frame that a supervisor would see: seams and detail.

Both are taken over pairs of 4-adjacent pixels of one label (label borders are the
layout's, not the texture's):

* ``seam_share``: the share of pairs whose source positions are not neighbours in the
  source, i.e. whose step in ``source.x/y`` differs from the expected ``scale`` step
  (one pixel across, ``scale`` source pixels) by more than ``tol`` source pixels. A
  patch-based synthesis has seams only at patch borders; a coordinate map that decays
  over a shot breaks into many small pieces and this share grows.
* ``detail``: the mean absolute colour difference of the pairs (summed over channels):
  a texture that blurs loses it, one that breaks into tiles with hard edges gains it.

Pure functions of arrays.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import PJIT


@njit(**PJIT)
def _seams(sx, sy, lab, scale, tol):
    h, w = lab.shape
    pairs = np.zeros(h, np.int64)
    seams = np.zeros(h, np.int64)
    t2 = tol * tol
    for i in prange(h):
        n = 0
        s = 0
        for j in range(w):
            if j + 1 < w and lab[i, j + 1] == lab[i, j]:
                n += 1
                dx = np.float64(sx[i, j + 1]) - sx[i, j] - scale
                dy = np.float64(sy[i, j + 1]) - sy[i, j]
                if dx * dx + dy * dy > t2:
                    s += 1
            if i + 1 < h and lab[i + 1, j] == lab[i, j]:
                n += 1
                dx = np.float64(sx[i + 1, j]) - sx[i, j]
                dy = np.float64(sy[i + 1, j]) - sy[i, j] - scale
                if dx * dx + dy * dy > t2:
                    s += 1
        pairs[i] = n
        seams[i] = s
    return pairs.sum(), seams.sum()


def seam_share(sx: np.ndarray, sy: np.ndarray, labels: np.ndarray, *, scale: float = 1.0,
               tol: float = 1.0) -> float:
    """Share of same-label 4-adjacent pixel pairs whose source positions are not neighbours.

    Parameters
    ----------
    sx, sy : (M, N) float ndarray
        The coordinate map (``source.x``, ``source.y``).
    labels : (M, N) integer ndarray
        ``label.id``; pairs across a label border are not counted.
    scale : float
        Source pixels per output pixel (the expected step between neighbours).
    tol : float
        Largest distance, in source pixels, between a pair's step and the expected step.
    """
    lab = np.ascontiguousarray(labels, np.uint32)
    n, s = _seams(np.ascontiguousarray(sx, np.float32), np.ascontiguousarray(sy, np.float32), lab,
                  float(scale), float(tol))
    return float(s) / n if n else 0.0


@njit(**PJIT)
def _detail(rgb, lab):
    h, w, c = rgb.shape
    pairs = np.zeros(h, np.int64)
    total = np.zeros(h, np.float64)
    for i in prange(h):
        n = 0
        t = 0.0
        for j in range(w):
            if j + 1 < w and lab[i, j + 1] == lab[i, j]:
                n += 1
                for k in range(c):
                    t += abs(np.float64(rgb[i, j + 1, k]) - rgb[i, j, k])
            if i + 1 < h and lab[i + 1, j] == lab[i, j]:
                n += 1
                for k in range(c):
                    t += abs(np.float64(rgb[i + 1, j, k]) - rgb[i, j, k])
        pairs[i] = n
        total[i] = t
    return pairs.sum(), total.sum()


def detail(rgb: np.ndarray, labels: np.ndarray) -> float:
    """Mean absolute colour difference (summed over channels) of same-label 4-adjacent pairs.

    rgb : (M, N, C) float ndarray; labels : (M, N) integer ndarray.
    """
    n, t = _detail(np.ascontiguousarray(rgb, np.float32), np.ascontiguousarray(labels, np.uint32))
    return float(t) / n if n else 0.0


def repetition(sx: np.ndarray, sy: np.ndarray, source_shape: tuple[int, int], *, top: float = 0.01) -> float:
    """Share of the output's pixels drawn from the most-used ``top`` share of source pixels
    (``source.x/y`` rounded to source pixels). A synthesis that copies the source evenly
    gives about ``top`` times the output/source area ratio, capped at 1; the same few
    source patches tiled on a lattice give much more."""
    hs, ws = source_shape
    c = np.clip(np.rint(sx), 0, ws - 1).astype(np.int64)
    r = np.clip(np.rint(sy), 0, hs - 1).astype(np.int64)
    counts = np.bincount((r * ws + c).ravel(), minlength=hs * ws)
    k = max(1, int(round(top * hs * ws)))
    return float(np.sort(counts)[-k:].sum() / counts.sum())
