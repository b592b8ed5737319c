"""k-coherent pixel correction with repetition rejection (Bonneel et al. 2010, §5 step 2).

After patch growth, the coordinate map is refined coarse to fine, after Lefebvre and
Hoppe 2005: at each level the map is upsampled (children inherit their parent's exemplar
position plus their offset) and corrected. A correction pass visits the pixels in four
interleaved sub-sets (row and column parity); within one sub-set all pixels are updated
in parallel from the state before it, so results do not depend on the thread count.

For a pixel p the candidates are k-coherent: for each pixel q of p's 3×3 neighbourhood,
the exemplar position S[q] (the map, ``coords`` in the code) shifted back by h (q − p),
and the same shift applied to the k most similar exemplar pixels of S[q] (its similarity
set, found once per level by a k-nearest-neighbour PatchMatch over the exemplar). A
candidate must lie in the exemplar and carry the guide's label at p, and is rejected
when

* it is already used in the 9×9 window around p, or
* a non-coherent pixel of that window uses an exemplar pixel within ``radius`` of it
  (the paper: 2^(l−1) at level l, l = 1 the coarsest) — a near copy, or
* (``copy_spacing``, off by default; frames over ``FAR_FRAME`` times the photo's area) a
  non-coherent pixel farther away, within a share of the even spread's spacing of the
  label's copies, uses its spot (``far_copy``) — a copy too near on the frame.

The survivor closest to p's neighbourhood under eq. 1 augmented with colour and height

    d = ||(N_D, N_RGB, h_w t)(A) − (N_D, N_RGB, h_w t)(B)||_2 + w C(A, B)

(t the relative height in the label's vertical run, ``features.label_heights``, h_w
``height_weight``)

replaces S[p]; when every candidate is rejected S[p] stays. Optional factors on a
candidate's distance: the usage term (``_usage_excess``), the tone balance (``_tone_balance``,
Kopf et al. 2007's histogram reweighting with ``tone_over_only``), the tone spread
(``_tone_spread``), the tone match (``_tone_z``: a pixel keeps its tone's z-score in its
label) and the rare-look budget (``_rare_excess``: a label's darkest and brightest looks
copied at most a given number of times in a frame larger than the photo); docs/synthesis.md
and docs/formats.md have their figures.

References
----------
S. Lefebvre, H. Hoppe. Parallel controllable texture synthesis. SIGGRAPH 2005.
M. Ashikhmin. Synthesizing natural textures. I3D 2001 (coherence).
J. Kopf et al. Solid texture synthesis from 2D exemplars. SIGGRAPH 2007 (histogram matching).
C. Barnes et al. The generalized PatchMatch correspondence algorithm. ECCV 2010 (k-NN).
"""
from __future__ import annotations

import os
from typing import NamedTuple

import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import JIT, PJIT
from proxyshade.kernels.random import mix_seed, rand
from proxyshade.kernels.features import (NB2, Level, Metric, chamfer_masks, dist_sq_contour, dist_sq_rgb, gather_target,
                                         height_sq)

WINDOW = 4  # half side of the 9x9 repetition window

# The kernels take a ``features.Level`` whole (its spacing ``h`` and both sides' features)
# and ``features.Metric`` (the weights of eq. 1).


class Rule(NamedTuple):
    """A correction's choices at one level: ``radius`` the near-copy radius (exemplar
    pixels), ``use_rgb`` the colour term, ``kappa`` the penalty (× 1 + kappa) on
    similarity-set candidates, ``uniformity`` the weight of the over-use term,
    ``tone_match`` the weight Z of the tone-match term (× 1 + Z (z_c − z_p)², ``_tone_z``;
    0: off)."""

    radius: int
    use_rgb: bool
    kappa: float
    uniformity: float
    tone_match: float = 0.0


# ---------------------------------------------------------------------------
# hashing: explicit randomness, one stream per (seed, level, pixel, draw)


# ---------------------------------------------------------------------------
# exemplar self-similarity: k-NN lists


@njit(**JIT)
def _ex_dist(lv, m, y, x, yy, xx, bound):
    """Distance between exemplar windows (y, x) and (yy, xx) of level ``lv`` (spacing h),
    eq. 1 + colour + height."""
    src_dist, src_rgb, src_masks, src_h, h = lv.src_dist, lv.src_rgb, lv.src_masks, lv.src_height, lv.h
    H, W = src_dist.shape
    s = height_sq(src_h, y, x, src_h[yy, xx], m.height_weight)
    b2 = bound * bound
    for di in range(-2, 3):
        a0 = min(max(y + di * h, 0), H - 1)
        b0 = min(max(yy + di * h, 0), H - 1)
        for dj in range(-2, 3):
            a1 = min(max(x + dj * h, 0), W - 1)
            b1 = min(max(xx + dj * h, 0), W - 1)
            d = src_dist[a0, a1] - src_dist[b0, b1]
            s += d * d
            for c in range(3):
                e = src_rgb[a0, a1, c] - src_rgb[b0, b1, c]
                s += e * e
        if s > b2:
            return np.sqrt(s)
    r = np.sqrt(s)
    if r > bound:
        return r
    return r + m.w * chamfer_masks(src_masks[y, x], src_masks[yy, xx])


@njit(**JIT)
def _insert(ly, lx, ld, k, cy, cx, d):
    """Insert (cy, cx, d) into the sorted k-list if better than its worst and new."""
    if d >= ld[k - 1]:
        return
    for t in range(k):
        if ly[t] == cy and lx[t] == cx:
            return
    t = k - 1
    while t > 0 and ld[t - 1] > d:
        ly[t] = ly[t - 1]
        lx[t] = lx[t - 1]
        ld[t] = ld[t - 1]
        t -= 1
    ly[t] = cy
    lx[t] = cx
    ld[t] = d


@njit(**JIT)
def _knn_init(lv, m, k, excl, seed, starts, lists, out, y0, y1):
    """Random first k-NN lists ``out`` = (rows, columns, distances) (H, W, k) of the
    exemplar pixels of level ``lv``, rows y0..y1: 2k draws among the pixel's label (``starts``,
    ``lists``: ``patch._label_lists``), none within ``excl`` of it."""
    ky, kx, kd = out
    src_lab, h = lv.src_lab, lv.h
    H, W = src_lab.shape
    for y in range(y0, y1):
        for x in range(W):
            for t in range(k):
                ky[y, x, t] = y
                kx[y, x, t] = x
                kd[y, x, t] = np.inf
            l = src_lab[y, x]
            n = starts[l + 1] - starts[l]
            for t in range(2 * k):
                c = lists[starts[l] + rand(seed, y * W + x, 0x1000 + t, h) % n]
                cy = c // W
                cx = c % W
                if max(abs(cy - y), abs(cx - x)) <= excl:
                    continue
                d = _ex_dist(lv, m, y, x, cy, cx, kd[y, x, k - 1])
                _insert(ky[y, x], kx[y, x], kd[y, x], k, cy, cx, d)


