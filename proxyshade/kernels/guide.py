"""Guidance synthesis: k-coherent parallel label synthesis with the Chamfer metric.

Bonneel et al. 2010, §4.2, after Lefebvre and Hoppe 2005 (parallel controllable texture
synthesis), on label maps: the state is a map of exemplar coordinates; each level is
upsampled from the coarser one, then corrected in parallel sub-passes (the four pixel
parities, each reading a snapshot, so results do not depend on the thread count), with no
jitter. A pixel's candidates are the k-coherent ones: for each neighbour q in its 3×3
window, the exemplar coordinate that continues q's patch at p, and the k coordinates of
that one's similarity set. The similarity set of an exemplar coordinate holds itself
and k − 1 coordinates picked, by Hochbaum-Shmoys farthest-point traversal in image space,
among the 4k closest in feature space of a seeded sample. Features are 5×5 label windows
of the voting stack, compared with the symmetric Chamfer distance
(``proxyshade.kernels.chamfer``); the guidance adds the Chamfer distance between the
candidate's window and the proxy guide's window (voting pyramid) at the pixel.

Options: ``locked`` label pairs whose border pixels only take candidates of the proxy's
label there (§9.3: "ID boundaries should remain unaltered"), and ``allowed`` label
adjacencies (those of the source and of the proxy): a candidate that would put two labels
side by side which neither input ever has side by side is rejected.

The ``l2`` variant (the paper's Fig. 3 baseline) compares 5×5 windows of label colours
blurred by a Gaussian stack with the L2 norm instead.

Labels here are dense indices 0..n-1.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import JIT, PJIT
from proxyshade.kernels.chamfer import chamfer_bounded, chamfer_masks
from proxyshade.kernels.features import window_masks
from proxyshade.kernels.patch import _label_lists
from proxyshade.kernels.random import uniform

NB = 5
R = 2


class Exemplar(NamedTuple):
    """One level of the label exemplar: ``lab`` (He, We) int32 dense labels, ``masks``
    (He, We, n) uint32 label masks of its 5×5 windows of spacing h (``exemplar_masks``),
    ``col`` (He, We, 3) label colours (the l2 metric; unread by the Chamfer one), ``sim``
    (He, We, k, 2) int32 similarity sets (``similarity_sets``)."""

    lab: np.ndarray
    masks: np.ndarray
    col: np.ndarray
    sim: np.ndarray


class Guide(NamedTuple):
    """The proxy guide at one level: ``masks`` (H, W, n) uint32 label masks of its 5×5
    windows (``grid_masks``), ``col`` (H, W, 75) colour windows (l2; unread by Chamfer),
    ``target`` (H, W) int32 dense labels, ``locked`` (H, W) bool pixels that only take
    candidates of the target's label (``locked_border``), ``allowed`` (n, n) bool label
    adjacencies (``adjacency``)."""

    masks: np.ndarray
    col: np.ndarray
    target: np.ndarray
    locked: np.ndarray
    allowed: np.ndarray


class Rule(NamedTuple):
    """A correction at one level: exemplar spacing ``h``, the weight ``w_proxy`` of the
    agreement with the proxy, ``metric`` 0 (Chamfer) or 1 (l2), ``n`` labels."""

    h: int
    w_proxy: float
    metric: int
    n: int


@njit(**JIT)
def _clamp(v, lo, hi):
    return lo if v < lo else (hi if v > hi else v)


def exemplar_masks(lab, h, n):
    """(He, We, n) uint32 Chamfer label masks of the 5×5 windows of spacing ``h`` (clamped)
    of every exemplar pixel (``features.window_masks``)."""
    return window_masks(lab, h, n)


def grid_masks(lab, n):
    """(H, W, n) uint32 label masks of the 5×5 windows (spacing 1, clamped) of a label map."""
    return window_masks(lab, 1, n)


@njit(**JIT)
def _window_dist(metric, ma, mb, fa, fb):
    if metric == 0:
        return float(chamfer_masks(ma, mb))
    s = 0.0
    for t in range(fa.shape[0]):
        d = fa[t] - fb[t]
        s += d * d
    return s


@njit(**JIT)
def _color_window(col, y, x, h, out):
    """5×5 window (spacing h, clamped) of an (H, W, 3) colour stack, flattened into ``out``."""
    H, W = col.shape[0], col.shape[1]
    k = 0
    for dy in range(-R, R + 1):
        yy = _clamp(y + dy * h, 0, H - 1)
        for dx in range(-R, R + 1):
            xx = _clamp(x + dx * h, 0, W - 1)
            for c in range(3):
                out[k] = col[yy, xx, c]
                k += 1


@njit(**PJIT)
def similarity_sets(lab, masks, col, h, k, sample, seed, metric):
    """(He, We, k, 2) int32: per exemplar pixel, itself then k − 1 coordinates spread by
    farthest-point traversal (Hochbaum-Shmoys) among the 4k closest of ``sample`` seeded
    random ones (ties: the earlier draw); draws within 2h of the pixel are skipped."""
    He, We = lab.shape
    out = np.empty((He, We, k, 2), np.int32)
    for y in prange(He):
        # the index as int64: a parallel loop types it twice (int64, uint64), its callees compile twice
        _similarity_row(np.int64(y), masks, col, h, k, sample, seed, metric, out)
    return out


@njit(**JIT)
def _similarity_row(y, masks, col, h, k, sample, seed, metric, out):
    """Row ``y`` of ``similarity_sets`` (its loop body: a serial kernel compiles faster
    than the same code inside a parallel loop)."""
    He, We = out.shape[0], out.shape[1]
    m = 4 * k
    cand = np.empty((sample, 2), np.int32)
    top = np.empty(m, np.int64)  # draws kept, by increasing distance then draw index
    topd = np.empty(m, np.float64)
    fa = np.empty(75, np.float64)
    fb = np.empty(75, np.float64)
    used = np.empty(m, np.bool_)
    for x in range(We):
        if metric == 1:
            _color_window(col, y, x, h, fa)
        nt = 0
        for s in range(sample):
            cy = int(uniform(seed, y * We + x, 2 * s, 0) * He)
            cx = int(uniform(seed, y * We + x, 2 * s + 1, 0) * We)
            cand[s, 0] = cy
            cand[s, 1] = cx
            if abs(cy - y) <= 2 * h and abs(cx - x) <= 2 * h:
                continue  # trivially similar neighbours are not alternatives
            if metric == 1:
                _color_window(col, cy, cx, h, fb)
                d = _window_dist(1, masks[y, x], masks[cy, cx], fa, fb)
                if nt == m and d >= topd[m - 1]:
                    continue
            else:
                bound = np.int64(1) << 40
                if nt == m:
                    bound = np.int64(topd[m - 1]) - 1  # a tie with the last kept loses (later draw)
                    if bound < 0:
                        continue
                e = chamfer_bounded(masks[y, x], masks[cy, cx], bound)
                if e > bound:
                    continue
                d = float(e)
            # insert after every kept draw of distance <= d
            t = nt if nt < m else m - 1
            while t > 0 and topd[t - 1] > d:
                if t < m:
                    top[t] = top[t - 1]
                    topd[t] = topd[t - 1]
                t -= 1
            top[t] = s
            topd[t] = d
            if nt < m:
                nt += 1
        out[y, x, 0, 0] = y
        out[y, x, 0, 1] = x
        chosen = 1
        used[:] = False
        while chosen < k:
            best = -1
            bestd = -1.0
            for t in range(nt):
                if used[t]:
                    continue
                cy, cx = cand[top[t], 0], cand[top[t], 1]
                dmin = np.inf
                for c in range(chosen):
                    dd = float((cy - out[y, x, c, 0]) ** 2 + (cx - out[y, x, c, 1]) ** 2)
                    dmin = min(dmin, dd)
                if dmin > bestd:
                    bestd = dmin
                    best = t
            if best < 0:
                out[y, x, chosen, 0] = y
                out[y, x, chosen, 1] = x
            else:
                used[best] = True
                out[y, x, chosen, 0] = cand[top[best], 0]
                out[y, x, chosen, 1] = cand[top[best], 1]
            chosen += 1


# serial: 0.03 ms at the guide size; a parallel loop compiled 0.5 s longer (bench_compile --mode entries)
@njit(**JIT)
def _init_state(target, He, We, starts, lists, seed):
    H, W = target.shape
    coords = np.empty((H, W, 2), np.int32)
    for i in range(H):
        for j in range(W):
            l = target[i, j]
            u = uniform(seed, i, j, 0)
            cnt = starts[l + 1] - starts[l]
            if cnt > 0:
                f = lists[starts[l] + int(u * cnt)]
            else:
                f = int(u * He * We)
            coords[i, j, 0] = f // We
            coords[i, j, 1] = f % We
    return coords


def init_state(target, ex_lab, seed):
    """Coarsest-level state: each pixel an exemplar coordinate of the target's label
    (seeded choice among that label's exemplar pixels in raster order; any pixel when the
    label is absent)."""
    target = np.ascontiguousarray(target, np.int32)
    ex_lab = np.ascontiguousarray(ex_lab, np.int32)
    n = int(max(target.max(), ex_lab.max())) + 1
    starts, lists = _label_lists(ex_lab, n)
    return _init_state(target, ex_lab.shape[0], ex_lab.shape[1], starts, lists, seed)


# serial: 0.07 ms a call at the guide size; a parallel loop compiled 0.3 s longer
@njit(**JIT)
def upsample_state(coords, h, He, We, H, W):
    """Children of a coarser level's coordinates: coords + h·d for d in {0, 1}², clamped."""
    out = np.empty((H, W, 2), np.int32)
    for i in range(H):
        for j in range(W):
            pi = min(i // 2, coords.shape[0] - 1)
            pj = min(j // 2, coords.shape[1] - 1)
            out[i, j, 0] = _clamp(coords[pi, pj, 0] + h * (i % 2), 0, He - 1)
            out[i, j, 1] = _clamp(coords[pi, pj, 1] + h * (j % 2), 0, We - 1)
    return out


@njit(**JIT)
def _candidate(q, i, j, coords_old, sim, h):
    """Candidate ``q`` of pixel (i, j): -1 is the current coordinate, then for each 3×3
    neighbour (row-major) the k entries of the similarity set ``sim`` (He, We, k, 2) of the
    coordinate that continues the neighbour's patch at (i, j)."""
    H, W = coords_old.shape[0], coords_old.shape[1]
    He, We, k = sim.shape[0], sim.shape[1], sim.shape[2]
    if q < 0:
        return coords_old[i, j, 0], coords_old[i, j, 1]
    nb = q // k
    t = q % k
    ii = _clamp(i + nb // 3 - 1, 0, H - 1)
    jj = _clamp(j + nb % 3 - 1, 0, W - 1)
    by = _clamp(coords_old[ii, jj, 0] - h * (ii - i), 0, He - 1)
    bx = _clamp(coords_old[ii, jj, 1] - h * (jj - j), 0, We - 1)
    return sim[by, bx, t, 0], sim[by, bx, t, 1]


@njit(inline="always", **JIT)
def _correct_pixel(i, j, coords_old, ex, guide, rule, scratch):
    """The corrected coordinates of pixel (i, j): among its candidates, the first one
    minimizing d(synthesized window, candidate) + w_proxy d(proxy window, candidate).
    Repeated candidates are evaluated once and Chamfer sums stop early once they cannot
    win (neither changes the result). ``scratch``: the caller's buffers (ms, fs, fe, seen)."""
    ex_lab, ex_masks, ex_col, sim = ex
    tgt_masks, tgt_col, target, locked_mask, allowed = guide
    h, w_proxy, metric, n = rule
    ms, fs, fe, seen = scratch
    H, W = coords_old.shape[0], coords_old.shape[1]
    He, We = ex_lab.shape
    k = sim.shape[2]
    # the synthesized neighbourhood: labels (colours) under the current coordinates
    for l in range(n):
        ms[l] = 0
    kk = 0
    for dy in range(-R, R + 1):
        ii = _clamp(i + dy, 0, H - 1)
        for dx in range(-R, R + 1):
            jj = _clamp(j + dx, 0, W - 1)
            ey, ex = coords_old[ii, jj, 0], coords_old[ii, jj, 1]
            ms[ex_lab[ey, ex]] |= np.uint32(1) << np.uint32(kk)
            if metric == 1:
                for c in range(3):
                    fs[3 * kk + c] = ex_col[ey, ex, c]
            kk += 1
    best_y, best_x = coords_old[i, j, 0], coords_old[i, j, 1]
    best = np.inf
    nseen = 0
    for q in range(-1, 9 * k):
        cy, cx = _candidate(q, i, j, coords_old, sim, h)
        key = np.int64(cy) * We + cx
        dup = False
        for u in range(nseen):
            if seen[u] == key:
                dup = True
                break
        if dup:
            continue  # same cost as its first occurrence: cannot win (strict <)
        seen[nseen] = key
        nseen += 1
        lc = ex_lab[cy, cx]
        if locked_mask[i, j] and lc != target[i, j]:
            continue
        ok = True
        for d in range(4):
            ni = i + (d == 0) - (d == 1)
            nj = j + (d == 2) - (d == 3)
            if ni < 0 or ni >= H or nj < 0 or nj >= W:
                continue
            ln = ex_lab[coords_old[ni, nj, 0], coords_old[ni, nj, 1]]
            if not allowed[lc, ln]:
                ok = False
        if not ok:
            continue
        if metric == 1:
            _color_window(ex_col, cy, cx, h, fe)
            d1 = _window_dist(1, ms, ms, fs, fe)
            d2 = _window_dist(1, ms, ms, tgt_col[i, j], fe)
        else:
            # exact Chamfer sums unless already too large to win; a margin of one
            # unit keeps float rounding of d1 + w d2 out of the decision
            b1 = np.int64(1) << 40
            if best < 1e12:
                b1 = np.int64(best) + 1
            e1 = chamfer_bounded(ms, ex_masks[cy, cx], b1)
            if e1 > b1:
                continue
            d1 = float(e1)
            if w_proxy > 0.0 and best < 1e12:
                b2 = np.int64((best - d1) / w_proxy) + 1
            else:
                b2 = np.int64(1) << 40
            e2 = chamfer_bounded(tgt_masks[i, j], ex_masks[cy, cx], b2)
            if e2 > b2:
                continue
            d2 = float(e2)
        c = d1 + w_proxy * d2
        if c < best:
            best = c
            best_y, best_x = cy, cx
    return best_y, best_x


@njit(**PJIT)
def _subpass(coords_old, coords_new, active, parity, ex, guide, rule):
    """Correct the ``active`` pixels of ``parity`` (i % 2, j % 2) (``_correct_pixel``); the
    others keep ``coords_new``'s coordinates."""
    par_i, par_j = parity
    H = coords_old.shape[0]
    for i2 in prange((H - par_i + 1) // 2):
        _subpass_row(np.int64(par_i + 2 * i2), par_j, coords_old, coords_new, active, ex, guide, rule)


@njit(**JIT)
def _subpass_row(i, par_j, coords_old, coords_new, active, ex, guide, rule):
    """Row ``i`` of ``_subpass`` (its loop body: a serial kernel compiles faster than the
    same code inside a parallel loop, where the loop index takes two types)."""
    W = coords_old.shape[1]
    k = ex.sim.shape[2]
    ms = np.zeros(rule.n, np.uint32)
    fs = np.empty(75, np.float64)
    fe = np.empty(75, np.float64)
    seen = np.empty(9 * k + 1, np.int64)
    for j in range(par_j, W, 2):
        if active[i, j]:
            coords_new[i, j, 0], coords_new[i, j, 1] = _correct_pixel(i, j, coords_old, ex, guide, rule, (ms, fs, fe, seen))


def correct(coords, ex: Exemplar, guide: Guide, rule: Rule, *, passes, active=None):
    """``passes`` correction passes of four parity sub-passes each; returns the new state.
    ``active`` (H, W bool, default every pixel): only those pixels are corrected, every other
    one keeps its coordinates and is context for its neighbours (an edit's progressive
    update, §7: "we initialize flagged areas with the new labels and perform correction
    passes")."""
    rule = Rule(int(rule.h), float(rule.w_proxy), int(rule.metric), int(rule.n))
    coords = coords.copy()
    active = np.ones(coords.shape[:2], np.bool_) if active is None else np.ascontiguousarray(active, np.bool_)
    if not active.any():
        return coords
    # A pixel's correction reads only the state in its 5×5 window (the synthesized window,
    # the 3×3 neighbours' candidates, the 4-neighbours' labels): one corrected before, none of
    # whose window changed since (nor in the sub-pass that corrected it, whose snapshot it
    # read), would come out as it is, so it is not corrected again (the same result).
    H, W = coords.shape[:2]
    changed = np.full((H, W), -1, np.int64)  # the sub-pass that last changed each pixel
    tried = np.full((H, W), -1, np.int64)  # ... that last corrected it (-1: none yet)
    s = 0
    for _ in range(passes):
        for par_i, par_j in ((0, 0), (1, 1), (0, 1), (1, 0)):
            need = np.zeros((H, W), np.bool_)
            sub = (slice(par_i, None, 2), slice(par_j, None, 2))
            need[sub] = active[sub] & (_max5(changed)[sub] >= tried[sub])
            snap = coords.copy()
            if need.any():
                _subpass(snap, coords, need, (par_i, par_j), ex, guide, rule)
            changed[(coords != snap).any(-1)] = s
            tried[need] = s
            s += 1
    return coords


def _max5(a: np.ndarray) -> np.ndarray:
    """The largest of ``a`` over each pixel's 5×5 window (clamped at the borders)."""
    p = np.pad(a, R, mode="edge")
    rows = p[:, 0:-2 * R].copy()
    for d in range(1, 2 * R + 1):
        np.maximum(rows, p[:, d:d + a.shape[1]], out=rows)
    out = rows[0:a.shape[0]].copy()
    for d in range(1, 2 * R + 1):
        np.maximum(out, rows[d:d + a.shape[0]], out=out)
    return out


def adjacency(*label_maps: np.ndarray, n: int) -> np.ndarray:
    """(n, n) bool: labels that are 4-adjacent (or equal) somewhere in any of the maps."""
    A = np.eye(n, dtype=bool)
    for m in label_maps:
        if m.size and (m.min() < 0 or m.max() >= n):
            raise IndexError(f"label indices must lie in 0..{n - 1}")
        for a, b in ((m[:, :-1], m[:, 1:]), (m[:-1, :], m[1:, :])):
            # the pairs present, counted (one pass; a scattered assignment per pixel pair was slower)
            seen = np.bincount((a.astype(np.int64) * n + b).ravel(), minlength=n * n)[:n * n].reshape(n, n) > 0
            A |= seen | seen.T
    return A


def new_adjacencies(result: np.ndarray, *inputs: np.ndarray, n: int) -> set[tuple[int, int]]:
    """Label pairs side by side in ``result`` but in none of ``inputs``."""
    have = adjacency(result, n=n)
    ref = adjacency(*inputs, n=n)
    return {(int(a), int(b)) for a, b in zip(*np.nonzero(have & ~ref)) if a < b}


def locked_border(target: np.ndarray, pairs: list[tuple[int, int]], radius: int = 2) -> np.ndarray:
    """Pixels within ``radius`` of a border between the two labels of a locked pair."""
    out = np.zeros(target.shape, bool)
    H, W = target.shape
    for a, b in pairs:
        border = np.zeros(target.shape, bool)
        for da, db in ((target[:, :-1], target[:, 1:]), (target[:-1, :], target[1:, :])):
            hit = ((da == a) & (db == b)) | ((da == b) & (db == a))
            if da.shape[1] != W:
                border[:, :-1] |= hit
                border[:, 1:] |= hit
            else:
                border[:-1, :] |= hit
                border[1:, :] |= hit
        ii, jj = np.nonzero(border)
        for di in range(-radius, radius + 1):
            for dj in range(-radius, radius + 1):
                out[np.clip(ii + di, 0, H - 1), np.clip(jj + dj, 0, W - 1)] = True
    return out
