"""Reprojection kernels against slow references and hand-made camera cases."""
import numpy as np
import pytest

from proxyshade.io.usd import CameraInfo
from proxyshade.kernels import reproject as K
from proxyshade.kernels.lookup import lookup


NO_CHECK = np.zeros((0, 0), np.uint32)  # fill_from_neighbours without the source-label check

def cam(width=24, height=20, f=30.0, pos=(0.0, 0.0, 0.0), yaw=0.0, pitch=0.0, cx=None, cy=None):
    c, s = np.cos(yaw), np.sin(yaw)
    Ry = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    c, s = np.cos(pitch), np.sin(pitch)
    Rx = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    M = np.eye(4)
    M[:3, :3] = Ry @ Rx
    M[:3, 3] = pos
    return CameraInfo("/cam", 1, width=width, height=height, fx=f, fy=f, cx=width / 2 if cx is None else cx,
                      cy=height / 2 if cy is None else cy, near=0.1, far=1000.0, camera_to_world=M)


def random_cams(rng):
    a = cam(pos=rng.normal(size=3) * 0.3, yaw=rng.normal() * 0.1, pitch=rng.normal() * 0.1)
    b = cam(pos=rng.normal(size=3) * 0.3, yaw=rng.normal() * 0.1, pitch=rng.normal() * 0.1, f=33.0)
    return a, b


# -- transfer ---------------------------------------------------------------
def test_transfer_matches_camera_project_unproject():
    rng = np.random.default_rng(0)
    for _ in range(3):
        c0, c1 = random_cams(rng)
        Z = rng.uniform(5, 50, (c0.height, c0.width))
        Z[0, :5] = np.inf  # sky: a direction
        col, row = c0.pixel_grid()
        w = K.inverse_depth(Z)
        u, v, q, ok = K.transfer(w, K.relative_matrix(c0, c1), K.intrinsics(c0), K.intrinsics(c1), c1.near)
        Zf = np.where(np.isinf(Z), 1e9, Z)
        eu, ev, ed = c1.project(c0.unproject(col, row, Zf))
        assert ok.all()
        np.testing.assert_allclose(u, eu, atol=1e-5)
        np.testing.assert_allclose(v, ev, atol=1e-5)
        np.testing.assert_allclose(q, np.where(np.isinf(Z), 0, 1 / ed), rtol=1e-9, atol=1e-12)


def test_transfer_identity_and_behind_camera():
    c0 = cam()
    Z = np.full((c0.height, c0.width), 10.0)
    u, v, q, ok = K.transfer(K.inverse_depth(Z), np.eye(4), K.intrinsics(c0), K.intrinsics(c0), 0.1)
    col, row = c0.pixel_grid()
    np.testing.assert_allclose(u, col, atol=1e-12)
    np.testing.assert_allclose(v, row, atol=1e-12)
    c1 = cam(yaw=np.pi)  # looking the other way: everything behind
    _, _, _, ok = K.transfer(K.inverse_depth(Z), K.relative_matrix(c0, c1), K.intrinsics(c0), K.intrinsics(c1), 0.1)
    assert not ok.any()



def test_transfer_is_xfer_at_every_pixel_bit_for_bit():
    rng = np.random.default_rng(3)
    c0, c1 = random_cams(rng)
    w = K.inverse_depth(rng.uniform(0.05, 60, (c0.height, c0.width)))
    w[0, :4] = 0.0  # sky
    w[1, 1] = np.nan
    w[2, 2] = 100.0  # in front of the near plane of camera 1
    M, k0, k1 = K.relative_matrix(c0, c1), K.intrinsics(c0), K.intrinsics(c1)
    u, v, q, ok = K.transfer(w, M, k0, k1, c1.near)
    assert not ok.all() and ok.any()
    for i in range(c0.height):
        for j in range(c0.width):
            want = K._xfer(j + 0.5, i + 0.5, w[i, j], M, k0, k1, c1.near) if np.isfinite(w[i, j]) else (0, 0, 0, False)
            assert (u[i, j], v[i, j], q[i, j], ok[i, j]) == want

