"""Temporal kernels against slow references and hand-made cases."""
import numpy as np
import pytest

from proxyshade.kernels import temporal as T
from proxyshade.kernels.reproject import Landing

CODES = T.FlagCodes(np.uint32(1), np.uint32(2), np.uint32(3), np.uint32(4))


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
def test_dilate_matches_reference(seed):
    f = np.random.default_rng(seed).random((23, 17)) > 0.85
    for r in (0, 1, 3):
        assert np.array_equal(T.dilate(f, r), ref_dilate(f, r))


def ref_clean_flags(raw, radius, min_neighbours, dilate):
    """Isolated flags removed, then the newly occluded (2) and disoccluded (1) flags dilated
    into unflagged pixels, 2 before 1: the carry's clean-up as whole-array steps."""
    anyf = raw > 0
    kept = ref_remove_isolated(anyf, radius, min_neighbours) if min_neighbours > 0 else anyf
    out = np.where(kept, raw, 0).astype(np.uint32)
    todo = ~kept
    for reason in (2, 1) if dilate > 0 else ():
        m = ref_dilate(out == reason, dilate) & todo
        out[m] = reason
        todo &= ~m
    return out


def test_isolated_single_flags_removed_regions_kept():
    f = np.zeros((20, 20), bool)
    f[2, 2] = True  # alone
    f[10:14, 10:14] = True  # a region
    ones = np.ones(f.shape, bool)
    g, _ = T.clean_flags(f.astype(np.uint32), 2, 1, 0, ones, ~ones, 1, 2, 3)
    assert not g[2, 2] and g[10:14, 10:14].all()
    d = T.dilate(g > 0, 2)
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


@pytest.mark.parametrize("correct", [True, False])
def test_keep_carried_matches_numpy_reference(correct):
    """What a carried pixel keeps by its flag, against the plain array expressions."""
    rng = np.random.default_rng(5)
    h, w, RE = 11, 14, 4
    flag = rng.choice(np.array([0, 0, 0, 1, 2, 3, RE], np.uint32), (h, w))
    f32 = lambda *s: rng.normal(size=s).astype(np.float32)
    D, ext, sx, sy = f32(h, w), f32(h, w), f32(h, w), f32(h, w)
    patch = rng.integers(0, 50, (h, w)).astype(np.uint32)
    rgb, res = f32(h, w, 3), f32(h, w, 3)
    R, G, B, osx, osy, op, oD, oext, *corr = T.keep_carried(flag, RE, D, ext, sx, sy, patch, rgb, res, correct)
    whole = flag == 0
    keep = whole | (flag == RE)
    r = np.where(whole[..., None], res, 0.0).astype(np.float32)
    col = np.where(keep[..., None], rgb + r if correct else res, 0.0)
    for k, got in enumerate((R, G, B)):
        assert np.array_equal(got, col[..., k])
    for got, a in ((osx, sx), (osy, sy), (op, patch), (oext, ext)):
        assert np.array_equal(got, np.where(keep, a, 0))
    assert np.array_equal(oD, np.where(whole, D, 0))
    for k, got in enumerate(corr):
        assert np.array_equal(got, r[..., k] if correct else np.zeros((h, w)))


def test_area_perimeter_matches_numpy_reference():
    """Per-id area and perimeter (edges to another id, an unkept pixel or the border)."""
    rng = np.random.default_rng(9)
    ids = rng.integers(0, 6, (15, 19))
    have = rng.random((15, 19)) < 0.8
    area, per = T.area_perimeter(have, ids, 6)
    m = np.pad(np.where(have, ids, -1), 1, constant_values=-1)
    want = np.zeros(6, int)
    for di, dj in ((0, 1), (0, -1), (1, 0), (-1, 0)):
        edge = have & (m[1 + di:1 + di + 15, 1 + dj:1 + dj + 19] != ids)
        want += np.bincount(ids[edge], minlength=6)
    assert np.array_equal(area, np.bincount(ids[have], minlength=6))
    assert np.array_equal(per, want)


