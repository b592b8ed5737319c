"""Looking images up through a coordinate map.

The synthesis state of N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided
Texture Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010 (§5) is a coordinate
map; this reads through it.

The synthesis state is a map from each output pixel to a position in the source
(``source.x``, ``source.y``: column and row in source pixels, pixel centres at integer
values). Every colour of a synthesized plate is read through this one function, so the
same map can be re-applied to any other image or AOV of the source (another exposure,
a time-lapse photo, a relit version, its label map).

Float images are sampled bilinearly with clamp-to-edge (at integer coordinates this is
exactly the pixel), or with a Lanczos filter (``filter="lanczos3"``, 6×6 taps, or
``"lanczos4"``, 8×8 taps: sharp at
fractional positions, where bilinear averages neighbours and loses up to half the
texture's finest detail), or ``"flat4"``: 8×8 taps like Lanczos-4, weighted per phase as the
least-squares fractional delay whose response is flat to 0.9 × Nyquist (``_flat_table``;
Lanczos-4's falls to 0.45 there at half a pixel: a painted texture read at fractional
positions loses a tenth of its gradient), the result clamped to the range of the 4×4
pixels around the position (``_clamp_taps``: the flatter response rings more next to hard
edges and banding; clamped, it adds no gradient there); integer images (ids) take the
nearest pixel, never a blend.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import JIT, PJIT


@njit(**PJIT)
def _bilinear(img, sx, sy, out):
    h, w, c = img.shape
    oh, ow = sx.shape
    for i in prange(oh):
        for j in range(ow):
            x = min(max(np.float64(sx[i, j]), 0.0), w - 1.0)
            y = min(max(np.float64(sy[i, j]), 0.0), h - 1.0)
            x0 = int(np.floor(x))
            y0 = int(np.floor(y))
            fx = x - x0
            fy = y - y0
            x1 = min(x0 + 1, w - 1)
            y1 = min(y0 + 1, h - 1)
            if fx == 0.0 and fy == 0.0:
                for k in range(c):
                    out[i, j, k] = img[y0, x0, k]
                continue
            for k in range(c):
                a = (1.0 - fx) * img[y0, x0, k] + fx * img[y0, x1, k]
                b = (1.0 - fx) * img[y1, x0, k] + fx * img[y1, x1, k]
                out[i, j, k] = (1.0 - fy) * a + fy * b


LANCZOS_BINS = 4096  # phases of the weight tables: positions are read to 1/4096 pixel


def _lanczos_table(a: int, bins: int = LANCZOS_BINS) -> np.ndarray:
    """(bins + 1, 2a) normalised Lanczos-a weights of taps floor(x) − a + 1 … floor(x) + a
    for phases t = x − floor(x) = b / bins; phase 0 is exactly the pixel (1 at its tap)."""
    t = np.arange(bins + 1, dtype=np.float64)[:, None] / bins
    d = np.arange(-a + 1, a + 1, dtype=np.float64)[None, :] - t
    w = np.sinc(d) * np.sinc(d / a)
    w[np.abs(d) >= a] = 0.0
    w /= w.sum(axis=1, keepdims=True)
    w[0] = 0.0
    w[0, a - 1] = 1.0
    w[bins] = 0.0
    w[bins, a] = 1.0
    return w


def _flat_table(a: int, band: float = 0.9, bins: int = LANCZOS_BINS) -> np.ndarray:
    """(bins + 1, 2a) weights of taps floor(x) − a + 1 … floor(x) + a for phases t = b / bins:
    per phase the weights w summing to 1 that minimise ∫₀^Ω |Σ_k w_k e^{iωk} − e^{iωt}|² dω,
    Ω = ``band`` · π (the fractional delay by t, least squares over the band; T. I. Laakso et
    al., "Splitting the unit delay", IEEE Signal Processing Magazine 13(1), 1996: least-squares
    FIR fractional delay over a band).
    Normal equations A w = b − μ 1 with A_kl = ∫ cos(ω(k − l)), b_k = ∫ cos(ω(k − t)); phase 0
    is exactly the pixel (the solution there), as in ``_lanczos_table``."""
    om = band * np.pi
    k = np.arange(-a + 1, a + 1, dtype=np.float64)
    A = om * np.sinc(om * (k[:, None] - k[None, :]) / np.pi)
    t = np.arange(bins + 1, dtype=np.float64)[:, None] / bins
    b = om * np.sinc(om * (k[None, :] - t) / np.pi)  # (bins + 1, 2a)
    Ai = np.linalg.inv(A)
    u = Ai @ np.ones(2 * a)
    w = b @ Ai  # A symmetric: rows are A⁻¹ b
    w += np.outer(1.0 - w.sum(axis=1), u / u.sum())  # the constraint Σ w = 1
    w[0] = 0.0
    w[0, a - 1] = 1.0
    w[bins] = 0.0
    w[bins, a] = 1.0
    return w


_LANCZOS = {"lanczos3": _lanczos_table(3), "lanczos4": _lanczos_table(4), "flat4": _flat_table(4)}
FLAT4 = _LANCZOS["flat4"]  # (bins + 1, 8) flat4 weights per phase, for kernels that read with them
FLAT2 = _flat_table(2, 0.5)  # (bins + 1, 4): 4x4 taps flat to 0.5 x Nyquist (0.95 there, gain <= 1.014 below)


@njit(**JIT)
def _tap_start(x, size, bins, a):
    """(first tap, phase bin) of position x (clamped into [0, size − 1])."""
    x = min(max(x, 0.0), size - 1.0)
    x0 = int(np.floor(x))
    return x0 - a + 1, int(np.floor((x - x0) * bins + 0.5))


@njit(inline="always", **JIT)
def _lanczos_colour(img, xs, ys, bx, by, table, inside):
    """The first three channels of ``img`` under the separable Lanczos taps from (ys, xs)
    (rows of taps summed first, then weighted by row); taps clamped at the border unless
    ``inside``."""
    h, w = img.shape[0], img.shape[1]
    n = table.shape[1]
    r0 = r1 = r2 = 0.0
    for r in range(n):
        yy = ys + r if inside else min(max(ys + r, 0), h - 1)
        t0 = t1 = t2 = 0.0
        for t in range(n):
            xx = xs + t if inside else min(max(xs + t, 0), w - 1)
            wx = table[bx, t]
            t0 += wx * img[yy, xx, 0]
            t1 += wx * img[yy, xx, 1]
            t2 += wx * img[yy, xx, 2]
        wy = table[by, r]
        r0 += wy * t0
        r1 += wy * t1
        r2 += wy * t2
    return r0, r1, r2


@njit(**PJIT)
def _lanczos(img, sx, sy, table, out):
    h, w, c = img.shape
    oh, ow = sx.shape
    bins = table.shape[0] - 1
    n = table.shape[1]
    a = n // 2
    for i in prange(oh):
        acc = np.zeros(c, np.float64)
        row = np.zeros(c, np.float64)
        for j in range(ow):
            xs, bx = _tap_start(np.float64(sx[i, j]), w, bins, a)
            ys, by = _tap_start(np.float64(sy[i, j]), h, bins, a)
            if bx == 0 and by == 0:
                for k in range(c):
                    out[i, j, k] = img[ys + a - 1, xs + a - 1, k]
                continue
            inside = xs >= 0 and ys >= 0 and xs + n <= w and ys + n <= h
            if c == 3:  # colour: scalar accumulators
                out[i, j, 0], out[i, j, 1], out[i, j, 2] = _lanczos_colour(img, xs, ys, bx, by, table, inside)
                continue
            acc[:] = 0.0
            for r in range(n):
                yy = min(max(ys + r, 0), h - 1)
                row[:] = 0.0
                for t in range(n):
                    xx = min(max(xs + t, 0), w - 1)
                    for k in range(c):
                        row[k] += table[bx, t] * img[yy, xx, k]
                for k in range(c):
                    acc[k] += table[by, r] * row[k]
            for k in range(c):
                out[i, j, k] = acc[k]


@njit(inline="always", **JIT)
def _range4(img, x, y, k):
    """(lo, hi) of channel ``k`` over the 4×4 pixels around position (x, y) (floor − 1 …
    floor + 2, clamped to the image): ``_clamp_taps``'s range."""
    h, w = img.shape[0], img.shape[1]
    x0 = int(np.floor(min(max(x, 0.0), w - 1.0)))
    y0 = int(np.floor(min(max(y, 0.0), h - 1.0)))
    lo = np.inf
    hi = -np.inf
    for r in range(y0 - 1, y0 + 3):
        rr = min(max(r, 0), h - 1)
        for t in range(x0 - 1, x0 + 3):
            v = img[rr, min(max(t, 0), w - 1), k]
            lo = min(lo, v)
            hi = max(hi, v)
    return lo, hi


