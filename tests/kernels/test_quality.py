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


# ---- decay over a shot: gradient, blockiness, luma ranges -------------------------------------

def gradient_ref(lum, mask):
    tot, n = 0.0, 0
    for i in range(lum.shape[0] - 1):
        for j in range(lum.shape[1] - 1):
            if mask[i, j] and mask[i, j + 1] and mask[i + 1, j]:
                tot += ((lum[i, j + 1] - lum[i, j]) ** 2 + (lum[i + 1, j] - lum[i, j]) ** 2) ** 0.5
                n += 1
    return tot / n


def test_gradient_magnitude_matches_reference_and_skips_label_borders():
    rng = np.random.default_rng(7)
    lum = rng.random((19, 23))
    mask = rng.random((19, 23)) < 0.8
    assert np.isclose(Q.gradient_magnitude(lum, mask), gradient_ref(lum, mask))
    two = np.where(np.arange(30)[None, :] < 15, 0.2, 0.9) * np.ones((20, 1))  # two flat labels
    assert Q.gradient_magnitude(two, two < 0.5) == 0.0 and Q.gradient_magnitude(two, two > 0) > 0


def block_spectrum_ref(lum, mask, win, periods):
    import math

    e = [0.0] * len(periods)
    for L, M in ((lum, mask), (lum.T, mask.T)):
        for i in range(L.shape[0]):
            for w0 in range(0, L.shape[1] - 2 - win + 1, win):
                xs = range(w0 + 1, w0 + 1 + win)  # the centres of the second differences
                if not all(M[i, x - 1] and M[i, x] and M[i, x + 1] for x in xs):
                    continue
                a = [abs(L[i, x - 1] - 2 * L[i, x] + L[i, x + 1]) for x in xs]
                d = [(v - sum(a) / win) * (0.5 - 0.5 * math.cos(2 * math.pi * t / (win - 1))) for t, v in enumerate(a)]
                for k, p in enumerate(periods):
                    re = sum(v * math.cos(2 * math.pi * t / p) for t, v in enumerate(d))
                    im = sum(v * math.sin(2 * math.pi * t / p) for t, v in enumerate(d))
                    e[k] += re * re + im * im
    return np.array(e)


def test_block_spectrum_matches_reference():
    rng = np.random.default_rng(8)
    lum = rng.random((27, 45))
    mask = np.ones(lum.shape, bool)
    mask[5:9, 10:30] = False
    mask[:, 40:] = False
    got = Q.block_spectrum(lum, mask, win=8, periods=(3.0, 4.0, 5.0))
    assert np.allclose(got, block_spectrum_ref(lum, mask, 8, (3.0, 4.0, 5.0)))


def test_blockiness_tells_4px_blocks_from_texture_wherever_the_grid_lies():
    """Fine noise scores about 1; the same noise
    magnified into 4×4 blocks scores far higher, at any offset of the block grid, and
    blocks of 3 or 5 pixels do not."""
    rng = np.random.default_rng(9)
    noise = rng.random((240, 240))
    mask = np.ones(noise.shape, bool)
    assert 0.8 < Q.blockiness(noise, mask) < 1.25
    coarse = rng.random((80, 80))
    for off in (0, 1, 3):
        blocks = np.kron(coarse, np.ones((4, 4)))[off:off + 240, off:off + 240]
        assert Q.blockiness(blocks, np.ones(blocks.shape, bool)) > 3
    for n in (3, 5):
        b = np.kron(coarse, np.ones((n, n)))[:240, :240]
        assert Q.blockiness(b, np.ones(b.shape, bool)) < 1
    # on a smooth texture (as photos are) a share of soft-edged blocks raises it with the share
    from scipy import ndimage

    smooth = ndimage.gaussian_filter(noise, 2)
    soft = ndimage.gaussian_filter(np.kron(coarse, np.ones((4, 4)))[:240, :240], 0.5) * smooth.std() / 0.29
    b = [Q.blockiness((1 - a) * smooth + a * soft, mask) for a in (0.0, 0.1, 0.3)]
    assert b[0] < b[1] < b[2] and b[2] > 1.4 * b[0]