# -- the grid -----------------------------------------------------------------
def corners_reference(w, lab, tol):
    h, wd = w.shape

    def con(i, j, a, b):
        if not (0 <= a < h and 0 <= b < wd) or not np.isfinite(w[a, b]) or lab[a, b] != lab[i, j]:
            return False
        return abs(w[i, j] - w[a, b]) <= tol * max(w[i, j], w[a, b])

    gx = np.zeros((h, wd))
    gy = np.zeros((h, wd))
    for i in range(h):
        for j in range(wd):
            if not np.isfinite(w[i, j]):
                continue
            l, r = con(i, j, i, j - 1), con(i, j, i, j + 1)
            gx[i, j] = (w[i, j + 1] - w[i, j - 1]) / 2 if l and r else (w[i, j] - w[i, j - 1] if l else (
                w[i, j + 1] - w[i, j] if r else 0.0))
            t, b = con(i, j, i - 1, j), con(i, j, i + 1, j)
            gy[i, j] = (w[i + 1, j] - w[i - 1, j]) / 2 if t and b else (w[i, j] - w[i - 1, j] if t else (
                w[i + 1, j] - w[i, j] if b else 0.0))
    out = np.full((h, wd, 4), np.nan)
    for i in range(h):
        for j in range(wd):
            if not np.isfinite(w[i, j]):
                continue
            for k, (dy, dx) in enumerate(((-1, -1), (-1, 1), (1, -1), (1, 1))):
                cy, cx = i + 0.5 + dy / 2, j + 0.5 + dx / 2
                vals = [w[a, b] + (cx - b - 0.5) * gx[a, b] + (cy - a - 0.5) * gy[a, b]
                        for a, b in ((i, j), (i, j + dx), (i + dy, j), (i + dy, j + dx))
                        if (a, b) == (i, j) or con(i, j, a, b)]
                out[i, j, k] = max(0.0, float(np.mean(vals)))
    return out


def test_grid_corners_match_reference():
    rng = np.random.default_rng(1)
    w = rng.uniform(0.1, 0.12, (9, 11))
    w[2:5, 3:6] = 0.3  # a depth jump
    w[7, 1] = np.nan
    lab = np.ones((9, 11), np.uint32)
    lab[:, 8:] = 2
    got = K.grid_corners(w, lab, 0.1)
    np.testing.assert_allclose(got, corners_reference(w, lab, 0.1), rtol=1e-12, equal_nan=True)


def test_grid_corners_exact_on_a_plane_and_shared():
    i, j = np.mgrid[0:8, 0:10].astype(np.float64)
    w = 0.1 + 0.003 * (j + 0.5) - 0.002 * (i + 0.5)  # inverse depth of a plane is affine on screen
    got = K.grid_corners(w, np.ones((8, 10), np.uint32), 0.5)
    for k, (dy, dx) in enumerate(((0, 0), (0, 1), (1, 0), (1, 1))):
        np.testing.assert_allclose(got[..., k], 0.1 + 0.003 * (j + dx) - 0.002 * (i + dy), atol=1e-14)
    np.testing.assert_array_equal(got[:, :-1, 1], got[:, 1:, 0])  # neighbours share corners exactly
    np.testing.assert_array_equal(got[:-1, :, 2], got[1:, :, 0])


def splat_reference(cw, keep, M, k0, k1, near, h, w):
    zb = np.full((h, w), -1.0)
    src = np.full((h, w), -1, np.int64)
    h0, w0 = keep.shape
    for i in range(h0):
        for j in range(w0):
            if not keep[i, j]:
                continue
            P = []
            for k in range(4):
                col, row = j + k % 2, i + k // 2
                a, b, c, ok = K._xfer(float(col), float(row), cw[i, j, k], M, k0, k1, near)
                if not ok:
                    break
                P.append((a, b, c))
            if len(P) < 4:
                continue
            P = np.array(P)
            for r in range(h):
                for c in range(w):
                    for tri in ((0, 1, 3), (0, 3, 2)):
                        A, B, C = P[list(tri)]
                        area = (B[0] - A[0]) * (C[1] - A[1]) - (B[1] - A[1]) * (C[0] - A[0])
                        if area == 0:
                            continue
                        px, py = c + 0.5, r + 0.5
                        l0 = ((C[0] - B[0]) * (py - B[1]) - (C[1] - B[1]) * (px - B[0])) / area
                        l1 = ((A[0] - C[0]) * (py - C[1]) - (A[1] - C[1]) * (px - C[0])) / area
                        l2 = ((B[0] - A[0]) * (py - A[1]) - (B[1] - A[1]) * (px - A[0])) / area
                        if min(l0, l1, l2) < 0:
                            continue
                        q = l0 * A[2] + l1 * B[2] + l2 * C[2]
                        if q > zb[r, c]:
                            zb[r, c] = q
                            src[r, c] = i * w0 + j
                        break
    return zb, src


def test_splat_matches_reference():
    rng = np.random.default_rng(2)
    c0, c1 = random_cams(rng)
    c0 = cam(12, 10, 15.0)
    c1 = cam(13, 11, 16.0, pos=(0.4, 0.1, -0.3), yaw=0.05)
    Z = rng.uniform(8, 12, (10, 12))
    Z[3:6, 4:8] = 4.0
    lab = np.ones((10, 12), np.uint32)
    w = K.inverse_depth(Z)
    cw = K.grid_corners(w, lab, 0.1)
    keep = rng.random((10, 12)) > 0.1
    args = (cw, keep, K.relative_matrix(c0, c1), K.intrinsics(c0), K.intrinsics(c1), 0.1, 11, 13)
    zb, src = K.splat_grid(*args, 64.0)
    rz, rs = splat_reference(*args)
    np.testing.assert_array_equal(src, rs)
    np.testing.assert_allclose(zb, rz, rtol=1e-12)


