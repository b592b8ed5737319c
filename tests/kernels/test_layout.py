"""kernels.layout against colour-science and slow references; quality's fidelity measures."""
import numpy as np

from proxyshade.io.colourlib import colour_science
from proxyshade.kernels import layout as kl
from proxyshade.kernels import quality as Q
from proxyshade.kernels.features import label_heights


def test_srgb_scale_matches_colour_science():
    rng = np.random.default_rng(0)
    lin = rng.random((17, 19, 3)).astype(np.float32) * 1.2
    c = colour_science()
    enc = c.cctf_encoding(lin.astype(np.float64), function="sRGB")
    np.testing.assert_allclose(kl.srgb_encode(lin), enc, atol=1e-6)


def test_luma_and_its_move_match_colour_science_and_a_slow_reference():
    rng = np.random.default_rng(1)
    lin = (rng.random((13, 11, 3)) * 1.1).astype(np.float32)
    lin[0, 0] = 0.0  # black takes the luminance offset alone
    field = np.stack([(rng.random((13, 11)) - 0.5) * 0.3, (rng.random((13, 11)) - 0.5),
                      (rng.random((13, 11)) - 0.5)], -1).astype(np.float32)
    c = colour_science()
    weights = c.RGB_COLOURSPACES["sRGB"].matrix_RGB_to_XYZ[1]
    np.testing.assert_allclose(kl.LUMA, weights, atol=1e-4)
    y = lin.astype(np.float64) @ weights
    np.testing.assert_allclose(kl.luma_encoded(lin)[..., 1], c.cctf_encoding(y, function="sRGB"), atol=2e-6)
    out = kl.move_luma_chroma(lin, field)
    for i in range(13):
        for j in range(11):
            yn = c.cctf_decoding(max(c.cctf_encoding(y[i, j], function="sRGB") + field[i, j, 0], 0.0), function="sRGB")
            if y[i, j] > 1e-8:
                x = lin[i, j] * np.exp([field[i, j, 1], 0.0, field[i, j, 2]])
                want = x * yn / (x @ weights)
            else:
                want = lin[i, j] + yn
            np.testing.assert_allclose(out[i, j], want, rtol=2e-5, atol=2e-6)
    # the luminance lands on its moved value and the hue on the gains
    np.testing.assert_allclose(out.astype(np.float64) @ weights,
                               c.cctf_decoding(np.clip(c.cctf_encoding(y, function="sRGB") + field[..., 0], 0, None),
                                               function="sRGB"), rtol=1e-4, atol=1e-6)


def test_profile_and_heights_match_a_slow_reference():
    rng = np.random.default_rng(1)
    lab = (rng.random((23, 11)) < 0.3).astype(np.int32)
    t, n = label_heights(lab, lengths=True)
    for j in range(lab.shape[1]):
        i = 0
        while i < lab.shape[0]:
            k = i
            while k + 1 < lab.shape[0] and lab[k + 1, j] == lab[i, j]:
                k += 1
            for r in range(i, k + 1):
                assert n[r, j] == k - i + 1
                assert np.isclose(t[r, j], (r - i) / (k - i) if k > i else 0.5)
            i = k + 1
    img = rng.random((23, 11, 3)).astype(np.float32)
    means, counts = kl.profile(img, lab, t, 2, 4)
    for l in range(2):
        for b in range(4):
            m = (lab == l) & (np.minimum((t * 4).astype(int), 3) == b)
            assert counts[l, b] == m.sum()
            if m.any():
                np.testing.assert_allclose(means[l, b], img[m].mean(0), rtol=1e-5)


def test_smooth_offset_stays_within_labels_and_keeps_constants():
    lab = np.zeros((40, 50), np.int32)
    lab[:, 25:] = 1
    v = np.where(lab[..., None] == 0, np.float32(0.1), np.float32(-0.3)) * np.ones(3, np.float32)
    out = kl.smooth_offset(v, lab, 2)
    np.testing.assert_allclose(out, v, atol=1e-6)  # each label constant: nothing leaks across the border
    v2 = v.copy()
    v2[:20, :25] = 0.5  # a step inside label 0 is smoothed, label 1 untouched
    out2 = kl.smooth_offset(v2, lab, 2)
    np.testing.assert_allclose(out2[lab == 1], v2[lab == 1], atol=1e-6)
    assert 0.1 < out2[20, 10, 0] < 0.5


def test_fidelity_measures_tell_a_copy_from_a_shifted_copy():
    rng = np.random.default_rng(2)
    img = rng.random((40, 60, 3)) * 0.8
    lab = np.zeros((40, 60), np.uint32)
    lab[20:] = 1
    same = Q.label_fidelity(img, lab, img, lab, 1, window_stride=(4, 2))
    assert np.allclose(same["shift"], 0) and np.isclose(same["std_ratio"], 1) and np.isclose(same["grad_ratio"], 1)
    assert same["hist_chi2"] == 0 and same["window_chi2"] == 0
    moved = Q.label_fidelity(np.clip(img + 0.1, 0, 1), lab, img, lab, 1, window_stride=(4, 2))
    assert np.all(moved["shift"] > 0.08) and moved["hist_chi2"] > 0.05
    ramp = np.linspace(0, 1, 40)[:, None].repeat(60, 1)
    sky = np.ones((40, 60), bool)
    assert Q.profile_correlation(Q.vertical_profile(ramp, sky), Q.vertical_profile(ramp ** 2, sky)) > 0.9
    sx, sy = np.meshgrid(np.arange(60.0), np.arange(40.0))
    assert Q.copies(sx, sy, (40, 60)) == 1.0
    assert Q.copies(sx % 16, sy % 16, (40, 60)) > 8  # one 16² tile pasted 2.5 x 3.75 times
