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


def _palette_reference(ids, labels=None):
    """id_palette as np.unique and colorsys give it (the table's colours, hues, 0 black)."""
    import colorsys
    known = {int(t["id"]): [int(t["color"].lstrip("#")[i:i + 2], 16) for i in (0, 2, 4)] for t in labels or []}
    out = np.zeros(np.shape(ids) + (3,), np.uint8)
    for idx, u in np.ndenumerate(ids):
        if int(u) in known:
            out[idx] = known[int(u)]
        elif u != 0:
            r, g, b = colorsys.hsv_to_rgb((int(u) * 0.618033988749895) % 1.0, 0.65, 0.95)
            out[idx] = [int(r * 255), int(g * 255), int(b * 255)]
    return out


@pytest.mark.parametrize("dtype,top", [(np.uint32, 40), (np.uint32, 5000), (np.int32, 300), (np.int64, 70000),
                                       (np.uint32, 2**32 - 1), (np.int32, -1)])
def test_id_palette_gives_the_colorsys_colours_of_each_id(dtype, top):
    """The table lookup (small ids) and np.unique (large or negative ids) both give each id the
    table's colour where known, else its golden-ratio hue exactly as colorsys computes it, 0 black;
    frames taller than a band of rows included."""
    from proxyshade.kernels import display
    rng = np.random.default_rng(top % 97)
    lo = -5 if top < 0 else 0
    ids = rng.integers(lo, max(top, 1), size=(display.ROWS + 19, 31), endpoint=True).astype(dtype)
    ids[0, :3] = [0, 1, max(top, 1)]
    labels = [{"id": 1, "color": "#ff8000"}, {"id": 7, "color": "102030"}, {"id": 10**6, "color": "#ffffff"}]
    for lab in (None, labels):
        np.testing.assert_array_equal(display.id_palette(ids, lab), _palette_reference(ids, lab))
    np.testing.assert_array_equal(display.id_palette(ids[3], labels), _palette_reference(ids[3], labels))


def test_id_palette_hues_match_colorsys_for_every_id_in_a_wide_range():
    """The vectorized hues are colorsys's, bit for bit, over a wide range of ids (every sector)."""
    import colorsys
    from proxyshade.kernels.display import _hues
    u = np.concatenate([np.arange(200000), np.arange(2**32 - 1000, 2**32)]).astype(np.int64)
    got = _hues(u)
    for k in np.random.default_rng(0).choice(len(u), 20000, replace=False).tolist() + list(range(50)):
        r, g, b = colorsys.hsv_to_rgb((int(u[k]) * 0.618033988749895) % 1.0, 0.65, 0.95)
        assert got[k].tolist() == [int(r * 255), int(g * 255), int(b * 255)], int(u[k])