def test_splat_identity_covers_each_pixel_with_itself_and_translation_shifts():
    c0 = cam(16, 12, 20.0)
    Z = np.full((12, 16), 10.0)
    w = K.inverse_depth(Z)
    cw = K.grid_corners(w, np.ones((12, 16), np.uint32), 0.1)
    keep = np.ones((12, 16), bool)
    zb, src = K.splat_grid(cw, keep, np.eye(4), K.intrinsics(c0), K.intrinsics(c0), 0.1, 12, 16, 64.0)
    np.testing.assert_array_equal(src, np.arange(12 * 16).reshape(12, 16))
    np.testing.assert_allclose(zb, 0.1)
    c1 = cam(16, 12, 20.0, pos=(1.0, 0.0, 0.0))  # 1 unit at depth 10 with f = 20: 2 pixels
    zb, src = K.splat_grid(cw, keep, K.relative_matrix(c0, c1), K.intrinsics(c0), K.intrinsics(c1), 0.1, 12, 16, 64.)
    np.testing.assert_array_equal(src[:, :14], np.arange(12 * 16).reshape(12, 16)[:, 2:])
    assert (src[:, 14:] == -1).all()


def test_splat_thread_independent():
    import numba

    rng = np.random.default_rng(5)
    c0 = cam(40, 36, 40.0)
    c1 = cam(40, 36, 42.0, pos=(0.5, 0.2, 0.3), yaw=0.04)
    Z = rng.uniform(5, 6, (36, 40))
    cw = K.grid_corners(K.inverse_depth(Z), np.ones((36, 40), np.uint32), 0.05)
    args = (cw, np.ones((36, 40), bool), K.relative_matrix(c0, c1), K.intrinsics(c0), K.intrinsics(c1), 0.1, 36, 40,
            64.0)
    a = K.splat_grid(*args)
    n = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        b = K.splat_grid(*args)
    finally:
        numba.set_num_threads(n)
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])


def test_stale_winners():
    # frame-0 pixel 0 lay on the proxy and is drawn at (0, 0), in front of the proxy there; a proxy pixel
    # as near in its 3x3 window (a silhouette one pixel off) keeps it
    on = np.array([[True, True]])
    wg = np.array([[0.5, 0.1, 0.1]])
    src = np.array([[0, -1, 1]])
    wp1 = np.array([[0.1, 0.5, 0.1]])
    got = K.stale_winners(wg, src, wp1, on, np.ones((1, 2), bool), 0.25, 1)
    assert not got.any()
    got = K.stale_winners(wg, src, wp1, on, np.ones((1, 2), bool), 0.25, 0)
    np.testing.assert_array_equal(got, [[True, False]])
    wp1 = np.array([[0.1, 0.1, 0.1]])
    wg = np.array([[0.5, 0.1, 0.1]])
    src = np.array([[0, -1, 1]])
    got = K.stale_winners(wg, src, wp1, on, np.ones((1, 2), bool), 0.25)
    np.testing.assert_array_equal(got, [[True, False]])
    got = K.stale_winners(wg, src, wp1, np.array([[False, True]]), np.ones((1, 2), bool), 0.25)
    assert not got.any()  # off the proxy at frame 0 (an extension of the guide): kept


# -- gathering the previous frame ----------------------------------------------
def gather_reference(u, v, q, ok, lab, pw, plab, ppatch, psx, psy, pres, pd, tol, scale):
    h, w = u.shape
    hp, wp = pw.shape
    out = {k: np.zeros((h, w)) for k in ("sx", "sy", "patch", "d")}
    out["valid"] = np.zeros((h, w), bool)
    out["res"] = np.zeros((h, w, 3))

    def same(a, b):
        return abs(a - b) <= tol * max(a, b)

    for i in range(h):
        for j in range(w):
            x, y = u[i, j], v[i, j]
            if not ok[i, j] or not (0 <= x < wp and 0 <= y < hp):
                continue
            rn, cn = int(y), int(x)
            if plab[rn, cn] != lab[i, j] or not same(q[i, j], pw[rn, cn]):
                continue
            out["valid"][i, j] = True
            out["patch"][i, j] = ppatch[rn, cn]
            c0, r0 = int(np.floor(x - 0.5)), int(np.floor(y - 0.5))
            ax, ay = x - 0.5 - c0, y - 0.5 - r0
            taps = []
            for dr in (0, 1):
                for dc in (0, 1):
                    rr, cc = min(max(r0 + dr, 0), hp - 1), min(max(c0 + dc, 0), wp - 1)
                    wt = (ay if dr else 1 - ay) * (ax if dc else 1 - ax)
                    taps.append((rr, cc, wt, plab[rr, cc] == lab[i, j] and same(q[i, j], pw[rr, cc])))
            good = [t for t in taps if t[3]]
            if len(good) == 4 and all(ppatch[r, c] == ppatch[rn, cn] for r, c, _, _ in good):
                out["sx"][i, j] = sum(wt * psx[r, c] for r, c, wt, _ in good)
                out["sy"][i, j] = sum(wt * psy[r, c] for r, c, wt, _ in good)
            else:
                out["sx"][i, j] = psx[rn, cn] + (x - cn - 0.5) * scale
                out["sy"][i, j] = psy[rn, cn] + (y - rn - 0.5) * scale
            mine = [t for t in good if ppatch[t[0], t[1]] == ppatch[rn, cn]]  # not across a seam
            W = sum(t[2] for t in mine)
            if W > 0:
                out["res"][i, j] = sum(wt * pres[r, c] for r, c, wt, _ in mine) / W
                out["d"][i, j] = sum(wt * pd[r, c] for r, c, wt, _ in mine) / W
            else:
                out["res"][i, j], out["d"][i, j] = pres[rn, cn], pd[rn, cn]
    return out