@njit(**PJIT)
def _lanczos_rgb(img, rgbx, sx, sy, table, mask, clamp, out):
    """``_lanczos`` of a colour image read from ``rgbx``: ``img`` itself, or for many reads a
    float64 copy with its channels padded to four ((M, N, 4): no conversion per tap, aligned
    pixels), the Lanczos-4 taps unrolled; every sum in ``_lanczos``'s order (bit-identical
    output; a 1024² read of a 600×800 source, one thread: 0.058 s padded, 0.082 s from
    ``img``, 0.104 s by ``_lanczos`` and ``_clamp_taps``). Pixels where ``mask`` (when not empty) is
    False are 0, not read. ``clamp``: each value clamped to its 4×4 pixels' range
    (``_range4``) as it is written, the numbers ``_clamp_taps`` gives after the read."""
    h, w, c = img.shape
    oh, ow = sx.shape
    bins = table.shape[0] - 1
    n = table.shape[1]
    a = n // 2
    masked = mask.size > 0
    for i in prange(oh):
        for j in range(ow):
            if masked and not mask[i, j]:
                out[i, j, 0] = out[i, j, 1] = out[i, j, 2] = 0.0
                continue
            xs, bx = _tap_start(np.float64(sx[i, j]), w, bins, a)
            ys, by = _tap_start(np.float64(sy[i, j]), h, bins, a)
            if bx == 0 and by == 0:
                for k in range(3):
                    out[i, j, k] = img[ys + a - 1, xs + a - 1, k]
                continue
            inside = xs >= 0 and ys >= 0 and xs + n <= w and ys + n <= h
            if inside and n == 8:  # Lanczos-4 away from the border: fixed trip counts, unrolled
                r0 = r1 = r2 = 0.0
                for r in range(8):
                    t0 = t1 = t2 = 0.0
                    for t in range(8):
                        wx = table[bx, t]
                        t0 += wx * rgbx[ys + r, xs + t, 0]
                        t1 += wx * rgbx[ys + r, xs + t, 1]
                        t2 += wx * rgbx[ys + r, xs + t, 2]
                    wy = table[by, r]
                    r0 += wy * t0
                    r1 += wy * t1
                    r2 += wy * t2
                if clamp:  # the 4x4 pixels around: taps 2..5 (the float64 copies of img's values)
                    lo0 = lo1 = lo2 = np.inf
                    hi0 = hi1 = hi2 = -np.inf
                    for r in range(2, 6):
                        for t in range(2, 6):
                            lo0 = min(lo0, rgbx[ys + r, xs + t, 0])
                            hi0 = max(hi0, rgbx[ys + r, xs + t, 0])
                            lo1 = min(lo1, rgbx[ys + r, xs + t, 1])
                            hi1 = max(hi1, rgbx[ys + r, xs + t, 1])
                            lo2 = min(lo2, rgbx[ys + r, xs + t, 2])
                            hi2 = max(hi2, rgbx[ys + r, xs + t, 2])
                    out[i, j, 0] = min(max(np.float32(r0), lo0), hi0)
                    out[i, j, 1] = min(max(np.float32(r1), lo1), hi1)
                    out[i, j, 2] = min(max(np.float32(r2), lo2), hi2)
                else:
                    out[i, j, 0] = r0
                    out[i, j, 1] = r1
                    out[i, j, 2] = r2
                continue
            out[i, j, 0], out[i, j, 1], out[i, j, 2] = _lanczos_colour(rgbx, xs, ys, bx, by, table, inside)
            if clamp:
                for k in range(3):
                    lo, hi = _range4(img, np.float64(sx[i, j]), np.float64(sy[i, j]), k)
                    out[i, j, k] = min(max(out[i, j, k], lo), hi)


