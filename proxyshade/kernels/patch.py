"""Patch growth by flood fill (Bonneel et al. 2010, §5, step 1).

Uncovered guide pixels are taken in a random order (the seed decides). For each, its
closest exemplar pixel A of the same label is found exhaustively under

    d(pA, pB) = ||N_DA(pA) − N_DB(pB)||_2 + w C(pA, pB)                     (eq. 1)

(N the 5×5 neighbourhood of contour distances D, C the symmetric Chamfer distance of the
label windows, w = 90), the norm taken with one more term, ``height_weight`` times the
difference of the two pixels' relative heights in their labels' vertical runs
(``features.label_heights``; 0 = the paper's eq. 1). The exhaustive search scans the
candidates from a random start (the seed and the pixel decide) and ties go to the first
met: the interior of a large region, where every candidate is at distance 0 under the
clamped contour distances, is drawn from anywhere in the source region, not always from
its first pixel in scan order (which pasted one source patch dozens of times and gave
the whole region that patch's colour). The best match seeds a flood fill that walks the guide B and the
exemplar A together (one translation) and stops at covered pixels, at the exemplar's
border, at exemplar pixels of another label than the guide's, and where d exceeds
``threshold_scale · best + threshold_offset`` (the paper: 25 % more than the closest
distance, + 5). This repeats until every pixel is covered; each fill is one patch.

With ``mask`` only masked pixels are (re)covered; the others keep their coordinates and
patch ids (used to resynthesize flagged pixels of a later frame).
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import JIT, PJIT
from proxyshade.kernels.random import permutation, rand
from proxyshade.kernels.features import NB2, chamfer_masks, dist_sq_D, gather_target, height_sq


@njit(**JIT)
def _eq1(src_dist, src_masks, src_h, y, x, tD, tmask, th, hw, w, bound):
    """eq. 1 (+ the height term) for exemplar (y, x) against target features; early
    exit above ``bound``."""
    b2 = bound * bound
    hs = height_sq(src_h, y, x, th, hw)
    dsq = hs if hs > b2 else hs + dist_sq_D(src_dist, 1, y, x, tD, b2 - hs)
    dd = np.sqrt(dsq)
    if dd > bound:
        return dd
    return dd + w * chamfer_masks(src_masks[y, x], tmask)


@njit(**PJIT)
def _best_match(cands, src_dist, src_masks, src_h, tD, tmask, th, hw, w, start, nchunks):
    """Exhaustive argmin of eq. 1 over ``cands`` (flat exemplar indices) scanned from
    ``start`` (cyclically), in parallel chunks; ties go to the earlier candidate in that
    order whatever the thread count."""
    n = cands.shape[0]
    W = src_dist.shape[1]
    best_d = np.full(nchunks, np.inf)
    best_i = np.full(nchunks, -1, np.int64)
    step = (n + nchunks - 1) // nchunks
    for ch in prange(nchunks):
        bd = np.inf
        bi = -1
        for t in range(ch * step, min((ch + 1) * step, n)):
            c = cands[(t + start) % n]
            d = _eq1(src_dist, src_masks, src_h, c // W, c % W, tD, tmask, th, hw, w, bd)
            if d < bd:
                bd = d
                bi = c
                if bd == 0.0:  # nothing later in this chunk can win a tie
                    break
        best_d[ch] = bd
        best_i[ch] = bi
    bd = np.inf
    bi = -1
    for ch in range(nchunks):
        if best_d[ch] < bd:
            bd = best_d[ch]
            bi = best_i[ch]
    return bi, bd


@njit(**JIT)
def _grow(src_lab, src_dist, src_masks, src_h, tgt_lab, tgt_dist, tgt_masks, tgt_h, hw, free, S, patch, pid, i0,
          j0, oy, ox, thr, w, queue, stamp):
    """Flood fill from target (i0, j0) with exemplar offset (oy, ox); returns pixel count."""
    Ht, Wt = tgt_lab.shape
    He, We = src_lab.shape
    tD = np.empty(NB2, np.float32)
    head = 0
    tail = 0
    queue[tail] = i0 * Wt + j0
    tail += 1
    stamp[i0, j0] = pid
    count = 0
    while head < tail:
        p = queue[head]
        head += 1
        i = p // Wt
        j = p % Wt
        y = i + oy
        x = j + ox
        if count > 0:  # the seed is accepted by construction
            if y < 0 or y >= He or x < 0 or x >= We or src_lab[y, x] != tgt_lab[i, j]:
                continue
            gather_target(tgt_dist, i, j, tD)
            d = _eq1(src_dist, src_masks, src_h, y, x, tD, tgt_masks[i, j], tgt_h[i, j], hw, w, thr)
            if d > thr:
                continue
        free[i, j] = False
        S[i, j, 0] = y
        S[i, j, 1] = x
        patch[i, j] = pid
        count += 1
        for k in range(4):
            ii = i + (k == 1) - (k == 0)
            jj = j + (k == 3) - (k == 2)
            if ii < 0 or ii >= Ht or jj < 0 or jj >= Wt:
                continue
            if free[ii, jj] and stamp[ii, jj] != pid:
                stamp[ii, jj] = pid
                queue[tail] = ii * Wt + jj
                tail += 1
    return count


@njit(**JIT)
def _label_lists(src_lab, n):
    """Exemplar pixels grouped by label: (starts (n + 1), flat indices)."""
    He, We = src_lab.shape
    cnt = np.zeros(n + 1, np.int64)
    for y in range(He):
        for x in range(We):
            cnt[src_lab[y, x] + 1] += 1
    for l in range(n):
        cnt[l + 1] += cnt[l]
    pos = cnt[:n].copy()
    out = np.empty(He * We, np.int64)
    for y in range(He):
        for x in range(We):
            l = src_lab[y, x]
            out[pos[l]] = y * We + x
            pos[l] += 1
    return cnt, out


@njit(**JIT)
def _flood_fill(src_lab, src_dist, src_masks, src_h, tgt_lab, tgt_dist, tgt_masks, tgt_h, hw, order, free, S,
                patch, first_id, w, thr_scale, thr_offset, seed, nchunks):
    n = src_masks.shape[2]
    starts, lists = _label_lists(src_lab, n)
    Ht, Wt = tgt_lab.shape
    queue = np.empty(Ht * Wt, np.int64)
    stamp = np.zeros((Ht, Wt), np.int64)
    tD = np.empty(NB2, np.float32)
    pid = first_id
    npatch = 0
    for t in range(order.shape[0]):
        p = order[t]
        i = p // Wt
        j = p % Wt
        if not free[i, j]:
            continue
        l = tgt_lab[i, j]
        cands = lists[starts[l]:starts[l + 1]]
        if cands.shape[0] == 0:
            return -1 - l  # the exemplar lacks this label
        gather_target(tgt_dist, i, j, tD)
        start = rand(seed, p, 0x5CA7, 0) % cands.shape[0]
        c, best = _best_match(cands, src_dist, src_masks, src_h, tD, tgt_masks[i, j], tgt_h[i, j], hw, w, start,
                              nchunks)
        We = src_lab.shape[1]
        oy = c // We - i
        ox = c % We - j
        _grow(src_lab, src_dist, src_masks, src_h, tgt_lab, tgt_dist, tgt_masks, tgt_h, hw, free, S, patch, pid, i,
              j, oy, ox, thr_scale * best + thr_offset, w, queue, stamp)
        pid += 1
        npatch += 1
    return npatch


def flood_fill(src_lab: np.ndarray, src_dist: np.ndarray, src_masks: np.ndarray, tgt_lab: np.ndarray,
               tgt_dist: np.ndarray, tgt_masks: np.ndarray, *, seed: int, w: float,
               threshold_scale: float, threshold_offset: float, mask: np.ndarray | None = None,
               S: np.ndarray | None = None, patch: np.ndarray | None = None, chunks: int = 16,
               src_height: np.ndarray | None = None, tgt_height: np.ndarray | None = None,
               height_weight: float = 0.0):
    """Cover the guide with patches of the exemplar.

    Parameters
    ----------
    src_lab, src_dist, src_masks : exemplar dense labels (He, We), contour distances and
        Chamfer window masks (He, We, n) at the synthesis resolution.
    tgt_lab, tgt_dist, tgt_masks : the same for the guide (Ht, Wt).
    seed : int
        Order in which uncovered pixels seed patches, and where each search starts.
    w, threshold_scale, threshold_offset : float
        Chamfer weight of eq. 1 and the flood-fill stopping rule.
    src_height, tgt_height, height_weight : ``features.label_heights`` of the two sides
        and the weight of their difference (none or 0: no height term).
    mask : (Ht, Wt) bool, optional
        Only these pixels are covered; the others keep ``S`` and ``patch``.
    S, patch : existing state (required with ``mask``).

    Returns
    -------
    S : (Ht, Wt, 2) int32 exemplar (row, column) of each guide pixel.
    patch : (Ht, Wt) int64 patch ids (new ones start after the largest existing id).
    npatch : number of patches grown.

    Raises ValueError naming the label when a guide label has no exemplar pixel.
    """
    Ht, Wt = tgt_lab.shape
    if mask is None:
        free = np.ones((Ht, Wt), np.bool_)
        S = np.zeros((Ht, Wt, 2), np.int32)
        patch = np.zeros((Ht, Wt), np.int64)
        first = 1
    else:
        if S is None or patch is None:
            raise ValueError("flood_fill with a mask needs the existing S and patch")
        free = np.ascontiguousarray(mask, dtype=np.bool_).copy()
        S = np.ascontiguousarray(S, dtype=np.int32).copy()
        patch = np.ascontiguousarray(patch, dtype=np.int64).copy()
        first = int(patch.max()) + 1 if patch.size else 1
    order = permutation(seed, Ht * Wt)
    if src_height is None or tgt_height is None:
        src_height, tgt_height, height_weight = np.zeros(src_lab.shape, np.float32), np.zeros((Ht, Wt), np.float32), 0.0
    r = _flood_fill(np.ascontiguousarray(src_lab, np.int32), np.ascontiguousarray(src_dist, np.float32),
                    np.ascontiguousarray(src_masks), np.ascontiguousarray(src_height, np.float32),
                    np.ascontiguousarray(tgt_lab, np.int32), np.ascontiguousarray(tgt_dist, np.float32),
                    np.ascontiguousarray(tgt_masks), np.ascontiguousarray(tgt_height, np.float32),
                    float(height_weight), order, free, S, patch, first, float(w), float(threshold_scale),
                    float(threshold_offset), int(seed), int(chunks))
    if r < 0:
        raise ValueError(f"label index {-1 - r} of the guide has no pixel in the exemplar")
    return S, patch, r


@njit(**JIT)
def _offset_components(S, out):
    Ht, Wt = S.shape[0], S.shape[1]
    stack = np.empty(Ht * Wt, np.int64)
    nid = 0
    for i0 in range(Ht):
        for j0 in range(Wt):
            if out[i0, j0] != 0:
                continue
            nid += 1
            oy = S[i0, j0, 0] - i0
            ox = S[i0, j0, 1] - j0
            out[i0, j0] = nid
            stack[0] = i0 * Wt + j0
            top = 1
            while top > 0:
                top -= 1
                p = stack[top]
                i = p // Wt
                j = p % Wt
                for k in range(4):
                    ii = i + (k == 1) - (k == 0)
                    jj = j + (k == 3) - (k == 2)
                    if ii < 0 or ii >= Ht or jj < 0 or jj >= Wt or out[ii, jj] != 0:
                        continue
                    if S[ii, jj, 0] - ii == oy and S[ii, jj, 1] - jj == ox:
                        out[ii, jj] = nid
                        stack[top] = ii * Wt + jj
                        top += 1
    return nid


def offset_components(S: np.ndarray) -> tuple[np.ndarray, int]:
    """Patch ids of a coordinate map: 4-connected pixels sharing one translation
    (S[p] - p) form a patch; ids 1.. in scan order of each patch's first pixel.

    Returns ((M, N) uint32 ids, number of patches).
    """
    out = np.zeros(S.shape[:2], np.int64)
    n = _offset_components(np.ascontiguousarray(S, dtype=np.int64), out)
    return out.astype(np.uint32), int(n)