def test_gather_prev_matches_reference():
    rng = np.random.default_rng(4)
    h, w = 9, 10
    u = rng.uniform(-1, w + 1, (h, w))
    v = rng.uniform(-1, h + 1, (h, w))
    q = rng.choice([0.1, 0.2], (h, w))
    ok = rng.random((h, w)) > 0.1
    lab = rng.integers(1, 3, (h, w)).astype(np.uint32)
    pw = rng.choice([0.1, 0.2, 0.101], (h, w))
    plab = rng.integers(1, 3, (h, w)).astype(np.uint32)
    ppatch = rng.integers(1, 3, (h, w)).astype(np.uint32)
    psx, psy = (rng.random((h, w)).astype(np.float32) * 50 for _ in range(2))
    pres = rng.random((h, w, 3)).astype(np.float32)
    pd = rng.random((h, w)).astype(np.float32)
    got = K.gather_prev(u, v, q, ok, lab=lab, prev_w=pw, prev_lab=plab, prev_patch=ppatch, prev_sx=psx, prev_sy=psy,
                        prev_res=pres, prev_d=pd, tol=0.02, scale=0.5)
    ref = gather_reference(u, v, q, ok, lab, pw, plab, ppatch, psx, psy, pres, pd, 0.02, 0.5)
    valid, sx, sy, patch, res, d = got
    assert valid.any() and not valid.all()
    np.testing.assert_array_equal(valid, ref["valid"])
    np.testing.assert_allclose(sx, ref["sx"], rtol=1e-5)
    np.testing.assert_allclose(sy, ref["sy"], rtol=1e-5)
    np.testing.assert_array_equal(patch, ref["patch"])
    np.testing.assert_allclose(res, ref["res"], rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(d, ref["d"], rtol=1e-5, atol=1e-6)


def test_gather_integer_shift_copies_exactly():
    h, w = 8, 12
    i, j = np.mgrid[0:h, 0:w].astype(np.float64)
    u, v = j + 0.5 + 3, i + 0.5  # every pixel lands on the centre of the pixel 3 to the right
    ones = np.ones((h, w), bool)
    lab = np.ones((h, w), np.uint32)
    q = np.full((h, w), 0.1)
    rng = np.random.default_rng(0)
    psx = (j * 1.0).astype(np.float32)
    psy = (i * 1.0).astype(np.float32)
    pres = rng.random((h, w, 3)).astype(np.float32)
    valid, sx, sy, patch, res, d = K.gather_prev(u, v, q, ones, lab=lab, prev_w=q, prev_lab=lab, prev_patch=lab,
                                                 prev_sx=psx, prev_sy=psy, prev_res=pres,
                                                 prev_d=np.zeros((h, w), np.float32), tol=0.02, scale=1.0)
    np.testing.assert_array_equal(valid, j < w - 3)
    np.testing.assert_array_equal(sx[:, :w - 3], psx[:, 3:])
    np.testing.assert_array_equal(res[:, :w - 3], pres[:, 3:])


# -- det J and filling ---------------------------------------------------------
def test_surface_jacobian_matches_plain_jacobian_on_one_surface_and_stops_at_silhouettes():
    from proxyshade.kernels.temporal import jacobian_det

    rng = np.random.default_rng(6)
    u, v = rng.random((2, 10, 12)) * 20
    valid = rng.random((10, 12)) > 0.2
    w = np.full((10, 12), 0.1)
    lab = np.ones((10, 12), np.uint32)
    np.testing.assert_allclose(K.surface_jacobian_det(u, v, w, lab, valid, 0.02), jacobian_det(u, v, valid))
    # a silhouette: the right half is a nearer surface; differences never cross it
    w[:, 6:] = 0.2
    valid[:] = True
    got = K.surface_jacobian_det(u, v, w, lab, valid, 0.02)
    left = jacobian_det(u[:, :6].copy(), v[:, :6].copy(), valid[:, :6].copy())
    np.testing.assert_allclose(got[:, :6], left)


def test_fill_from_neighbours_continues_the_patch():
    h, w = 7, 9
    need = np.zeros((h, w), bool)
    need[3, 4] = True
    have = ~need
    have[3, 3] = False  # the nearest in scan order of ring 1 is (2, 3)
    lab = np.ones((h, w), np.uint32)
    i, j = np.mgrid[0:h, 0:w].astype(np.float32)
    sx, sy = j * 2 + 5, i * 2 + 1  # scale 2
    patch = np.arange(h * w, dtype=np.uint32).reshape(h, w)
    res = np.zeros((h, w, 3), np.float32)
    d = np.zeros((h, w), np.float32)
    osx, osy, op, _, _, filled = K.fill_from_neighbours(need, have, lab, K.Carried(sx, sy, patch, res, d), 2, 2.0, NO_CHECK)
    assert filled[3, 4] and filled.sum() == 1
    assert (osx[3, 4], osy[3, 4]) == (sx[3, 4], sy[3, 4])  # a translation continued exactly
    assert op[3, 4] == patch[2, 3]
    lab[:, :] = 2
    lab[3, 4] = 1  # no neighbour of its label: not filled
    *_, filled = K.fill_from_neighbours(need, have, lab, K.Carried(sx, sy, patch, res, d), 2, 2.0, NO_CHECK)
    assert not filled.any()


def _fill_reference(need, have, lab, sx, sy, radius, scale, src_lab):
    """Plain Python: the first pixel of ``have`` with the label, ring by ring in scan order,
    whose continued position lies in the source on that label; (sx, sy, from) or None."""
    h, w = need.shape
    out = {}
    for i, j in zip(*np.nonzero(need)):
        for r in range(1, radius + 1):
            ring = [(a, b) for a in range(i - r, i + r + 1) for b in range(j - r, j + r + 1)
                    if max(abs(a - i), abs(b - j)) == r and 0 <= a < h and 0 <= b < w]
            hit = None
            for a, b in ring:
                if not have[a, b] or lab[a, b] != lab[i, j]:
                    continue
                x, y = np.float32(sx[a, b] + (j - b) * scale), np.float32(sy[a, b] + (i - a) * scale)
                xi, yi = int(np.floor(x + 0.5)), int(np.floor(y + 0.5))
                if 0 <= x <= src_lab.shape[1] - 1 and 0 <= y <= src_lab.shape[0] - 1 and src_lab[yi, xi] == lab[i, j]:
                    hit = (x, y, (a, b))
                    break
            if hit:
                out[(i, j)] = hit
                break
    return out


def test_fill_from_neighbours_with_source_labels_takes_the_next_neighbour_landing_on_the_label():
    """With the source's labels, a neighbour whose continued position lands on a source pixel
    of another label (or outside the source) is passed over for the next one in ring order
    whose lands on the pixel's label; none: not filled. Against a plain-Python search."""
    rng = np.random.default_rng(5)
    h, w = 24, 20
    lab = rng.integers(1, 3, (h, w)).astype(np.uint32)
    need = rng.random((h, w)) < 0.3
    have = ~need & (rng.random((h, w)) < 0.8)
    sx = (rng.random((h, w)) * 40 - 2).astype(np.float32)
    sy = (rng.random((h, w)) * 30 - 2).astype(np.float32)
    patch = np.arange(h * w, dtype=np.uint32).reshape(h, w)
    res = rng.random((h, w, 3)).astype(np.float32)
    d = rng.random((h, w)).astype(np.float32)
    src_lab = rng.integers(1, 4, (30, 40)).astype(np.uint32)
    osx, osy, op, ores, od, filled = K.fill_from_neighbours(need, have, lab, K.Carried(sx, sy, patch, res, d), 3, 1.5, src_lab)
    want = _fill_reference(need, have, lab, sx, sy, 3, 1.5, src_lab)
    assert 20 < len(want) < need.sum()  # some pixels pass their nearest neighbour over, some find none
    assert set(zip(*np.nonzero(filled))) == set(want)
    for (i, j), (x, y, (a, b)) in want.items():
        assert (osx[i, j], osy[i, j], op[i, j], od[i, j]) == (x, y, patch[a, b], d[a, b])
        np.testing.assert_array_equal(ores[i, j], res[a, b])
    plain = K.fill_from_neighbours(need, have, lab, K.Carried(sx, sy, patch, res, d), 3, 1.5, NO_CHECK)
    assert plain[-1].sum() > filled.sum()  # without the check the nearest is taken wherever it lands


def test_unproject_inverts_transfer_geometry():
    c0 = cam(pos=(1.0, 2.0, 3.0), yaw=0.3, pitch=-0.2)
    Z = np.random.default_rng(7).uniform(2, 9, (c0.height, c0.width)).astype(np.float32)
    Z[0, 0] = np.inf
    got = K.unproject(Z, np.ascontiguousarray(c0.camera_to_world), K.intrinsics(c0))
    col, row = c0.pixel_grid()
    ref = c0.unproject(col, row, np.where(np.isinf(Z), 1.0, Z).astype(np.float64))
    np.testing.assert_allclose(got[1:], ref[1:], rtol=1e-5, atol=1e-5)
    assert (got[0, 0] == 0).all()


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_inverse_depth_is_the_reciprocal_with_inf_as_zero(dtype):
    rng = np.random.default_rng(4)
    Z = rng.uniform(0.01, 100, (9, 11)).astype(dtype)
    Z[0, :3] = [np.inf, -np.inf, np.nan]
    Z[1, 0] = 0.0
    with np.errstate(divide="ignore"):
        want = np.where(np.isinf(Z.astype(np.float64)), 0.0, 1.0 / Z.astype(np.float64))
    got = K.inverse_depth(Z)
    assert got.dtype == np.float64
    assert np.array_equal(got, want, equal_nan=True)
    assert np.array_equal(K.inverse_depth(Z[0]), want[0], equal_nan=True)  # 1-D: numpy


# -- classify (ConsistentDepth's pixel kinds) ----------------------------------
def test_classify_matches_numpy_reference():
    """Each pixel's kind, label, depth and world position, against the plain array
    expressions of §6.1's four cases."""
    rng = np.random.default_rng(3)
    h, w, h0, w0 = 13, 17, 9, 11
    src = rng.integers(-1, h0 * w0, (h, w)).astype(np.int64)
    wg = np.where(src >= 0, rng.uniform(0.01, 2.0, (h, w)), -1.0)
    wg[0, :3] = 0.0  # drawn at infinity
    wp1 = rng.uniform(0.0, 2.0, (h, w))
    stale = rng.random((h0, w0)) < 0.2
    occ0 = rng.random((h0, w0)) < 0.5
    lab0 = rng.integers(1, 5, (h0, w0)).astype(np.uint32)
    plab = rng.integers(1, 5, (h, w)).astype(np.uint32)
    pZ = rng.uniform(1, 9, (h, w)).astype(np.float32)
    pP = [rng.normal(size=(h, w)).astype(np.float32) for _ in range(3)]
    c = cam(width=w, height=h, pos=(0.1, 0.2, 0.3), yaw=0.2)
    k = K.intrinsics(c)
    C = np.ascontiguousarray(c.camera_to_world, np.float64)
    tol = 0.1
    cat, lab, Z, X, Y, W, gone = K.classify(src=src, wg=wg, wp1=wp1, stale=stale, occluded0=occ0, lab0=lab0,
                                            plab=plab, pZ=pZ, pX=pP[0], pY=pP[1], pZw=pP[2], C=C, k=k, tol=tol)

    drawn = src >= 0
    s = np.where(drawn, src, 0)
    dropped = drawn & stale.ravel()[s]
    covered = drawn & ~dropped
    behind = covered & (wp1 > wg * (1.0 + tol))
    want = np.full((h, w), 4)
    want[covered & ~behind] = 1
    want[behind & occ0.ravel()[s]] = 2
    want[behind & ~occ0.ravel()[s]] = 3
    grid = want <= 2
    with np.errstate(divide="ignore"):
        zg = np.where(wg > 0, 1.0 / np.where(wg > 0, wg, 1.0), np.inf)
    wantZ = np.where(grid, zg, pZ).astype(np.float32)
    P = K.unproject(np.where(grid, wantZ, np.inf).astype(np.float32), C, k)
    assert np.array_equal(cat, want)
    assert np.array_equal(lab, np.where(grid, lab0.ravel()[s], plab))
    assert np.array_equal(Z, wantZ)
    for m, got in enumerate((X, Y, W)):
        assert np.array_equal(got, np.where(grid & np.isfinite(wantZ), P[..., m], pP[m]))
    assert gone.sum() == dropped.sum()


# -- seams anchored to the first frame -------------------------------------------
def _pan(frames, anchor, step=0.3):
    """Two patches (a seam at column 10 of the first frame), carried ``frames`` times by a
    pan of ``step`` pixels a frame (the sky under a slow rotation). Returns the last
    frame's patch ids and source x, and where the first frame's seam now lies on screen."""
    h, w = 4, 24
    i, j = np.mgrid[0:h, 0:w].astype(np.float64)
    lab = np.ones((h, w), np.uint32)
    q = np.zeros((h, w))
    ones = np.ones((h, w), bool)
    fpatch = np.where(j < 10, 1, 2).astype(np.uint32)
    fsx = np.where(j < 10, j + 100, j + 300).astype(np.float32)  # two translations
    fsy = i.astype(np.float32)
    patch, sx, sy = fpatch, fsx, fsy
    z = np.zeros((h, w), np.float32)
    for k in range(1, frames + 1):
        u, v = j + 0.5 + step, i + 0.5  # into the previous frame
        valid, nsx, nsy, npatch, res, d = K.gather_prev(u, v, q, ones, lab=lab, prev_w=q, prev_lab=lab,
                                                        prev_patch=patch, prev_sx=sx, prev_sy=sy,
                                                        prev_res=np.zeros((h, w, 3), np.float32), prev_d=z,
                                                        tol=0.02, scale=1.0)
        if anchor:
            fok, fp, fx, fy = K.first_positions(j + 0.5 + step * k, v, q, ones, lab=lab, first_w=q, first_lab=lab,
                                                first_patch=fpatch, first_sx=fsx, first_sy=fsy, tol=0.02, scale=1.0)
            K.anchor_seams(K.Landing(u, v, q, ones), valid, lab, K.PrevState(q, lab, patch, sx, sy, z, z, z, z),
                           K.FirstPositions(fok, fp, fx, fy), 0.02, 1.0, 0.01, K.Carried(nsx, nsy, npatch, res, d))
        patch, sx, sy = npatch, nsx, nsy
    return patch, sx, 10 - step * frames


def test_anchored_seams_follow_the_surface_under_a_subpixel_pan():
    """A pan of 0.3 px a frame: rounded anew from the previous frame each frame, the seam
    stays on its screen column while the texture slides under it (3 px off after 10
    frames); anchored to the first frame it moves with the texture, within half a pixel,
    and every pixel still reads its patch's own translation."""
    for anchor in (False, True):
        patch, sx, seam = _pan(10, anchor)
        edge = int(np.argmax(patch[0] == 2))  # first column of the right patch
        j = np.arange(patch.shape[1])
        if anchor:
            assert abs(edge - seam) <= 0.5
        else:
            assert edge == 10 and abs(edge - seam) >= 2.9  # the old behaviour this replaces
        expect = np.where(patch[0] == 1, j + 100, j + 300) + 0.3 * 10
        valid = j < patch.shape[1] - 8  # beyond: the border the pan uncovers (clamped taps)
        np.testing.assert_allclose(sx[0][valid], expect[valid], atol=1e-3)


def test_anchor_leaves_pixels_whose_first_patch_is_gone():
    """A pixel whose first-frame patch no longer has its translation in the previous frame
    (re-anchored, resynthesized) keeps gather_prev's nearest choice."""
    h, w = 3, 12
    i, j = np.mgrid[0:h, 0:w].astype(np.float64)
    lab = np.ones((h, w), np.uint32)
    q = np.zeros((h, w))
    ones = np.ones((h, w), bool)
    z = np.zeros((h, w), np.float32)
    prev_patch = np.where(j < 7, 1, 2).astype(np.uint32)
    prev_sx = np.where(j < 7, j + 100, j + 300).astype(np.float32)
    u, v = j + 0.5 + 0.3, i + 0.5
    valid, sx, sy, patch, res, d = K.gather_prev(u, v, q, ones, lab=lab, prev_w=q, prev_lab=lab,
                                                 prev_patch=prev_patch, prev_sx=prev_sx, prev_sy=i.astype(np.float32),
                                                 prev_res=np.zeros((h, w, 3), np.float32), prev_d=z, tol=0.02,
                                                 scale=1.0)
    before = (patch.copy(), sx.copy())
    fpatch = np.where(j < 6, 1, 2).astype(np.uint32)
    fsx = np.where(j < 6, j + 100, j + 500).astype(np.float32)  # patch 2 had another translation then
    fok, fp, fx, fy = K.first_positions(u, v, q, ones, lab=lab, first_w=q, first_lab=lab, first_patch=fpatch,
                                        first_sx=fsx, first_sy=i.astype(np.float32), tol=0.02, scale=1.0)
    K.anchor_seams(K.Landing(u, v, q, ones), valid, lab, K.PrevState(q, lab, prev_patch, prev_sx, i.astype(np.float32),
                                                                     z, z, z, z),
                   K.FirstPositions(fok, fp, fx, fy), 0.02, 1.0, 0.01, K.Carried(sx, sy, patch, res, d))
    np.testing.assert_array_equal(patch, before[0])
    np.testing.assert_array_equal(sx, before[1])


def _uniform_ref(patch, lab, before, after):
    h, w = patch.shape
    out = np.zeros((h, w), bool)
    for r in range(h):
        for c in range(w):
            if r - before < 0 or c - before < 0 or r + after >= h or c + after >= w:
                continue
            win = (slice(r - before, r + after + 1), slice(c - before, c + after + 1))
            out[r, c] = bool(np.all(patch[win] == patch[r, c]) and np.all(lab[win] == lab[r, c]))
    return out


def test_uniform_windows_match_reference():
    rng = np.random.default_rng(3)
    for _ in range(5):
        # blocky patches (ids from a coarse grid) and a few labels, so some windows are uniform
        patch = np.repeat(np.repeat(rng.integers(0, 4, (5, 6)), 9, 0), 7, 1).astype(np.uint32)[:40, :37]
        lab = (rng.random(patch.shape) < 0.01).astype(np.uint32)
        got = K.uniform_windows(patch, lab, 3, 4)
        ref = _uniform_ref(patch, lab, 3, 4)
        assert ref.any() and not ref.all()
        np.testing.assert_array_equal(got, ref)


@pytest.mark.parametrize("name", ["FLAT4", "FLAT2"])
def test_sharpen_residual_matches_plain_flat_read_inside_patches(name):
    from proxyshade.kernels import lookup as lk

    table = getattr(lk, name)
    a = table.shape[1] // 2

    rng = np.random.default_rng(5)
    hp, wp = 30, 34
    patch = np.ones((hp, wp), np.uint32)
    patch[:, 20:] = 2  # a seam at column 20
    lab = np.zeros((hp, wp), np.uint32)
    stack = rng.normal(size=(hp, wp, 3)).astype(np.float32)
    h, w = 12, 15
    u = rng.uniform(0, wp, (h, w))
    v = rng.uniform(0, hp, (h, w))
    u[0, 0], v[0, 0] = 10.5, 12.5  # exactly on a pixel centre: that pixel's value
    valid = rng.random((h, w)) < 0.9
    valid[0, 0] = True
    res = np.full((h, w, 3), -7.0, np.float32)
    uni = K.uniform_windows(patch, lab, a - 1, a)
    K.sharpen_residual((u, v, np.zeros((h, w)), np.ones((h, w), bool)), valid, uni, stack, table, res)
    done = 0
    for i in range(h):
        for j in range(w):
            x, y = u[i, j] - 0.5, v[i, j] - 0.5
            c0, r0 = int(np.floor(x)), int(np.floor(y))
            inside = a - 1 <= c0 < wp - a and a - 1 <= r0 < hp - a
            if not (valid[i, j] and inside and np.all(patch[r0 - a + 1:r0 + a + 1, c0 - a + 1:c0 + a + 1]
                                                       == patch[r0, c0])):
                assert np.all(res[i, j] == -7.0)  # left as gathered
                continue
            # plain reference: separable per-phase weights, then the 4x4 pixels' range
            wx = table[int(np.floor((x - c0) * (len(table) - 1) + 0.5))]
            wy = table[int(np.floor((y - r0) * (len(table) - 1) + 0.5))]
            win = stack[r0 - a + 1:r0 + a + 1, c0 - a + 1:c0 + a + 1].astype(np.float64)
            val = np.einsum("r,t,rtk->k", wy, wx, win)
            box = stack[r0 - 1:r0 + 3, c0 - 1:c0 + 3].reshape(-1, 3)
            val = np.clip(val, box.min(0), box.max(0))
            np.testing.assert_allclose(res[i, j], val, rtol=0, atol=1e-5)
            done += 1
    assert done > 20
    np.testing.assert_array_equal(res[0, 0], stack[12, 10])
    # a read just left of the seam would take taps across it: left bilinear (untouched here)
    res2 = np.full((1, 1, 3), -7.0, np.float32)
    K.sharpen_residual((np.array([[18.5]]), np.array([[15.5]]), np.zeros((1, 1)), np.ones((1, 1), bool)),
                       np.ones((1, 1), bool), uni, stack, table, res2)
    assert np.all(res2 == -7.0)


@pytest.mark.parametrize("name", ["flat2", "flat4"])
def test_gather_with_sharp_leaves_to_sharpen_only_the_pixels_it_reads_again(name):
    """gather_prev_planes with ``sharp`` (the uniform windows of the sharpen_residual that
    follows) skips the bilinear residual where sharpen_residual writes it: after the sharpen,
    every output is the one of a gather without ``sharp``, bit for bit."""
    from proxyshade.kernels.lookup import FLAT2, FLAT4

    table = FLAT4 if name == "flat4" else FLAT2
    a = table.shape[1] // 2
    rng = np.random.default_rng(11)
    h, w = 24, 26
    # patches of a few pixels' blocks, two labels: some taps inside one patch, some across
    patch = (np.arange(h)[:, None] // 9 * 4 + np.arange(w)[None, :] // 11 + 1).astype(np.uint32)
    lab = np.where(np.arange(w)[None, :] < 20, 1, 2).astype(np.uint32) * np.ones((h, 1), np.uint32)
    u = (np.arange(w)[None, :] + 0.5 + rng.uniform(-1.5, 1.5, (h, w)))
    v = (np.arange(h)[:, None] + 0.5 + rng.uniform(-1.5, 1.5, (h, w)))
    q = np.full((h, w), 0.1)
    ok = rng.random((h, w)) > 0.05
    planes = [rng.random((h, w)).astype(np.float32) for _ in range(3)]
    prev = (q, lab, patch, rng.random((h, w)).astype(np.float32) * 30, rng.random((h, w)).astype(np.float32) * 30,
            *planes, rng.random((h, w)).astype(np.float32))
    land = (u, v, q, ok)
    uni = K.uniform_windows(patch, lab, a - 1, a)
    none = np.zeros((0, 0), np.bool_)
    outs = []
    for sharp in (none, uni):
        valid, sx, sy, pat, res, d = K.gather_prev_planes(land, lab, prev, 0.02, 0.5, sharp, a)
        K.sharpen_residual(land, valid, uni, np.stack(planes, -1), table, res)
        outs.append((valid, sx, sy, pat, res, d))
    assert uni.any() and outs[0][0].any()
    for x, y in zip(*outs):
        assert np.array_equal(x, y)
