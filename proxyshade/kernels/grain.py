"""Grain: a label's detail, scale by scale, measured and re-weighted.

An option of the Poisson step (§5 step 3) of N. Bonneel, M. van de Panne, S. Lefebvre, G.
Drettakis, "Proxy-Guided Texture Synthesis for Rendering Natural Scenes", INRIA RR-7298,
2010; the paper has no such step.

A patch synthesis copies a label's texture from the source photo but not in the photo's
proportions: the correction's colour term favours the blander parts of a region (they are
the easiest to continue coherently) and the Poisson step smooths what is left near seams,
so a synthesized sky or lake has less detail, at every scale, than the photo's (issue 19).
These kernels split an image, label by label, into band-pass layers with box means that
never read another label's pixels,

    b_0 = x − m_1,  b_i = m_i − m_(i+1),  low = m_R,  x = low + Σ b_i,

where m_i is the mean of the pixel's own label over the (2 r_i + 1)² window clipped to the
image (``radii`` r_1 < .. < r_R), measure each layer's energy per label and height bin
(``band_energy``) and rebuild the image with each layer scaled by a gain per label, height
bin and layer (``regrade``). Box means come from one summed-area table per label, over
the label's bounding box.

Pure functions of arrays; labels dense (0..n-1); deterministic for any thread count.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import JIT, PJIT

_CHUNK = 64  # columns per task of the summed-area table's column pass
_NO_GAINS = np.zeros((0, 0, 0), np.float64)  # the arrays a _label_pass does not use
_NO_ROWS = np.zeros((0, 0, 0), np.float64)
_NO_COUNTS = np.zeros((0, 0), np.int64)
_NO_OUT = np.zeros((0, 0, 0), np.float32)


@njit(**JIT)
def _boxes(lab, n):
    """(n, 4) int64: each label's bounding box, rows [r0, r1) and columns [c0, c1)
    (r1 = 0 for a label with no pixel)."""
    H, W = lab.shape
    box = np.empty((n, 4), np.int64)
    for k in range(n):
        box[k, 0], box[k, 1], box[k, 2], box[k, 3] = H, 0, W, 0
    for i in range(H):
        for j in range(W):
            k = lab[i, j]
            box[k, 0] = min(box[k, 0], i)
            box[k, 1] = max(box[k, 1], i + 1)
            box[k, 2] = min(box[k, 2], j)
            box[k, 3] = max(box[k, 3], j + 1)
    return box


@njit(**PJIT)
def _sat(img, lab, k, r0, r1, c0, c1, f, sat):
    """``sat`` (⌈(r1-r0)/f⌉+1, ⌈(c1-c0)/f⌉+1, 4) float64: summed-area table, over label
    ``k``'s box (rows [r0, r1), columns [c0, c1)) cut into f × f blocks from its origin,
    of each block's sums of the three channels and of its count of label-``k`` pixels (row
    0 and column 0 zero; f = 1: the pixels themselves). No pixel of ``k`` lies outside its
    box, so a window clipped to the box holds the same pixels of ``k`` as clipped to the
    image."""
    H, W = (r1 - r0 + f - 1) // f, (c1 - c0 + f - 1) // f
    for bi in prange(H):  # each block row's running sums
        for c in range(4):
            sat[bi + 1, 0, c] = 0.0
        for bj in range(W):
            s0 = s1 = s2 = m = 0.0
            for i in range(r0 + bi * f, min(r0 + bi * f + f, r1)):
                for j in range(c0 + bj * f, min(c0 + bj * f + f, c1)):
                    if lab[i, j] == k:
                        s0 += img[i, j, 0]
                        s1 += img[i, j, 1]
                        s2 += img[i, j, 2]
                        m += 1.0
            sat[bi + 1, bj + 1, 0] = sat[bi + 1, bj, 0] + s0
            sat[bi + 1, bj + 1, 1] = sat[bi + 1, bj, 1] + s1
            sat[bi + 1, bj + 1, 2] = sat[bi + 1, bj, 2] + s2
            sat[bi + 1, bj + 1, 3] = sat[bi + 1, bj, 3] + m
    for c in range(4):
        for j in range(W + 1):
            sat[0, j, c] = 0.0
    nchunk = (W + 1 + _CHUNK - 1) // _CHUNK
    for q in prange(nchunk):  # then down the columns, a block of columns per task
        j0 = q * _CHUNK
        j1 = min(j0 + _CHUNK, W + 1)
        for i in range(1, H + 1):
            for j in range(j0, j1):
                for c in range(4):
                    sat[i, j, c] += sat[i - 1, j, c]


@njit(inline="always", **JIT)
def _win(sat, i0, i1, j0, j1, c):
    """Channel ``c``'s sum over the cells [i0, i1) × [j0, j1) of a summed-area table."""
    return sat[i1, j1, c] - sat[i0, j1, c] - sat[i1, j0, c] + sat[i0, j0, c]


