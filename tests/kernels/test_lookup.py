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


def _lanczos_reference(img, x, y, a=3):
    """Slow Lanczos-a: normalised separable weights over taps floor - a + 1 .. floor + a, clamped."""
    h, w, c = img.shape
    x = min(max(x, 0.0), w - 1.0)
    y = min(max(y, 0.0), h - 1.0)
    x0, y0 = int(np.floor(x)), int(np.floor(y))

    def weights(t):
        d = np.arange(-a + 1, a + 1) - t
        wt = np.sinc(d) * np.sinc(d / a)
        return wt / wt.sum()

    wx, wy = weights(x - x0), weights(y - y0)
    out = np.zeros(c)
    for r in range(2 * a):
        yy = min(max(y0 - a + 1 + r, 0), h - 1)
        for t in range(2 * a):
            xx = min(max(x0 - a + 1 + t, 0), w - 1)
            out += wy[r] * wx[t] * img[yy, xx]
    return out


def test_lanczos_matches_reference_and_is_exact_at_pixels():
    rng = np.random.default_rng(8)
    img = rng.random((13, 17, 3)).astype(np.float32)
    sx = (rng.random((6, 7)) * 20 - 2).astype(np.float32)
    sy = (rng.random((6, 7)) * 16 - 2).astype(np.float32)
    got = lookup(img, sx, sy, filter="lanczos3")
    for i in range(6):
        for j in range(7):
            np.testing.assert_allclose(got[i, j], _lanczos_reference(img, float(sx[i, j]), float(sy[i, j])),
                                       atol=2e-3)  # the weights are tabled at 1/4096 pixel
    ii, jj = np.mgrid[0:13, 0:17].astype(np.float32)
    np.testing.assert_array_equal(lookup(img, jj, ii, filter="lanczos3"), img)
    with pytest.raises(ValueError, match="lanczos3"):
        lookup(img, sx, sy, filter="cubic")


def test_lanczos_keeps_detail_that_bilinear_blurs():
    rng = np.random.default_rng(9)
    img = rng.random((64, 64, 1)).astype(np.float32)
    ii, jj = np.mgrid[4:60, 4:60].astype(np.float32)
    grad = lambda a: np.abs(np.diff(a, axis=1)).mean()
    g0 = grad(img[4:60, 4:60])
    half = grad(lookup(img, jj + 0.25, ii + 0.25))
    sharp = grad(lookup(img, jj + 0.25, ii + 0.25, filter="lanczos3"))
    assert half < 0.8 * g0 and sharp > half * 1.15


@pytest.mark.parametrize("many", [True, False])
@pytest.mark.parametrize("filt", ["lanczos3", "lanczos4", "flat4"])
def test_colour_reads_take_the_unrolled_kernel_bit_identically(filt, many):
    """A colour read goes through ``_lanczos_rgb`` (from a padded float64 copy when there
    are at least as many positions as the image has pixels, else from the image, flat4's
    clamp as it reads): the same bits as the per-tap kernel then ``_clamp_taps``, inside,
    at the borders and at integer positions."""
    from proxyshade.kernels.lookup import _LANCZOS, CLAMPED, _clamp_taps, _lanczos

    rng = np.random.default_rng(10)
    img = rng.random((23, 31, 3)).astype(np.float32)
    sx = (rng.random((40, 30)) * 38 - 4).astype(np.float32)
    sy = (rng.random((40, 30)) * 30 - 4).astype(np.float32)
    sx[::7] = np.round(sx[::7])
    sy[::7] = np.round(sy[::7])
    if not many:
        sx, sy = sx[:15], sy[:15]
    assert (sx.size >= img.shape[0] * img.shape[1]) == many
    want = np.empty(sx.shape + (3,), np.float32)
    _lanczos(img, sx, sy, _LANCZOS[filt], want)
    if filt in CLAMPED:
        _clamp_taps(img, sx, sy, np.zeros((0, 0), np.bool_), want)
    got = lookup(img, sx, sy, filter=filt)
    assert np.array_equal(got.view(np.uint32), want.view(np.uint32))
    m = rng.random(sx.shape) < 0.5  # flat4's clamp as it reads, on the read pixels only
    masked = lookup(img, sx, sy, filter=filt, mask=m)
    assert np.array_equal(masked.view(np.uint32), np.where(m[..., None], want, np.float32(0)).view(np.uint32))
    if filt == "flat4":
        return  # its weights against their reference: test_flat4_matches_the_least_squares_delay...
    for i in range(0, sx.shape[0], 9):
        for j in range(0, 30, 7):
            a = 3 if filt == "lanczos3" else 4
            np.testing.assert_allclose(got[i, j], _lanczos_reference(img, float(sx[i, j]), float(sy[i, j]), a),
                                       atol=2e-3)


def _flat_weights(t, a=4, band=0.9, n=20000):
    """Slow least-squares fractional delay by t: the weights (summing to 1) minimising the
    squared error of the response against e^{iωt} sampled at n points of [0, band·π]
    (midpoint rule), from the constrained normal equations (KKT system)."""
    k = np.arange(-a + 1, a + 1)
    om = (np.arange(n) + 0.5) / n * band * np.pi
    E = np.exp(1j * np.outer(om, k))
    A = (E.conj().T @ E).real
    b = (E.conj().T @ np.exp(1j * om * t)).real
    K = np.block([[A, np.ones((2 * a, 1))], [np.ones((1, 2 * a)), np.zeros((1, 1))]])
    return np.linalg.solve(K, np.append(b, 1.0))[:2 * a]


