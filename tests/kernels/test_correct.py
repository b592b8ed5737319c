"""k-coherent correction: sub-pass against a written-out reference, repetition rejection,
similarity sets against brute force, level moves, determinism."""
import numba
import numpy as np
import pytest

from proxyshade.kernels import correct as kc
from proxyshade.kernels import features as kf

from tests.kernels import naive_synthesis as naive
from types import SimpleNamespace

from proxyshade.synthesis.params import Correction

# the nodes' defaults, without the height and usage terms
SYN = SimpleNamespace(**{**vars(Correction.defaults()), "height_weight": 0.0, "uniformity": 0.0})


def corr(**kw):
    """``SYN`` with some settings changed."""
    return SimpleNamespace(**{**vars(SYN), **kw})


def blobs(rng, h, w, n, k=5):
    ci, cj = rng.uniform(0, h, k), rng.uniform(0, w, k)
    ii, jj = np.mgrid[0:h, 0:w]
    return (((ii[..., None] - ci) ** 2 + (jj[..., None] - cj) ** 2).argmin(-1) % n).astype(np.int32)


def small_case(seed, n=3, ex=(20, 24), tgt=(16, 16), nlev=2):
    rng = np.random.default_rng(seed)
    ex_lab = blobs(rng, *ex, n)
    ex_lab.flat[:n] = np.arange(n)
    ex_rgb = (rng.random(ex + (3,)) * 0.5 + ex_lab[..., None] * 0.15).astype(np.float32)
    t = blobs(rng, *tgt, n)
    levels = kf.build_levels(ex_rgb, ex_lab, t, n, nlev, max_distance=5.0)
    return rng, levels