@njit(inline="always", **JIT)
def _bands_at(img, sat, i, j, radii, bands):
    """Pixel (i, j)'s layers into ``bands`` (R + 1, 3): b_0 .. b_(R-1), then the low pass;
    ``img`` and (i, j) relative to the box of ``sat``."""
    H, W = sat.shape[0] - 1, sat.shape[1] - 1
    prev0, prev1, prev2 = img[i, j, 0], img[i, j, 1], img[i, j, 2]
    for b in range(radii.shape[0]):
        r = radii[b]
        i0, i1 = max(i - r, 0), min(i + r, H - 1) + 1
        j0, j1 = max(j - r, 0), min(j + r, W - 1) + 1
        n = _win(sat, i0, i1, j0, j1, 3)
        m0 = _win(sat, i0, i1, j0, j1, 0) / n
        m1 = _win(sat, i0, i1, j0, j1, 1) / n
        m2 = _win(sat, i0, i1, j0, j1, 2) / n
        bands[b, 0] = prev0 - m0
        bands[b, 1] = prev1 - m1
        bands[b, 2] = prev2 - m2
        prev0, prev1, prev2 = m0, m1, m2
    R = radii.shape[0]
    bands[R, 0] = prev0
    bands[R, 1] = prev1
    bands[R, 2] = prev2


@njit(**PJIT)
def _label_pass(img, lab, hbin, k, r0, c0, sat, radii, gains, rows, counts, out, regrade):
    """The pixels of label ``k`` in its box (origin ``r0, c0``, the size of ``sat`` less
    1): with ``regrade``, ``out`` = low + Σ gains[k, bin, i] b_i; else, per box row, each
    layer's summed squared value (over channels) by height bin (``rows`` (rows, bins, R))
    and the pixel count (``counts`` (rows, bins))."""
    H, W = sat.shape[0] - 1, sat.shape[1] - 1
    R = radii.shape[0]
    box = img[r0:r0 + H, c0:c0 + W]
    for i in prange(H):
        bands = np.empty((R + 1, 3), np.float64)
        for j in range(W):
            if lab[r0 + i, c0 + j] != k:
                continue
            _bands_at(box, sat, i, j, radii, bands)
            t = hbin[r0 + i, c0 + j]
            if regrade:
                for c in range(3):
                    v = bands[R, c]
                    for b in range(R):
                        v += gains[k, t, b] * bands[b, c]
                    out[r0 + i, c0 + j, c] = v
            else:
                counts[i, t] += 1
                for b in range(R):
                    rows[i, t, b] += bands[b, 0] ** 2 + bands[b, 1] ** 2 + bands[b, 2] ** 2


def band_energy(img: np.ndarray, lab: np.ndarray, hbin: np.ndarray, radii: np.ndarray, n: int,
                bins: int) -> tuple[np.ndarray, np.ndarray]:
    """Summed layer energies of ``img`` (H, W, 3) by label (``lab`` dense, 0..n-1), height
    bin (``hbin``, 0..bins-1) and layer: (sums (n, bins, R) float64, counts (n, bins)
    int64). A layer's energy at a pixel is its squared value summed over the channels;
    the mean energy of a (label, bin) is sums / counts. Rows are added in order: the same
    figures for any thread count."""
    img = np.ascontiguousarray(img, np.float32)
    lab = np.ascontiguousarray(lab, np.int32)
    hbin = np.ascontiguousarray(hbin, np.int32)
    radii = np.ascontiguousarray(radii, np.int64)
    R = len(radii)
    sums = np.zeros((n, bins, R), np.float64)
    counts = np.zeros((n, bins), np.int64)
    for k, (r0, r1, c0, c1) in enumerate(_boxes(lab, n).tolist()):
        if r1 == 0:
            continue
        sat = np.empty((r1 - r0 + 1, c1 - c0 + 1, 4), np.float64)
        _sat(img, lab, k, r0, r1, c0, c1, 1, sat)
        rows = np.zeros((r1 - r0, bins, R), np.float64)
        crow = np.zeros((r1 - r0, bins), np.int64)
        _label_pass(img, lab, hbin, k, r0, c0, sat, radii, gains=_NO_GAINS, rows=rows, counts=crow, out=_NO_OUT,
                    regrade=False)
        sums[k] = rows.sum(0)  # numpy's pairwise sum over a fixed layout: thread-independent
        counts[k] = crow.sum(0)
    return sums, counts


