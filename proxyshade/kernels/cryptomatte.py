"""Cryptomatte 1.1 encoding: MurmurHash3 name ids and the ranking pixel filter.

Friedman and Jones 2015, "Fully automatic ID mattes with support for motion blur and
transparency" (SIGGRAPH poster), and the Cryptomatte specification 1.1.0
(github.com/Psyop/Cryptomatte, ``specification/``):

* a name's id is MurmurHash3_x86_32 (seed 0) of its UTF-8 bytes, stored as the float32
  with the same bits except that the exponent is clamped to [1, 254] (no zero, denormal,
  inf or NaN ids); an empty sample has id 0.0;
* the manifest maps each name to the 8 lowercase hex digits of that float's bits;
* each pixel stores the ids that cover it, ranked by coverage (the fraction of the
  pixel's samples they cover), as (id, coverage) pairs: ``<type>00.R/G`` rank 0,
  ``<type>00.B/A`` rank 1, ``<type>01.R/G`` rank 2, ...

MurmurHash3 (Austin Appleby, public domain) is implemented here; ``mmh3`` is only used by
the tests as an independent reference. Pure functions on arrays and strings; no I/O.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import JIT, PJIT

_M32 = 0xFFFFFFFF
_C1 = 0xCC9E2D51
_C2 = 0x1B873593


def _rotl32(x: int, r: int) -> int:
    return ((x << r) | (x >> (32 - r))) & _M32


def _fmix32(h: int) -> int:
    h ^= h >> 16
    h = (h * 0x85EBCA6B) & _M32
    h ^= h >> 13
    h = (h * 0xC2B2AE35) & _M32
    h ^= h >> 16
    return h


def murmurhash3_32(data: bytes | str, seed: int = 0) -> int:
    """MurmurHash3_x86_32 of ``data`` (str is UTF-8 encoded) as an unsigned int in [0, 2**32).

    Matches the reference C++ (and ``mmh3.hash(data, seed, signed=False)``).
    """
    if isinstance(data, str):
        data = data.encode("utf-8")
    n = len(data)
    h = seed & _M32
    nblocks = n // 4
    for i in range(nblocks):
        k = int.from_bytes(data[4 * i:4 * i + 4], "little")
        k = (k * _C1) & _M32
        k = _rotl32(k, 15)
        k = (k * _C2) & _M32
        h ^= k
        h = _rotl32(h, 13)
        h = (h * 5 + 0xE6546B64) & _M32
    tail = data[4 * nblocks:]
    k = 0
    if len(tail) >= 3:
        k ^= tail[2] << 16
    if len(tail) >= 2:
        k ^= tail[1] << 8
    if len(tail) >= 1:
        k ^= tail[0]
        k = (k * _C1) & _M32
        k = _rotl32(k, 15)
        k = (k * _C2) & _M32
        h ^= k
    h ^= n
    return _fmix32(h)


def hash_to_float32(hashes) -> np.ndarray:
    """uint32 hashes -> float32 ids: the same bits with the exponent clamped to [1, 254].

    Parameters
    ----------
    hashes : int or (N,) array of uint32
    """
    h = np.atleast_1d(np.asarray(hashes, dtype=np.uint64)).astype(np.uint32)
    exp = (h >> np.uint32(23)) & np.uint32(0xFF)
    exp = np.clip(exp, 1, 254).astype(np.uint32)
    bits = (h & np.uint32(0x807FFFFF)) | (exp << np.uint32(23))
    return bits.view(np.float32)


def name_id(name: str) -> np.float32:
    """The float32 Cryptomatte id of one name."""
    return hash_to_float32(murmurhash3_32(name))[0]


def id_hex(value) -> str:
    """The manifest's 8 hex digits for a float32 id (its bits, as '%08x')."""
    return "%08x" % int(np.asarray(value, dtype=np.float32).reshape(1).view(np.uint32)[0])


def layer_key(type_name: str) -> str:
    """The 7-character metadata key of a Cryptomatte type: the first hex digits of its hash."""
    return ("%08x" % murmurhash3_32(type_name))[:7]


