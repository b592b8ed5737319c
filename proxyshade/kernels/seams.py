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
result does not depend on the number of threads. Pixels of different target labels are not
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
def _run_cost(S, img, target, ri, rj, n):
    """Summed seam cost of the ``n`` pixels (``ri``, ``rj``) read at their own offsets (a
    pair inside the run counts twice, a pair to the rest of the map once)."""
    e = 0.0
    for t in range(n):
        i, j = ri[t], rj[t]
        e += _energy(S, img, target, i, j, S[i, j, 0] - i, S[i, j, 1] - j)
    return e


@njit(**JIT)
def _run_pass(S, img, target, labels, max_run):
    """Run moves, in scan order: for a pixel ``p`` (offset ``a``) whose neighbour ``q`` in
    direction ``k`` reads another offset ``b``, the run of pixels through ``p`` across
    ``k`` (along the seam) that read ``a`` with a ``k``-neighbour reading ``b``, at most
    ``max_run`` long each way (the whole run, and the part on either side of ``p`` with
    ``p``), takes ``b`` when that lowers the summed seam cost and every pixel of it then
    reads a source pixel of its label. A straight seam across many rows shifts by one
    pixel, which the one-pixel moves cannot do. Returns the number of pixels moved."""
    H, W = target.shape
    Hs, Ws = labels.shape
    ri = np.empty(2 * max_run + 1, np.int64)
    rj = np.empty(2 * max_run + 1, np.int64)
    moved = 0
    for i in range(H):
        for j in range(W):
            for k in range(4):
                y, x = i + _DY[k], j + _DX[k]
                if y < 0 or x < 0 or y >= H or x >= W or target[y, x] != target[i, j]:
                    continue
                ay, ax = S[i, j, 0] - i, S[i, j, 1] - j
                by, bx = S[y, x, 0] - y, S[y, x, 1] - x
                if ay == by and ax == bx:
                    continue
                ey, ex = _DX[k], _DY[k]  # along the seam: perpendicular to (dy, dx)
                ext = np.zeros(2, np.int64)  # pixels beyond p: -e side, +e side
                for side in range(2):
                    sgn = 1 if side == 1 else -1
                    for t in range(1, max_run + 1):
                        u, v = i + sgn * t * ey, j + sgn * t * ex
                        uy, vx = u + _DY[k], v + _DX[k]
                        if u < 0 or v < 0 or u >= H or v >= W or uy < 0 or vx < 0 or uy >= H or vx >= W:
                            break
                        if (target[u, v] != target[i, j] or target[uy, vx] != target[i, j]
                                or S[u, v, 0] - u != ay or S[u, v, 1] - v != ax
                                or S[uy, vx, 0] - uy != by or S[uy, vx, 1] - vx != bx):
                            break
                        ext[side] = t
                if ext[0] + ext[1] == 0:
                    continue  # a run of one: the one-pixel moves' case
                best, lo, hi = 0.0, 0, 0
                for c in range(3):  # the whole run, then p with the -e part, p with the +e part
                    l0 = ext[0] if c != 2 else 0
                    h0 = ext[1] if c != 1 else 0
                    if c > 0 and (l0 == 0 and h0 == 0 or l0 + h0 == ext[0] + ext[1]):
                        continue
                    n = 0
                    ok = True
                    for t in range(-l0, h0 + 1):
                        u, v = i + t * ey, j + t * ex
                        sy, sx = u + by, v + bx
                        if sy < 0 or sx < 0 or sy >= Hs or sx >= Ws or labels[sy, sx] != target[u, v]:
                            ok = False
                            break
                        ri[n] = u
                        rj[n] = v
                        n += 1
                    if not ok:
                        continue
                    before = _run_cost(S, img, target, ri, rj, n)
                    for t in range(n):
                        S[ri[t], rj[t], 0] = ri[t] + by
                        S[ri[t], rj[t], 1] = rj[t] + bx
                    gain = before - _run_cost(S, img, target, ri, rj, n)
                    for t in range(n):
                        S[ri[t], rj[t], 0] = ri[t] + ay
                        S[ri[t], rj[t], 1] = rj[t] + ax
                    if gain > best:
                        best, lo, hi = gain, l0, h0
                if best > 0.0:
                    for t in range(-lo, hi + 1):
                        u, v = i + t * ey, j + t * ex
                        S[u, v, 0] = u + by
                        S[u, v, 1] = v + bx
                    moved += lo + hi + 1
                    break  # p has a new offset: its other seams wait for the next pass
    return moved


def refine_seams(S: np.ndarray, img: np.ndarray, target: np.ndarray, labels: np.ndarray,
                 passes: int, max_run: int = 0) -> tuple[np.ndarray, int]:
    """``S`` (copied) after ``passes`` passes of seam moves (each two checkerboard halves
    of one-pixel moves, then, with ``max_run``, a scan of run moves: ``_run_pass``),
    stopping early when a pass changes nothing; and the number of pixel moves made."""
    S = np.ascontiguousarray(S, np.int32).copy()
    img = np.ascontiguousarray(img, np.float32)
    target = np.ascontiguousarray(target, np.int32)
    labels = np.ascontiguousarray(labels, np.int32)
    moves = 0
    for _ in range(passes):
        n = _sub_pass(S, img, target, labels, 0) + _sub_pass(S, img, target, labels, 1)
        if max_run > 0:
            n += _run_pass(S, img, target, labels, int(max_run))
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
