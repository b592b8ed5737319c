"""Temporal kernels against slow references and hand-made cases."""
import numpy as np
import pytest

from proxyshade.kernels import temporal as T


def test_translation_has_unit_determinant():
    i, j = np.mgrid[0:20, 0:30].astype(np.float64)
    det = T.jacobian_det(j + 3.25, i - 1.5, np.ones((20, 30), bool))
    np.testing.assert_allclose(det, 1.0, atol=1e-12)


def test_zoom_determinant_is_scale_squared():
    i, j = np.mgrid[0:16, 0:16].astype(np.float64)
    s = 0.8  # the previous frame sees the same content 0.8 times as large
    det = T.jacobian_det(8 + (j - 8) * s, 8 + (i - 8) * s, np.ones((16, 16), bool))
    np.testing.assert_allclose(det, s * s, atol=1e-12)


def test_determinant_matches_reference_with_invalid_pixels():
    rng = np.random.default_rng(3)
    u, v = rng.random((2, 9, 11)) * 10
    valid = rng.random((9, 11)) > 0.2
    got = T.jacobian_det(u, v, valid)
    h, w = u.shape
    for i in range(h):
        for j in range(w):
            if not valid[i, j]:
                assert got[i, j] == 1
                continue
            jl = j - 1 if j > 0 and valid[i, j - 1] else j
            jr = j + 1 if j < w - 1 and valid[i, j + 1] else j
            iu = i - 1 if i > 0 and valid[i - 1, j] else i
            idn = i + 1 if i < h - 1 and valid[i + 1, j] else i
            if jr == jl or idn == iu:
                assert got[i, j] == 1
                continue
            J = np.array([[(u[i, jr] - u[i, jl]) / (jr - jl), (u[idn, j] - u[iu, j]) / (idn - iu)],
                          [(v[i, jr] - v[i, jl]) / (jr - jl), (v[idn, j] - v[iu, j]) / (idn - iu)]])
            assert got[i, j] == pytest.approx(np.linalg.det(J), abs=1e-9)


def ref_remove_isolated(f, r, k):
    out = np.zeros_like(f)
    for i, j in zip(*np.nonzero(f)):
        win = f[max(0, i - r):i + r + 1, max(0, j - r):j + r + 1]
        out[i, j] = win.sum() - 1 >= k
    return out


def ref_dilate(f, r):
    out = np.zeros_like(f)
    for i, j in zip(*np.nonzero(f)):
        out[max(0, i - r):i + r + 1, max(0, j - r):j + r + 1] = True
    return out


@pytest.mark.parametrize("seed", range(5))
def test_cleanup_matches_references(seed):
    f = np.random.default_rng(seed).random((23, 17)) > 0.85
    assert np.array_equal(T.remove_isolated(f, 2, 1), ref_remove_isolated(f, 2, 1))
    assert np.array_equal(T.remove_isolated(f, 2, 3), ref_remove_isolated(f, 2, 3))
    for r in (0, 1, 3):
        assert np.array_equal(T.dilate(f, r), ref_dilate(f, r))


def test_isolated_single_flags_removed_regions_kept():
    f = np.zeros((20, 20), bool)
    f[2, 2] = True  # alone
    f[10:14, 10:14] = True  # a region
    g = T.remove_isolated(f, 2, 1)
    assert not g[2, 2] and g[10:14, 10:14].all()
    d = T.dilate(g, 2)
    assert d[8:16, 8:16].all() and d.sum() == 64


# -- additions for the temporal nodes (issue 6) --------------------------------
def test_components4_match_scipy():
    from scipy import ndimage

    rng = np.random.default_rng(11)
    mask = rng.random((40, 50)) > 0.55
    lab, boxes = T.components4(mask)
    ref, n = ndimage.label(mask)  # 4-connectivity, numbered in scan order too
    np.testing.assert_array_equal(lab, ref)
    assert len(boxes) == n
    for k, sl in enumerate(ndimage.find_objects(ref)):
        assert tuple(boxes[k]) == (sl[0].start, sl[0].stop - 1, sl[1].start, sl[1].stop - 1)


def test_group_boxes_cover_every_component_with_a_margin():
    mask = np.zeros((60, 80), bool)
    mask[5:8, 5:9] = True
    mask[10:12, 6:10] = True  # near the first: merged (cheap)
    mask[40:55, 60:75] = True
    mask[0:60, 79] = True  # a border strip: clipped at the image
    _, boxes = T.components4(mask)
    groups = T.group_boxes(boxes, mask.shape, slack=64)
    seen = sorted(k for g in groups for k in g[4])
    assert seen == [1, 2, 3, 4]
    for r0, r1, c0, c1, ids in groups:
        for k in ids:
            b = boxes[k - 1]
            assert r0 <= max(0, b[0] - 1) and r1 >= min(60, b[1] + 2) and c0 <= max(0, b[2] - 1) and c1 >= min(80, b[3] + 2)
    assert len(groups) < 4


