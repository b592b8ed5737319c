"""Kernels of annotated-exemplar synthesis (Diamanti, Barnes, Paris, Shechtman and
Sorkine-Hornung, "Synthesis of complex image appearance from limited exemplars", TOG 2015).

Annotation points are vectors in [0, 1]^d. Distances in annotation space are measured in
the ε-scaled metric ``sqrt(sum(((p_k - a_k) / eps_k)^2))``: an axis-aligned ellipsoid with
semi-axes ``s * eps_k`` around ``a`` is the set of points at scaled distance <= s.

- ``ball_scale``: for each target point, the smallest scaling ``s`` of the ε-ellipsoid that
  holds ``N`` source points (points given once with a multiplicity): R⁰_ik = s·ε_k, and the
  paper's R_ik = max(ε_k, R⁰_ik) = ε_k·max(1, s).
- ``eq2_weights``: W_i(a) = (1/Z) Σ_k ε_k / g(R_ik(a) − ε_k) with the clip of g.
- ``mean_shift``: Gaussian mean shift of weighted points (every point to its mode).
- ``nearest_init`` / ``patchmatch`` / ``vote``: generalized PatchMatch restricted to one
  cluster and to each target pixel's ε-ball (a ``Ball``; candidates outside are
  rejected), scan order reversed every iteration, random search over the whole source,
  an occurrence penalty, two row bands in parallel that exchange their occurrence
  changes in fixed steps (the result does not depend on the thread count), and the
  average of overlapping patches.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import JIT, PJIT
from proxyshade.kernels.random import rand


@njit(inline="always", **JIT)
def _sdist2(p, a, inv_eps):
    s = 0.0
    for k in range(p.shape[0]):
        t = (np.float64(p[k]) - np.float64(a[k])) * inv_eps[k]
        s += t * t
    return s


@njit(**PJIT)
def _ball_scale(pts, counts, inv_eps, targets, n_hold, out):
    u = pts.shape[0]
    for t in prange(targets.shape[0]):
        d = np.empty(u)
        for p in range(u):
            d[p] = _sdist2(pts[p], targets[t], inv_eps)
        order = np.argsort(d, kind="mergesort")
        acc = 0
        r = np.inf
        for q in range(u):
            acc += counts[order[q]]
            if acc >= n_hold:
                r = np.sqrt(d[order[q]])
                break
        out[t] = r


def ball_scale(pts: np.ndarray, counts: np.ndarray, eps: np.ndarray, targets: np.ndarray, n_hold: int) -> np.ndarray:
    """The smallest scaling ``s`` of the ε-ellipsoid around each target point that holds
    ``n_hold`` source points.

    pts (U, d) distinct source points with ``counts`` (U,) pixels each; targets (M, d).
    Returns (M,) float64: the ``n_hold``-th smallest scaled distance counting
    multiplicities (inf when fewer points exist).
    """
    pts = np.ascontiguousarray(pts, np.float64)
    targets = np.ascontiguousarray(targets, np.float64)
    out = np.empty(targets.shape[0], np.float64)
    _ball_scale(pts, np.ascontiguousarray(counts, np.int64), 1.0 / np.asarray(eps, np.float64),
                targets, int(n_hold), out)
    return out


def eq2_weights(s: np.ndarray, eps: np.ndarray) -> np.ndarray:
    """Eq. 2: W_i(a) = (1/Z) Σ_k ε_k / g(R_ik(a) − ε_k), R_ik = ε_k·max(1, s_i(a)).

    s (M, C): the ball scales of M target points for C clusters. g(x) = x for x > 0;
    at or below zero g is clipped to 0.8·min_a{R_ik(a) − ε_k | R_ik(a) − ε_k > 0} (per
    cluster and dimension; the minimum over all clusters where a cluster has no positive
    value, 1 where none has). Returns (M, C) float64 summing to 1 over the clusters.
    """
    s = np.asarray(s, np.float64)
    eps = np.asarray(eps, np.float64)
    x = eps[None, None, :] * np.maximum(s[:, :, None] - 1.0, 0.0)  # (M, C, d) R_ik - eps_k
    pos = x > 0
    big = np.where(pos, x, np.inf)
    clip = big.min(axis=0)  # (C, d)
    glob = clip.min(axis=0)  # (d,)
    glob = np.where(np.isfinite(glob), glob, 1.0)
    clip = 0.8 * np.where(np.isfinite(clip), clip, glob[None, :])
    g = np.where(pos, x, clip[None, :, :])
    w = (eps[None, None, :] / g).sum(axis=2)
    return w / w.sum(axis=1, keepdims=True)


@njit(**PJIT)
def _mean_shift(pts, counts, h, iters, tol, out):
    u, d = pts.shape
    inv = 1.0 / (2.0 * h * h)
    for p in prange(u):
        x = pts[p].copy()
        for _ in range(iters):
            num = np.zeros(d)
            den = 0.0
            for q in range(u):
                r2 = 0.0
                for k in range(d):
                    t = x[k] - pts[q, k]
                    r2 += t * t
                wq = counts[q] * np.exp(-r2 * inv)
                den += wq
                for k in range(d):
                    num[k] += wq * pts[q, k]
            step = 0.0
            for k in range(d):
                nk = num[k] / den
                step += (nk - x[k]) ** 2
                x[k] = nk
            if step < tol * tol:
                break
        out[p] = x


def mean_shift(pts: np.ndarray, counts: np.ndarray, bandwidth: float, *, iters: int = 100,
               tol: float = 1e-5) -> np.ndarray:
    """Gaussian mean shift: each point (with multiplicity ``counts``) moved to its mode.

    Returns (U, d) float64 modes (the iteration stops when a step is below ``tol``)."""
    pts = np.ascontiguousarray(pts, np.float64)
    out = np.empty_like(pts)
    _mean_shift(pts, np.ascontiguousarray(counts, np.float64), float(bandwidth), int(iters), float(tol), out)
    return out


def group_modes(modes: np.ndarray, counts: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Group converged modes closer than ``radius``: returns (labels (U,) int32 from 0,
    centres (C, d)); clusters ordered by decreasing pixel count (ties: first point)."""
    centres: list[np.ndarray] = []
    lab = np.empty(len(modes), np.int32)
    for p, m in enumerate(modes):
        for c, z in enumerate(centres):
            if np.sqrt(((m - z) ** 2).sum()) < radius:
                lab[p] = c
                break
        else:
            lab[p] = len(centres)
            centres.append(m)
    size = np.bincount(lab, weights=counts, minlength=len(centres))
    order = np.argsort(-size, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return rank[lab].astype(np.int32), np.array(centres)[order]


class Ball(NamedTuple):
    """Where the target pixels of one cluster may copy from (``patchmatch``, ``repair``):
    source pixels that are ``usable``, in ``cluster`` and inside the target pixel's ε-ball
    (scaled annotation distance <= max(1, tgt_s)). Build it with ``Ball.of``."""

    src_ann: np.ndarray  # (H, W, d) float64
    src_cluster: np.ndarray  # (H, W) int32
    cluster: int
    usable: np.ndarray  # (H, W) bool
    inv_eps: np.ndarray  # (d,) float64: 1 / ε per annotation
    tgt_ann: np.ndarray  # (h, w, d) float64
    tgt_s: np.ndarray  # (h, w) float64: the ball scale of each target pixel

    @classmethod
    def of(cls, src_ann, src_cluster, cluster, usable, eps, tgt_ann, tgt_s) -> "Ball":
        """The record with the types the kernels take (``eps``: ε per annotation)."""
        return cls(np.ascontiguousarray(src_ann, np.float64), np.ascontiguousarray(src_cluster, np.int32),
                   int(cluster), np.ascontiguousarray(usable, np.bool_), 1.0 / np.asarray(eps, np.float64),
                   np.ascontiguousarray(tgt_ann, np.float64), np.ascontiguousarray(tgt_s, np.float64))


@njit(inline="always", **JIT)
def _ok(ball, cy, cx, i, j):
    """Whether source pixel (cy, cx) is allowed for target pixel (i, j)."""
    H, W = ball.src_cluster.shape
    if cy < 0 or cy >= H or cx < 0 or cx >= W:
        return False
    if not ball.usable[cy, cx] or ball.src_cluster[cy, cx] != ball.cluster:
        return False
    s_max = max(1.0, ball.tgt_s[i, j])
    return _sdist2(ball.src_ann[cy, cx], ball.tgt_ann[i, j], ball.inv_eps) <= s_max * s_max * (1.0 + 1e-9)


@njit(inline="always", **JIT)
def _pdist(src, tgt, nf, half_width, i, j, cy, cx, bound):
    """Sum of squared differences between the target patch at (i, j) and the source patch
    at (cy, cx), which lies whole inside the source; target pixels outside are skipped.
    src (H, W·nf), tgt (h, w·nf) float32 rows of nf features per pixel. Summed in float32,
    eight running sums per patch row, in a fixed order; returns once a row's total exceeds
    ``bound``."""
    h = tgt.shape[0]
    w = tgt.shape[1] // nf
    j0 = max(j - half_width, 0)
    n = (min(j + half_width + 1, w) - j0) * nf
    so = (cx - j + j0) * nf
    to = j0 * nf
    d = np.float32(0.0)
    for dy in range(-half_width, half_width + 1):
        ti = i + dy
        if ti < 0 or ti >= h:
            continue
        sy = cy + dy
        a0 = np.float32(0.0)
        a1 = np.float32(0.0)
        a2 = np.float32(0.0)
        a3 = np.float32(0.0)
        a4 = np.float32(0.0)
        a5 = np.float32(0.0)
        a6 = np.float32(0.0)
        a7 = np.float32(0.0)
        t = 0
        while t + 8 <= n:
            e0 = src[sy, so + t] - tgt[ti, to + t]
            e1 = src[sy, so + t + 1] - tgt[ti, to + t + 1]
            e2 = src[sy, so + t + 2] - tgt[ti, to + t + 2]
            e3 = src[sy, so + t + 3] - tgt[ti, to + t + 3]
            e4 = src[sy, so + t + 4] - tgt[ti, to + t + 4]
            e5 = src[sy, so + t + 5] - tgt[ti, to + t + 5]
            e6 = src[sy, so + t + 6] - tgt[ti, to + t + 6]
            e7 = src[sy, so + t + 7] - tgt[ti, to + t + 7]
            a0 += e0 * e0
            a1 += e1 * e1
            a2 += e2 * e2
            a3 += e3 * e3
            a4 += e4 * e4
            a5 += e5 * e5
            a6 += e6 * e6
            a7 += e7 * e7
            t += 8
        while t < n:
            e0 = src[sy, so + t] - tgt[ti, to + t]
            a0 += e0 * e0
            t += 1
        d += ((a0 + a1) + (a2 + a3)) + ((a4 + a5) + (a6 + a7))
        if d > bound:
            return d
    return d


def _rows(a):
    """(H, W, F) -> contiguous float32 (H, W·F) and F."""
    a = np.ascontiguousarray(a, np.float32)
    return a.reshape(a.shape[0], -1), a.shape[2]


def patch_distance(src, tgt, half_width, i, j, cy, cx):
    """Sum of squared feature differences between the target patch at (i, j) and the
    source patch at (cy, cx) (whole inside the source; target pixels outside the image
    skipped), as PatchMatch computes it (float32)."""
    H, W = src.shape[:2]
    if not (half_width <= cy < H - half_width and half_width <= cx < W - half_width):
        raise ValueError(f"source patch at ({cy}, {cx}) is not whole inside the {H}x{W} source")
    s, nf = _rows(src)
    t, _ = _rows(tgt)
    return float(_pdist(s, t, nf, int(half_width), int(i), int(j), int(cy), int(cx), np.inf))


@njit(**PJIT)
def _nearest_bins(bins, targets, inv_eps, out):
    for t in prange(targets.shape[0]):
        best = 0
        bd = np.inf
        for b in range(bins.shape[0]):
            d = _sdist2(bins[b], targets[t], inv_eps)
            if d < bd:
                bd = d
                best = b
        out[t] = best


def nearest_bins(bins, targets, eps) -> np.ndarray:
    """Index of the nearest of ``bins`` (B, d) to each of ``targets`` (M, d) in the
    ε-scaled metric (the first on ties). Returns (M,) int64."""
    out = np.empty(len(targets), np.int64)
    _nearest_bins(np.ascontiguousarray(bins, np.float64), np.ascontiguousarray(targets, np.float64),
                  1.0 / np.asarray(eps, np.float64), out)
    return out


@njit(**PJIT)
def _draw(tb, bin_start, bin_count, order, W, seed, oy, ox):
    h, w = tb.shape
    for i in prange(h):
        for j in range(w):
            b = tb[i, j]
            c = order[bin_start[b] + rand(seed, i * w + j, 0x1417, 0) % bin_count[b]]
            oy[i, j] = c // W
            ox[i, j] = c % W


def draw_members(tb, bin_start, bin_count, order, src_width, seed):
    """For each target pixel a random source pixel of its bin ``tb`` (h, w): one of
    ``order[bin_start[b]:bin_start[b]+bin_count[b]]`` (flat indices). Returns (y, x) int32."""
    h, w = tb.shape
    oy = np.empty((h, w), np.int32)
    ox = np.empty((h, w), np.int32)
    _draw(np.ascontiguousarray(tb, np.int64), bin_start.astype(np.int64), bin_count.astype(np.int64),
          order.astype(np.int64), int(src_width), int(seed), oy, ox)
    return oy, ox


def nearest_init(tgt_ann, bins, bin_start, bin_count, order, src_width, eps, seed):
    """Each target pixel starts at a source pixel whose annotation is the most similar:
    a random pixel of the nearest annotation bin (``nearest_bins``, ``draw_members``)."""
    h, w, d = tgt_ann.shape
    tb = nearest_bins(bins, np.asarray(tgt_ann).reshape(-1, d), eps).reshape(h, w)
    return draw_members(tb, bin_start, bin_count, order, src_width, seed)


@njit(**PJIT)
def _repair(ball, ny, nx, iy, ix):
    h, w = ny.shape
    for i in prange(h):
        for j in range(w):
            if not _ok(ball, ny[i, j], nx[i, j], i, j):
                ny[i, j] = iy[i, j]
                nx[i, j] = ix[i, j]


def repair(ball: Ball, ny, nx, iy, ix):
    """Replace (in place) every entry of (ny, nx) that the ``Ball`` does not allow by the
    start (iy, ix)."""
    _repair(ball, ny, nx, iy, ix)


@njit(inline="always", **JIT)
def _overlap(dy, dx, p):
    """Pixels shared by two p×p patches whose centres are (dy, dx) apart."""
    return max(0, p - abs(dy)) * max(0, p - abs(dx))


@njit(inline="always", **JIT)
def _move(omega, half_width, cy, cx, inc):
    """Add ``inc`` times one patch at (cy, cx) to the occurrence sums ``omega``."""
    H, W = omega.shape
    p = 2 * half_width + 1
    for y in range(max(cy - 2 * half_width, 0), min(cy + 2 * half_width + 1, H)):
        for x in range(max(cx - 2 * half_width, 0), min(cx + 2 * half_width + 1, W)):
            omega[y, x] += inc * _overlap(y - cy, x - cx, p)


@njit(**PJIT)
def _tent_rows(a, half_width, out):
    """out[y, x] = Σ_b a[y, b] · max(0, 2 half_width + 1 − |b − x|): along each row, how many pixels
    the patch centred at x shares with each patch centred at b, weighted by a (one axis of
    the separable overlap)."""
    H, W = a.shape
    p = 2 * half_width + 1
    for y in prange(H):
        for x in range(W):
            s = 0
            for b in range(max(x - 2 * half_width, 0), min(x + 2 * half_width + 1, W)):
                s += a[y, b] * max(0, p - abs(b - x))
            out[y, x] = s


@njit(**PJIT)
def _occurrences(ny, nx, half_width, omega):
    """omega[c]: over the source patch at c, the sum of how many target patches (the
    source patch of each target pixel) hold each of its pixels, i.e. Σ_b count[b]·(pixels
    patch c shares with patch b); the overlap is separable (a 1-D tent per axis)."""
    H, W = omega.shape
    h, w = ny.shape
    count = np.zeros((H, W), np.int32)
    for i in range(h):
        for j in range(w):
            count[ny[i, j], nx[i, j]] += 1
    rows = np.empty((H, W), np.int32)
    _tent_rows(count, half_width, rows)
    _tent_rows(rows.T, half_width, omega.T)  # the columns' pass: rows of the transposed views


def occurrences(ny, nx, half_width, shape) -> np.ndarray:
    """(H, W) int32 of ``shape``: for each source patch centre, how many of the target's
    patches (the source patch at (ny, nx) of each target pixel, whole inside the source)
    hold each pixel of that source patch, summed over the patch."""
    omega = np.empty(shape, np.int32)
    _occurrences(np.ascontiguousarray(ny, np.int32), np.ascontiguousarray(nx, np.int32), int(half_width), omega)
    return omega


class Search(NamedTuple):
    """How one PatchMatch iteration searches (``_pm_sweep``)."""

    half_width: int  # patch half-width
    seed: int
    it: int  # the iteration: its parity sets the scan direction
    lam: float  # occurrence penalty per covering patch pixel


BANDS = 2  # row bands of the target a PatchMatch sweep runs in parallel (fixed: the result never depends on the threads)
PHASES = 8  # steps of each band, between which the bands exchange their changes to the occurrence sums


@njit(**PJIT)
def _pm_sweep(src, tgt, nf, ball, members, search, ny, nx, nd):
    """One PatchMatch iteration. The target is cut in ``BANDS`` bands of rows, each scanned
    in order (reversed on odd iterations) on its own thread, in ``PHASES`` steps. Each
    band keeps its own copy of the occurrence sums, updated at each accepted candidate (as
    EbSynth does); between steps every band adds the others' changes of the step before
    (one move per changed pixel), so no band goes more than a step without seeing the
    others'. A band reads its own entries as they change and the others' as they were
    when the iteration began. Every number drawn is named by (pixel, iteration,
    candidate): the result does not depend on the thread count."""
    half_width, seed, it, lam = search.half_width, search.seed, search.it, search.lam
    H = src.shape[0]
    W = src.shape[1] // nf
    h, w = ny.shape
    nm = members.shape[0]
    q = 1 if it % 2 == 0 else -1
    p2 = (2 * half_width + 1) ** 2
    bh = (h + BANDS - 1) // BANDS  # rows per band
    step = (bh + PHASES - 1) // PHASES  # rows per step
    om = np.empty((BANDS, H, W), np.int32)
    _occurrences(ny, nx, half_width, om[0])
    for b in range(1, BANDS):
        om[b] = om[0]
    py = ny.copy()  # the entries at the iteration's start, read across band borders
    px = nx.copy()
    moves = np.empty((2, BANDS, step * w, 4), np.int32)  # per step parity and band: old (y, x), new (y, x)
    nmoves = np.zeros((2, BANDS), np.int64)
    for ph in range((bh + step - 1) // step):
        now = ph % 2
        for b in prange(BANDS):
            own = om[b]
            for o in range(BANDS):  # the other bands' moves of the step before
                if o != b:
                    for e in range(nmoves[1 - now, o]):
                        _move(own, half_width, moves[1 - now, o, e, 0], moves[1 - now, o, e, 1], -1)
                        _move(own, half_width, moves[1 - now, o, e, 2], moves[1 - now, o, e, 3], 1)
            lo = b * bh
            hi = min(h, lo + bh)
            n = max(hi - lo, 0) * w
            made = 0
            for k in range(min(ph * step, bh) * w, min((ph + 1) * step, bh) * w):
                if k >= n:
                    break
                kk = lo * w + (k if q == 1 else n - 1 - k)
                i = kk // w
                j = kk % w
                oy, ox = ny[i, j], nx[i, j]
                cur = nd[i, j] + lam * own[oy, ox]  # only this pixel moves its own patch
                for c in range(2 + 12 + 2):
                    if c < 2:  # propagation from the previous pixel of the row and of the column
                        yy = i if c == 0 else i - q
                        xx = j - q if c == 0 else j
                        if yy < 0 or yy >= h or xx < 0 or xx >= w:
                            continue
                        if lo <= yy < hi:
                            cy = ny[yy, xx] + (i - yy)
                            cx = nx[yy, xx] + (j - xx)
                        else:
                            cy = py[yy, xx] + (i - yy)
                            cx = px[yy, xx] + (j - xx)
                    elif c < 14:  # random search around the best, radius halving from the whole source
                        R = max(H, W) >> (c - 2)
                        if R < 1:
                            continue
                        y0, y1 = max(ny[i, j] - R, half_width), min(ny[i, j] + R, H - 1 - half_width)
                        x0, x1 = max(nx[i, j] - R, half_width), min(nx[i, j] + R, W - 1 - half_width)
                        if y1 < y0 or x1 < x0:
                            continue
                        r = rand(seed, kk, it * 64 + c, 1)  # 53 bits: the low 26 for y, the high 27 for x
                        cy = y0 + (r & 0x3FFFFFF) % (y1 - y0 + 1)
                        cx = x0 + (r >> 26) % (x1 - x0 + 1)
                    else:  # a jump anywhere in the cluster (kept only inside the ball)
                        m = members[rand(seed, kk, it * 64 + c, 3) % nm]
                        cy = m // W
                        cx = m % W
                    by, bx = ny[i, j], nx[i, j]
                    inside = half_width <= cy < H - half_width and half_width <= cx < W - half_width
                    if (cy == by and cx == bx) or not inside:
                        continue
                    if not _ok(ball, cy, cx, i, j):
                        continue
                    pen = lam * (own[cy, cx] + p2)
                    if pen >= cur:
                        continue
                    d = _pdist(src, tgt, nf, half_width, i, j, cy, cx, cur - pen)
                    if d + pen < cur:
                        _move(own, half_width, by, bx, -1)
                        _move(own, half_width, cy, cx, 1)
                        ny[i, j] = cy
                        nx[i, j] = cx
                        nd[i, j] = d
                        cur = d + lam * own[cy, cx]
                if ny[i, j] != oy or nx[i, j] != ox:
                    moves[now, b, made, 0] = oy
                    moves[now, b, made, 1] = ox
                    moves[now, b, made, 2] = ny[i, j]
                    moves[now, b, made, 3] = nx[i, j]
                    made += 1
            nmoves[now, b] = made


@njit(**PJIT)
def _pm_score(src, tgt, nf, half_width, ny, nx, nd):
    h, w = ny.shape
    for i in prange(h):
        for j in range(w):
            nd[i, j] = _pdist(src, tgt, nf, half_width, i, j, ny[i, j], nx[i, j], np.inf)


def patchmatch(src, tgt, ball: Ball, ny, nx, *, half_width, iterations, seed, members=None, uniformity=0.0):
    """Generalized PatchMatch in one cluster: for each target pixel the source patch centre
    (ny, nx) minimising the feature distance (``patch_distance``) plus a uniformity
    penalty, among the source pixels the ``Ball`` allows (usable, in the cluster, inside
    the pixel's ε-ball). (ny, nx) must start allowed (``nearest_init``, ``repair``);
    entries are clipped to centres of whole patches inside the source.

    The penalty (Kaspar et al. 2015, as EbSynth counts it) is ``uniformity`` times the
    number of target patches covering the candidate's source patch (``occurrences``), over
    what an even use of the source gives per patch. Iterations scan the target in order,
    reversed on odd iterations (propagation from the left and upper neighbours, then from
    the right and lower ones), in bands of ``BAND`` rows run in parallel (``_pm_sweep``);
    random search draws in windows around the best that halve from the whole source, then
    two jumps anywhere in the cluster (``members``: flat indices of the cluster's usable
    pixels). The result does not depend on the thread count.

    src (H, W, F), tgt (h, w, F) float32 features. Returns (ny, nx, nd): nd (float32) the
    patch distances without the penalty.
    """
    s, nf = _rows(src)
    t, _ = _rows(tgt)
    if members is None:
        members = np.flatnonzero(ball.usable & (ball.src_cluster == ball.cluster)).astype(np.int64)
    H, W = src.shape[:2]
    if H <= 2 * half_width or W <= 2 * half_width:
        raise ValueError(f"source {H}x{W} is smaller than a patch ({2 * half_width + 1})")
    ny = np.clip(ny, half_width, H - 1 - half_width).astype(np.int32)  # whole patches inside the source
    nx = np.clip(nx, half_width, W - 1 - half_width).astype(np.int32)
    nd = np.empty(ny.shape, np.float32)
    h, w = ny.shape
    p2 = (2 * half_width + 1) ** 2
    lam = float(uniformity) / (h * w * p2 / (H * W)) if uniformity else 0.0  # per patch over an even use
    _pm_score(s, t, nf, int(half_width), ny, nx, nd)
    members = np.asarray(members, np.int64)
    for it in range(int(iterations)):
        _pm_sweep(s, t, nf, ball, members, Search(int(half_width), int(seed), it, lam), ny, nx, nd)
    return ny, nx, nd


@njit(**PJIT)
def _vote(src, ny, nx, half_width, out):
    H, W, F = src.shape
    h, w = ny.shape
    for i in prange(h):
        acc = np.empty(F)
        for j in range(w):
            acc[:] = 0.0
            n = 0
            for dy in range(-half_width, half_width + 1):
                qi = i - dy
                if qi < 0 or qi >= h:
                    continue
                for dx in range(-half_width, half_width + 1):
                    qj = j - dx
                    if qj < 0 or qj >= w:
                        continue
                    sy = min(max(ny[qi, qj] + dy, 0), H - 1)
                    sx = min(max(nx[qi, qj] + dx, 0), W - 1)
                    for f in range(F):
                        acc[f] += src[sy, sx, f]
                    n += 1
            for f in range(F):
                out[i, j, f] = acc[f] / n


def vote(src: np.ndarray, ny: np.ndarray, nx: np.ndarray, half_width: int) -> np.ndarray:
    """Voting: each target pixel is the mean of what the (2·half_width+1)² patches covering it
    say (the patch of target pixel q at offset o reads source ``nnf(q) + o``, clamped).
    src (H, W, F); returns (h, w, F) float32."""
    src = np.ascontiguousarray(src, np.float32)
    out = np.empty(ny.shape + (src.shape[2],), np.float32)
    _vote(src, np.ascontiguousarray(ny, np.int32), np.ascontiguousarray(nx, np.int32), int(half_width), out)
    return out


def merge_system(L: np.ndarray, gx: np.ndarray, gy: np.ndarray, screen: float) -> np.ndarray:
    """Right-hand side of the screened Poisson reconstruction of u from a target gradient
    field (gx[i, j] ≈ u[i, j+1] − u[i, j], gy[i, j] ≈ u[i+1, j] − u[i, j]) and the values
    L (weight ``screen``): (Δ_graph + screen·I) u = screen·L − div g, with the graph
    Laplacian of the 4-connected grid (``kernels.poisson.solve_system``'s A, no fixed
    pixel)."""
    b = screen * L.astype(np.float64)
    b[:, :-1] -= gx[:, :-1]
    b[:, 1:] += gx[:, :-1]
    b[:-1, :] -= gy[:-1, :]
    b[1:, :] += gy[:-1, :]
    return b


def screened_poisson(L: np.ndarray, gx: np.ndarray, gy: np.ndarray, screen: float, *, tol: float = 1e-6,
                     max_iter: int = 200) -> np.ndarray:
    """u minimising Σ_edges (u_q − u_p − g_pq)² + screen·Σ (u − L)² (one channel), solved
    with ``kernels.poisson.solve_system``. Returns (h, w) float32."""
    from proxyshade.kernels.poisson import solve_system

    b = merge_system(L, gx, gy, screen)
    b3 = np.zeros(L.shape + (3,), np.float32)
    b3[..., 0] = b
    v, _ = solve_system(np.zeros(L.shape, np.bool_), b3, screen=float(screen), tol=tol, max_iter=max_iter)
    return v[..., 0]


def merge_channels(values: np.ndarray, grads: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The merge of C per-cluster results: values (C, h, w, V) (L*, a*, b*, α) averaged
    with the weights (h, w, C); gradients (C, h, w, 2) (∂L*/∂x, ∂L*/∂y): that of the cluster
    with the largest ‖W_i ∇L*_i‖ (the first on ties). Returns ((h, w, V), (h, w, 2))."""
    w = np.moveaxis(np.asarray(weights, np.float64), 2, 0)  # (C, h, w)
    mean = (w[..., None] * values).sum(axis=0)
    norm = w * np.sqrt((grads.astype(np.float64) ** 2).sum(axis=3))
    pick = np.argmax(norm, axis=0)
    g = np.take_along_axis(grads, pick[None, :, :, None], axis=0)[0]
    return mean, g
