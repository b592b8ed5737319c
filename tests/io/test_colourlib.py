"""The 8-bit sRGB tables (io/colourlib.py) give colour-science's own bytes, and spare its import."""
import subprocess
import sys

import numpy as np
import pytest

from proxyshade.io import colourlib


@pytest.fixture
def tables_home(tmp_path, monkeypatch):
    """A per-user cache folder of the test's own, and no tables in this process yet."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    colourlib._srgb_tables.cache_clear()
    yield tmp_path
    colourlib._srgb_tables.cache_clear()


def direct_decode(rgb8):
    c = colourlib.colour_science()
    return np.asarray(c.cctf_decoding(rgb8.astype(np.float64) / 255.0, function="sRGB"), dtype=np.float32)


def direct_encode(v):
    c = colourlib.colour_science()
    return (np.clip(c.cctf_encoding(v, function="sRGB"), 0, 1) * 255 + 0.5).astype(np.uint8)


def test_decode_is_colour_science_bit_for_bit(tables_home):
    rng = np.random.default_rng(1)
    img = rng.integers(0, 256, (37, 53, 3), dtype=np.uint8)
    every = np.arange(256, dtype=np.uint8)
    for a in (img, every):
        got = colourlib.decode_srgb8(a)
        assert got.dtype == np.float32 and got.shape == a.shape
        assert (got.view(np.uint32) == direct_decode(a).view(np.uint32)).all()


def test_encode_is_colour_science_bit_for_bit(tables_home):
    rng = np.random.default_rng(2)
    _, thresholds = colourlib.srgb_tables()
    bits = thresholds.view(np.int64)
    near = np.concatenate([(bits + d).view(np.float64) for d in range(-3, 4)])  # each code's edge, +-3 ulp
    edges = (np.arange(colourlib.ENCODE_BUCKETS + 1) / colourlib.ENCODE_BUCKETS).view(np.int64)
    near = np.concatenate([near] + [(edges[edges + d >= 0] + d).view(np.float64) for d in (-2, -1, 0, 1, 2)])  # the buckets' edges
    cases = [rng.uniform(-0.2, 1.3, 200_000), 10 ** rng.uniform(-7, 0.05, 200_000),
             rng.uniform(0, 1, 100_000).astype(np.float32).astype(np.float64), near,
             np.array([0.0, -0.0, -1.0, 1.0, 2.0, 1e6, 5e-324, 0.0031308, np.inf, -np.inf])]
    for v in cases:
        v = v[rng.permutation(len(v))].reshape(-1, 1)  # any order and shape
        got = colourlib.encode_srgb8(v)
        assert got.dtype == np.uint8 and got.shape == v.shape
        assert (got == direct_encode(v)).all()
    assert colourlib.encode_srgb8(np.array([0.0, 1.0])).tolist() == [0, 255]


def test_tables_are_kept_per_version_and_rebuilt_when_damaged(tables_home):
    first = colourlib.srgb_tables()
    files = list((tables_home / "proxyshade" / "colour").iterdir())
    assert len(files) == 1 and "colour-" in files[0].name and "numpy-" in files[0].name
    colourlib._srgb_tables.cache_clear()
    again = colourlib.srgb_tables()  # read back
    assert all((a == b).all() for a, b in zip(first, again))
    files[0].write_bytes(files[0].read_bytes()[:-8] + np.float64(-1).tobytes())  # thresholds out of order
    colourlib._srgb_tables.cache_clear()
    rebuilt = colourlib.srgb_tables()
    assert all((a == b).all() for a, b in zip(first, rebuilt))
    assert files[0].read_bytes()[-8:] == first[1][-1:].tobytes()


def test_eight_bit_conversions_do_not_import_colour_science(tables_home):
    colourlib.srgb_tables()  # the tables written once
    code = ("import sys, numpy as np; from proxyshade.io.colourlib import decode_srgb8, encode_srgb8; "
            "v = decode_srgb8(np.arange(256, dtype=np.uint8)); "
            "assert (encode_srgb8(v.astype(np.float64)) == np.arange(256)).all(); "
            "print('colour' in sys.modules, 'scipy' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={"XDG_CACHE_HOME": str(tables_home), "PATH": "/usr/bin:/bin"})
    assert out.stdout.split() == ["False", "False"]
