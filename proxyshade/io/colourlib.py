"""colour-science, imported on first use, and its 8-bit sRGB conversions as tables.

Importing colour-science takes about half a CPU second and 60-120 MiB of resident memory
(it pulls in scipy and its plotting helpers). A first frame only converts 8-bit sRGB: the
source photo decoded (``decode_srgb8``) and the preview encoded to 8 bits
(``encode_srgb8``). Both are colour-science's own results, tabulated once per installed
colour-science and numpy (``srgb_tables``, kept in the per-user cache folder): decoding is
the 256 codes through ``cctf_decoding``; encoding a value is the number of code
thresholds it reaches, the thresholds found by bisection on ``cctf_encoding``'s 8-bit
result. A command that converts only 8-bit sRGB thus never imports colour-science after
the first run of an install; the tables give the same bytes as the direct calls
(``tests/io/test_colourlib.py``).
"""
from __future__ import annotations

import functools
import os
import threading
import warnings
from importlib import metadata
from pathlib import Path

import lazy_loader

np = lazy_loader.load("numpy")  # on first use: a fully cached run never loads numpy

_TABLES_FORMAT = 1
_TABLES_LOCK = threading.Lock()  # one thread reads or makes them (writers run on two threads)


@functools.cache
def colour_science():
    """The ``colour`` module (colour-science)."""
    warnings.filterwarnings("ignore", message='.*"Matplotlib" related API features.*')
    import colour

    return colour


def _quantize(enc):
    """colour-science's sRGB encoding (float64) to 8-bit codes, as the previews round it."""
    return (np.clip(enc, 0, 1) * 255 + 0.5).astype(np.uint8)


def _encode_direct(v):
    """8-bit sRGB codes of linear float64 values through colour-science itself."""
    return _quantize(colour_science().cctf_encoding(v, function="sRGB"))


def compute_tables() -> tuple:
    """(decode (256,) float32, thresholds (255,) float64) from colour-science: decode[k] is
    code k's linear value; thresholds[k - 1] the smallest float64 whose encoding rounds to
    code k or more (bisection over the positive doubles' bit patterns, whose order is the
    values' order; the encoding rounded to 8 bits is non-decreasing)."""
    decode = np.asarray(colour_science().cctf_decoding(np.arange(256, dtype=np.float64) / 255.0, function="sRGB"),
                        dtype=np.float32)
    codes = np.arange(1, 256)
    lo = np.zeros(255, np.int64)  # bits of 0.0: below every threshold (its code is 0)
    hi = np.full(255, np.float64(1.0).view(np.int64))  # 1.0 encodes to 255
    if (_encode_direct(np.array([0.0, 1.0])) != [0, 255]).any():
        raise RuntimeError("colour-science's sRGB encoding does not map 0 and 1 to codes 0 and 255")
    while (hi - lo > 1).any():
        mid = lo + (hi - lo) // 2
        up = _encode_direct(mid.view(np.float64)) >= codes
        hi = np.where(up, mid, hi)
        lo = np.where(up, lo, mid)
    return decode, hi.view(np.float64)


def _tables_path() -> Path:
    from proxyshade.io.files import user_cache_dir

    v = lambda d: metadata.version(d)  # noqa: E731 - distribution versions, without importing them
    return user_cache_dir() / "colour" / f"srgb{_TABLES_FORMAT}-colour-{v('colour-science')}-numpy-{v('numpy')}.bin"


def srgb_tables() -> tuple:
    """``compute_tables()``, once per process (``_srgb_tables``), on one thread at a time."""
    with _TABLES_LOCK:
        return _srgb_tables()



@functools.cache
def _srgb_tables() -> tuple:
    """``compute_tables()``, read from the per-user cache folder (``colour/``, named by the
    colour-science and numpy versions) or computed and written there (temporary name and
    rename; a cache that cannot be written only costs the computation next time)."""
    from proxyshade.io.files import temp_for

    path = _tables_path()
    try:
        raw = path.read_bytes()
        if len(raw) == 256 * 4 + 255 * 8:
            decode = np.frombuffer(raw[:1024], "<f4").copy()
            thresholds = np.frombuffer(raw[1024:], "<f8").copy()
            if (np.diff(thresholds) > 0).all() and thresholds[0] > 0 and (np.diff(decode) > 0).all():
                return decode, thresholds
    except OSError:
        pass
    decode, thresholds = compute_tables()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = temp_for(path)
        try:
            tmp.write_bytes(decode.astype("<f4").tobytes() + thresholds.astype("<f8").tobytes())
            os.replace(tmp, path)
        finally:
            if os.path.lexists(tmp):
                tmp.unlink()
    except OSError:
        pass
    return decode, thresholds


@functools.cache
def srgb_encoding_table(steps: int) -> "np.ndarray":
    """colour-science's sRGB encoding of t² at ``steps`` + 1 even t in [0, 1] (float64,
    read-only): a kernel interpolates it at √v, where the encoding is smooth
    (``kernels.temporal._display``)."""
    t = np.linspace(0.0, 1.0, steps + 1)
    table = np.asarray(colour_science().cctf_encoding(t * t, function="sRGB"), np.float64)
    table.flags.writeable = False
    return table


def decode_srgb8(rgb8) -> "np.ndarray":
    """uint8 sRGB codes -> float32 linear: colour-science's ``cctf_decoding`` of code / 255."""
    return srgb_tables()[0][rgb8]


ENCODE_BUCKETS = 4096  # even steps of [0, 1] indexing the codes' thresholds (encode_srgb8)


@functools.cache
def _encode_index() -> tuple:
    """For ``encode_srgb8``: per bucket b of ``ENCODE_BUCKETS``, the count of thresholds at or
    below (b - 1) / N (a start never above a value's code, for any value whose rounded
    v·N falls in bucket b); the thresholds with a NaN after the last (never passed); and the
    most thresholds between a bucket's start and (b + 2) / N (the steps that reach any code)."""
    t = srgb_tables()[1]
    n = ENCODE_BUCKETS
    counts = np.searchsorted(t, np.arange(-1, n + 2) / n, side="right")
    return counts[:n].astype(np.uint8), np.append(t, np.nan), int((counts[3:] - counts[:n]).max())


def encode_srgb8(linear) -> "np.ndarray":
    """Linear float64 values (not NaN) -> uint8 sRGB codes: colour-science's ``cctf_encoding``,
    clipped to [0, 1], times 255, rounded half up. The code is the count of its thresholds
    at or below the value (``np.searchsorted(thresholds, v, side="right")``), found from a
    bucket's start in a few vectorised steps (4.5x faster than the binary search: a 1024-wide
    preview's 0.09 CPU s)."""
    start, thresholds, steps = _encode_index()
    v = np.asarray(linear, np.float64)
    bucket = v * ENCODE_BUCKETS
    np.clip(bucket, 0, ENCODE_BUCKETS - 1, out=bucket)
    code = start[bucket.astype(np.intp)]  # uint8: at most 255, the NaN after the last threshold never passed
    del bucket
    for _ in range(steps):
        code += thresholds[code] <= v
    return code
