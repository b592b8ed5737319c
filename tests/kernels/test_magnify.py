"""Magnification of a coordinate map and label repair."""
import numpy as np

from proxyshade.kernels import magnify as km


def test_magnify_formula():
    rng = np.random.default_rng(0)
    S = rng.integers(0, 50, (5, 7, 2)).astype(np.int32)
    out = km.magnify(S, 4, (18, 27))
    for i in range(18):
        for j in range(27):
            assert tuple(out[i, j]) == (4 * S[i // 4, j // 4, 0] + i % 4, 4 * S[i // 4, j // 4, 1] + j % 4)


def test_repair_continues_neighbour_translation():
    src = np.zeros((20, 20), np.int32)
    src[:, 10:] = 1
    # identity map, but the guide wants label 1 from column 8 on: columns 8, 9 land on 0
    ii, jj = np.mgrid[0:12, 0:12]
    S = np.stack([ii, jj], -1).astype(np.int32)
    guide = np.zeros((12, 12), np.int32)
    guide[:, 8:] = 1
    # pixels right of the wrong band come from a patch shifted by +4 columns
    S[:, 10:, 1] += 4
    out, rep = km.repair_labels(S, guide, src)
    assert rep["wrong"] == 24 and rep["extended"] == 24 and rep["left"] == 0
    assert (src[out[..., 0], out[..., 1]] == guide).all()
    # the band continues the right-hand patch's translation (column + 4)
    assert np.array_equal(out[:, 8:10, 1], jj[:, 8:10] + 4)


def test_repair_falls_back_to_nearest_right_label():
    src = np.zeros((30, 30), np.int32)
    src[25:, 25:] = 2
    S = np.zeros((4, 4, 2), np.int32) + 5
    guide = np.full((4, 4), 2, np.int32)  # nothing around has label 2: every pixel is wrong
    out, rep = km.repair_labels(S, guide, src)
    assert rep["nearest"] == 16 and rep["left"] == 0
    assert (out == 25).all()  # nearest label-2 pixel of (5, 5) is (25, 25)


def test_labels_all_right_is_identity():
    rng = np.random.default_rng(1)
    src = rng.integers(0, 3, (20, 20)).astype(np.int32)
    S = rng.integers(0, 20, (9, 9, 2)).astype(np.int32)
    guide = src[S[..., 0], S[..., 1]]
    out, rep = km.repair_labels(S, guide, src)
    assert rep["wrong"] == 0 and np.array_equal(out, S)


def _repair_step(S, ok, guide, srclab):
    """One whole-frame front step, plain Python: every wrong pixel takes the first of its 8
    neighbours (this order) that is right, of its label, and whose translation continued
    lands on its label; all read the previous state. Returns the new S, ok and the count."""
    Ht, Wt = guide.shape
    Hs, Ws = srclab.shape
    S2, ok2, n = S.copy(), ok.copy(), 0
    for i in range(Ht):
        for j in range(Wt):
            if ok[i, j]:
                continue
            for di, dj in ((-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (-1, 1), (1, -1), (1, 1)):
                a, b = i + di, j + dj
                if not (0 <= a < Ht and 0 <= b < Wt) or not ok[a, b] or guide[a, b] != guide[i, j]:
                    continue
                y, x = S[a, b, 0] - di, S[a, b, 1] - dj
                if 0 <= y < Hs and 0 <= x < Ws and srclab[y, x] == guide[i, j]:
                    S2[i, j] = (y, x)
                    ok2[i, j] = True
                    n += 1
                    break
    return S2, ok2, n


def _repair_by_whole_frame_steps(S, guide, srclab, max_steps=64):
    """The front growth written with whole-frame steps (``_repair_step``), no fallback."""
    S = np.ascontiguousarray(S, np.int32).copy()
    ok = np.empty(guide.shape, np.bool_)
    km._label_ok(S, guide, srclab, ok)
    for _ in range(max_steps):
        S, ok, n = _repair_step(S, ok, guide, srclab)
        if n == 0:
            break
    return S, ok


def test_front_over_wrong_pixels_equals_whole_frame_steps():
    rng = np.random.default_rng(5)
    for trial in range(4):
        srclab = (rng.random((30, 40)) < 0.5).astype(np.int32) + 1
        srclab[:, :20] = 1 + (trial % 2)
        guide = np.where(np.arange(48)[:, None] + np.arange(56)[None, :] < 50, 1, 2).astype(np.int32)
        S = np.stack([rng.integers(0, 30, (48, 56)), rng.integers(0, 40, (48, 56))], -1).astype(np.int32)
        want, ok = _repair_by_whole_frame_steps(S, guide, srclab, max_steps=3 + trial)
        got, info = km.repair_labels(S, guide, srclab, max_steps=3 + trial, nearest=False)
        assert np.array_equal(got, want)
        assert info["extended"] == info["wrong"] - int((~ok).sum()) > 0


def test_only_target_matches_numpy():
    """The guide on the ``only`` pixels, the (clamped) source label under the map elsewhere."""
    rng = np.random.default_rng(11)
    srclab = rng.integers(0, 4, (9, 12)).astype(np.int32)
    S = rng.integers(-3, 14, (7, 8, 2)).astype(np.int32)
    only = rng.random((7, 8)) < 0.4
    guide = rng.integers(0, 4, (7, 8)).astype(np.int32)
    here = srclab[np.clip(S[..., 0], 0, 8), np.clip(S[..., 1], 0, 11)]
    from proxyshade.kernels.magnify import only_target
    assert np.array_equal(only_target(S, srclab, only, guide), np.where(only, guide, here))
