"""Guidance-synthesis kernels against slow references written from their definitions."""
import numba
import numpy as np
import pytest

from proxyshade.kernels import guide as kg
from proxyshade.kernels.random import uniform

from tests.kernels.naive_synthesis import window
from tests.kernels.test_chamfer import chamfer_ref


def blobs(rng, h, w, n, k=6):
    ci, cj = rng.uniform(0, h, k), rng.uniform(0, w, k)
    ii, jj = np.mgrid[0:h, 0:w]
    lab = (((ii[..., None] - ci) ** 2 + (jj[..., None] - cj) ** 2).argmin(-1) % n).astype(np.int32)
    lab.flat[:n] = np.arange(n)
    return lab


def colour_window(col, y, x, h):
    H, W, _ = col.shape
    return np.array([col[min(max(y + dy * h, 0), H - 1), min(max(x + dx * h, 0), W - 1)]
                     for dy in range(-2, 3) for dx in range(-2, 3)]).ravel()


def similarity_ref(lab, h, k, sample, seed):
    """Itself, then k - 1 by farthest-point traversal among the 4k closest (Chamfer, ties:
    earlier draw) of the seeded draws that are more than 2h away."""
    He, We = lab.shape
    out = np.empty((He, We, k, 2), int)
    for y in range(He):
        for x in range(We):
            draws = []
            for s in range(sample):
                cy = int(uniform(seed, y * We + x, 2 * s, 0) * He)
                cx = int(uniform(seed, y * We + x, 2 * s + 1, 0) * We)
                if abs(cy - y) <= 2 * h and abs(cx - x) <= 2 * h:
                    continue
                draws.append((chamfer_ref(window(lab, y, x, h), window(lab, cy, cx, h)), s, (cy, cx)))
            pool = [c for _, _, c in sorted(draws)[:4 * k]]
            chosen = [(y, x)]
            while len(chosen) < k:
                if not pool:  # fewer draws than k: the pixel itself again
                    chosen.append((y, x))
                    continue
                score = [min((c[0] - a) ** 2 + (c[1] - b) ** 2 for a, b in chosen) for c in pool]
                chosen.append(pool.pop(int(np.argmax(score))))  # first maximum
            out[y, x] = chosen
    return out


@pytest.mark.parametrize("h", [1, 2])
def test_similarity_sets_match_reference(h):
    rng = np.random.default_rng(h)
    lab = blobs(rng, 11, 13, 3)
    k, sample, seed = 3, 20, 5
    got = kg.similarity_sets(lab, kg.exemplar_masks(lab, h, 3), np.zeros((1, 1, 3)), h, k, sample, seed, 0)
    assert np.array_equal(got, similarity_ref(lab, h, k, sample, seed))


def test_exemplar_masks_hold_the_spaced_window():
    rng = np.random.default_rng(1)
    lab = blobs(rng, 9, 10, 4)
    m = kg.exemplar_masks(lab, 2, 4)
    for y in range(9):
        for x in range(10):
            win = window(lab, y, x, 2).ravel()
            for l in range(4):
                assert int(m[y, x, l]) == sum(1 << t for t in range(25) if win[t] == l)


def subpass_ref(S, pi, pj, ex_lab, ex_col, sim, tgt_col, target, locked, allowed, h, w, metric):
    """One parity sub-pass written out: synthesized window vs candidate window plus w x
    proxy window vs candidate window; first minimum wins; locked pixels take only the
    proxy's label; no candidate may sit next to a label it is not allowed to touch."""
    H, W = target.shape
    He, We = ex_lab.shape
    k = sim.shape[2]
    out = S.copy()
    syn = ex_lab[S[..., 0], S[..., 1]]
    cl = lambda v, n: min(max(v, 0), n - 1)  # noqa: E731
    for i in range(pi, H, 2):
        for j in range(pj, W, 2):
            cands = [tuple(S[i, j])]
            for di in (-1, 0, 1):
                for dj in (-1, 0, 1):
                    ii, jj = cl(i + di, H), cl(j + dj, W)
                    by, bx = cl(S[ii, jj, 0] - h * (ii - i), He), cl(S[ii, jj, 1] - h * (jj - j), We)
                    cands += [tuple(sim[by, bx, t]) for t in range(k)]
            best, arg = np.inf, tuple(S[i, j])
            for cy, cx in cands:
                lc = ex_lab[cy, cx]
                if locked[i, j] and lc != target[i, j]:
                    continue
                nbrs = [syn[a, b] for a, b in ((i - 1, j), (i + 1, j), (i, j - 1), (i, j + 1)) if 0 <= a < H and 0 <= b < W]
                if not all(allowed[lc, v] for v in nbrs):
                    continue
                if metric == 0:
                    d1 = chamfer_ref(window(syn, i, j), window(ex_lab, cy, cx, h))
                    d2 = chamfer_ref(window(target, i, j), window(ex_lab, cy, cx, h))
                else:
                    fs = np.array([ex_col[S[cl(i + dy, H), cl(j + dx, W), 0], S[cl(i + dy, H), cl(j + dx, W), 1]]
                                   for dy in range(-2, 3) for dx in range(-2, 3)]).ravel()
                    fe = colour_window(ex_col, cy, cx, h)
                    d1 = float(((fs - fe) ** 2).sum())
                    d2 = float(((tgt_col[i, j] - fe) ** 2).sum())
                c = d1 + w * d2
                if c < best:
                    best, arg = c, (cy, cx)
            out[i, j] = arg
    return out


