"""Patch growth by flood fill (Bonneel et al. 2010, §5, step 1).

Uncovered guide pixels are taken in a random order (the seed decides). For each, its
closest exemplar pixel A of the same label is found exhaustively under

    d(pA, pB) = ||N_DA(pA) − N_DB(pB)||_2 + w C(pA, pB)                     (eq. 1)

(N the 5×5 neighbourhood of contour distances D, C the symmetric Chamfer distance of the
label windows, w = 90). The best match seeds a flood fill that walks the guide B and the
exemplar A together (one translation) and stops at covered pixels, at the exemplar's
border, at exemplar pixels of another label than the guide's, and where d exceeds
``threshold_scale · best + threshold_offset`` (the paper: 25 % more than the closest
distance, + 5). This repeats until every pixel is covered; each fill is one patch.

With ``mask`` only masked pixels are (re)covered; the others keep their coordinates and
patch ids (used to resynthesize flagged pixels of a later frame).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from proxyshade.kernels._config import JIT
from proxyshade.kernels.random import permutation
from proxyshade.kernels.features import NB2, chamfer_masks, dist_sq_D, gather_target


@njit(**JIT)
def _eq1(src_dist, src_masks, y, x, tD, tmask, w, bound):
    """eq. 1 for exemplar (y, x) against target features; early exit above ``bound``."""
    dsq = dist_sq_D(src_dist, 1, y, x, tD, bound * bound)
    dd = np.sqrt(dsq)
    if dd > bound:
        return dd
    return dd + w * chamfer_masks(src_masks[y, x], tmask)


@njit(**JIT)
def _mask_hash(m):
    """64-bit hash of a window's label masks (FNV-1a over the words)."""
    h = np.uint64(14695981039346656037)
    for l in range(m.shape[0]):
        h = (h ^ np.uint64(m[l])) * np.uint64(1099511628211)
    return h


@njit(**JIT)
def _best_match(cands, src_dist, src_masks, tD, tmask, w, bound, c0, same_window):
    """Argmin of eq. 1 over ``cands`` (ascending flat exemplar indices), ties to the
    lowest index, from ``bound``, eq. 1 at candidate ``c0`` (inf and −1 when none is
    known): candidates stop after the first row of the 5×5 window that exceeds the best.
    With ``same_window`` only the candidates whose label masks equal the target's are
    taken (the others are hash collisions of ``_window_groups``)."""
    W = src_dist.shape[1]
    n = tmask.shape[0]
    bd = bound
    bi = c0
    for t in range(cands.shape[0]):
        c = cands[t]
        if bd == 0.0 and c > bi:  # only a tie could win, and ties go to the lowest index
            break
        y = c // W
        x = c % W
        if same_window:
            same = True
            for l in range(n):
                if src_masks[y, x, l] != tmask[l]:
                    same = False
                    break
            if not same:
                continue
        d = _eq1(src_dist, src_masks, y, x, tD, tmask, w, bd)
        if d < bd or (d == bd and c < bi):
            bd = d
            bi = c
    return bi, bd


@njit(**JIT)
def _continued_bound(src_lab, src_dist, src_masks, tgt_lab, free, S, i, j, tD, tmask, w):
    """eq. 1 of the best continuation at target (i, j) of a covered 4-neighbour's
    translation that lands on an exemplar pixel of (i, j)'s label (the lowest index
    among equals), as (distance, flat index); (inf, −1) when there is none."""
    Ht, Wt = tgt_lab.shape
    He, We = src_lab.shape
    bd = np.inf
    bc = -1
    for k in range(4):
        ii = i + (k == 1) - (k == 0)
        jj = j + (k == 3) - (k == 2)
        if ii < 0 or ii >= Ht or jj < 0 or jj >= Wt or free[ii, jj]:
            continue
        y = S[ii, jj, 0] + i - ii
        x = S[ii, jj, 1] + j - jj
        if y < 0 or y >= He or x < 0 or x >= We or src_lab[y, x] != tgt_lab[i, j]:
            continue
        c = y * We + x
        d = _eq1(src_dist, src_masks, y, x, tD, tmask, w, np.inf)
        if d < bd or (d == bd and c < bc):
            bd = d
            bc = c
    return bd, bc


