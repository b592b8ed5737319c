"""synthesis.grain: the gains that match a frame's detail to the photo's, label by label."""
import numpy as np

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
    g = grain.source_colours(src, {"grain": table})
    assert g is grain.source_colours(src, {"grain": table})  # kept for the next frame
    np.testing.assert_allclose(g[lab == 1], rgb[lab == 1], atol=1e-5)  # labels the table does not name
    assert g[lab == 3].std() > 1.5 * rgb[lab == 3].std()
