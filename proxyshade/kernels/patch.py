"""Patch growth by flood fill (Bonneel et al. 2010, §5, step 1).

Uncovered guide pixels are taken in a random order (the seed decides). For each, its
closest exemplar pixel A of the same label is found exhaustively under

    d(pA, pB) = ||N_DA(pA) − N_DB(pB)||_2 + w C(pA, pB)                     (eq. 1)

(N the 5×5 neighbourhood of contour distances D, C the symmetric Chamfer distance of the
label windows, w = 90), the norm taken with one more term, ``height_weight`` times the
difference of the two pixels' relative heights in their labels' vertical runs
(``features.label_heights``; 0 = the paper's eq. 1). The search is exhaustive in its
answer: the closest candidate, ties going to the first met scanning the label's pixels
from a random start (the seed and the pixel decide): the interior of a large region, where every candidate is at distance 0 under the
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

from typing import NamedTuple

import numpy as np
from numba import njit

from proxyshade.kernels._config import JIT
from proxyshade.kernels.random import _keys, permutation, rand
from proxyshade.kernels.features import NB2, Level, Metric, chamfer_masks, dist_sq_contour, gather_target, height_sq

# The kernels take the finest ``features.Level`` (h = 1) whole, and ``features.Metric``.


class Probe(NamedTuple):
    """A guide pixel's side of eq. 1: its 5×5 contour distances ``dist`` (``NB2``), its
    window's label masks ``masks`` (n,) and its relative height ``height``."""

    dist: np.ndarray
    masks: np.ndarray
    height: np.float32


class Scan(NamedTuple):
    """A label's candidates in scan order from ``start`` (ties go to the first met):
    ``posof`` each exemplar pixel's position in its label's list, ``n`` the list's length."""

    posof: np.ndarray
    start: int
    n: int


class Cover(NamedTuple):
    """The map being covered: ``free`` (Ht, Wt) bool pixels still to cover, ``coords`` (Ht, Wt, 2)
    int32 exemplar (row, column), ``patch`` (Ht, Wt) int64 patch ids."""

    free: np.ndarray
    coords: np.ndarray
    patch: np.ndarray


class Groups(NamedTuple):
    """Each label's candidates ordered by the hash of their window's label masks
    (``_window_groups``): flat indices, hashes, the end of each position's run of equal
    hashes, whether the run's masks are all equal."""

    grouped: np.ndarray
    hashes: np.ndarray
    end: np.ndarray
    uniform: np.ndarray


@njit(**JIT)
def _eq1(src_dist, src_masks, src_height, y, x, target_dist, tmask, target_height, m, bound):
    """eq. 1 (+ the height term) for exemplar (y, x) against a guide pixel's 5×5 contour
    distances ``target_dist``, window label masks ``tmask`` and relative height ``target_height`` (a
    ``Probe``'s fields); early exit above ``bound``. (Arrays, not records: the hottest call
    of the flood fill, where reading a record's arrays costs their reference counts.)"""
    b2 = bound * bound
    hs = height_sq(src_height, y, x, target_height, m.height_weight)
    dsq = hs if hs > b2 else hs + dist_sq_contour(src_dist, 1, y, x, target_dist, b2 - hs)
    dd = np.sqrt(dsq)
    if dd > bound:
        return dd
    return dd + m.w * chamfer_masks(src_masks[y, x], tmask)


@njit(**JIT)
def _mask_hash(m):
    """64-bit hash of a window's label masks (FNV-1a over the words)."""
    h = np.uint64(14695981039346656037)
    for l in range(m.shape[0]):
        h = (h ^ np.uint64(m[l])) * np.uint64(1099511628211)
    return h


@njit(inline="always", **JIT)
def _same_masks(a, b):
    """Two windows' label masks (n,) are equal."""
    for l in range(a.shape[0]):
        if a[l] != b[l]:
            return False
    return True


@njit(inline="always", **JIT)
def _better(d, k, bd, bk):
    """Distance d at tie key k beats the best so far (bd, bk)."""
    return d < bd or (d == bd and k < bk)