@njit(**JIT)
def _knn_iter(lv, m, k, excl, seed, it, old, new, y0, y1):
    """One PatchMatch k-NN iteration on rows y0..y1 (reads the lists ``old``, writes ``new``,
    each (rows, columns, distances)): propagation from the 4 neighbours' lists, then random
    search around each entry with halving radius."""
    oy, ox, od = old
    ny, nx, nd = new
    src_lab, h = lv.src_lab, lv.h
    H, W = src_lab.shape
    for y in range(y0, y1):
        for x in range(W):
            ly = ny[y, x]
            lx = nx[y, x]
            ld = nd[y, x]
            for t in range(k):
                ly[t] = oy[y, x, t]
                lx[t] = ox[y, x, t]
                ld[t] = od[y, x, t]
            l = src_lab[y, x]
            for q in range(4):
                dy = (q == 1) - (q == 0)
                dx = (q == 3) - (q == 2)
                yy = y + dy
                xx = x + dx
                if yy < 0 or yy >= H or xx < 0 or xx >= W:
                    continue
                for t in range(k):
                    cy = oy[yy, xx, t] - dy
                    cx = ox[yy, xx, t] - dx
                    if cy < 0 or cy >= H or cx < 0 or cx >= W:
                        continue
                    if src_lab[cy, cx] != l or max(abs(cy - y), abs(cx - x)) <= excl:
                        continue
                    d = _ex_dist(lv, m, y, x, cy, cx, ld[k - 1])
                    _insert(ly, lx, ld, k, cy, cx, d)
            draw = 0
            for t in range(k):
                by = ly[t]
                bx = lx[t]
                R = max(H, W) // 2
                while R >= 1:
                    cy = by + rand(seed, y * W + x, it * 4096 + draw, h) % (2 * R + 1) - R
                    draw += 1
                    cx = bx + rand(seed, y * W + x, it * 4096 + draw, h) % (2 * R + 1) - R
                    draw += 1
                    R //= 2
                    if cy < 0 or cy >= H or cx < 0 or cx >= W:
                        continue
                    if src_lab[cy, cx] != l or max(abs(cy - y), abs(cx - x)) <= excl:
                        continue
                    d = _ex_dist(lv, m, y, x, cy, cx, ld[k - 1])
                    _insert(ly, lx, ld, k, cy, cx, d)


KNN_INIT, KNN_ITER, KNN_RESCORE = 0, 1, 2  # the steps of ``_knn_pass``


@njit(**PJIT)
def _knn_pass(step, lv, m, k, excl, seed, it, starts, flat, old, new):
    """One step of the k-NN search over the exemplar's rows in parallel: ``KNN_INIT``
    (``_knn_init`` into ``new``, from the label lists ``starts``, ``flat``), ``KNN_ITER``
    (``_knn_iter`` from ``old`` into ``new``) or ``KNN_RESCORE`` (``_knn_rescore`` of ``new``
    in place). One parallel loop calling serial row kernels: each parallel loop passing a
    ``Level`` costs about 1 s to compile (``kernels/_config.py``)."""
    for y in prange(lv.src_lab.shape[0]):
        y0 = np.int64(y)
        if step == KNN_INIT:
            _knn_init(lv, m, k, excl, seed, starts, flat, new, y0, y0 + 1)
        elif step == KNN_ITER:
            _knn_iter(lv, m, k, excl, seed, it, old, new, y0, y0 + 1)
        else:
            _knn_rescore(lv, m, k, excl, new, y0, y0 + 1)


def similarity_sets(level, k: int, metric: Metric, *, seed: int, iterations: int,
                    init: np.ndarray | None = None) -> np.ndarray:
    """(He, We, k, 2) int32: for each exemplar pixel, k similar exemplar pixels of the
    same label, more than ``2 h`` away (approximate k-NN by PatchMatch under ``metric``).

    ``init`` (a finer level's lists) seeds the search instead of random draws.
    """
    from proxyshade.kernels.patch import _label_lists

    lab = level.src_lab
    H, W = lab.shape
    n = level.src_masks.shape[2]
    excl = 2 * level.h
    m = Metric(float(metric.w), float(metric.height_weight))
    lists = (np.empty((H, W, k), np.int32), np.empty((H, W, k), np.int32), np.empty((H, W, k), np.float64))
    none = np.zeros(0, np.int64)
    if init is None:
        starts, flat = _label_lists(lab, n)
        _knn_pass(KNN_INIT, level, m, k, excl, seed, it=0, starts=starts, flat=flat, old=lists, new=lists)
    else:
        lists[0][...] = init[..., 0]
        lists[1][...] = init[..., 1]
        lists[2][...] = np.inf
        _knn_pass(KNN_RESCORE, level, m, k, excl, seed, it=0, starts=none, flat=none, old=lists, new=lists)
    spare = tuple(np.empty_like(a) for a in lists)
    for it in range(iterations):
        _knn_pass(KNN_ITER, level, m, k, excl, seed, it=it + 1, starts=none, flat=none, old=lists, new=spare)
        lists, spare = spare, lists
    return np.stack(lists[:2], axis=-1)


@njit(**JIT)
def _knn_rescore(lv, m, k, excl, lists, y0, y1):
    """Re-evaluate given ``lists`` (rows, columns, distances) at level ``lv``, rows y0..y1
    (entries breaking the rules become self with inf)."""
    ky, kx, kd = lists
    src_lab = lv.src_lab
    H, W = src_lab.shape
    for y in range(y0, y1):
        for x in range(W):
            ly = ky[y, x].copy()
            lx = kx[y, x].copy()
            for t in range(k):
                ky[y, x, t] = y
                kx[y, x, t] = x
                kd[y, x, t] = np.inf
            for t in range(k):
                cy = np.int64(ly[t])  # one signature of _ex_dist and _insert with _knn_init's
                cx = np.int64(lx[t])
                if src_lab[cy, cx] != src_lab[y, x] or max(abs(cy - y), abs(cx - x)) <= excl:
                    continue
                d = _ex_dist(lv, m, y, x, cy, cx, kd[y, x, k - 1])
                _insert(ky[y, x], kx[y, x], kd[y, x], k, cy, cx, d)


# ---------------------------------------------------------------------------
# correction


@njit(**JIT)
def _usage_excess(coords, src_lab, expected, R, out):
    """For each exemplar pixel, how much its (2R+1)² window is over-used: max(0, uses /
    expected uses − 1), uses = target pixels whose ``coords`` falls in the window, expected =
    Σ over the window's exemplar pixels of ``expected[label]`` (target pixels per exemplar
    pixel of that label: the rate of a synthesis that draws on the whole source region
    evenly). Window sums by integral images; deterministic."""
    He, We = src_lab.shape
    iu = np.zeros((He + 1, We + 1))
    ie = np.zeros((He + 1, We + 1))
    for i in range(coords.shape[0]):
        for j in range(coords.shape[1]):
            iu[coords[i, j, 0] + 1, coords[i, j, 1] + 1] += 1.0
    for y in range(He):
        for x in range(We):
            ie[y + 1, x + 1] = expected[src_lab[y, x]]
    _integrate(iu)
    _integrate(ie)
    for y in range(He):
        for x in range(We):
            u, e = _window_sums(iu, ie, y, x, R)
            out[y, x] = max(u / e - 1.0, 0.0) if e > 0 else 0.0


