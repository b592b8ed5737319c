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
neighbours here (a label border is not a patch seam). A pixel, run or line none of whose
neighbourhood changed since it was last tried is not tried again (``SeamMemory``, also
across calls on one map): the result is that of trying everything, with less work.

``coords``: (H, W, 2) int32 map (row, column) into a source grid; ``img``: (Hs, Ws, C) float32
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
def _pair_cost(coords, img, target, i, j, oy, ox, k):
    """The seam cost between pixel (i, j) read at offset (oy, ox) and its neighbour ``k``
    (``_DY``/``_DX``) read at its own offset: 0 off the image, across a label border or
    when both read at one offset."""
    return _pair_at(coords, img, target, i, j, oy, ox, _DY[k], _DX[k])


@njit(**JIT)
def _pair_at(coords, img, target, i, j, oy, ox, dy, dx):
    """``_pair_cost`` with the neighbour (i + dy, j + dx) (a step known to the caller: a
    tuple read at a varying index costs as much as the colours)."""
    H, W = target.shape
    y, x = i + dy, j + dx
    if y < 0 or x < 0 or y >= H or x >= W or target[y, x] != target[i, j]:
        return 0.0
    qy, qx = coords[y, x, 0] - y, coords[y, x, 1] - x
    if qy == oy and qx == ox:
        return 0.0
    return _dist2(img, i + oy, j + ox, i + qy, j + qx) + _dist2(img, y + oy, x + ox, y + qy, x + qx)


@njit(**JIT)
def _energy(coords, img, target, i, j, oy, ox):
    """Summed seam cost between pixel (i, j) read at offset (oy, ox) and its same-label
    neighbours read at their own offsets."""
    e = 0.0
    for k in range(4):
        e += _pair_at(coords, img, target, i, j, oy, ox, _DY[k], _DX[k])
    return e


@njit(**PJIT)
def _sub_pass(coords, img, target, labels, parity, stamp, tried, lines, clock, changed):
    """One checkerboard half: every pixel of ``parity`` takes its best offset; the number
    of pixels that changed. ``stamp``: the ``clock`` at which each pixel last changed;
    ``tried``: at which each pixel was last tried (a pixel none of whose neighbours or
    itself changed since is not tried again: it would keep its offset again); ``lines``:
    the same per row and column (``SeamMemory``): a row none of whose pixels or its
    neighbour rows' changed since it was last tried is not tried again. ``changed`` (zeros):
    the number of pixels changed per row is added."""
    H, W = target.shape
    Hs, Ws = labels.shape
    for i0 in prange(H):
        i = np.int64(i0)  # the callees typed for int64 only (a parallel loop's index is typed uint64 too)
        if lines[2 + parity, i] > lines[0, i] and (i == 0 or lines[2 + parity, i] > lines[0, i - 1]) and (
                i == H - 1 or lines[2 + parity, i] > lines[0, i + 1]):
            continue
        lines[2 + parity, i] = clock
        for j in range((i + parity) % 2, W, 2):
            if tried[i, j] > stamp[i, j] and (i == 0 or tried[i, j] > stamp[i - 1, j]) and (
                    j == 0 or tried[i, j] > stamp[i, j - 1]) and (j == W - 1 or tried[i, j] > stamp[i, j + 1]) and (
                    i == H - 1 or tried[i, j] > stamp[i + 1, j]):
                continue
            tried[i, j] = clock  # off a seam too: it stays off while neither it nor a neighbour changes
            oy, ox = coords[i, j, 0] - i, coords[i, j, 1] - j
            seam = False
            for k in range(4):
                y, x = i + _DY[k], j + _DX[k]
                if 0 <= y < H and 0 <= x < W and target[y, x] == target[i, j] and (
                        coords[y, x, 0] - y != oy or coords[y, x, 1] - x != ox):
                    seam = True
                    break
            if not seam:
                continue
            best = _energy(coords, img, target, i, j, oy, ox)
            by, bx = oy, ox
            for k in range(4):
                y, x = i + _DY[k], j + _DX[k]
                if y < 0 or x < 0 or y >= H or x >= W or target[y, x] != target[i, j]:
                    continue
                cy, cx = coords[y, x, 0] - y, coords[y, x, 1] - x
                if (cy == oy and cx == ox) or (cy == by and cx == bx):
                    continue
                sy, sx = i + cy, j + cx
                if sy < 0 or sx < 0 or sy >= Hs or sx >= Ws or labels[sy, sx] != target[i, j]:
                    continue
                e = 0.0  # _energy, cut short once it reaches the best (terms are never negative: the same choice)
                for kk in range(4):
                    e += _pair_at(coords, img, target, i, j, cy, cx, _DY[kk], _DX[kk])
                    if e >= best:
                        break
                if e < best:
                    best, by, bx = e, cy, cx
            if by != oy or bx != ox:
                coords[i, j, 0] = i + by
                coords[i, j, 1] = j + bx
                stamp[i, j] = clock
                changed[i] += 1
    return changed.sum()


