"""Temporal coherence kernels: distortion of reprojected coordinates and flag clean-up.

Bonneel et al. 2010, §6.2: "We compute the determinant of the Jacobian J of the
reprojected pixel coordinates ... D = ||det(J) − 1|| which we accumulate across frames.
If D becomes greater than a given threshold, D is reset to 0 and the pixel is flagged for
resynthesis. We perturb D with random noise to avoid a coherent wave ... We remove these
isolated pixels in 5×5 neighborhoods. We dilate remaining flagged regions."

Pure functions on arrays. Randomness is a hash of (seed, row, column), never a global
generator, so serial and parallel runs agree bit for bit.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import JIT, PJIT


@njit(**JIT)
def hash_uniform(seed, i, j):
    """A uniform float in [0, 1) from (seed, i, j): splitmix64 of the packed triple."""
    z = np.uint64(seed) * np.uint64(0x9E3779B97F4A7C15) + np.uint64(i) * np.uint64(0xBF58476D1CE4E5B9) \
        + np.uint64(j) * np.uint64(0x94D049BB133111EB) + np.uint64(0x632BE59BD9B4E019)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    z = z ^ (z >> np.uint64(31))
    return float(z >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@njit(**PJIT)
def jacobian_det(u, v, valid):
    """det J of the map (row, col) -> (u, v) by central differences (one-sided at borders
    and next to invalid pixels). u, v: (H, W) float; valid: (H, W) bool. Invalid pixels get 1.

    J = [[du/dx, du/dy], [dv/dx, dv/dy]] with x = column, y = row.
    """
    h, w = u.shape
    out = np.ones((h, w), np.float64)
    for i0 in prange(h):
        i = np.int64(i0)  # prange indices are unsigned: keep index arithmetic signed
        for j in range(w):
            if not valid[i, j]:
                continue
            # x derivatives
            jl = j - 1 if j > 0 and valid[i, j - 1] else j
            jr = j + 1 if j < w - 1 and valid[i, j + 1] else j
            iu = i - 1 if i > 0 and valid[i - 1, j] else i
            idn = i + 1 if i < h - 1 and valid[i + 1, j] else i
            if jr == jl or idn == iu:
                continue
            dux = (u[i, jr] - u[i, jl]) / (jr - jl)
            dvx = (v[i, jr] - v[i, jl]) / (jr - jl)
            duy = (u[idn, j] - u[iu, j]) / (idn - iu)
            dvy = (v[idn, j] - v[iu, j]) / (idn - iu)
            out[i, j] = dux * dvy - duy * dvx
    return out


@njit(**PJIT)
def accumulate_distortion(d_prev, det, valid, threshold, noise, seed):
    """D += |det − 1| (+ uniform noise in [0, noise)) where valid; where D > threshold, D
    resets to 0 and the pixel is flagged. Returns (D float32, flagged bool)."""
    h, w = det.shape
    d = np.zeros((h, w), np.float32)
    flag = np.zeros((h, w), np.bool_)
    for i in prange(h):
        for j in range(w):
            if not valid[i, j]:
                continue
            x = d_prev[i, j] + abs(det[i, j] - 1.0)
            if noise > 0.0:
                x += noise * hash_uniform(seed, i, j)
            if x > threshold:
                flag[i, j] = True
                x = 0.0
            d[i, j] = x
    return d, flag


@njit(**PJIT)
def remove_isolated(flags, radius, min_neighbours):
    """Unflag pixels with fewer than ``min_neighbours`` other flagged pixels in their
    (2·radius+1)² window (5×5 for radius 2). Reads one array, writes another."""
    h, w = flags.shape
    out = np.zeros((h, w), np.bool_)
    for i in prange(h):
        for j in range(w):
            if not flags[i, j]:
                continue
            n = 0
            for a in range(max(0, i - radius), min(h, i + radius + 1)):
                for b in range(max(0, j - radius), min(w, j + radius + 1)):
                    if flags[a, b]:
                        n += 1
            out[i, j] = n - 1 >= min_neighbours
    return out


@njit(**PJIT)
def dilate(flags, radius):
    """Square dilation by ``radius`` pixels (separable: rows, then columns)."""
    h, w = flags.shape
    tmp = np.zeros((h, w), np.bool_)
    for i in prange(h):
        last = -radius - 1  # last flagged column seen
        for j in range(w):
            if flags[i, j]:
                last = j
            if j - last <= radius:
                tmp[i, j] = True
        nxt = w + radius + 1
        for j in range(w - 1, -1, -1):
            if flags[i, j]:
                nxt = j
            if nxt - j <= radius:
                tmp[i, j] = True
    out = np.zeros((h, w), np.bool_)
    for j in prange(w):
        last = -radius - 1
        for i in range(h):
            if tmp[i, j]:
                last = i
            if i - last <= radius:
                out[i, j] = True
        nxt = h + radius + 1
        for i in range(h - 1, -1, -1):
            if tmp[i, j]:
                nxt = i
            if nxt - i <= radius:
                out[i, j] = True
    return out


@njit(**PJIT)
def uniform_field(seed, h, w):
    """(h, w) float32 of ``hash_uniform(seed, i, j)``: the same numbers the distortion
    noise uses, for seeding per-pixel start values."""
    out = np.empty((h, w), np.float32)
    for i in prange(h):
        for j in range(w):
            out[i, j] = hash_uniform(seed, i, j)
    return out