@njit(inline="always", **JIT)
def _tie_key(c, scan):
    """Where candidate c comes in its label's ``scan`` (ties go to the first)."""
    k = scan.posof[c] - scan.start
    return k + scan.n if k < 0 else k


@njit(**JIT)
def _best_match(cands, lv, m, probe, bound, c0, scan, same_window):
    """Argmin of eq. 1 over ``cands`` (flat exemplar indices of one label), ties to the
    first in the label's ``scan`` (``_tie_key``), from ``bound``, eq. 1 at candidate
    ``c0`` (inf and −1 when none is known): candidates stop after the first row of the
    5×5 window that exceeds the best. With ``same_window`` only the candidates whose
    label masks equal the target's are taken (the others are hash collisions of
    ``_window_groups``)."""
    src_dist, src_masks, src_h = lv.src_dist, lv.src_masks, lv.src_height
    target_dist, tmask, target_height = probe
    W = src_dist.shape[1]
    bd = bound
    bi = c0
    bk = _tie_key(c0, scan) if c0 >= 0 else scan.n
    for t in range(cands.shape[0]):
        c = cands[t]
        k = _tie_key(c, scan)
        if bd == 0.0 and k > bk:  # only a tie could win, and this one comes later
            continue
        y = c // W
        x = c % W
        if same_window and not _same_masks(src_masks[y, x], tmask):
            continue
        d = _eq1(src_dist, src_masks, src_h, y, x, target_dist, tmask, target_height, m, bd)
        if _better(d, k, bd, bk):
            bd = d
            bi = c
            bk = k
    return bi, bd


@njit(**JIT)
def _continued_bound(lv, m, cover, i, j, probe, scan):
    """eq. 1 of the best continuation at target (i, j) (its ``probe``) of a covered
    4-neighbour's translation that lands on an exemplar pixel of (i, j)'s label (the first
    in the ``scan`` order among equals), as (distance, flat index); (inf, −1) when there
    is none."""
    src_lab, tgt_lab, free, coords = lv.src_lab, lv.tgt_lab, cover.free, cover.coords
    Ht, Wt = tgt_lab.shape
    He, We = src_lab.shape
    bd = np.inf
    bc = -1
    bk = scan.n
    for k in range(4):
        ii = i + (k == 1) - (k == 0)
        jj = j + (k == 3) - (k == 2)
        if ii < 0 or ii >= Ht or jj < 0 or jj >= Wt or free[ii, jj]:
            continue
        y = coords[ii, jj, 0] + i - ii
        x = coords[ii, jj, 1] + j - jj
        if y < 0 or y >= He or x < 0 or x >= We or src_lab[y, x] != tgt_lab[i, j]:
            continue
        c = y * We + x
        key = _tie_key(c, scan)
        d = _eq1(lv.src_dist, lv.src_masks, lv.src_height, y, x, probe.dist, probe.masks, probe.height, m, np.inf)
        if _better(d, key, bd, bk):
            bd = d
            bc = c
            bk = key
    return bd, bc