@njit(inline="always", **JIT)
def _integrate(a):
    """``a`` (H + 1, W + 1), zero first row and column, made its own integral image in place."""
    for y in range(1, a.shape[0]):
        for x in range(1, a.shape[1]):
            a[y, x] += a[y - 1, x] + a[y, x - 1] - a[y - 1, x - 1]


@njit(inline="always", **JIT)
def _window_sums(iu, ie, y, x, R):
    """The sums of two integral images over pixel (y, x)'s (2R+1)² window, clipped to the image."""
    He, We = iu.shape[0] - 1, iu.shape[1] - 1
    y0, y1 = max(y - R, 0), min(y + R + 1, He)
    x0, x1 = max(x - R, 0), min(x + R + 1, We)
    return (iu[y1, x1] - iu[y0, x1] - iu[y1, x0] + iu[y0, x0],
            ie[y1, x1] - ie[y0, x1] - ie[y1, x0] + ie[y0, x0])



RARE_TAIL = 0.1  # the shares of a label's darkest and brightest exemplar pixels that make its rare look
RARE_CONTRAST = 0.15  # a rare pixel's least luma distance from its label's median (sRGB, 0-1)
RARE_WEIGHT = 1.0  # a candidate on a rare look pays × (1 + RARE_WEIGHT × its window's over-use of the budget)


@njit(**JIT)
def _rare_excess(coords, src_lab, rare, budget, R, out):
    """The rare-look budget: for each exemplar pixel of ``rare`` (its label's rare look,
    ``rare_mask``) whose label has a budget, how much the rare pixels of its (2R+1)² window
    are over-used: max(0, uses / allowed − 1), uses = target pixels whose ``coords`` falls on
    a rare pixel of the window, allowed = Σ over those rare pixels of ``budget[label]``
    (target pixels per exemplar pixel: copies of a rare look); 0 at the other pixels and
    where ``budget[label]`` is 0 (no budget). Window sums by integral images; deterministic."""
    He, We = src_lab.shape
    iu = np.zeros((He + 1, We + 1))
    ie = np.zeros((He + 1, We + 1))
    for i in range(coords.shape[0]):
        for j in range(coords.shape[1]):
            y = coords[i, j, 0]
            x = coords[i, j, 1]
            if rare[y, x] and budget[src_lab[y, x]] > 0:
                iu[y + 1, x + 1] += 1.0
    for y in range(He):
        for x in range(We):
            if rare[y, x]:
                ie[y + 1, x + 1] = budget[src_lab[y, x]]
    _integrate(iu)
    _integrate(ie)
    for y in range(He):
        for x in range(We):
            out[y, x] = 0.0
            if not rare[y, x] or budget[src_lab[y, x]] <= 0:
                continue
            u, e = _window_sums(iu, ie, y, x, R)
            out[y, x] = max(u / e - 1.0, 0.0)


def rare_mask(src_lab: np.ndarray, src_rgb: np.ndarray, tail: float, contrast: float = RARE_CONTRAST) -> np.ndarray:
    """(He, We) bool: each label's rare look at a level, ``kernels.quality.rare_looks`` (its
    ``tail`` darkest and brightest pixels, at least ``contrast`` in luma from its median) on
    the level's colour features (``src_rgb``: 255 · sRGB)."""
    from proxyshade.kernels.quality import rare_looks
    return rare_looks(np.asarray(src_rgb, np.float64) / 255.0, src_lab, tail=tail, contrast=contrast)


def rare_budgets(expected: np.ndarray, copies: float, h: int) -> np.ndarray:
    """Per label, the target pixels a rare exemplar pixel may take at a level of spacing
    ``h``: ``copies`` / h² (``copies`` copies of a rare look at the synthesis size; a level
    pixel stands for h² of them) where an even draw over the label (``expected``) would
    use it more, else 0: no budget (a frame about the photo's size, where the usage term
    alone already spreads the draw)."""
    cap = float(copies) / float(h * h)
    return np.where(np.asarray(expected) > cap, cap, 0.0).astype(np.float64)


TONE_FLOOR = 0.05  # the least factor of the tone-balance term (a tone the target lacks entirely)
TONE_BINS = 16  # luma bins of the tone-balance term (``_tone_balance``)
TONE_FREE_PASSES = 2  # the finest level's last passes run without it (bench_photos: window chi2 / EbSynth 1.17 -> 1.08 at 0.5)


@njit(**JIT)
def _tone_balance(coords, src_lab, src_rgb, nlab, nbins, out):
    """For each exemplar pixel, how over- or under-represented its tone is among the target
    pixels of its label: r − 1 clipped at −1, r = (share of the label's target pixels whose
    ``coords`` falls in the pixel's luma bin) / (share of the label's exemplar pixels in that
    bin); 0 for a label no target pixel uses. Luma of ``src_rgb`` (255 · sRGB, the colour
    features) in ``nbins`` equal bins. Deterministic (sequential sums)."""
    He, We = src_lab.shape
    hs = np.zeros((nlab, nbins))
    ht = np.zeros((nlab, nbins))
    b = np.empty((He, We), np.int64)
    for y in range(He):
        for x in range(We):
            v = (0.2126 * src_rgb[y, x, 0] + 0.7152 * src_rgb[y, x, 1] + 0.0722 * src_rgb[y, x, 2]) / 255.0
            k = min(max(int(v * nbins), 0), nbins - 1)
            b[y, x] = k
            hs[src_lab[y, x], k] += 1.0
    for i in range(coords.shape[0]):
        for j in range(coords.shape[1]):
            y = coords[i, j, 0]
            x = coords[i, j, 1]
            ht[src_lab[y, x], b[y, x]] += 1.0
    ns = np.zeros(nlab)
    nt = np.zeros(nlab)
    for l in range(nlab):  # sequential sums (numpy's axis sum compiles slowly)
        for k in range(nbins):
            ns[l] += hs[l, k]
            nt[l] += ht[l, k]
    for y in range(He):
        for x in range(We):
            l = src_lab[y, x]
            k = b[y, x]
            out[y, x] = max((ht[l, k] / nt[l]) / (hs[l, k] / ns[l]) - 1.0, -1.0) if nt[l] > 0 else 0.0


