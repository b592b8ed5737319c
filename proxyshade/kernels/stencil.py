"""The 5-point operator of the Poisson correction (``kernels.poisson``), shared by its two
solvers (``kernels.multigrid``, ``kernels.sor``).

Bonneel, van de Panne, Lefebvre, Drettakis. Proxy-Guided Texture Synthesis for Rendering
Natural Scenes. INRIA RR-7298, 2010 (§5 step 3: the Poisson transfer this operator poses).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from proxyshade.kernels._config import JIT

# ---------------------------------------------------------------------------
# operators: level = (diag, wE, wS); (A x)_p = diag_p x_p - sum_q w_pq x_q.
# diag == 0 marks a cell with no unknown (fixed). The finest level's edge weights are 0 or 1
# (1 between two cells with unknowns): uint8 from ``fine_operator``, or not stored at all
# (empty weight arrays: ``edge`` reads them from the diagonal, so the multigrid levels share
# one float32 signature per kernel and a 4K frame holds 16 MiB less); float32 on the coarse
# levels. A weight is read as float32 in every case, so every product and sum is the same.


@njit(**JIT)
def edge(diag, wt, i, j, i2, j2):
    """The weight ``wt[i, j]`` of the edge (i, j)-(i2, j2) as float32; an empty ``wt``:
    the finest level's, 1 where both cells have an unknown (diag != 0), else 0; ``None``:
    the same, chosen when the kernel is typed (numba prunes the ``is None`` branch: no test
    of the array in the compiled loop, so the finest level's own kernels compile and run
    faster). Not inlined by numba (that would skip the pruning); LLVM inlines it."""
    if wt is None:
        return np.float32((diag[i, j] != 0.0) & (diag[i2, j2] != 0.0))
    if wt.shape[0] == 0:
        return np.float32((diag[i, j] != 0.0) & (diag[i2, j2] != 0.0))
    return np.float32(wt[i, j])


@njit(inline="always", **JIT)
def neighbour_sum(diag, x, we, ws, i, j, h, w):
    """Sum over the 4 neighbours of (i, j) of edge weight × x, per channel (east weights
    ``we[i, j]`` join (i, j)-(i, j+1), south weights ``ws[i, j]`` join (i, j)-(i+1, j))."""
    i, j = np.int64(i), np.int64(j)  # one signature of ``edge`` (a prange index is uint64)
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    if j + 1 < w:
        c = edge(diag, we, i, j, i, j + 1)
        s0 += c * x[i, j + 1, 0]
        s1 += c * x[i, j + 1, 1]
        s2 += c * x[i, j + 1, 2]
    if j > 0:
        c = edge(diag, we, i, j - 1, i, j)
        s0 += c * x[i, j - 1, 0]
        s1 += c * x[i, j - 1, 1]
        s2 += c * x[i, j - 1, 2]
    if i + 1 < h:
        c = edge(diag, ws, i, j, i + 1, j)
        s0 += c * x[i + 1, j, 0]
        s1 += c * x[i + 1, j, 1]
        s2 += c * x[i + 1, j, 2]
    if i > 0:
        c = edge(diag, ws, i - 1, j, i, j)
        s0 += c * x[i - 1, j, 0]
        s1 += c * x[i - 1, j, 1]
        s2 += c * x[i - 1, j, 2]
    return s0, s1, s2


@njit(**JIT)
def fine_operator(fixed, screen):
    """The finest level's operator: diag (float32: in-image neighbours + ``screen`` at a
    free pixel, 0 at a fixed one) and the east and south weights (uint8: 1 between two
    free pixels, else 0)."""
    h, w = fixed.shape
    diag = np.zeros((h, w), np.float32)
    we = np.zeros((h, w), np.uint8)
    ws = np.zeros((h, w), np.uint8)
    for i in range(h):  # serial: a few milliseconds a frame (a parallel loop compiles 1 s slower)
        for j in range(w):
            if fixed[i, j]:
                continue
            n = 0
            if i > 0:
                n += 1
            if i + 1 < h:
                n += 1
                if not fixed[i + 1, j]:
                    ws[i, j] = 1.0
            if j > 0:
                n += 1
            if j + 1 < w:
                n += 1
                if not fixed[i, j + 1]:
                    we[i, j] = 1.0
            diag[i, j] = n + screen
    return diag, we, ws


@njit(inline="always", **JIT)
def apply_at(diag, we, ws, x, i, j):
    """(A x)_(i, j) for the three channels."""
    i, j = np.int64(i), np.int64(j)  # one signature of ``edge`` (a prange index is uint64)
    h, w = diag.shape
    d = diag[i, j]
    s0 = d * x[i, j, 0]
    s1 = d * x[i, j, 1]
    s2 = d * x[i, j, 2]
    if j + 1 < w:
        c = edge(diag, we, i, j, i, j + 1)
        s0 -= c * x[i, j + 1, 0]
        s1 -= c * x[i, j + 1, 1]
        s2 -= c * x[i, j + 1, 2]
    if j > 0:
        c = edge(diag, we, i, j - 1, i, j)
        s0 -= c * x[i, j - 1, 0]
        s1 -= c * x[i, j - 1, 1]
        s2 -= c * x[i, j - 1, 2]
    if i + 1 < h:
        c = edge(diag, ws, i, j, i + 1, j)
        s0 -= c * x[i + 1, j, 0]
        s1 -= c * x[i + 1, j, 1]
        s2 -= c * x[i + 1, j, 2]
    if i > 0:
        c = edge(diag, ws, i - 1, j, i, j)
        s0 -= c * x[i - 1, j, 0]
        s1 -= c * x[i - 1, j, 1]
        s2 -= c * x[i - 1, j, 2]
    return s0, s1, s2