def test_patch_mean_and_in_ids_match_numpy():
    rng = np.random.default_rng(4)
    ids = rng.integers(0, 7, (13, 11))
    have = rng.random((13, 11)) < 0.7
    v = rng.normal(size=(13, 11)).astype(np.float32)
    count = np.bincount(ids[have], minlength=7)
    want = np.bincount(ids[have], weights=v[have], minlength=7) / np.maximum(count, 1)
    assert np.array_equal(T.patch_mean(have, ids, v, 7), want)
    chosen = rng.random(5) < 0.5  # ids 5 and 6 lie past the table: not chosen
    assert np.array_equal(T.in_ids(have, ids, chosen), have & np.append(chosen, [False, False])[ids])


def test_merge_redo_matches_numpy():
    rng = np.random.default_rng(6)
    redo = rng.random((8, 9)) < 0.3
    f = lambda: rng.normal(size=(8, 9)).astype(np.float32)
    pn, po = (rng.integers(0, 9, (8, 9)).astype(np.uint32) for _ in range(2))
    a, b, c, d = f(), f(), f(), f()
    sx, sy, p = T.merge_redo(redo, a, b, pn, np.uint32(20), c, d, po)
    assert np.array_equal(sx, np.where(redo, a, c)) and np.array_equal(sy, np.where(redo, b, d))
    assert np.array_equal(p, np.where(redo, pn + np.uint32(20), po))


@pytest.mark.parametrize("correct", [True, False])
def test_colour_planes_match_numpy(correct):
    rng = np.random.default_rng(8)
    rgb, before = (rng.normal(size=(6, 7, 3)).astype(np.float32) for _ in range(2))
    flagged = rng.random((6, 7)) < 0.4
    old = [rng.normal(size=(6, 7)).astype(np.float32) for _ in range(3)]
    if not correct:
        old = [np.zeros((0, 0), np.float32)] * 3
    R, G, B, *corr = T.colour_planes(rgb, flagged, before, *old, correct)
    for k, got in enumerate((R, G, B)):
        assert np.array_equal(got, rgb[..., k])
    if correct:
        want = np.where(flagged[..., None], rgb - before, np.stack(old, -1))
        for k in range(3):
            assert np.array_equal(corr[k], want[..., k])


def _labelled_case(rng, h=13, w=17):
    """A small source label map and maps reading it near, across and outside its borders."""
    src_lab = np.zeros((9, 12), np.uint32)
    src_lab[:, 6:] = 1
    src_lab[5:, 2:5] = 2
    lab = rng.integers(0, 3, (h, w)).astype(np.uint32)
    sx = rng.uniform(-1.5, 12.5, (h, w)).astype(np.float32)
    sy = rng.uniform(-1.5, 9.5, (h, w)).astype(np.float32)
    sx[0, :4] = [0.0, 11.0, 5.5, 5.75]  # on the edges, half way between labels
    mask = rng.random((h, w)) < 0.7
    return src_lab, sx, sy, lab, mask


def _on_label_reference(src_lab, x, y, L):
    hs, ws = src_lab.shape
    if not (x >= 0 and y >= 0 and x <= ws - 1 and y <= hs - 1):
        return False
    c = min(int(np.floor(min(max(float(x), 0.0), ws - 1.0) + 0.5)), ws - 1)
    r = min(int(np.floor(min(max(float(y), 0.0), hs - 1.0) + 0.5)), hs - 1)
    return src_lab[r, c] == L


def stray(src_lab, sx, sy, lab, mask, margin):
    """``flag_reasons``' stray pixels for the kept pixels ``mask`` (nothing else flagged)."""
    h, w = mask.shape
    no = np.zeros((h, w), bool)
    z = np.zeros((h, w), np.float64)
    _, s = T.flag_reasons(have=mask, absorbed=no, distorted=no, src_lab=src_lab, sx=sx, sy=sy, lab=lab, margin=margin,
                          cat=np.zeros((h, w), np.uint32), cat_c=np.uint32(3), land=Landing(z, z, z, no),
                          prev_lab=np.zeros((2, 2), np.uint32), codes=CODES)
    return s


