"""kernels/btf against slow, obvious references: eq. 3 (single and pair form), the
sequential confidence-weighted synthesis, the alignment measure and rectification."""
import math

import numba
import numpy as np
import pytest

from proxyshade.kernels import btf as K
from proxyshade.kernels.random import rand


@pytest.fixture
def rng():
    return np.random.default_rng(7)


def _img(rng, h, w):
    return rng.random((h, w, 3)).astype(np.float32)


def naive_disk(r):
    return {(dy, dx) for dy in range(-r, r + 1) for dx in range(-r, r + 1) if 0 < dy * dy + dx * dx <= r * r}


def naive_distance(out, k, T, inp, p, c, r, so, si=None, pair=None, cw=0.0, wrap=False):
    """Σ over the disk of w‖out − in‖² (+ cw (1 − w)‖A′ − A‖² with ``pair`` = (A′, A));
    input neighbours outside the input cost 1 per channel, output ones outside are skipped
    (with ``wrap``, taken from the opposite border)."""
    si = so if si is None else si
    total = 0.0
    for dy, dx in sorted(naive_disk(r)):
        qy, qx = p[0] + dy * so, p[1] + dx * so
        iy, ix = c[0] + dy * si, c[1] + dx * si
        if wrap:
            qy, qx = qy % out.shape[0], qx % out.shape[1]
        if not (0 <= qy < out.shape[0] and 0 <= qx < out.shape[1]):
            continue
        w = k[qy, qx] / T
        inside = 0 <= iy < inp.shape[0] and 0 <= ix < inp.shape[1]
        db = sum((float(out[qy, qx, ch]) - float(inp[iy, ix, ch])) ** 2 for ch in range(3)) if inside else 3.0
        total += w * db
        if pair is not None:
            Ao, Ai = pair
            da = sum((float(Ao[qy, qx, ch]) - float(Ai[iy, ix, ch])) ** 2 for ch in range(3)) if inside else 3.0
            total += cw * (1 - w) * da
    return total


@pytest.mark.parametrize("r", [1, 2, 3, 4])
def test_disk_offsets_are_the_disk(r):
    offs = K.disk_offsets(r)
    assert {tuple(o) for o in offs} == naive_disk(r) and len(offs) == len(naive_disk(r))


@pytest.mark.parametrize("so,si", [(1, 1), (2, 2), (1, 2)])
def test_disk_distance_matches_eq3(rng, so, si):
    out, inp = _img(rng, 9, 11), _img(rng, 7, 8)
    k = rng.integers(0, 5, (9, 11)).astype(np.int64)
    for _ in range(60):
        p = (int(rng.integers(0, 9)), int(rng.integers(0, 11)))
        c = (int(rng.integers(0, 7)), int(rng.integers(0, 8)))
        for r in (2, 3):
            want = naive_distance(out, k, 4, inp, p, c, r, so, si)
            got = K.disk_distance(out, k, 4, inp, p[0], p[1], c[0], c[1], K.disk(r, so, si), np.inf)
            assert got == pytest.approx(want, rel=1e-12, abs=1e-12)
            # a bound below the distance stops early but still says "worse than the bound"
            if want > 0:
                assert K.disk_distance(out, k, 4, inp, p[0], p[1], c[0], c[1], K.disk(r, so, si),
                                       want * 0.5) > want * 0.5


def test_pair_distance_matches_the_other_view_form(rng):
    ob, ib, oa, ia = _img(rng, 8, 8), _img(rng, 6, 7), _img(rng, 8, 8), _img(rng, 6, 7)
    dq = np.zeros((8, 8), np.int64)
    k = rng.integers(0, 5, (8, 8)).astype(np.int64)
    for _ in range(60):
        p = (int(rng.integers(0, 8)), int(rng.integers(0, 8)))
        c = (int(rng.integers(0, 6)), int(rng.integers(0, 7)))
        want = naive_distance(ob, k, 4, ib, p, c, 2, 1, pair=(oa, ia), cw=0.25)
        got = K.pair_distance(out_b=ob, k=k, T=4, inp_b=ib, sup=K.Support(oa, ia, dq, dq, 0.25, True), py=p[0],
                              px=p[1], cy=c[0], cx=c[1], dk=K.disk(2), bound=np.inf)
        assert got == pytest.approx(want, rel=1e-12, abs=1e-12)


