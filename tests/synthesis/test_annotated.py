"""synthesis.annotated: two clusters of a two-material source; a target annotation between
them is flagged missing and interpolated (CIELAB merge), the ends copy their material;
binary weights are one-hot; the analogies and single-cluster baselines use one cluster."""
import numpy as np
import pytest

from proxyshade.synthesis import annotated as sa


def two_materials(seed=0, h=40, w=64):
    rng = np.random.default_rng(seed)
    g = rng.random((h, w))
    rgb = np.zeros((h, w, 3), np.float32)
    rgb[:, : w // 2] = (0.2 + 0.3 * g[:, : w // 2, None]) * np.array([1.0, 0.3, 0.2])  # reddish gravel
    rgb[:, w // 2:] = (0.2 + 0.3 * g[:, w // 2:, None]) * np.array([0.2, 1.0, 0.3])  # green grass
    ann = np.zeros((h, w, 1))
    ann[:, w // 2:] = 1.0
    return rgb, ann


T = np.linspace(0, 1, 48)


def target(h=24):
    """A ramp 0 -> 1 over 48 columns (gravel to grass, the paper's Fig. 15)."""
    return np.repeat(T[None, :, None], h, axis=0)


P = dict(levels=2, em=1, iterations=3, bandwidth=0.3)


@pytest.fixture(scope="module")
def full():
    rgb, ann = two_materials()
    return sa.synthesize(rgb, np.ones(rgb.shape[:2], np.float32), ann, np.ones(rgb.shape[:2], bool), target(),
                         sa.AnnotatedParams(**P))


def test_two_clusters_and_missing_only_between_them(full):
    assert full["n_clusters"] == 2
    m = full["missing"]
    inside = (T <= 0.09) | (T >= 0.91)
    between = (T >= 0.15) & (T <= 0.85)
    assert m[:, between].min() == 1 and m[:, inside].max() == 0
    W = full["weights"]
    np.testing.assert_allclose(W.sum(2), 1)
    assert W[:, T <= 0.06, 0].min() > 0.95 and W[:, T >= 0.94, 1].min() > 0.95  # inside a ball: that cluster
    np.testing.assert_allclose(W[:, np.abs(T - 0.5) < 0.03, 0], 0.5, atol=0.1)  # halfway: about equal


def test_ends_copy_their_material_and_the_middle_is_interpolated(full):
    rgb, ann = two_materials()
    left, right = rgb[:, :32].mean((0, 1)), rgb[:, 32:].mean((0, 1))
    out = full["rgb"]
    a, mid, b = out[4:-4, :4].mean((0, 1)), out[4:-4, 22:26].mean((0, 1)), out[4:-4, 44:].mean((0, 1))
    np.testing.assert_allclose(a, left, rtol=0.25)
    np.testing.assert_allclose(b, right, rtol=0.25)
    # the middle is neither: its red and green lie strictly between the two materials'
    assert right[0] < mid[0] < left[0] and left[1] < mid[1] < right[1]
    # copied pixels of the ends come from the right half of the source
    assert np.all(full["sx"][:, :4] < 32) and np.all(full["sx"][:, 44:] >= 32)


def test_binary_weights_are_one_hot_and_baselines_use_one_cluster():
    rgb, ann = two_materials()
    one = np.ones(rgb.shape[:2], np.float32)
    use = np.ones(rgb.shape[:2], bool)
    r = sa.synthesize(rgb, one, ann, use, target(), sa.AnnotatedParams(mode="binary", **P))
    assert set(np.unique(r["weights"])) == {0.0, 1.0} and np.all(r["weights"].sum(2) == 1)
    for mode in ("single", "analogies"):
        r = sa.synthesize(rgb, one, ann, use, target(), sa.AnnotatedParams(mode=mode, **P))
        assert r["n_clusters"] == 1 and np.all(r["cluster"] == 1)


def test_within_one_exemplar_against_a_window_loop():
    rng = np.random.default_rng(3)
    ids = np.repeat(np.repeat(rng.integers(0, 3, (4, 5)), 5, 0), 4, 1).astype(np.uint32)
    got = sa.within_one_exemplar(ids, 1)
    H, W = ids.shape
    for i in range(H):
        for j in range(W):
            win = ids[max(i - 1, 0):i + 2, max(j - 1, 0):j + 2]
            assert got[i, j] == (ids[i, j] > 0 and np.all(win == ids[i, j]))


def test_annotations_in_the_distance_keep_copies_near_their_annotation():
    """A source whose annotation is a smooth ramp within one material: with the annotations
    in the patch distance the copied pixels' annotations follow the target's more closely
    than with the paper's distance (annotations only through the ε-balls)."""
    rng = np.random.default_rng(1)
    h, w = 48, 64
    ramp = np.repeat(np.linspace(0, 1, w)[None, :], h, 0)
    rgb = ((0.2 + 0.3 * rng.random((h, w)))[..., None] * np.array([0.4, 0.8, 0.3])).astype(np.float32)
    ann = ramp[..., None]
    tgt = np.repeat(np.linspace(0.1, 0.9, 40)[None, :, None], 24, axis=0)
    err = {}
    for aw in (0.0, 1.5):
        r = sa.synthesize(rgb, np.ones((h, w), np.float32), ann, np.ones((h, w), bool), tgt,
                          sa.AnnotatedParams(**dict(P, eps=0.3), ann_distance=aw))
        got = ann[r["sy"].astype(int), r["sx"].astype(int), 0]
        err[aw] = float(np.abs(got - tgt[..., 0]).mean())
    assert err[1.5] < 0.7 * err[0.0], err
