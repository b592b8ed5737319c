"""AnnotatedSynth: the output follows the target's annotations, 1 and 2 threads give the
same plate, and each bad input is a one-line error naming the node, the channel and the fix."""
import numba
import numpy as np
import pytest

from proxyshade.errors import NodeInputError
from proxyshade.graph.plate import Plate
from proxyshade.graph.testing import run_node

N = 48
FAST = dict(levels=2, em=1, iterations=3, bandwidth=0.3)


def source(seed=0, n=N):
    """A 'material' whose brightness follows ann.light and whose grain follows ann.scale."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:n, 0:n] / (n - 1)
    light, scale = xx, yy
    grain = rng.random((n, n))
    v = (0.05 + 0.6 * light * (0.6 + 0.4 * grain)).astype(np.float32)
    ch = {"R": v, "G": 1.3 * v, "B": 0.5 * v, "ann.light": light.astype(np.float32),
          "ann.scale": scale.astype(np.float32)}
    return Plate(ch, {})


def target(n=N):
    yy, xx = np.mgrid[0:n, 0:n] / (n - 1)
    return Plate({"ann.light": (1 - yy).astype(np.float32), "ann.scale": xx.astype(np.float32)}, {})


def test_output_follows_the_target_annotation():
    out = run_node("AnnotatedSynth", FAST, {"source": source(), "target": target()})
    assert set(out.names()) >= {"R", "G", "B", "A", "source.x", "source.y", "cluster.id", "missing"}
    assert out["cluster.id"].dtype == np.uint32 and out["cluster.id"].min() >= 1
    # the light annotation runs top (1) to bottom (0) in the target: so must the brightness
    rows = out["G"].mean(axis=1)
    assert rows[:8].mean() > 3 * rows[-8:].mean()
    # copied source pixels carry a light annotation near the target's (inside the ε-balls)
    light_src = source()["ann.light"][out["source.y"].astype(int), out["source.x"].astype(int)]
    assert np.abs(light_src - target()["ann.light"]).mean() < 0.15


def two_clusters(n=N):
    """Two materials (light 0 left, 1 right) and a target ramp between them: two clusters,
    eq. 2 weights, the CIELAB merge and the screened Poisson solve all run."""
    s = source(n=n)
    light = (np.mgrid[0:n, 0:n][1] >= n // 2).astype(np.float32)
    return (s.with_channels({"ann.light": light, "G": s["G"] * (0.5 + light)}),
            target(n).with_channels({"ann.light": np.repeat(np.linspace(0, 1, n, dtype=np.float32)[None], n, 0)}))


def test_same_plate_with_one_and_two_threads():
    src, tgt = two_clusters()
    outs = []
    for t in (1, 2):
        numba.set_num_threads(t)
        try:
            outs.append(run_node("AnnotatedSynth", FAST, {"source": src, "target": tgt}))
        finally:
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    assert set(np.unique(outs[0]["cluster.id"])) == {1, 2}
    assert outs[0].equals(outs[1])


def test_target_mask_limits_the_output_and_the_range_check():
    src, tgt = two_clusters()
    mask = np.zeros((N, N), np.float32)
    mask[10:30, 5:40] = 1
    light = tgt["ann.light"].copy()
    light[~(mask > 0)] = 7.0  # outside the mask: not a target, not checked
    out = run_node("AnnotatedSynth", FAST, {"source": src, "target": tgt.with_channels({"ann.light": light, "mask": mask})})
    assert np.all(out["A"][mask == 0] == 0) and np.all(out["G"][mask == 0] == 0)
    assert out["A"][mask > 0].min() > 0.99 and out["G"][mask > 0].min() > 0


def test_background_is_kept_outside_the_mask_and_covered_inside():
    src, tgt = two_clusters()
    mask = np.zeros((N, N), np.float32)
    mask[10:30, 5:40] = 1
    rng = np.random.default_rng(4)
    bg = Plate({c: rng.random((N, N)).astype(np.float32) for c in ("R", "G", "B")} | {"Z": np.ones((N, N), np.float32)},
               {"frame": 1})
    alone = run_node("AnnotatedSynth", FAST, {"source": src, "target": tgt.with_channels({"mask": mask})})
    out = run_node("AnnotatedSynth", FAST, {"source": src, "target": tgt.with_channels({"mask": mask}), "background": bg})
    m = mask > 0
    for c in ("R", "G", "B"):
        np.testing.assert_array_equal(out[c][~m], bg[c][~m])
        np.testing.assert_allclose(out[c][m], alone[c][m], atol=1e-6)
    assert np.all(out["Z"] == 1) and np.all(out["A"] == 1) and out.meta["frame"] == 1
    with pytest.raises(NodeInputError, match="background is 24x48, the target 48x48; render the proxy"):
        run_node("AnnotatedSynth", FAST, {"source": src, "target": tgt,
                                          "background": Plate({c: bg[c][:, :24].copy() for c in "RGB"}, {})})


def _err(src, tgt, match, params=FAST):
    with pytest.raises(NodeInputError, match=match) as e:
        run_node("AnnotatedSynth", params, {"source": src, "target": tgt}, name="synth")
    msg = str(e.value)
    assert msg.startswith("synth:") and "\n" not in msg and ";" in msg  # node, then what and the fix
    return msg


def test_annotation_names_differ():
    t = target()
    t = Plate({"ann.light": t["ann.light"], "ann.depth": t["ann.scale"]}, {})
    _err(source(), t, "ann.scale.*ann.depth|differ")


@pytest.mark.parametrize("bad", [1.5, -0.2])
def test_values_outside_unit_range(bad):
    t = target()
    v = t["ann.light"].copy()
    v[3, 3] = bad
    _err(source(), t.with_channels({"ann.light": v}), "ann.light.*outside \\[0, 1\\]")


def test_nan():
    s = source()
    v = s["ann.scale"].copy()
    v[10, 10] = np.nan
    _err(s.with_channels({"ann.scale": v}), target(), "ann.scale.*NaN")


def test_target_outside_source_range():
    s = source()
    _err(s.with_channels({"ann.light": 0.5 * s["ann.light"]}), target(), "ann.light.*outside the source's range")


def test_too_few_usable_pixels():
    s = source()
    mask = np.zeros((N, N), np.float32)
    mask[:20, :20] = 1
    _err(s.with_channels({"mask": mask}), target(), "fewer than 1000")


def test_atlas_patches_stay_inside_one_exemplar():
    src, tgt = two_clusters()
    ex = np.where(np.mgrid[0:N, 0:N][1] < 12, 1, 2).astype(np.uint32)  # boundary at column 12
    free = run_node("AnnotatedSynth", FAST, {"source": src, "target": tgt})["source.x"]
    assert np.any((free >= 10) & (free <= 13))  # without exemplar.id, copies straddle it
    out = run_node("AnnotatedSynth", FAST, {"source": src.with_channels({"exemplar.id": ex}), "target": tgt})
    sx = out["source.x"]
    assert np.all((sx <= 9) | (sx >= 14))  # no 5x5 patch centred within 2 px of the boundary