@njit(inline="always", **JIT)
def _label_luma(src_lab, src_rgb, nlab):
    """Each exemplar pixel's luma t (``src_rgb``: 255 · sRGB, the colour features) and, per
    label, its pixel count, luma sum and sum of squared deviations from the label's mean
    (sequential sums: deterministic)."""
    He, We = src_lab.shape
    t = np.empty((He, We))
    s0 = np.zeros(nlab)
    s1 = np.zeros(nlab)
    for y in range(He):
        for x in range(We):
            v = 0.2126 * src_rgb[y, x, 0] + 0.7152 * src_rgb[y, x, 1] + 0.0722 * src_rgb[y, x, 2]
            t[y, x] = v
            s0[src_lab[y, x]] += 1.0
            s1[src_lab[y, x]] += v
    V = np.zeros(nlab)
    for y in range(He):
        for x in range(We):
            l = src_lab[y, x]
            e = t[y, x] - s1[l] / s0[l]
            V[l] += e * e
    return t, s0, s1, V


@njit(**JIT)
def _tone_spread(coords, src_lab, src_rgb, nlab, out):
    """For each exemplar pixel, how a target pixel taking it would move its label's tone
    spread back toward the photo's: d × clip(1 − (t − μ)² / V, −1, 1), t the pixel's luma
    (``src_rgb``: 255 · sRGB, the colour features), μ the mean luma of the label's target
    pixels (read through ``coords``), V the variance of the photo label's luma (its exemplar
    pixels), d = max(0, 1 − v / V) the label's deficit (v: the target pixels' variance
    about μ); 0 for a label no target pixel
    uses or with V = 0. Positive (a penalty) near the mean, negative (a bonus) for tones
    farther than √V from it, only in a label that lost spread. Deterministic (sequential
    sums)."""
    He, We = src_lab.shape
    t, s0, s1, V = _label_luma(src_lab, src_rgb, nlab)
    n = np.zeros(nlab)
    m = np.zeros(nlab)
    for i in range(coords.shape[0]):
        for j in range(coords.shape[1]):
            y = coords[i, j, 0]
            x = coords[i, j, 1]
            n[src_lab[y, x]] += 1.0
            m[src_lab[y, x]] += t[y, x]
    for l in range(nlab):
        if n[l] > 0:
            m[l] /= n[l]
        if s0[l] > 0:
            V[l] /= s0[l]
    v = np.zeros(nlab)
    for i in range(coords.shape[0]):
        for j in range(coords.shape[1]):
            y = coords[i, j, 0]
            x = coords[i, j, 1]
            l = src_lab[y, x]
            e = t[y, x] - m[l]
            v[l] += e * e
    d = np.zeros(nlab)
    for l in range(nlab):
        if n[l] > 0 and V[l] > 0:
            d[l] = max(1.0 - v[l] / n[l] / V[l], 0.0)
    for y in range(He):
        for x in range(We):
            l = src_lab[y, x]
            if d[l] > 0:
                e = t[y, x] - m[l]
                out[y, x] = d[l] * min(max(1.0 - e * e / V[l], -1.0), 1.0)
            else:
                out[y, x] = 0.0


@njit(**JIT)
def _tone_z(src_lab, src_rgb, nlab, out):
    """Each exemplar pixel's tone as a z-score within its label: (t − μ) / σ, t its luma
    (``src_rgb``: 255 · sRGB, the colour features of the level), μ and σ the mean and
    standard deviation of the luma of the label's exemplar pixels (0 where σ = 0).
    Deterministic (sequential sums)."""
    He, We = src_lab.shape
    t, s0, s1, V = _label_luma(src_lab, src_rgb, nlab)
    for y in range(He):
        for x in range(We):
            l = src_lab[y, x]
            sd = np.sqrt(V[l] / s0[l])
            out[y, x] = (t[y, x] - s1[l] / s0[l]) / sd if sd > 0 else 0.0


@njit(**JIT)
def rejected(coords, i, j, cy, cx, h, radius):
    """Whether candidate (cy, cx) for pixel (i, j) repeats a use in the 9x9 window.

    A window pixel q != p using exactly (cy, cx), or a non-coherent one (coords[q] !=
    candidate + h (q - p)) using an exemplar pixel within ``radius`` (L-inf), rejects it.
    """
    Ht, Wt = coords.shape[0], coords.shape[1]
    for di in range(-WINDOW, WINDOW + 1):
        ii = i + di
        if ii < 0 or ii >= Ht:
            continue
        for dj in range(-WINDOW, WINDOW + 1):
            jj = j + dj
            if jj < 0 or jj >= Wt or (di == 0 and dj == 0):
                continue
            dy = coords[ii, jj, 0] - cy
            dx = coords[ii, jj, 1] - cx
            if dy == h * di and dx == h * dj:
                continue  # coherent neighbour
            if abs(dy) <= radius and abs(dx) <= radius:
                return True
    return False


@njit(**JIT)
def _users(flat, start, order):
    """The target pixels using each exemplar pixel, as lists: those (flat, row-major) whose
    exemplar pixel ``flat`` (Ht, Wt: row · We + column of their coords) is e are
    ``order[start[e]:start[e + 1]]``, in row-major order (``start`` He·We + 1, ``order``
    Ht·Wt; a counting sort, deterministic)."""
    Ht, Wt = flat.shape
    ne = start.shape[0] - 1
    for e in range(ne + 1):
        start[e] = 0
    for i in range(Ht):
        for j in range(Wt):
            start[flat[i, j] + 1] += 1
    for e in range(ne):
        start[e + 1] += start[e]
    fill = start[:-1].copy()
    for i in range(Ht):
        for j in range(Wt):
            e = flat[i, j]
            order[fill[e]] = i * Wt + j
            fill[e] += 1


@njit(**JIT)
def far_copy(coords, i, j, cy, cx, h, reach2, r, start, order, We):
    """Whether candidate (cy, cx) for pixel (i, j) would sit within √``reach2`` level pixels
    (Euclidean) of another copy of its spot: a target pixel q ≠ p using an exemplar pixel
    within ``r`` (L-inf) of the candidate that is not coherent with it (coords[q] ≠ candidate
    + h (q − p)). ``start``, ``order``: the users of each exemplar pixel (``_users``), ``We``
    the exemplar's width. The frame-scaled complement of ``rejected``'s 9×9 window."""
    Wt = coords.shape[1]
    He = (start.shape[0] - 1) // We
    for y in range(max(cy - r, 0), min(cy + r + 1, He)):
        for x in range(max(cx - r, 0), min(cx + r + 1, We)):
            e = y * We + x
            for t in range(start[e], start[e + 1]):
                q = order[t]
                di = q // Wt - i
                dj = q % Wt - j
                if di * di + dj * dj > reach2 or (di == 0 and dj == 0):
                    continue
                if y - cy == h * di and x - cx == h * dj:
                    continue  # coherent with the candidate: the same copy
                return True
    return False


