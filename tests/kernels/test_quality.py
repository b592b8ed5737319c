"""quality.repetition and label_repetition against slow references, and what they tell apart."""
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


def label_repetition_ref(sx, sy, labels, source_labels, top):
    hs, ws = source_labels.shape
    use = Counter()
    for x, y in zip(sx.ravel(), sy.ravel()):
        use[(min(max(int(np.rint(y)), 0), hs - 1), min(max(int(np.rint(x)), 0), ws - 1))] += 1
    num = den = 0.0
    rates = []
    for lab in sorted(set(labels.ravel().tolist())):
        pix = [(y, x) for y in range(hs) for x in range(ws) if source_labels[y, x] == lab]
        area = int((labels == lab).sum())
        if not pix:
            continue
        rates += [area / len(pix)] * len(pix)
        counts = sorted((use[p] for p in pix), reverse=True)
        if sum(counts):
            k = max(1, int(round(top * len(pix))))
            num += area * sum(counts[:k]) / sum(counts)
            den += area
    k = max(1, int(round(top * hs * ws)))
    floor = sum(sorted(rates, reverse=True)[:k]) / sum(int((labels == lab).sum()) for lab in set(source_labels.ravel().tolist()))
    return num / den, floor


def test_label_repetition_matches_reference_on_random_maps():
    rng = np.random.default_rng(4)
    for _ in range(4):
        src_lab = rng.integers(1, 4, (14, 19)).astype(np.uint32)
        sx, sy = rng.uniform(-2, 21, (2, 11, 13)).astype(np.float32)
        lab = rng.integers(1, 5, (11, 13)).astype(np.uint32)  # label 4: not in the source
        got = Q.label_repetition(sx, sy, lab, src_lab, top=0.1)
        assert np.allclose(got, label_repetition_ref(sx, sy, lab, src_lab, 0.1))


def test_label_repetition_separates_framing_from_tiling():
    """A frame with more of a small label draws its pixels more often (a higher
    ``repetition`` and floor) but, spread evenly, not a higher per-label measure; a lattice
    of one patch inside the label raises the per-label measure."""
    src = np.ones((120, 160), np.uint32)
    src[:, 120:] = 2  # label 2: a quarter of the source
    i, j = np.mgrid[0:120, 0:160].astype(np.float32)
    even = Q.label_repetition(j, i, src, src)  # a plain copy
    i, j = np.mgrid[0:120, 0:240].astype(np.float32)  # a wider frame: label 1 as in the source, then
    lab = np.where(j >= 120, 2, 1).astype(np.uint32)  # 120 columns of label 2 from its 40 (each pixel thrice)
    sx = np.where(lab == 2, 120 + (j - 120) % 40, j)
    wide = Q.label_repetition(sx, i, lab, src)
    tiled = Q.label_repetition(np.where(lab == 2, 120 + (j - 120) % 8, j), i % 12, lab, src)
    assert np.isclose(even[0], 0.01, atol=2e-3) and np.isclose(wide[0], 0.01, atol=2e-3)
    assert wide[1] > 1.8 * even[1] and Q.repetition(sx, i, src.shape) > 1.8 * even[1]
    assert tiled[0] > 5 * wide[0]


def _orientation_ref(lum, bins):
    h, w = lum.shape
    out = np.zeros(bins)
    for i in range(1, h - 1):
        for j in range(1, w - 1):
            gx = (lum[i, j + 1] - lum[i, j - 1]) / 2
            gy = (lum[i + 1, j] - lum[i - 1, j]) / 2
            a = np.arctan2(gy, gx)
            a = a + np.pi if a < 0 else a
            a = 0.0 if a >= np.pi else a
            out[min(int(a / np.pi * bins), bins - 1)] += np.hypot(gx, gy)
    return out


def test_orientation_histogram_matches_a_pixel_loop():
    rng = np.random.default_rng(4)
    for bins in (18, 7):
        lum = rng.random((9, 12))
        np.testing.assert_allclose(Q.orientation_histogram(lum, bins=bins), _orientation_ref(lum, bins), rtol=1e-12)


def test_orientation_histogram_tells_streaks_from_an_isotropic_texture():
    rng = np.random.default_rng(5)
    noise = rng.random((64, 64))
    streaks = np.add.outer(np.arange(64), np.arange(64)) % 6 / 6.0  # diagonal stripes
    o_noise, o_streak = Q.orientation_histogram(noise), Q.orientation_histogram(streaks)
    assert o_streak.max() / o_streak.sum() > 0.9  # nearly all weight in one orientation
    assert Q.chi2(Q.orientation_histogram(rng.random((64, 64))), o_noise) < 0.02
    assert Q.chi2(o_streak, o_noise) > 0.5
