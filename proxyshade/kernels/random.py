"""The one random source of proxyshade: counter-based, so every number is a pure function
of (seed, counters) and results never depend on call order, thread count or scheduling.

A number is the splitmix64 finaliser (Steele, Lea and Flood, "Fast splittable
pseudorandom number generators", OOPSLA 2014) chained over the seed and up to three
counters (``rand``): each draw is named by what it is for (a pixel, a draw index, a
level), not by how many draws came before. ``mix_seed`` derives the seed of a sub-stream
(a pyramid level, a frame) the same way, from Python.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import JIT, PJIT

_GOLDEN = 0x9E3779B97F4A7C15


@njit(**JIT)
def _mix(x):
    x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return x ^ (x >> np.uint64(31))


@njit(**JIT)
def rand(seed, a, b, c):
    """A uniform integer in [0, 2^53) from the seed and three counters."""
    x = _mix(np.uint64(seed) + np.uint64(_GOLDEN))
    x = _mix(x ^ np.uint64(a))
    x = _mix(x ^ np.uint64(b))
    x = _mix(x ^ np.uint64(c))
    return np.int64(x >> np.uint64(11))


@njit(**JIT)
def uniform(seed, a, b, c):
    """A uniform float in [0, 1) from the seed and three counters (``rand`` / 2^53)."""
    return float(rand(seed, a, b, c)) * (1.0 / 9007199254740992.0)


@njit(**PJIT)
def uniform_field(seed, ids):
    """``uniform(seed, id, 0, 0)`` for each entry of an (H, W) id map (float32): one number
    per id, the same wherever and whenever the id appears."""
    h, w = ids.shape
    out = np.empty((h, w), np.float32)
    for i in prange(h):
        for j in range(w):
            out[i, j] = uniform(seed, ids[i, j], 0, 0)
    return out


@njit(**JIT)
def _keys(seed, n):
    out = np.empty(n, np.int64)
    for i in range(n):
        out[i] = rand(seed, i, 0, 0)
    return out


def permutation(seed: int, n: int) -> np.ndarray:
    """A random order of ``range(n)`` (int64): the indices sorted by their ``rand`` key."""
    return np.argsort(_keys(int(seed), int(n)), kind="stable").astype(np.int64)


def mix_seed(seed: int, *parts: int) -> int:
    """The seed of a sub-stream of ``seed`` named by ``parts`` (a level, a frame):
    non-negative, below 2^52, different for different parts."""
    x = int(seed) & 0xFFFFFFFFFFFFFFFF
    for p in parts:
        x = int(rand(np.uint64(x), np.uint64(int(p) & 0xFFFFFFFFFFFFFFFF), 0x5EED, 0))
    return x >> 1