def ref_stray(src_lab, sx, sy, lab, mask, margin=0.5):
    m = np.float32(margin)
    out = np.zeros(mask.shape, bool)
    for (i, j), on in np.ndenumerate(mask):
        x, y, L = sx[i, j], sy[i, j], lab[i, j]
        out[i, j] = on and not _on_label_reference(src_lab, x, y, L) and not (margin > 0 and any(
            _on_label_reference(src_lab, x + a, y + b, L) for a, b in ((m, 0), (-m, 0), (0, m), (0, -m))))
    return out


def ref_newly_occluded(cat, u, v, ok, lab, prev_lab, cat_c=3):
    out = np.zeros(lab.shape, bool)
    hp, wp = prev_lab.shape
    for (i, j), c in np.ndenumerate(cat):
        if c == cat_c and ok[i, j]:
            x, y = int(np.floor(u[i, j])), int(np.floor(v[i, j]))
            out[i, j] = not (0 <= x < wp and 0 <= y < hp) or prev_lab[y, x] != lab[i, j]
    return out


@pytest.mark.parametrize("seed", [0, 1])
def test_fits_and_stray_match_the_pixel_by_pixel_reference(seed):
    """``fits_label``: inside the source on a pixel of its label (nearest, as ``lookup``
    reads ids); a stray kept pixel (``flag_reasons``): not, and neither are the positions
    half a pixel to each side (float32 sums)."""
    rng = np.random.default_rng(seed)
    src_lab, sx, sy, lab, mask = _labelled_case(rng)
    fits = T.fits_label(src_lab, sx, sy, lab, mask)
    off = stray(src_lab, sx, sy, lab, mask, 0.5)
    off0 = stray(src_lab, sx, sy, lab, mask, 0.0)
    m = np.float32(0.5)
    for (i, j), on in np.ndenumerate(mask):
        x, y, L = sx[i, j], sy[i, j], lab[i, j]
        f = on and _on_label_reference(src_lab, x, y, L)
        near = any(_on_label_reference(src_lab, x + a, y + b, L)
                   for a, b in ((m, 0), (-m, 0), (0, m), (0, -m)))
        assert fits[i, j] == f and off0[i, j] == (on and not f) and off[i, j] == (on and not f and not near)
    assert fits.any() and off.any() and (off0 & ~off).any()


def test_map_deviation_patches_is_map_deviation_with_patch_links():
    from proxyshade.kernels.reproject import patch_links

    rng = np.random.default_rng(8)
    h, w = 15, 19
    sx, sy = (rng.random((2, h, w)) * 30).astype(np.float32)
    valid = rng.random((h, w)) > 0.15
    patch = rng.integers(1, 4, (h, w)).astype(np.uint32)
    lab = rng.integers(0, 2, (h, w)).astype(np.uint32)
    ref = T.map_deviation(sx, sy, valid, patch_links(valid, patch, lab), 0.75)
    got = T.map_deviation_patches(sx, sy, valid, patch, lab, 0.75)
    assert np.array_equal(got, ref) and (got > 0).any()


@pytest.mark.parametrize("seed,dilate,min_n", [(0, 2, 3), (1, 1, 0), (2, 0, 3)])
def test_clean_flags_kernel_matches_the_numpy_steps(seed, dilate, min_n):
    """Isolated flags dropped, newly occluded then disoccluded flags dilated into unflagged
    pixels, then the unflagged pixels without a carry disoccluded and the stray ones
    distorted: the whole-array steps of ``synthesis.temporal`` and the carry, and the counts."""
    rng = np.random.default_rng(seed)
    h, w = 40, 50
    raw = rng.choice(np.array([0] * 12 + [1, 2, 3, 4], np.uint32), (h, w))
    raw[5:12, 5:20] = 1
    raw[20:26, 30:45] = 2
    have = rng.random((h, w)) > 0.1
    stray = rng.random((h, w)) > 0.9
    ref = ref_clean_flags(raw, 2, min_n, dilate)
    ref[~have & (ref == 0)] = 1
    ref[stray & (ref == 0)] = 3
    got, n = T.clean_flags(raw, 2, min_n, dilate, have, stray, 1, 2, 3)
    assert np.array_equal(got, ref) and np.array_equal(n, np.bincount(ref.ravel(), minlength=5))