@njit(**PJIT)
def _nearest(img, sx, sy, out):
    h, w, c = img.shape
    oh, ow = sx.shape
    for i in prange(oh):
        for j in range(ow):
            x = int(np.floor(min(max(np.float64(sx[i, j]), 0.0), w - 1.0) + 0.5))
            y = int(np.floor(min(max(np.float64(sy[i, j]), 0.0), h - 1.0) + 0.5))
            x = min(x, w - 1)
            y = min(y, h - 1)
            for k in range(c):
                out[i, j, k] = img[y, x, k]


@njit(**PJIT)
def _clamp_taps(img, sx, sy, mask, out):
    """``out`` clamped in place, per channel, to the range of the 4×4 pixels around each
    position (floor − 1 … floor + 2, clamped to the image): a filter's ringing next to a
    hard edge goes no further than the pixels on either side. Pixels where ``mask`` (when
    not empty) is False are left alone."""
    h, w, c = img.shape
    oh, ow = sx.shape
    masked = mask.size > 0
    for i in prange(oh):
        for j in range(ow):
            if masked and not mask[i, j]:
                continue
            for k in range(c):
                lo, hi = _range4(img, np.float64(sx[i, j]), np.float64(sy[i, j]), k)
                out[i, j, k] = min(max(out[i, j, k], lo), hi)