def test_block_ratio_sd_is_the_noise_of_a_labels_block_ratio():
    """Per-window powers sum to the spectrum; two frames of the same noise give a ratio near
    1 whose bootstrap sd covers the frame-to-frame swing, larger on a small label (few
    windows) than on a large one; no windows, no figure."""
    rng = np.random.default_rng(11)
    a, b = rng.random((200, 200)), rng.random((200, 200))
    big = np.ones(a.shape, bool)
    small = np.zeros(a.shape, bool)
    small[:22, :22] = True
    wa = Q.block_windows(a, big)
    assert wa.shape[1] == 3 and np.allclose(wa.sum(0), Q.block_spectrum(a, big))
    sd_big = Q.block_ratio_sd(wa, Q.block_windows(b, big))
    sd_small = Q.block_ratio_sd(Q.block_windows(a, small), Q.block_windows(b, small))
    ratio = Q.blockiness(a, big) / Q.blockiness(b, big)
    assert 0 < sd_big < sd_small and abs(ratio - 1) < 4 * sd_big
    assert np.isnan(Q.block_ratio_sd(wa, Q.block_windows(b, np.zeros(a.shape, bool))))


def test_outside_shares_match_a_per_pixel_reference():
    rng = np.random.default_rng(10)
    src = rng.random((30, 40))
    src_mask = rng.random((30, 40)) < 0.5
    lo, hi = Q.label_range(src, src_mask)
    vals = np.sort(src[src_mask])
    assert np.isclose(lo, np.percentile(vals, 0.5)) and np.isclose(hi, np.percentile(vals, 99.5))
    lum = rng.uniform(-0.1, 1.1, (12, 17))
    mask = rng.random((12, 17)) < 0.7
    ref = sum(1 for i in range(12) for j in range(17) if mask[i, j] and not lo - 1e-6 <= lum[i, j] <= hi + 1e-6)
    assert np.isclose(Q.outside_share(lum, mask, (lo, hi)), ref / mask.sum())
    sx, sy = rng.uniform(-3, 43, (12, 17)), rng.uniform(-3, 33, (12, 17))
    n = 0
    for i in range(12):
        for j in range(17):
            if mask[i, j]:
                v = src[min(max(int(np.rint(sy[i, j])), 0), 29), min(max(int(np.rint(sx[i, j])), 0), 39)]
                n += not lo - 1e-6 <= v <= hi + 1e-6
    assert np.isclose(Q.source_outside_share(sx, sy, mask, src, (lo, hi)), n / mask.sum())


def test_source_outside_share_sees_a_copy_of_another_labels_pixels():
    """An even copy of a label's photo pixels leaves out about the range's 1 %; the same
    output reading a clump of another label's pixels counts them."""
    rng = np.random.default_rng(11)
    src = np.concatenate([rng.uniform(0.4, 0.6, (50, 50)), rng.uniform(0.0, 0.1, (50, 50))], 1)  # water | rock
    water = np.zeros(src.shape, bool)
    water[:, :50] = True
    rngw = Q.label_range(src, water)
    i, j = np.mgrid[0:50, 0:50].astype(np.float64)
    out = np.ones((50, 50), bool)
    assert Q.source_outside_share(j, i, out, src, rngw) <= 0.011
    sx = np.where((i < 10) & (j < 10), j + 60, j)  # a 10x10 clump read from the rock
    assert np.isclose(Q.source_outside_share(sx, i, out, src, rngw) - Q.source_outside_share(j, i, out, src, rngw),
                      0.04, atol=0.005)


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