@pytest.mark.parametrize("small", [0, 64])  # windows with multigrid CG, or SOR on the free pixels
@pytest.mark.parametrize("screen", [0.0, 0.01])
def test_poisson_regions_equal_the_whole_frame_solve(screen, small):
    from proxyshade.kernels import poisson as P

    rng = np.random.default_rng(12)
    h, w = 48, 56
    colors = rng.random((h, w, 3)).astype(np.float32)
    patch = (np.arange(h)[:, None] // 7 * 10 + np.arange(w)[None, :] // 9).astype(np.uint32)
    labels = np.ones((h, w), np.uint32)
    labels[:, 30:] = 2
    free = np.zeros((h, w), bool)
    free[4:15, 3:20] = True
    free[30:45, 25:50] = True  # crosses the label border
    free[20:22, 50:56] = True  # touches the image border
    src = rng.random((32, 32, 3)).astype(np.float32)
    sx = np.clip(np.arange(w)[None, :] * 0.5 + 0 * np.arange(h)[:, None], 0, 31).astype(np.float32)
    sy = np.clip(np.arange(h)[:, None] * 0.5 + 0 * np.arange(w)[None, :], 0, 31).astype(np.float32)
    gx, gy = P.seam_gradients(src, sx, sy, 0.5)
    ref, _ = P.poisson_transfer(colors, patch, labels, fixed=~free, values=colors, seam_gx=gx, seam_gy=gy,
                                screen=screen, tol=1e-7, max_iter=500)
    got, info = T.poisson_regions(colors, patch, labels, free, source=src, sx=sx, sy=sy, step=0.5, screen=screen,
                                  tol=1e-7, max_iter=500, slack=0, small=small)
    if small:
        assert info["windows"] == 0 and info["sor_pixels"] == free.sum() - (free & P.contour_mask(labels)).sum()
    else:
        assert info["windows"] == 3 and info["window_pixels"] < h * w
    np.testing.assert_array_equal(got[~free], colors[~free])
    np.testing.assert_allclose(got, ref, atol=2e-4)


def test_map_deviation_matches_reference():
    rng = np.random.default_rng(4)
    sx, sy = rng.random((2, 9, 11)) * 20
    valid = rng.random((9, 11)) > 0.2
    patch = rng.integers(1, 3, (9, 11)).astype(np.uint32)
    lab = np.ones((9, 11), np.uint32)
    from proxyshade.kernels.reproject import patch_links
    links = patch_links(valid, patch, lab)
    got = T.map_deviation(sx, sy, valid, links, 2.0)
    h, w = sx.shape
    ok = lambda a, b, i, j: 0 <= a < h and 0 <= b < w and valid[a, b] and patch[a, b] == patch[i, j]
    for i in range(h):
        for j in range(w):
            if not valid[i, j]:
                assert got[i, j] == 0
                continue
            jl, jr = (j - 1 if ok(i, j - 1, i, j) else j), (j + 1 if ok(i, j + 1, i, j) else j)
            iu, idn = (i - 1 if ok(i - 1, j, i, j) else i), (i + 1 if ok(i + 1, j, i, j) else i)
            J = np.eye(2)
            if jr != jl:
                J[:, 0] = [(sx[i, jr] - sx[i, jl]) / (jr - jl) / 2, (sy[i, jr] - sy[i, jl]) / (jr - jl) / 2]
            if idn != iu:
                J[:, 1] = [(sx[idn, j] - sx[iu, j]) / (idn - iu) / 2, (sy[idn, j] - sy[iu, j]) / (idn - iu) / 2]
            assert got[i, j] == pytest.approx(np.linalg.norm(J - np.eye(2)), rel=1e-5, abs=1e-6)


def test_region_thickness_is_twice_area_over_perimeter():
    mask = np.zeros((30, 40), bool)
    mask[2:5, 3:33] = True  # a band 3 px wide, 30 long
    mask[10:20, 10:20] = True  # a 10 x 10 square
    mask[25:30, 0:1] = True  # 5 x 1 at the image border (the border counts as outside)
    comp, boxes = T.components4(mask)
    got = T.region_thickness(mask, comp, len(boxes))
    np.testing.assert_allclose(got, [2 * 90 / 66, 2 * 100 / 40, 1.0])  # the last: 10 / 12, clamped to 1