def test_continue_filled_and_flag_reasons_match_the_numpy_steps():
    rng = np.random.default_rng(9)
    src_lab, sx, sy, lab, _ = _labelled_case(rng, 21, 23)
    h, w = lab.shape
    filled = rng.random((h, w)) < 0.4
    valid = ~filled & (rng.random((h, w)) < 0.8)
    ext = rng.integers(0, 8, (h, w)).astype(np.float32)
    e1 = ext.copy()
    keep, have = T.continue_filled(filled, valid, e1, src_lab, sx, sy, lab, 6.0)
    e0 = np.where(filled, ext + 1.0, ext).astype(np.float32)
    k0 = filled & T.fits_label(src_lab, sx, sy, lab, filled) & (e0 <= 6)
    assert np.array_equal(e1, e0) and np.array_equal(keep, k0) and np.array_equal(have, valid | k0)
    absorbed = rng.random((h, w)) < 0.1
    distorted = rng.random((h, w)) < 0.1
    cat = rng.integers(1, 5, (h, w)).astype(np.uint32)
    u, v = rng.uniform(-2, 14, (2, h, w))
    ok = rng.random((h, w)) < 0.9
    prev_lab = rng.integers(0, 3, (11, 12)).astype(np.uint32)
    raw, stray = T.flag_reasons(have=have, absorbed=absorbed, distorted=distorted, src_lab=src_lab, sx=sx, sy=sy,
                                lab=lab, margin=0.5, cat=cat, cat_c=np.uint32(3),
                                land=Landing(u, v, np.zeros((h, w)), ok), prev_lab=prev_lab, codes=CODES)
    r = np.zeros((h, w), np.uint32)
    r[absorbed] = 4
    fits = T.fits_label(src_lab, sx, sy, lab, distorted)
    r[distorted] = np.where(fits[distorted], 4, 3)
    s = ref_stray(src_lab, sx, sy, lab, have & (r == 0))
    r[s] = 3
    r[~have] = 1
    r[ref_newly_occluded(cat, u, v, ok, lab, prev_lab)] = 2
    assert np.array_equal(stray, s) and np.array_equal(raw, r)
    assert all((r == k).any() for k in range(5))


def test_reanchor_matches_the_bincount_means():
    rng = np.random.default_rng(10)
    h, w = 17, 21
    ids = rng.integers(0, 6, (h, w)).astype(np.uint32)
    distorted = rng.random((h, w)) < 0.5
    sx, sy = (rng.random((2, h, w)) * 40).astype(np.float32)
    ii, jj = np.nonzero(distorted)
    pid = ids[ii, jj].astype(np.int64)
    c = np.maximum(np.bincount(pid, minlength=6), 1).astype(np.float64)
    m = [np.bincount(pid, weights=wt, minlength=6) / c for wt in (ii, jj, sx[ii, jj], sy[ii, jj])]
    rx, ry = sx.copy(), sy.copy()
    rx[ii, jj] = m[2][pid] + (jj - m[1][pid]) * 0.5
    ry[ii, jj] = m[3][pid] + (ii - m[0][pid]) * 0.5
    T.reanchor(distorted, ids, sx, sy, 0.5, 6)
    assert np.array_equal(sx, rx) and np.array_equal(sy, ry)


