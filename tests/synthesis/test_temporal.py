"""The temporal layer's pieces: flag clean-up, fragment absorption, patch widths."""
import numpy as np

from proxyshade.kernels.temporal import clean_flags
from proxyshade.synthesis.temporal import FLAG, absorb_fragments, patch_width


def test_clean_flags_removes_isolated_and_dilates_regions():
    raw = np.zeros((20, 24), np.uint32)
    raw[3, 3] = FLAG["distorted"]  # alone in its 5x5 window
    raw[10:13, 10:13] = FLAG["disoccluded"]  # a region
    raw[11, 13] = FLAG["newly_occluded"]
    ones = np.ones(raw.shape, bool)
    out, _ = clean_flags(raw, 2, 3, 2, ones, ~ones, FLAG["disoccluded"], FLAG["newly_occluded"], FLAG["distorted"])
    assert out[3, 3] == 0 and not out[:6, :6].any()
    grown = np.zeros((20, 24), bool)
    for i, j in zip(*np.nonzero(raw[6:, 6:])):  # squares of radius 2 around the kept flags
        grown[i + 6 - 2:i + 6 + 3, j + 6 - 2:j + 6 + 3] = True
    np.testing.assert_array_equal(out > 0, grown)
    assert out[11, 15] == FLAG["newly_occluded"]  # grown from the newly occluded pixel (it wins ties)
    assert out[8, 8] == FLAG["disoccluded"] and out[11, 11] == FLAG["disoccluded"]


def test_fragments_continue_the_patch_they_touch_most():
    H, W = 12, 16
    i, j = np.mgrid[0:H, 0:W]
    patch = np.where(j < 8, 1, 2).astype(np.uint32)
    sx = np.where(j < 8, j + 10.0, j + 40.0).astype(np.float32)
    sy = (i + 5.0).astype(np.float32)
    patch[4:6, 6:8] = 3  # a 2x2 fragment on the left patch's side, touching patch 2 on one edge
    sx[4:6, 6:8] = 70.0 + j[4:6, 6:8]
    lab = np.ones((H, W), np.uint32)
    src_lab = np.ones((40, 100), np.uint32)
    have = np.ones((H, W), bool)
    absorbed, nsx, nsy, npatch = absorb_fragments(have, patch, lab, sx, sy, 1.0, 8, src_lab)
    assert absorbed.sum() == 4 and absorbed[4:6, 6:8].all()
    assert (npatch[4:6, 6:8] == 1).all()  # 6 contacts with patch 1 (left, top, bottom), 2 with patch 2
    np.testing.assert_array_equal(nsx[4:6, 6:8], j[4:6, 6:8] + 10.0)  # patch 1's translation carried on
    np.testing.assert_array_equal(nsy, sy)
    # where the continued copy would leave the fragment's label, it stays as it is
    src_lab[:, 16:18] = 2
    absorbed, nsx, _, npatch = absorb_fragments(have, patch, lab, sx, sy, 1.0, 8, src_lab)
    assert not absorbed.any() and np.array_equal(nsx, sx) and np.array_equal(npatch, patch)


def test_thin_slivers_are_fragments_too():
    H, W = 12, 40
    i, j = np.mgrid[0:H, 0:W]
    patch = np.where(j < 20, 1, 2).astype(np.uint32)
    patch[5, 2:38] = 3  # a 1-px sliver 36 px long: large enough by area, 2A/P < 1.5
    sx = np.where(patch == 1, j + 10.0, np.where(patch == 2, j + 60.0, j + 150.0)).astype(np.float32)
    sy = (i + 5.0).astype(np.float32)
    have = np.ones((H, W), bool)
    area, width = patch_width(have, patch.astype(np.int64), 4)
    assert area[3] == 36 and width[3] < 1.5 and width[1] > 4
    absorbed, nsx, _, npatch = absorb_fragments(have, patch, np.ones((H, W), np.uint32), sx, sy, 1.0, 16,
                                                np.ones((40, 240), np.uint32), 1.5)
    assert absorbed.sum() == 36 and set(np.unique(npatch[5, 2:38])) <= {1, 2}
    assert not absorbed[patch != 3].any()


def test_typical_labels_mark_each_labels_luminance_tails():
    """``typical_labels``: a pixel is RARE when its luminance lies below its label's ``tail``
    quantile or above its ``1 - tail`` quantile (linear interpolation between order
    statistics), against a per-pixel loop over sorted values."""
    from proxyshade.graph.plate import Plate
    from proxyshade.synthesis.temporal import RARE, typical_labels

    rng = np.random.default_rng(3)
    h, w = 23, 31
    lab = rng.integers(1, 4, (h, w)).astype(np.uint32)
    rgb = rng.random((h, w, 3)).astype(np.float32)
    src = Plate({"R": rgb[..., 0].copy(), "G": rgb[..., 1].copy(), "B": rgb[..., 2].copy(), "label.id": lab}, {})
    tail = 0.07
    got = typical_labels(src, tail)
    lum = rgb.astype(np.float64) @ np.array([0.2126, 0.7152, 0.0722])

    def quantile(vals, q):
        v = sorted(vals)
        x = q * (len(v) - 1)
        i = int(x)
        return v[i] if i + 1 >= len(v) else v[i] + (x - i) * (v[i + 1] - v[i])

    for k in (1, 2, 3):
        vals = [lum[i, j] for i in range(h) for j in range(w) if lab[i, j] == k]
        lo, hi = quantile(vals, tail), quantile(vals, 1 - tail)
        for i in range(h):
            for j in range(w):
                if lab[i, j] == k:
                    assert got[i, j] == (RARE if lum[i, j] < lo or lum[i, j] > hi else k)
    assert 0.1 < (got == RARE).mean() < 0.18


