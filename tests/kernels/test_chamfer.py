"""Symmetric Chamfer distance of 5x5 label windows against the paper's definition."""
import numpy as np
import pytest

from proxyshade.kernels import chamfer as kc


def chamfer_one_way_ref(a, b):
    """Sum over pixels of A of the L-inf distance to the closest pixel of B with the same
    label; 2 x window size = 10 when B has none."""
    s = 0
    for p in np.ndindex(5, 5):
        same = np.argwhere(b == a[p])
        s += 10 if len(same) == 0 else int(np.abs(same - np.array(p)).max(1).min())
    return s


def chamfer_ref(a, b):
    return chamfer_one_way_ref(a, b) + chamfer_one_way_ref(b, a)


def masks(win, n):
    return kc.masks_from_windows(win.reshape(1, 1, 25), n)[0, 0]


@pytest.mark.parametrize("missing", [False, True])
def test_exact_on_random_windows(missing):
    rng = np.random.default_rng(11 + missing)
    for _ in range(400):
        n = int(rng.integers(1, 6))
        a = rng.integers(0, n, (5, 5)).astype(np.int32)
        if rng.random() < 0.5:  # smooth windows: few labels, region-like
            a = (np.add.outer(np.arange(5) * rng.integers(-2, 3), np.arange(5) * rng.integers(-2, 3)) // 4 % n
                 ).astype(np.int32)
        b = rng.integers(0, n, (5, 5)).astype(np.int32)
        if missing and n > 1:  # B lacks some of A's labels
            gone = rng.choice(n, int(rng.integers(1, n)), replace=False)
            keep = np.setdiff1d(np.arange(n), gone)
            b = keep[rng.integers(0, len(keep), (5, 5))].astype(np.int32)
        ma, mb = masks(a, n), masks(b, n)
        ref = chamfer_ref(a, b)
        assert kc.chamfer_masks(ma, mb) == ref
        assert kc.chamfer_masks(mb, ma) == ref
        assert kc.chamfer_ring(ma, mb) == ref
        assert kc.chamfer_one_way(ma, mb) == chamfer_one_way_ref(a, b)


def test_missing_label_costs_twice_window_size_per_pixel():
    a = np.zeros((5, 5), np.int32)
    a[0, 0] = 1
    b = np.zeros((5, 5), np.int32)
    # A -> B: the 1 at (0, 0) has no 1 in B: 10; A's zeros are all zeros of B: 0
    assert kc.chamfer_one_way(masks(a, 2), masks(b, 2)) == 10
    # B -> A: B's zero at (0, 0) is one pixel from A's nearest zero
    assert kc.chamfer_one_way(masks(b, 2), masks(a, 2)) == 1
    assert kc.chamfer_masks(masks(a, 2), masks(b, 2)) == 11


def test_identical_windows_are_zero_and_distance_is_symmetric():
    rng = np.random.default_rng(2)
    a = rng.integers(0, 3, (5, 5)).astype(np.int32)
    assert kc.chamfer_masks(masks(a, 3), masks(a, 3)) == 0


def test_far_corner_distance_four():
    a = np.zeros((5, 5), np.int32)
    b = np.zeros((5, 5), np.int32)
    a[0, 0] = 1
    b[4, 4] = 1
    # A's 1 at (0,0) -> B's 1 at (4,4): 4; B's 1 -> A's: 4; zeros always have a zero at 0 or 1
    ref = chamfer_ref(a, b)
    assert ref == 4 + 4 + 1 + 1
    assert kc.chamfer_masks(masks(a, 2), masks(b, 2)) == ref


def test_dilate_and_popcount():
    rng = np.random.default_rng(5)
    for _ in range(200):
        m = rng.random((5, 5)) < 0.2
        bits = int(sum(1 << k for k in range(25) if m.flat[k]))
        pad = np.pad(m, 1)
        dil = np.zeros_like(m)
        for dy in range(3):
            for dx in range(3):
                dil |= pad[dy:dy + 5, dx:dx + 5]
        assert kc.dilate(bits) == int(sum(1 << k for k in range(25) if dil.flat[k]))
        assert kc.popcount25(bits) == int(m.sum())


def test_masks_round_trip():
    rng = np.random.default_rng(8)
    win = rng.integers(0, 4, (3, 4, 25)).astype(np.int32)
    ms = kc.masks_from_windows(win, 4)
    for i in range(3):
        for j in range(4):
            assert np.array_equal(kc.window_of(ms[i, j]).ravel(), win[i, j])


def test_bounded_is_exact_below_the_bound_and_above_it_otherwise():
    rng = np.random.default_rng(21)
    for _ in range(300):
        n = int(rng.integers(2, 6))
        a = rng.integers(0, n, (5, 5)).astype(np.int32)
        b = rng.integers(0, n, (5, 5)).astype(np.int32)
        ma, mb = masks(a, n), masks(b, n)
        d = chamfer_ref(a, b)
        bound = int(rng.integers(0, 2 * d + 2))
        got = kc.chamfer_bounded(ma, mb, bound)
        assert got == d if d <= bound else got > bound