def test_label_gradients_match_the_per_label_reference():
    """Every label's gradient sum and count are quality.gradient_magnitude's on the display
    luma of colour-science's sRGB encoding (linear values below 0 and above 1 included)."""
    from proxyshade.io.colourlib import colour_science
    from proxyshade.kernels import quality as Q

    rng = np.random.default_rng(5)
    rgb = (rng.random((23, 31, 3)) * 1.3 - 0.1).astype(np.float32)
    rgb[:4] *= 0.002  # the linear segment of the encoding
    lab = rng.integers(0, 3, (23, 31)).astype(np.uint32)
    lab[5:15, 8:25] = 1  # a block with interior pixels
    from proxyshade.io.colourlib import srgb_encoding_table

    table = srgb_encoding_table(T.ENCODE_STEPS)
    s, c = T.label_gradients(rgb, lab, 4, table)
    enc = np.clip(colour_science().cctf_encoding(np.clip(rgb.astype(np.float64), 0, None), function="sRGB"), 0, 1)
    lum = Q.luma(enc)
    for L in range(4):
        m = lab == L
        ok = m[:-1, :-1] & m[:-1, 1:] & m[1:, :-1]
        assert c[L] == ok.sum()
        ref = Q.gradient_magnitude(lum, m)
        assert (s[L] / c[L] if c[L] else 0.0) == pytest.approx(ref, rel=1e-5, abs=1e-12)
    assert c[3] == 0 and s[3] == 0.0
    v = np.linspace(-0.1, 1.2, 20001)  # the encoding itself (the power segment from a table): within 1e-6
    enc = np.clip(colour_science().cctf_encoding(np.clip(v, 0, None), function="sRGB"), 0, 1)
    got = np.array([T._display(x, table) for x in v])
    assert np.abs(got - enc).max() < 1e-6


def ref_snap(src_lab, sx, sy, lab, mask, margin):
    """``snap_to_label`` pixel by pixel: an off-label pixel on its label ``margin`` to its right,
    left, below or above (first in that order) moved onto that source pixel's nearest position."""
    hs, ws = src_lab.shape
    sx, sy = sx.copy(), sy.copy()
    moved = np.zeros(mask.shape, bool)
    m = np.float32(margin)
    for (i, j), on in np.ndenumerate(mask):
        x, y, L = sx[i, j], sy[i, j], lab[i, j]
        if not on or _on_label_reference(src_lab, x, y, L):
            continue
        for a, b in ((m, 0), (-m, 0), (0, m), (0, -m)):
            if not _on_label_reference(src_lab, np.float32(x + np.float32(a)), np.float32(y + np.float32(b)), L):
                continue
            if a:  # the on-label pixel's column; the position in it nearest to x
                c = int(np.floor(float(np.float32(x + np.float32(a))) + 0.5))
                cand = [v for v in np.arange(c - 0.5, c + 0.5, 1 / 64, dtype=np.float64)
                        if _on_label_reference(src_lab, np.float32(v), y, L)]
                sx[i, j] = np.float32(min(cand, key=lambda v: abs(v - float(x))))
            else:
                r = int(np.floor(float(np.float32(y + np.float32(b))) + 0.5))
                cand = [v for v in np.arange(r - 0.5, r + 0.5, 1 / 64, dtype=np.float64)
                        if _on_label_reference(src_lab, x, np.float32(v), L)]
                sy[i, j] = np.float32(min(cand, key=lambda v: abs(v - float(y))))
            moved[i, j] = True
            break
    return sx, sy, moved


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_snap_to_label_moves_half_off_pixels_onto_their_label(seed):
    """A kept pixel at most half a source pixel off its label (not stray) is moved by at most
    half a pixel, along one axis, onto its label's nearest position (the reference's, to a 64th
    of a pixel, searched over the on-label pixel); every other pixel is left as it was."""
    rng = np.random.default_rng(seed)
    src_lab, sx, sy, lab, mask = _labelled_case(rng, 31, 37)
    want_sx, want_sy, want = ref_snap(src_lab, sx, sy, lab, mask, 0.5)
    gx, gy = sx.copy(), sy.copy()
    moved = T.snap_to_label(src_lab, gx, gy, lab, mask, np.float32(0.5))
    assert np.array_equal(moved, want) and want.any()
    assert np.array_equal(gx[~want], sx[~want]) and np.array_equal(gy[~want], sy[~want])
    assert np.abs(gx - want_sx).max() <= 1 / 64 and np.abs(gy - want_sy).max() <= 1 / 64
    assert (np.abs(gx - sx) + np.abs(gy - sy)).max() <= 0.5
    assert T.fits_label(src_lab, gx, gy, lab, want)[want].all()
    # what it moved is what flag_reasons' stray test spares: moved pixels were off their label, not stray
    assert not stray(src_lab, sx, sy, lab, want, 0.5).any() and not T.fits_label(src_lab, sx, sy, lab, want)[want].any()