def test_flat4_matches_the_least_squares_delay_and_is_exact_at_pixels():
    """``flat4``: per axis the least-squares fractional delay over 0.9 × Nyquist, 8 taps
    separable and clamped like Lanczos-4, then clamped to the range of the 4×4 pixels
    around the position; exactly the pixel at integer positions."""
    rng = np.random.default_rng(11)
    img = rng.random((13, 17, 3)).astype(np.float32)
    sx = (rng.random((6, 7)) * 20 - 2).astype(np.float32)
    sy = (rng.random((6, 7)) * 16 - 2).astype(np.float32)
    got = lookup(img, sx, sy, filter="flat4")
    h, w, _ = img.shape
    for i in range(6):
        for j in range(7):
            x, y = min(max(float(sx[i, j]), 0.0), w - 1.0), min(max(float(sy[i, j]), 0.0), h - 1.0)
            x0, y0 = int(np.floor(x)), int(np.floor(y))
            wx, wy = _flat_weights(x - x0), _flat_weights(y - y0)
            px = lambda r, t: img[min(max(y0 + r, 0), h - 1), min(max(x0 + t, 0), w - 1)]
            want = sum(wy[r] * wx[t] * px(r - 3, t - 3) for r in range(8) for t in range(8))
            near = np.array([px(r, t) for r in range(-1, 3) for t in range(-1, 3)])
            want = np.clip(want, near.min(0), near.max(0))
            np.testing.assert_allclose(got[i, j], want, atol=2e-3)  # the weights are tabled at 1/4096 pixel
    ii, jj = np.mgrid[0:13, 0:17].astype(np.float32)
    np.testing.assert_array_equal(lookup(img, jj, ii, filter="flat4"), img)


def test_flat4_keeps_more_gradient_than_lanczos4_and_does_not_ring():
    """Pixel-level noise read half a pixel off (the phase that loses most) keeps more of its
    gradient through ``flat4`` than through Lanczos-4 (a texture read at fractional
    positions: docs/temporal.md); a step edge read anywhere stays within its two levels
    (Lanczos-4 overshoots it by a tenth)."""
    rng = np.random.default_rng(12)
    img = rng.random((96, 96, 3)).astype(np.float32)
    ii, jj = np.mgrid[8:88, 8:88].astype(np.float32)
    grad = lambda a: np.abs(np.diff(a[..., 0], axis=1)).mean() + np.abs(np.diff(a[..., 0], axis=0)).mean()
    l4 = grad(lookup(img, jj + 0.5, ii + 0.5, filter="lanczos4"))
    assert grad(lookup(img, jj + 0.5, ii + 0.5, filter="flat4")) > 1.05 * l4
    step = np.zeros((40, 40, 3), np.float32)
    step[:, 20:] = 1.0
    x = np.tile(np.linspace(12.0, 28.0, 97, dtype=np.float32), (3, 1))
    y = np.full_like(x, 10.3)
    assert lookup(step, x, y, filter="lanczos4").max() > 1.05
    got = lookup(step, x, y, filter="flat4")
    assert got.min() >= 0.0 and got.max() <= 1.0 and np.ptp(got) == 1.0


@pytest.mark.parametrize("filter", ["bilinear", "lanczos4", "flat4"])
def test_mask_reads_only_masked_pixels(filter):
    """``mask=``: the masked pixels are the plain lookup's, the others 0 (the colour
    fast path, where the output is larger than the image, and the general one)."""
    rng = np.random.default_rng(2)
    img = rng.random((9, 12, 3)).astype(np.float32)
    sx, sy = rng.uniform(-1, 12, (20, 21)), rng.uniform(-1, 9, (20, 21))
    m = rng.random((20, 21)) < 0.6
    got = lookup(img, sx, sy, filter=filter, mask=m)
    assert np.array_equal(got, np.where(m[..., None], lookup(img, sx, sy, filter=filter), 0))


@pytest.mark.parametrize("filt", ["lanczos4", "flat4"])
def test_a_kept_padded_copy_reads_the_same_numbers(filt):
    """``padded``: the caller's ``padded_rgb`` of the image (kept for a run's frames) gives
    the read lookup gives when it pads the image itself, masked or not."""
    from proxyshade.kernels.lookup import padded_rgb

    rng = np.random.default_rng(3)
    img = rng.random((9, 11, 3)).astype(np.float32)
    sx = rng.uniform(-2, 12, (12, 10)).astype(np.float32)  # more reads than pixels: the padded path
    sy = rng.uniform(-2, 10, (12, 10)).astype(np.float32)
    mask = rng.random((12, 10)) > 0.3
    for m in (None, mask):
        want = lookup(img, sx, sy, filter=filt, mask=m)
        got = lookup(img, sx, sy, filter=filt, mask=m, padded=padded_rgb(img))
        assert np.array_equal(got, want)
    assert not np.array_equal(lookup(img, sx, sy, filter=filt, padded=padded_rgb(img * 2)),
                              lookup(img, sx, sy, filter=filt))  # the copy is what is read
