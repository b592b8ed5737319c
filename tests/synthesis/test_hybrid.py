"""synthesis.hybrid: the weight controls (per pixel, per level), the symmetric option, the
bundled sets' split and the single-exemplar texture core."""
from pathlib import Path

import numpy as np
import pytest

from proxyshade.errors import NodeInputError
from proxyshade.graph.plate import Plate
from proxyshade.graph.testing import run_node
from proxyshade.synthesis import hybrid as H

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def analysis():
    rng = np.random.default_rng(3)
    a = np.cumsum(rng.random((32, 32, 3)), 1).astype(np.float32) / 32  # two different exemplars
    b = rng.random((32, 32, 3)).astype(np.float32)
    return H.analyse(np.concatenate([a, b], 1), 32, levels=3, descriptor_levels=2, q=2, iterations=2, seed=0)


def test_ramp_map_goes_from_the_first_to_the_last_exemplar():
    w = H.ramp_map((4, 10), [2, 0], 3)
    assert w.shape == (4, 10, 3)
    np.testing.assert_allclose(w.sum(-1), 1.0)
    np.testing.assert_allclose(w[:, :, 1], 0.0)
    assert w[0, 0, 2] > 0.9 and w[0, -1, 0] > 0.9 and (np.diff(w[0, :, 0]) > 0).all()
    np.testing.assert_allclose(H.ramp_map((10, 4), [0, 1], 2, axis=0)[:, 0], w[0, :, [2, 0]].T)


def test_a_weight_map_steers_each_side_to_its_exemplar(analysis):
    shape = (32, 64)
    S = H.synthesize(analysis, shape, jitter_threshold=0.1, seed=1, weights=np.ones(2), passes=2,
                     weight_map=H.ramp_map(shape, [0, 1], 2))
    e = S[..., 1] // 32
    assert e[:, :12].mean() < 0.1 and e[:, -12:].mean() > 0.9 and 0.3 < e.mean() < 0.7
    flat = H.synthesize(analysis, shape, jitter_threshold=0.1, seed=1, weights=np.ones(2), passes=2)[..., 1] // 32
    assert abs(flat[:, :12].mean() - flat[:, -12:].mean()) < 0.5  # without the map: no such sides


def test_smooth_noise_is_uniform_smooth_and_seeded():
    u = H.smooth_noise((64, 96), 8, seed=5)
    assert u.shape == (64, 96) and 0 < u.min() and u.max() < 1
    np.testing.assert_allclose(np.sort(u.ravel()), (np.arange(u.size) + 0.5) / u.size)  # uniform: ranks
    step = np.abs(np.diff(u, axis=1)).mean()
    assert step < 0.1  # smooth over the cell: an independent draw per pixel steps by 1/3 on average
    assert step > np.abs(np.diff(H.smooth_noise((64, 96), 32, seed=5), axis=1)).mean()  # a larger cell: smoother
    np.testing.assert_array_equal(H.smooth_noise((64, 96), 8, seed=5), u)
    assert (H.smooth_noise((64, 96), 8, seed=6) != u).any()


def test_dithered_map_prefers_by_the_cumulative_weights():
    w = H.ramp_map((40, 50), [0, 2], 3)
    d = H.dithered_map(w, 4, seed=1, others=0.25)
    u = H.smooth_noise((40, 50), 4, seed=1)
    pick = np.where(u < w[..., 0], 0, 2)  # written out for two exemplars: the first below its weight
    np.testing.assert_array_equal(d.argmax(-1), pick)
    assert set(np.unique(d[..., [0, 2]])) <= {0.0, 0.25, 1.0} and (d[..., 1] == 0).all()  # weight 0 stays 0
    np.testing.assert_array_equal(d[..., 0] == 0, w[..., 0] == 0)


def test_a_dithered_ramp_mixes_each_column_by_its_weight(analysis):
    shape = (64, 128)
    want = H.ramp_map(shape, [0, 1], 2)[0, :, 1]
    share = {}
    for cell in (0, 4):
        e = np.concatenate([H.synthesize(analysis, shape, jitter_threshold=0.1, seed=s, weights=np.ones(2), passes=2,
                                         weight_map=H.ramp_weights(shape, [0, 1], 2, cell=cell, seed=s))[..., 1] // 32
                            for s in (1, 2)])
        share[cell] = np.array([e[:, a:a + 16].mean() for a in range(0, 128, 16)])
    w = np.array([want[a:a + 16].mean() for a in range(0, 128, 16)])
    assert np.abs(share[4] - w).mean() < 0.1 and np.abs(share[4] - w).max() < 0.2
    assert np.abs(share[4] - w).mean() < np.abs(share[0] - w).mean()  # the plain map switches more sharply
    assert (np.diff(share[4]) > -0.1).all()  # rises across the output


