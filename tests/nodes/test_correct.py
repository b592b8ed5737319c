"""Correct: label fidelity, patches, repetition, determinism."""
import numba
import numpy as np
import pytest

from proxyshade.graph.testing import run_node
from proxyshade.kernels.patch import offset_components

from tests.nodes import _synthesis as T


def exemplar_coords(p):
    F = p.meta["synthesis"]["exemplar_factor"]
    return (np.rint((p["source.y"] + 0.5) / F - 0.5).astype(int), np.rint((p["source.x"] + 0.5) / F - 0.5).astype(int))


def repeats_in_window(p, half=4):
    """Share of pixels whose exemplar position is used by another pixel of their 9x9 window."""
    y, x = exemplar_coords(p)
    code = y * 100000 + x
    H, W = code.shape
    pad = np.pad(code, half, constant_values=-1)
    hit = np.zeros((H, W), bool)
    for di in range(-half, half + 1):
        for dj in range(-half, half + 1):
            if di or dj:
                hit |= pad[half + di:half + di + H, half + dj:half + dj + W] == code
    return hit.mean()


@pytest.mark.parametrize("sample", T.SAMPLES)
def test_fidelity_patches_and_repetition(sample):
    c = T.chain(sample)
    init, cor, src = c["init"], c["correct"], c["source"]
    assert cor.shape == init.shape
    assert T.label_fidelity(src, cor) >= 0.99
    y, x = exemplar_coords(cor)
    ids, n = offset_components(np.stack([y, x], -1))
    assert np.array_equal(cor["patch.id"], ids) and cor.meta["synthesis"]["patches"] == n
    # the 9x9 rejection leaves (almost) no exemplar pixel twice in a window
    assert repeats_in_window(cor) <= 0.01
    # usage: no exemplar pixel serves more than 8x its fair share, nor 0.2% of the map
    _, cnt = np.unique(y * 100000 + x, return_counts=True)
    assert cnt.max() <= 8 * cnt.mean() and cnt.max() <= 0.002 * y.size


def _top_share(p):
    """Share of the map drawn from its most-used 1 % of exemplar pixels."""
    from proxyshade.kernels.quality import repetition

    y, x = exemplar_coords(p)
    return repetition(x, y, tuple(p.meta["synthesis"]["exemplar"]))


def test_near_copy_radius_spreads_the_use_of_the_source():
    """A wide guide 4x the source's width (a synthesis 256 wide from a 128-wide exemplar):
    with the default near-copy radius the most-used 1% of exemplar pixels serve clearly
    less of the map than with the one-pixel radius of the finest level alone (seams
    joining copies of nearly the same spot), and label fidelity is unchanged."""
    src, g = T.source("renoir"), T.guide("renoir", (512, 1024))
    init = run_node("PatchInit", {}, {"guide": g, "source": src})
    near = run_node("Correct", {"near_copy": 0}, {"init": init, "source": src})
    far = run_node("Correct", {}, {"init": init, "source": src})
    assert _top_share(far) < 0.9 * _top_share(near)
    assert T.label_fidelity(src, far) >= 0.995 and T.label_fidelity(src, near) >= 0.995


@pytest.mark.parametrize("params", [{}, {"tone_match": 1.0, "match_spacing": 1}])
def test_same_result_with_one_or_two_threads(params):
    src, g = T.source("renoir"), T.guide("renoir", (256, 256))
    init = run_node("PatchInit", {}, {"guide": g, "source": src})
    a = run_node("Correct", params, {"init": init, "source": src})
    numba.set_num_threads(1)
    try:
        b = run_node("Correct", params, {"init": init, "source": src})
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    assert a.equals(b)
    if params:  # the option reaches the correction: another map than the defaults'
        assert not a.equals(run_node("Correct", {}, {"init": init, "source": src}))


def _label_luma_std(src, p):
    """Per label (pixels reading their own label): the luma std of the source read through the map."""
    y, x = exemplar_coords(p)
    F = p.meta["synthesis"]["exemplar_factor"]
    rgb, lab = src.rgb(), src["label.id"]
    yy = np.clip(np.rint((y + 0.5) * F - 0.5).astype(int), 0, lab.shape[0] - 1)
    xx = np.clip(np.rint((x + 0.5) * F - 0.5).astype(int), 0, lab.shape[1] - 1)
    luma = rgb[yy, xx] @ np.array([0.2126, 0.7152, 0.0722])
    ids = p["label.id"]
    return {int(k): luma[(ids == k) & (lab[yy, xx] == k)].std() for k in np.unique(ids) if (ids == k).sum() > 200}


def test_tone_match_keeps_more_of_patch_inits_tone_spread():
    """With ``tone_match`` each label's luma spread stays nearer PatchInit's (the drop the
    correction makes, summed over the labels, is at most two thirds of the default's)."""
    src, g = T.source("renoir"), T.guide("renoir", (256, 256))
    init = run_node("PatchInit", {}, {"guide": g, "source": src})
    s0 = _label_luma_std(src, init)
    assert len(s0) >= 3
    drop = lambda p: sum(max(s0[k] - v, 0.0) for k, v in _label_luma_std(src, p).items())  # noqa: E731
    plain = run_node("Correct", {}, {"init": init, "source": src})
    kept = run_node("Correct", {"tone_match": 1.0, "match_spacing": 1}, {"init": init, "source": src})
    assert drop(kept) <= 2 / 3 * drop(plain), (drop(plain), drop(kept))


