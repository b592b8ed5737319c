"""Flood-fill patch growth against a slow reference; patch ids of a coordinate map."""
import numpy as np
import pytest
from scipy import ndimage

from proxyshade.kernels.random import permutation
from proxyshade.kernels import features as kf
from proxyshade.kernels import patch as kpatch
from proxyshade.kernels.distance import contour_distance

from tests.kernels import naive_synthesis as naive


def blobs(rng, h, w, n, k=4):
    ci, cj = rng.uniform(0, h, k), rng.uniform(0, w, k)
    ii, jj = np.mgrid[0:h, 0:w]
    return (((ii[..., None] - ci) ** 2 + (jj[..., None] - cj) ** 2).argmin(-1) % n).astype(np.int32)


def case(seed, n=3):
    rng = np.random.default_rng(seed)
    src = blobs(rng, 11, 13, n)
    src.flat[: n] = np.arange(n)  # every label present
    tgt = blobs(rng, 9, 10, n)
    return src, tgt


def level(src, sd, tgt, td, n):
    """The finest level of an exemplar ``src`` and a guide ``tgt`` with contour distances
    ``sd``, ``td`` (no colour: the flood fill reads none)."""
    return kf.Level(1, src, sd, np.zeros(src.shape + (3,), np.float32), kf.window_masks(src, 1, n), tgt, td,
                    kf.window_masks(tgt, 1, n), kf.label_heights(src), kf.label_heights(tgt))


def run_kernel(src, tgt, n, seed, mask=None, S=None, patch=None, w=90.0, ts=1.25, to=5.0, hw=0.0):
    sd = np.minimum(contour_distance(src), 4.0).astype(np.float32)
    td = np.minimum(contour_distance(tgt), 4.0).astype(np.float32)
    return sd, td, kpatch.flood_fill(level(src, sd, tgt, td, n), kf.Metric(w, hw), seed=seed, threshold_scale=ts,
                                     threshold_offset=to, mask=mask, coords=S, patch=patch)


def test_chamfer_masks_match_paper_definition():
    rng = np.random.default_rng(3)
    for _ in range(300):
        n = rng.integers(1, 5)
        a = rng.integers(0, n, (5, 5)).astype(np.int32)
        b = rng.integers(0, n, (5, 5)).astype(np.int32)
        ma = kf.window_masks(a, 1, n)[2, 2]
        mb = kf.window_masks(b, 1, n)[2, 2]
        assert kf.chamfer_masks(ma, mb) == naive.chamfer(a, b)


@pytest.mark.parametrize("seed,hw,w", [(0, 0.0, 90.0), (1, 0.0, 90.0), (2, 16.0, 90.0), (3, 40.0, 90.0),
                                       (0, 0.0, 1.5), (2, 16.0, 1.5)])  # w 1.5: the alike-window shortcut rarely decides
def test_flood_fill_matches_reference(seed, hw, w):
    """The kernel's search (alike windows first, runs of alike windows skipped by their
    Chamfer term, a neighbour's continuation as a head start) finds the exhaustive
    argmin of eq. 1 (height term included), ties to the first met from the random
    start: the same patches as the candidate-by-candidate search."""
    src, tgt = case(seed)
    sd, td, (S, patch, npatch) = run_kernel(src, tgt, 3, seed, hw=hw, w=w)
    order = permutation(seed, tgt.size)
    S_ref, patch_ref = naive.flood_fill(src, sd, tgt, td, order, w, 1.25, 5.0, seed,
                                        (kf.label_heights(src), kf.label_heights(tgt)), hw)
    assert np.array_equal(patch, patch_ref)
    assert np.array_equal(S, S_ref)
    assert npatch == patch.max()


@pytest.mark.parametrize("seed", range(3))
def test_masked_flood_fill_matches_reference(seed):
    """Re-covering a mask next to kept patches (the update frame's case, where the kept
    neighbours' continuations start the search) gives the reference's patches."""
    src, tgt = case(seed + 20)
    sd, td, (S, patch, n0) = run_kernel(src, tgt, 3, seed)
    rng = np.random.default_rng(seed)
    mask = rng.random(tgt.shape) < 0.3
    _, _, (S2, patch2, _) = run_kernel(src, tgt, 3, seed + 5, mask=mask, S=S, patch=patch)
    order = permutation(seed + 5, tgt.size)
    S_ref, patch_ref = naive.flood_fill(src, sd, tgt, td, order, 90.0, 1.25, 5.0, seed + 5,
                                        (kf.label_heights(src), kf.label_heights(tgt)), 0.0, mask=mask, S0=S,
                                        patch0=patch)
    assert np.array_equal(S2, S_ref)
    assert np.array_equal(patch2, patch_ref)


