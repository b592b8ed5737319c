"""Hybrid kernels against slow, written-out references: the per-box stack, neighbourhoods,
PCA, the multiscale descriptor, candidate sets (quota, separation, near-exhaustive
distances), the jitter/correction sub-pass, the spatial jitter; determinism."""
import numba
import numpy as np
import pytest

from proxyshade.kernels import hybrid as kh
from proxyshade.kernels.random import rand
from proxyshade.synthesis import hybrid as sh


def test_stack_is_a_box_mean_clamped_inside_each_exemplar():
    rng = np.random.default_rng(0)
    img = rng.random((9, 2 * 11, 3)).astype(np.float32)
    for h in (1, 2, 4):
        out = kh.stack_level(img, 11, h)
        lo = h // 2
        for i in range(9):
            for j in range(22):
                x0 = j // 11 * 11
                acc = np.zeros(3)
                for di in range(-lo, h - lo):
                    for dj in range(-lo, h - lo):
                        acc += img[min(max(i + di, 0), 8), min(max(j + dj, x0), x0 + 10)]
                np.testing.assert_allclose(out[i, j], acc / h / h, rtol=1e-5, atol=1e-6)
    other = img.copy()
    other[:, 11:] = 100.0  # the second exemplar changes: the first's stack does not
    np.testing.assert_array_equal(kh.stack_level(other, 11, 4)[:, :11], kh.stack_level(img, 11, 4)[:, :11])


def _gaussian_stack_reference(img, bw, levels):
    """Level after level, every pixel written out: the 5 × 5 binomial (1 4 6 4 1 / 16 in
    each direction) with taps 2^(s−1) apart, each tap clamped into the pixel's box."""
    w = np.array([1, 4, 6, 4, 1]) / 16.0
    H, Wa, _ = img.shape
    cur = img.astype(np.float64)
    out = [cur]
    for s in range(1, levels):
        step = 2 ** (s - 1)
        nxt = np.zeros_like(cur)
        for i in range(H):
            for j in range(Wa):
                x0 = j // bw * bw
                for a in range(5):
                    for b in range(5):
                        ii = min(max(i + (a - 2) * step, 0), H - 1)
                        jj = min(max(j + (b - 2) * step, x0), x0 + bw - 1)
                        nxt[i, j] += w[a] * w[b] * cur[ii, jj]
        out.append(nxt)
        cur = nxt
    return out


def test_gaussian_stack_matches_the_written_out_binomial_inside_each_exemplar():
    rng = np.random.default_rng(0)
    img = rng.random((13, 2 * 11, 3)).astype(np.float32)
    got = kh.gaussian_stack(img, 11, 4)
    want = _gaussian_stack_reference(img, 11, 4)
    assert len(got) == 4
    np.testing.assert_array_equal(got[0], img)
    for g, r in zip(got, want):
        np.testing.assert_allclose(g, r, rtol=1e-5, atol=1e-6)
    other = img.copy()
    other[:, 11:] = 100.0  # the second exemplar changes: the first's stack does not
    for a, b in zip(kh.gaussian_stack(other, 11, 4), got):
        np.testing.assert_array_equal(a[:, :11], b[:, :11])
    # a pyramid's Gaussian: a constant stays constant, and level s blurs a point to σ² = (4^s − 1) / 3
    dot = np.zeros((33, 33, 1), np.float32)
    dot[16, 16] = 1.0
    for s, lev in enumerate(kh.gaussian_stack(dot, 33, 4)):
        prof = lev[16, :, 0].astype(np.float64) / lev[16, :, 0].sum()
        var = float((prof * (np.arange(33) - 16.0) ** 2).sum())
        assert var == pytest.approx((4 ** s - 1) / 3, rel=1e-4)
    flat = kh.gaussian_stack(np.full((9, 18, 3), 0.25, np.float32), 9, 3)
    for lev in flat:
        np.testing.assert_allclose(lev, 0.25, rtol=1e-6)


def test_gather_reads_5x5_at_spacing_h_inside_the_box():
    rng = np.random.default_rng(1)
    img = rng.random((7, 16, 3)).astype(np.float32)
    N = kh.gather(img, 8, 2)
    for i in range(7):
        for j in range(16):
            x0 = j // 8 * 8
            want = [img[min(max(i + 2 * a, 0), 6), min(max(j + 2 * b, x0), x0 + 7)] for a in range(-2, 3)
                    for b in range(-2, 3)]
            np.testing.assert_array_equal(N[i, j], np.concatenate(want))


