"""MurmurHash3, the float conversion and the ranking filter against independent references."""
import struct

import mmh3
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from proxyshade.kernels import cryptomatte as cm


@given(st.binary(max_size=40), st.integers(0, 2**32 - 1))
@settings(max_examples=300, deadline=None)
def test_murmurhash3_matches_mmh3(data, seed):
    assert cm.murmurhash3_32(data, seed) == mmh3.hash(data, seed, signed=False)


@pytest.mark.parametrize("name", ["", "a", "ab", "abc", "abcd", "sky", "grass", "/World/Car/body", "été ☁"])
def test_murmurhash3_of_names(name):
    assert cm.murmurhash3_32(name) == mmh3.hash(name, 0, signed=False)


def spec_float(hash_32: int) -> float:
    """The specification's Python example (sign handled separately)."""
    mantissa = hash_32 & ((1 << 23) - 1)
    exp = min(max((hash_32 >> 23) & 0xFF, 1), 254) << 23
    sign = hash_32 >> 31
    f = struct.unpack("<f", struct.pack("<I", exp | mantissa))[0]
    return -f if sign else f


@pytest.mark.parametrize("h", [0, 1, 0x007FFFFF, 0x00800000, 0x7F800000, 0x7FFFFFFF, 0x80000000,
                               0xFF800001, 0xFFFFFFFF, 0x3F800000, 0x12345678])
def test_float_conversion_clamps_exponent(h):
    f = cm.hash_to_float32(h)[0]
    assert np.isfinite(f) and f != 0
    assert struct.pack("<f", f) == struct.pack("<f", spec_float(h))
    exp = (int(f.view(np.uint32)) >> 23) & 0xFF
    assert 1 <= exp <= 254


def test_float_conversion_random_hashes_match_spec():
    rng = np.random.default_rng(0)
    hs = rng.integers(0, 2**32, 2000, dtype=np.uint64).astype(np.uint32)
    got = cm.hash_to_float32(hs)
    want = np.array([spec_float(int(h)) for h in hs], np.float32)
    assert np.array_equal(got.view(np.uint32), want.view(np.uint32))


def test_manifest_hex_and_key():
    name = "bunny"
    f = struct.unpack("<f", struct.pack("<I", mmh3.hash(name, 0, signed=False)))[0]
    if not np.isfinite(f) or f == 0:
        pytest.skip("example name hits the clamp")
    assert cm.manifest([name]) == {name: "%08x" % mmh3.hash(name, 0, signed=False)}
    assert cm.layer_key("CryptoLabel") == ("%08x" % mmh3.hash("CryptoLabel", 0, signed=False))[:7]


def naive_rank(ids, lut, levels, factor):
    h, w = ids.shape[0] // factor, ids.shape[1] // factor
    oid = np.zeros((h, w, levels), np.float32)
    ocov = np.zeros((h, w, levels), np.float32)
    for y in range(h):
        for x in range(w):
            block = ids[y * factor:(y + 1) * factor, x * factor:(x + 1) * factor].ravel()
            vals, counts = np.unique(block[block != 0], return_counts=True)
            order = sorted(zip(-counts, vals))
            for r, (c, v) in enumerate(order[:levels]):
                oid[y, x, r] = lut[v]
                ocov[y, x, r] = np.float32(-c / factor**2)
    return oid, ocov


@pytest.mark.parametrize("factor,levels", [(1, 2), (2, 6), (3, 4), (4, 8)])
def test_rank_matches_naive(factor, levels):
    rng = np.random.default_rng(factor * 10 + levels)
    ids = rng.integers(0, 6, (5 * factor, 7 * factor)).astype(np.uint32)
    lut = cm.hash_to_float32(rng.integers(0, 2**32, 6, dtype=np.uint64))
    got = cm.rank_coverage(ids, lut, levels=levels, factor=factor)
    want = naive_rank(ids, lut, levels, factor)
    assert np.array_equal(got[0].view(np.uint32), want[0].view(np.uint32))
    assert np.array_equal(got[1], want[1])
    cov = got[1].sum(-1)
    assert np.all(cov <= 1 + 1e-6)


def test_rank_single_sample_full_coverage():
    ids = np.array([[0, 1], [2, 2]], np.uint32)
    lut = np.array([0, 1.5, -2.5], np.float32)
    rid, rcov = cm.rank_coverage(ids, lut, levels=2)
    assert rid[..., 0].tolist() == [[0, 1.5], [-2.5, -2.5]]
    assert rcov[..., 0].tolist() == [[0, 1], [1, 1]]
    assert not rcov[..., 1].any() and not rid[..., 1].any()


def test_rank_rejects_unknown_id():
    with pytest.raises(ValueError, match="lookup table"):
        cm.rank_coverage(np.array([[3]], np.uint32), np.zeros(2, np.float32))
