"""The one random source: counter-based splitmix64, against a plain-Python reference."""
from __future__ import annotations

import numpy as np

from proxyshade.kernels import random as R

M = (1 << 64) - 1


def mix_ref(x: int) -> int:
    x = ((x ^ (x >> 30)) * 0xBF58476D1CE4E5B9) & M
    x = ((x ^ (x >> 27)) * 0x94D049BB133111EB) & M
    return x ^ (x >> 31)


def rand_ref(seed, a, b, c) -> int:
    x = mix_ref((seed + 0x9E3779B97F4A7C15) & M)
    for k in (a, b, c):
        x = mix_ref(x ^ (k & M))
    return x >> 11


def test_rand_matches_reference_on_random_counters():
    rng = np.random.default_rng(0)
    for seed, a, b, c in rng.integers(0, 2 ** 62, (50, 4)).tolist():
        assert R.rand(seed, a, b, c) == rand_ref(seed, a, b, c)
        assert R.uniform(seed, a, b, c) == rand_ref(seed, a, b, c) / 2 ** 53


def test_uniform_field_is_one_number_per_id():
    ids = np.array([[3, 3, 9], [9, 0, 3]], np.uint32)
    f = R.uniform_field(11, ids)
    assert f[0, 0] == f[0, 1] == f[1, 2] and f[0, 2] == f[1, 0] and f[0, 0] != f[0, 2]
    assert f[0, 0] == np.float32(rand_ref(11, 3, 0, 0) / 2 ** 53) and 0 <= f.min() and f.max() < 1
    assert not np.array_equal(f, R.uniform_field(12, ids))


def test_permutation_is_a_seeded_permutation():
    p = R.permutation(5, 1000)
    assert sorted(p.tolist()) == list(range(1000))
    np.testing.assert_array_equal(p, R.permutation(5, 1000))
    assert not np.array_equal(p, R.permutation(6, 1000))
    keys = [rand_ref(5, i, 0, 0) for i in range(1000)]
    assert [keys[i] for i in p] == sorted(keys)
    # roughly uniform: the first tenth of the order holds about a tenth of each half
    assert 30 < int((p[:100] < 500).sum()) < 70


def test_mix_seed_names_distinct_streams():
    seeds = {R.mix_seed(s, part) for s in range(20) for part in range(20)}
    assert len(seeds) == 400 and min(seeds) >= 0 and max(seeds) < 2 ** 52
    assert R.mix_seed(3, 7) == R.mix_seed(3, 7) != R.mix_seed(7, 3)