def test_pca_spans_numpys_svd_subspace_and_projects():
    rng = np.random.default_rng(2)
    X = (rng.normal(size=(5000, 75)) * np.linspace(3, 0.1, 75)).astype(np.float32)
    X += rng.normal(size=(1, 75)).astype(np.float32)
    mean, B = kh.pca_basis(X, 6)
    np.testing.assert_allclose(mean, X.astype(np.float64).mean(0), atol=1e-9)
    C = X.astype(np.float64) - X.astype(np.float64).mean(0)
    _, sv, Vt = np.linalg.svd(C, full_matrices=False)
    V = Vt[:6].T
    np.testing.assert_allclose(B @ B.T, V @ V.T, atol=1e-6)  # the same 6-D subspace
    np.testing.assert_allclose(np.abs(B.T @ V), np.eye(6), atol=1e-6)  # the same directions, in order
    P = kh.project(X.reshape(50, 100, 75), mean, B)
    np.testing.assert_allclose(P.reshape(-1, 6), C @ B, rtol=1e-4, atol=1e-4)


def test_multiscale_concatenates_L_successive_finer_levels():
    P = [np.full((2, 3, 6), s, np.float32) for s in range(5)]
    assert kh.multiscale(P, 3, 8)[0, 0].tolist() == [3.0] * 6 + [2.0] * 6 + [1.0] * 6 + [0.0] * 6
    assert kh.multiscale(P, 4, 2)[1, 2].tolist() == [4.0] * 6 + [3.0] * 6
    assert kh.multiscale(P, 2, 1).shape == (2, 3, 6)
    sc = [0.5, 2.0, 4.0, 8.0, 16.0]  # the analysis's default: each level times its scale
    assert kh.multiscale(P, 2, 8, scales=sc)[0, 0].tolist() == [8.0] * 6 + [2.0] * 6 + [0.0] * 6


def test_analysis_stacks_are_the_gaussian_stack_by_default_and_the_box_stack_on_request():
    rng = np.random.default_rng(3)
    rgb = rng.random((32, 64, 3)).astype(np.float32)
    base = sh.standardised(rgb, 32)
    an = sh.analyse(rgb, 32, levels=3, descriptor_levels=8, q=1, iterations=1, seed=0)
    for got, want in zip(an.stacks, kh.gaussian_stack(base, 32, 3)):
        np.testing.assert_array_equal(got, want)
    box = sh.analyse(rgb, 32, levels=3, descriptor_levels=8, q=1, iterations=1, seed=0, stack="box")
    for s, got in enumerate(box.stacks):
        np.testing.assert_array_equal(got, kh.stack_level(base, 32, 2 ** s))
    with pytest.raises(ValueError, match="stack"):
        sh.analyse(rgb, 32, levels=3, descriptor_levels=8, q=1, iterations=1, seed=0, stack="pyramid")


def test_analysis_candidates_come_from_the_finer_levels_each_scaled():
    """Level s's candidates are the search under levels s, s − 1, .. each scaled to unit RMS
    (started from the finer level's lists, one iteration), not under the coarser levels."""
    from proxyshade.kernels.random import mix_seed

    rng = np.random.default_rng(4)
    rgb = rng.random((32, 64, 3)).astype(np.float32)
    an = sh.analyse(rgb, 32, levels=3, descriptor_levels=8, q=2, iterations=2, seed=1)
    sc = kh.level_scales(an.P)
    for s in (1, 2):
        D = kh.multiscale(an.P, s, 8, scales=sc)
        assert D.shape[-1] == 6 * (s + 1)
        want, _ = kh.candidates(D, D, 32, 2, an.sep, own_box=True, iterations=1, seed=mix_seed(1, s),
                                init=an.cands[s - 1])
        np.testing.assert_array_equal(an.cands[s], want)
    coarser = sh.analyse(rgb, 32, levels=3, descriptor_levels=8, q=2, iterations=2, seed=1, coarser=True)
    assert (coarser.cands[1] != an.cands[1]).any()