def manifest(names) -> dict[str, str]:
    """{name: hex id} for ``names`` (sorted by name)."""
    return {n: id_hex(name_id(n)) for n in sorted(names)}


@njit(**PJIT)
def _rank(ids, factor, lut, levels, out_id, out_cov):  # pragma: no cover - compiled
    """Ranked ids and coverages into the zeroed (levels, h, w) ``out_id``, ``out_cov``."""
    h = out_id.shape[1]  # rank-major: (levels, h, w)
    for y in prange(h):
        _rank_row(np.int64(y), ids, factor, lut, levels, out_id, out_cov)


@njit(**JIT)
def _rank_row(y, ids, factor, lut, levels, out_id, out_cov):  # pragma: no cover - compiled
    """Row ``y`` of ``_rank`` (its loop body: a serial kernel compiles faster than the same
    code inside a parallel loop)."""
    w = out_id.shape[2]
    nsamp = factor * factor
    inv = 1.0 / nsamp
    uniq = np.empty(nsamp, dtype=np.uint32)
    count = np.empty(nsamp, dtype=np.int64)
    for x in range(w):
        nu = 0
        for sy in range(factor):
            for sx in range(factor):
                v = ids[y * factor + sy, x * factor + sx]
                if v == 0:
                    continue
                found = False
                for u in range(nu):
                    if uniq[u] == v:
                        count[u] += 1
                        found = True
                        break
                if not found:
                    uniq[nu] = v
                    count[nu] = 1
                    nu += 1
        # selection by coverage (descending), ties by smaller id: deterministic
        for r in range(levels):
            best = -1
            for u in range(nu):
                if count[u] > 0 and (best < 0 or count[u] > count[best]
                                     or (count[u] == count[best] and uniq[u] < uniq[best])):
                    best = u
            if best < 0:  # the remaining ranks stay empty (the outputs come zeroed): with one
                break         # sample per pixel their pages are never touched
            out_id[r, y, x] = lut[uniq[best]]
            out_cov[r, y, x] = np.float32(count[best] * inv)
            count[best] = 0


def rank_coverage(ids: np.ndarray, lut: np.ndarray, *, levels: int = 6, factor: int = 1):
    """Ranked (id, coverage) pairs per pixel from a per-sample id map.

    Parameters
    ----------
    ids : (M * factor, N * factor) uint32 ndarray
        Integer id per sample (``factor`` x ``factor`` samples per output pixel, box
        filtered); 0 means no object and is never ranked.
    lut : (K,) float32 ndarray
        Cryptomatte float id of each integer id (``lut[0]`` is unused); every id in
        ``ids`` must be < K.
    levels : int
        Number of ranks kept.
    factor : int
        Samples per pixel along each axis.

    Returns
    -------
    ids, coverage : (M, N, levels) float32 ndarrays
        (views of rank-major arrays: ``ids[..., r]`` is C-contiguous). Rank r holds the
        r-th most covering id of each pixel (ties: smaller integer id first) and its coverage in [0, 1]; empty ranks are (0, 0).
    """
    ids = np.ascontiguousarray(ids, dtype=np.uint32)
    if factor < 1 or ids.shape[0] % factor or ids.shape[1] % factor:
        raise ValueError(f"id map {ids.shape} is not a multiple of factor {factor}")
    lut = np.ascontiguousarray(lut, dtype=np.float32)
    if ids.size and int(ids.max()) >= lut.shape[0]:
        raise ValueError(f"id {int(ids.max())} has no entry in the lookup table of {lut.shape[0]}")
    h, w = ids.shape[0] // factor, ids.shape[1] // factor
    # computed rank-major, so that each rank (one EXR channel) is a contiguous slice (an
    # (H, W, levels) copy per channel cost more than the ranking at 4K)
    out_id = np.zeros((levels, h, w), np.float32)
    out_cov = np.zeros((levels, h, w), np.float32)
    _rank(ids, factor, lut, levels, out_id, out_cov)
    return np.moveaxis(out_id, 0, -1), np.moveaxis(out_cov, 0, -1)