FILTERS = ("bilinear", "lanczos3", "lanczos4", "flat4")
CLAMPED = ("flat4",)  # read, then clamped to the 4×4 pixels' range (_clamp_taps)


def padded_rgb(image: np.ndarray) -> np.ndarray:
    """(M, N, 4) float64: a colour image's channels padded to four, as ``lookup`` reads a
    colour image it reads at many positions (``lookup``'s ``padded``: made once for many reads)."""
    out = np.zeros(image.shape[:2] + (4,), np.float64)
    out[..., :3] = image
    return out


def lookup(image: np.ndarray, sx: np.ndarray, sy: np.ndarray, *, filter: str = "bilinear",
           mask: np.ndarray | None = None, padded: np.ndarray | None = None) -> np.ndarray:
    """Sample ``image`` at source positions ``(sx, sy)``.

    Parameters
    ----------
    image : (M, N) or (M, N, C) ndarray
        A source image or AOV. Float images are sampled bilinearly, integer images
        (label or object ids) at the nearest pixel.
    sx, sy : (P, Q) float ndarray
        Column and row in ``image`` pixels (centres at integers); clamped to the image.
        Read as float32 (exact for integers below 2**24).
    filter : {'bilinear', 'lanczos3', 'lanczos4', 'flat4'}
        Reconstruction of float images between pixel centres. All are exactly the pixel
        at integer positions; ``lanczos3`` / ``lanczos4`` (windowed sinc, 6×6 / 8×8 taps, phases to 1/4096
        pixel, clamp-to-edge) keeps the fine detail that bilinear blurs at fractional
        positions, at the cost of a slight ringing next to hard edges; ``flat4`` (8×8 taps,
        flat to 0.9 × Nyquist, clamped to the 4×4 pixels' range) keeps more of it
        without the ringing.
    mask : (P, Q) bool ndarray, optional
        Only these pixels are read; the others are 0.
    padded : (M, N, 4) float64 ndarray, optional
        ``padded_rgb(image)``, kept by a caller that reads the same colour image every frame:
        used where ``lookup`` would make it (a Lanczos or flat read of at least as many
        positions as the image has pixels); the same numbers.

    Returns
    -------
    (P, Q) or (P, Q, C) ndarray
        float32 for float images, the image's dtype for integer images.
    """
    if filter not in FILTERS:
        raise ValueError(f"{filter!r} is not a valid filter. Valid filters are 'bilinear', 'lanczos3', 'lanczos4' and 'flat4'")
    image = np.asarray(image)
    sx = np.ascontiguousarray(sx, dtype=np.float32)  # one compiled signature for every caller
    sy = np.ascontiguousarray(sy, dtype=np.float32)
    if sx.shape != sy.shape or sx.ndim != 2:
        raise ValueError(f"sx and sy must be 2-D and the same shape, got {sx.shape} and {sy.shape}")
    if image.ndim not in (2, 3):
        raise ValueError(f"image must be (M, N) or (M, N, C), got shape {image.shape}")
    flat = image.ndim == 2
    img = np.ascontiguousarray(image[..., None] if flat else image)
    if np.issubdtype(img.dtype, np.integer) or img.dtype == np.bool_:
        out = np.empty(sx.shape + (img.shape[2],), img.dtype)
        _nearest(img, sx, sy, out)
    else:
        img = img.astype(np.float32, copy=False)
        out = np.empty(sx.shape + (img.shape[2],), np.float32)
        m = np.zeros((0, 0), np.bool_) if mask is None else np.ascontiguousarray(mask, np.bool_)
        if filter in _LANCZOS and img.shape[2] == 3:
            rgbx = img
            if sx.size >= img.shape[0] * img.shape[1]:
                # many reads of a colour image: pad it to four float64 channels once (vector sums)
                if padded is not None and padded.shape == img.shape[:2] + (4,) and padded.dtype == np.float64:
                    rgbx = np.ascontiguousarray(padded)
                else:
                    rgbx = padded_rgb(img)
            _lanczos_rgb(img, rgbx, sx, sy, _LANCZOS[filter], m, filter in CLAMPED, out)  # clamped as read
            mask = None  # applied
        else:
            if filter in _LANCZOS:
                _lanczos(img, sx, sy, _LANCZOS[filter], out)
            else:
                _bilinear(img, sx, sy, out)
            if filter in CLAMPED:
                _clamp_taps(img, sx, sy, m, out)
    if mask is not None:
        out[~np.asarray(mask, bool)] = 0
    return out[..., 0] if flat else out


