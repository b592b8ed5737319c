"""Synthesis magnification (Bonneel et al. 2010, §5 step 3) and label repair.

Magnification upsamples the patches, not the pixels: output pixel f p + δ (δ in
[0, f)²) takes exemplar position S[p] (the synthesis map, ``coords`` in the code) scaled
by f plus δ, so every patch keeps its translation and the output reads the source at full
detail. No correction pass runs.

The detailed guide at the output size has finer borders than the synthesis-size guide,
so some pixels land on a source pixel of another label. ``repair_labels`` moves them:
first by continuing a neighbour's translation (S[q] + p − q) when that lands on the
right label, repeated as a front that grows into the wrong region; the few left take the
nearest source pixel of the right label (exact Euclidean nearest-site transform).
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import PJIT
from proxyshade.kernels.distance import nearest_site


@njit(**PJIT)
def _magnify(coords, f, Ho, Wo, out):
    Ht, Wt = coords.shape[0], coords.shape[1]
    for i in prange(Ho):
        I = min(i // f, Ht - 1)
        di = i - f * I
        for j in range(Wo):
            J = min(j // f, Wt - 1)
            dj = j - f * J
            out[i, j, 0] = f * coords[I, J, 0] + di
            out[i, j, 1] = f * coords[I, J, 1] + dj


def magnify(coords: np.ndarray, f: int, shape: tuple[int, int]) -> np.ndarray:
    """(Ho, Wo, 2) int32: coords (Ht, Wt, 2) magnified by the integer factor f (exemplar
    coordinates scaled by f plus the sub-pixel offset), cropped to ``shape``."""
    out = np.empty(tuple(shape) + (2,), np.int32)
    _magnify(np.ascontiguousarray(coords, np.int32), int(f), shape[0], shape[1], out)
    return out


@njit(**PJIT)
def _only_target(coords, srclab, only, guide):
    """``guide`` where ``only``, elsewhere the label each pixel lands on (row/column of
    ``coords`` clamped into ``srclab``): the target under which only ``only`` pixels move."""
    Ht, Wt = guide.shape
    Hs, Ws = srclab.shape
    out = np.empty((Ht, Wt), np.int32)
    for i in prange(Ht):
        for j in range(Wt):
            if only[i, j]:
                out[i, j] = guide[i, j]
            else:
                out[i, j] = srclab[min(max(coords[i, j, 0], 0), Hs - 1), min(max(coords[i, j, 1], 0), Ws - 1)]
    return out


def only_target(coords: np.ndarray, srclab: np.ndarray, only: np.ndarray, guide: np.ndarray) -> np.ndarray:
    """(M, N) int32: ``guide`` on the ``only`` pixels, the source label under ``coords``
    elsewhere (``repair_labels`` then moves only the ``only`` pixels, and those whose
    ``coords`` leaves the source)."""
    return _only_target(np.ascontiguousarray(coords, np.int32), np.ascontiguousarray(srclab, np.int32),
                        np.ascontiguousarray(only, np.bool_), np.ascontiguousarray(guide, np.int32))


@njit(**PJIT)
def _label_ok(coords, guide, srclab, ok):
    Ht, Wt = guide.shape
    Hs, Ws = srclab.shape
    bad = 0
    rows = np.zeros(Ht, np.int64)
    for i in prange(Ht):
        for j in range(Wt):
            y = coords[i, j, 0]
            x = coords[i, j, 1]
            good = 0 <= y < Hs and 0 <= x < Ws and srclab[y, x] == guide[i, j]
            ok[i, j] = good
            if not good:
                rows[i] += 1
    for i in range(Ht):
        bad += rows[i]
    return bad


@njit(**PJIT)
def _front_steps(coords, ok, guide, srclab, ii, jj, max_steps):
    """Front steps (at most ``max_steps``, until a step fixes nothing), visiting only the
    pixels still wrong (``ii``, ``jj``: the wrong pixels, scan order). In one step a wrong
    pixel takes the first of its 8 neighbours (fixed order) that is right, of its label,
    and whose translation continued lands on its label in the source; each step reads the
    state of the previous one (whole-frame steps give the same result: the tests' reference). Updates coords, ok in place;
    returns how many were fixed."""
    Ht, Wt = guide.shape
    Hs, Ws = srclab.shape
    n = ii.shape[0]
    ny = np.empty(n, np.int32)
    nx = np.empty(n, np.int32)
    got = np.zeros(n, np.bool_)
    extended = 0
    for _ in range(max_steps):
        if n == 0:
            break
        for k in prange(n):
            i = ii[k]
            j = jj[k]
            got[k] = False
            lab = guide[i, j]
            for m in range(8):
                di = (-1, 1, 0, 0, -1, -1, 1, 1)[m]
                dj = (0, 0, -1, 1, -1, 1, -1, 1)[m]
                a = i + di
                b = j + dj
                if a < 0 or a >= Ht or b < 0 or b >= Wt or not ok[a, b] or guide[a, b] != lab:
                    continue
                y = coords[a, b, 0] - di
                x = coords[a, b, 1] - dj
                if 0 <= y < Hs and 0 <= x < Ws and srclab[y, x] == lab:
                    ny[k] = y
                    nx[k] = x
                    got[k] = True
                    break
        m = 0
        for k in range(n):
            if got[k]:
                coords[ii[k], jj[k], 0] = ny[k]
                coords[ii[k], jj[k], 1] = nx[k]
                ok[ii[k], jj[k]] = True
            else:
                ii[m] = ii[k]
                jj[m] = jj[k]
                m += 1
        if m == n:
            break
        extended += n - m
        n = m
    return extended


def repair_labels(coords: np.ndarray, guide: np.ndarray, srclab: np.ndarray, *, max_steps: int = 64,
                  nearest: bool = True, sites_of=None) -> tuple[np.ndarray, dict]:
    """Move pixels whose source label differs from the guide's onto the right label.

    Parameters
    ----------
    coords : (M, N, 2) int row/column into ``srclab``.
    guide : (M, N) int labels wanted; srclab : (Hs, Ws) int labels of the source grid.
    max_steps : front-growth steps before the nearest-source-pixel fallback.
    sites_of : callable, optional
        ``sites_of(label)``: ``distance.nearest_site(srclab == label)`` (a caller may
        keep them between calls on one ``srclab``); computed here by default.

    Returns the repaired map and counts {"wrong", "extended", "nearest", "left"}.
    """
    coords = np.ascontiguousarray(coords, np.int32).copy()
    guide = np.ascontiguousarray(guide, np.int32)
    srclab = np.ascontiguousarray(srclab, np.int32)
    ok = np.empty(guide.shape, np.bool_)
    wrong = int(_label_ok(coords, guide, srclab, ok))
    ii, jj = np.nonzero(~ok)
    ii, jj = ii.astype(np.int64), jj.astype(np.int64)
    extended = int(_front_steps(coords, ok, guide, srclab, ii.copy(), jj.copy(), int(max_steps)))
    near = 0
    if nearest and extended < wrong:
        left = ~ok[ii, jj]  # the wrong pixels the fronts did not reach, in scan order
        ii, jj = ii[left], jj[left]
        g = guide[ii, jj]
        for lab in np.unique(g):
            if sites_of is None:
                sites = srclab == lab
                ft = nearest_site(sites) if sites.any() else None
            else:
                ft = sites_of(int(lab))
            if ft is None:
                continue
            m = g == lab
            a, b = ii[m], jj[m]
            y = np.clip(coords[a, b, 0], 0, srclab.shape[0] - 1)
            x = np.clip(coords[a, b, 1], 0, srclab.shape[1] - 1)
            coords[a, b] = ft[y, x]
            ok[a, b] = True
            near += int(m.sum())
    return coords, {"wrong": wrong, "extended": extended, "nearest": near, "left": wrong - extended - near}