@njit(inline="always", **JIT)
def _across(coords, target, i, j, dy, dx):
    """Whether (i, j) and its neighbour (i + dy, j + dx) are across a seam: the neighbour inside
    the image, of (i, j)'s target label, reading another offset; with the two offsets
    (ay, ax) of (i, j) and (by, bx) of the neighbour (zeros where there is no seam)."""
    H, W = target.shape
    y, x = i + dy, j + dx
    if y < 0 or x < 0 or y >= H or x >= W or target[y, x] != target[i, j]:
        return False, 0, 0, 0, 0
    ay, ax = coords[i, j, 0] - i, coords[i, j, 1] - j
    by, bx = coords[y, x, 0] - y, coords[y, x, 1] - x
    return not (ay == by and ax == bx), ay, ax, by, bx


@njit(**JIT)
def _on_run(coords, target, t, u, v, dy, dx, ay, ax, by, bx):
    """Whether (u, v) and its neighbour across the seam, (u + dy, v + dx), are a pixel pair
    of the seam run: both inside, of label ``t``, read at offsets (ay, ax) and (by, bx)."""
    H, W = target.shape
    uy, vx = u + dy, v + dx
    if u < 0 or v < 0 or u >= H or v >= W or uy < 0 or vx < 0 or uy >= H or vx >= W:
        return False
    return (target[u, v] == t and target[uy, vx] == t
            and coords[u, v, 0] - u == ay and coords[u, v, 1] - v == ax
            and coords[uy, vx, 0] - uy == by and coords[uy, vx, 1] - vx == bx)


@njit(**JIT)
def _run_at(coords, img, target, labels, i, j, k, rc, rv, lo_end, hi_end, stamp, tried, span, clock):
    """The run move of the seam run that starts at (i, j) across direction ``k`` (see
    ``_run_pass``; (i, j) starts it: its neighbour that way is inside the image, of its target
    label, and reads another offset, and its predecessor along the seam does not continue
    that run); the number of pixels moved. Not tried again
    (``tried[i, j, k]``, the ``clock`` when it last was) where no pixel the run reads (its
    pixels, those before and after it and those on either side) changed since (``stamp``).
    ``span[i, j, k]``: the run's length when last tried (255: that or more); where none of
    those pixels changed since, the run is that long still, so only its stamps are read."""
    H, W = target.shape
    Hs, Ws = labels.shape
    dy, dx = _DY[k], _DX[k]  # across the seam (the opposite way: -dy, -dx)
    y, x = i + dy, j + dx
    ay, ax = coords[i, j, 0] - i, coords[i, j, 1] - j
    by, bx = coords[y, x, 0] - y, coords[y, x, 1] - x
    ey, ex = dx * dx, dy * dy  # along the seam: (0, 1) or (1, 0)
    t = target[i, j]
    ev = tried[i, j, k]
    if ev > 0:  # the run as it is now; does anything it reads carry a later stamp?
        again = False
        last = span[i, j, k]
        n = -1
        while not again:
            u, v = i + n * ey, j + n * ex
            if u >= 0 and v >= 0 and u < H and v < W:
                again = stamp[u, v] >= ev
                for sg in (1, -1):  # across the seam, either way
                    uy, vx = u + sg * dy, v + sg * dx
                    if uy >= 0 and vx >= 0 and uy < H and vx < W and stamp[uy, vx] >= ev:
                        again = True
            if n < 0:
                n = 0
                continue
            if last < 255:
                if n == last:  # the pixel after the run as it was (it is so still unless a stamp says otherwise)
                    break
            elif not _on_run(coords, target, t, u, v, dy, dx, ay, ax, by, bx):
                break
            n += 1
        if not again:
            return 0
    tried[i, j, k] = clock
    n = 0
    while True:
        u, v = i + n * ey, j + n * ex
        if not _on_run(coords, target, t, u, v, dy, dx, ay, ax, by, bx):
            break
        sy, sx = u + by, v + bx
        rv[n] = 0 <= sy < Hs and 0 <= sx < Ws and labels[sy, sx] == target[u, v]
        rc[n] = (_pair_at(coords, img, target, u, v, by, bx, dy, dx) + _pair_at(coords, img, target, u, v, by, bx, -dy, -dx)
                 - _pair_at(coords, img, target, u, v, ay, ax, dy, dx) - _pair_at(coords, img, target, u, v, ay, ax, -dy, -dx))
        if n == 0:  # the pair with the pixel before the run
            lo_end[n] = (_pair_at(coords, img, target, u, v, by, bx, -ey, -ex)
                         - _pair_at(coords, img, target, u, v, ay, ax, -ey, -ex))
        else:  # the pair with the previous pixel of the run: the one its hi_end took, summed the other way round
            lo_end[n] = hi_end[n - 1]
        hi_end[n] = (_pair_at(coords, img, target, u, v, by, bx, ey, ex)
                     - _pair_at(coords, img, target, u, v, ay, ax, ey, ex))  # with the pixel after it
        n += 1
    span[i, j, k] = min(n, 255)
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
        coords[u, v, 0] = u + by
        coords[u, v, 1] = v + bx
        stamp[u, v] = clock
    return hi - lo + 1


