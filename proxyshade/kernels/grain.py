"""Grain: a label's detail, scale by scale, measured and re-weighted.

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
def _sat(img, lab, k, r0, r1, c0, c1, sat):
    """``sat`` (r1-r0+1, c1-c0+1, 4) float64: summed-area table, over label ``k``'s box
    (rows [r0, r1), columns [c0, c1)), of the three channels and the count of the pixels
    of label ``k`` (row 0 and column 0 zero). No pixel of ``k`` lies outside its box, so
    a window clipped to the box holds the same pixels of ``k`` as clipped to the image."""
    H, W = r1 - r0, c1 - c0
    for i in prange(H):  # each row's running sums
        for c in range(4):
            sat[i + 1, 0, c] = 0.0
        for j in range(W):
            if lab[r0 + i, c0 + j] == k:
                for c in range(3):
                    sat[i + 1, j + 1, c] = sat[i + 1, j, c] + img[r0 + i, c0 + j, c]
                sat[i + 1, j + 1, 3] = sat[i + 1, j, 3] + 1.0
            else:
                for c in range(4):
                    sat[i + 1, j + 1, c] = sat[i + 1, j, c]
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
def _bands_at(img, sat, i, j, radii, bands):
    """Pixel (i, j)'s layers into ``bands`` (R + 1, 3): b_0 .. b_(R-1), then the low pass;
    ``img`` and (i, j) relative to the box of ``sat``."""
    H, W = sat.shape[0] - 1, sat.shape[1] - 1
    prev0, prev1, prev2 = img[i, j, 0], img[i, j, 1], img[i, j, 2]
    for b in range(radii.shape[0]):
        r = radii[b]
        i0, i1 = max(i - r, 0), min(i + r, H - 1) + 1
        j0, j1 = max(j - r, 0), min(j + r, W - 1) + 1
        n = sat[i1, j1, 3] - sat[i0, j1, 3] - sat[i1, j0, 3] + sat[i0, j0, 3]
        m0 = (sat[i1, j1, 0] - sat[i0, j1, 0] - sat[i1, j0, 0] + sat[i0, j0, 0]) / n
        m1 = (sat[i1, j1, 1] - sat[i0, j1, 1] - sat[i1, j0, 1] + sat[i0, j0, 1]) / n
        m2 = (sat[i1, j1, 2] - sat[i0, j1, 2] - sat[i1, j0, 2] + sat[i0, j0, 2]) / n
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
        _sat(img, lab, k, r0, r1, c0, c1, sat)
        rows = np.zeros((r1 - r0, bins, R), np.float64)
        crow = np.zeros((r1 - r0, bins), np.int64)
        _label_pass(img, lab, hbin, k, r0, c0, sat, radii, _NO_GAINS, rows, crow, _NO_OUT, False)
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
        _sat(img, lab, k, r0, r1, c0, c1, sat)
        _label_pass(img, lab, hbin, k, r0, c0, sat, radii, gains, _NO_ROWS, _NO_COUNTS, out, True)
    return out