@njit(**JIT)
def _cand_dist(lv, m, use_rgb, i, j, cy, cx, target_dist, target_rgb, best):
    """Eq. 1 with colour and height for candidate (cy, cx) at target (i, j), whose 5×5
    contour distances and colours under the current map are ``target_dist``, ``target_rgb``; early exit
    above best."""
    h = lv.h
    b2 = best * best
    s = height_sq(lv.src_height, cy, cx, lv.tgt_height[i, j], m.height_weight)
    if s <= b2:
        s += dist_sq_contour(lv.src_dist, h, cy, cx, target_dist, b2 - s)
    if use_rgb and s <= b2:
        s += dist_sq_rgb(lv.src_rgb, h, cy, cx, target_rgb, b2 - s)
    d = np.sqrt(s)
    if d >= best:
        return d
    return d + m.w * chamfer_masks(lv.src_masks[cy, cx], lv.tgt_masks[i, j])


@njit(**JIT)
def _subpass_rows(lv, m, rule, knn, over, zs, zt, coords_old, coords_new, active, parity, counts, r0, r1, far):
    """Correct pixels with (i % 2, j % 2) == ``parity`` of level ``lv``, reading coords_old,
    writing coords_new; ``knn`` the similarity sets (He, We, k, 2).

    Candidates from similarity sets (not a neighbour's coherent continuation) have their
    distance multiplied by 1 + kappa; every candidate's by 1 + uniformity × its exemplar
    neighbourhood's over-use ``over`` (``usage_excess``), and with ``rule.tone_match`` Z > 0
    by 1 + Z (zs[c] − zt[p])²: ``zs`` (He, We) the exemplar pixels' tone z-scores
    (``_tone_z``), ``zt`` (Ht, Wt) the tone each target pixel should keep (read only when
    Z > 0).

    ``far`` (reach², r, start, order): a candidate of label l that would win is also rejected
    when ``far_copy`` finds another copy of its spot within √reach²[l] level pixels (reach²[l]
    0: not tested); ``correct_level``'s ``copy_spacing``.

    counts[i] accumulates (changed, all rejected) per row for reporting. Rows 2 r + parity[0]
    for r in r0..r1 (``_subpass``: all of them in parallel).
    """
    pi, pj = parity
    src_lab, src_rgb, tgt_lab, tgt_dist, h = lv.src_lab, lv.src_rgb, lv.tgt_lab, lv.tgt_dist, lv.h
    radius, use_rgb, kappa, uniformity, zw = rule.radius, rule.use_rgb, rule.kappa, rule.uniformity, rule.tone_match
    reach2, far_r, far_start, far_order = far
    Ht, Wt = tgt_lab.shape
    He, We = src_lab.shape
    k = knn.shape[2]
    ncand = 9 * (k + 1)
    for r in range(r0, r1):
        i = pi + 2 * r
        target_dist = np.empty(NB2, np.float32)
        target_rgb = np.empty((NB2, 3), np.float32)
        cyl = np.empty(ncand, np.int64)
        cxl = np.empty(ncand, np.int64)
        coh = np.empty(ncand, np.bool_)
        for j in range(pj, Wt, 2):
            if not active[i, j]:
                continue
            lab = tgt_lab[i, j]
            far2 = reach2[lab]
            gather_target(tgt_dist, i, j, target_dist)
            if use_rgb:
                t = 0
                for di in range(-2, 3):
                    ii = min(max(i + di, 0), Ht - 1)
                    for dj in range(-2, 3):
                        jj = min(max(j + dj, 0), Wt - 1)
                        sy = coords_old[ii, jj, 0]
                        sx = coords_old[ii, jj, 1]
                        for c in range(3):
                            target_rgb[t, c] = src_rgb[sy, sx, c]
                        t += 1
            # candidate list (deduplicated, deterministic order)
            nc = 0
            for di in range(-1, 2):
                ii = i + di
                if ii < 0 or ii >= Ht:
                    continue
                for dj in range(-1, 2):
                    jj = j + dj
                    if jj < 0 or jj >= Wt:
                        continue
                    qy = coords_old[ii, jj, 0]
                    qx = coords_old[ii, jj, 1]
                    for t in range(k + 1):
                        if t == 0:
                            cy = qy - h * di
                            cx = qx - h * dj
                        else:
                            cy = knn[qy, qx, t - 1, 0] - h * di
                            cx = knn[qy, qx, t - 1, 1] - h * dj
                        if cy < 0 or cy >= He or cx < 0 or cx >= We or src_lab[cy, cx] != lab:
                            continue
                        dup = False
                        for u in range(nc):
                            if cyl[u] == cy and cxl[u] == cx:
                                dup = True
                                coh[u] = coh[u] or t == 0
                                break
                        if not dup:
                            cyl[nc] = cy
                            cxl[nc] = cx
                            coh[nc] = t == 0
                            nc += 1
            best = np.inf
            by = coords_old[i, j, 0]
            bx = coords_old[i, j, 1]
            for u in range(nc):
                cy = cyl[u]
                cx = cxl[u]
                f = (1.0 if coh[u] else 1.0 + kappa) * (1.0 + uniformity * over[cy, cx])
                if zw > 0:
                    e = zs[cy, cx] - zt[i, j]
                    f *= 1.0 + zw * e * e
                d = f * _cand_dist(lv, m, use_rgb, i, j, cy, cx, target_dist, target_rgb, best / f)
                # rejection is only tested for a candidate that would win (same result, cheaper)
                if d < best and not rejected(coords_old, i, j, cy, cx, h, radius) and not (
                        far2 > 0 and far_copy(coords_old, i, j, cy, cx, h, far2, far_r, far_start, far_order, We)):
                    best = d
                    by = cy
                    bx = cx
            if best == np.inf and src_lab[by, bx] != lab:
                # every candidate was rejected and the current position has the wrong
                # label: label fidelity wins over repetition
                for u in range(nc):
                    f = (1.0 if coh[u] else 1.0 + kappa) * (1.0 + uniformity * over[cyl[u], cxl[u]])
                    if zw > 0:
                        e = zs[cyl[u], cxl[u]] - zt[i, j]
                        f *= 1.0 + zw * e * e
                    d = f * _cand_dist(lv, m, use_rgb, i, j, cyl[u], cxl[u], target_dist, target_rgb, best / f)
                    if d < best:
                        best = d
                        by = cyl[u]
                        bx = cxl[u]
                counts[i, 1] += 1
            elif best == np.inf:
                counts[i, 1] += 1
            if by != coords_old[i, j, 0] or bx != coords_old[i, j, 1]:
                counts[i, 0] += 1
            coords_new[i, j, 0] = by
            coords_new[i, j, 1] = bx