@njit(**PJIT)
def _run_pass(coords, img, target, labels, vertical, parity, stamp, tried, span, lines, clock, moved):
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
    result. Returns the number of pixels moved. ``stamp``, ``tried``, ``span``, ``clock``: as
    ``_run_at``; ``lines``: as ``_sub_pass`` (a line none of whose pixels or its neighbour
    lines' changed since it was last tried is not tried again); ``moved`` (zeros): the number
    of pixels moved per line is added."""
    nl = target.shape[1] if vertical else target.shape[0]
    for li in prange((nl - parity + 1) // 2):
        # the line's index as int64: a parallel loop types it twice (int64, uint64), its callees compile twice
        _run_line(coords, img, target, labels, vertical, np.int64(2 * li + parity), stamp, tried, span, lines, clock,
                  moved)
    return moved.sum()


@njit(**JIT)
def _run_line(coords, img, target, labels, vertical, line, stamp, tried, span, lines, clock, moved):
    """Line ``line`` of ``_run_pass`` (its loop body: a serial kernel compiles faster than the same
    code inside a parallel loop)."""
    H, W = target.shape
    nl, L = (W, H) if vertical else (H, W)
    ls, lt = (1, 5) if vertical else (0, 4)
    if lines[lt, line] > lines[ls, line] and (line == 0 or lines[lt, line] > lines[ls, line - 1]) and (
            line == nl - 1 or lines[lt, line] > lines[ls, line + 1]):
        return
    last = lines[lt, line]  # the clock when the line was last tried (0: never, or the clock wrapped)
    lines[lt, line] = clock
    rc = np.empty(L, np.float64)
    rv = np.empty(L, np.bool_)
    lo_end = np.empty(L, np.float64)
    hi_end = np.empty(L, np.float64)
    # Only the stretches with a change near them are tried again. A column of the line is
    # dirty where a pixel of it, or of a neighbour line, changed since ``last`` (stamp >= last).
    # A run start (``_run_at``) whose run, the pixel before it and the one after it are in clean
    # columns reads only what it read when the line was last tried, when it was tried or
    # found unchanged: ``_run_at`` would return 0 and write nothing. So each dirty column c
    # brings the positions c and c + 1 (their start test reads c) and the start of each run
    # holding c - 1 or c (walked back from there), with everything between, in order; every
    # other position is passed over. A move writes its pixels' stamps (the clock), so what
    # it changes ahead is dirty when the scan gets there. The result is the full scan's.
    t = 0
    until = 0  # positions below this are tried in full
    while t < L:
        if t >= until:
            c = t - 1 if t > 0 else 0
            while c < L:  # the next dirty column
                dirty = False
                for dl in range(-1, 2):
                    m = line + dl
                    if 0 <= m < nl and (stamp[c, m] if vertical else stamp[m, c]) >= last:
                        dirty = True
                if dirty:
                    break
                c += 1
            if c >= L:
                break
            s = c if c >= t else t
            for p in range(c - 1, c + 1):
                if p < t:
                    continue
                i, j = (p, line) if vertical else (line, p)
                ti = target[i, j]
                for kk in range(2):  # the start of the run across kk holding p, not before t
                    dy, dx = (0, 2 * kk - 1) if vertical else (2 * kk - 1, 0)
                    seam, ay, ax, by, bx = _across(coords, target, i, j, dy, dx)
                    if not seam:
                        continue
                    q = p
                    while q > t:
                        u, v = (q - 1, line) if vertical else (line, q - 1)
                        if _on_run(coords, target, ti, u, v, dy, dx, ay, ax, by, bx):
                            q -= 1
                        else:
                            break
                    s = min(s, q)
            t = s
            until = c + 2
        i, j = (t, line) if vertical else (line, t)
        ti = target[i, j]
        for kk in range(2):
            # does (i, j) start a run across k (``_run_at``)? Written out here: most pixels are on no
            # seam or inside a run, and this test is most of the loop's cost; coords are read
            # again after each run move
            k = (1 + kk) if vertical else 3 * kk
            dy, dx = (0, 2 * kk - 1) if vertical else (2 * kk - 1, 0)
            seam, ay, ax, by, bx = _across(coords, target, i, j, dy, dx)
            if not seam:
                continue
            u, v = (i - 1, j) if vertical else (i, j - 1)  # the predecessor along the seam
            if (u >= 0 and v >= 0 and target[u, v] == ti and target[u + dy, v + dx] == ti
                    and coords[u, v, 0] - u == ay and coords[u, v, 1] - v == ax
                    and coords[u + dy, v + dx, 0] - (u + dy) == by and coords[u + dy, v + dx, 1] - (v + dx) == bx):
                continue  # it continues the run
            moved[line] += _run_at(coords, img, target, labels, i, j, k, rc=rc, rv=rv, lo_end=lo_end, hi_end=hi_end,
                                   stamp=stamp, tried=tried, span=span, clock=clock)
        t += 1


class SeamMemory:
    """What ``refine_seams`` keeps between its calls on one map (the colours, targets and
    labels the same arrays): when each pixel last changed and when each was last tried, so
    that a later call tries again only what a change since can move; the result is the same
    as without it. The map a call returns is kept (not copied): change it only through a
    copy (``shift_patches`` copies) before giving it back."""

    def __init__(self):
        self.coords = None

    def start(self, coords: np.ndarray, args: tuple) -> None:
        """Ready for a call on ``coords`` with ``args`` (img, target, labels): the pixels that
        differ from the map the last call returned marked as changed; everything marked
        untried on the first call or other arrays."""
        H, W = coords.shape[:2]
        if self.coords is None or self.coords.shape != coords.shape or any(x is not y for x, y in zip(args, self.args)):
            self.args = args
            self.stamp = np.zeros((H, W), np.uint8)  # the clock at which each pixel last changed
            self.tried = np.zeros((H, W), np.uint8)  # ... was last tried by a one-pixel move
            self.tried_run = np.zeros((H, W, 4), np.uint8)  # ... was last tried as a run's start, per direction
            self.span_run = np.zeros((H, W, 4), np.uint8)  # that run's length then (255: 255 or more)
            # per row and column: last change (rows, columns), last tried by one-pixel moves
            # (rows, parity 0 and 1), by run moves (rows, columns)
            self.lines = np.zeros((6, max(H, W)), np.uint8)
            self.clock = 0
        else:
            diff = (coords != self.coords).any(-1)
            c = self.tick()
            self.stamp[diff] = c
            self.lines[0, :H][diff.any(1)] = c
            self.lines[1, :W][diff.any(0)] = c

    def mark(self, per_line: np.ndarray, vertical: bool) -> None:
        """After a pass over the rows (columns with ``vertical``) that changed ``per_line``
        pixels of each at the clock: the last change of each row and column (``lines[0]``,
        ``lines[1]``) updated."""
        t = np.flatnonzero(per_line)
        if t.size:
            v = int(vertical)
            self.lines[v, t] = self.clock
            hit = (self.stamp[:, t] if vertical else self.stamp[t]) == self.clock
            self.lines[1 - v, np.flatnonzero(hit.any(axis=v))] = self.clock

    def tick(self) -> int:
        """The next clock value (all marks cleared when the 8-bit clock would wrap)."""
        self.clock += 1
        if self.clock == 256:
            self.stamp[:] = 0
            self.tried[:] = 0
            self.tried_run[:] = 0
            self.lines[:] = 0
            self.clock = 1
        return self.clock


def refine_seams(coords: np.ndarray, img: np.ndarray, target: np.ndarray, labels: np.ndarray,
                 passes: int, runs: bool = False, memory: SeamMemory | None = None) -> tuple[np.ndarray, int]:
    """``coords`` (copied) after ``passes`` passes of seam moves (each two checkerboard halves
    of one-pixel moves, then, with ``runs``, run moves on even and odd rows, then columns:
    ``_run_pass``),
    stopping early when a pass changes nothing; and the number of pixel moves made. A pixel
    or run whose neighbourhood has not changed since it was last tried is not tried again;
    ``memory`` carries that over calls on one map (the same result, less work)."""
    coords = np.ascontiguousarray(coords, np.int32).copy()
    img = np.ascontiguousarray(img, np.float32)
    target = np.ascontiguousarray(target, np.int32)
    labels = np.ascontiguousarray(labels, np.int32)
    m = memory if memory is not None else SeamMemory()
    m.start(coords, (img, target, labels))
    moves = 0
    rows, cols = np.zeros(coords.shape[0], np.int64), np.zeros(coords.shape[1], np.int64)  # changes per line
    for _ in range(passes):
        n = 0
        for parity in (0, 1):
            rows[:] = 0
            n += _sub_pass(coords, img, target, labels, parity, m.stamp, m.tried, m.lines, m.tick(), rows)
            m.mark(rows, False)
        if runs:
            for vertical in (False, True):
                for parity in (0, 1):
                    (cols if vertical else rows)[:] = 0
                    n += _run_pass(coords, img, target, labels, vertical, parity, stamp=m.stamp, tried=m.tried_run,
                                   span=m.span_run, lines=m.lines, clock=m.tick(), moved=cols if vertical else rows)
                    m.mark(cols if vertical else rows, vertical)
        moves += int(n)
        if n == 0:
            break
    m.coords = coords
    return coords, moves


def seam_cost(coords: np.ndarray, img: np.ndarray, target: np.ndarray) -> float:
    """The total seam cost of a map (each neighbouring pair of one target label counted once)."""
    return float(_seam_cost(np.ascontiguousarray(coords, np.int32), np.ascontiguousarray(img, np.float32),
                            np.ascontiguousarray(target, np.int32)))


@njit(**JIT)
def _seam_cost(coords, img, target):
    H, W = target.shape
    tot = 0.0
    for i in range(H):
        for j in range(W):
            for k in range(2, 4):  # right and down: each pair once
                tot += _pair_cost(coords, img, target, i, j, coords[i, j, 0] - i, coords[i, j, 1] - j, k)
    return tot


# ---------------------------------------------------------------------------
# whole patches shifted by a few output pixels


SPREAD_LOSS = 0.1  # the most share of a label's spread about its mean tone the shifts may lose (``shift_patches``)
ADOPT_MAX = 8  # most neighbouring patches' offsets a patch tries (``_shift_passes``)


@njit(**JIT)
def _spread(img, m, order, a, b, oy, ox):
    """Σ over the pixels ``order[a:b]`` ((row, column), one piece: one target label) read at
    offset (oy, ox) of (their tone − ``m``, their label's mean tone)², tone the sum of ``img``'s
    channels (off the grid: 0)."""
    Hs, Ws, C = img.shape
    s = 0.0
    for t in range(a, b):
        i, j = order[t, 0], order[t, 1]
        if 0 <= i + oy < Hs and 0 <= j + ox < Ws:
            v = -m
            for c in range(C):
                v += img[i + oy, j + ox, c]
            s += v * v
    return s


@njit(**JIT)
def _shift_passes(coords, img, target, labels, patch, radius, adopt, passes, keep):
    """Up to ``passes`` passes (stopping after one that moves nothing); in each, each piece
    (a patch's pixels of one target label; ids in order of (``patch`` id, label)) in turn
    takes, among its offset moved by up to ``radius`` pixels each way, the one of least
    summed seam cost to its neighbours (its own when none is lower; a moved piece reads its
    label everywhere, where it is need not, and its label's summed spread about its mean
    tone on the source grid (``_spread``, the running total over its pieces) stays at least
    ``keep`` times its value before the first pass), and a piece of at most ``adopt`` pixels also
    among the offsets of the pieces around it (the first ``ADOPT_MAX`` met, farther than
    ``radius``: joining a neighbour removes their seam); sequential, so any thread count
    gives one result. A piece's pairs across its seams and what its neighbours read are
    gathered once; an offset's sum stops once it reaches the best so far. A piece that
    moved nothing when last tried, none of whose neighbours has moved since, is not tried
    again (it would again move nothing) unless an offset was refused for its label's
    spread then and that label's budget has grown since. Returns the number of piece
    moves."""
    Hs, Ws, C = img.shape
    H, W = target.shape
    # each label's mean tone (its source pixels' channel sums, summed in raster order)
    nl = 0
    for sy in range(Hs):
        for sx in range(Ws):
            nl = max(nl, labels[sy, sx])
    npatch = 0
    for i in range(H):
        for j in range(W):
            nl = max(nl, target[i, j])
            npatch = max(npatch, patch[i, j])
    nl += 1
    mu = np.zeros(nl, np.float64)
    cnt = np.zeros(nl, np.int64)
    for sy in range(Hs):
        for sx in range(Ws):
            v = 0.0
            for c in range(C):
                v += img[sy, sx, c]
            mu[labels[sy, sx]] += v
            cnt[labels[sy, sx]] += 1
    for lab in range(nl):
        mu[lab] /= max(cnt[lab], 1)
    # pieces: a patch's pixels of one target label, ids from 1 in order of (patch, label). Per patch
    # (ids from 0): its size, its first pixel's label and whether it has pixels of another (mixed)
    size = np.zeros(npatch + 1, np.int64)
    one = np.empty(npatch + 1, np.int64)
    mixed = np.zeros(npatch + 1, np.bool_)
    for i in range(H):
        for j in range(W):
            p = patch[i, j]
            if size[p] == 0:
                one[p] = target[i, j]
            elif target[i, j] != one[p]:
                mixed[p] = True
            size[p] += 1
    # a mixed patch's labels ascending, ``nlab[p]`` of them from ``lab_at[p]`` in ``labs`` (its
    # pixels' labels gathered there first)
    lab_at = np.zeros(npatch + 2, np.int64)
    for p in range(npatch + 1):
        lab_at[p + 1] = lab_at[p] + (size[p] if mixed[p] else 0)
    labs = np.empty(lab_at[npatch + 1], np.int64)
    nlab = np.zeros(npatch + 1, np.int64)
    for i in range(H):
        for j in range(W):
            p = patch[i, j]
            if mixed[p]:
                labs[lab_at[p] + nlab[p]] = target[i, j]
                nlab[p] += 1
    seen = np.full(nl, -1, np.int64)  # the patch whose labels last showed each label
    base = np.zeros(npatch + 1, np.int64)  # each patch's first piece id
    npiece = 0
    for p in range(npatch + 1):
        base[p] = npiece + 1
        if not mixed[p]:
            npiece += 1 if size[p] > 0 else 0
            continue
        m, o = 0, lab_at[p]
        for t in range(o, o + nlab[p]):
            lab = labs[t]
            if seen[lab] != p:
                seen[lab] = p
                u = o + m  # insert into labs[o:o + m], ascending (u <= t)
                while u > o and labs[u - 1] > lab:
                    labs[u] = labs[u - 1]
                    u -= 1
                labs[u] = lab
                m += 1
        nlab[p] = m
        npiece += m
    # each piece's pixels (``starts`` counted), label and first pixel's offset
    piece = np.empty((H, W), np.int64)
    starts = np.zeros(npiece + 1, np.int64)
    plab = np.empty(npiece + 1, np.int64)
    poff = np.empty((npiece + 1, 2), np.int64)
    for i in range(H):
        for j in range(W):
            p = patch[i, j]
            q = base[p]
            if mixed[p]:
                while labs[lab_at[p] + q - base[p]] != target[i, j]:
                    q += 1
            piece[i, j] = q
            if starts[q] == 0:
                plab[q] = target[i, j]
                poff[q, 0], poff[q, 1] = coords[i, j, 0] - i, coords[i, j, 1] - j
            starts[q] += 1
    patch = piece
    npatch = npiece
    for p in range(npatch):
        starts[p + 1] += starts[p]
    # order[starts[p]:starts[p + 1]]: piece p + 1's pixels (row, column), in raster order; and
    # each label's summed spread now (``_spread`` of its pieces at their first pixels' offsets, pieces
    # in id order) and the least it may fall to
    fill = np.empty(npatch, np.int64)  # each piece's next free place in order, then in pr
    for p in range(npatch):
        fill[p] = starts[p]
    order = np.empty((H * W, 2), np.int32)
    psum = np.zeros(npatch + 1, np.float64)
    for i in range(H):
        for j in range(W):
            q = patch[i, j]
            order[fill[q - 1], 0], order[fill[q - 1], 1] = i, j
            fill[q - 1] += 1
            sy, sx = i + poff[q, 0], j + poff[q, 1]
            if 0 <= sy < Hs and 0 <= sx < Ws:
                v = -mu[target[i, j]]
                for c in range(C):
                    v += img[sy, sx, c]
                psum[q] += v * v
    tot = np.zeros(nl, np.float64)
    for q in range(1, npatch + 1):
        tot[plab[q]] += psum[q]
    floor = np.empty(nl, np.float64)
    for lab in range(nl):
        floor[lab] = tot[lab] * keep
    # pstarts[p]:pstarts[p + 1]: patch p + 1's pairs with a same-label 4-neighbour in another
    # patch (the only pixels a shift's cost reads): pr[t] = inside (row, column), outside
    # (row, column), its patch; inside pixels in raster order, neighbours up, left, right, down
    pstarts = np.zeros(npatch + 1, np.int64)
    pr = np.empty((0, 5), np.int64)
    for r in range(2):  # count, then fill (a raster scan each)
        for p in range(npatch):
            fill[p] = pstarts[p] if r == 1 else 0
        for i in range(H):
            for j in range(W):
                p = patch[i, j]
                for k in range(4):
                    y, x = i + _DY[k], j + _DX[k]
                    if p == 0 or y < 0 or x < 0 or y >= H or x >= W or target[y, x] != target[i, j] or patch[y, x] == p:
                        continue
                    if r == 1:
                        t = fill[p - 1]
                        pr[t, 0], pr[t, 1], pr[t, 2], pr[t, 3], pr[t, 4] = i, j, y, x, patch[y, x]
                    fill[p - 1] += 1
        if r == 0:
            for p in range(npatch):
                pstarts[p + 1] = pstarts[p] + fill[p]
            pr = np.empty((pstarts[npatch], 5), np.int64)
    most = 0
    for p in range(npatch):
        most = max(most, pstarts[p + 1] - pstarts[p])
    qoff = np.empty((most, 2), np.int64)
    ok = np.empty((most, 2), np.bool_)
    col = np.zeros((most, 2, C), np.float32)
    cand = np.empty(((2 * radius + 1) ** 2 + ADOPT_MAX, 2), np.int64)
    tried = np.full(npatch + 1, -1, np.int64)  # the clock when a piece last moved nothing
    moved_at = np.zeros(npatch + 1, np.int64)  # the clock when a piece last moved
    # for a piece that moved nothing with an offset refused for its label's spread: its spread and the
    # least an offset's could be then (``least``); else -inf
    own = np.zeros(npatch + 1, np.float64)
    refused = np.full(npatch + 1, -np.inf)
    clock = 0
    moves = 0
    for _ in range(passes):
        moved = 0
        for p in range(npatch):
            a, b = starts[p], starts[p + 1]
            if b == a:
                continue
            pid = p + 1
            ps, n = pstarts[p], pstarts[p + 1] - pstarts[p]
            i0, j0 = order[a, 0], order[a, 1]
            lab = target[i0, j0]
            # (tried again anyway when its label's budget has grown past an offset it refused)
            if tried[pid] >= 0 and not own[pid] - (tot[lab] - floor[lab]) < refused[pid]:
                again = False
                for t in range(ps, ps + n):
                    if moved_at[pr[t, 4]] > tried[pid]:
                        again = True
                        break
                if not again:
                    continue
            oy, ox = coords[i0, j0, 0] - i0, coords[i0, j0, 1] - j0
            for t in range(n):  # what the neighbours read: the same for every offset tried
                y, x = pr[ps + t, 2], pr[ps + t, 3]
                ry, rx = coords[y, x, 0] - y, coords[y, x, 1] - x
                qoff[t, 0], qoff[t, 1] = ry, rx
                sy, sx = pr[ps + t, 0] + ry, pr[ps + t, 1] + rx
                ok[t, 0] = 0 <= sy < Hs and 0 <= sx < Ws
                if ok[t, 0]:
                    for c in range(C):
                        col[t, 0, c] = img[sy, sx, c]
                sy, sx = y + ry, x + rx
                ok[t, 1] = 0 <= sy < Hs and 0 <= sx < Ws
                if ok[t, 1]:
                    for c in range(C):
                        col[t, 1, c] = img[sy, sx, c]
            # the offsets tried, in order: its own, moved by up to radius each way (rows, then
            # columns, ascending), then for a small patch its neighbours' (first met, farther)
            ncand = 0
            for dy in range(-radius, radius + 1):
                for dx in range(-radius, radius + 1):
                    if dy != 0 or dx != 0:
                        ncand += 1
                        cand[ncand, 0], cand[ncand, 1] = oy + dy, ox + dx
            cand[0, 0], cand[0, 1] = oy, ox
            if b - a <= adopt:
                seen = 0
                for t in range(n):
                    ry, rx = qoff[t, 0], qoff[t, 1]
                    if max(abs(ry - oy), abs(rx - ox)) <= radius:
                        continue  # among the shifts already
                    dup = False
                    for u in range(ncand + 1 - seen, ncand + 1):
                        if cand[u, 0] == ry and cand[u, 1] == rx:
                            dup = True
                            break
                    if dup or seen == ADOPT_MAX:
                        continue
                    ncand += 1
                    cand[ncand, 0], cand[ncand, 1] = ry, rx
                    seen += 1
            # each one's summed seam cost to the neighbours, cut short once it reaches the best
            # (terms are never negative); one lower than the best is taken where every pixel of
            # the patch then reads a source pixel of its target's label (its own offset need not)
            best = np.inf
            by, bx = oy, ox
            spread = -1.0  # its spread at its offset, once needed
            least = np.inf
            pick = 0.0  # the best offset's spread
            refused[pid] = -np.inf
            for u in range(ncand + 1):
                cy, cx = cand[u, 0], cand[u, 1]
                e = 0.0
                for t in range(n):
                    if qoff[t, 0] == cy and qoff[t, 1] == cx:
                        continue
                    pair = 0.0  # the pair's two sides read at (cy, cx) against the neighbours' colours
                    for side in range(2):
                        sy, sx = pr[ps + t, 2 * side] + cy, pr[ps + t, 2 * side + 1] + cx
                        d = OUTSIDE
                        if ok[t, side] and 0 <= sy < Hs and 0 <= sx < Ws:
                            d = 0.0
                            for c in range(C):
                                r = img[sy, sx, c] - col[t, side, c]
                                d += r * r
                        pair += d
                    e += pair
                    if e >= best:
                        break
                if e < best and u > 0:
                    for t in range(a, b):
                        sy, sx = order[t, 0] + cy, order[t, 1] + cx  # (a piece's pixels are all of its label)
                        if sy < 0 or sx < 0 or sy >= Hs or sx >= Ws or labels[sy, sx] != lab:
                            e = np.inf
                            break
                    if e < best:  # its label's spread may fall to floor over the step (tot: its value now)
                        if spread < 0.0:
                            spread = _spread(img, mu[lab], order, a, b, oy, ox)
                            least = spread - (tot[lab] - floor[lab])
                        sp = _spread(img, mu[lab], order, a, b, cy, cx)
                        if sp < least:
                            e = np.inf
                            refused[pid] = least
                        else:
                            pick = sp
                if e < best or u == 0:
                    best, by, bx = e, cy, cx
                if u == 0 and not best > 0.0:
                    break
            if by != oy or bx != ox:
                tot[lab] += pick - spread
                for t in range(a, b):
                    ii, jj = order[t, 0], order[t, 1]
                    coords[ii, jj, 0] = ii + by
                    coords[ii, jj, 1] = jj + bx
                clock += 1
                moved_at[pid] = clock
                tried[pid] = -1
                moved += 1
            else:
                tried[pid] = clock
                own[pid] = spread
        moves += moved
        if moved == 0:
            break
    return moves


def shift_patches(coords: np.ndarray, img: np.ndarray, target: np.ndarray, labels: np.ndarray, patch: np.ndarray,
                  radius: int, passes: int, adopt: int = 0, spread_loss: float | None = None) -> tuple[np.ndarray, int]:
    """``coords`` (copied) after ``passes`` passes in which every patch (``patch``: ids from 1,
    4-connected regions of one offset, ``patch.offset_components``) may move whole by up to
    ``radius`` pixels each way to where its seams cost least (Kwatra et al. 2003's cost, as
    ``refine_seams``), as long as each of its pixels then reads a source pixel of its
    target label: a patch magnified from the synthesis is placed to a whole exemplar pixel
    (``factor`` output pixels); this aligns it with its neighbours at the output's
    resolution. A patch of at most ``adopt`` pixels may also take a neighbouring patch's
    offset (``_shift_passes``). A patch across a label border moves as one piece per label. No
    label loses more than ``spread_loss`` (None: ``SPREAD_LOSS``) of its pieces' summed squared tone deviation from its
    mean tone on the source grid (``_spread``): shifts to where seams cost least drew the
    pieces of a label's tails onto its mode (bench_photos: a near-black label's std ratio
    0.88 -> 0.70). Each pass lowers the total ``seam_cost``; pieces keep their pixels; stops
    early when a pass moves nothing. Returns the map and the number of piece moves."""
    coords = np.ascontiguousarray(coords, np.int32).copy()
    img = np.ascontiguousarray(img, np.float32)
    target = np.ascontiguousarray(target, np.int32)
    labels = np.ascontiguousarray(labels, np.int32)
    moves = _shift_passes(coords, img, target, labels, np.ascontiguousarray(patch, np.int64), int(radius), int(adopt),
                          int(passes), 1.0 - (SPREAD_LOSS if spread_loss is None else float(spread_loss)))
    return coords, int(moves)
