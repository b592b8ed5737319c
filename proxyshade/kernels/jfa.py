"""Jump flooding with a label-favouring metric, for depth extension (Bonneel et al. 2010, §4.3, §7).

"Pixels in the synthesized guide that have the same labels as the corresponding pixels in
the proxy guide are assigned the proxy depth. For each pixel in the remaining regions, we
assign the depth of the closest pixel having the same label both in the proxy and the
synthesized guide." Implemented with jump flooding (Rong and Tan 2006) and "a base metric
similar to the distance transform but including an additional constant term to favour
seeds with the same label", in "a 2+JFA+1 scheme".

Our reading of 2+JFA+1: two preparatory passes of steps 2 and 1, the standard passes of
steps N/2, N/4, ..., 1, then one more pass of step 1 (each extra pass repairs some of
JFA's rare misses). The metric of seed s for pixel p is the squared Euclidean distance
plus ``penalty`` when the seed's label differs from p's label.

Every pass reads one buffer and writes another, each thread owning its pixels, so the
result does not depend on the thread count. A seed whose own label is the one it wants
costs 0 and can never change, so passes only visit the other pixels (in depth extension,
the few whose label the detailed guide changed).
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import JIT, PJIT


@njit(**JIT)
def _cost(i, j, si, sj, lab_p, seed_lab, penalty):
    d = float((i - si) * (i - si) + (j - sj) * (j - sj))
    if seed_lab != lab_p:
        d += penalty
    return d


@njit(**PJIT)
def _pass(seed_in, seed_out, labels, seed_labels, step, penalty, active):
    h, w = labels.shape
    for a in prange(active.shape[0]):
        i = active[a] // w
        j = active[a] % w
        best = seed_in[i, j]
        if best >= 0:
            bc = _cost(i, j, best // w, best % w, labels[i, j], seed_labels[best // w, best % w], penalty)
        else:
            bc = np.inf
        for di in (-step, 0, step):
            ii = i + di
            if ii < 0 or ii >= h:
                continue
            for dj in (-step, 0, step):
                jj = j + dj
                if jj < 0 or jj >= w or (di == 0 and dj == 0):
                    continue
                s = seed_in[ii, jj]
                if s < 0 or s == best:
                    continue
                c = _cost(i, j, s // w, s % w, labels[i, j], seed_labels[s // w, s % w], penalty)
                if c < bc or (c == bc and s < best):
                    bc = c
                    best = s
        seed_out[i, j] = best


def jump_flood(is_seed: np.ndarray, labels: np.ndarray, seed_labels: np.ndarray, *, penalty: float = 1024.0) -> np.ndarray:
    """Nearest seed of every pixel under distance² + ``penalty``·(label differs).

    Parameters
    ----------
    is_seed : (H, W) bool
    labels : (H, W) int
        The label each pixel wants its seed to have.
    seed_labels : (H, W) int
        The label of each pixel as a seed.
    penalty : float
        Added to the squared distance of a seed of another label.

    Returns
    -------
    (H, W) int64 flat index (row * W + col) of the chosen seed, −1 where there are no seeds.
    """
    h, w = labels.shape
    a = np.where(is_seed, np.arange(h * w, dtype=np.int64).reshape(h, w), -1)
    b = a.copy()
    labels = np.ascontiguousarray(labels, dtype=np.int64)
    seed_labels = np.ascontiguousarray(seed_labels, dtype=np.int64)
    # a seed of its own label costs 0 and never changes: only the other pixels are updated
    active = np.flatnonzero(~(is_seed & (labels == seed_labels))).astype(np.int64)
    n = 1
    while n < max(h, w):
        n *= 2
    steps = [2, 1]
    s = n // 2
    while s >= 1:
        steps.append(s)
        s //= 2
    steps.append(1)
    for st in steps:
        _pass(a, b, labels, seed_labels, st, float(penalty), active)
        a, b = b, a
    return a
