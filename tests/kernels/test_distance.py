"""Contour distance: exact against brute force on small random label maps."""
import numpy as np
import pytest

from proxyshade.kernels import distance


def brute_contour_distance(labels):
    h, w = labels.shape
    contour = np.zeros((h, w), bool)
    contour[1:, :] |= labels[1:, :] != labels[:-1, :]
    contour[:-1, :] |= labels[:-1, :] != labels[1:, :]
    contour[:, 1:] |= labels[:, 1:] != labels[:, :-1]
    contour[:, :-1] |= labels[:, :-1] != labels[:, 1:]
    ci, cj = np.nonzero(contour)
    if ci.size == 0:
        return contour, np.full((h, w), np.inf)
    ii, jj = np.mgrid[0:h, 0:w]
    d2 = (ii[..., None] - ci) ** 2 + (jj[..., None] - cj) ** 2
    return contour, np.sqrt(d2.min(-1).astype(np.float64))


def blobs(rng, h, w, n):
    """Random label maps with regions of varied size (not just noise)."""
    k = rng.integers(2, 6)
    ci = rng.uniform(0, h, k)
    cj = rng.uniform(0, w, k)
    ii, jj = np.mgrid[0:h, 0:w]
    d = (ii[..., None] - ci) ** 2 + (jj[..., None] - cj) ** 2
    return (d.argmin(-1) % n + 1).astype(np.uint32)


@pytest.mark.parametrize("seed", range(12))
def test_matches_brute_force(seed):
    rng = np.random.default_rng(seed)
    h, w = rng.integers(1, 40, 2)
    if seed % 3 == 0:
        labels = rng.integers(1, 4, (h, w)).astype(np.uint32)
    else:
        labels = blobs(rng, h, w, 3)
    contour, want = brute_contour_distance(labels)
    assert np.array_equal(distance.contour_mask(labels), contour)
    got = distance.contour_distance(labels)
    assert got.dtype == np.float32
    assert np.array_equal(got, want.astype(np.float32))


def test_sparse_sites_exact_squared():
    rng = np.random.default_rng(5)
    for _ in range(20):
        h, w = rng.integers(1, 50, 2)
        sites = rng.random((h, w)) < rng.choice([0.002, 0.02, 0.2])
        sites[rng.integers(h), rng.integers(w)] = True
        got = distance.squared_distance(sites)
        ci, cj = np.nonzero(sites)
        ii, jj = np.mgrid[0:h, 0:w]
        want = ((ii[..., None] - ci) ** 2 + (jj[..., None] - cj) ** 2).min(-1)
        assert np.array_equal(got, want)


def test_single_label_is_inf_or_clamped():
    labels = np.full((7, 9), 3, np.uint32)
    assert np.isinf(distance.contour_distance(labels)).all()
    assert (distance.contour_distance(labels, max_distance=4.0) == 4.0).all()


def test_clamp():
    labels = np.ones((30, 30), np.uint32)
    labels[:, 15:] = 2
    d = distance.contour_distance(labels, max_distance=5.0)
    assert d[0, 14] == 0 and d[0, 15] == 0 and d[0, 13] == 1
    assert d[0, 0] == 5.0 and d.max() == 5.0


def test_parallel_equals_serial():
    import numba
    rng = np.random.default_rng(1)
    labels = blobs(rng, 97, 61, 4)
    a = distance.contour_distance(labels)
    numba.set_num_threads(1)
    try:
        b = distance.contour_distance(labels)
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    assert np.array_equal(a, b)


def test_nearest_site_is_a_nearest():
    rng = np.random.default_rng(9)
    for _ in range(20):
        h, w = rng.integers(1, 40, 2)
        sites = rng.random((h, w)) < rng.choice([0.005, 0.05, 0.3])
        got = distance.nearest_site(sites)
        if not sites.any():
            assert (got == -1).all()
            continue
        ci, cj = np.nonzero(sites)
        ii, jj = np.mgrid[0:h, 0:w]
        want = ((ii[..., None] - ci) ** 2 + (jj[..., None] - cj) ** 2).min(-1)
        assert sites[got[..., 0], got[..., 1]].all()
        d2 = (got[..., 0] - ii) ** 2 + (got[..., 1] - jj) ** 2
        assert np.array_equal(d2, want)
