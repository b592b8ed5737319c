"""Voting stack and pyramid against slow references; the median for two labels."""
import numpy as np
import pytest

from proxyshade.kernels import voting as kv


def vote_ref(lab, i, j, k, n):
    H, W = lab.shape
    lo = k // 2
    win = lab[max(i - lo, 0):min(i - lo + k, H), max(j - lo, 0):min(j - lo + k, W)]
    cnt = np.bincount(win.ravel(), minlength=n)
    return int(np.argmax(cnt))  # ties: the smallest label


def stack_ref(lab, nlevels, n):
    out = []
    for l in range(nlevels):
        h = 2 ** (nlevels - 1 - l)
        out.append(np.array([[vote_ref(lab, i, j, h, n) for j in range(lab.shape[1])]
                             for i in range(lab.shape[0])]))
    return out


def labels(rng, H, W, n):
    if rng.random() < 0.5:
        return rng.integers(0, n, (H, W)).astype(np.int32)
    ci, cj = rng.uniform(0, H, 5), rng.uniform(0, W, 5)
    ii, jj = np.mgrid[0:H, 0:W]
    return (((ii[..., None] - ci) ** 2 + (jj[..., None] - cj) ** 2).argmin(-1) % n).astype(np.int32)


@pytest.mark.parametrize("seed", range(6))
def test_stack_and_pyramid_match_reference(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 5))
    H, W = (int(v) for v in rng.integers(5, 27, 2))
    lab = labels(rng, H, W, n)
    nlev = int(rng.integers(1, 5))
    ref = stack_ref(lab, nlev, n)
    st = kv.vote_stack(lab, nlev, n)
    pyr = kv.vote_pyramid(lab, nlev, n)
    assert len(st) == len(pyr) == nlev
    for l in range(nlev):
        h = 2 ** (nlev - 1 - l)
        assert np.array_equal(st[l], ref[l])
        # the pyramid is the stack sampled every h pixels from h/2
        assert np.array_equal(pyr[l], ref[l][h // 2::h, h // 2::h])
        assert np.array_equal(kv.vote_down(lab, h, n), pyr[l])
    assert np.array_equal(st[-1], lab) and np.array_equal(pyr[-1], lab)


@pytest.mark.parametrize("k", [2, 3, 4, 5, 8])
def test_two_labels_is_median_filter(k):
    rng = np.random.default_rng(k)
    lab = labels(rng, 23, 19, 2)
    out = kv.vote_filter(lab, k, 2)
    H, W = lab.shape
    lo = k // 2
    for i in range(H):
        for j in range(W):
            win = np.sort(lab[max(i - lo, 0):min(i - lo + k, H), max(j - lo, 0):min(j - lo + k, W)].ravel())
            assert out[i, j] == win[(len(win) - 1) // 2]  # lower median (ties -> smaller label)


def test_uniform_and_parallel_identical():
    import numba

    rng = np.random.default_rng(4)
    lab = labels(rng, 64, 48, 4)
    a = kv.vote_pyramid(lab, 4, 4)
    old = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        b = kv.vote_pyramid(lab, 4, 4)
    finally:
        numba.set_num_threads(old)
    assert all(np.array_equal(x, y) for x, y in zip(a, b))
    assert all((v == 2).all() for v in kv.vote_stack(np.full((9, 9), 2, np.int32), 3, 4))
