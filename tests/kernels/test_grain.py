"""kernels.grain against a slow reference: box means over the pixel's own label only."""
import numba
import numpy as np
import pytest

from proxyshade.kernels import grain


def ref_layers(img, lab, radii):
    """(R + 1, H, W, 3): the layers b_0..b_(R-1) and the low pass, pixel by pixel."""
    H, W, _ = img.shape
    out = np.zeros((len(radii) + 1, H, W, 3))
    for i in range(H):
        for j in range(W):
            prev = img[i, j].astype(np.float64)
            for b, r in enumerate(radii):
                win = img[max(i - r, 0):i + r + 1, max(j - r, 0):j + r + 1].astype(np.float64)
                same = lab[max(i - r, 0):i + r + 1, max(j - r, 0):j + r + 1] == lab[i, j]
                m = win[same].mean(0)
                out[b, i, j] = prev - m
                prev = m
            out[len(radii), i, j] = prev
    return out


def case(seed, shape=(23, 31), n=3):
    """Random colours and labels: blocks with single pixels sprinkled in (odd seeds), or
    (even seeds) each label in its own part of the image, so its box is smaller than the
    image and away from its borders."""
    rng = np.random.default_rng(seed)
    img = rng.random(shape + (3,)).astype(np.float32)
    if seed % 2:
        lab = rng.integers(0, n, (shape[0] // 4 + 1, shape[1] // 4 + 1))
        lab = np.kron(lab, np.ones((4, 4), int))[:shape[0], :shape[1]].astype(np.int32)
        lab[rng.random(shape) < 0.05] = rng.integers(0, n)
    else:
        lab = np.zeros(shape, np.int32)
        lab[4:15, 6:20] = 1
        lab[9:13, 10:17] = 2
        lab[17:21, 22:29] = 2
    hbin = rng.integers(0, 2, shape).astype(np.int32)
    return img, lab, hbin


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_band_energy_matches_the_reference(seed):
    img, lab, hbin = case(seed)
    radii = np.array([1, 2, 4, 8])
    layers = ref_layers(img, lab, radii)
    sums, counts = grain.band_energy(img, lab, hbin, radii, 3, 2)
    for k in range(3):
        for t in range(2):
            m = (lab == k) & (hbin == t)
            assert counts[k, t] == m.sum()
            want = [(layers[b][m] ** 2).sum() for b in range(len(radii))]
            np.testing.assert_allclose(sums[k, t], want, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("seed", [3, 4])
def test_regrade_matches_the_reference_and_gain_one_is_the_identity(seed):
    img, lab, hbin = case(seed)
    radii = np.array([1, 3, 6])
    rng = np.random.default_rng(seed)
    gains = rng.uniform(0.5, 2.0, (3, 2, 3))
    layers = ref_layers(img, lab, radii)
    want = layers[-1] + sum(gains[lab, hbin, b][..., None] * layers[b] for b in range(len(radii)))
    np.testing.assert_allclose(grain.regrade(img, lab, hbin, radii, gains), want, atol=2e-6)
    np.testing.assert_allclose(grain.regrade(img, lab, hbin, radii, np.ones((3, 2, 3))), img, atol=2e-6)


@pytest.mark.parametrize("seed", [5, 6])
def test_threads_give_the_same_bits(seed):
    img, lab, hbin = case(seed, shape=(130, 150))
    radii = np.array([1, 2, 4, 8, 16, 32])
    gains = np.random.default_rng(5).uniform(0.5, 2.0, (3, 2, 6))
    old = numba.get_num_threads()
    try:
        runs = []
        for t in (1, min(2, numba.config.NUMBA_NUM_THREADS)):
            numba.set_num_threads(t)
            runs.append((grain.band_energy(img, lab, hbin, radii, 3, 2), grain.regrade(img, lab, hbin, radii, gains),
                         grain.spread_energy(img, lab, hbin, radii[3:], 3, 2, 2),
                         grain.spread_regrade(img, lab, hbin, radii[3:], gains[..., :2], 2)))
    finally:
        numba.set_num_threads(old)
    (a, ra, sa, sra), (b, rb, sb, srb) = runs
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1]) and np.array_equal(ra, rb)
    assert np.array_equal(sa[0], sb[0]) and np.array_equal(sa[1], sb[1]) and np.array_equal(sra, srb)


def ref_block_layers(img, lab, radii, f):
    """((R, H, W, 3), same): the label means at each radius as ``spread_regrade`` and
    ``spread_energy`` define them, written out: f × f blocks from each label's bounding box
    origin, a block's mean over the blocks within round(r / f) of it; a pixel's the bilinear
    blend of the surrounding block centres that hold its label (regrade), its own block's
    (energy)."""
    H, W, _ = img.shape
    out = np.zeros((len(radii), H, W, 3))
    own = np.zeros((len(radii), H, W, 3))
    for k in np.unique(lab):
        ys, xs = np.nonzero(lab == k)
        r0, c0, r1, c1 = ys.min(), xs.min(), ys.max() + 1, xs.max() + 1
        hb, wb = -(-(r1 - r0) // f), -(-(c1 - c0) // f)
        sums, cnt = np.zeros((hb, wb, 3)), np.zeros((hb, wb))
        for i in range(r0, r1):
            for j in range(c0, c1):
                if lab[i, j] == k:
                    sums[(i - r0) // f, (j - c0) // f] += img[i, j]
                    cnt[(i - r0) // f, (j - c0) // f] += 1
        means = np.zeros((len(radii), hb, wb, 3))
        for r, rad in enumerate(radii):
            q = max(int(round(rad / f)), 1)
            for bi in range(hb):
                for bj in range(wb):
                    sl = (slice(max(bi - q, 0), bi + q + 1), slice(max(bj - q, 0), bj + q + 1))
                    if cnt[sl].sum():
                        means[r, bi, bj] = sums[sl].sum((0, 1)) / cnt[sl].sum()

        def axis(i, nb):
            t = (i - 0.5 * (f - 1)) / f
            b0 = int(np.floor(t))
            return (0, 0, 0.0) if b0 < 0 else (nb - 1, nb - 1, 0.0) if b0 >= nb - 1 else (b0, b0 + 1, t - b0)

        for i in range(r0, r1):
            for j in range(c0, c1):
                if lab[i, j] != k:
                    continue
                own[:, i, j] = means[:, (i - r0) // f, (j - c0) // f]
                (y0, y1, ty), (x0, x1, tx) = axis(i - r0, hb), axis(j - c0, wb)
                acc, wsum = np.zeros((len(radii), 3)), 0.0
                for by, bx, w in ((y0, x0, (1 - ty) * (1 - tx)), (y0, x1, (1 - ty) * tx),
                                  (y1, x0, ty * (1 - tx)), (y1, x1, ty * tx)):
                    if w > 0 and cnt[by, bx] > 0:
                        acc += w * means[:, by, bx]
                        wsum += w
                out[:, i, j] = acc / wsum
    return out, own


@pytest.mark.parametrize("seed,f", [(0, 2), (1, 3), (2, 1), (3, 2)])
def test_spread_kernels_match_the_block_reference(seed, f):
    img, lab, hbin = case(seed)
    radii = np.array([2, 4, 7])
    means, own = ref_block_layers(img, lab, radii, f)
    layers = [means[l] - means[l + 1] for l in range(len(radii) - 1)]
    own_layers = [own[l] - own[l + 1] for l in range(len(radii) - 1)]
    sums, counts = grain.spread_energy(img, lab, hbin, radii, 3, 2, f)
    for k in range(3):
        for t in range(2):
            m = (lab == k) & (hbin == t)
            assert counts[k, t] == m.sum()
            np.testing.assert_allclose(sums[k, t], [(b[m] ** 2).sum() for b in own_layers], rtol=1e-9, atol=1e-9)
    gains = np.random.default_rng(seed).uniform(0.5, 2.0, (3, 2, 2))
    want = img + sum((gains[lab, hbin, l] - 1)[..., None] * layers[l] for l in range(2))
    np.testing.assert_allclose(grain.spread_regrade(img, lab, hbin, radii, gains, f), want, atol=2e-6)


@pytest.mark.parametrize("seed", [0, 1])
def test_spread_kernels_on_single_pixels_are_band_energy_and_regrade(seed):
    """f = 1: the layers between band_energy's means, and a regrade that leaves the layer
    under the first radius alone."""
    img, lab, hbin = case(seed)
    radii = np.array([1, 3, 6])
    sums, counts = grain.band_energy(img, lab, hbin, radii, 3, 2)
    s1, c1 = grain.spread_energy(img, lab, hbin, radii, 3, 2, 1)
    assert np.array_equal(c1, counts)
    np.testing.assert_allclose(s1, sums[..., 1:], rtol=1e-12)
    gains = np.random.default_rng(seed).uniform(0.5, 2.0, (3, 2, 2))
    full = np.concatenate([np.ones((3, 2, 1)), gains], -1)[..., :3]
    np.testing.assert_allclose(grain.spread_regrade(img, lab, hbin, radii, gains, 1),
                               grain.regrade(img, lab, hbin, radii, np.concatenate([full, np.ones((3, 2, 0))], -1)),
                               atol=2e-6)


def test_spread_on_blocks_is_close_to_the_pixel_windows_on_a_smooth_image():
    """Radii of 8 blocks and more (the spread's: 32 px on 4 px blocks): the regraded
    change differs from the pixel windows' by a few per cent (a window of 2r + f px, not
    2r + 1, and clipped at block edges), and so do the energy ratios the gains are made of
    (the blocks' energies run a little low, on both images alike)."""
    y, x = np.mgrid[:200, :260].astype(np.float32)
    lab = (y > 70 + 20 * np.sin(x / 40)).astype(np.int32)
    hbin = np.zeros(lab.shape, np.int32)
    radii = np.array([32, 64, 128])

    def image(seed, amp):
        rng = np.random.default_rng(seed)
        img = np.stack([0.5 + amp * np.sin(x / 23 + c) * np.cos(y / 31 - c) for c in range(3)], -1)
        return (img + 0.05 * rng.standard_normal(img.shape)).astype(np.float32)

    a, b = image(7, 0.2), image(8, 0.12)
    gains = np.array([[[1.8, 1.5]], [[1.6, 2.0]]])
    exact = grain.spread_regrade(a, lab, hbin, radii, gains, 1) - a
    blocks = grain.spread_regrade(a, lab, hbin, radii, gains, 4) - a
    assert np.abs(blocks - exact).mean() < 0.08 * np.abs(exact).mean()  # 5 % here
    ratio = lambda f: grain.spread_energy(a, lab, hbin, radii, 2, 1, f)[0] / grain.spread_energy(b, lab, hbin, radii, 2, 1, f)[0]
    np.testing.assert_allclose(ratio(4), ratio(1), rtol=0.05)