@njit(**JIT)
def _grow(lv, m, cover, pid, i0, j0, oy, ox, thr, queue, stamp):
    """Flood fill from target (i0, j0) with exemplar offset (oy, ox), stopping above eq. 1
    ``thr``; returns pixel count. ``queue``, ``stamp``: the caller's scratch buffers."""
    src_lab, src_dist, src_masks, src_h = lv.src_lab, lv.src_dist, lv.src_masks, lv.src_height
    tgt_lab, tgt_dist, tgt_masks, tgt_h = lv.tgt_lab, lv.tgt_dist, lv.tgt_masks, lv.tgt_height
    free, coords, patch = cover
    Ht, Wt = tgt_lab.shape
    He, We = src_lab.shape
    target_dist = np.empty(NB2, np.float32)
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
            gather_target(tgt_dist, i, j, target_dist)
            d = _eq1(src_dist, src_masks, src_h, y, x, target_dist, tgt_masks[i, j], tgt_h[i, j], m, thr)
            if d > thr:
                continue
        free[i, j] = False
        coords[i, j, 0] = y
        coords[i, j, 1] = x
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
def _mask_hashes(src_masks, lists):
    """``_mask_hash`` of the window of each exemplar pixel of ``lists`` (flat indices)."""
    We = src_masks.shape[1]
    out = np.empty(lists.shape[0], np.uint64)
    for t in range(lists.shape[0]):
        c = lists[t]
        out[t] = _mask_hash(src_masks[c // We, c % We])
    return out


@njit(**JIT)
def _runs(src_masks, starts, grouped, hashes):
    """The end of each position's run of equal ``hashes`` within its label, and whether
    the run's masks are all equal (no hash collision)."""
    We = src_masks.shape[1]
    end = np.empty(grouped.shape[0], np.int64)
    uniform = np.ones(grouped.shape[0], np.bool_)
    for l in range(starts.shape[0] - 1):
        r = starts[l]
        while r < starts[l + 1]:
            e = r + 1
            while e < starts[l + 1] and hashes[e] == hashes[r]:
                e += 1
            c0 = grouped[r]
            for t in range(r + 1, e):
                c = grouped[t]
                if not _same_masks(src_masks[c // We, c % We], src_masks[c0 // We, c0 % We]):
                    uniform[r] = False
            end[r] = e
            r = e
    return end, uniform


def _window_groups(src_masks, starts, lists):
    """Each label's candidates ordered by the hash of their label masks (``_mask_hash``;
    by index among equal hashes: a stable sort, numpy's, which numba compiles in 1 s),
    windows alike side by side: ``Groups`` (flat indices, hashes, the end of each
    position's run of equal hashes, whether the run's masks are all equal (no hash
    collision))."""
    h = _mask_hashes(src_masks, lists)
    grouped, hashes = lists.copy(), h.copy()
    for l in range(starts.shape[0] - 1):
        a, b = starts[l], starts[l + 1]
        o = np.argsort(h[a:b], kind="stable")
        grouped[a:b] = lists[a:b][o]
        hashes[a:b] = h[a:b][o]
    return Groups(grouped, hashes, *_runs(src_masks, starts, grouped, hashes))


@njit(**JIT)
def _best_by_window(groups, a, b, lv, m, probe, bound, c0, scan):
    """``_best_match`` over every candidate ``groups.grouped[a:b]``, a run of alike windows
    at a time: the run's Chamfer term is computed once, and a run whose term alone exceeds
    the best is skipped whole (eq. 1 is at least its Chamfer term). The same answer as
    the candidate-by-candidate scan."""
    grouped, end, uniform = groups.grouped, groups.end, groups.uniform
    src_dist, src_masks, src_h = lv.src_dist, lv.src_masks, lv.src_height
    target_dist, target_height, height_weight = probe.dist, probe.height, m.height_weight
    W = src_dist.shape[1]
    bd = bound
    bi = c0
    bk = _tie_key(c0, scan) if c0 >= 0 else scan.n
    r = a
    while r < b:
        e = end[r]
        if not uniform[r]:  # a hash collision: candidate by candidate
            bi, bd = _best_match(grouped[r:e], lv, m, probe, bd, bi, scan, np.bool_(False))  # not literal: one signature
            bk = _tie_key(bi, scan) if bi >= 0 else scan.n
            r = e
            continue
        c = grouped[r]
        wc = m.w * chamfer_masks(src_masks[c // W, c % W], probe.masks)
        if wc <= bd:
            # eq. 1 = sqrt(height² + D sum) + wc <= bd needs the root <= bd − wc: the sums
            # stop past that (with a margin far above rounding, so no tie is lost)
            lim = (bd - wc) * (1.0 + 1e-9) + 1e-9
            for t in range(r, e):
                c = grouped[t]
                k = _tie_key(c, scan)
                if bd == 0.0 and k > bk:
                    continue
                y = c // W
                x = c % W
                l2 = lim * lim
                dsq = height_sq(src_h, y, x, target_height, height_weight)
                if dsq <= l2:
                    dsq += dist_sq_contour(src_dist, 1, y, x, target_dist, l2 - dsq)
                dd = np.sqrt(dsq)
                if dd > lim:
                    continue
                d = dd + wc
                if _better(d, k, bd, bk):
                    bd = d
                    bi = c
                    bk = k
                    lim = (bd - wc) * (1.0 + 1e-9) + 1e-9
        r = e
    return bi, bd


@njit(**JIT)
def _positions(starts, lists, size):
    """Each exemplar pixel's position in its label's list (``_label_lists``)."""
    posof = np.zeros(size, np.int64)
    for l in range(starts.shape[0] - 1):
        for t in range(starts[l], starts[l + 1]):
            posof[lists[t]] = t - starts[l]
    return posof


@njit(inline="always", **JIT)
def _bisect(a, v, right):
    """``np.searchsorted(a, v, side="right" if right else "left")`` (inlined: numpy's compiles
    slower)."""
    lo = 0
    hi = a.shape[0]
    while lo < hi:
        mid = (lo + hi) // 2
        if a[mid] < v or (right and a[mid] == v):
            lo = mid + 1
        else:
            hi = mid
    return lo


@njit(**JIT)
def _flood_fill(lv, m, cover, order, first_id, thr_scale, thr_offset, seed, starts, groups, posof):
    """Patches grown from the free pixels of ``cover`` taken in ``order``, ids from
    ``first_id``; returns their count. ``starts``: the label lists' (``_label_lists``),
    ``groups``: ``_window_groups``, ``posof``: ``_positions``."""
    src_lab, tgt_lab, free = lv.src_lab, lv.tgt_lab, cover.free
    Ht, Wt = tgt_lab.shape
    queue = np.empty(Ht * Wt, np.int64)
    stamp = np.zeros((Ht, Wt), np.int64)
    target_dist = np.empty(NB2, np.float32)
    pid = first_id
    npatch = 0
    for t in range(order.shape[0]):
        p = order[t]
        i = p // Wt
        j = p % Wt
        if not free[i, j]:
            continue
        l = tgt_lab[i, j]
        nl = starts[l + 1] - starts[l]
        gather_target(lv.tgt_dist, i, j, target_dist)
        scan = Scan(posof, rand(seed, p, 0x5CA7, 0) % nl, nl)
        probe = Probe(target_dist, lv.tgt_masks[i, j], lv.tgt_height[i, j])
        b0, c0 = _continued_bound(lv, m, cover, i, j, probe, scan)
        # the candidates with the target's window of labels first (Chamfer term 0; every
        # other's at least 1, integer distances): when one is closer than w, it is the
        # exhaustive answer; otherwise every candidate is searched
        hs = groups.hashes[starts[l]:starts[l + 1]]
        tk = _mask_hash(probe.masks)
        g0 = starts[l] + _bisect(hs, tk, False)
        g1 = starts[l] + _bisect(hs, tk, True)
        c, best = _best_match(groups.grouped[g0:g1], lv, m, probe, b0, c0, scan, np.bool_(True))
        if best >= m.w:
            c, best = _best_by_window(groups, starts[l], starts[l + 1], lv, m, probe, best, c, scan)
        We = src_lab.shape[1]
        oy = c // We - i
        ox = c % We - j
        _grow(lv, m, cover, pid, i, j, oy, ox, thr=thr_scale * best + thr_offset, queue=queue, stamp=stamp)
        pid += 1
        npatch += 1
    return npatch


def masked_order(seed: int, free: np.ndarray) -> np.ndarray:
    """``permutation(seed, free.size)`` with only the ``free`` pixels' flat indices, in the
    same relative order (their ``rand`` keys sorted stably: ties by index, as the whole
    permutation breaks them). ``_flood_fill`` skips every pixel not free when it is reached
    and never frees one, so this order grows the same patches; a masked flood fill of a
    few percent of a 256² level sorts those pixels instead of the whole level's (7 ms)."""
    idx = np.flatnonzero(free)
    return idx[np.argsort(_keys(int(seed), int(free.size))[idx], kind="stable")].astype(np.int64)


def flood_fill(level: Level, metric: Metric, *, seed: int, threshold_scale: float, threshold_offset: float,
               mask: np.ndarray | None = None, coords: np.ndarray | None = None, patch: np.ndarray | None = None):
    """Cover the guide with patches of the exemplar.

    Parameters
    ----------
    level : the finest ``features.Level`` (h = 1): exemplar and guide dense labels,
        contour distances, Chamfer window masks and relative heights (its colour is not read).
    metric : ``features.Metric``, the weights of eq. 1 (Chamfer, relative height).
    seed : int
        Order in which uncovered pixels seed patches, and where each search starts.
    threshold_scale, threshold_offset : float
        The flood-fill stopping rule.
    mask : (Ht, Wt) bool, optional
        Only these pixels are covered; the others keep ``coords`` and ``patch``.
    coords, patch : existing state (required with ``mask``).

    Returns
    -------
    coords : (Ht, Wt, 2) int32 exemplar (row, column) (the paper's S) of each guide pixel.
    patch : (Ht, Wt) int64 patch ids (new ones start after the largest existing id).
    npatch : number of patches grown.

    Every label of the guide has exemplar pixels (``synthesis.exemplar.synthesis_setup`` checks it).
    """
    Ht, Wt = level.tgt_lab.shape
    if mask is None:
        free = np.ones((Ht, Wt), np.bool_)
        coords = np.zeros((Ht, Wt, 2), np.int32)
        patch = np.zeros((Ht, Wt), np.int64)
        first = 1
    else:
        if coords is None or patch is None:
            raise ValueError("flood_fill with a mask needs the existing coords and patch")
        free = np.ascontiguousarray(mask, dtype=np.bool_).copy()
        coords = np.ascontiguousarray(coords, dtype=np.int32).copy()
        patch = np.ascontiguousarray(patch, dtype=np.int64).copy()
        first = int(patch.max()) + 1 if patch.size else 1
    order = permutation(seed, Ht * Wt) if mask is None else masked_order(seed, free)
    starts, lists = _label_lists(level.src_lab, level.src_masks.shape[2])
    r = _flood_fill(level, Metric(float(metric.w), float(metric.height_weight)), Cover(free, coords, patch), order,
                    first_id=first, thr_scale=float(threshold_scale), thr_offset=float(threshold_offset),
                    seed=int(seed), starts=starts, groups=_window_groups(level.src_masks, starts, lists),
                    posof=_positions(starts, lists, lists.shape[0]))
    return coords, patch, r


@njit(**JIT)
def _offset_components(coords, out):
    Ht, Wt = coords.shape[0], coords.shape[1]
    stack = np.empty(Ht * Wt, np.int64)
    nid = 0
    for i0 in range(Ht):
        for j0 in range(Wt):
            if out[i0, j0] != 0:
                continue
            nid += 1
            oy = coords[i0, j0, 0] - i0
            ox = coords[i0, j0, 1] - j0
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
                    if coords[ii, jj, 0] - ii == oy and coords[ii, jj, 1] - jj == ox:
                        out[ii, jj] = nid
                        stack[top] = ii * Wt + jj
                        top += 1
    return nid


def offset_components(coords: np.ndarray) -> tuple[np.ndarray, int]:
    """Patch ids of a coordinate map: 4-connected pixels sharing one translation
    (coords[p] - p) form a patch; ids 1.. in scan order of each patch's first pixel.

    Returns ((M, N) uint32 ids, number of patches).
    """
    out = np.zeros(coords.shape[:2], np.int64)
    n = _offset_components(np.ascontiguousarray(coords, dtype=np.int64), out)
    return out.astype(np.uint32), int(n)