def random_state(rng, lv):
    """Patches of random translations with the right labels where possible."""
    Ht, Wt = lv.tgt_lab.shape
    He, We = lv.src_lab.shape
    S = np.stack([rng.integers(0, He, (Ht, Wt)), rng.integers(0, We, (Ht, Wt))], -1).astype(np.int32)
    S[: Ht // 2, : Wt // 2] = (np.mgrid[0:Ht // 2, 0:Wt // 2].transpose(1, 2, 0) + 2).clip(0, min(He, We) - 1)
    return S


def test_rejected_matches_reference():
    rng = np.random.default_rng(0)
    S = rng.integers(0, 12, (14, 15, 2)).astype(np.int32)
    for _ in range(400):
        i, j = rng.integers(0, 14), rng.integers(0, 15)
        cy, cx = rng.integers(0, 12, 2)
        h, r = int(rng.choice([1, 2, 4])), int(rng.choice([0, 1, 2, 4]))
        assert kc.rejected(S, i, j, cy, cx, h, r) == naive.rejected(S, i, j, cy, cx, h, r)


def subpass(lv, knn, S, S_new, active, pi, pj, radius, kappa, counts, hw=0.0, over=None, uniformity=0.0, zw=0.0,
            zs=None, zt=None, far=None):
    over = np.zeros(lv.src_lab.shape) if over is None else over
    zs = kc.NO_Z if zs is None else zs
    zt = kc.NO_Z if zt is None else zt
    if far is None:
        far = kc.no_far(lv.src_masks.shape[2])
    else:  # (reach² per label, r): the users' lists of this state
        He, We = lv.src_lab.shape
        far = (np.asarray(far[0], np.float64), np.int64(far[1]), np.zeros(He * We + 1, np.int64),
               np.zeros(S.shape[0] * S.shape[1], np.int64))
        kc._users(S[..., 0] * np.int32(We) + S[..., 1], far[2], far[3])
    kc._subpass(lv, kf.Metric(90.0, hw), kc.Rule(radius, True, kappa, uniformity, zw), knn, over, zs, zt, S, S_new,
                active, (pi, pj), counts, far)


@pytest.mark.parametrize("seed,kappa,use_level,hw,uniformity,zw,far",
                         [(0, 0.0, -1, 0.0, 0.0, 0.0, None), (1, 0.5, -1, 0.0, 0.0, 0.0, None),
                          (2, 0.0, 0, 0.0, 0.0, 0.0, None), (3, 0.0, -1, 16.0, 1.0, 0.0, None),
                          (4, 0.5, 0, 40.0, 3.0, 0.0, None), (5, 0.0, -1, 0.0, 0.0, 0.5, None),
                          (6, 0.5, 0, 16.0, 1.0, 4.0, None), (7, 0.0, -1, 0.0, 0.0, 0.0, ([40.0, 0.0, 90.0], 0)),
                          (8, 0.5, 0, 16.0, 1.0, 0.0, ([60.0, 20.0, 0.0], 1))])
def test_subpass_matches_reference(seed, kappa, use_level, hw, uniformity, zw, far):
    """The sub-pass kernel against ``naive.correct_pixel``, with and without the kappa,
    height, usage, tone-match terms (random z-scores, a random tone to keep) and the
    far-copy rejection (``copy_spacing``; one label untested)."""
    rng, levels = small_case(seed)
    lv = levels[use_level]
    knn = kc.similarity_sets(lv, 2, kf.Metric(SYN.w, hw), seed=seed, iterations=2)
    S = random_state(rng, lv)
    radius = lv.h
    over = rng.random(lv.src_lab.shape) * (rng.random(lv.src_lab.shape) < 0.5)
    zs = rng.normal(size=lv.src_lab.shape) if zw > 0 else None
    zt = rng.normal(size=lv.tgt_lab.shape) if zw > 0 else None
    for pi, pj in ((0, 0), (1, 0)):
        S_new = S.copy()
        active = np.ones(lv.tgt_lab.shape, bool)
        counts = np.zeros((S.shape[0], 2), np.int64)
        subpass(lv, knn, S, S_new, active, pi, pj, radius=radius, kappa=kappa, counts=counts, hw=hw, over=over,
                uniformity=uniformity, zw=zw, zs=zs, zt=zt, far=far)
        for i in range(pi, S.shape[0], 2):
            for j in range(pj, S.shape[1], 2):
                assert tuple(S_new[i, j]) == naive.correct_pixel(lv, knn, S, i, j, radius, 90.0, kappa, hw, over,
                                                                 uniformity, zw, zs, zt, far), (i, j)
        # pixels outside the sub-set are untouched
        other = np.ones(S.shape[:2], bool)
        other[pi::2, pj::2] = False
        assert np.array_equal(S_new[other], S[other])
        S = S_new


def test_far_copy_and_users_match_reference():
    """The users' lists against a stable sort, and ``far_copy`` against every pixel looked
    at, on small random maps (exemplar pixels used many times, as at 4K)."""
    rng = np.random.default_rng(3)
    for _ in range(5):
        He, We, Ht, Wt = 6, 7, 18, 21
        S = np.stack([rng.integers(0, He, (Ht, Wt)), rng.integers(0, We, (Ht, Wt))], -1).astype(np.int32)
        S[2:9, 3:12] = np.mgrid[0:7, 0:9].transpose(1, 2, 0) % [He, We]  # a coherent patch
        flat = S[..., 0] * np.int32(We) + S[..., 1]
        start, order = np.zeros(He * We + 1, np.int64), np.zeros(Ht * Wt, np.int64)
        kc._users(flat, start, order)
        np.testing.assert_array_equal(order, np.argsort(flat.ravel(), kind="stable"))
        np.testing.assert_array_equal(start, np.r_[0, np.cumsum(np.bincount(flat.ravel(), minlength=He * We))])
        hits = 0
        for _ in range(300):
            i, j = int(rng.integers(0, Ht)), int(rng.integers(0, Wt))
            cy, cx = int(rng.integers(0, He)), int(rng.integers(0, We))
            h, r, reach2 = int(rng.choice([1, 2, 4])), int(rng.choice([0, 1, 2])), float(rng.choice([2.0, 9.5, 50.0]))
            want = naive.far_copy(S, i, j, cy, cx, h, reach2, r)
            assert kc.far_copy(S, i, j, cy, cx, h, reach2, r, start, order, We) == want
            hits += want
        assert 0 < hits < 300


def test_no_accepted_candidate_already_in_the_window():
    """After each sub-pass, a pixel that changed does not use an exemplar pixel already
    used elsewhere in its 9x9 window before the sub-pass (unless label fidelity forced it)."""
    rng, levels = small_case(5, ex=(30, 36), tgt=(24, 24))
    lv = levels[-1]
    knn = kc.similarity_sets(lv, 2, kf.Metric(SYN.w, 0.0), seed=5, iterations=2)
    Ht, Wt = lv.tgt_lab.shape
    # a state full of repeats: two copies of the same exemplar area side by side
    ii, jj = np.mgrid[0:Ht, 0:Wt]
    S = np.stack([ii % 12 + 3, jj % 12 + 3], -1).astype(np.int32)
    changed = forced = 0
    for _ in range(2):
        for pi, pj in ((0, 0), (1, 1), (0, 1), (1, 0)):
            S_new = S.copy()
            counts = np.zeros((Ht, 2), np.int64)
            subpass(lv, knn, S, S_new, np.ones((Ht, Wt), bool), pi, pj, 1, 0.0, counts)
            for i, j in zip(*np.nonzero((S_new != S).any(-1))):
                win = S[max(i - 4, 0):i + 5, max(j - 4, 0):j + 5].reshape(-1, 2).tolist()
                win.remove(S[i, j].tolist())
                if S_new[i, j].tolist() in win:
                    forced += 1
                    assert lv.src_lab[tuple(S[i, j])] != lv.tgt_lab[i, j]
                changed += 1
            S = S_new
    assert changed > 100


def test_similarity_sets_are_valid_and_close_to_brute_force():
    rng, levels = small_case(6, ex=(18, 20))
    lv = levels[-1]
    k = 3
    knn = kc.similarity_sets(lv, k, kf.Metric(SYN.w, 0.0), seed=1, iterations=3)
    He, We = lv.src_lab.shape
    ratios = []
    for y in range(He):
        for x in range(We):
            d_all = []
            for yy in range(He):
                for xx in range(We):
                    if lv.src_lab[yy, xx] != lv.src_lab[y, x] or max(abs(yy - y), abs(xx - x)) <= 2 * lv.h:
                        continue
                    d_all.append(kc._ex_dist(lv, kf.Metric(90.0, 0.0), y, x, yy, xx, np.inf))
            got = [kc._ex_dist(lv, kf.Metric(90.0, 0.0), y, x, cy, cx, np.inf)
                   for cy, cx in knn[y, x] if (cy, cx) != (y, x)]
            for cy, cx in knn[y, x]:
                if (cy, cx) != (y, x):
                    assert lv.src_lab[cy, cx] == lv.src_lab[y, x] and max(abs(cy - y), abs(cx - x)) > 2 * lv.h
            if len(d_all) >= k and got:
                assert got == sorted(got)
                ratios.append(np.mean(sorted(d_all)[:k]) / max(np.mean(got), 1e-9))
    # PatchMatch is approximate: its lists hold, on average, at least 80% of the best quality
    assert np.mean(ratios) >= 0.8, np.mean(ratios)


def test_translation_survives_down_and_up():
    Ht, Wt, He, We = 32, 32, 60, 60
    ii, jj = np.mgrid[0:Ht, 0:Wt]
    S = np.stack([ii + 7, jj + 11], -1).astype(np.int32)
    for h in (2, 4, 8):
        shape = (Ht // h, Wt // h)
        down = kc.downsample_state(S, h, shape, (He, We))
        assert np.array_equal(down[0, 0], S[h // 2, h // 2])
        up = down
        hh = h
        while hh > 1:
            hh //= 2
            up = kc.upsample_state(up, hh, (Ht // hh, Wt // hh), (He, We))
        assert np.array_equal(up, S)


@pytest.mark.parametrize("tone_balance,tone_spacing,tone_spread,tone_match,match_from",
                         [(0.0, 1, 0.0, 0.0, "init"), (1.0, 1, 0.0, 0.0, "init"), (0.25, 2, 0.0, 0.0, "init"),
                          (0.25, 2, 2.0, 0.0, "init"), (0.25, 2, 0.0, 1.0, "init"), (0.0, 1, 0.0, 1.0, "level")])
def test_synthesis_is_deterministic_across_thread_counts(tone_balance, tone_spacing, tone_spread, tone_match,
                                                         match_from):
    rng, levels = small_case(9, ex=(40, 48), tgt=(32, 32), nlev=3)
    S0 = random_state(rng, levels[-1])
    c = corr(k=2, tone_balance=tone_balance, tone_spacing=tone_spacing, tone_spread=tone_spread, tone_match=tone_match,
             match_spacing=1, match_from=match_from)
    a, _ = kc.synthesize(levels, S0, c, seed=3)
    numba.set_num_threads(1)
    try:
        b, _ = kc.synthesize(levels, S0, c, seed=3)
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    assert np.array_equal(a, b)
    # labels are respected
    assert (levels[-1].src_lab[a[..., 0], a[..., 1]] == levels[-1].tgt_lab).mean() > 0.99


def test_precomputed_similarity_sets_give_the_same_result():
    rng, levels = small_case(11, ex=(40, 48), tgt=(32, 32), nlev=3)
    S0 = random_state(rng, levels[-1])
    a, _ = kc.synthesize(levels, S0, corr(k=2), seed=5)
    sims = kc.level_similarity_sets(levels, 2, kf.Metric(SYN.w, 0.0), seed=5, knn_iterations=SYN.knn_iterations)
    b, _ = kc.synthesize(levels, S0, corr(k=2), seed=123, similarity=sims)  # the seed only seeds the search
    assert np.array_equal(a, b)
    with pytest.raises(ValueError, match="similarity"):
        kc.synthesize(levels, S0, corr(k=3), seed=0, similarity=sims)


def test_mask_limits_changes():
    rng, levels = small_case(10, ex=(40, 48), tgt=(32, 32), nlev=3)
    S0 = random_state(rng, levels[-1])
    mask = np.zeros((32, 32), bool)
    mask[8:20, 4:28] = True
    S, _ = kc.synthesize(levels, S0, corr(k=2), seed=0, mask=mask)
    assert np.array_equal(S[~mask], S0[~mask])
    assert (S[mask] != S0[mask]).any()


@pytest.mark.parametrize("bands", [2, 3])
def test_sub_passes_in_row_bands_are_exactly_the_whole_ones(monkeypatch, bands):
    """Each sub-pass's rows computed apart (as Dask workers do, ``synthesis.tiles``), with
    the usage and tone-balance terms and a mask: the same map as the whole synthesis, bit for bit."""
    from proxyshade.synthesis.tiles import InProcess

    rng, levels = small_case(12, ex=(40, 48), tgt=(48, 40), nlev=3)
    S0 = random_state(rng, levels[-1])
    mask = np.ones((48, 40), bool)
    mask[30:, :12] = False
    c = corr(k=2, uniformity=0.25, height_weight=4.0, tone_balance=0.5, tone_spread=1.0, tone_match=0.5, match_spacing=1)
    a, _ = kc.synthesize(levels, S0, c, seed=4, mask=mask)
    calls = []

    class Counting(InProcess):
        def __call__(self, fn, shared, jobs):
            calls.append(len(jobs))
            return super().__call__(fn, shared, jobs)

    monkeypatch.setattr(kc, "TILE_MIN_PIXELS", 0)
    b, _ = kc.synthesize(levels, S0, c, seed=4, mask=mask, tiles=Counting(bands))
    assert calls and set(calls) == {bands}  # every sub-pass of every level went through the bands
    assert np.array_equal(a, b)


def test_downsample_mask_is_any_of_each_block():
    from proxyshade.kernels.correct import downsample_mask

    rng = np.random.default_rng(12)
    for (H, W), h, shape in [((13, 17), 4, (4, 5)), ((16, 16), 2, (8, 8)), ((9, 6), 8, (2, 1))]:
        m = rng.random((H, W)) < 0.05
        pad = np.zeros((shape[0] * h, shape[1] * h), bool)
        pad[:H, :W] = m
        assert np.array_equal(downsample_mask(m, h, shape), pad.reshape(shape[0], h, shape[1], h).any(axis=(1, 3)))


@pytest.mark.parametrize("rule,min_radius,want", [("spacing", 0, [4, 2, 1]), ("spacing", 3, [4, 3, 3]),
                                                  ("level", 0, [1, 2, 4]), ("level", 3, [3, 3, 4])])
def test_near_copy_radius_is_at_least_min_radius(monkeypatch, rule, min_radius, want):
    """Each level's near-copy radius: the rule's (spacing h, or 2^l from the coarsest), raised
    to ``min_radius`` exemplar pixels."""
    rng, levels = small_case(13, ex=(40, 48), tgt=(32, 32), nlev=3)
    S0 = random_state(rng, levels[-1])
    seen, orig = [], kc.correct_level

    def spy(level, S, knn, **kw):
        seen.append(kw["rule"].radius)
        return orig(level, S, knn, **kw)

    monkeypatch.setattr(kc, "correct_level", spy)
    kc.synthesize(levels, S0, corr(k=2, radius=rule), seed=0, min_radius=min_radius)
    assert seen == want


def tone_balance_reference(S, src_lab, src_rgb, nlab, nbins):
    """``_tone_balance`` written out: per label, the target's and the photo's luma-bin shares."""
    luma = (0.2126 * src_rgb[..., 0] + 0.7152 * src_rgb[..., 1] + 0.0722 * src_rgb[..., 2]) / 255.0
    bins = np.clip((luma * nbins).astype(int), 0, nbins - 1)
    used_lab = src_lab[S[..., 0], S[..., 1]]
    used_bin = bins[S[..., 0], S[..., 1]]
    out = np.zeros(src_lab.shape)
    for y in range(src_lab.shape[0]):
        for x in range(src_lab.shape[1]):
            l, k = src_lab[y, x], bins[y, x]
            n_t = (used_lab == l).sum()
            if n_t == 0:
                continue
            share_t = ((used_lab == l) & (used_bin == k)).sum() / n_t
            share_s = ((src_lab == l) & (bins == k)).sum() / (src_lab == l).sum()
            out[y, x] = max(share_t / share_s - 1.0, -1.0)
    return out


def tone_case(seed: int, clump_rows: int):
    """A random exemplar of 3 labels (seed 2: one of them unused by the map), tones mixed
    dark and bright, and a 9x11 map whose first ``clump_rows`` rows read one pixel."""
    rng = np.random.default_rng(seed)
    He, We, n = 13, 17, 3
    src_lab = rng.integers(0, n - (seed == 2), (He, We)).astype(np.int32)
    src_rgb = (rng.random((He, We, 3)) * 255 * rng.choice([0.3, 1.0], (He, We, 1))).astype(np.float32)
    S = np.stack([rng.integers(0, He, (9, 11)), rng.integers(0, We, (9, 11))], -1).astype(np.int32)
    S[:clump_rows] = S[0, 0]
    return S, src_lab, src_rgb, n


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_tone_balance_matches_reference(seed):
    S, src_lab, src_rgb, n = tone_case(seed, 4)  # a clump: one tone over-used
    out = np.full(src_lab.shape, np.nan)
    kc._tone_balance(S, src_lab, src_rgb, n, kc.TONE_BINS, out)
    np.testing.assert_allclose(out, tone_balance_reference(S, src_lab, src_rgb, n, kc.TONE_BINS), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("over_only", [False, True])
def test_tone_balance_favours_the_tones_the_target_lacks(over_only):
    """A label whose exemplar is half bright and flat, half dark and textured, and a map
    that uses mostly the bright half: with the tone-balance term the correction takes more
    of the dark half (the photo's tones) than the usage term alone, also when only the
    over-used tones pay (``tone_over_only``, Kopf et al. 2007's reweighting)."""
    rng = np.random.default_rng(5)
    He, We = 24, 32
    ex_lab = np.zeros((He, We), np.int32)
    ex_lab[:, :2] = 1  # a second label, so the label window has contours
    ex_rgb = np.full((He, We, 3), 0.8, np.float32)
    ex_rgb[:, We // 2:] = (0.05 + 0.1 * rng.random((He, We - We // 2, 1))).astype(np.float32)
    tgt = np.zeros((20, 20), np.int32)
    tgt[:, :2] = 1
    levels = kf.build_levels(ex_rgb, ex_lab, tgt, 2, 1, max_distance=5.0)
    lv = levels[-1]
    # random positions, four in five in the bright half (the label's columns 2..15 of 2..31)
    S = np.stack([rng.integers(0, He, (20, 20)),
                  np.where(rng.random((20, 20)) < 0.8, rng.integers(2, We // 2, (20, 20)),
                           rng.integers(We // 2, We, (20, 20)))], -1).astype(np.int32)
    S[tgt == 1] = np.stack([rng.integers(0, He, (tgt == 1).sum()), rng.integers(0, 2, (tgt == 1).sum())], -1)
    dark = lambda S: (S[..., 1] >= We // 2)[tgt == 0].mean()  # noqa: E731
    knn = kc.similarity_sets(lv, 2, kf.Metric(90.0, 0.0), seed=0, iterations=2)
    rule = kc.Rule(1, True, 0.0, 0.25)
    a, _ = kc.correct_level(lv, S, knn, passes=3, metric=kf.Metric(90.0, 0.0), rule=rule)
    b, _ = kc.correct_level(lv, S, knn, passes=3, metric=kf.Metric(90.0, 0.0), rule=rule, tone_balance=1.0,
                            tone_over_only=over_only)
    assert dark(b) > dark(a) + 0.05, (dark(S), dark(a), dark(b))


def test_tone_over_only_charges_over_used_tones_and_gives_no_bonus(monkeypatch):
    """With ``tone_over_only`` the factor the sub-passes get is the usage term plus T x max(r - 1, 0):
    never below the usage term's (no bonus), above it where a tone is over-used."""
    rng, levels = small_case(16, ex=(40, 48), tgt=(32, 32), nlev=1)
    lv = levels[-1]
    S = random_state(rng, lv)
    S[:12] = S[0, 0]  # a clump: one tone over-used
    knn = kc.similarity_sets(lv, 2, kf.Metric(90.0, 0.0), seed=0, iterations=2)
    seen, orig = [], kc._subpass

    def spy(lv_, m, rule, knn_, over, *a):
        seen.append(over.copy())
        return orig(lv_, m, rule, knn_, over, *a)

    monkeypatch.setattr(kc, "_subpass", spy)
    kc.correct_level(lv, S, knn, passes=3, metric=kf.Metric(90.0, 0.0), rule=kc.Rule(1, True, 0.0, 0.0), tone_balance=1.0,
                     tone_over_only=True)
    tone = np.empty(lv.src_lab.shape)
    kc._tone_balance(S, lv.src_lab, lv.src_rgb, lv.src_masks.shape[2], kc.TONE_BINS, tone)
    assert (tone < 0).any() and (tone > 0).any()
    np.testing.assert_allclose(seen[0], np.maximum(tone, 0.0), atol=1e-12)  # the first sub-pass reads S


@pytest.mark.parametrize("spacing,want", [(1, [4, 2, 1]), (2, [4, 2]), (4, [4]), (8, [])])
def test_tone_balance_acts_only_at_levels_of_tone_spacing_or_more(monkeypatch, spacing, want):
    """``tone_spacing``: the tone-balance term is computed at the levels whose spacing h is
    at least it; with none such the map is exactly the usage term's alone."""
    rng, levels = small_case(14, ex=(40, 48), tgt=(32, 32), nlev=3)
    S0 = random_state(rng, levels[-1])
    seen, orig = [], kc._tone_balance
    h_of = {lv.tgt_lab.shape: lv.h for lv in levels}  # the exemplar side is a stack: one size

    def spy(S, *a):
        seen.append(h_of[S.shape[:2]])
        return orig(S, *a)

    monkeypatch.setattr(kc, "_tone_balance", spy)
    c = corr(k=2, uniformity=0.25, tone_balance=0.5, tone_spacing=spacing)
    a, _ = kc.synthesize(levels, S0, c, seed=2)
    assert sorted(set(seen), reverse=True) == want
    if not want:
        b, _ = kc.synthesize(levels, S0, corr(k=2, uniformity=0.25), seed=2)
        assert np.array_equal(a, b)


def tone_spread_reference(S, src_lab, src_rgb, nlab):
    """``_tone_spread`` written out: per label, the target's luma mean and variance read
    through ``S`` against the photo label's variance."""
    rgb = src_rgb.astype(np.float64)
    luma = 0.2126 * rgb[..., 0] + 0.7152 * rgb[..., 1] + 0.0722 * rgb[..., 2]
    used_lab = src_lab[S[..., 0], S[..., 1]]
    used = luma[S[..., 0], S[..., 1]]
    out = np.zeros(src_lab.shape)
    for l in range(nlab):
        t = used[used_lab == l]
        if t.size == 0:
            continue
        V = luma[src_lab == l].var()
        if V <= 0:
            continue
        d = max(1.0 - t.var() / V, 0.0)
        m = src_lab == l
        out[m] = d * np.clip(1.0 - (luma[m] - t.mean()) ** 2 / V, -1.0, 1.0)
    return out


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_tone_spread_matches_reference(seed):
    S, src_lab, src_rgb, n = tone_case(seed, 5)  # a clump: the target's spread falls under the photo's
    out = np.full(src_lab.shape, np.nan)
    kc._tone_spread(S, src_lab, src_rgb, n, out)
    want = tone_spread_reference(S, src_lab, src_rgb, n)
    np.testing.assert_allclose(out, want, rtol=1e-9, atol=1e-9)
    assert (want != 0).any() and (want < 0).any() and (want > 0).any()


def _ramp_levels(rng, noise: float, size: int):
    """A 24x32 exemplar whose label 0 is a ramp from dark to bright with a faint texture of
    ``noise`` (label 1: its two left columns), a size x size target of the same two labels,
    and the finest level built on them: (exemplar labels, target labels, level)."""
    He, We = 24, 32
    ex_lab = np.zeros((He, We), np.int32)
    ex_lab[:, :2] = 1
    ramp = np.linspace(0.05, 0.95, We - 2, dtype=np.float32)
    ex_rgb = np.full((He, We, 3), 0.5, np.float32)
    ex_rgb[:, 2:] = (ramp[None, :, None] + noise * rng.random((He, We - 2, 1))).astype(np.float32)
    tgt = np.zeros((size, size), np.int32)
    tgt[:, :2] = 1
    return ex_lab, tgt, kf.build_levels(ex_rgb, ex_lab, tgt, 2, 1, max_distance=5.0)[-1]


def test_tone_spread_keeps_a_labels_spread_the_correction_would_lose():
    """A label whose exemplar is a smooth ramp from dark to bright, and a map reading mostly
    its middle: with the tone-spread term the corrected map's luma spread in the label is
    nearer the photo's than with the usage term alone, and a map already as spread as the
    photo gets no term at all."""
    rng = np.random.default_rng(7)
    He, We = 24, 32
    ex_lab, tgt, lv = _ramp_levels(rng, 0.02, 20)
    mid = rng.integers(We // 2 - 4, We // 2 + 4, (20, 20))
    S = np.stack([rng.integers(0, He, (20, 20)), np.where(rng.random((20, 20)) < 0.9, mid,
                                                         rng.integers(2, We, (20, 20)))], -1).astype(np.int32)
    S[tgt == 1] = np.stack([rng.integers(0, He, (tgt == 1).sum()), rng.integers(0, 2, (tgt == 1).sum())], -1)
    luma = lambda S: (lv.src_rgb[S[..., 0], S[..., 1]] @ np.array([0.2126, 0.7152, 0.0722]))[tgt == 0]  # noqa: E731
    photo = (lv.src_rgb[ex_lab == 0] @ np.array([0.2126, 0.7152, 0.0722])).std()
    knn = kc.similarity_sets(lv, 2, kf.Metric(90.0, 0.0), seed=0, iterations=2)
    rule = kc.Rule(1, True, 0.0, 0.0)  # no usage term: the colour metric alone keeps the clump
    a, _ = kc.correct_level(lv, S, knn, passes=6, metric=kf.Metric(90.0, 0.0), rule=rule)
    b, _ = kc.correct_level(lv, S, knn, passes=6, metric=kf.Metric(90.0, 0.0), rule=rule, tone_spread=2.0)
    assert luma(b).std() > luma(a).std() + 0.1 * photo, (luma(S).std(), luma(a).std(), luma(b).std(), photo)
    spread = np.full(ex_lab.shape, np.nan)
    full = np.stack(np.nonzero(np.ones((He, We), bool)), -1).reshape(He, We, 2).astype(np.int32)  # the photo itself
    kc._tone_spread(full, lv.src_lab, lv.src_rgb, 2, spread)
    assert np.abs(spread).max() < 1e-9


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_tone_z_matches_reference(seed):
    """``_tone_z``: each exemplar pixel's luma z-score within its label, written out (a label
    of one flat tone: 0)."""
    _, src_lab, src_rgb, n = tone_case(seed, 0)
    src_rgb[src_lab == 1] = 40.0  # a flat label
    out = np.full(src_lab.shape, np.nan)
    kc._tone_z(src_lab, src_rgb, n, out)
    luma = src_rgb.astype(np.float64) @ np.array([0.2126, 0.7152, 0.0722])
    want = np.zeros(src_lab.shape)
    for l in range(n):
        m = src_lab == l
        if m.any() and luma[m].std() > 1e-9:
            want[m] = (luma[m] - luma[m].mean()) / luma[m].std()
    np.testing.assert_allclose(out, want, rtol=1e-9, atol=1e-9)
    assert np.abs(want).max() > 1.0


def _ramp_case(seed):
    """A label whose exemplar is a ramp from dark to bright with a faint texture (a second
    label at its left), and a 24x24 map of random positions of the right labels."""
    rng = np.random.default_rng(seed)
    He, We = 24, 32
    ex_lab, tgt, lv = _ramp_levels(rng, 0.05, 24)
    S = np.stack([rng.integers(0, He, tgt.shape), rng.integers(2, We, tgt.shape)], -1).astype(np.int32)
    S[tgt == 1] = np.stack([rng.integers(0, He, (tgt == 1).sum()), rng.integers(0, 2, (tgt == 1).sum())], -1)
    return lv, S, tgt


@pytest.mark.parametrize("seed", [0, 1])
def test_tone_match_keeps_each_pixels_tone(seed):
    """A map of random positions on a ramp: the correction makes patches, pulling tones
    together; with the tone-match term each pixel ends nearer the tone it started with
    (mean |z change| lower) and the label keeps more of its spread; at 0 the map is
    exactly the one without the term."""
    lv, S, tgt = _ramp_case(seed)
    z = np.empty(lv.src_lab.shape)
    kc._tone_z(lv.src_lab, lv.src_rgb, 2, z)
    knn = kc.similarity_sets(lv, 2, kf.Metric(90.0, 0.0), seed=0, iterations=2)
    run = lambda Z: kc.correct_level(lv, S, knn, passes=4, metric=kf.Metric(90.0, 0.0),  # noqa: E731
                                     rule=kc.Rule(1, True, 0.0, 0.25, Z))[0]
    a, b = run(0.0), run(4.0)
    drift = lambda M: np.abs(z[M[..., 0], M[..., 1]] - z[S[..., 0], S[..., 1]])[tgt == 0].mean()  # noqa: E731
    spread = lambda M: z[M[..., 0], M[..., 1]][tgt == 0].std()  # noqa: E731
    assert drift(b) < 0.5 * drift(a), (drift(a), drift(b))
    assert spread(b) > spread(a) + 0.05, (spread(S), spread(a), spread(b))
    c, _ = kc.correct_level(lv, S, knn, passes=4, metric=kf.Metric(90.0, 0.0), rule=kc.Rule(1, True, 0.0, 0.25))
    assert np.array_equal(a, c)


@pytest.mark.parametrize("spacing,want", [(1, [4, 2, 1]), (2, [4, 2]), (8, [])])
def test_tone_match_acts_only_at_levels_of_match_spacing_or_more(monkeypatch, spacing, want):
    """``match_spacing``: the term's weight reaches the levels whose spacing h is at least it
    (0 at the others); keeping PatchInit's tones (``match_from: init``) passes the map
    ``synthesize`` started from, taken down to the level; with no such level the map is
    exactly the one without the term."""
    rng, levels = small_case(15, ex=(40, 48), tgt=(32, 32), nlev=3)
    S0 = random_state(rng, levels[-1])
    seen, orig = [], kc.correct_level

    def spy(level, S, knn, **kw):
        if kw["rule"].tone_match > 0:
            seen.append(level.h)
            keep = kw["keep_tones"]
            assert np.array_equal(keep, kc.downsample_state(S0, level.h, level.tgt_lab.shape, level.src_lab.shape))
        return orig(level, S, knn, **kw)

    monkeypatch.setattr(kc, "correct_level", spy)
    a, _ = kc.synthesize(levels, S0, corr(k=2, uniformity=0.25, tone_match=1.0, match_spacing=spacing), seed=2)
    assert seen == want
    if not want:
        b, _ = kc.synthesize(levels, S0, corr(k=2, uniformity=0.25), seed=2)
        assert np.array_equal(a, b)


def rare_excess_reference(S, src_lab, rare, budget, R):
    """``_rare_excess`` written out: per rare exemplar pixel of a label with a budget, the
    uses of the window's rare pixels over their budget, less 1, at least 0."""
    He, We = src_lab.shape
    uses = np.zeros((He, We))
    for y, x in S.reshape(-1, 2):
        uses[y, x] += 1
    out = np.zeros((He, We))
    for y in range(He):
        for x in range(We):
            if not rare[y, x] or budget[src_lab[y, x]] == 0:
                continue
            u = e = 0.0
            for yy in range(max(y - R, 0), min(y + R + 1, He)):
                for xx in range(max(x - R, 0), min(x + R + 1, We)):
                    if rare[yy, xx]:
                        u += uses[yy, xx] if budget[src_lab[yy, xx]] > 0 else 0.0
                        e += budget[src_lab[yy, xx]]
            out[y, x] = max(u / e - 1.0, 0.0)
    return out


def rare_mask_reference(src_lab, src_rgb, nlab, tail, contrast):
    """``rare_mask`` written out: per label, its pixels at least as dark as its k-th darkest
    or as bright as its k-th brightest, k = round(tail × the label's pixels), at least 1, and
    at least ``contrast`` × 255 from the label's median luma (the lower middle one)."""
    out = np.zeros(src_lab.shape, bool)
    luma = lambda p: 0.2126 * float(src_rgb[p][0]) + 0.7152 * float(src_rgb[p][1]) + 0.0722 * float(src_rgb[p][2])  # noqa: E731
    for l in range(nlab):
        pts = [(y, x) for y in range(src_lab.shape[0]) for x in range(src_lab.shape[1]) if src_lab[y, x] == l]
        if not pts:
            continue
        v = sorted(luma(p) for p in pts)
        k = max(1, int(round(tail * len(pts))))
        med = v[(len(v) - 1) // 2]
        for p in pts:
            out[p] = (luma(p) <= v[k - 1] or luma(p) >= v[-k]) and abs(luma(p) - med) >= contrast * 255
    return out


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("R", [1, 2])
def test_rare_excess_and_mask_match_reference(seed, R):
    S, src_lab, src_rgb, n = tone_case(seed, 4)  # a clump: one pixel over-used
    for contrast in (0.0, 0.3):
        np.testing.assert_array_equal(kc.rare_mask(src_lab, src_rgb, 0.1, contrast),
                                      rare_mask_reference(src_lab, src_rgb, n, 0.1, contrast))
    rare = kc.rare_mask(src_lab, src_rgb, 0.05)
    np.testing.assert_array_equal(rare, rare_mask_reference(src_lab, src_rgb, n, 0.05, kc.RARE_CONTRAST))
    S[:2] = np.argwhere(rare)[0]  # a rare pixel over-used
    budget = np.array([0.3, 0.0, 0.5])  # label 1 without a budget
    out = np.full(src_lab.shape, np.nan)
    kc._rare_excess(S, src_lab, rare, budget, R, out)
    ref = rare_excess_reference(S, src_lab, rare, budget, R)
    np.testing.assert_allclose(out, ref, rtol=1e-12, atol=1e-12)
    assert (ref > 0).any() and (ref[~rare] == 0).all() and (ref[src_lab == 1] == 0).all()


def test_rare_budgets_apply_only_where_an_even_draw_copies_more():
    """A budget of C copies at the synthesis size is C / h² at a level of spacing h, and
    only for labels an even draw would use more (a frame larger than the photo's label)."""
    b = kc.rare_budgets(np.array([0.5, 3.0, 12.0]), 2.0, 1)
    np.testing.assert_array_equal(b, [0.0, 2.0, 2.0])
    np.testing.assert_array_equal(kc.rare_budgets(np.array([0.1, 0.75, 3.0]), 2.0, 2), [0.0, 0.5, 0.5])


def _rare_case():
    """One label, a grey exemplar with a few white 2x2 'tents' (its rare look) and a frame
    about 1.3 times its area whose map repeats the first tent on a lattice over its top half."""
    rng = np.random.default_rng(7)
    He, We = 32, 40
    ex_lab = np.zeros((He, We), np.int32)
    ex_lab[:, :2] = 1  # a second label, so the label window has contours
    ex_rgb = (0.4 + 0.1 * rng.random((He, We, 1))).repeat(3, -1).astype(np.float32)
    tents = [(5, 8), (14, 30), (25, 12), (20, 22)]
    for y, x in tents:
        ex_rgb[y:y + 2, x:x + 2] = 0.95
    tgt = np.zeros((40, 40), np.int32)
    tgt[:, :2] = 1
    levels = kf.build_levels(ex_rgb, ex_lab, tgt, 2, 2, max_distance=5.0)
    S = np.stack([rng.integers(0, He, (40, 40)), rng.integers(2, We, (40, 40))], -1).astype(np.int32)
    S[tgt == 1] = np.stack([rng.integers(0, He, (tgt == 1).sum()), rng.integers(0, 2, (tgt == 1).sum())], -1)
    for i in range(0, 20, 4):
        for j in range(4, 40, 4):
            S[i:i + 2, j:j + 2] = np.mgrid[5:7, 8:10].transpose(1, 2, 0)
    return levels, S


def test_rare_budget_cuts_the_copies_of_a_rare_look():
    """The tents' pixels: with a budget of half a copy each (the frame's even draw would give
    1.3), the corrected map uses them fewer times than with the usage term alone; with a
    budget above the even draw, exactly the map without it."""
    levels, S = _rare_case()
    lv = levels[-1]
    tent = lv.src_rgb[..., 0] > 200  # 255 · sRGB of 0.95
    used = lambda M: tent[M[..., 0], M[..., 1]].sum()  # noqa: E731
    a, _ = kc.synthesize(levels, S, corr(k=2, uniformity=0.25), seed=1)
    b, _ = kc.synthesize(levels, S, corr(k=2, uniformity=0.25), seed=1, rare_budget=0.5)
    assert used(b) < used(a), (used(S), used(a), used(b))
    c, _ = kc.synthesize(levels, S, corr(k=2, uniformity=0.25), seed=1, rare_budget=2.0)
    assert np.array_equal(a, c)


def _same_with_one_thread_and_in_bands(levels, S, c, **kw):
    """The correction's map is the same on all threads, on one, and in three row bands."""
    from proxyshade.synthesis.tiles import InProcess

    a, _ = kc.synthesize(levels, S, c, seed=2, **kw)
    numba.set_num_threads(1)
    try:
        b, _ = kc.synthesize(levels, S, c, seed=2, **kw)
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    assert np.array_equal(a, b)
    old = kc.TILE_MIN_PIXELS
    kc.TILE_MIN_PIXELS = 0
    try:
        d, _ = kc.synthesize(levels, S, c, seed=2, tiles=InProcess(3), **kw)
    finally:
        kc.TILE_MIN_PIXELS = old
    assert np.array_equal(a, d)


@pytest.mark.parametrize("tone_balance,uniformity", [(0.0, 0.25), (0.25, 0.25), (0.0, 0.0)])
def test_rare_budget_is_deterministic_across_thread_counts_and_bands(tone_balance, uniformity):
    levels, S = _rare_case()
    c = corr(k=2, uniformity=uniformity, tone_balance=tone_balance, tone_spacing=1)
    _same_with_one_thread_and_in_bands(levels, S, c, rare_budget=0.5)


def _far_case(seed=11):
    """Two labels, a noisy exemplar 24×28 and a frame 64×64 (six times its area, as 4K is
    from a 1024-wide photo), from a map of random positions."""
    rng = np.random.default_rng(seed)
    He, We = 24, 28
    ex_lab = np.zeros((He, We), np.int32)
    ex_lab[:, :6] = 1
    ex_rgb = rng.random((He, We, 3)).astype(np.float32)
    tgt = np.zeros((64, 64), np.int32)
    tgt[:, :10] = 1
    levels = kf.build_levels(ex_rgb, ex_lab, tgt, 2, 2, max_distance=5.0)
    S = np.stack([rng.integers(0, He, (64, 64)), rng.integers(6, We, (64, 64))], -1).astype(np.int32)
    S[tgt == 1] = np.stack([rng.integers(0, He, (tgt == 1).sum()), rng.integers(0, 6, (tgt == 1).sum())], -1)
    return levels, S, tgt


def _near_copies(S, lab, label, reach):
    """The share of a label's target pixels with another pixel within ``reach`` using the same
    exemplar pixel without being coherent with it (a copy nearby)."""
    pts = {}
    for i, j in zip(*np.nonzero(lab == label)):
        pts.setdefault(tuple(S[i, j]), []).append((i, j))
    near = 0
    for p in pts.values():
        a = np.array(p, float)
        e = np.hypot(a[:, None, 0] - a[None, :, 0], a[:, None, 1] - a[None, :, 1])
        np.fill_diagonal(e, np.inf)
        near += (e.min(1) <= reach).sum()
    return near / (lab == label).sum()


def test_copy_spacing_spreads_the_copies_of_a_spot():
    """In a frame six times the exemplar's area each exemplar pixel is used about six times;
    with copy_spacing 0.5 (a reach of 0.5 √(24 × 22) = 11.5 pixels) far fewer pixels have a
    copy of their spot that near, labels kept."""
    levels, S, tgt = _far_case()
    c = corr(k=2, uniformity=0.25)
    a, _ = kc.synthesize(levels, S, c, seed=1)
    b, _ = kc.synthesize(levels, S, c, seed=1, copy_spacing=0.5)
    lv = levels[-1]
    assert (lv.src_lab[b[..., 0], b[..., 1]] == tgt).mean() >= (lv.src_lab[a[..., 0], a[..., 1]] == tgt).mean() - 0.01
    reach = 0.5 * np.sqrt(24 * 22)
    assert _near_copies(b, tgt, 0, reach) < 0.5 * _near_copies(a, tgt, 0, reach), (
        _near_copies(a, tgt, 0, reach), _near_copies(b, tgt, 0, reach))


def test_copy_spacing_leaves_a_frame_about_the_photos_size_alone():
    """``far_reach`` is 0 for every label when the frame is at most ``FAR_FRAME`` times the
    exemplar's area (a 1024-wide frame from a 1024-wide photo: today's map exactly), and for a
    label copied at most once; else (spacing √(exemplar pixels of the label) / h)²."""
    levels, S = _rare_case()  # frame 1.25 × the exemplar
    a, _ = kc.synthesize(levels, S, corr(k=2, uniformity=0.25), seed=1)
    b, _ = kc.synthesize(levels, S, corr(k=2, uniformity=0.25), seed=1, copy_spacing=0.5)
    assert np.array_equal(a, b)
    assert not kc.far_reach(levels[-1], np.array([1.25, 1.25]), 0.5).any()
    lv = _far_case()[0][-1]  # 64² from 24×28, h = 1: label 0 has 24 × 22 exemplar pixels
    np.testing.assert_allclose(kc.far_reach(lv, np.array([6.0, 0.9]), 0.5), [0.25 * 24 * 22, 0.0])


@pytest.mark.parametrize("uniformity", [0.25, 0.0])
def test_copy_spacing_is_deterministic_across_thread_counts_and_bands(uniformity):
    levels, S, _ = _far_case(12)
    c = corr(k=2, uniformity=uniformity)
    _same_with_one_thread_and_in_bands(levels, S, c, copy_spacing=0.5)