def test_map_stretch_patches_is_the_smaller_singular_value_of_the_linked_jacobian():
    """``map_stretch_patches``: per valid pixel, the smaller singular value (``np.linalg.svd``) of
    J / scale, J by central differences over the neighbours of its patch and label (one-sided
    over one, the identity's column over none), 0 where not valid."""
    rng = np.random.default_rng(12)
    h, w = 13, 17
    i, j = np.mgrid[0:h, 0:w]
    # smooth maps (a zoom and a shear) plus noise, so both singular values vary
    sx = (0.8 * j + 0.3 * i + rng.random((h, w)) * 0.5).astype(np.float32)
    sy = (1.1 * i - 0.2 * j + rng.random((h, w)) * 0.5).astype(np.float32)
    valid = rng.random((h, w)) > 0.15
    patch = (1 + (j >= 9) + (i >= 7)).astype(np.uint32)  # blocks, so most pixels have linked neighbours
    lab = (rng.random((h, w)) > 0.1).astype(np.uint32)
    scale = 0.75
    got = T.map_stretch_patches(sx, sy, valid, patch, lab, scale)
    linked = lambda a, b, i0, j0: (0 <= a < h and 0 <= b < w and valid[a, b] and patch[a, b] == patch[i0, j0]
                                   and lab[a, b] == lab[i0, j0])
    X, Y = sx.astype(np.float64), sy.astype(np.float64)
    seen = 0
    for i0 in range(h):
        for j0 in range(w):
            if not valid[i0, j0]:
                assert got[i0, j0] == 0
                continue
            J = np.eye(2)
            jl = j0 - 1 if linked(i0, j0 - 1, i0, j0) else j0
            jr = j0 + 1 if linked(i0, j0 + 1, i0, j0) else j0
            iu = i0 - 1 if linked(i0 - 1, j0, i0, j0) else i0
            idn = i0 + 1 if linked(i0 + 1, j0, i0, j0) else i0
            if jr != jl:
                J[:, 0] = [(X[i0, jr] - X[i0, jl]) / (jr - jl) / scale, (Y[i0, jr] - Y[i0, jl]) / (jr - jl) / scale]
            if idn != iu:
                J[:, 1] = [(X[idn, j0] - X[iu, j0]) / (idn - iu) / scale, (Y[idn, j0] - Y[iu, j0]) / (idn - iu) / scale]
                seen += jr != jl
            assert got[i0, j0] == pytest.approx(np.linalg.svd(J, compute_uv=False)[-1], abs=2e-6)
    assert seen > 20 and got[valid].min() < got[valid].max() - 0.1


def test_map_stretch_of_a_zoom_is_its_inverse_and_blind_to_rotation():
    i, j = np.mgrid[0:20, 0:20].astype(np.float32)
    ones = np.ones((20, 20), np.uint32)
    valid = np.ones((20, 20), bool)
    zoom = T.map_stretch_patches(j * 0.8, i * 0.8, valid, ones, ones, 1.0)  # the screen 1.25x the source
    np.testing.assert_allclose(zoom, 0.8, rtol=1e-6)
    c, s = np.cos(0.3), np.sin(0.3)
    rot = T.map_stretch_patches((c * j - s * i).astype(np.float32), (s * j + c * i).astype(np.float32), valid, ones,
                                ones, 1.0)
    np.testing.assert_allclose(rot, 1.0, rtol=1e-5)
