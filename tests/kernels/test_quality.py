"""quality.repetition against a slow reference, and what it tells apart."""
from collections import Counter

import numpy as np

from proxyshade.kernels import quality as Q


def repetition_ref(sx, sy, shape, top):
    hs, ws = shape
    counts = Counter()
    for x, y in zip(sx.ravel(), sy.ravel()):
        counts[(min(max(int(np.rint(y)), 0), hs - 1), min(max(int(np.rint(x)), 0), ws - 1))] += 1
    k = max(1, int(round(top * hs * ws)))
    return sum(sorted(counts.values(), reverse=True)[:k]) / sx.size


def test_repetition_matches_reference_on_random_maps():
    rng = np.random.default_rng(3)
    for _ in range(5):
        sx, sy = rng.uniform(-2, 40, (2, 17, 23)).astype(np.float32)
        assert np.isclose(Q.repetition(sx, sy, (30, 38), top=0.05), repetition_ref(sx, sy, (30, 38), 0.05))


def test_a_lattice_of_one_patch_repeats_far_more_than_a_plain_copy():
    i, j = np.mgrid[0:120, 0:160].astype(np.float32)
    copy = Q.repetition(j, i, (120, 160))  # the whole source once: the top 1% of pixels draw 1%
    tiled = Q.repetition(j % 16, i % 12, (120, 160))  # one 16x12 patch tiled 100 times
    assert np.isclose(copy, 0.01, atol=1e-3) and tiled > 0.9
