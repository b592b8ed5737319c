"""Voting stack and pyramid of a label map (Bonneel et al. 2010, §4.2).

"the use of discrete identifiers precludes building a multiresolution Gaussian stack ...
We thus build a voting stack from which we can extract a voting pyramid ... by keeping
the identifier which is the most present in a N×N kernel around each pixel. The kernel
size is scaled by a factor of two at each level of the stack. The pyramid is extracted
from the stack by sampling the stack every 2^l pixels ... This corresponds to median
filtering when we only have two labels."

Conventions (shared by the texture synthesis of ``kernels.features``):

* levels are listed coarsest first; level ``l`` of ``nlevels`` has spacing
  ``h = 2 ** (nlevels - 1 - l)``, the finest (``h = 1``) is the labels themselves;
* the stack level of spacing ``h`` votes over the ``h × h`` kernel covering offsets
  ``-h/2 .. h/2 - 1`` (rows and columns) around each pixel, clipped at the image border;
* the pyramid samples that stack at ``h/2 + m h``, i.e. pyramid pixel ``m`` is the vote of
  the block ``[m h, (m + 1) h)`` (clipped) — computed here directly on the blocks;
* ties go to the smallest label index.

Labels are dense indices ``0..n-1`` (int32).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from proxyshade.kernels._config import JIT


# serial: 0.1 ms a call (label pyramids); a parallel loop compiled 0.5 s longer
@njit(**JIT)
def _vote_stack_level(lab, k, n, out):
    """Most frequent label in the k × k window (offsets -k//2 .. k - k//2 - 1, clipped)
    of every pixel; a sliding column histogram along each row."""
    H, W = lab.shape
    lo = k // 2
    for i in range(H):
        y0 = max(i - lo, 0)
        y1 = min(i - lo + k, H)
        cnt = np.zeros(n, np.int64)
        for x in range(0, min(k - lo, W)):
            for y in range(y0, y1):
                cnt[lab[y, x]] += 1
        for j in range(W):
            if j > 0:
                xa = j - lo + k - 1  # column entering
                if xa < W:
                    for y in range(y0, y1):
                        cnt[lab[y, xa]] += 1
                xr = j - 1 - lo  # column leaving
                if xr >= 0:
                    for y in range(y0, y1):
                        cnt[lab[y, xr]] -= 1
            best = 0
            for l in range(1, n):
                if cnt[l] > cnt[best]:
                    best = l
            out[i, j] = best


@njit(**JIT)
def _vote_blocks(lab, h, n, out, r0, r1):
    """out[m, q] = most frequent label of the block [m h, (m+1) h) x [q h, (q+1) h), rows
    m in r0..r1."""
    H, W = lab.shape
    Ho, Wo = out.shape
    for m in range(r0, r1):
        cnt = np.zeros(n, np.int64)
        for q in range(Wo):
            cnt[:] = 0
            for y in range(m * h, min((m + 1) * h, H)):
                for x in range(q * h, min((q + 1) * h, W)):
                    cnt[lab[y, x]] += 1
            best = 0
            for l in range(1, n):
                if cnt[l] > cnt[best]:
                    best = l
            out[m, q] = best


def vote_filter(lab: np.ndarray, k: int, n: int) -> np.ndarray:
    """(H, W) labels -> (H, W) int32 majority vote over each pixel's k × k kernel."""
    lab = np.ascontiguousarray(lab, np.int32)
    if k == 1:
        return lab.copy()
    out = np.empty(lab.shape, np.int32)
    _vote_stack_level(lab, int(k), int(n), out)
    return out


def vote_down(lab: np.ndarray, h: int, n: int) -> np.ndarray:
    """One pyramid level: the vote of each h × h block; shape ``len(range(h // 2, H, h))``
    by the same for W (i.e. ``ceil(H / h)`` unless the last block is shorter than h/2)."""
    lab = np.ascontiguousarray(lab, np.int32)
    if h == 1:
        return lab.copy()
    H, W = lab.shape
    out = np.empty((len(range(h // 2, H, h)), len(range(h // 2, W, h))), np.int32)
    _vote_blocks(lab, int(h), int(n), out, 0, out.shape[0])
    return out


def vote_stack(lab: np.ndarray, nlevels: int, n: int) -> list[np.ndarray]:
    """Voting stack, coarsest first: ``nlevels`` (H, W) int32 maps; the level of spacing
    h votes over an h × h kernel (the finest is ``lab`` itself)."""
    lab = np.ascontiguousarray(lab, np.int32)
    return [lab if h == 1 else vote_filter(lab, h, n) for h in (2 ** (nlevels - 1 - l) for l in range(nlevels))]


def vote_pyramid(lab: np.ndarray, nlevels: int, n: int) -> list[np.ndarray]:
    """Voting pyramid, coarsest first: the stack sampled every h pixels (from h/2)."""
    lab = np.ascontiguousarray(lab, np.int32)
    return [lab if h == 1 else vote_down(lab, h, n) for h in (2 ** (nlevels - 1 - l) for l in range(nlevels))]
