"""Annotated-exemplar kernels against slow, obvious references: ε-ball radii against
sorting all distances, eq. 2 with the clip, mean shift against an O(n²) loop, constrained
PatchMatch (every entry in cluster and ball; mean distance near exhaustive search),
voting, merge + screened Poisson against scipy's sparse solver."""
import numpy as np
import pytest

from proxyshade.kernels import annotated as ka


def test_ball_scale_is_the_nth_smallest_of_all_sorted_distances():
    rng = np.random.default_rng(0)
    for d in (1, 2, 3):
        pts = rng.random((40, d))
        counts = rng.integers(1, 5, 40)
        eps = rng.uniform(0.05, 0.2, d)
        tgt = rng.random((25, d))
        for n in (1, 7, int(counts.sum())):
            got = ka.ball_scale(pts, counts, eps, tgt, n)
            full = np.repeat(pts, counts, axis=0)  # every pixel, not merged
            for t in range(len(tgt)):
                dist = np.sqrt((((full - tgt[t]) / eps) ** 2).sum(1))
                assert got[t] == pytest.approx(np.sort(dist)[n - 1], abs=1e-12)
        assert np.all(np.isinf(ka.ball_scale(pts, counts, eps, tgt, int(counts.sum()) + 1)))


def test_eq2_weights_with_the_clip():
    rng = np.random.default_rng(1)
    eps = np.array([0.1, 0.05, 0.2])
    s = rng.uniform(0.5, 3.0, (30, 3))
    s[:5, 0] = 0.7  # inside the ε-ball of cluster 0: g is clipped there
    w = ka.eq2_weights(s, eps)
    M, C = s.shape
    ref = np.zeros((M, C))
    for i in range(C):
        for k in range(3):
            pos = [eps[k] * max(s[a, i], 1) - eps[k] for a in range(M) if eps[k] * max(s[a, i], 1) - eps[k] > 0]
            clip = 0.8 * min(pos)
            for a in range(M):
                x = eps[k] * max(s[a, i], 1.0) - eps[k]
                ref[a, i] += eps[k] / (x if x > 0 else clip)
    ref /= ref.sum(1, keepdims=True)
    np.testing.assert_allclose(w, ref, rtol=1e-12)
    assert np.all(w[:5, 0] > w[:5, 1:].max(1))  # inside its ball, a cluster dominates


def _mean_shift_ref(pts, counts, h, iters=100, tol=1e-5):
    out = []
    for p in pts:
        x = p.astype(float).copy()
        for _ in range(iters):
            num = np.zeros_like(x)
            den = 0.0
            for q, c in zip(pts, counts):
                wq = c * np.exp(-((x - q) ** 2).sum() / (2 * h * h))
                num += wq * q
                den += wq
            new = num / den
            done = ((new - x) ** 2).sum() < tol * tol
            x = new
            if done:
                break
        out.append(x)
    return np.array(out)


def test_mean_shift_modes_match_the_quadratic_loop():
    rng = np.random.default_rng(2)
    pts = np.concatenate([rng.normal(0.2, 0.05, (30, 2)), rng.normal(0.8, 0.05, (30, 2))]).clip(0, 1)
    counts = rng.integers(1, 4, 60)
    modes = ka.mean_shift(pts, counts, 0.15)
    ref = _mean_shift_ref(pts, counts, 0.15)
    assert np.abs(modes - ref).max() < 1e-3
    lab, centres = ka.group_modes(modes, counts, 0.075)
    assert len(centres) == 2 and np.all(lab[:30] == lab[0]) and np.all(lab[30:] == lab[30]) and lab[0] != lab[30]