def _stranded_case(rng, colour):
    """A 20×24 source with three labels (random colours, or black) and a 30×40 frame of
    three labels whose map reads it at random positions, 80 % of its pixels masked."""
    from proxyshade.graph.plate import Plate

    src_lab = np.ones((20, 24), np.uint32)
    src_lab[:, 12:] = 2
    src_lab[14:, 3:7] = 3
    rgb = rng.random((20, 24, 3)).astype(np.float32) if colour else np.zeros((20, 24, 3), np.float32)
    source = Plate({"label.id": src_lab, "R": rgb[..., 0].copy(), "G": rgb[..., 1].copy(), "B": rgb[..., 2].copy()},
                   {})
    lab = np.ones((30, 40), np.uint32)
    lab[:, 25:] = 2
    lab[5:9, 5:9] = 3
    sx = rng.uniform(-1, 24, (30, 40)).astype(np.float32)
    sy = rng.uniform(-1, 20, (30, 40)).astype(np.float32)
    mask = rng.random((30, 40)) < 0.8
    return source, src_lab, lab, sx, sy, mask


def test_stranded_pixels_match_the_pixel_by_pixel_reference():
    """``stranded_pixels``: a masked pixel whose nearest source pixel has another label among its
    8 neighbours in the source, while its own (2d + 1)² window on screen holds only its label."""
    from proxyshade.synthesis.temporal import stranded_pixels

    source, src_lab, lab, sx, sy, mask = _stranded_case(np.random.default_rng(3), colour=False)
    d = 3
    got = stranded_pixels(source, sx, sy, lab, mask, d)
    want = np.zeros(mask.shape, bool)
    for (i, j), on in np.ndenumerate(mask):
        if not on:
            continue
        c = min(int(np.floor(min(max(float(sx[i, j]), 0.0), 23.0) + 0.5)), 23)
        r = min(int(np.floor(min(max(float(sy[i, j]), 0.0), 19.0) + 0.5)), 19)
        win = src_lab[max(r - 1, 0):r + 2, max(c - 1, 0):c + 2]
        fringe = (win != src_lab[r, c]).any()
        scr = lab[max(i - d, 0):i + d + 1, max(j - d, 0):j + d + 1]
        want[i, j] = fringe and (scr == lab[i, j]).all()
    assert np.array_equal(got, want) and want.any() and (mask & ~want).any()
    assert not stranded_pixels(source, sx, sy, lab, mask, 0).any()


def test_stranded_pixels_with_a_tail_keep_only_rare_fringe_looks():
    """``stranded_pixels(..., tail=t)``: the stranded pixels (without a tail) whose nearest source
    pixel is also a rare look of its label (``typical_labels(source, t)``), and none else."""
    from proxyshade.synthesis.temporal import RARE, stranded_pixels, typical_labels

    source, src_lab, lab, sx, sy, mask = _stranded_case(np.random.default_rng(5), colour=True)
    tail = 0.2
    every = stranded_pixels(source, sx, sy, lab, mask, 3)
    got = stranded_pixels(source, sx, sy, lab, mask, 3, tail=tail)
    typ = typical_labels(source, tail)
    c = np.minimum(np.floor(np.clip(sx, 0, 23) + 0.5).astype(int), 23)
    r = np.minimum(np.floor(np.clip(sy, 0, 19) + 0.5).astype(int), 19)
    want = every & (typ[r, c] == RARE)
    assert np.array_equal(got, want) and want.any() and (every & ~want).any()


def test_rare_fringe_ratio_keeps_labels_whose_fringe_has_a_look_of_its_own():
    """``rare_fringe(source, tail, ratio)``: the fringe's rare looks only on labels whose fringe
    pixels are rare at least ``ratio`` times as often as their other pixels (counted per label
    by hand): label 1's fringe is dark (all rare), label 2's looks like its inside."""
    from proxyshade.graph.plate import Plate
    from proxyshade.synthesis.temporal import RARE, rare_fringe, source_fringe, typical_labels

    rng = np.random.default_rng(9)
    lab = np.ones((30, 40), np.uint32)
    lab[:, 20:] = 2
    lum = 0.4 + 0.2 * rng.random((30, 40))
    lum[:, 19] = 0.01  # label 1's fringe beside label 2: darkened
    rgb = np.repeat(lum[..., None], 3, -1).astype(np.float32)
    source = Plate({"label.id": lab, "R": rgb[..., 0].copy(), "G": rgb[..., 1].copy(), "B": rgb[..., 2].copy()}, {})
    tail = 0.05
    fringe, rare = source_fringe(source), typical_labels(source, tail) == RARE
    for ratio in (2.0, 50.0):
        got = rare_fringe(source, tail, ratio)
        for k in (1, 2):
            m = lab == k
            on = (fringe & rare & m).sum() / (fringe & m).sum() >= ratio * (rare & m & ~fringe).sum() / (m & ~fringe).sum()
            np.testing.assert_array_equal(got[m], (fringe & rare & m)[m] & on)
    assert rare_fringe(source, tail, 2.0)[lab == 1].any() and not rare_fringe(source, tail, 2.0)[lab == 2].any()
    np.testing.assert_array_equal(rare_fringe(source, tail), fringe & rare)
