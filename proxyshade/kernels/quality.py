"""Measures of a synthesized frame that a supervisor would see: seams and detail.

Both are taken over pairs of 4-adjacent pixels of one label (label borders are the
layout's, not the texture's):

* ``seam_share``: the share of pairs whose source positions are not neighbours in the
  source, i.e. whose step in ``source.x/y`` differs from the expected ``scale`` step
  (one pixel across, ``scale`` source pixels) by more than ``tol`` source pixels. A
  patch-based synthesis has seams only at patch borders; a coordinate map that decays
  over a shot breaks into many small pieces and this share grows.
* ``detail``: the mean absolute colour difference of the pairs (summed over channels):
  a texture that blurs loses it, one that breaks into tiles with hard edges gains it.

Pure functions of arrays.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import PJIT


@njit(**PJIT)
def _seams(sx, sy, lab, scale, tol):
    h, w = lab.shape
    pairs = np.zeros(h, np.int64)
    seams = np.zeros(h, np.int64)
    t2 = tol * tol
    for i in prange(h):
        n = 0
        s = 0
        for j in range(w):
            if j + 1 < w and lab[i, j + 1] == lab[i, j]:
                n += 1
                dx = np.float64(sx[i, j + 1]) - sx[i, j] - scale
                dy = np.float64(sy[i, j + 1]) - sy[i, j]
                if dx * dx + dy * dy > t2:
                    s += 1
            if i + 1 < h and lab[i + 1, j] == lab[i, j]:
                n += 1
                dx = np.float64(sx[i + 1, j]) - sx[i, j]
                dy = np.float64(sy[i + 1, j]) - sy[i, j] - scale
                if dx * dx + dy * dy > t2:
                    s += 1
        pairs[i] = n
        seams[i] = s
    return pairs.sum(), seams.sum()


def seam_share(sx: np.ndarray, sy: np.ndarray, labels: np.ndarray, *, scale: float = 1.0,
               tol: float = 1.0) -> float:
    """Share of same-label 4-adjacent pixel pairs whose source positions are not neighbours.

    Parameters
    ----------
    sx, sy : (M, N) float ndarray
        The coordinate map (``source.x``, ``source.y``).
    labels : (M, N) integer ndarray
        ``label.id``; pairs across a label border are not counted.
    scale : float
        Source pixels per output pixel (the expected step between neighbours).
    tol : float
        Largest distance, in source pixels, between a pair's step and the expected step.
    """
    lab = np.ascontiguousarray(labels, np.uint32)
    n, s = _seams(np.ascontiguousarray(sx, np.float32), np.ascontiguousarray(sy, np.float32), lab,
                  float(scale), float(tol))
    return float(s) / n if n else 0.0


@njit(**PJIT)
def _detail(rgb, lab):
    h, w, c = rgb.shape
    pairs = np.zeros(h, np.int64)
    total = np.zeros(h, np.float64)
    for i in prange(h):
        n = 0
        t = 0.0
        for j in range(w):
            if j + 1 < w and lab[i, j + 1] == lab[i, j]:
                n += 1
                for k in range(c):
                    t += abs(np.float64(rgb[i, j + 1, k]) - rgb[i, j, k])
            if i + 1 < h and lab[i + 1, j] == lab[i, j]:
                n += 1
                for k in range(c):
                    t += abs(np.float64(rgb[i + 1, j, k]) - rgb[i, j, k])
        pairs[i] = n
        total[i] = t
    return pairs.sum(), total.sum()


def detail(rgb: np.ndarray, labels: np.ndarray) -> float:
    """Mean absolute colour difference (summed over channels) of same-label 4-adjacent pairs.

    rgb : (M, N, C) float ndarray; labels : (M, N) integer ndarray.
    """
    n, t = _detail(np.ascontiguousarray(rgb, np.float32), np.ascontiguousarray(labels, np.uint32))
    return float(t) / n if n else 0.0


def repetition(sx: np.ndarray, sy: np.ndarray, source_shape: tuple[int, int], *, top: float = 0.01) -> float:
    """Share of the output's pixels drawn from the most-used ``top`` share of source pixels
    (``source.x/y`` rounded to source pixels). A synthesis that copies the source evenly
    gives about ``top`` times the output/source area ratio, capped at 1; the same few
    source patches tiled on a lattice give much more."""
    counts = _source_uses(sx, sy, source_shape)
    return _top_share(counts, top) / counts.sum()


def _source_uses(sx: np.ndarray, sy: np.ndarray, source_shape: tuple[int, int]) -> np.ndarray:
    """How many output pixels draw on each source pixel (flat, ``source.x/y`` rounded)."""
    hs, ws = source_shape
    c = np.clip(np.rint(sx), 0, ws - 1).astype(np.int64)
    r = np.clip(np.rint(sy), 0, hs - 1).astype(np.int64)
    return np.bincount((r * ws + c).ravel(), minlength=hs * ws)


def _top_share(values: np.ndarray, top: float) -> float:
    """The sum of the largest ``top`` share of ``values`` (at least one)."""
    k = max(1, int(round(top * values.size)))
    return float(np.sort(values)[-k:].sum())


def label_repetition(sx: np.ndarray, sy: np.ndarray, labels: np.ndarray, source_labels: np.ndarray, *,
                     top: float = 0.01) -> tuple[float, float]:
    """``repetition`` label by label: for each label of the output, the share of its output
    pixels drawn from the most-used ``top`` share of the source pixels of that label, the
    mean weighted by output area; and the floor ``repetition`` has from the framing alone
    (the share of the most-used ``top`` of all source pixels when every label's source
    pixels are used evenly: a frame showing a label over more area than its share of the
    source uses that label's pixels more often, however well spread). Output pixels whose
    label the source lacks are left out of the first. Returns (per-label measure, floor)."""
    sl = np.asarray(source_labels).astype(np.int64)
    ol = np.asarray(labels).astype(np.int64).ravel()
    n = int(max(sl.max(), ol.max())) + 1
    a = np.bincount(ol, minlength=n).astype(np.float64)  # output pixels per label
    b = np.bincount(sl.ravel(), minlength=n).astype(np.float64)  # source pixels per label
    counts = _source_uses(sx, sy, sl.shape)
    flat = sl.ravel()
    num = den = 0.0
    for lab in np.flatnonzero((a > 0) & (b > 0)):
        cl = counts[flat == lab]
        if cl.sum() > 0:
            num += a[lab] * _top_share(cl, top) / cl.sum()
            den += a[lab]
    rate = np.where(b > 0, a / np.maximum(b, 1.0), 0.0)[flat]  # uses per source pixel, evenly spread
    floor = _top_share(rate, top) / max(a[b > 0].sum(), 1.0)
    return (float(num / den) if den else 0.0), floor



def rare_looks(source_srgb: np.ndarray, source_labels: np.ndarray, *, tail: float = 0.1,
               contrast: float = 0.15) -> np.ndarray:
    """(H, W) bool: each label's rare look, its ``tail`` darkest and ``tail`` brightest
    source pixels by luma (ties at the thresholds included) that differ from the label's
    median luma by at least ``contrast``: the white tents on a plain, the dark bushes along a
    field (a flat sky's brightest pixels are not a look of their own)."""
    sl = np.asarray(source_labels).astype(np.int64)
    lum = luma(np.asarray(source_srgb, np.float64)).ravel()
    flat = sl.ravel()
    out = np.zeros(flat.size, np.bool_)
    for lab in np.unique(flat):
        idx = np.flatnonzero(flat == lab)
        v = np.sort(lum[idx])
        k = max(1, int(round(tail * idx.size)))
        t, med = lum[idx], v[(v.size - 1) // 2]
        out[idx[((t <= v[k - 1]) | (t >= v[-k])) & (np.abs(t - med) >= contrast)]] = True
    return out.reshape(sl.shape)


def rare_use(sx: np.ndarray, sy: np.ndarray, labels: np.ndarray, source_labels: np.ndarray,
             rare: np.ndarray, *, size: int = 16) -> dict[int, tuple[float, float, float]]:
    """How many times the output shows each label's rare look (``rare``, e.g. ``rare_looks``):
    {label: (copies, even, peak)}: ``copies`` the mean uses of its rare source pixels (output
    pixels per source pixel, ``source.x/y`` rounded), ``even`` the label's output pixels per
    source pixel (an even draw over the label: label area in frame / in photo), ``peak`` the
    most copies of one ``size``² window of rare pixels (at least a tenth of it rare). A rare
    look copied across a large frame at the even rate is still visible repetition: its
    copies, not their ratio to ``even``, are what a viewer counts. Labels absent from the
    output or the source are left out."""
    sl = np.asarray(source_labels).astype(np.int64)
    ol = np.asarray(labels).astype(np.int64).ravel()
    n = int(max(sl.max(), ol.max())) + 1
    a = np.bincount(ol, minlength=n).astype(np.float64)
    b = np.bincount(sl.ravel(), minlength=n).astype(np.float64)
    counts = _source_uses(sx, sy, sl.shape).reshape(sl.shape).astype(np.float64)
    rare = np.asarray(rare, np.bool_)
    s = min(size, *sl.shape)
    res = {}
    for lab in np.flatnonzero((a > 0) & (b > 0)):
        m = rare & (sl == lab)
        if not m.any():
            continue
        ii = np.pad(np.where(m, counts, 0.0), ((1, 0), (1, 0))).cumsum(0).cumsum(1)
        im = np.pad(m.astype(np.float64), ((1, 0), (1, 0))).cumsum(0).cumsum(1)
        box = ii[s:, s:] - ii[:-s, s:] - ii[s:, :-s] + ii[:-s, :-s]
        nb = im[s:, s:] - im[:-s, s:] - im[s:, :-s] + im[:-s, :-s]
        ok = nb >= max(1.0, 0.1 * s * s)  # windows holding a rare patch, not one stray pixel
        copies = float(counts[m].mean())
        res[int(lab)] = (copies, float(a[lab] / b[lab]), float((box[ok] / nb[ok]).max()) if ok.any() else copies)
    return res

# ---- fidelity to the photo, label by label (bench/bench_fidelity.py) -------------------------
# Colours are sRGB-encoded in [0, 1] (what a viewer compares); a label's pixels in the
# output are compared with the same label's pixels in the source photo.

def chi2(p: np.ndarray, q: np.ndarray) -> float:
    """χ² distance ½ Σ (p − q)² / (p + q) of two histograms, each normalised to sum 1
    (0: identical, 1: disjoint)."""
    p = np.asarray(p, np.float64).ravel()
    q = np.asarray(q, np.float64).ravel()
    p = p / max(p.sum(), 1e-300)
    q = q / max(q.sum(), 1e-300)
    s = p + q
    nz = s > 0
    return float(0.5 * np.sum((p[nz] - q[nz]) ** 2 / s[nz]))


def colour_histogram(srgb: np.ndarray, bins: int = 8) -> np.ndarray:
    """``bins``³ joint histogram of (n, 3) sRGB colours in [0, 1] (counts)."""
    q = np.clip((np.asarray(srgb, np.float64) * bins).astype(np.int64), 0, bins - 1)
    return np.bincount((q[:, 0] * bins + q[:, 1]) * bins + q[:, 2], minlength=bins ** 3).astype(np.float64)


def pair_gradient(img: np.ndarray, mask: np.ndarray) -> float:
    """Mean absolute difference (summed over channels) of 4-adjacent pixel pairs both in
    ``mask``: ``detail`` restricted to one label."""
    img = np.asarray(img, np.float64)
    if img.ndim == 2:
        img = img[..., None]
    tot, n = 0.0, 0
    for a, b, ma, mb in ((img[:, 1:], img[:, :-1], mask[:, 1:], mask[:, :-1]),
                         (img[1:], img[:-1], mask[1:], mask[:-1])):
        m = ma & mb
        tot += float(np.abs(a - b)[m].sum())
        n += int(m.sum())
    return tot / n if n else 0.0


def luma(srgb: np.ndarray) -> np.ndarray:
    """Rec. 709 weights on sRGB-encoded values (a display luma), (H, W)."""
    return srgb[..., 0] * 0.2126 + srgb[..., 1] * 0.7152 + srgb[..., 2] * 0.0722


def window_histograms(lum: np.ndarray, mask: np.ndarray, *, win: int = 11, bins: int = 16,
                      stride: int = 1) -> np.ndarray:
    """Normalised ``bins``-bin histograms of ``lum`` (in [0, 1]) over the ``mask`` pixels of
    the ``win``×``win`` windows centred on ``mask`` pixels of a ``stride`` grid; (n, bins)
    float32. Windows with fewer than half their pixels in ``mask`` are left out (a window
    straddling a label border says little about the label's texture)."""
    h, w = lum.shape
    r = win // 2
    q = np.clip((lum * bins).astype(np.int64), 0, bins - 1)
    ys, xs = np.mgrid[r:h - r:stride, r:w - r:stride]
    keep = mask[ys, xs]
    ys, xs = ys[keep], xs[keep]
    out = np.empty((len(ys), bins), np.float64)
    for b in range(bins):
        ind = np.pad(((q == b) & mask).astype(np.int64), ((1, 0), (1, 0))).cumsum(0).cumsum(1)
        out[:, b] = (ind[ys + r + 1, xs + r + 1] - ind[ys - r, xs + r + 1] - ind[ys + r + 1, xs - r]
                     + ind[ys - r, xs - r])
    n = out.sum(1)
    ok = n >= 0.5 * win * win
    return (out[ok] / n[ok, None]).astype(np.float32)


@njit(**PJIT)
def _nearest_chi2(a, b):
    n, k = a.shape
    out = np.empty(n, np.float64)
    for i in prange(n):
        best = np.inf
        for j in range(b.shape[0]):
            d = 0.0
            for t in range(k):
                s = a[i, t] + b[j, t]
                if s > 0:
                    e = a[i, t] - b[j, t]
                    d += e * e / s
                if d >= best:
                    break
            if d < best:
                best = d
        out[i] = 0.5 * best
    return out


def orientation_histogram(lum: np.ndarray, *, bins: int = 18) -> np.ndarray:
    """Magnitude-weighted histogram of gradient orientations of ``lum`` (M, N): central
    differences on the interior pixels, orientation atan2(gy, gx) modulo π (an edge and its
    opposite are one orientation) in ``bins`` equal bins of [0, π), each pixel adding its
    gradient magnitude. Streaks along one direction pile the weight into one bin; compare
    two with ``chi2``. Returns (bins,) float64."""
    y = np.asarray(lum, np.float64)
    gx = (y[1:-1, 2:] - y[1:-1, :-2]) * 0.5
    gy = (y[2:, 1:-1] - y[:-2, 1:-1]) * 0.5
    mag = np.hypot(gx, gy)
    ang = np.mod(np.arctan2(gy, gx), np.pi)
    k = np.minimum((ang * (bins / np.pi)).astype(np.int64), bins - 1)
    return np.bincount(k.ravel(), weights=mag.ravel(), minlength=bins)


def nearest_window_chi2(out_hist: np.ndarray, src_hist: np.ndarray) -> float:
    """Mean over the output's window histograms of the χ² to the nearest source window
    histogram (rows of ``window_histograms``); nan when either side has none."""
    if len(out_hist) == 0 or len(src_hist) == 0:
        return float("nan")
    return float(_nearest_chi2(np.ascontiguousarray(out_hist, np.float32),
                               np.ascontiguousarray(src_hist, np.float32)).mean())


def copies(sx: np.ndarray, sy: np.ndarray, source_shape: tuple[int, int], *, size: int = 16,
           scale: float = 1.0) -> float:
    """The largest number of copies of one ``size``×``size`` source patch in the output:
    output pixels per source pixel (``source.x/y`` rounded; ``scale`` source pixels per
    output pixel), averaged over each ``size``² source window, maximum over windows. Each
    output pixel reads one source position, so a patch pasted n times counts n there
    (a lone repaired pixel does not make a copy)."""
    hs, ws = source_shape
    c = np.clip(np.rint(sx), 0, ws - 1).astype(np.int64)
    r = np.clip(np.rint(sy), 0, hs - 1).astype(np.int64)
    counts = np.bincount((r * ws + c).ravel(), minlength=hs * ws).reshape(hs, ws) * (scale * scale)
    s = min(size, hs, ws)
    ii = np.pad(counts, ((1, 0), (1, 0))).cumsum(0).cumsum(1)
    box = ii[s:, s:] - ii[:-s, s:] - ii[s:, :-s] + ii[:-s, :-s]
    return float(box.max() / (s * s))


def vertical_profile(img: np.ndarray, mask: np.ndarray, *, bins: int = 10) -> np.ndarray:
    """Mean of ``img`` (H, W) over ``mask`` by relative height: in each column the mask's
    pixels from its first row (t = 0, the top) to its last (t = 1, the horizon for a sky),
    ``bins`` bins of t; nan for empty bins."""
    h, w = mask.shape
    rows = np.arange(h)[:, None].repeat(w, 1)
    any_ = mask.any(0)
    top = np.where(any_, np.argmax(mask, 0), 0)
    bottom = np.where(any_, h - 1 - np.argmax(mask[::-1], 0), 0)
    t = (rows - top) / np.maximum(bottom - top, 1)
    k = np.clip((t[mask] * bins).astype(np.int64), 0, bins - 1)
    s = np.bincount(k, weights=np.asarray(img, np.float64)[mask], minlength=bins)
    n = np.bincount(k, minlength=bins)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, s / np.maximum(n, 1), np.nan)


def profile_correlation(a: np.ndarray, b: np.ndarray) -> float:
    """Pearson correlation of two profiles over the bins both have (nan when fewer than 3)."""
    ok = np.isfinite(a) & np.isfinite(b)
    if ok.sum() < 3 or np.std(a[ok]) == 0 or np.std(b[ok]) == 0:
        return float("nan")
    return float(np.corrcoef(a[ok], b[ok])[0, 1])


def label_fidelity(out_srgb: np.ndarray, out_lab: np.ndarray, src_srgb: np.ndarray, src_lab: np.ndarray,
                   label: int, *, window_stride: tuple[int, int] = (16, 3)) -> dict:
    """Per-label figures of an output against its source photo (both sRGB in [0, 1],
    (H, W, 3), and label ids): ``shift`` (mean colour difference per channel, output −
    source), ``std_ratio`` (√ of the summed channel variances, output over source),
    ``hist_chi2`` (8×8×8 colour histograms), ``window_chi2`` (11×11-window 16-bin luma
    histograms, each output window to its nearest same-label source window; output and
    source windows taken every ``window_stride`` pixels), ``grad_ratio`` (``pair_gradient``
    output over source)."""
    mo, ms = out_lab == label, src_lab == label
    o, s = out_srgb[mo].astype(np.float64), src_srgb[ms].astype(np.float64)
    so, ss = np.sqrt(o.var(0).sum()), np.sqrt(s.var(0).sum())
    go, gs = pair_gradient(out_srgb, mo), pair_gradient(src_srgb, ms)
    wo = window_histograms(luma(out_srgb), mo, stride=window_stride[0])
    ws = window_histograms(luma(src_srgb), ms, stride=window_stride[1])
    return {"shift": o.mean(0) - s.mean(0), "std_ratio": so / ss if ss > 0 else float("nan"),
            "hist_chi2": chi2(colour_histogram(o), colour_histogram(s)),
            "window_chi2": nearest_window_chi2(wo, ws), "grad_ratio": go / gs if gs > 0 else float("nan"),
            "share": float(mo.mean())}


# ---- decay over a shot, label by label (bench/bench_shot.py; bench_photos' luma range) ------
# Luma ``lum`` is display luma (``luma`` of sRGB-encoded colours); ``mask`` a label's pixels.

def gradient_magnitude(lum: np.ndarray, mask: np.ndarray) -> float:
    """Mean gradient magnitude √(dx² + dy²) of ``lum`` over the ``mask`` pixels whose right
    and lower neighbours are in ``mask`` too (forward differences; a label border is not
    the texture's gradient); 0 when there are none."""
    lum = np.asarray(lum, np.float64)
    ok = mask[:-1, :-1] & mask[:-1, 1:] & mask[1:, :-1]
    dx = lum[:-1, 1:] - lum[:-1, :-1]
    dy = lum[1:, :-1] - lum[:-1, :-1]
    g = np.sqrt(dx * dx + dy * dy)[ok]
    return float(g.mean()) if g.size else 0.0


BLOCK_PERIODS = (3.0, 4.0, 5.0)


def _hann_dft(d2: np.ndarray, ok: np.ndarray, win: int, periods) -> np.ndarray:
    """Power of the Hann-windowed DFT of |``d2``| less its window mean (rows) at each
    period, one row per non-overlapping ``win``-long window (starting at column 0) that
    lies wholly in ``ok``: (windows, periods)."""
    h, w = d2.shape
    n = w // win
    if n == 0:
        return np.zeros((0, len(periods)))
    a = d2[:, :n * win].reshape(h, n, win)
    full = ok[:, :n * win].reshape(h, n, win).all(-1)
    a = np.abs(a[full])
    a = (a - a.mean(-1, keepdims=True)) * np.hanning(win)  # (k, win)
    t = np.arange(win)
    return np.stack([np.abs(a @ np.exp(-2j * np.pi * t / p)) ** 2 for p in periods], axis=-1)


def block_windows(lum: np.ndarray, mask: np.ndarray, *, win: int = 20, periods=BLOCK_PERIODS) -> np.ndarray:
    """``block_spectrum``'s power per window: (windows, periods), the rows' windows then the
    columns'."""
    lum = np.asarray(lum, np.float64)
    mask = np.asarray(mask, bool)
    parts = []
    for L, M in ((lum, mask), (lum.T, mask.T)):
        d2 = L[:, :-2] - 2 * L[:, 1:-1] + L[:, 2:]
        ok = M[:, :-2] & M[:, 1:-1] & M[:, 2:]
        parts.append(_hann_dft(d2, ok, win, periods))
    return np.concatenate(parts)


def block_spectrum(lum: np.ndarray, mask: np.ndarray, *, win: int = 20, periods=BLOCK_PERIODS) -> np.ndarray:
    """How much the second differences' energy repeats at each of ``periods`` (pixels):
    the magnitudes of the horizontal second differences |L[x−1] − 2L[x] + L[x+1]| along
    rows and of the vertical ones along columns, cut into non-overlapping ``win``-pixel
    windows wholly in ``mask``, each less its mean and Hann-windowed; the power of their
    DFT at frequency 1/period, summed over windows and both directions. A mosaic of n×n
    blocks puts a pair of spikes in the second difference at every block edge, n pixels
    apart, whatever the steps' signs: a line at period n in the magnitudes (wherever the
    blocks' grid lies: the power of a window does not depend on its phase)."""
    return block_windows(lum, mask, win=win, periods=periods).sum(0)


def block_of(e: np.ndarray) -> float:
    """``blockiness`` of a spectrum at periods (p − 1, p, p + 1): the middle over the sides' mean."""
    side = 0.5 * (e[0] + e[2])
    return float(e[1] / side) if side > 0 else float("nan")


def blockiness(lum: np.ndarray, mask: np.ndarray, *, period: float = 4.0, win: int = 20) -> float:
    """Energy of the luma's second differences at ``period`` over the mean of the
    neighbouring periods (``period`` ∓ 1), ``block_spectrum``; nan where the label has no
    whole window. 4×4 blocks (magnified synthesis pixels carried as blocks) raise it;
    white noise scores about 1 (a texture's value depends on its spectrum, so it is
    compared with frame 1's)."""
    return block_of(block_spectrum(lum, mask, win=win, periods=(period - 1.0, period, period + 1.0)))


def block_ratio_sd(after: np.ndarray, before: np.ndarray, *, n: int = 400, seed: int = 0) -> float:
    """Bootstrap standard deviation of ``blockiness`` of one frame over another's, from
    their ``block_windows`` at periods (3, 4, 5) (``after``, ``before``): each frame's
    windows resampled with replacement, ``n`` times (a fixed ``seed``). The noise of a
    label's block ratio: a label with few whole windows swings by more than the 1.1 bar
    from frame to frame while nothing changes."""
    after = np.asarray(after, np.float64)
    before = np.asarray(before, np.float64)
    if len(after) == 0 or len(before) == 0:
        return float("nan")
    rng = np.random.default_rng(seed)
    r = [block_of(after[rng.integers(0, len(after), len(after))].sum(0))
         / block_of(before[rng.integers(0, len(before), len(before))].sum(0)) for _ in range(n)]
    return float(np.nanstd(r))


def label_range(src_lum: np.ndarray, src_mask: np.ndarray, *, lo: float = 0.5, hi: float = 99.5) -> tuple[float, float]:
    """The ``lo``–``hi`` percentile range of the photo's luma over a label's pixels."""
    a, b = np.percentile(np.asarray(src_lum, np.float64)[src_mask], [lo, hi])
    return float(a), float(b)


def outside_share(lum: np.ndarray, mask: np.ndarray, rng: tuple[float, float], *, eps: float = 1e-6) -> float:
    """Share of the ``mask`` pixels whose luma lies outside ``rng`` (``label_range`` of the
    photo's label) by more than ``eps``: bench_photos' ``outside``; 0 for an empty mask."""
    v = np.asarray(lum, np.float64)[mask]
    return float(((v < rng[0] - eps) | (v > rng[1] + eps)).mean()) if v.size else 0.0


def source_outside_share(sx: np.ndarray, sy: np.ndarray, mask: np.ndarray, src_lum: np.ndarray,
                         rng: tuple[float, float], *, eps: float = 1e-6) -> float:
    """Share of the ``mask`` pixels whose source pixel (``source.x/y`` rounded, clamped to
    the photo) has a luma outside ``rng`` (the photo label's ``label_range``): pixels that
    copy what the label rarely looks like (a source pixel of another label, or the label's
    outliers in the photo). A copy that uses the label's photo pixels evenly scores about
    the share the range leaves out (1 % for 0.5–99.5 %); clumps and ghosts raise it."""
    hs, ws = src_lum.shape
    c = np.clip(np.rint(np.asarray(sx, np.float64)[mask]), 0, ws - 1).astype(np.int64)
    r = np.clip(np.rint(np.asarray(sy, np.float64)[mask]), 0, hs - 1).astype(np.int64)
    v = np.asarray(src_lum, np.float64)[r, c]
    return float(((v < rng[0] - eps) | (v > rng[1] + eps)).mean()) if v.size else 0.0


def _copy_centres(py: np.ndarray, px: np.ndarray, size: int) -> np.ndarray:
    """(n, 2) centres of the copies among output pixels (py, px) that read one source window
    of side ``size``: pixels binned in ``size``² output blocks (pieces under a sixteenth of a
    window dropped: stray or repaired pixels), pieces whose centres lie within 3/4 ``size``
    joined (a whole copy straddles up to four blocks, its pieces' centres ``size`` / 2 apart
    along each axis), each copy's centre its pixels' mean."""
    b = (py // size) * (1 << 20) + px // size
    ub, inv, n = np.unique(b, return_inverse=True, return_counts=True)
    cy = np.bincount(inv, py) / n
    cx = np.bincount(inv, px) / n
    keep = n >= max(1, size * size // 16)
    cy, cx, n = cy[keep], cx[keep], n[keep].astype(np.float64)
    m = len(n)
    comp = np.arange(m)
    if m > 1:
        near = np.hypot(cy[:, None] - cy[None], cx[:, None] - cx[None]) < 0.75 * size
        for i in range(m):  # single linkage: each piece takes the smallest id it reaches
            stack = [i]
            while stack:
                k = stack.pop()
                for t in np.flatnonzero(near[k] & (comp > comp[i])):
                    comp[t] = comp[i]
                    stack.append(t)
    _, g = np.unique(comp, return_inverse=True)
    w = np.bincount(g, n)
    return np.stack([np.bincount(g, n * cy) / w, np.bincount(g, n * cx) / w], -1) if m else np.zeros((0, 2))


def copy_spacing(sx: np.ndarray, sy: np.ndarray, labels: np.ndarray, source_labels: np.ndarray, *,
                 size: int = 16, top: int = 8, close: float = 0.25, source_luma: np.ndarray | None = None,
                 flat: float = 0.03, looks: np.ndarray | None = None) -> dict[int, tuple[float, float, float, float]]:
    """Visible repetition: how near each other the copies of a label's most-used source
    windows sit on the frame. For each label, its ``top`` most-used ``size``² source windows
    (a ``size`` grid over the source; uses: the label's output pixels reading them); for each
    copy of such a window (``_copy_centres``) the distance d to the nearest other copy of it,
    against the spacing s = √(label area in frame / copies) an even spread of that many copies
    over the label would give; with ``source_luma`` (the photo's, sRGB) only windows whose luma
    varies by at least ``flat`` (standard deviation) count: a flat patch of sky repeated is not
    seen; with ``looks`` (H, W bool, e.g. ``rare_looks``) only windows at least a tenth of whose
    pixels are such looks (a bush, a tent: what a viewer recognises again). {label: (median
    d / s, share of copies with d < ``close`` s, median d in output pixels, mean copies per
    window)}: 1 and 0 for copies on a lattice, about
    0.5 and 0.18 (at ``close`` 0.25) for copies placed at random, less for copies clustered
    (the same bush twice within a screenful). The copy count itself is forced by the frame's
    area; where the copies lie is not. Labels with fewer than two copies of any such window
    are left out."""
    sl = np.asarray(source_labels).astype(np.int64)
    ol = np.asarray(labels).astype(np.int64)
    hs, ws = sl.shape
    c = np.clip(np.rint(sx), 0, ws - 1).astype(np.int64)
    r = np.clip(np.rint(sy), 0, hs - 1).astype(np.int64)
    ncx = -(-ws // size)
    cell = (r // size) * ncx + c // size
    own = sl[r, c] == ol
    ncy = -(-hs // size)
    varied = np.ones(ncy * ncx, np.bool_)
    if source_luma is not None:
        cells = ((np.arange(hs)[:, None] // size) * ncx + np.arange(ws)[None] // size).ravel()
        lum = np.asarray(source_luma, np.float64).ravel()
        n = np.bincount(cells, minlength=ncy * ncx)
        m1 = np.bincount(cells, lum, minlength=ncy * ncx) / np.maximum(n, 1)
        m2 = np.bincount(cells, lum * lum, minlength=ncy * ncx) / np.maximum(n, 1)
        varied = np.sqrt(np.maximum(m2 - m1 * m1, 0.0)) >= flat
    if looks is not None:
        cells = ((np.arange(hs)[:, None] // size) * ncx + np.arange(ws)[None] // size).ravel()
        share = np.bincount(cells, np.asarray(looks, np.float64).ravel(), minlength=ncy * ncx)
        varied &= share >= 0.1 * size * size
    res = {}
    for lab in np.unique(ol):
        area = float((ol == lab).sum())
        py, px = np.nonzero(own & (ol == lab))
        if not len(py):
            continue
        cl = cell[py, px]
        uses = np.where(varied, np.bincount(cl, minlength=ncy * ncx), 0)
        ratios, dists, ncop = [], [], []
        for w in np.argsort(-uses, kind="stable")[:top]:
            if uses[w] == 0:
                break
            sel = cl == w
            cen = _copy_centres(py[sel], px[sel], size)
            if len(cen) < 2:
                continue
            d = np.hypot(cen[:, None, 0] - cen[None, :, 0], cen[:, None, 1] - cen[None, :, 1])
            np.fill_diagonal(d, np.inf)
            d = d.min(1)
            ratios.append(d / np.sqrt(area / len(cen)))
            dists.append(d)
            ncop.append(len(cen))
        if ratios:
            q, d = np.concatenate(ratios), np.concatenate(dists)
            res[int(lab)] = (float(np.median(q)), float((q < close).mean()), float(np.median(d)), float(np.mean(ncop)))
    return res