def subpass_case(rng):
    """A small random correction sub-pass problem: 3 labels, a 14×15 exemplar, a 9×8 state
    with 2 similar coordinates each (the first the coordinate itself), 20 % locked pixels,
    labels 0 and 2 never adjacent."""
    n, k = 3, 2
    ex_lab = blobs(rng, 14, 15, n)
    target = blobs(rng, 9, 8, n)
    S = np.stack([rng.integers(0, 14, (9, 8)), rng.integers(0, 15, (9, 8))], -1).astype(np.int32)
    sim = np.stack([rng.integers(0, 14, (14, 15, k)), rng.integers(0, 15, (14, 15, k))], -1).astype(np.int32)
    sim[:, :, 0] = np.stack(np.mgrid[0:14, 0:15], -1)
    ex_col, tgt_col = rng.random((14, 15, 3)), rng.random((9, 8, 75))
    locked = rng.random((9, 8)) < 0.2
    allowed = np.ones((n, n), bool)
    allowed[0, 2] = allowed[2, 0] = False
    return n, ex_lab, target, S, sim, ex_col, tgt_col, locked, allowed


@pytest.mark.parametrize("metric,h,w", [(0, 1, 1.0), (0, 2, 0.7), (1, 2, 1.0)])
def test_correction_subpass_matches_reference(metric, h, w):
    rng = np.random.default_rng(10 * metric + h)
    n, ex_lab, target, S, sim, ex_col, tgt_col, locked, allowed = subpass_case(rng)
    masks = kg.exemplar_masks(ex_lab, h, n)
    tmasks = kg.grid_masks(target, n)
    for pi, pj in ((0, 0), (1, 1), (0, 1), (1, 0)):
        new = S.copy()
        kg._subpass(S, new, np.ones(target.shape, bool), (pi, pj), kg.Exemplar(ex_lab, masks, ex_col, sim),
                    kg.Guide(tmasks, tgt_col, target, locked, allowed), kg.Rule(h, w, metric, n))
        ref = subpass_ref(S, pi, pj, ex_lab, ex_col, sim, tgt_col, target, locked, allowed, h, w, metric)
        assert np.array_equal(new, ref)
        assert (new != S).any() or pi + pj > 0  # the test exercises changes


@pytest.mark.parametrize("metric,h", [(0, 1), (1, 2)])
def test_masked_subpass_corrects_the_active_pixels_as_the_reference_and_keeps_the_others(metric, h):
    """An edit's masked correction: active pixels take the reference's choice (reading every
    pixel, active or not, as context), inactive ones keep their coordinates."""
    rng = np.random.default_rng(20 + metric)
    n, ex_lab, target, S, sim, ex_col, tgt_col, locked, allowed = subpass_case(rng)
    active = rng.random((9, 8)) < 0.4
    masks, tmasks = kg.exemplar_masks(ex_lab, h, n), kg.grid_masks(target, n)
    for pi, pj in ((0, 0), (1, 1), (0, 1), (1, 0)):
        new = S.copy()
        kg._subpass(S, new, active, (pi, pj), kg.Exemplar(ex_lab, masks, ex_col, sim),
                    kg.Guide(tmasks, tgt_col, target, locked, allowed), kg.Rule(h, 1.0, metric, n))
        ref = subpass_ref(S, pi, pj, ex_lab, ex_col, sim, tgt_col, target, locked, allowed, h, 1.0, metric)
        assert np.array_equal(new[active], ref[active])
        assert np.array_equal(new[~active], S[~active])
        assert (new[active] != S[active]).any() or pi + pj > 0
    args = (kg.Exemplar(ex_lab, masks, ex_col, sim), kg.Guide(tmasks, tgt_col, target, locked, allowed))
    # and the masked passes do not depend on the thread count
    outs = []
    old = numba.get_num_threads()
    try:
        for t in (1, 2):
            numba.set_num_threads(t)
            outs.append(kg.correct(S, *args, kg.Rule(h, 1.0, metric, n), passes=2, active=active))
    finally:
        numba.set_num_threads(old)
    assert np.array_equal(outs[0], outs[1]) and np.array_equal(outs[0][~active], S[~active])