def _constrained_case(seed, n=48):
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:n, 0:n] / n
    # a smooth 2-D annotation field and clusters by the first annotation
    ann = np.stack([xx, 0.5 + 0.5 * np.sin(3 * yy)], -1)
    ann = np.round(ann * 32) / 32
    cluster = (ann[..., 0] > 0.5).astype(np.int32)
    f = rng.random((n // 4, n // 4, 3))
    src = np.kron(f, np.ones((4, 4, 1))) + 0.3 * rng.random((n, n, 3))
    src = src.astype(np.float32)
    shift = np.roll(src, (5, 7), axis=(0, 1))
    tgt = (shift + 0.1 * rng.random((n, n, 3))).astype(np.float32)
    tgt_ann = np.round(rng.random((n, n, 2)) * 0 + ann[::-1, :], 6)  # flipped annotation layout
    usable = np.ones((n, n), bool)
    return src, tgt, ann, cluster, usable, tgt_ann


@pytest.mark.parametrize("cluster_id", [0, 1])
def test_constrained_patchmatch_stays_in_cluster_and_ball_and_nears_exhaustive(cluster_id):
    src, tgt, ann, cluster, usable, tgt_ann = _constrained_case(3)
    n = src.shape[0]
    eps = np.array([0.1, 0.1])
    sel = usable & (cluster == cluster_id)
    bins, inv, counts = np.unique(ann[sel], axis=0, return_inverse=True, return_counts=True)
    members = np.flatnonzero(sel)
    order = members[np.argsort(inv.ravel(), kind="stable")]
    start = np.concatenate([[0], np.cumsum(counts)[:-1]])
    s = ka.ball_scale(bins, counts, eps, tgt_ann.reshape(-1, 2), 60).reshape(n, n)
    iy, ix = ka.nearest_init(tgt_ann, bins, start, counts, order, n, eps, seed=4)
    ball = ka.Ball.of(ann, cluster, cluster_id, usable, eps, tgt_ann, s)
    ny, nx, nd = ka.patchmatch(src, tgt, ball, iy, ix, half_width=2, iterations=12, seed=5)
    # 100% of the entries in the cluster and in the pixel's ball
    assert np.all(cluster[ny, nx] == cluster_id)
    d = np.sqrt((((ann[ny, nx] - tgt_ann) / eps) ** 2).sum(-1))
    assert np.all(d <= np.maximum(1.0, s) * (1 + 1e-9))
    # the distances reported are the patch distances of the entries
    for i, j in [(0, 0), (10, 20), (47, 47)]:
        assert nd[i, j] == pytest.approx(ka.patch_distance(src, tgt, 2, i, j, ny[i, j], nx[i, j]))
    # exhaustive constrained search over the centres of whole patches inside the source
    best = np.empty((n, n))
    cand = np.argwhere(sel)
    cand = cand[(cand.min(1) >= 2) & (cand.max(1) < n - 2)]
    for i in range(n):
        for j in range(n):
            ok = np.sqrt((((ann[cand[:, 0], cand[:, 1]] - tgt_ann[i, j]) / eps) ** 2).sum(-1)) <= max(1.0, s[i, j]) * (1 + 1e-9)
            best[i, j] = min(ka.patch_distance(src, tgt, 2, i, j, cy, cx) for cy, cx in cand[ok])
    assert nd.mean() <= 1.05 * best.mean()


def test_patchmatch_same_result_with_one_and_two_threads():
    import numba

    src, tgt, ann, cluster, usable, tgt_ann = _constrained_case(6, n=32)
    eps = np.array([0.1, 0.1])
    sel = cluster == 0
    bins, inv, counts = np.unique(ann[sel], axis=0, return_inverse=True, return_counts=True)
    order = np.flatnonzero(sel)[np.argsort(inv.ravel(), kind="stable")]
    start = np.concatenate([[0], np.cumsum(counts)[:-1]])
    s = ka.ball_scale(bins, counts, eps, tgt_ann.reshape(-1, 2), 30).reshape(32, 32)
    out = []
    for t in (1, 2):
        numba.set_num_threads(t)
        iy, ix = ka.nearest_init(tgt_ann, bins, start, counts, order, 32, eps, seed=1)
        ball = ka.Ball.of(ann, cluster, 0, usable, eps, tgt_ann, s)
        out.append(ka.patchmatch(src, tgt, ball, iy, ix, half_width=2, iterations=3, seed=2))
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    for a, b in zip(*out):
        np.testing.assert_array_equal(a, b)


def test_vote_is_the_mean_of_the_covering_patches():
    rng = np.random.default_rng(7)
    src = rng.random((12, 10, 2)).astype(np.float32)
    ny = rng.integers(0, 12, (7, 9)).astype(np.int32)
    nx = rng.integers(0, 10, (7, 9)).astype(np.int32)
    got = ka.vote(src, ny, nx, 1)
    ref = np.zeros((7, 9, 2))
    for i in range(7):
        for j in range(9):
            vals = []
            for dy in (-1, 0, 1):
                for dx in (-1, 0, 1):
                    qi, qj = i - dy, j - dx
                    if 0 <= qi < 7 and 0 <= qj < 9:
                        vals.append(src[min(max(ny[qi, qj] + dy, 0), 11), min(max(nx[qi, qj] + dx, 0), 9)])
            ref[i, j] = np.mean(vals, axis=0)
    np.testing.assert_allclose(got, ref, rtol=1e-6)


def test_merge_and_screened_poisson_match_spsolve():
    import scipy.sparse as sp
    from scipy.sparse.linalg import spsolve

    rng = np.random.default_rng(8)
    C, h, w = 3, 17, 23
    vals = rng.random((C, h, w, 4)) * 50
    grads = rng.normal(0, 3, (C, h, w, 2))
    W = rng.random((h, w, C))
    W /= W.sum(2, keepdims=True)
    mean, g = ka.merge_channels(vals, grads, W)
    # reference merge
    for i in range(h):
        for j in range(w):
            assert np.allclose(mean[i, j], sum(W[i, j, c] * vals[c, i, j] for c in range(C)))
            k = max(range(C), key=lambda c: (W[i, j, c] * np.hypot(*grads[c, i, j]), -c))
            assert np.array_equal(g[i, j], grads[k, i, j])
    screen = 0.2
    u = ka.screened_poisson(mean[..., 0], g[..., 0], g[..., 1], screen, tol=1e-7)
    # reference: minimise Σ_edges (u_q - u_p - g_pq)² + screen Σ (u - L)² by normal equations
    n = h * w
    idx = np.arange(n).reshape(h, w)
    rows, cols, data, rhs = [], [], [], screen * mean[..., 0].ravel()
    e = 0
    D = []
    gv = []
    for i in range(h):
        for j in range(w):
            if j + 1 < w:
                D.append((idx[i, j], idx[i, j + 1])); gv.append(g[i, j, 0])
            if i + 1 < h:
                D.append((idx[i, j], idx[i + 1, j])); gv.append(g[i, j, 1])
    m = len(D)
    G = sp.lil_matrix((m, n))
    for r, (p, q) in enumerate(D):
        G[r, p] = -1
        G[r, q] = 1
    G = G.tocsr()
    A = (G.T @ G + screen * sp.identity(n)).tocsc()
    b = G.T @ np.array(gv) + rhs
    ref = spsolve(A, b).reshape(h, w)
    assert np.linalg.norm(u - ref) / np.linalg.norm(ref) <= 1e-4


def test_patch_distance_is_the_sum_of_squares_over_the_patch_inside_the_target():
    rng = np.random.default_rng(9)
    src = rng.random((13, 11, 7)).astype(np.float32)
    tgt = rng.random((9, 10, 7)).astype(np.float32)
    for _ in range(60):
        hw = int(rng.integers(1, 4))
        i, j = int(rng.integers(0, 9)), int(rng.integers(0, 10))
        cy, cx = int(rng.integers(hw, 13 - hw)), int(rng.integers(hw, 11 - hw))
        ref = 0.0
        for dy in range(-hw, hw + 1):
            for dx in range(-hw, hw + 1):
                if 0 <= i + dy < 9 and 0 <= j + dx < 10:
                    ref += float(((src[cy + dy, cx + dx].astype(float) - tgt[i + dy, j + dx]) ** 2).sum())
        assert ka.patch_distance(src, tgt, hw, i, j, cy, cx) == pytest.approx(ref, rel=1e-5)
    with pytest.raises(ValueError, match="not whole inside"):
        ka.patch_distance(src, tgt, 2, 0, 0, 1, 5)


def test_occurrences_sum_the_patches_holding_each_pixel_of_a_source_patch():
    rng = np.random.default_rng(10)
    H, W, hw = 14, 12, 2
    ny = rng.integers(hw, H - hw, (9, 8)).astype(np.int32)
    nx = rng.integers(hw, W - hw, (9, 8)).astype(np.int32)
    cover = np.zeros((H, W), np.int64)  # how many target patches hold each source pixel
    for cy, cx in zip(ny.ravel(), nx.ravel()):
        cover[cy - hw:cy + hw + 1, cx - hw:cx + hw + 1] += 1
    got = ka.occurrences(ny, nx, hw, (H, W))
    for cy in range(hw, H - hw):
        for cx in range(hw, W - hw):
            assert got[cy, cx] == cover[cy - hw:cy + hw + 1, cx - hw:cx + hw + 1].sum()