def regrade(img: np.ndarray, lab: np.ndarray, hbin: np.ndarray, radii: np.ndarray, gains: np.ndarray) -> np.ndarray:
    """``img`` (H, W, 3) rebuilt as low + Σ gains[label, bin, i] · b_i, label by label
    (float32). Gains of 1 give ``img`` back (to rounding)."""
    img = np.ascontiguousarray(img, np.float32)
    lab = np.ascontiguousarray(lab, np.int32)
    hbin = np.ascontiguousarray(hbin, np.int32)
    radii = np.ascontiguousarray(radii, np.int64)
    gains = np.ascontiguousarray(gains, np.float64)
    H, W = lab.shape
    out = np.empty((H, W, 3), np.float32)
    for k, (r0, r1, c0, c1) in enumerate(_boxes(lab, gains.shape[0]).tolist()):
        if r1 == 0:
            continue
        sat = np.empty((r1 - r0 + 1, c1 - c0 + 1, 4), np.float64)
        _sat(img, lab, k, r0, r1, c0, c1, 1, sat)
        _label_pass(img, lab, hbin, k, r0, c0, sat, radii, gains=gains, rows=_NO_ROWS, counts=_NO_COUNTS, out=out,
                    regrade=True)
    return out


# ---- the large layers on f × f blocks (``synthesis.grain.spread``) ----

@njit(**PJIT)
def _block_means(sat, rb, M):
    """``M`` (Hb, Wb, R, 3): for each block of ``sat`` (``_sat``) that holds a pixel of
    its label, the label's mean over the blocks within ±``rb[r]`` blocks of it (clipped to
    the box)."""
    Hb, Wb = sat.shape[0] - 1, sat.shape[1] - 1
    for bi in prange(Hb):
        for bj in range(Wb):
            if _win(sat, bi, bi + 1, bj, bj + 1, 3) == 0.0:
                continue
            for r in range(rb.shape[0]):
                i0, i1 = max(bi - rb[r], 0), min(bi + rb[r], Hb - 1) + 1
                j0, j1 = max(bj - rb[r], 0), min(bj + rb[r], Wb - 1) + 1
                n = _win(sat, i0, i1, j0, j1, 3)
                for c in range(3):
                    M[bi, bj, r, c] = _win(sat, i0, i1, j0, j1, c) / n


@njit(inline="always", **JIT)
def _axis(i, f, nb):
    """The two blocks either side of box coordinate ``i`` (block centres at b·f + (f-1)/2)
    and the second one's bilinear weight."""
    t = (i - 0.5 * (f - 1)) / f
    b0 = int(np.floor(t))
    if b0 < 0:
        return 0, 0, 0.0
    if b0 >= nb - 1:
        return nb - 1, nb - 1, 0.0
    return b0, b0 + 1, t - b0


@njit(**PJIT)
def _block_bins(lab, hbin, k, r0, r1, c0, c1, f, cb):
    """``cb`` (Hb, Wb, bins) int64: each block's count of label-``k`` pixels by height bin."""
    Hb, Wb = cb.shape[0], cb.shape[1]
    for bi in prange(Hb):
        for bj in range(Wb):
            for i in range(r0 + bi * f, min(r0 + bi * f + f, r1)):
                for j in range(c0 + bj * f, min(c0 + bj * f + f, c1)):
                    if lab[i, j] == k:
                        cb[bi, bj, hbin[i, j]] += 1


@njit(**PJIT)
def _block_energy(M, cb, rows):
    """``rows`` (Hb, bins, R − 1): per block row, the layers' summed squared values
    (over channels) at each block's centre, times the block's label pixels of each bin."""
    Hb, Wb, bins = cb.shape
    R = M.shape[2]
    for bi in prange(Hb):
        for bj in range(Wb):
            for l in range(R - 1):
                e = 0.0
                for c in range(3):
                    e += (M[bi, bj, l, c] - M[bi, bj, l + 1, c]) ** 2
                for t in range(bins):
                    rows[bi, t, l] += cb[bi, bj, t] * e


