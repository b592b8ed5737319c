"""Looking images up through a coordinate map."""
import numpy as np
import pytest

from proxyshade.graph.plate import Plate
from proxyshade.kernels.lookup import lookup, lookup_plate


def bilinear_ref(img, x, y):
    h, w = img.shape[:2]
    x = min(max(float(x), 0.0), w - 1.0)
    y = min(max(float(y), 0.0), h - 1.0)
    x0, y0 = int(np.floor(x)), int(np.floor(y))
    x1, y1 = min(x0 + 1, w - 1), min(y0 + 1, h - 1)
    fx, fy = x - x0, y - y0
    top = (1 - fx) * img[y0, x0].astype(np.float64) + fx * img[y0, x1]
    bot = (1 - fx) * img[y1, x0].astype(np.float64) + fx * img[y1, x1]
    return (1 - fy) * top + fy * bot


@pytest.mark.parametrize("channels", [None, 1, 3])
def test_bilinear_matches_reference(channels):
    rng = np.random.default_rng(0)
    shape = (13, 17) if channels is None else (13, 17, channels)
    img = rng.random(shape).astype(np.float32)
    sx = rng.uniform(-3, 20, (6, 7)).astype(np.float32)
    sy = rng.uniform(-3, 16, (6, 7)).astype(np.float32)
    got = lookup(img, sx, sy)
    assert got.shape == (6, 7) + (() if channels is None else (channels,))
    for i in range(6):
        for j in range(7):
            assert np.allclose(got[i, j], bilinear_ref(img, sx[i, j], sy[i, j]), atol=1e-6)


def test_integer_coordinates_are_exact():
    rng = np.random.default_rng(1)
    img = rng.random((20, 30, 3)).astype(np.float32)
    yy, xx = np.mgrid[0:20, 0:30]
    got = lookup(img, xx.astype(np.float32), yy.astype(np.float32))
    assert np.array_equal(got, img)


def test_ids_take_the_nearest_pixel():
    ids = np.arange(12, dtype=np.uint32).reshape(3, 4)
    sx = np.array([[0.4, 0.6, 2.5, 9.0]], np.float32)
    sy = np.array([[0.0, 1.49, 1.51, -2.0]], np.float32)
    got = lookup(ids, sx, sy)
    assert got.dtype == np.uint32
    assert got.tolist() == [[0, 5, 11, 3]]


def test_lookup_plate_reapplies_a_map_to_any_aov():
    rng = np.random.default_rng(2)
    src = Plate({"R": rng.random((8, 9)).astype(np.float32), "label.id": rng.integers(1, 4, (8, 9)).astype(np.uint32)})
    sx = np.array([[3.0, 8.0]], np.float32)
    sy = np.array([[2.0, 7.0]], np.float32)
    out = lookup_plate(src, sx, sy)
    assert out["R"][0, 0] == src["R"][2, 3] and out["label.id"][0, 1] == src["label.id"][7, 8]
    assert out["label.id"].dtype == np.uint32