@njit(**PJIT)
def _subpass(lv, m, rule, knn, over, zs, zt, coords_old, coords_new, active, parity, counts, far):
    """``_subpass_rows`` of every row of the parity, in parallel (the loop body a serial
    kernel called with int64 rows: typed once, ``kernels/_config.py``)."""
    for r in prange((lv.tgt_lab.shape[0] - parity[0] + 1) // 2):
        _subpass_rows(lv, m, rule, knn, over, zs, zt, coords_old, coords_new, active=active, parity=parity, counts=counts,
                      r0=np.int64(r), r1=np.int64(r + 1), far=far)


NO_Z = np.zeros((1, 1))  # the tone z-scores' place when the tone-match term is off (never read)


def no_far(nlab: int) -> tuple:
    """``_subpass_rows``' ``far`` when ``copy_spacing`` is off: no label tested."""
    return np.zeros(max(int(nlab), 1)), np.int64(0), np.zeros(1, np.int64), np.zeros(1, np.int64)


def far_reach(level, expected: np.ndarray, spacing: float) -> np.ndarray:
    """Per label, the squared least distance (level pixels) ``copy_spacing`` keeps between two
    copies of one spot at ``level``: (``spacing`` × √(the label's exemplar pixels) / h)², the
    spacing an even spread of its copies over its frame area gives (frame area / copies =
    the exemplar area: copies = frame area / exemplar area), where the label is copied more
    than once (``expected`` × h² > 1); 0 elsewhere and everywhere when the frame (the level's
    pixels × h²) is at most ``FAR_FRAME`` × the exemplar's area: a 1024-wide frame from a
    1024-wide photo keeps today's result by construction."""
    He, We = level.src_lab.shape
    Ht, Wt = level.tgt_lab.shape
    h = int(level.h)
    n = len(expected)
    out = np.zeros(max(n, 1))
    if spacing <= 0 or Ht * Wt * h * h <= FAR_FRAME * He * We:
        return out
    area = np.bincount(level.src_lab.ravel(), minlength=n)[:n].astype(np.float64)
    on = np.asarray(expected) * h * h > 1.0
    out[:n] = np.where(on, (spacing * np.sqrt(area) / h) ** 2, 0.0)
    return out


FAR_FRAME = 2.0  # copy_spacing acts only in a frame of more than this many times the photo's area

# levels smaller than this (512² synthesis pixels) are corrected whole even with a band runner
# (the environment variable lets a test band small levels on Dask workers; results are the same)
TILE_MIN_PIXELS = int(os.environ.get("PROXYSHADE_TILE_MIN_PIXELS", 1 << 18))


def subpass_rows(level, knn, coords_old, active, over, r0: int, r1: int, parity: tuple[int, int], metric: Metric,
                 rule: Rule, zs: np.ndarray | None = None, zt: np.ndarray | None = None, far: tuple | None = None):
    """One parity sub-pass on rows r0..r1 of the target only: (the new coords of those rows,
    their counts). Every pixel of a sub-pass reads only the state before it (``coords_old``)
    and the usage term ``over`` computed from it, so the rows of a band come out exactly
    as in the whole sub-pass: a tile of ``correct_level``."""
    coords_new = coords_old.copy()
    band = np.zeros(active.shape, np.bool_)
    band[r0:r1] = active[r0:r1]
    counts = np.zeros((coords_old.shape[0], 2), np.int64)
    zs = NO_Z if zs is None else zs
    zt = NO_Z if zt is None else zt
    far = no_far(level.src_masks.shape[2]) if far is None else far
    _subpass(level, metric, rule, knn, over, zs, zt, coords_old, coords_new, band, parity, counts, far)
    return coords_new[r0:r1], counts[r0:r1]


def correct_level(level, coords: np.ndarray, knn: np.ndarray, *, passes: int, metric: Metric, rule: Rule,
                  active: np.ndarray | None = None, tiles=None, tone_balance: float = 0.0,
                  tone_spacing: int = 1, tone_spread: float = 0.0,
                  spread_spacing: int = 1, keep_tones: np.ndarray | None = None,
                  tone_over_only: bool = False, rare_budget: float = 0.0,
                  rare_tail: float = RARE_TAIL, copy_spacing: float = 0.0) -> tuple[np.ndarray, dict]:
    """``passes`` correction passes (4 parity sub-passes each) at one level.

    ``tone_balance`` (T): each candidate's distance is multiplied by 1 + U × over-use
    (``_usage_excess``, U = ``rule.uniformity``) + T × its tone's imbalance in its label
    (``_tone_balance``: negative for tones the target uses less than the photo's label
    does), at least ``TONE_FLOOR``, except in the last ``TONE_FREE_PASSES`` passes of the
    finest level (h = 1); 0: the usage term alone (exactly as without it). ``tone_spread``
    (D) adds D × ``_tone_spread`` the same way: in a label
    whose tones spread less about their mean than the photo label's, candidates near the
    mean pay, those far from it gain. At a level whose spacing h is under ``tone_spacing`` (``spread_spacing``) the
    tone-balance (tone-spread) term is off; with neither, the usage term alone.
    ``tone_over_only``: the tone-balance term only charges the tones the target over-uses
    (r − 1 clipped at 0: Kopf et al. 2007's histogram reweighting, which gives rare tones
    no bonus).

    ``rule.tone_match`` (Z > 0): each candidate's distance is also multiplied by
    1 + Z (z_c − z_p)², z_c its tone's z-score in its label (``_tone_z`` of the level's
    colours), z_p that of the exemplar pixel ``keep_tones`` gives p (a map like ``coords``;
    default: ``coords``, the map entering the level), in every pass: a pixel keeps the tone
    deviation it came with instead of taking a candidate's regressed toward the label's mean.

    ``rare_budget`` (C > 0): the rare looks' budget. A label's rare look (``rare_mask``: its
    ``rare_tail`` darkest and brightest exemplar pixels) may be copied C times at the
    synthesis size (``rare_budgets``; labels an even draw would use less are left alone);
    candidates on it pay a further + ``RARE_WEIGHT`` × ``_rare_excess`` in that factor, in
    every pass. 0: off (exactly as without it).

    ``copy_spacing`` (a > 0): in a frame of more than ``FAR_FRAME`` times the photo's area, a
    candidate that would win is also rejected when another, non-coherent copy of its spot
    (an exemplar pixel within h // 2 of it) lies within a × √(its label's exemplar pixels) / h
    level pixels (``far_reach``, ``far_copy``): the copies of one source window, whose number
    the frame's area forces, are kept about a × the spacing of an even spread apart instead of
    clustering. 0: off (exactly as without it).

    ``tiles``: None (every sub-pass whole, the kernels' threads over its rows), or a runner
    ``tiles(fn, shared, jobs) -> [fn(*shared, *job) for job in jobs]`` that may run the
    jobs elsewhere (Dask workers: ``synthesis.tiles``); then, at a level of at least
    ``TILE_MIN_PIXELS``, each sub-pass runs as ``tiles.bands`` row bands of
    ``subpass_rows`` (shared: the level and the similarity sets), exactly the whole
    sub-pass's result."""
    Ht, Wt = level.tgt_lab.shape
    if active is None:
        active = np.ones((Ht, Wt), np.bool_)
    metric = Metric(float(metric.w), float(metric.height_weight))
    rule = Rule(int(rule.radius), bool(rule.use_rgb), float(rule.kappa), float(rule.uniformity),
                float(rule.tone_match))
    coords_old = np.ascontiguousarray(coords, np.int32).copy()
    coords_new = coords_old.copy()
    counts = np.zeros((Ht, 2), np.int64)
    n = level.src_masks.shape[2]
    zs, zt = NO_Z, NO_Z
    if rule.tone_match > 0:
        zs = np.empty(level.src_lab.shape)
        _tone_z(level.src_lab, level.src_rgb, n, zs)
        keep = coords_old if keep_tones is None else np.asarray(keep_tones)
        zt = np.ascontiguousarray(zs[keep[..., 0], keep[..., 1]])
    expected = (np.bincount(level.tgt_lab.ravel(), minlength=n)
                / np.maximum(np.bincount(level.src_lab.ravel(), minlength=n), 1)).astype(np.float64)
    over = np.zeros(level.src_lab.shape, np.float64)
    tone = np.zeros(level.src_lab.shape, np.float64) if tone_balance > 0 and level.h >= tone_spacing else None
    spread = np.zeros(level.src_lab.shape, np.float64) if tone_spread > 0 and level.h >= spread_spacing else None
    budget = rare_budgets(expected, rare_budget, level.h) if rare_budget > 0 else None
    rare = rare_mask(level.src_lab, level.src_rgb, rare_tail) if budget is not None and budget.any() else None
    rexc = np.zeros(level.src_lab.shape, np.float64) if rare is not None else None
    far = no_far(n)
    reach = far_reach(level, expected, copy_spacing) if copy_spacing > 0 else far[0]
    if reach.any():
        He, We = level.src_lab.shape
        far = (reach, np.int64(level.h // 2), np.zeros(He * We + 1, np.int64), np.zeros(Ht * Wt, np.int64))
    kernel_rule = rule
    nb = min(getattr(tiles, "bands", 1), Ht // 8) if tiles is not None and Ht * Wt >= TILE_MIN_PIXELS else 1
    edges = np.linspace(0, Ht, nb + 1).astype(int)
    for p in range(passes):
        for parity in ((0, 0), (1, 1), (0, 1), (1, 0)):
            if rule.uniformity > 0:
                _usage_excess(coords_old, level.src_lab, expected, 2 * level.h, over)
            terms = tone is not None or spread is not None
            weighed = False  # ``over`` holds the whole factor less 1 (the kernel's uniformity 1)
            if terms and level.h == 1 and p >= passes - TONE_FREE_PASSES:
                kernel_rule = rule  # the finest level's last passes: seams settle on colour alone
            elif terms:
                kernel_rule = rule._replace(uniformity=1.0)  # the factor is in ``over``
                weighed = True
                over *= rule.uniformity
                if tone is not None:
                    _tone_balance(coords_old, level.src_lab, level.src_rgb, n, TONE_BINS, tone)
                    if tone_over_only:
                        np.maximum(tone, 0.0, out=tone)
                    over += tone_balance * tone
                if spread is not None:
                    _tone_spread(coords_old, level.src_lab, level.src_rgb, n, spread)
                    over += tone_spread * spread
                np.maximum(over, TONE_FLOOR - 1.0, out=over)
            if rare is not None:
                if not weighed:
                    over *= rule.uniformity  # 0: clears the last sub-pass' budget
                kernel_rule = rule._replace(uniformity=1.0)
                _rare_excess(coords_old, level.src_lab, rare, budget, 2 * level.h, rexc)
                over += RARE_WEIGHT * rexc
            if far[0].any():
                _users(coords_old[..., 0] * np.int32(level.src_lab.shape[1]) + coords_old[..., 1], far[2], far[3])
            if nb > 1:
                jobs = [(coords_old, active, over, int(a), int(b), parity, metric, kernel_rule, zs, zt, far)
                        for a, b in zip(edges[:-1], edges[1:])]
                for (a, b), (rows, cnt) in zip(zip(edges[:-1], edges[1:]), tiles(subpass_rows, (level, knn), jobs)):
                    coords_new[a:b] = rows
                    counts[a:b] += cnt
            else:
                _subpass(level, metric, kernel_rule, knn, over, zs, zt, coords_old, coords_new, active, parity, counts, far)
            coords_old[...] = coords_new  # only this sub-set changed
    c = counts.sum(0)
    return coords_old, {"changed": int(c[0]), "all_rejected": int(c[1])}


# ---------------------------------------------------------------------------
# moving the state between levels


@njit(**JIT)
def _downsample(coords, h, Hl, Wl, He, We, out):
    """S_l[P] = coords[h P + h // 2] (the anchor fine pixel), clamped into the exemplar."""
    Ht, Wt = coords.shape[0], coords.shape[1]
    for I in range(Hl):
        for J in range(Wl):
            ai = h * I + h // 2
            aj = h * J + h // 2
            fi = min(ai, Ht - 1)
            fj = min(aj, Wt - 1)
            y = coords[fi, fj, 0] + (ai - fi)
            x = coords[fi, fj, 1] + (aj - fj)
            out[I, J, 0] = min(max(y, 0), He - 1)
            out[I, J, 1] = min(max(x, 0), We - 1)


@njit(**JIT)
def _upsample(Sp, h, Hl, Wl, He, We, out):
    """From the level with spacing 2h to spacing h: child 2P + D of parent P takes
    S_p[P] + h D - (h - h // 2), clamped into the exemplar."""
    Hp, Wp = Sp.shape[0], Sp.shape[1]
    off = h - h // 2
    for i in range(Hl):
        I = min(i // 2, Hp - 1)
        di = i - 2 * I
        for j in range(Wl):
            J = min(j // 2, Wp - 1)
            dj = j - 2 * J
            out[i, j, 0] = min(max(Sp[I, J, 0] + h * di - off, 0), He - 1)
            out[i, j, 1] = min(max(Sp[I, J, 1] + h * dj - off, 0), We - 1)


def downsample_state(coords: np.ndarray, h: int, shape: tuple[int, int], ex_shape: tuple[int, int]) -> np.ndarray:
    out = np.empty(shape + (2,), np.int32)
    _downsample(np.ascontiguousarray(coords, np.int32), h, shape[0], shape[1], ex_shape[0], ex_shape[1], out)
    return out


def upsample_state(coords: np.ndarray, h: int, shape: tuple[int, int], ex_shape: tuple[int, int]) -> np.ndarray:
    out = np.empty(shape + (2,), np.int32)
    _upsample(np.ascontiguousarray(coords, np.int32), h, shape[0], shape[1], ex_shape[0], ex_shape[1], out)
    return out


@njit(**JIT)
def _block_any(mask, h, out):
    Ht, Wt = mask.shape
    for I in range(out.shape[0]):
        for i in range(I * h, min((I + 1) * h, Ht)):
            for j in range(Wt):
                if mask[i, j]:
                    out[I, j // h] = True


def downsample_mask(mask: np.ndarray, h: int, shape: tuple[int, int]) -> np.ndarray:
    """A level pixel is active when any of its h x h fine pixels is (fine pixels past
    ``shape`` × h are ignored)."""
    out = np.zeros(shape, np.bool_)
    m = np.ascontiguousarray(mask, np.bool_)[:shape[0] * h, :shape[1] * h]
    _block_any(np.ascontiguousarray(m), int(h), out)
    return out


def level_similarity_sets(levels: list, k: int, metric: Metric, *, seed: int, knn_iterations: int) -> list:
    """``similarity_sets`` of every level (coarsest first), as ``synthesize`` uses them."""
    L = len(levels)
    ex_shape = levels[-1].src_lab.shape
    knns = [None] * L
    for l in range(L - 1, -1, -1):  # finest first: coarser lists start from finer ones
        init = knns[l + 1] if l + 1 < L else None
        knns[l] = similarity_sets(levels[l], k, metric, seed=mix_seed(seed, l),
                                  iterations=knn_iterations if init is None else 1, init=init) if k > 0 else \
            np.zeros(ex_shape + (0, 2), np.int32)
    return knns


def synthesize(levels: list, S_init: np.ndarray, corr, *, seed: int, mask: np.ndarray | None = None,
               similarity: list | None = None, min_radius: int = 0, timings: dict | None = None,
               tiles=None, rare_budget: float = 0.0, rare_tail: float = RARE_TAIL,
               copy_spacing: float = 0.0) -> tuple[np.ndarray, list[dict]]:
    """Coarse-to-fine correction of an initial coordinate map.

    Parameters
    ----------
    levels : list of ``features.Level``, coarsest first (the last at the synthesis size).
    S_init : (Ht, Wt, 2) int32 exemplar (row, column) per guide pixel, e.g. from
        ``patch.flood_fill``.
    corr : the correction's settings, as attributes (the ``synthesis.params.Correction``
        group): ``passes``, ``passes_finest`` correction passes per level and at the finest
        level; ``k`` the size of the similarity sets (k-coherence) and ``knn_iterations``
        their search's; ``w``, ``height_weight`` the weights of eq. 1 (``features.Metric``);
        ``use_rgb``, ``kappa`` (``Rule``); ``uniformity``: candidates' distances are
        multiplied by 1 + uniformity × the over-use of their exemplar neighbourhood
        (``_usage_excess``; 0: none): the synthesis draws on the whole source region
        instead of converging on its blandest patch; ``tone_balance``: the tone-balance
        term of ``correct_level`` (``tone_over_only``: Kopf et al.'s form, optional);
        ``tone_match`` at the levels of spacing ≥ ``match_spacing``, keeping the tones of
        PatchInit's map (``match_from: "init"``, ``S_init`` taken down to the level) or of the
        map entering the level (``"level"``) (optional attributes; off when absent);
        ``radius``: the near-copy radius rule, "spacing" (h exemplar pixels at a level of
        spacing h) or "level" (2^l at level l, the paper's).
    seed : seeds the similarity sets' search.
    mask : (Ht, Wt) bool, optional; only these pixels change, the rest keep ``S_init``.
    min_radius : smallest near-copy radius in exemplar pixels at every level (the
        radius rule's where larger; 0: the rule alone). The rule gives one exemplar
        pixel at the finest level, so a seam may join two copies of nearly the same source
        spot (a shift of 1–3 exemplar pixels); magnified, each exemplar pixel is ``factor``
        output pixels and such seams pile onto the same few source pixels (see
        docs/formats.md, "near copies").
    similarity : optional per-level similarity sets from ``level_similarity_sets`` (they
        depend on the exemplar side of the levels, k, w, height_weight, seed and
        knn_iterations only): passed again, the search is skipped (a later frame of one source).
    tiles : optional runner of row bands of the large levels' sub-passes (``correct_level``).
    rare_budget, rare_tail : copies of a rare look allowed at the synthesis size, the tails that
        make it (``correct_level``; 0: off).
    copy_spacing : the least distance between two copies of one spot, as a share of an even
        spread's spacing, in a frame much larger than the photo (``correct_level``; 0: off).

    Returns the corrected map and per-level statistics.
    """
    import time

    L = len(levels)
    ex_shape = levels[-1].src_lab.shape
    S_init = np.ascontiguousarray(S_init, np.int32)
    metric = Metric(float(corr.w), float(corr.height_weight))
    t0 = time.perf_counter()
    if similarity is None:
        knns = level_similarity_sets(levels, corr.k, metric, seed=seed, knn_iterations=corr.knn_iterations)
    else:
        knns = list(similarity)
        if len(knns) != L or any(a.shape[:3] != ex_shape + (corr.k,) for a in knns):
            raise ValueError(f"similarity must hold {L} arrays of shape {ex_shape + (corr.k, 2)}")
    t1 = time.perf_counter()
    stats = []
    coords = None
    for l, lv in enumerate(levels):
        shape = lv.tgt_lab.shape
        h = lv.h
        start = downsample_state(S_init, h, shape, ex_shape)
        if coords is None:
            coords = start
        else:
            up = upsample_state(coords, h, shape, ex_shape)
            if mask is not None:
                act = downsample_mask(mask, h, shape)
                coords = np.where(act[..., None], up, start)
            else:
                coords = up
        active = downsample_mask(mask, h, shape) if mask is not None else None
        radius = max(h if corr.radius == "spacing" else 2 ** l, int(min_radius))
        n = corr.passes_finest if l == L - 1 else corr.passes
        Z = float(getattr(corr, "tone_match", 0.0)) if h >= int(getattr(corr, "match_spacing", 1)) else 0.0
        anchor = getattr(corr, "match_from", "init")
        coords, st = correct_level(lv, coords, knns[l], passes=n, metric=metric,
                              rule=Rule(radius, bool(corr.use_rgb), float(corr.kappa), float(corr.uniformity), Z),
                              active=active, tiles=tiles, tone_balance=float(corr.tone_balance),
                              tone_spacing=int(corr.tone_spacing), tone_spread=float(corr.tone_spread),
                              spread_spacing=int(corr.spread_spacing),
                              keep_tones=start if anchor == "init" else None,
                              tone_over_only=bool(getattr(corr, "tone_over_only", False)),
                              rare_budget=float(rare_budget), rare_tail=float(rare_tail),
                              copy_spacing=float(copy_spacing))
        st.update(level=l, h=h, shape=shape, passes=n, radius=radius)
        stats.append(st)
    if mask is not None:
        coords = np.where(np.asarray(mask)[..., None], coords, S_init)
    if timings is not None:
        timings["similarity"] = t1 - t0
        timings["corrections"] = time.perf_counter() - t1
    return coords, stats