@pytest.mark.parametrize("share", [0.0, 0.05, 0.5, 1.0])
def test_masked_order_is_the_permutation_restricted_to_the_mask(share):
    """The masked flood fill's seed order: the whole level's ``permutation`` with only the free
    pixels, in the same relative order (what lets it skip sorting the whole level)."""
    rng = np.random.default_rng(7)
    for seed in (0, 3, 2**40 + 1):
        free = rng.random((37, 53)) < share
        full = permutation(seed, free.size)
        got = kpatch.masked_order(seed, free)
        assert got.dtype == np.int64
        assert np.array_equal(got, full[free.ravel()[full]])


def test_window_runs_with_a_hash_collision_are_searched_one_by_one():
    """A run of equal hashes whose masks differ (a collision, forced here by marking every
    run non-uniform) is searched candidate by candidate: the same argmin."""
    src, tgt = case(4)
    n = 3
    sd = np.minimum(contour_distance(src), 4.0).astype(np.float32)
    td = np.minimum(contour_distance(tgt), 4.0).astype(np.float32)
    lv = level(src, sd, tgt, td, n)
    m = kf.Metric(90.0, 16.0)
    starts, lists = kpatch._label_lists(src, n)
    groups = kpatch._window_groups(lv.src_masks, starts, lists)
    collided = groups._replace(uniform=np.zeros_like(groups.uniform))
    posof = kpatch._positions(starts, lists, lists.shape[0])
    target_dist = np.empty(25, np.float32)
    for i, j in [(0, 0), (4, 5), (8, 9), (3, 7)]:
        l = tgt[i, j]
        nl = starts[l + 1] - starts[l]
        kf.gather_target(td, i, j, target_dist)
        probe = kpatch.Probe(target_dist, lv.tgt_masks[i, j], lv.tgt_height[i, j])
        scan = kpatch.Scan(posof, 3 % nl, nl)
        want = kpatch._best_match(lists[starts[l]:starts[l + 1]], lv, m, probe, np.inf, -1, scan, False)
        assert kpatch._best_by_window(groups, starts[l], starts[l + 1], lv, m, probe, np.inf, -1, scan) == want
        assert kpatch._best_by_window(collided, starts[l], starts[l + 1], lv, m, probe, np.inf, -1, scan) == want
def test_patches_are_connected_translations_with_the_guide_labels():
    src, tgt = case(7)
    _, _, (S, patch, npatch) = run_kernel(src, tgt, 3, 7)
    assert (patch > 0).all()
    assert (src[S[..., 0], S[..., 1]] == tgt).all()  # label fidelity is exact
    ii, jj = np.mgrid[0:tgt.shape[0], 0:tgt.shape[1]]
    for p in range(1, npatch + 1):
        m = patch == p
        assert ndimage.label(m)[1] == 1
        assert len({(int(a), int(b)) for a, b in zip((S[..., 0] - ii)[m], (S[..., 1] - jj)[m])}) == 1


def test_mask_only_recovers_masked_pixels():
    src, tgt = case(8)
    _, _, (S, patch, n0) = run_kernel(src, tgt, 3, 8)
    mask = np.zeros(tgt.shape, bool)
    mask[2:6, 3:8] = True
    _, _, (S2, patch2, n1) = run_kernel(src, tgt, 3, 99, mask=mask, S=S, patch=patch)
    assert np.array_equal(S2[~mask], S[~mask]) and np.array_equal(patch2[~mask], patch[~mask])
    assert (patch2[mask] > n0).all() and n1 >= 1
    assert (src[S2[..., 0], S2[..., 1]] == tgt).all()


def test_offset_components_match_scipy():
    rng = np.random.default_rng(4)
    S = rng.integers(0, 3, (30, 40, 2)).astype(np.int32)
    ii, jj = np.mgrid[0:30, 0:40]
    S[..., 0] += ii
    S[..., 1] += jj
    ids, n = kpatch.offset_components(S)
    code = (S[..., 0] - ii) * 10 + (S[..., 1] - jj)
    total = 0
    for c in np.unique(code):
        lab, k = ndimage.label(code == c)
        total += k
        for r in range(1, k + 1):
            assert len(np.unique(ids[lab == r])) == 1
    assert n == total == len(np.unique(ids))
