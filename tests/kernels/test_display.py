"""The preview's view transform: faithful below the knee, no clip above 1."""
import numpy as np
import pytest

from proxyshade.kernels.display import KNEE, view_transform


def test_shoulder_is_identity_below_the_knee_and_clip_is_exact_below_one():
    x = np.linspace(0.0, KNEE, 101)
    assert np.array_equal(view_transform(x), x)
    y = np.linspace(0.0, 1.0, 101)
    assert np.array_equal(view_transform(y, "clip"), y)


def test_shoulder_keeps_values_above_one_apart_and_below_white():
    x = np.array([0.95, 1.0, 1.1, 1.3, 1.6])
    v = view_transform(x)
    assert np.all(np.diff(v) > 0), "brighter plate values must show brighter"
    assert np.all(v < 1.0) and np.all(v > KNEE)
    assert np.all(view_transform(x, "clip")[1:] == 1.0)  # what the clip loses


def test_shoulder_is_continuous_with_slope_one_at_the_knee():
    e = 1e-6
    assert view_transform(np.array([KNEE + e]))[0] == pytest.approx(KNEE + e, abs=1e-10)


def test_negative_values_show_black():
    assert np.all(view_transform(np.array([-1.0, -1e-3])) == 0.0)
    assert np.all(view_transform(np.array([-1.0]), "clip") == 0.0)


def test_unknown_view_is_refused():
    with pytest.raises(ValueError, match="shoulder"):
        view_transform(np.zeros(3), "aces")


def test_to_display_in_bands_gives_the_whole_frame_encoding():
    """to_display converts a band of rows at a time (memory): a frame taller than a band,
    with values above 1, negatives, NaN and infinities, gives the bytes of the whole frame
    encoded at once (sRGB of the shoulder view, rounded)."""
    from proxyshade.io.colourlib import colour_science
    from proxyshade.kernels import display
    from proxyshade.plate import Plate

    rng = np.random.default_rng(3)
    h = 2 * display.ROWS + 37
    rgb = (rng.random((h, 23, 3)) * 1.6 - 0.1).astype(np.float32)
    rgb[5, 3, 0], rgb[h - 1, 0, 1], rgb[display.ROWS, 7, 2] = np.nan, np.inf, -np.inf
    plate = Plate({c: rgb[..., k].copy() for k, c in enumerate("RGB")}, {})
    lin = np.nan_to_num(rgb.astype(np.float64) * 2.0 ** 0.5, nan=0.0, posinf=1e6, neginf=0.0)
    enc = colour_science().cctf_encoding(display.view_transform(lin), function="sRGB")
    want = (np.clip(enc, 0, 1) * 255 + 0.5).astype(np.uint8)
    np.testing.assert_array_equal(display.to_display(plate, ["R", "G", "B"], exposure=0.5), want)