def test_multiscale_coarser_concatenates_L_successive_coarser_levels_each_scaled():
    rng = np.random.default_rng(11)
    P = [(rng.normal(size=(4, 5, 6)) * (5 - s)).astype(np.float32) for s in range(5)]
    sc = kh.level_scales(P)
    for s, t in zip(sc, P):  # 1 / RMS norm: every scaled level has unit mean squared norm
        np.testing.assert_allclose(np.mean(((t.astype(np.float64) * s) ** 2).sum(-1)), 1.0, rtol=1e-9)
    got = kh.multiscale(P, 1, 3, coarser=True, scales=sc)
    want = np.concatenate([P[1] * np.float32(sc[1]), P[2] * np.float32(sc[2]), P[3] * np.float32(sc[3])], -1)
    np.testing.assert_array_equal(got, want)
    assert kh.multiscale(P, 3, 8, coarser=True).shape == (4, 5, 12)  # only levels 3 and 4 exist
    np.testing.assert_array_equal(kh.multiscale(P, 4, 8, coarser=True), P[4])


def exhaustive(D, bw, q, sep, own):
    """Greedy over the sorted distances: the q nearest of each box, skipping any within sep
    of one taken (and of the query pixel in its own box)."""
    H, Wa, _ = D.shape
    nb = Wa // bw
    flat = D.reshape(-1, D.shape[2]).astype(np.float64)
    out = np.empty((H, Wa, nb, q))
    for i in range(H):
        for j in range(Wa):
            d = ((flat - D[i, j].astype(np.float64)) ** 2).sum(1).reshape(H, Wa)
            for b in range(nb):
                taken = []
                for k in np.argsort(d[:, b * bw:(b + 1) * bw], axis=None, kind="stable"):
                    y, x = divmod(int(k), bw)
                    x += b * bw
                    if own and b == j // bw and max(abs(y - i), abs(x - j)) < sep:
                        continue
                    if any(max(abs(y - a), abs(x - c)) < sep for a, c, _ in taken):
                        continue
                    taken.append((y, x, d[y, x]))
                    if len(taken) == q:
                        break
                out[i, j, b] = [t[2] for t in taken]
    return out


def texture_descriptors(s):
    """Multiscale descriptors of level ``s`` of a 2-exemplar atlas of 32² crops of the
    bundled brick and gravel (the search's premise: natural images, coherent matches)."""
    from pathlib import Path

    from proxyshade.io.images import read_u8

    tex = Path(__file__).resolve().parents[2] / "samples" / "textures"
    a = read_u8(tex / "brick.png")[:64:2, :64:2]
    b = read_u8(tex / "gravel.png")[100:164:2, 100:164:2]
    rgb = (np.concatenate([a, b], 1).astype(np.float32) / 255) ** 2.2
    an = sh.analyse(rgb, 32, levels=3, descriptor_levels=8, q=1, iterations=1, seed=0)
    return kh.multiscale(an.P, s, 8)


