"""Synthesis features: exemplar resampling, dense labels, levels."""
import numpy as np

from proxyshade.kernels import features as kf
from proxyshade.kernels.distance import contour_distance


def test_area_resample_integer_factor_is_block_mean():
    rng = np.random.default_rng(0)
    img = rng.random((16, 24, 3)).astype(np.float32)
    lab = rng.integers(0, 3, (16, 24)).astype(np.int32)
    ex_rgb, ex_lab = kf.build_exemplar(img, lab, 4.0, 3)
    assert ex_rgb.shape == (4, 6, 3)
    want = img.reshape(4, 4, 6, 4, 3).mean(axis=(1, 3))
    assert np.allclose(ex_rgb, want, atol=1e-6)
    for i in range(4):
        for j in range(6):
            counts = np.bincount(lab[4 * i:4 * i + 4, 4 * j:4 * j + 4].ravel(), minlength=3)
            assert ex_lab[i, j] == counts.argmax()


def test_fractional_factor_preserves_mean_of_constant():
    img = np.full((10, 15, 3), 0.25, np.float32)
    ex_rgb, _ = kf.build_exemplar(img, np.zeros((10, 15), np.int32), 1.5, 1)
    assert ex_rgb.shape == (6, 10, 3)
    assert np.allclose(ex_rgb, 0.25)


def test_dense_labels_and_missing():
    ids = np.array([[3, 7], [9, 3]], np.uint32)
    dense, missing = kf.dense_labels(ids, np.array([7, 3]))
    assert dense.tolist() == [[1, 0], [0, 1]]
    assert missing.tolist() == [[False, False], [True, False]]


def test_levels_shapes_and_distances():
    rng = np.random.default_rng(1)
    ex_lab = np.zeros((40, 50), np.int32)
    ex_lab[:, 25:] = 1
    ex_rgb = rng.random((40, 50, 3)).astype(np.float32)
    tgt = np.zeros((32, 32), np.int32)
    tgt[10:20, 5:30] = 1
    lv = kf.build_levels(ex_rgb, ex_lab, tgt, 2, 3, max_distance=6.0)
    assert [l.h for l in lv] == [4, 2, 1]
    assert [l.tgt_lab.shape for l in lv] == [(8, 8), (16, 16), (32, 32)]
    assert all(l.src_lab.shape == (40, 50) for l in lv)
    fin = lv[-1]
    assert np.array_equal(fin.tgt_dist, np.minimum(contour_distance(tgt), 6.0))
    # finest exemplar colours are the sRGB features of the exemplar
    assert np.allclose(fin.src_rgb, kf.srgb_features(ex_rgb))
    assert fin.src_masks.shape == (40, 50, 2)
    only = kf.build_levels(ex_rgb, ex_lab, tgt, 2, 3, max_distance=6.0, finest_only=True)
    assert len(only) == 1 and np.array_equal(only[0].src_dist, fin.src_dist)