def lookup_plate(plate, sx: np.ndarray, sy: np.ndarray, names=None) -> dict[str, np.ndarray]:
    """Look up channels of a source plate (default: all of them) through a coordinate map.

    Returns ``{name: (P, Q) array}`` with each channel's dtype (float16 read as float32).
    """
    names = list(plate.names() if names is None else names)
    out = {}
    for n in names:
        a = plate[n]
        v = lookup(a, sx, sy)
        out[n] = v.astype(a.dtype) if a.dtype == np.uint32 else v.astype(np.float32)
    return out


def lookup_many(source: np.ndarray, xs: np.ndarray, ys: np.ndarray, filter: str) -> np.ndarray:
    """``lookup`` of a list of positions (xs, ys) (1-D), read in rows of 1024 so that its
    parallel loop over rows shares them between threads (each read is independent of the
    others: the same numbers as one row). (n, C) float32 for a float (H, W, C) image."""
    n = len(xs)
    if n == 0:
        return np.zeros((0, 3), np.float32)
    width = 1024
    m = -(-n // width) * width
    X = np.zeros(m, np.float32)
    Y = np.zeros(m, np.float32)
    X[:n] = xs
    Y[:n] = ys
    return np.ascontiguousarray(lookup(source, X.reshape(-1, width), Y.reshape(-1, width), filter=filter)
                                .reshape(m, -1)[:n], np.float32)