@njit(**PJIT)
def _spread_pass(img, lab, hbin, k, r0, r1, c0, c1, f, sat, M, gains, D, out):
    """The pixels of label ``k`` in its box: ``out`` = x + the change Σ (gains[k, bin, l]
    − 1) (m_l − m_(l+1)) of the pixel's bin, taken at the centres of the surrounding
    blocks that hold a pixel of ``k`` (``D``, filled here) and blended bilinearly."""
    Hb, Wb = sat.shape[0] - 1, sat.shape[1] - 1
    R, bins = M.shape[2], D.shape[2]
    for bi in prange(Hb):
        for bj in range(Wb):
            for t in range(bins):
                for c in range(3):
                    v = 0.0
                    for l in range(R - 1):
                        v += (gains[k, t, l] - 1.0) * (M[bi, bj, l, c] - M[bi, bj, l + 1, c])
                    D[bi, bj, t, c] = v
    for i in prange(r1 - r0):
        y0, y1, ty = _axis(i, f, Hb)
        for j in range(c1 - c0):
            if lab[r0 + i, c0 + j] != k:
                continue
            x0, x1, tx = _axis(j, f, Wb)
            t = hbin[r0 + i, c0 + j]
            d0 = d1 = d2 = wsum = 0.0
            for q in range(4):
                by = y1 if q >= 2 else y0
                bx = x1 if q % 2 == 1 else x0
                w = (ty if q >= 2 else 1.0 - ty) * (tx if q % 2 == 1 else 1.0 - tx)
                if w <= 0.0 or _win(sat, by, by + 1, bx, bx + 1, 3) == 0.0:
                    continue
                wsum += w
                d0 += w * D[by, bx, t, 0]
                d1 += w * D[by, bx, t, 1]
                d2 += w * D[by, bx, t, 2]
            out[r0 + i, c0 + j, 0] = img[r0 + i, c0 + j, 0] + d0 / wsum
            out[r0 + i, c0 + j, 1] = img[r0 + i, c0 + j, 1] + d1 / wsum
            out[r0 + i, c0 + j, 2] = img[r0 + i, c0 + j, 2] + d2 / wsum


def _spread_labels(img, lab, hbin, radii, f, n, gains, bins):
    """The per-label loop of ``spread_energy`` (``gains`` None) and ``spread_regrade``."""
    img = np.ascontiguousarray(img, np.float32)
    lab = np.ascontiguousarray(lab, np.int32)
    hbin = np.ascontiguousarray(hbin, np.int32)
    rb = np.maximum(np.round(np.asarray(radii, np.float64) / f), 1).astype(np.int64)
    R = len(rb)
    regrade = gains is not None
    out = img.copy() if regrade else _NO_OUT
    sums = np.zeros((n, bins, R - 1), np.float64)
    counts = np.zeros((n, bins), np.int64)
    for k, (r0, r1, c0, c1) in enumerate(_boxes(lab, n).tolist()):
        if r1 == 0:
            continue
        hb, wb = (r1 - r0 + f - 1) // f, (c1 - c0 + f - 1) // f
        sat = np.empty((hb + 1, wb + 1, 4), np.float64)
        _sat(img, lab, k, r0, r1, c0, c1, f, sat)
        M = np.zeros((hb, wb, R, 3), np.float64)
        _block_means(sat, rb, M)
        if regrade:
            _spread_pass(img, lab, hbin, k, r0, r1, c0, c1, f=f, sat=sat, M=M, gains=gains,
                         D=np.empty((hb, wb, bins, 3)), out=out)
        else:
            cb = np.zeros((hb, wb, bins), np.int64)
            _block_bins(lab, hbin, k, r0, r1, c0, c1, f, cb)
            rows = np.zeros((hb, bins, R - 1), np.float64)
            _block_energy(M, cb, rows)
            sums[k] = rows.sum(0)
            counts[k] = cb.sum((0, 1))
    return out if regrade else (sums, counts)


def spread_energy(img: np.ndarray, lab: np.ndarray, hbin: np.ndarray, radii: np.ndarray, n: int, bins: int,
                  f: int) -> tuple[np.ndarray, np.ndarray]:
    """Summed energies of the layers between the label means of radii ``radii`` (r_1 <
    .. < r_R; R − 1 layers m_l − m_(l+1)) by label and height bin, as ``band_energy``
    (sums (n, bins, R − 1), counts (n, bins)), on f × f blocks: a block's mean is its
    label's over the blocks within round(r / f) blocks of it, and each of its label's
    pixels counts its block's layers. f = 1 gives ``band_energy``'s layers exactly; for
    radii of 8 f and more (smooth layers) the blocks cost a fraction of the pixel windows
    and differ from them by a few per cent."""
    return _spread_labels(img, lab, hbin, radii, int(f), n, None, bins)


def spread_regrade(img: np.ndarray, lab: np.ndarray, hbin: np.ndarray, radii: np.ndarray, gains: np.ndarray,
                   f: int) -> np.ndarray:
    """``img`` + Σ (gains[label, bin, l] − 1) · b_l over ``spread_energy``'s layers (gains
    (n, bins, R − 1)), the change taken at block centres and blended bilinearly between
    the surrounding blocks that hold the pixel's label: float32; what lies under the
    first radius is left as it is."""
    gains = np.ascontiguousarray(gains, np.float64)
    return _spread_labels(img, lab, hbin, radii, int(f), gains.shape[0], gains, gains.shape[1])