@pytest.mark.parametrize("q,s,iterations", [(2, 1, 4), (2, 2, 4), (1, 2, 8)])
def test_candidates_keep_quota_and_separation_and_are_near_exhaustive(q, s, iterations):
    D = texture_descriptors(s)
    sep = 2  # 5% of 32
    c, d = kh.candidates(D, D, 32, q, sep, own_box=True, iterations=iterations, seed=5)
    assert c.shape == (32, 64, 2, q, 2) and (c[..., 0] >= 0).all()  # the quota, always
    for i in range(32):
        for j in range(64):
            for b in range(2):
                pos = c[i, j, b]
                assert ((pos[:, 1] // 32) == b).all()
                for a in range(q):
                    if b == j // 32:
                        assert max(abs(pos[a, 0] - i), abs(pos[a, 1] - j)) >= sep
                    for e in range(a):
                        assert max(abs(pos[a, 0] - pos[e, 0]), abs(pos[a, 1] - pos[e, 1])) >= sep
                    want = ((D[i, j].astype(np.float64) - D[pos[a, 0], pos[a, 1]]) ** 2).sum()
                    np.testing.assert_allclose(d[i, j, b, a], want, rtol=1e-6)
    ref = exhaustive(D, 32, q, sep, True)
    assert d.mean() <= 1.05 * ref.mean(), (d.mean(), ref.mean())


def test_nearest_patch_search_from_another_image_is_near_exhaustive():
    rng = np.random.default_rng(4)
    A = texture_descriptors(1)
    Q = np.ascontiguousarray(A[4:28, 20:52] + rng.normal(0, 0.05, (24, 32, A.shape[2])).astype(np.float32))
    c, d = kh.candidates(Q, A, 32, 1, 1, own_box=False, iterations=6, seed=1)
    best = d[..., 0].min(-1)
    flat = A.reshape(-1, A.shape[2]).astype(np.float64)
    ref = np.array([((flat - Q[i, j]) ** 2).sum(1).min() for i in range(24) for j in range(32)]).reshape(24, 32)
    assert best.mean() <= 1.05 * ref.mean() and (best >= ref - 1e-6).all(), (best.mean(), ref.mean())


def small_level(seed, Ht=10, Wt=12, bh=16, bw=16, nb=2, q=2):
    rng = np.random.default_rng(seed)
    rgb = rng.random((bh, nb * bw, 3)).astype(np.float32)
    an = sh.analyse(rgb, bw, levels=2, descriptor_levels=2, q=q, iterations=2, seed=seed)
    S = np.stack([rng.integers(0, bh, (Ht, Wt)), rng.integers(0, nb * bw, (Ht, Wt))], -1).astype(np.int32)
    return rng, an, S


def reference_subpass(an, s, inv_w, S, pi, pj, h, J, seed, salt, coherence=1.0):
    """Written out: Ñ_S(p), candidates of the 3×3 neighbours, d_i / weight, then the
    first minimum (J = 0) or a uniform pick among (d − dmin) <= J (dmax − dmin)."""
    st, mean, B, P, cand = an.stacks[s], an.means[s], an.bases[s], an.P[s], an.cands[s]
    Ht, Wt = S.shape[:2]
    Ha, bw = P.shape[0], an.bw
    out = S.copy()
    for i in range(pi, Ht, 2):
        for j in range(pj, Wt, 2):
            x = []
            for a in range(-2, 3):
                for b in range(-2, 3):
                    ii, jj = min(max(i + a, 0), Ht - 1), min(max(j + b, 0), Wt - 1)
                    y0, x0 = S[ii, jj]  # continued by h per pixel past the grid, clamped into its box
                    box = x0 // bw * bw
                    y1 = min(max(y0 + h * (i + a - ii), 0), Ha - 1)
                    x1 = min(max(x0 + h * (j + b - jj), box), box + bw - 1)
                    x.append(st[y1, x1].astype(np.float64))
            x = np.concatenate(x)
            nd = (x - mean) @ B
            cands = []
            for di in (-1, 0, 1):
                for dj in (-1, 0, 1):
                    ii, jj = i + di, j + dj
                    if not (0 <= ii < Ht and 0 <= jj < Wt):
                        continue
                    ptrs = [tuple(S[ii, jj])] + [tuple(p) for p in cand[S[ii, jj, 0], S[ii, jj, 1]].reshape(-1, 2)]
                    for u, (py, px) in enumerate(ptrs):
                        cy, cx = py - h * di, px - h * dj
                        x0 = px // bw * bw
                        if 0 <= cy < Ha and x0 <= cx < x0 + bw and inv_w[i, j, px // bw] != np.inf:
                            d = ((nd - P[cy, cx]) ** 2).sum() * inv_w[i, j, px // bw]
                            cands.append((cy, cx, d * coherence if u == 0 else d))  # u = 0: the coherent one
            d = np.array([c[2] for c in cands])
            if J == 0:
                k = int(np.argmin(d))
            else:
                span = d.max() - d.min()
                ok = [u for u in range(len(d)) if span <= 0 or d[u] - d.min() <= J * span]
                k = ok[rand(seed, i * Wt + j, salt, 0) % len(ok)]
            out[i, j] = cands[k][:2]
    return out


@pytest.mark.parametrize("J,weights,coherence", [(0.0, (1.0, 1.0), 1.0), (0.0, (1.0, 3.0), 0.3), (0.3, (1.0, 1.0), 1.0),
                                               (1.0, (2.0, 0.5), 0.5), (0.5, (0.0, 1.0), 1.0)])
def test_subpass_matches_the_written_out_reference(J, weights, coherence):
    rng, an, S = small_level(int(J * 10) + 1)
    inv_w = np.array([1.0 / w if w > 0 else np.inf for w in weights])
    per_pixel = np.ascontiguousarray(np.broadcast_to(inv_w, S.shape[:2] + inv_w.shape)).copy()
    per_pixel[::3, ::2] = per_pixel[::3, ::2, ::-1]  # weights that vary over the output
    for s, h in ((0, 1), (1, 2)):
        for pi, pj in ((0, 0), (1, 0)):
            S_new = S.copy()
            kh._subpass(an.level(s), per_pixel, S, S_new, pi=pi, pj=pj, h=h, bw=an.bw, jitter_threshold=J, seed=77,
                        salt=3, coherence=coherence)
            want = reference_subpass(an, s, per_pixel, S, pi, pj, h=h, J=J, seed=77, salt=3, coherence=coherence)
            np.testing.assert_allclose(S_new, want)  # float64 sums in the same order: exact
    if J > 0:
        S1 = kh.run_pass(an.level(0), inv_w, S, h=1, bw=an.bw, jitter_threshold=J, seed=1, salt=0)
        S2 = kh.run_pass(an.level(0), inv_w, S, h=1, bw=an.bw, jitter_threshold=J, seed=2, salt=0)
        assert (S1 != S2).any()  # the seed matters when J > 0


def test_an_exemplars_own_map_is_a_fixed_point_of_the_correction():
    rng = np.random.default_rng(10)
    rgb = rng.random((32, 64, 3)).astype(np.float32)
    an = sh.analyse(rgb, 32, levels=3, descriptor_levels=8, q=2, iterations=2, seed=1)
    for s, h in ((0, 1), (2, 4)):
        ii, jj = np.mgrid[0:32 // h, 0:32 // h]
        S = np.stack([ii * h + h // 2, jj * h + h // 2 + 32], -1).astype(np.int32)  # exemplar 2's own map
        np.testing.assert_array_equal(kh.run_pass(an.level(s), np.ones(2), S, h=h, bw=32, jitter_threshold=0.0, seed=0, salt=1), S)


def test_jitter_with_J_0_is_exactly_the_correction_pass():
    _, an, S = small_level(9)
    corr = kh.run_pass(an.level(1), np.ones(2), S, h=2, bw=an.bw, jitter_threshold=0.0, seed=0, salt=1)
    for seed, salt in ((1, 0), (123, 5)):
        np.testing.assert_array_equal(kh.run_pass(an.level(1), np.ones(2), S, h=2, bw=an.bw, jitter_threshold=0.0, seed=seed, salt=salt),
                                      corr)
    assert (corr != S).any()


def test_spatial_jitter_matches_reference_and_stays_in_the_box():
    rng = np.random.default_rng(6)
    S = np.stack([rng.integers(0, 16, (9, 9)), rng.integers(0, 48, (9, 9))], -1).astype(np.int32)
    out = kh.spatial_jitter(S, h=4, r=0.7, bw=16, atlas_height=16, seed=3)
    for i in range(9):
        for j in range(9):
            x0 = S[i, j, 1] // 16 * 16
            for c, lo, hi in ((0, 0, 15), (1, x0, x0 + 15)):
                xi = 2.0 * (rand(3, i * 9 + j, c, 0) / 2.0 ** 53) - 1.0
                assert out[i, j, c] == min(max(S[i, j, c] + int(np.floor(4 * 0.7 * xi + 0.5)), lo), hi)


def test_hybrid_is_bit_identical_with_1_and_2_threads():
    rng = np.random.default_rng(7)
    rgb = rng.random((32, 64, 3)).astype(np.float32)
    runs = []
    for t in (1, 2):
        numba.set_num_threads(t)
        try:
            an = sh.analyse(rgb, 32, levels=3, descriptor_levels=8, q=2, iterations=2, seed=1)
            runs.append((an, sh.synthesize(an, (24, 32), jitter_threshold=0.4, seed=3, weights=np.array([1.0, 2.0]), passes=2)))
        finally:
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    (a1, S1), (a2, S2) = runs
    for x, y in zip(a1.cands + a1.P, a2.cands + a2.P):
        np.testing.assert_array_equal(x, y)
    np.testing.assert_array_equal(S1, S2)
    assert ((S1[..., 1] // 32) == 1).any() and ((S1[..., 1] // 32) == 0).any()  # both exemplars used


def test_nearest_chamfer_is_the_minimum_over_exemplar_windows():
    from proxyshade.kernels.chamfer import chamfer_ring
    from proxyshade.kernels.features import window_masks

    rng = np.random.default_rng(8)
    out = window_masks(rng.integers(0, 3, (6, 6)).astype(np.int32), 1, 3).reshape(-1, 3)
    ex = window_masks((np.arange(64).reshape(8, 8) // 24 % 3).astype(np.int32), 1, 3).reshape(-1, 3)
    got = kh.nearest_chamfer(out, ex)
    want = [min(chamfer_ring(o, e) for e in ex) for o in out]
    np.testing.assert_allclose(got, want)
    assert kh.nearest_chamfer(ex[:5], ex).tolist() == [0.0] * 5
