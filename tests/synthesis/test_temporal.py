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