@pytest.mark.parametrize("metric,h,masked", [(0, 1, False), (1, 2, False), (0, 2, True)])
def test_correction_passes_match_the_reference_subpasses(metric, h, masked):
    """``correct`` passes over the pixels none of whose 5×5 window changed since they were
    last corrected: its passes equal the reference's sub-passes correcting every (active)
    pixel each time."""
    rng = np.random.default_rng(30 + metric + h)
    n, ex_lab, target, S, sim, ex_col, tgt_col, locked, allowed = subpass_case(rng)
    active = rng.random(target.shape) < 0.6 if masked else np.ones(target.shape, bool)
    masks, tmasks = kg.exemplar_masks(ex_lab, h, n), kg.grid_masks(target, n)
    got = kg.correct(S, kg.Exemplar(ex_lab, masks, ex_col, sim), kg.Guide(tmasks, tgt_col, target, locked, allowed),
                     kg.Rule(h, 0.7, metric, n), passes=4, active=active if masked else None)
    want = S.copy()
    for _ in range(4):
        for pi, pj in ((0, 0), (1, 1), (0, 1), (1, 0)):
            ref = subpass_ref(want, pi, pj, ex_lab, ex_col, sim, tgt_col, target, locked, allowed, h, 0.7, metric)
            want = np.where(active[..., None], ref, want)
    assert np.array_equal(got, want) and (got != S).any()


def test_correction_passes_on_a_larger_map_match_every_pixel_corrected():
    rng = np.random.default_rng(5)
    n = 4
    ex_lab, target = blobs(rng, 40, 36, n, k=12), blobs(rng, 48, 40, n, k=10)
    masks = kg.exemplar_masks(ex_lab, 1, n)
    sim = kg.similarity_sets(ex_lab, masks, np.zeros((1, 1, 3)), 1, 3, 24, 1, 0)
    S0 = kg.init_state(target, ex_lab, 2)
    args = (kg.Exemplar(ex_lab, masks, np.zeros((1, 1, 3)), sim),
            kg.Guide(kg.grid_masks(target, n), np.zeros((1, 1, 75)), target, np.zeros(target.shape, bool),
                     kg.adjacency(ex_lab, target, n=n)), kg.Rule(1, 1.0, 0, n))
    got = kg.correct(S0, *args, passes=5)
    want, every = S0.copy(), np.ones(target.shape, bool)
    for _ in range(5):
        for par in ((0, 0), (1, 1), (0, 1), (1, 0)):
            snap = want.copy()
            kg._subpass(snap, want, every, par, *args)
    assert np.array_equal(got, want) and (got != S0).any()


def test_correction_is_thread_count_independent():
    rng = np.random.default_rng(3)
    n = 4
    ex_lab = blobs(rng, 40, 36, n, k=12)
    target = blobs(rng, 32, 32, n, k=10)
    masks = kg.exemplar_masks(ex_lab, 1, n)
    sim = kg.similarity_sets(ex_lab, masks, np.zeros((1, 1, 3)), 1, 3, 24, 1, 0)
    S0 = kg.init_state(target, ex_lab, 2)
    args = (kg.Exemplar(ex_lab, masks, np.zeros((1, 1, 3)), sim),
            kg.Guide(kg.grid_masks(target, n), np.zeros((1, 1, 75)), target, np.zeros(target.shape, bool),
                     kg.adjacency(ex_lab, target, n=n)))
    outs = []
    old = numba.get_num_threads()
    try:
        for t in (1, 2):
            numba.set_num_threads(t)
            outs.append(kg.correct(S0, *args, kg.Rule(1, 1.0, 0, n), passes=2))
    finally:
        numba.set_num_threads(old)
    assert np.array_equal(outs[0], outs[1])
    # the corrected labels follow the target much better than chance
    assert (ex_lab[outs[0][..., 0], outs[0][..., 1]] == target).mean() > 0.8


def test_init_state_takes_the_targets_label_and_upsampling_continues_patches():
    rng = np.random.default_rng(4)
    ex_lab = blobs(rng, 20, 24, 3)
    target = blobs(rng, 8, 8, 3)
    S = kg.init_state(target, ex_lab, 7)
    assert np.array_equal(ex_lab[S[..., 0], S[..., 1]], target)
    assert np.array_equal(S, kg.init_state(target, ex_lab, 7))
    assert not np.array_equal(S, kg.init_state(target, ex_lab, 8))
    up = kg.upsample_state(S, 2, 20, 24, 16, 15)
    for i in range(16):
        for j in range(15):
            p = S[min(i // 2, 7), min(j // 2, 7)]
            assert tuple(up[i, j]) == (min(p[0] + 2 * (i % 2), 19), min(p[1] + 2 * (j % 2), 23))


def test_adjacency_and_locked_border():
    a = np.array([[0, 0, 1], [0, 2, 1], [2, 2, 1]])
    A = kg.adjacency(a, n=4)
    assert A[0, 1] and A[0, 2] and A[1, 2] and not A[0, 3] and A[3, 3]
    b = np.array([[0, 1, 1], [0, 1, 1], [0, 1, 3]])
    assert kg.new_adjacencies(b, a, n=4) == {(1, 3)}
    t = np.zeros((9, 9), int)
    t[5:] = 1
    t[:, 7:] = 2
    m = kg.locked_border(t, [(0, 1)], radius=1)
    rows = np.nonzero(m.any(1))[0]
    assert rows.tolist() == [3, 4, 5, 6]  # one pixel around the 0|1 border at rows 4|5
    assert not m[:, 8].any()  # the 0|2 and 1|2 borders are not locked