@njit(**JIT)
def _grow(src_lab, src_dist, src_masks, tgt_lab, tgt_dist, tgt_masks, free, S, patch, pid, i0, j0, oy, ox,
          thr, w, queue, stamp):
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
            d = _eq1(src_dist, src_masks, y, x, tD, tgt_masks[i, j], w, thr)
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
def _window_groups(src_masks, starts, lists):
    """Each label's candidates ordered by the hash of their label masks (``_mask_hash``;
    by index among equal hashes), windows alike side by side: (flat indices, hashes,
    the end of each position's run of equal hashes, whether the run's masks are all
    equal (no hash collision))."""
    We = src_masks.shape[1]
    n = src_masks.shape[2]
    grouped = lists.copy()
    hashes = np.empty(lists.shape[0], np.uint64)
    for l in range(starts.shape[0] - 1):
        a, b = starts[l], starts[l + 1]
        h = np.empty(b - a, np.uint64)
        for t in range(b - a):
            c = lists[a + t]
            h[t] = _mask_hash(src_masks[c // We, c % We])
        o = np.argsort(h, kind="mergesort")
        for t in range(b - a):
            grouped[a + t] = lists[a + o[t]]
            hashes[a + t] = h[o[t]]
    end = np.empty(lists.shape[0], np.int64)
    uniform = np.ones(lists.shape[0], np.bool_)
    for l in range(starts.shape[0] - 1):
        r = starts[l]
        while r < starts[l + 1]:
            e = r + 1
            while e < starts[l + 1] and hashes[e] == hashes[r]:
                e += 1
            c0 = grouped[r]
            for t in range(r + 1, e):
                c = grouped[t]
                for k in range(n):
                    if src_masks[c // We, c % We, k] != src_masks[c0 // We, c0 % We, k]:
                        uniform[r] = False
            end[r] = e
            r = e
    return grouped, hashes, end, uniform


@njit(**JIT)
def _best_by_window(grouped, end, uniform, a, b, src_dist, src_masks, tD, tmask, w, bound, c0):
    """``_best_match`` over every candidate grouped[a:b], a run of alike windows at a
    time: the run's Chamfer term is computed once, and a run whose term alone exceeds
    the best is skipped whole (eq. 1 is at least its Chamfer term). The same answer as
    the candidate-by-candidate scan."""
    W = src_dist.shape[1]
    bd = bound
    bi = c0
    r = a
    while r < b:
        e = end[r]
        if not uniform[r]:  # a hash collision: candidate by candidate
            c, d = _best_match(grouped[r:e], src_dist, src_masks, tD, tmask, w, bd, bi, False)
            bd, bi = d, c
            r = e
            continue
        c = grouped[r]
        wc = w * chamfer_masks(src_masks[c // W, c % W], tmask)
        if wc <= bd:
            # eq. 1 = dd + wc <= bd needs dd <= bd − wc: the D sums stop past that (with a
            # margin far above rounding, so no tie is lost)
            lim = (bd - wc) * (1.0 + 1e-9) + 1e-9
            for t in range(r, e):
                c = grouped[t]
                if bd == 0.0 and c > bi:
                    break
                dsq = dist_sq_D(src_dist, 1, c // W, c % W, tD, lim * lim)
                dd = np.sqrt(dsq)
                if dd > lim:
                    continue
                d = dd + wc
                if d < bd or (d == bd and c < bi):
                    bd = d
                    bi = c
                    lim = (bd - wc) * (1.0 + 1e-9) + 1e-9
        r = e
    return bi, bd


@njit(**JIT)
def _flood_fill(src_lab, src_dist, src_masks, tgt_lab, tgt_dist, tgt_masks, order, free, S, patch, first_id,
                w, thr_scale, thr_offset):
    n = src_masks.shape[2]
    starts, lists = _label_lists(src_lab, n)
    grouped, hashes, end, uniform = _window_groups(src_masks, starts, lists)
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
        b0, c0 = _continued_bound(src_lab, src_dist, src_masks, tgt_lab, free, S, i, j, tD, tgt_masks[i, j], w)
        # the candidates with the target's window of labels first (Chamfer term 0; every
        # other candidate's is at least 1, integer distances): when one is closer than
        # w, it is the exhaustive answer; otherwise every candidate is searched
        tmask = tgt_masks[i, j]
        hs = hashes[starts[l]:starts[l + 1]]
        th = _mask_hash(tmask)
        g0 = starts[l] + np.searchsorted(hs, th)
        g1 = starts[l] + np.searchsorted(hs, th, side="right")
        c, best = _best_match(grouped[g0:g1], src_dist, src_masks, tD, tmask, w, b0, c0, True)
        if best >= w:
            c, best = _best_by_window(grouped, end, uniform, starts[l], starts[l + 1], src_dist, src_masks, tD, tmask,
                                      w, best, c)
        We = src_lab.shape[1]
        oy = c // We - i
        ox = c % We - j
        _grow(src_lab, src_dist, src_masks, tgt_lab, tgt_dist, tgt_masks, free, S, patch, pid, i, j, oy, ox,
              thr_scale * best + thr_offset, w, queue, stamp)
        pid += 1
        npatch += 1
    return npatch


def flood_fill(src_lab: np.ndarray, src_dist: np.ndarray, src_masks: np.ndarray, tgt_lab: np.ndarray,
               tgt_dist: np.ndarray, tgt_masks: np.ndarray, *, seed: int, w: float,
               threshold_scale: float, threshold_offset: float, mask: np.ndarray | None = None,
               S: np.ndarray | None = None, patch: np.ndarray | None = None):
    """Cover the guide with patches of the exemplar.

    Parameters
    ----------
    src_lab, src_dist, src_masks : exemplar dense labels (He, We), contour distances and
        Chamfer window masks (He, We, n) at the synthesis resolution.
    tgt_lab, tgt_dist, tgt_masks : the same for the guide (Ht, Wt).
    seed : int
        Order in which uncovered pixels seed patches.
    w, threshold_scale, threshold_offset : float
        Chamfer weight of eq. 1 and the flood-fill stopping rule.
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
    r = _flood_fill(np.ascontiguousarray(src_lab, np.int32), np.ascontiguousarray(src_dist, np.float32),
                    np.ascontiguousarray(src_masks), np.ascontiguousarray(tgt_lab, np.int32),
                    np.ascontiguousarray(tgt_dist, np.float32), np.ascontiguousarray(tgt_masks), order, free, S,
                    patch, first, float(w), float(threshold_scale), float(threshold_offset))
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