def test_zero_passes_at_one_level_keeps_the_patch_map():
    src, g = T.source("monet"), T.guide("monet", (256, 256))
    init = run_node("PatchInit", {}, {"guide": g, "source": src})
    out = run_node("Correct", {"passes": 0, "passes_finest": 0, "coarse_size": 64}, {"init": init, "source": src})
    assert np.array_equal(out["source.x"], init["source.x"]) and np.array_equal(out["source.y"], init["source.y"])


def test_missing_synthesis_metadata():
    from proxyshade.errors import NodeInputError
    c = T.chain("renoir")
    bare = c["init"].with_channels()
    bare.meta.pop("synthesis")
    with pytest.raises(NodeInputError, match=r"^correct: input 'init' has no synthesis metadata"):
        run_node("Correct", {}, {"init": bare, "source": c["source"]}, name="correct")


@pytest.mark.parametrize("shape,target,near_copy,want", [((80, 128), (256, 256), 4, 4), ((80, 128), (540, 1024), 8, 5),
                                                         ((24, 24), (256, 256), 4, 1), ((150, 200), (256, 256), 0, 0),
                                                         ((96, 128), (96, 128), 4, 1), ((96, 128), (192, 256), 4, 4)])
def test_near_copy_radius_is_capped_by_the_exemplar_and_its_use(shape, target, near_copy, want):
    """The radius Correct asks for, at most a sixteenth of the exemplar's shorter side and
    at most the mean use of an exemplar pixel (1 for a synthesis at the photo's own size)."""
    from types import SimpleNamespace

    from proxyshade.synthesis.patches import near_copy_radius

    st = SimpleNamespace(ex_lab=np.zeros(shape, np.int32), tgt_lab=np.zeros(target, np.int32))
    assert near_copy_radius(st, near_copy) == want


def test_rare_budget_cuts_the_copies_of_the_rare_looks():
    """A wide guide 4x the source's width (a synthesis 256 wide from a 128-wide exemplar, so an
    even draw copies each source spot about twice): with a budget of half a copy the rare looks
    (each label's darkest and brightest tenth) are copied fewer times, labels kept; with a
    budget above the even draw the map is exactly the default's."""
    from proxyshade.kernels.quality import rare_looks, rare_use

    src, g = T.source("renoir"), T.guide("renoir", (512, 1024))
    init = run_node("PatchInit", {}, {"guide": g, "source": src})
    off = run_node("Correct", {}, {"init": init, "source": src})
    on = run_node("Correct", {"rare_budget": 0.5}, {"init": init, "source": src})
    rare = rare_looks(np.clip(src.rgb(), 0, 1) ** (1 / 2.2), src["label.id"])

    def copies(p):
        r = rare_use(p["source.x"], p["source.y"], p["label.id"], src["label.id"], rare)
        return sum(c for c, _, _ in r.values())

    assert copies(on) < 0.9 * copies(off)
    assert T.label_fidelity(src, on) >= 0.995
    same = run_node("Correct", {"rare_budget": 1000.0}, {"init": init, "source": src})
    assert np.array_equal(same["source.x"], off["source.x"]) and np.array_equal(same["source.y"], off["source.y"])


def test_copy_spacing_spreads_copies_in_a_large_frame_only():
    """A guide 4x the source's width and twice its height (an even draw copies each source
    spot several times): with copy_spacing the copies of the most-used source windows sit
    farther apart on the frame (``quality.copy_spacing``), labels kept; a guide of the
    source's own size gives exactly the map without it (1024 from a 1024-wide photo)."""
    from proxyshade.kernels.quality import copy_spacing

    src = T.source("renoir")
    g = T.guide("renoir", (512, 1024))
    init = run_node("PatchInit", {}, {"guide": g, "source": src})
    off = run_node("Correct", {}, {"init": init, "source": src})
    on = run_node("Correct", {"copy_spacing": 0.5}, {"init": init, "source": src})

    def spacing(p):
        r = copy_spacing(p["source.x"], p["source.y"], p["label.id"], src["label.id"], size=8)
        return np.median([q for q, _, _, _ in r.values()])

    assert spacing(on) > 1.1 * spacing(off), (spacing(off), spacing(on))
    assert T.label_fidelity(src, on) >= 0.995
    g1 = T.guide("renoir", src.shape)
    init1 = run_node("PatchInit", {}, {"guide": g1, "source": src})
    a = run_node("Correct", {}, {"init": init1, "source": src})
    b = run_node("Correct", {"copy_spacing": 0.5}, {"init": init1, "source": src})
    assert np.array_equal(a["source.x"], b["source.x"]) and np.array_equal(a["source.y"], b["source.y"])
