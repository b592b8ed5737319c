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
            runs.append((grain.band_energy(img, lab, hbin, radii, 3, 2), grain.regrade(img, lab, hbin, radii, gains)))
    finally:
        numba.set_num_threads(old)
    (a, ra), (b, rb) = runs
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1]) and np.array_equal(ra, rb)
