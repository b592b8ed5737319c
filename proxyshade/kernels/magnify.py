"""Synthesis magnification (Bonneel et al. 2010, §5 step 3) and label repair.

Magnification upsamples the patches, not the pixels: output pixel f p + δ (δ in
[0, f)²) takes exemplar position S[p] scaled by f plus δ, so every patch keeps its
translation and the output reads the source at full detail. No correction pass runs.

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
def _magnify(S, f, Ho, Wo, out):
    Ht, Wt = S.shape[0], S.shape[1]
    for i in prange(Ho):
        I = min(i // f, Ht - 1)
        di = i - f * I
        for j in range(Wo):
            J = min(j // f, Wt - 1)
            dj = j - f * J
            out[i, j, 0] = f * S[I, J, 0] + di
            out[i, j, 1] = f * S[I, J, 1] + dj


def magnify(S: np.ndarray, f: int, shape: tuple[int, int]) -> np.ndarray:
    """(Ho, Wo, 2) int32: S (Ht, Wt, 2) magnified by the integer factor f (exemplar
    coordinates scaled by f plus the sub-pixel offset), cropped to ``shape``."""
    out = np.empty(tuple(shape) + (2,), np.int32)
    _magnify(np.ascontiguousarray(S, np.int32), int(f), shape[0], shape[1], out)
    return out


@njit(**PJIT)
def _label_ok(S, guide, srclab, ok):
    Ht, Wt = guide.shape
    Hs, Ws = srclab.shape
    bad = 0
    rows = np.zeros(Ht, np.int64)
    for i in prange(Ht):
        for j in range(Wt):
            y = S[i, j, 0]
            x = S[i, j, 1]
            good = 0 <= y < Hs and 0 <= x < Ws and srclab[y, x] == guide[i, j]
            ok[i, j] = good
            if not good:
                rows[i] += 1
    for i in range(Ht):
        bad += rows[i]
    return bad


@njit(**PJIT)
def _repair_step(S, ok, guide, srclab, S_new, ok_new):
    """One front step (reads S/ok, writes S_new/ok_new); returns how many were fixed."""
    Ht, Wt = guide.shape
    Hs, Ws = srclab.shape
    rows = np.zeros(Ht, np.int64)
    for i in prange(Ht):
        for j in range(Wt):
            S_new[i, j, 0] = S[i, j, 0]
            S_new[i, j, 1] = S[i, j, 1]
            ok_new[i, j] = ok[i, j]
            if ok[i, j]:
                continue
            lab = guide[i, j]
            for k in range(8):
                di = (-1, 1, 0, 0, -1, -1, 1, 1)[k]
                dj = (0, 0, -1, 1, -1, 1, -1, 1)[k]
                ii = i + di
                jj = j + dj
                if ii < 0 or ii >= Ht or jj < 0 or jj >= Wt or not ok[ii, jj] or guide[ii, jj] != lab:
                    continue
                y = S[ii, jj, 0] - di
                x = S[ii, jj, 1] - dj
                if 0 <= y < Hs and 0 <= x < Ws and srclab[y, x] == lab:
                    S_new[i, j, 0] = y
                    S_new[i, j, 1] = x
                    ok_new[i, j] = True
                    rows[i] += 1
                    break
    n = 0
    for i in range(Ht):
        n += rows[i]
    return n


def repair_labels(S: np.ndarray, guide: np.ndarray, srclab: np.ndarray, *, max_steps: int = 64,
                  nearest: bool = True) -> tuple[np.ndarray, dict]:
    """Move pixels whose source label differs from the guide's onto the right label.

    Parameters
    ----------
    S : (M, N, 2) int row/column into ``srclab``.
    guide : (M, N) int labels wanted; srclab : (Hs, Ws) int labels of the source grid.
    max_steps : front-growth steps before the nearest-source-pixel fallback.

    Returns the repaired map and counts {"wrong", "extended", "nearest", "left"}.
    """
    S = np.ascontiguousarray(S, np.int32).copy()
    guide = np.ascontiguousarray(guide, np.int32)
    srclab = np.ascontiguousarray(srclab, np.int32)
    ok = np.empty(guide.shape, np.bool_)
    wrong = int(_label_ok(S, guide, srclab, ok))
    extended = 0
    S2 = np.empty_like(S)
    ok2 = np.empty_like(ok)
    for _ in range(max_steps):
        if extended == wrong:
            break
        n = int(_repair_step(S, ok, guide, srclab, S2, ok2))
        S, S2 = S2, S
        ok, ok2 = ok2, ok
        if n == 0:
            break
        extended += n
    near = 0
    if nearest and extended < wrong:
        for lab in np.unique(guide[~ok]):
            sel = ~ok & (guide == lab)
            sites = srclab == lab
            if not sites.any():
                continue
            ft = nearest_site(sites)
            y = np.clip(S[sel][:, 0], 0, srclab.shape[0] - 1)
            x = np.clip(S[sel][:, 1], 0, srclab.shape[1] - 1)
            S[sel] = ft[y, x]
            ok[sel] = True
            near += int(sel.sum())
    return S, {"wrong": wrong, "extended": extended, "nearest": near, "left": wrong - extended - near}
