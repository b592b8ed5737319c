"""Low frequencies of a label's colour by height: the layout the Poisson step restores.

An option of the Poisson step (§5 step 3) of N. Bonneel, M. van de Panne, S. Lefebvre, G.
Drettakis, "Proxy-Guided Texture Synthesis for Rendering Natural Scenes", INRIA RR-7298,
2010; the paper has no such step.

A patch synthesis reproduces a label's texture but not where in the label its colours
sit: a sky from patches of anywhere in the photo's sky loses the photo's darker top and
hazier horizon, a lake drawn mostly from the thick (sunlit) part of the photo's lake
comes out brighter than the photo's lake. ``profile`` measures a label's mean colour by
relative height in its vertical runs (``features.label_heights``: 0 at the run's top, 1
at its bottom), ``smooth_offset`` spreads a per-pixel offset over same-label neighbours
so that it has no edges of its own (two columns whose runs end at different heights).

Pure functions of arrays.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import JIT, PJIT


@njit(inline="always", **JIT)
def _encode(x):
    """IEC 61966-2-1 sRGB encoding of one linear float32 value (negative values clamp to 0)."""
    if x <= np.float32(0.0031308):
        return np.float32(12.92) * max(x, np.float32(0.0))
    return np.float32(1.055) * x ** np.float32(1.0 / 2.4) - np.float32(0.055)


@njit(inline="always", **JIT)
def _decode(v):
    """IEC 61966-2-1 sRGB decoding of one encoded float32 value (negative values clamp to 0)."""
    if v <= np.float32(0.04045):
        return max(v, np.float32(0.0)) / np.float32(12.92)
    return ((v + np.float32(0.055)) / np.float32(1.055)) ** np.float32(2.4)


@njit(**PJIT)
def _cctf_image(img, out, decode):
    h, w, c = img.shape
    for i in prange(h):
        for j in range(w):
            for k in range(c):
                out[i, j, k] = _decode(img[i, j, k]) if decode else _encode(img[i, j, k])


def srgb_encode(lin: np.ndarray) -> np.ndarray:
    """(H, W, 3) linear -> float32 sRGB-encoded (0..1 for 0..1; negative values clamp to 0)."""
    lin = np.ascontiguousarray(lin, np.float32)
    out = np.empty(lin.shape, np.float32)
    _cctf_image(lin, out, False)
    return out


def srgb_decode(enc: np.ndarray) -> np.ndarray:
    """(H, W, 3) sRGB-encoded -> float32 linear (``srgb_encode``'s inverse; negative values clamp to 0)."""
    enc = np.ascontiguousarray(enc, np.float32)
    out = np.empty(enc.shape, np.float32)
    _cctf_image(enc, out, True)
    return out


# Rec. 709 luminance weights (linear RGB), as colour-science's RGB_luminance for sRGB primaries
LUMA = (0.2126, 0.7152, 0.0722)


@njit(**PJIT)
def _luma_encoded(lin, out):
    h, w, _ = lin.shape
    wr, wg, wb = np.float32(LUMA[0]), np.float32(LUMA[1]), np.float32(LUMA[2])
    for i in prange(h):
        for j in range(w):
            y = _encode(wr * lin[i, j, 0] + wg * lin[i, j, 1] + wb * lin[i, j, 2])
            out[i, j, 0] = y
            out[i, j, 1] = y
            out[i, j, 2] = y


def luma_encoded(lin: np.ndarray) -> np.ndarray:
    """(H, W, 3) float32: each pixel's sRGB-encoded luminance (Rec. 709 weights of the
    linear colour), in all three channels (for ``profile``)."""
    lin = np.ascontiguousarray(lin, np.float32)
    out = np.empty(lin.shape, np.float32)
    _luma_encoded(lin, out)
    return out


@njit(**PJIT)
def _move_luma_chroma(lin, field, out):
    h, w, _ = lin.shape
    wr, wg, wb = np.float32(LUMA[0]), np.float32(LUMA[1]), np.float32(LUMA[2])
    for i in prange(h):
        for j in range(w):
            r, g, b = lin[i, j, 0], lin[i, j, 1], lin[i, j, 2]
            y = wr * r + wg * g + wb * b
            yn = _decode(_encode(y) + field[i, j, 0])
            xr = r * np.exp(field[i, j, 1])
            xb = b * np.exp(field[i, j, 2])
            yx = wr * xr + wg * g + wb * xb
            if y > np.float32(1e-8) and yx > np.float32(1e-8):
                s = yn / yx
                out[i, j, 0] = xr * s
                out[i, j, 1] = g * s
                out[i, j, 2] = xb * s
            else:  # black (or negative): the luminance offset alone, neutral
                d = yn - max(y, np.float32(0.0))
                out[i, j, 0] = r + d
                out[i, j, 1] = g + d
                out[i, j, 2] = b + d


def move_luma_chroma(lin: np.ndarray, field: np.ndarray) -> np.ndarray:
    """Linear colours moved by ``field`` (H, W, 3): channel 0 an offset of the luminance on
    the sRGB-encoded scale (the contrast a viewer sees stays where it is constant),
    channels 1 and 2 the logs of gains of R and B relative to G (a white balance: every
    pixel's chromaticity scaled alike, so shadows and highlights keep one hue). Each
    pixel's luminance becomes decode(encode(Y) + field[..., 0]) exactly. (H, W, 3) float32."""
    lin = np.ascontiguousarray(lin, np.float32)
    out = np.empty(lin.shape, np.float32)
    _move_luma_chroma(lin, np.ascontiguousarray(field, np.float32), out)
    return out


@njit(**JIT)
def _profile(img, lab, t, n, bins, sums, counts):
    h, w = lab.shape
    for i in range(h):
        for j in range(w):
            b = min(int(t[i, j] * bins), bins - 1)
            l = lab[i, j]
            counts[l, b] += 1.0
            for c in range(3):
                sums[l, b, c] += img[i, j, c]


def profile(img: np.ndarray, lab: np.ndarray, t: np.ndarray, n: int, bins: int) -> tuple[np.ndarray, np.ndarray]:
    """Mean colour of each dense label 0..n-1 by ``bins`` bins of height ``t``: ((n, bins, 3)
    means, nan where empty; (n, bins) pixel counts)."""
    sums = np.zeros((n, bins, 3))
    counts = np.zeros((n, bins))
    _profile(np.ascontiguousarray(img, np.float32), np.ascontiguousarray(lab, np.int32),
             np.ascontiguousarray(t, np.float32), n, bins, sums, counts)
    with np.errstate(invalid="ignore", divide="ignore"):
        return sums / counts[..., None], counts


@njit(**PJIT)
def _at_height(table, lab, t, out):
    """out[p] = table[lab[p]] linearly interpolated at t[p] between bin centres."""
    h, w = lab.shape
    bins = table.shape[1]
    for i in prange(h):
        for j in range(w):
            x = t[i, j] * bins - 0.5
            b0 = min(max(int(np.floor(x)), 0), bins - 1)
            b1 = min(b0 + 1, bins - 1)
            f = min(max(x - b0, 0.0), 1.0)
            l = lab[i, j]
            for c in range(3):
                out[i, j, c] = (1.0 - f) * table[l, b0, c] + f * table[l, b1, c]


def at_height(table: np.ndarray, lab: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(H, W, 3) float32: each pixel's row of ``table`` (n, bins, 3, finite) at its height."""
    out = np.empty(lab.shape + (3,), np.float32)
    _at_height(np.ascontiguousarray(table, np.float64), np.ascontiguousarray(lab, np.int32),
               np.ascontiguousarray(t, np.float32), out)
    return out


@njit(**JIT)
def _block_sums(v, lab, n, f, out):
    h, w = lab.shape
    for i in range(h):
        for j in range(w):
            l = lab[i, j]
            I = i // f
            J = j // f
            out[I, J, l, 3] += 1.0
            for c in range(3):
                out[I, J, l, c] += v[i, j, c]


@njit(**JIT)
def _box_blocks(s, r):
    """Box sum of radius r over the block grid (separable, clamped)."""
    H, W, n, k = s.shape
    tmp = np.zeros_like(s)
    for I in range(H):
        for J in range(W):
            for d in range(max(J - r, 0), min(J + r + 1, W)):
                for l in range(n):
                    for c in range(k):
                        tmp[I, J, l, c] += s[I, d, l, c]
    out = np.zeros_like(s)
    for I in range(H):
        for d in range(max(I - r, 0), min(I + r + 1, H)):
            for J in range(W):
                for l in range(n):
                    for c in range(k):
                        out[I, J, l, c] += tmp[d, J, l, c]
    return out


@njit(**PJIT)
def _spread(b, lab, v, f, out):
    """Per pixel: bilinear mix of the four nearest blocks' same-label means (weighted by
    their same-label pixel count); the pixel's own value where no block holds its label."""
    h, w = lab.shape
    H, W = b.shape[0], b.shape[1]
    for i in prange(h):
        y = (i + 0.5) / f - 0.5
        I0 = min(max(int(np.floor(y)), 0), H - 1)
        I1 = min(I0 + 1, H - 1)
        fy = min(max(y - I0, 0.0), 1.0)
        for j in range(w):
            x = (j + 0.5) / f - 0.5
            J0 = min(max(int(np.floor(x)), 0), W - 1)
            J1 = min(J0 + 1, W - 1)
            fx = min(max(x - J0, 0.0), 1.0)
            l = lab[i, j]
            s0 = 0.0
            s1 = 0.0
            s2 = 0.0
            cnt = 0.0
            for k in range(4):
                I = I1 if k >= 2 else I0
                J = J1 if k % 2 == 1 else J0
                wgt = (fy if k >= 2 else 1.0 - fy) * (fx if k % 2 == 1 else 1.0 - fx)
                s0 += wgt * b[I, J, l, 0]
                s1 += wgt * b[I, J, l, 1]
                s2 += wgt * b[I, J, l, 2]
                cnt += wgt * b[I, J, l, 3]
            if cnt > 1e-9:
                out[i, j, 0] = s0 / cnt
                out[i, j, 1] = s1 / cnt
                out[i, j, 2] = s2 / cnt
            else:
                out[i, j, 0] = v[i, j, 0]
                out[i, j, 1] = v[i, j, 1]
                out[i, j, 2] = v[i, j, 2]


def smooth_offset(v: np.ndarray, lab: np.ndarray, n: int, *, block: int = 8, radius: int = 2) -> np.ndarray:
    """``v`` (H, W, 3) averaged over same-label pixels about ``block`` × (2 ``radius`` + 1)
    pixels across (blocks of ``block`` pixels, box of ``radius`` blocks, bilinear back):
    a field that changes within a label only over tens of pixels, never across a label
    border. (H, W, 3) float32."""
    h, w = lab.shape
    lab = np.ascontiguousarray(lab, np.int32)
    v = np.ascontiguousarray(v, np.float32)
    s = np.zeros(((h + block - 1) // block, (w + block - 1) // block, n, 4))
    _block_sums(v, lab, n, block, s)
    out = np.empty((h, w, 3), np.float32)
    _spread(_box_blocks(s, radius), lab, v, block, out)
    return out