def naive_level(inp, qy, qx, k, T, r, si, seed, level, pair=None, cw=0.0, wrap=False):
    """The sequential loop written plainly: draw a pixel with probability ∝ T − k by walking
    the pixels in order, try the current source, every neighbour's shifted source (and the
    support's, in the pair form), keep the first strictly better one, raise k."""
    qy, qx, k = qy.copy(), qx.copy(), k.copy()
    H, W = qy.shape
    out = inp[qy, qx].copy()
    visits = np.zeros((H, W), np.int64)
    offs = sorted(naive_disk(r))
    step = 0
    while (T - k).sum() > 0:
        total = int((T - k).sum())
        x = int(rand(seed, step, level, 0)) % total
        step += 1
        for p in range(H * W):
            wgt = T - k[p // W, p % W]
            if x < wgt:
                break
            x -= wgt
        py, px = divmod(p, W)
        args = dict(pair=None if pair is None else (pair[0], pair[1]), cw=cw, wrap=wrap)
        best_c = (qy[py, px], qx[py, px])
        best = naive_distance(out, k, T, inp, (py, px), best_c, r, 1, si, **args)
        cands = []
        for dy, dx in offs:
            ny, nx = (py + dy) % H if wrap else py + dy, (px + dx) % W if wrap else px + dx
            if 0 <= ny < H and 0 <= nx < W:
                cands.append((qy[ny, nx] - dy * si, qx[ny, nx] - dx * si))
        if pair is not None:
            qay, qax = pair[2], pair[3]
            for dy, dx in offs:
                ny, nx = (py + dy) % H if wrap else py + dy, (px + dx) % W if wrap else px + dx
                if 0 <= ny < H and 0 <= nx < W:
                    cands.append((qay[ny, nx] - dy * si, qax[ny, nx] - dx * si))
            cands.append((qay[py, px], qax[py, px]))
        cur = best_c
        for c in cands:
            if not (0 <= c[0] < inp.shape[0] and 0 <= c[1] < inp.shape[1]) or c == cur:
                continue
            d = naive_distance(out, k, T, inp, (py, px), c, r, 1, si, **args)
            if d < best:
                best, best_c = d, c
        qy[py, px], qx[py, px] = best_c
        out[py, px] = inp[best_c]
        k[py, px] += 1
        visits[py, px] += 1
    return qy, qx, visits


def _level(inp, qy, qx, k, T, r, si, seed, level, pair=None, cw=0.0, wrap=False):
    qy, qx, k = qy.copy(), qx.copy(), k.copy()
    vis = np.zeros(qy.shape, np.int64)
    out = K.gather(inp, qy, qx)
    sup = K.no_support() if pair is None else K.Support(*pair, cw, True)
    K.synth_level(inp=inp, out=out, qy=qy, qx=qx, k=k, T=T, dk=K.disk(r, 1, si, wrap), seed=seed, level=level, sup=sup,
                  visits=vis)
    assert np.array_equal(out, inp[qy, qx])  # the output is always the input at the sources
    return qy, qx, vis


@pytest.mark.parametrize("r,si,k0,wrap", [(1, 1, 0, False), (2, 1, 0, False), (1, 2, 2, False), (2, 1, 0, True)])
def test_sequential_level_matches_the_plain_loop(rng, r, si, k0, wrap):
    inp = _img(rng, 6, 7)
    inp[..., 1] = inp[..., 0]  # some structure: equal channels make ties likelier
    qy = rng.integers(0, 6, (8, 9)).astype(np.int64)
    qx = rng.integers(0, 7, (8, 9)).astype(np.int64)
    k = np.full((8, 9), k0, np.int64)
    got = _level(inp, qy, qx, k, 4, r, si, 11, 1, wrap=wrap)
    want = naive_level(inp, qy, qx, k, 4, r, si, 11, 1, wrap=wrap)
    for a, b in zip(got, want):
        assert np.array_equal(a, b)
    assert (got[2] == 4 - k0).all()  # every pixel visited exactly T times from w = 0, T − k0 from k0
    assert not np.array_equal(got[0], qy) or not np.array_equal(got[1], qx)  # it did change something


@pytest.mark.parametrize("wrap", [False, True])
def test_other_view_level_matches_the_plain_loop(rng, wrap):
    ia, ib = _img(rng, 6, 7), _img(rng, 6, 7)
    qay = rng.integers(0, 6, (8, 8)).astype(np.int64)
    qax = rng.integers(0, 7, (8, 8)).astype(np.int64)
    oa = K.gather(ia, qay, qax)
    k = np.full((8, 8), 2, np.int64)
    got = _level(ib, qay, qax, k, 4, 2, 1, 5, 0, pair=(oa, ia, qay, qax), cw=0.25, wrap=wrap)
    want = naive_level(ib, qay, qax, k, 4, 2, 1, 5, 0, pair=(oa, ia, qay, qax), cw=0.25, wrap=wrap)
    for a, b in zip(got, want):
        assert np.array_equal(a, b)
    assert (got[2] == 2).all()


def test_other_views_in_parallel_equal_each_view_alone_with_one_or_two_threads(rng):
    ia = _img(rng, 10, 10)
    views = np.stack([_img(rng, 10, 10) for _ in range(3)])
    qay = rng.integers(0, 10, (12, 12)).astype(np.int64)
    qax = rng.integers(0, 10, (12, 12)).astype(np.int64)
    oa = K.gather(ia, qay, qax)
    seeds = np.array([3, 9, 27], np.int64)
    res = []
    for threads in (1, 2):
        numba.set_num_threads(threads)
        qy, qx, vis = (np.zeros((3, 12, 12), np.int64) for _ in range(3))
        per_view = K.Support(np.stack([oa] * 3), ia, np.stack([qay] * 3), np.stack([qax] * 3), 0.25, True)
        K.synth_others(views, per_view, 4, 2, K.disk(2), seeds, qy, qx, vis)
        res.append((qy, qx, vis))
    for a, b in zip(*res):
        assert np.array_equal(a, b)
    for v in range(3):
        alone = _level(views[v], qay, qax, np.full((12, 12), 2, np.int64), 4, 2, 1, seeds[v], 0,
                       pair=(oa, ia, qay, qax), cw=0.25)
        assert np.array_equal(res[0][0][v], alone[0]) and np.array_equal(res[0][1][v], alone[1])
    assert (res[0][2] == 2).all()


def test_edge_distance_is_the_mean_euclidean_distance(rng):
    stack = rng.random((4, 9, 10, 3)).astype(np.float32)
    edges = np.array([[0, 1], [1, 2], [3, 0]], np.int64)
    got = K.edge_distance(stack, edges, 2, 7, 1, 8)
    s = stack.astype(np.float64)[:, 2:7, 1:8]
    want = [np.sqrt(((s[a] - s[b]) ** 2).sum(-1)).mean() for a, b in edges]
    np.testing.assert_allclose(got, want, rtol=1e-12)


def _ray_to_plane(slant, tilt, h_from, h_to, x, z):
    """Follow the view ray through (x, h_from, z) to the plane y = h_to (plain vectors)."""
    s, t = math.radians(slant), math.radians(tilt)
    omega = np.array([math.sin(s) * math.cos(t), math.cos(s), math.sin(s) * math.sin(t)])  # toward the camera
    p = np.array([x, h_from, z])
    lam = (h_to - h_from) / omega[1]
    q = p + lam * omega
    assert abs(q[1] - h_to) < 1e-12
    return q[0], q[2]


@pytest.mark.parametrize("slant,tilt,dh", [(0, 0, 0.3), (25, 0, 0.1), (40, 30, -0.2), (70, 90, 0.05), (55, 75, 0.4)])
def test_plane_shift_follows_the_view_ray(slant, tilt, dh):
    pixel = 0.02
    # a view rectified to plane 0 shows at plane point q what the ray through q meets; to show the
    # plane dh instead, pixel (x, z) must read where the ray through (x, dh, z) crosses plane 0
    x, z = 0.37, -0.21
    qx, qz = _ray_to_plane(slant, tilt, dh, 0.0, x, z)
    dx, dy = K.plane_shift(slant, tilt, dh, pixel)
    assert dx == pytest.approx((qx - x) / pixel, abs=1e-9)
    assert dy == pytest.approx((qz - z) / pixel, abs=1e-9)


@pytest.mark.parametrize("slant,tilt", [(30, 0), (50, 45), (65, 90)])
def test_rectification_is_exact_on_a_plane(slant, tilt):
    """A textured plane at height h photographed rectified to plane 0, then rectified to
    plane h, is the frontal texture: exact for a texture bilinear interpolation reproduces."""
    from proxyshade.synthesis.btf import rectify

    H = W = 40
    pixel, h = 0.01, 0.06
    rows, cols = np.mgrid[0:H, 0:W].astype(np.float64)
    tex = lambda x, z: np.stack([0.2 + 0.5 * x + 0.1 * z, 0.3 + 0.2 * z, 0.1 + 0.3 * x - 0.2 * z], -1)  # noqa: E731
    # the view: plane point (col, row) sees the texture where the ray crosses the plane y = h
    t = math.tan(math.radians(slant)) * h
    xs = cols * pixel + t * math.cos(math.radians(tilt))
    zs = rows * pixel + t * math.sin(math.radians(tilt))
    view = tex(xs, zs).astype(np.float32)
    frontal = tex(cols * pixel, rows * pixel)
    out = rectify(view[None], [{"slant": slant, "tilt": tilt}], h, pixel, filter="bilinear")[0]
    m = int(math.ceil(t / pixel)) + 1
    np.testing.assert_allclose(out[m:-m, m:-m], frontal[m:-m, m:-m], atol=2e-6)
    # and at the wrong plane it is not
    wrong = rectify(view[None], [{"slant": slant, "tilt": tilt}], 0.0, pixel, filter="bilinear")[0]
    assert np.abs(wrong[m:-m, m:-m] - frontal[m:-m, m:-m]).max() > 1e-3


def test_multigrid_visits_each_pixel_T_times_then_twice_per_finer_level(rng):
    from proxyshade.synthesis.btf import synthesize_view

    img = _img(rng, 20, 20)
    qy, qx, visits = synthesize_view(img, (24, 24), radius=2, T=4, levels=3, seed=3)
    assert [v.shape for v in visits] == [(6, 6), (12, 12), (24, 24)]
    assert (visits[0] == 4).all() and (visits[1] == 2).all() and (visits[2] == 2).all()
    assert qy.shape == (24, 24) and qy.min() >= 0 and qy.max() < 20 and qx.min() >= 0 and qx.max() < 20
    # the same seed gives the same map, another seed another one
    again = synthesize_view(img, (24, 24), radius=2, T=4, levels=3, seed=3)
    other = synthesize_view(img, (24, 24), radius=2, T=4, levels=3, seed=4)
    assert np.array_equal(again[0], qy) and np.array_equal(again[1], qx)
    assert not np.array_equal(other[0], qy)


def naive_shade(views, grid, step, tilts, sampled, u, v, slant, tilt):
    """One pixel shaded from a stack, the obvious way: ``grid[(k, tilt)]`` is a view (k = 0
    the frontal one); weights along slant between k·step and (k + 1)·step (clamped to the
    grid), along tilt between the two captured tilts around it when the arc between them
    is ``sampled[(t0, t1)]``, else the nearer one; each view bilinear with wrap-around."""
    K = max(k for k, _ in grid)
    s = min(max(slant / step, 0.0), K)
    k0 = min(int(math.floor(s)), K - 1)
    ws = {k0: 1 - (s - k0), k0 + 1: s - k0}
    phi = tilt % 360.0
    ts = sorted(tilts)
    wt = None
    for a, b in zip(ts, ts[1:] + [ts[0] + 360.0]):
        for p in (phi, phi + 360.0):
            if a <= p < b:
                if sampled[(a % 360.0, b % 360.0)]:
                    wt = {a % 360.0: (b - p) / (b - a), b % 360.0: (p - a) / (b - a)}
                else:
                    wt = {a % 360.0: 1.0} if p - a < b - p else {b % 360.0: 1.0}
    h, w = views.shape[1:3]
    x0, y0 = math.floor(u), math.floor(v)
    fx, fy = u - x0, v - y0
    out = np.zeros(3)
    for k, a in ws.items():
        for t, b in wt.items():
            n = grid[(0, 0.0)] if k == 0 else grid[(k, t)]
            img = views[n].astype(np.float64)
            for dy, wy in ((0, 1 - fy), (1, fy)):
                for dx, wx in ((0, 1 - fx), (1, fx)):
                    out += a * b * wy * wx * img[(y0 + dy) % h, (x0 + dx) % w]
    return out


@pytest.mark.parametrize("tilts", [[0.0, 90.0, 180.0, 270.0], [0.0, 30.0, 60.0, 90.0]])
def test_shade_views_matches_reference(rng, tilts):
    step, K_ = 20.0, 3
    views_list = [{"slant": 0.0, "tilt": 0.0}] + [{"slant": k * step, "tilt": t} for k in range(1, K_ + 1)
                                                   for t in tilts]
    from proxyshade.synthesis import btf

    table, st, tl, spans = btf.shade_grid(views_list)
    grid = {(0, 0.0): 0}
    grid.update({(int(round(v["slant"] / step)), v["tilt"] % 360.0): n for n, v in enumerate(views_list) if n})
    ts = sorted(tl)
    gaps = {(a, b): ((b - a) % 360.0) for a, b in zip(ts, ts[1:] + ts[:1])}
    biggest = max(gaps.values())
    sampled = {ab: not (g == biggest and sum(x == biggest for x in gaps.values()) == 1) for ab, g in gaps.items()}
    views = rng.random((len(views_list), 9, 7, 3)).astype(np.float32)
    H, W = 6, 5
    u = rng.uniform(-20, 20, (H, W))
    v = rng.uniform(-20, 20, (H, W))
    slant = rng.uniform(0, 85, (H, W))  # past the grid's 60° too
    tilt = rng.uniform(-400, 400, (H, W))
    mask = rng.random((H, W)) < 0.8
    out = np.full((H, W, 3), -1.0, np.float32)
    K.shade_views(views, K.ShadeGrid(table, st, tl, spans), u, v, slant, tilt, mask, out)
    for i in range(H):
        for j in range(W):
            if mask[i, j]:
                ref = naive_shade(views, grid, step, ts, sampled, u[i, j], v[i, j], slant[i, j], tilt[i, j])
                np.testing.assert_allclose(out[i, j], ref, rtol=1e-5, atol=1e-6)
            else:
                assert (out[i, j] == -1.0).all()  # off the mask: untouched


def test_shade_views_on_a_grid_direction_is_that_view(rng):
    """At a captured direction and a texel centre the shaded pixel is that view's pixel."""
    from proxyshade.synthesis import btf

    views_list = [{"slant": 0.0, "tilt": 0.0}] + [{"slant": s, "tilt": t} for s in (30.0, 60.0) for t in (0.0, 90.0)]
    table, st, tl, spans = btf.shade_grid(views_list)
    views = rng.random((5, 8, 8, 3)).astype(np.float32)
    u = np.array([[3.0, 5.0, 8.0 + 2.0]])
    v = np.array([[1.0, 6.0, -8.0 + 4.0]])
    slant, tilt = np.array([[60.0, 30.0, 0.0]]), np.array([[90.0, 0.0, 45.0]])
    out = np.zeros((1, 3, 3), np.float32)
    K.shade_views(views, K.ShadeGrid(table, st, tl, spans), u, v, slant, tilt, np.ones((1, 3), bool), out)
    np.testing.assert_array_equal(out[0, 0], views[4, 1, 3])
    np.testing.assert_array_equal(out[0, 1], views[1, 6, 5])
    np.testing.assert_array_equal(out[0, 2], views[0, 4, 2])  # frontal, wrapped texel (2, 4)


def test_other_views_start_from_and_hold_to_their_own_support_map(rng):
    """Each view v runs the pair level against its own support map (sup.qy[v], A at it)."""
    ia = _img(rng, 10, 10)
    views = np.stack([_img(rng, 10, 10) for _ in range(2)])
    cy = rng.integers(0, 10, (2, 12, 12)).astype(np.int64)
    cx = rng.integers(0, 10, (2, 12, 12)).astype(np.int64)
    oa = np.stack([K.gather(ia, cy[v], cx[v]) for v in range(2)])
    qy, qx, vis = (np.zeros((2, 12, 12), np.int64) for _ in range(3))
    K.synth_others(views, K.Support(oa, ia, cy, cx, 0.25, True), 4, 2, K.disk(2), np.array([4, 8], np.int64),
                   qy, qx, vis)
    for v, seed in enumerate((4, 8)):
        alone = naive_level(views[v], cy[v], cx[v], np.full((12, 12), 2, np.int64), 4, 2, 1, seed, 0,
                            pair=(oa[v], ia, cy[v], cx[v]), cw=0.25)
        assert np.array_equal(qy[v], alone[0]) and np.array_equal(qx[v], alone[1])


def naive_sweep(images, ref, shifts, offsets, tau):
    """sweep_costs written plainly: per height and pixel, the mean over the other views that
    read inside of the truncated squared RGB distance, each view read bilinearly."""
    V, h, w = images.shape[:3]
    out = np.empty((len(offsets), h, w))
    for m, o in enumerate(offsets):
        for i in range(h):
            for j in range(w):
                costs = []
                for n in range(V):
                    x, y = j + shifts[n, 0] * o, i + shifts[n, 1] * o
                    if n == ref or not (0 <= x <= w - 1 and 0 <= y <= h - 1):
                        continue
                    x0, y0 = int(math.floor(x)), int(math.floor(y))
                    x1, y1 = min(x0 + 1, w - 1), min(y0 + 1, h - 1)
                    fx, fy = x - x0, y - y0
                    im = images[n].astype(np.float64)
                    val = ((1 - fy) * ((1 - fx) * im[y0, x0] + fx * im[y0, x1])
                           + fy * ((1 - fx) * im[y1, x0] + fx * im[y1, x1]))
                    costs.append(min(float(((val - images[ref, i, j].astype(np.float64)) ** 2).sum()), tau))
                out[m, i, j] = np.mean(costs) if costs else tau
    return out


def test_sweep_costs_match_the_plain_loop(rng):
    images = rng.random((4, 7, 9, 3)).astype(np.float32)
    shifts = rng.normal(0, 3, (4, 2))
    shifts[1] = 0.0  # the reference view: never read
    offsets = np.linspace(-1.2, 1.2, 5)
    got = np.empty((5, 7, 9), np.float32)
    K.sweep_costs(images, 1, shifts, offsets, 0.4, got)
    want = naive_sweep(images, 1, shifts, offsets, 0.4)
    np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-7)
    assert (want < 0.4).any() and (want == 0.4).any()  # truncated somewhere, not everywhere
