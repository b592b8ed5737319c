"""Patch seams moved to where the two sources agree, at the output resolution.

Magnify turns each synthesis pixel into ``factor``×``factor`` output pixels, so the seams
between patches run on a ``factor``-pixel staircase wherever the synthesis put them. This
moves them, one output pixel at a time, to where the colours of the patches on either side
agree: the seam cost of Kwatra et al. 2003 ("Graphcut Textures", §3: for neighbours ``p``,
``q`` read from offsets ``a`` and ``b``, ``‖A(p) − B(p)‖² + ‖A(q) − B(q)‖²``, 0 when
``a = b``), lowered by iterated conditional modes instead of a graph cut: each pixel next to
a seam takes, among its own offset and its four neighbours', the one with the least summed
seam cost to its neighbours, as long as the source pixel it then reads has the pixel's
label. Checkerboard sub-passes (a pixel's neighbours are all of the other parity), so the
result does not depend on the number of threads. A straight seam across many rows is a
local minimum of those one-pixel moves; run moves (``_run_pass``) shift the best part of
each run of pixels along a seam at once. Pixels of different target labels are not
neighbours here (a label border is not a patch seam).

``S``: (H, W, 2) int32 map (row, column) into a source grid; ``img``: (Hs, Ws, C) float32
colours of that grid; ``target``: (H, W) int32 labels the output needs; ``labels``: (Hs, Ws)
int32 labels of the grid.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import JIT, PJIT

OUTSIDE = 4.0  # cost of reading a source pixel off the grid (per term; colours are ~[0, 1])

_DY = (-1, 0, 0, 1)
_DX = (0, -1, 1, 0)


@njit(**JIT)
def _dist2(img, ay, ax, by, bx):
    """‖img[a] − img[b]‖², OUTSIDE when either lies off the grid."""
    Hs, Ws, C = img.shape
    if ay < 0 or ax < 0 or by < 0 or bx < 0 or ay >= Hs or ax >= Ws or by >= Hs or bx >= Ws:
        return OUTSIDE
    d = 0.0
    for c in range(C):
        t = img[ay, ax, c] - img[by, bx, c]
        d += t * t
    return d


@njit(**JIT)
def _pair_cost(S, img, target, i, j, oy, ox, k):
    """The seam cost between pixel (i, j) read at offset (oy, ox) and its neighbour ``k``
    (``_DY``/``_DX``) read at its own offset: 0 off the image, across a label border or
    when both read at one offset."""
    H, W = target.shape
    y, x = i + _DY[k], j + _DX[k]
    if y < 0 or x < 0 or y >= H or x >= W or target[y, x] != target[i, j]:
        return 0.0
    qy, qx = S[y, x, 0] - y, S[y, x, 1] - x
    if qy == oy and qx == ox:
        return 0.0
    return _dist2(img, i + oy, j + ox, i + qy, j + qx) + _dist2(img, y + oy, x + ox, y + qy, x + qx)


@njit(**JIT)
def _energy(S, img, target, i, j, oy, ox):
    """Summed seam cost between pixel (i, j) read at offset (oy, ox) and its same-label
    neighbours read at their own offsets."""
    e = 0.0
    for k in range(4):
        e += _pair_cost(S, img, target, i, j, oy, ox, k)
    return e


@njit(**PJIT)
def _sub_pass(S, img, target, labels, parity):
    """One checkerboard half: every pixel of ``parity`` takes its best offset; the number
    of pixels that changed."""
    H, W = target.shape
    Hs, Ws = labels.shape
    changed = np.zeros(H, np.int64)
    for i in prange(H):
        for j in range((i + parity) % 2, W, 2):
            oy, ox = S[i, j, 0] - i, S[i, j, 1] - j
            seam = False
            for k in range(4):
                y, x = i + _DY[k], j + _DX[k]
                if 0 <= y < H and 0 <= x < W and target[y, x] == target[i, j] and (
                        S[y, x, 0] - y != oy or S[y, x, 1] - x != ox):
                    seam = True
                    break
            if not seam:
                continue
            best = _energy(S, img, target, i, j, oy, ox)
            by, bx = oy, ox
            for k in range(4):
                y, x = i + _DY[k], j + _DX[k]
                if y < 0 or x < 0 or y >= H or x >= W or target[y, x] != target[i, j]:
                    continue
                cy, cx = S[y, x, 0] - y, S[y, x, 1] - x
                if (cy == oy and cx == ox) or (cy == by and cx == bx):
                    continue
                sy, sx = i + cy, j + cx
                if sy < 0 or sx < 0 or sy >= Hs or sx >= Ws or labels[sy, sx] != target[i, j]:
                    continue
                e = _energy(S, img, target, i, j, cy, cx)
                if e < best:
                    best, by, bx = e, cy, cx
            if by != oy or bx != ox:
                S[i, j, 0] = i + by
                S[i, j, 1] = j + bx
                changed[i] += 1
    return changed.sum()


@njit(**JIT)
def _run_at(S, img, target, labels, i, j, k, rc, rv, lo_end, hi_end):
    """The run move of the seam run that starts at (i, j) across direction ``k`` (see
    ``_run_pass``), if (i, j) starts one; the number of pixels moved."""
    H, W = target.shape
    Hs, Ws = labels.shape
    y, x = i + _DY[k], j + _DX[k]
    if y < 0 or x < 0 or y >= H or x >= W or target[y, x] != target[i, j]:
        return 0
    ay, ax = S[i, j, 0] - i, S[i, j, 1] - j
    by, bx = S[y, x, 0] - y, S[y, x, 1] - x
    if ay == by and ax == bx:
        return 0
    ey, ex = _DX[k] * _DX[k], _DY[k] * _DY[k]  # along the seam: (0, 1) or (1, 0)
    kb = 3 - k  # the opposite direction (_DY/_DX are symmetric)
    ke = 2 if ex == 1 else 3  # direction +e
    u, v = i - ey, j - ex  # does the predecessor continue the run? then (i, j) does not start it
    if u >= 0 and v >= 0 and target[u, v] == target[i, j] and S[u, v, 0] - u == ay \
            and S[u, v, 1] - v == ax and target[u + _DY[k], v + _DX[k]] == target[i, j] \
            and S[u + _DY[k], v + _DX[k], 0] - u - _DY[k] == by \
            and S[u + _DY[k], v + _DX[k], 1] - v - _DX[k] == bx:
        return 0
    n = 0
    while True:
        u, v = i + n * ey, j + n * ex
        uy, vx = u + _DY[k], v + _DX[k]
        if u >= H or v >= W or uy < 0 or vx < 0 or uy >= H or vx >= W:
            break
        if (target[u, v] != target[i, j] or target[uy, vx] != target[i, j]
                or S[u, v, 0] - u != ay or S[u, v, 1] - v != ax
                or S[uy, vx, 0] - uy != by or S[uy, vx, 1] - vx != bx):
            break
        sy, sx = u + by, v + bx
        rv[n] = 0 <= sy < Hs and 0 <= sx < Ws and labels[sy, sx] == target[u, v]
        rc[n] = (_pair_cost(S, img, target, u, v, by, bx, k) + _pair_cost(S, img, target, u, v, by, bx, kb)
                 - _pair_cost(S, img, target, u, v, ay, ax, k) - _pair_cost(S, img, target, u, v, ay, ax, kb))
        lo_end[n] = (_pair_cost(S, img, target, u, v, by, bx, 3 - ke)
                     - _pair_cost(S, img, target, u, v, ay, ax, 3 - ke))
        hi_end[n] = _pair_cost(S, img, target, u, v, by, bx, ke) - _pair_cost(S, img, target, u, v, ay, ax, ke)
        n += 1
    # the part [l, h] of least Σ_{l..h} rc + lo_end[l] + hi_end[h] (pairs along the run
    # inside the part cost 0 before and after), of valid pixels only
    P = 0.0
    lv = np.inf
    lb = -1
    best = 0.0
    lo = -1
    hi = -1
    for t in range(n):
        if not rv[t]:
            lv = np.inf
            P += rc[t]
            continue
        val = lo_end[t] - P
        if val < lv:
            lv, lb = val, t
        P += rc[t]
        d = P + lv + hi_end[t]
        if d < best:
            best, lo, hi = d, lb, t
    if lo < 0:
        return 0
    for t in range(lo, hi + 1):
        u, v = i + t * ey, j + t * ex
        S[u, v, 0] = u + by
        S[u, v, 1] = v + bx
    return hi - lo + 1


@njit(**PJIT)
def _run_pass(S, img, target, labels, vertical, parity):
    """Run moves on the rows (``vertical`` false: seams between a row and the rows above
    and below, runs along the row) or columns of ``parity``. A run: the pixels ``r_0 ..
    r_{n-1}`` along a seam (each the next one's neighbour) that read one offset ``a``
    while their neighbours across it read another, ``b``, from the first (whose
    predecessor does not continue it) as far as it goes. Its contiguous part ``r_l ..
    r_h`` whose move to ``b`` lowers the summed seam cost most (exactly: ``Σ c_t`` over
    the part, ``c_t`` the change of ``r_t``'s pairs across the seam, plus the two end
    pairs along it; a maximum-sum sub-array) takes ``b``, where every pixel of it then
    reads a source pixel of its label. A straight seam across many rows shifts by one
    pixel, which one-pixel moves cannot do (each adds two pairs along the seam). Lines in
    order along them, directions in order (up, down; left, right); a line changes only
    itself and reads its neighbours, of the other parity: any thread count gives one
    result. Returns the number of pixels moved."""
    H, W = target.shape
    nl, L = (W, H) if vertical else (H, W)
    moved = np.zeros(nl, np.int64)
    for li in prange((nl - parity + 1) // 2):
        line = 2 * li + parity
        rc = np.empty(L, np.float64)
        rv = np.empty(L, np.bool_)
        lo_end = np.empty(L, np.float64)
        hi_end = np.empty(L, np.float64)
        for t in range(L):
            i, j = (t, line) if vertical else (line, t)
            for kk in range(2):
                k = (1 + kk) if vertical else 3 * kk
                y, x = i + _DY[k], j + _DX[k]  # most pixels are on no seam: no call
                if y < 0 or x < 0 or y >= H or x >= W or (S[y, x, 0] - y == S[i, j, 0] - i
                                                          and S[y, x, 1] - x == S[i, j, 1] - j):
                    continue
                moved[line] += _run_at(S, img, target, labels, i, j, k, rc, rv, lo_end, hi_end)
    return moved.sum()


def refine_seams(S: np.ndarray, img: np.ndarray, target: np.ndarray, labels: np.ndarray,
                 passes: int, runs: bool = False) -> tuple[np.ndarray, int]:
    """``S`` (copied) after ``passes`` passes of seam moves (each two checkerboard halves
    of one-pixel moves, then, with ``runs``, run moves on even and odd rows, then columns:
    ``_run_pass``),
    stopping early when a pass changes nothing; and the number of pixel moves made."""
    S = np.ascontiguousarray(S, np.int32).copy()
    img = np.ascontiguousarray(img, np.float32)
    target = np.ascontiguousarray(target, np.int32)
    labels = np.ascontiguousarray(labels, np.int32)
    moves = 0
    for _ in range(passes):
        n = _sub_pass(S, img, target, labels, 0) + _sub_pass(S, img, target, labels, 1)
        if runs:
            for vertical in (False, True):
                n += _run_pass(S, img, target, labels, vertical, 0) + _run_pass(S, img, target, labels, vertical, 1)
        moves += int(n)
        if n == 0:
            break
    return S, moves


def seam_cost(S: np.ndarray, img: np.ndarray, target: np.ndarray) -> float:
    """The total seam cost of a map (each neighbouring pair of one target label counted once)."""
    return float(_seam_cost(np.ascontiguousarray(S, np.int32), np.ascontiguousarray(img, np.float32),
                            np.ascontiguousarray(target, np.int32)))


@njit(**JIT)
def _seam_cost(S, img, target):
    H, W = target.shape
    tot = 0.0
    for i in range(H):
        for j in range(W):
            for k in range(2, 4):  # right and down: each pair once
                tot += _pair_cost(S, img, target, i, j, S[i, j, 0] - i, S[i, j, 1] - j, k)
    return tot


# ---------------------------------------------------------------------------
# whole patches shifted by a few output pixels


@njit(**JIT)
def _spread(img, target, mu, order, a, b, oy, ox, W):
    """Σ over the pixels ``order[a:b]`` read at offset (oy, ox) of (their tone − ``mu`` of
    their target label)², tone the sum of ``img``'s channels (off the grid: 0)."""
    Hs, Ws, C = img.shape
    s = 0.0
    for t in range(a, b):
        i, j = order[t] // W, order[t] % W
        if 0 <= i + oy < Hs and 0 <= j + ox < Ws:
            v = -mu[target[i, j]]
            for c in range(C):
                v += img[i + oy, j + ox, c]
            s += v * v
    return s


@njit(**JIT)
def _shift_cost(S, img, target, labels, patch, order, a, b, edge, ea, eb, pid, oy, ox, bound, check, mu, least):
    """Summed seam cost of patch ``pid`` (its pixels ``order[a:b]``, those with a neighbour
    outside it ``edge[ea:eb]``, flat indices) read at offset (oy, ox) against its same-label
    neighbours outside it, read at their own offsets; returned as soon as it passes
    ``bound``; under it, with ``check``, inf when a pixel would read a source pixel off the
    grid or of another label than its target's, or when its tones' spread about their
    labels' means (``_spread``) would fall under ``least``."""
    H, W = target.shape
    Hs, Ws = labels.shape
    e = 0.0
    for t in range(ea, eb):
        f = edge[t]
        i, j = f // W, f % W
        for k in range(4):  # the neighbour test is written out here and in _shift_pass: a helper returning
            y, x = i + _DY[k], j + _DX[k]  # the neighbour made the step 4x slower (0.67 -> 2.84 s, 1024x640)
            if y < 0 or x < 0 or y >= H or x >= W or target[y, x] != target[i, j] or patch[y, x] == pid:
                continue
            qy, qx = S[y, x, 0] - y, S[y, x, 1] - x
            if qy == oy and qx == ox:
                continue
            e += _dist2(img, i + oy, j + ox, i + qy, j + qx) + _dist2(img, y + oy, x + ox, y + qy, x + qx)
        if e > bound:
            return e
    for t in range(a if check else b, b):
        f = order[t]
        i, j = f // W, f % W
        sy, sx = i + oy, j + ox
        if sy < 0 or sx < 0 or sy >= Hs or sx >= Ws or labels[sy, sx] != target[i, j]:
            return np.inf
    if check and _spread(img, target, mu, order, a, b, oy, ox, W) < least:
        return np.inf
    return e


@njit(**JIT)
def _label_spread(S, img, target, mu, order, starts, nl):
    """Per target label (of each patch's first pixel), the summed ``_spread`` of its
    patches at their offsets, patches in id order."""
    W = target.shape[1]
    tot = np.zeros(nl, np.float64)
    for p in range(len(starts) - 1):
        a, b = starts[p], starts[p + 1]
        if b > a:
            f = order[a]
            i, j = f // W, f % W
            tot[target[i, j]] += _spread(img, target, mu, order, a, b, S[i, j, 0] - i, S[i, j, 1] - j, W)
    return tot


SPREAD_LOSS = 0.1  # the most share of a label's spread about its mean tone the shifts may lose (``shift_patches``)
ADOPT_MAX = 8  # most neighbouring patches' offsets a patch tries (``_shift_pass``)


@njit(**JIT)
def _shift_pass(S, img, target, labels, patch, order, starts, edge, estarts, radius, adopt, mu, tot, floor):
    """Each patch in turn (ids in order; ``order[starts[p]:starts[p + 1]]`` the flat
    indices of patch p + 1's pixels) takes, among its offset moved by up to ``radius``
    pixels each way, the one of least summed seam cost to its neighbours (``_shift_cost``;
    its own when none is lower; a moved patch reads its labels everywhere, where it is
    need not), and a patch of at most ``adopt`` pixels also among the offsets of the
    patches around it (the first ``ADOPT_MAX`` met, farther than ``radius``: joining a
    neighbour removes their seam); sequential, so any thread count gives one result.
    Returns the number of patches moved."""
    H, W = target.shape
    moved = 0
    cand = np.empty((ADOPT_MAX, 2), np.int64)
    for p in range(len(starts) - 1):
        a, b = starts[p], starts[p + 1]
        ea, eb = estarts[p], estarts[p + 1]
        if b == a:
            continue
        pid = p + 1
        f = order[a]
        oy, ox = S[f // W, f % W, 0] - f // W, S[f // W, f % W, 1] - f % W
        best = _shift_cost(S, img, target, labels, patch, order, a, b, edge, ea, eb, pid, oy, ox, np.inf, False, mu, 0.0)
        if best == 0.0:
            continue
        # its label (its first pixel's) may lose spread about its mean down to ``floor`` over the step
        # (``tot``: its spread now, earlier moves' gains and losses included)
        lab = target[f // W, f % W]
        spread = _spread(img, target, mu, order, a, b, oy, ox, W)
        least = spread - (tot[lab] - floor[lab])
        by, bx = oy, ox
        for dy in range(-radius, radius + 1):
            for dx in range(-radius, radius + 1):
                if dy == 0 and dx == 0:
                    continue
                e = _shift_cost(S, img, target, labels, patch, order, a, b, edge, ea, eb, pid, oy + dy, ox + dx, best, True,
                                mu, least)
                if e < best:
                    best, by, bx = e, oy + dy, ox + dx
        if b - a <= adopt:  # then each neighbouring patch's offset (first met, pixels in raster order)
            seen = 0
            for t in range(ea, eb):
                f = edge[t]
                i, j = f // W, f % W
                for k in range(4):
                    y, x = i + _DY[k], j + _DX[k]
                    if y < 0 or x < 0 or y >= H or x >= W or target[y, x] != target[i, j] or patch[y, x] == pid:
                        continue
                    qy, qx = S[y, x, 0] - y, S[y, x, 1] - x
                    if max(abs(qy - oy), abs(qx - ox)) <= radius:
                        continue  # among the shifts already
                    dup = False
                    for u in range(seen):
                        if cand[u, 0] == qy and cand[u, 1] == qx:
                            dup = True
                            break
                    if dup or seen == cand.shape[0]:
                        continue
                    cand[seen, 0] = qy
                    cand[seen, 1] = qx
                    seen += 1
            for u in range(seen):
                e = _shift_cost(S, img, target, labels, patch, order, a, b, edge, ea, eb, pid, cand[u, 0], cand[u, 1], best, True,
                            mu, least)
                if e < best:
                    best, by, bx = e, cand[u, 0], cand[u, 1]
        if by != oy or bx != ox:
            tot[lab] += _spread(img, target, mu, order, a, b, by, bx, W) - spread
            for t in range(a, b):
                f = order[t]
                S[f // W, f % W, 0] = f // W + by
                S[f // W, f % W, 1] = f % W + bx
            moved += 1
    return moved


def shift_patches(S: np.ndarray, img: np.ndarray, target: np.ndarray, labels: np.ndarray, patch: np.ndarray,
                  radius: int, passes: int, adopt: int = 0) -> tuple[np.ndarray, int]:
    """``S`` (copied) after ``passes`` passes in which every patch (``patch``: ids from 1,
    4-connected regions of one offset, ``patch.offset_components``) may move whole by up to
    ``radius`` pixels each way to where its seams cost least (Kwatra et al. 2003's cost, as
    ``refine_seams``), as long as each of its pixels then reads a source pixel of its
    target label: a patch magnified from the synthesis is placed to a whole exemplar pixel
    (``factor`` output pixels); this aligns it with its neighbours at the output's
    resolution. A patch of at most ``adopt`` pixels may also take a neighbouring patch's
    offset (``_shift_pass``). A patch across a label border moves as one piece per label. No
    label loses more than ``SPREAD_LOSS`` of its pieces' summed squared tone deviation from its
    mean tone on the source grid (``_spread``): shifts to where seams cost least drew the
    pieces of a label's tails onto its mode (bench_photos: a near-black label's std ratio
    0.88 -> 0.70). Each pass lowers the total ``seam_cost``; pieces keep their pixels; stops
    early when a pass moves nothing. Returns the map and the number of piece moves."""
    S = np.ascontiguousarray(S, np.int32).copy()
    img = np.ascontiguousarray(img, np.float32)
    target = np.ascontiguousarray(target, np.int32)
    labels = np.ascontiguousarray(labels, np.int32)
    nl = int(max(labels.max(initial=0), target.max(initial=0))) + 1
    # a patch across a label border moves as one piece per label (no seam joins them; a label's spread
    # below is its own pieces'): ids in order of (patch, label)
    patch = np.unique(np.asarray(patch, np.int64) * nl + target, return_inverse=True)[1].reshape(target.shape) + 1
    order = np.argsort(patch.ravel(), kind="stable").astype(np.int64)
    ids = np.arange(1, int(patch.max(initial=0)) + 2)
    starts = np.searchsorted(patch.ravel()[order], ids).astype(np.int64)
    # the pixels with a same-label 4-neighbour in another patch: the only ones a shift's cost reads
    rim = np.zeros(patch.shape, bool)
    for sa, sb in (((slice(None), slice(1, None)), (slice(None), slice(None, -1))),
                   ((slice(1, None), slice(None)), (slice(None, -1), slice(None)))):
        d = (patch[sa] != patch[sb]) & (target[sa] == target[sb])
        rim[sa] |= d
        rim[sb] |= d
    edge = order[rim.ravel()[order]]
    estarts = np.searchsorted(patch.ravel()[edge], ids).astype(np.int64)
    # each label's mean tone on the source grid, and its patches' summed spread about it (``_spread``):
    # the shifts may lower that sum by SPREAD_LOSS at most (they drew patches of a label's tails onto its mode)
    tone = img.sum(-1, dtype=np.float64).ravel()
    mu = np.bincount(labels.ravel(), tone, nl) / np.maximum(np.bincount(labels.ravel(), minlength=nl), 1)
    tot = _label_spread(S, img, target, mu, order, starts, nl)
    floor = tot * (1.0 - SPREAD_LOSS)
    moves = 0
    for _ in range(passes):
        n = _shift_pass(S, img, target, labels, patch, order, starts, edge, estarts, int(radius), int(adopt), mu,
                        tot, floor)
        moves += int(n)
        if n == 0:
            break
    return S, moves
