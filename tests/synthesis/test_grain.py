"""synthesis.grain: the gains that match a frame's detail to the photo's, label by label."""
import numpy as np

from proxyshade.graph.memo import Memo, RunMemo
from proxyshade.graph.plate import Plate
from proxyshade.kernels import grain as kgrain
from proxyshade.kernels import layout as klayout
from proxyshade.synthesis import grain


def photo(seed=0, shape=(96, 120)):
    rng = np.random.default_rng(seed)
    lab = np.ones(shape, np.uint32)
    lab[shape[0] // 2:] = 3  # a sky over water, ids not dense
    lab[60:80, 10:40] = 7
    rgb = (0.2 + 0.3 * rng.random(shape + (3,))).astype(np.float32)
    return rgb, lab


def plate(rgb, lab):
    return Plate({"R": rgb[..., 0].copy(), "G": rgb[..., 1].copy(), "B": rgb[..., 2].copy(), "label.id": lab}, {})


def test_the_photo_itself_needs_no_gain():
    rgb, lab = photo()
    table = grain.gain_table(rgb, lab, rgb, lab, max_gain=2.0)
    assert sorted(table["gains"]) == ["1", "3", "7"]
    for g in table["gains"].values():
        np.testing.assert_allclose(g, 1.0, atol=1e-6)
    np.testing.assert_allclose(grain.graded(plate(rgb, lab), table), rgb, atol=1e-5)


def test_a_frame_with_a_third_of_the_detail_gets_it_back():
    """A frame whose every layer was scaled by 1/3 (in the encoded colours): the table
    asks for about 3 (clamped to max_gain), and grading the frame by it restores the
    photo's detail energy."""
    rgb, lab = photo(1)
    dense = np.searchsorted([1, 3, 7], lab).astype(np.int32)
    hbin = np.zeros(lab.shape, np.int32)  # one height bin
    radii = np.array(grain.RADII)
    flat = klayout.srgb_decode(kgrain.regrade(klayout.srgb_encode(rgb), dense, hbin, radii,
                                              np.full((3, 1, len(radii)), 1 / 3)))
    table = grain.gain_table(flat, lab, rgb, lab, max_gain=8.0)
    fine = np.array([np.asarray(g)[:, :3] for g in table["gains"].values()])
    assert np.all((fine > 2.5) & (fine < 3.5))  # the fine layers: all the photo's energy is there
    assert max(np.max(g) for g in grain.gain_table(flat, lab, rgb, lab, max_gain=2.0)["gains"].values()) == 2.0
    back = grain.graded(plate(flat, lab), table)
    e = lambda x: kgrain.band_energy(klayout.srgb_encode(x), dense, hbin, radii, 3, 1)[0][..., :3].sum()
    assert abs(e(back) / e(rgb) - 1) < 0.1 and e(flat) / e(rgb) < 0.2


def test_source_colours_are_the_graded_source_only_with_a_table():
    rgb, lab = photo(2)
    src = plate(rgb, lab)
    assert np.array_equal(grain.source_colours(src, {}), src.rgb())
    table = {"radii": [1, 2], "bins": 1, "gains": {"3": [[2.0, 2.0]]}}
    memo = RunMemo(Memo())
    g = grain.source_colours(src, {"grain": table}, memo)
    assert g is grain.source_colours(src, {"grain": table}, memo)  # kept for the next frame
    np.testing.assert_allclose(g[lab == 1], rgb[lab == 1], atol=1e-5)  # labels the table does not name
    assert g[lab == 3].std() > 1.5 * rgb[lab == 3].std()


def landscape(seed=0, shape=(256, 320), large=1.0):
    """A sky over water (ids 2 and 5): fine noise plus large-scale waves (periods 120-300
    px) scaled by ``large``, in the encoded colours."""
    rng = np.random.default_rng(seed)
    lab = np.full(shape, 2, np.uint32)
    lab[shape[0] // 2:] = 5
    y, x = np.mgrid[:shape[0], :shape[1]].astype(np.float64)
    waves = 0.12 * np.sin(2 * np.pi * x / 300 + 1.0) * np.cos(2 * np.pi * y / 160) + 0.08 * np.sin(2 * np.pi * (x + y) / 120)
    enc = 0.45 + 0.05 * rng.standard_normal(shape + (3,)) + large * waves[..., None] * np.array([1.0, 0.9, 0.8])
    return klayout.srgb_decode(np.clip(enc, 0.0, 1.0).astype(np.float32)), lab


def spread_energy(rgb, lab):
    """The spread layers' mean energy (radii SPREAD_RADII, the layers after the first), per label."""
    dense = np.searchsorted([2, 5], lab).astype(np.int32)
    s, c = kgrain.band_energy(klayout.srgb_encode(rgb), dense, np.zeros(lab.shape, np.int32),
                              np.array(grain.SPREAD_RADII), 2, 1)
    return s[:, 0, 1:].sum(1) / c[:, 0]


def pixel_gradient(rgb):
    enc = klayout.srgb_encode(rgb)
    return np.abs(np.diff(enc, axis=0)).mean() + np.abs(np.diff(enc, axis=1)).mean()


def test_spread_raises_a_frame_large_scale_variation_toward_the_photo_and_keeps_its_detail():
    """A frame with half the photo's large-scale waves: one pass of spread takes its
    large-scale energy at least half the way to the photo's (a box layer of the regraded
    frame also holds some of its neighbours', so one pass falls short of the target),
    never past it, and leaves the pixel detail as it was."""
    photo_rgb, lab = landscape(0)
    frame, _ = landscape(1, large=0.5)
    out = grain.spread(frame, lab, photo_rgb, lab, max_gain=4.0)
    e_photo, e_frame, e_out = (spread_energy(x, lab) for x in (photo_rgb, frame, out))
    assert np.all(e_frame < 0.4 * e_photo)
    assert np.all(e_out > e_frame + 0.5 * (e_photo - e_frame)) and np.all(e_out < 1.05 * e_photo)
    assert abs(pixel_gradient(out) / pixel_gradient(frame) - 1) < 0.02
    capped = grain.spread(frame, lab, photo_rgb, lab, max_gain=1.5)  # gains of at most 1.5
    assert np.all(spread_energy(capped, lab) < 1.5 ** 2 * e_frame)
    assert np.all(spread_energy(capped, lab) > 1.2 * e_frame)


def test_spread_never_lowers_and_leaves_the_photo_itself_alone():
    photo_rgb, lab = landscape(0)
    assert grain.spread(photo_rgb, lab, photo_rgb, lab, max_gain=2.0) is photo_rgb
    strong, _ = landscape(1, large=2.0)
    assert grain.spread(strong, lab, photo_rgb, lab, max_gain=2.0) is strong


def test_spread_measures_the_photo_at_the_frame_scale():
    """A frame at half the photo's resolution (``scale`` 2 source pixels per output pixel)
    whose waves are the photo's: compared radius for radius at scale 2 it needs little; at
    scale 1 the photo's layers would be read at the wrong size."""
    photo_rgb, lab = landscape(0, shape=(512, 640))
    frame = photo_rgb.reshape(256, 2, 320, 2, 3).mean((1, 3)).astype(np.float32)
    flab = lab[::2, ::2]
    at2 = grain.spread(frame, flab, photo_rgb, lab, max_gain=4.0, scale=2.0)
    at1 = grain.spread(frame, flab, photo_rgb, lab, max_gain=4.0, scale=1.0)
    change = lambda out: np.abs(klayout.srgb_encode(out) - klayout.srgb_encode(frame)).mean()
    assert change(at2) < 0.25 * change(at1)