def _plain_with_tents():
    """A 40x60 source: label 0 a flat bright sky (tiny noise), label 1 a grey plain with
    two white 3x3 tents."""
    rng = np.random.default_rng(3)
    lab = np.zeros((40, 60), np.int64)
    lab[20:] = 1
    rgb = np.empty((40, 60, 3))
    rgb[:20] = 0.9 + 0.01 * rng.random((20, 60, 1))
    rgb[20:] = 0.45 + 0.05 * rng.random((20, 60, 1))
    for y, x in ((25, 10), (32, 40)):
        rgb[y:y + 3, x:x + 3] = 1.0
    return lab, rgb


def test_rare_looks_are_a_labels_far_tails_not_a_flat_labels_edges():
    lab, rgb = _plain_with_tents()
    rare = Q.rare_looks(rgb, lab, tail=0.025)
    assert rare[25:28, 10:13].all() and rare[32:35, 40:43].all()
    assert not rare[:20].any()  # the sky's brightest pixels are within the contrast of its median
    assert rare[20:].sum() == 18  # the tents; the plain's darkest pixels are close to its median


def test_rare_use_counts_the_copies_of_a_rare_look():
    """A frame twice the plain's area that draws the plain evenly shows each tent about twice
    (copies = even = 2); one that pastes the first tent over and over shows it far more."""
    lab, rgb = _plain_with_tents()
    rare = Q.rare_looks(rgb, lab)
    yy, xx = np.mgrid[20:40, 0:60]
    sy = np.concatenate([yy, yy], 0).astype(np.float32)  # the plain twice, side by side in rows
    sx = np.concatenate([xx, xx], 0).astype(np.float32)
    out_lab = np.ones(sy.shape, np.int64)
    c, e, w = Q.rare_use(sx, sy, out_lab, lab, rare)[1]
    assert c == 2.0 and e == 2.0 and w == 2.0
    sx2, sy2 = sx.copy(), sy.copy()
    for i in range(0, 40, 4):
        for j in range(0, 60, 4):
            sy2[i:i + 3, j:j + 3], sx2[i:i + 3, j:j + 3] = np.mgrid[25:28, 10:13]
    c2, e2, w2 = Q.rare_use(sx2, sy2, out_lab, lab, rare)[1]
    assert e2 == 2.0 and c2 > 10 and w2 > 10 * w


def _pasted(offsets, shape=(256, 256)):
    """An output of one label reading the lower half of a 128² source (tiled), with the
    source's window (16, 16)–(32, 32) pasted at ``offsets``."""
    yy, xx = np.mgrid[0:shape[0], 0:shape[1]]
    sy, sx = (64 + yy % 64).astype(np.float32), (xx % 128).astype(np.float32)
    for y, x in offsets:
        sy[y:y + 16, x:x + 16], sx[y:y + 16, x:x + 16] = np.mgrid[16:32, 16:32]
    return sx, sy, np.ones(shape, np.int64), np.ones((128, 128), np.int64)


def test_copy_spacing_tells_copies_on_a_lattice_from_clustered_ones():
    """Sixteen copies of one window: on a 64-pixel lattice (the even spacing of 16 copies
    over 256²) their nearest other copy is one spacing away; in pairs 36 or 24 pixels apart
    it is about half or a third of it, and the share under half the spacing goes from none to
    all."""
    lattice = [(y, x) for y in range(8, 256, 64) for x in range(8, 256, 64)]
    q, close, d, n = Q.copy_spacing(*_pasted(lattice), top=1, close=0.5)[1]
    assert n == 16 and d == 64 and q == 1.0 and close == 0.0
    pairs = [(y, x + dx) for y in range(8, 256, 64) for x in range(8, 256, 128) for dx in (0, 36)]
    q2, close2, d2, n2 = Q.copy_spacing(*_pasted(pairs), top=1, close=0.5)[1]
    assert n2 == 16 and d2 == 36 and q2 == 36 / 64 and close2 == 0.0
    tight = [(y, x + dx) for y in range(8, 256, 64) for x in range(8, 256, 128) for dx in (0, 24)]
    q3, close3, d3, n3 = Q.copy_spacing(*_pasted(tight), top=1, close=0.5)[1]
    assert n3 == 16 and d3 == 24 and close3 == 1.0
