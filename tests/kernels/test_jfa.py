"""Jump flooding against brute force."""
import numpy as np
import pytest

from proxyshade.kernels.jfa import jump_flood


def extend_depth(proxy_labels, guide_labels, z, *, penalty=1024.0):
    """The depth extension written out in numpy (``synthesis.depth`` pastes it with
    ``kernels.edit``): the proxy depth at each pixel's jump-flooding seed, inf without one,
    the proxy's own where the guide kept its label; and the seeds (flat, −1 for none)."""
    keep = proxy_labels == guide_labels
    src = jump_flood(keep, guide_labels, proxy_labels, penalty=penalty)
    out = np.where(src >= 0, z.reshape(-1)[np.maximum(src, 0)], np.inf).astype(np.float32)
    out[keep] = z[keep]
    return out, src


def brute(is_seed, labels, seed_labels, penalty):
    h, w = labels.shape
    si, sj = np.nonzero(is_seed)
    out = np.full((h, w), -1)
    cost = np.full((h, w), np.inf)
    for i in range(h):
        for j in range(w):
            c = (si - i) ** 2 + (sj - j) ** 2 + penalty * (seed_labels[si, sj] != labels[i, j])
            if len(c):
                k = np.argmin(c)  # first minimum = smallest flat index (seeds are in row-major order)
                out[i, j], cost[i, j] = si[k] * w + sj[k], c[k]
    return out, cost


def blobs(rng, h, w, n, jitter=0.0):
    """Random label regions (nearest of a few random centres), and the same regions with
    their centres and borders moved (``jitter``), as a detailed guide moves a proxy's borders."""
    cy, cx = rng.uniform(0, h, n), rng.uniform(0, w, n)
    ii, jj = np.mgrid[0:h, 0:w]
    a = np.argmin((ii[..., None] - cy) ** 2 + (jj[..., None] - cx) ** 2, axis=-1) % 3
    if not jitter:
        return a
    wob = jitter * np.sin(ii / 2.3 + rng.uniform(0, 6)) * np.cos(jj / 1.7 + rng.uniform(0, 6))
    cy2, cx2 = cy + rng.normal(0, jitter, n), cx + rng.normal(0, jitter, n)
    b = np.argmin((ii[..., None] + wob[..., None] - cy2) ** 2 + (jj[..., None] - cx2) ** 2, axis=-1) % 3
    return a, b


@pytest.mark.parametrize("seed", range(6))
def test_nearest_same_label_seed_matches_brute_force(seed):
    rng = np.random.default_rng(seed)
    h, w = 37, 29
    proxy, guide = blobs(rng, h, w, 7, jitter=2.5)
    keep = proxy == guide
    assert 0.02 < 1 - keep.mean() < 0.5
    pen = 1024.0
    got = jump_flood(keep, guide, proxy, penalty=pen)
    ref, cost = brute(keep, guide, proxy, pen)
    gi, gj = got // w, got % w
    ii, jj = np.mgrid[0:h, 0:w]
    got_cost = (gi - ii) ** 2 + (gj - jj) ** 2 + pen * (proxy.reshape(-1)[got] != guide)
    agree = got_cost == cost  # same distance (ties may pick another equidistant seed)
    assert agree.mean() >= 0.99
    z = rng.random((h, w)).astype(np.float32) + 1
    ext, src = extend_depth(proxy, guide, z, penalty=pen)
    same = src == ref
    assert np.array_equal(ext[same], z.reshape(-1)[ref[same]])  # zero depth error where they agree
    assert np.array_equal(ext[keep], z[keep])  # unchanged labels keep the proxy depth


def test_same_label_seeds_win_over_nearer_other_labels():
    labels = np.zeros((1, 10), int)
    seed_labels = np.array([[0, 1, 1, 1, 1, 1, 1, 1, 1, 1]])
    is_seed = np.ones((1, 10), bool)
    is_seed[0, 5] = False
    got = jump_flood(is_seed, labels, seed_labels, penalty=1e6)
    assert got[0, 5] == 0  # the only label-0 seed, far away, beats the label-1 neighbours


def test_no_seeds_gives_minus_one_and_threads_agree():
    import numba

    assert (jump_flood(np.zeros((4, 4), bool), np.zeros((4, 4), int), np.zeros((4, 4), int)) == -1).all()
    rng = np.random.default_rng(9)
    lab = blobs(rng, 64, 48, 8)
    seeds = rng.random((64, 48)) < 0.1
    outs = []
    for t in (1, 2):
        numba.set_num_threads(t)
        outs.append(jump_flood(seeds, lab, lab))
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    assert np.array_equal(outs[0], outs[1])