def test_a_random_layout_is_seeded_and_stays_in_the_boxes(analysis):
    shape = (48, 80)  # larger than the 32² boxes: the exemplar layout tiles
    tiled = [H.synthesize(analysis, shape, jitter_threshold=0.0, seed=s, weights=np.ones(2), passes=1) for s in (1, 2)]
    np.testing.assert_array_equal(tiled[0], tiled[1])  # J = 0: the seed does not act
    rand = [H.synthesize(analysis, shape, jitter_threshold=0.0, seed=s, weights=np.ones(2), passes=1, layout="random") for s in (1, 2)]
    assert (rand[0] != rand[1]).mean() > 0.5  # the seed draws the coarsest layout
    for S in rand:
        assert (S[..., 0] >= 0).all() and (S[..., 0] < 32).all() and (S[..., 1] >= 0).all() and (S[..., 1] < 64).all()


def test_level_weights_take_layout_from_one_exemplar_and_detail_from_another(analysis):
    S = H.synthesize(analysis, (32, 32), jitter_threshold=0.0, seed=1, weights=np.ones(2), passes=1,
                     level_weights=[[1, 0], [0, 1]])
    assert (S[..., 1] // 32 == 1).all()  # the finer levels: exemplar 2 only
    S1 = H.synthesize(analysis, (32, 32), jitter_threshold=0.0, seed=1, weights=np.ones(2), passes=1, level_weights=[[1, 0]])
    assert (S1[..., 1] // 32 == 0).all()  # the last row repeats
    with pytest.raises(NodeInputError, match="row 2 is all zero"):
        H.check_level_weights([[1, 1], [0, 0]], 2)
    with pytest.raises(NodeInputError, match="row 1 is \\[1\\], not 2 weights"):
        H.check_level_weights([[1]], 2)


def test_symmetric_state_mirrors_the_left_half_inside_each_box(analysis):
    S = H.synthesize(analysis, (32, 31), jitter_threshold=0.3, seed=2, weights=np.ones(2), passes=1, symmetric=True)
    left, right = S[:, :15], S[:, 16:][:, ::-1]
    np.testing.assert_array_equal(right[..., 0], left[..., 0])
    np.testing.assert_array_equal(right[..., 1] // 32, left[..., 1] // 32)
    np.testing.assert_array_equal(right[..., 1] % 32, 31 - left[..., 1] % 32)


def test_split_cuts_a_strip_into_equal_exemplars_and_refuses_a_bad_width():
    p = Plate({"R": np.arange(12, dtype=np.float32).reshape(2, 6)}, {"labels": []})
    parts = H.split_plate("set", p, 3)
    assert [n for n, _ in parts] == ["set.1", "set.2", "set.3"]
    np.testing.assert_array_equal(parts[1][1]["R"], [[2, 3], [8, 9]])
    with pytest.raises(NodeInputError, match="not 4 equal exemplars"):
        H.split_plate("set", p, 4)


def test_bundled_sets_pack_into_three_exemplar_atlases():
    for name in ("foliage", "gravel", "brick"):
        src = run_node("SourceRead", {"table": f"samples/hybrids/{name}/source.yaml"}, graph_dir=ROOT)
        atlas = run_node("ExemplarAtlas", {"size": [32, 32], "split": 3}, {"exemplar1": src})
        assert atlas.shape == (32, 96) and [b["input"] for b in atlas.meta["atlas"]] == [
            "exemplar1.1", "exemplar1.2", "exemplar1.3"]


def test_plain_texture_is_a_new_arrangement_not_the_tiled_exemplar():
    rng = np.random.default_rng(5)
    ex = rng.random((40, 40, 3)).astype(np.float32)
    r = H.plain_texture(ex, (64, 80), seed=1, levels=3, iterations=2)
    sx, sy = r["sx"].astype(int), r["sy"].astype(int)
    assert r["rgb"].shape == (64, 80, 3) and sx.max() < 40 and sy.max() < 40
    np.testing.assert_array_equal(r["rgb"], ex[sy, sx])
    ii, jj = np.mgrid[0:64, 0:80]
    assert ((sy == ii % 40) & (sx == jj % 40)).mean() < 0.5
    r2 = H.plain_texture(ex, (64, 80), seed=1, levels=3, iterations=2)
    np.testing.assert_array_equal(r2["sx"], r["sx"])


def test_variants_widen_a_source_with_rearranged_copies_that_keep_colour_and_label_together(tmp_path):
    from proxyshade.io.images import write_png

    rng = np.random.default_rng(8)
    cell = rng.integers(0, 200, (8, 12, 3))  # a texture: a repeated cell with noise, many places match
    photo = (np.tile(cell, (5, 4, 1)) + rng.integers(0, 40, (40, 48, 3))).astype(np.uint8)
    labels = np.zeros((40, 48, 3), np.uint8)
    labels[:20] = (255, 255, 255)
    labels[20:] = (0, 255, 0)
    write_png(tmp_path / "p.png", photo)
    write_png(tmp_path / "l.png", labels)
    (tmp_path / "source.yaml").write_text("image: p.png\nlabels_map: l.png\nlabels:\n  sky: {id: 1, color: '#ffffff'}\n"
                                          "  grass: {id: 2, color: '#00ff00'}\n")
    plain = run_node("SourceRead", {"table": "source.yaml"}, graph_dir=tmp_path)
    wide = run_node("SourceRead", {"table": "source.yaml", "variants": 2}, graph_dir=tmp_path)
    assert wide.shape == (40, 144) and wide.meta["source"]["variants"] == 2
    assert wide.meta["source"]["size"] == [144, 40]
    for c in ("R", "G", "B", "label.id"):
        np.testing.assert_array_equal(wide[c][:, :48], plain[c])
        ox, oy = wide["origin.x"].astype(int), wide["origin.y"].astype(int)
        np.testing.assert_array_equal(wide[c], plain[c][oy, ox])  # colour and label from the same photo pixel
    ii, jj = np.mgrid[0:40, 0:48]
    for k in (1, 2):
        same = (wide["origin.x"][:, 48 * k:48 * (k + 1)] == jj) & (wide["origin.y"][:, 48 * k:48 * (k + 1)] == ii)
        assert same.mean() < 0.9  # a variant, not a copy
    assert (wide["origin.x"][:, 48:96] != wide["origin.x"][:, 96:]).any()  # two different variants


def test_label_window_finds_the_window_richest_in_a_label():
    ids = np.ones((60, 80), np.int64)
    ids[40:52, 10:70] = 3  # a wide band
    ids[:, 75:] = 2  # a thin column
    y0, x0, h, w = H.label_window(ids, 3, 600, smallest=8)
    assert h * w <= 1.2 * 600 and (ids[y0:y0 + h, x0:x0 + w] == 3).mean() > 0.9 and w > h
    y0, x0, h, w = H.label_window(ids, 2, 240, smallest=5)
    assert (ids[y0:y0 + h, x0:x0 + w] == 2).mean() == 1.0 and h > w
    for lab, area in ((3, 600), (2, 240)):  # the best over every position and aspect, written out
        best = 0.0
        for aspect in (1 / 8, 1 / 4, 1 / 2, 1, 2, 4, 8):
            hh = int(min(60, max(8 if lab == 3 else 5, round(np.sqrt(area / aspect)))))
            ww = int(min(80, max(8 if lab == 3 else 5, round(area / hh))))
            for y in range(60 - hh + 1):
                for x in range(80 - ww + 1):
                    best = max(best, (ids[y:y + hh, x:x + ww] == lab).mean())
        y0, x0, h, w = H.label_window(ids, lab, area, smallest=8 if lab == 3 else 5)
        assert (ids[y0:y0 + h, x0:x0 + w] == lab).mean() == best


def test_even_variants_give_a_small_label_as_much_room_as_a_large_one(tmp_path):
    from proxyshade.io.images import write_png

    rng = np.random.default_rng(11)
    photo = rng.integers(0, 255, (112, 128, 3)).astype(np.uint8)
    labels = np.zeros((112, 128, 3), np.uint8)
    labels[:] = (0, 255, 0)
    labels[84:, :] = (0, 0, 255)  # water: a band, a quarter of the photo
    write_png(tmp_path / "p.png", photo)
    write_png(tmp_path / "l.png", labels)
    (tmp_path / "source.yaml").write_text("image: p.png\nlabels_map: l.png\nlabels:\n"
                                          "  grass: {id: 1, color: '#00ff00'}\n  water: {id: 2, color: '#0000ff'}\n")
    shares = {}
    for mix in ("even", "photo"):
        wide = run_node("SourceRead", {"table": "source.yaml", "variants": 2, "variant_labels": mix},
                        graph_dir=tmp_path)
        assert wide.shape == (112, 384)
        ox, oy = wide["origin.x"].astype(int), wide["origin.y"].astype(int)
        np.testing.assert_array_equal(wide["label.id"], wide["label.id"][:, :128][oy, ox])  # labels at the pointers
        shares[mix] = (wide["label.id"][:, 128:] == 2).mean()
    # even: half of each variant from a window mostly water (33 rows at least: 28 / 33 water)
    assert shares["even"] > 0.38 and shares["photo"] < 0.3


def test_texture_synth_runs_the_hybrid_core(tmp_path):
    from proxyshade.io.images import write_png
    from proxyshade.io.source import srgb_to_linear

    rng = np.random.default_rng(9)
    ex8 = rng.integers(0, 256, (40, 40, 3)).astype(np.uint8)
    write_png(tmp_path / "ex.png", ex8)
    out = run_node("TextureSynth", {"exemplar": "ex.png", "size": "48", "method": "hybrid"}, graph_dir=tmp_path)
    assert out.shape == (48, 48) and out.meta["texture"]["method"] == "hybrid"
    sx, sy = out["source.x"].astype(int), out["source.y"].astype(int)
    np.testing.assert_allclose(np.stack([out["R"], out["G"], out["B"]], -1), srgb_to_linear(ex8)[sy, sx])
