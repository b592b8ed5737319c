"""Magnify: output size, label fidelity on every sample, depth and provenance."""
import numpy as np
import pytest

from proxyshade.errors import NodeInputError
from proxyshade.graph.plate import Plate
from proxyshade.graph.testing import run_node
from proxyshade.kernels.lookup import lookup

from tests.nodes import _synthesis as T


@pytest.mark.parametrize("sample", T.SAMPLES)
def test_label_fidelity_on_every_sample(sample):
    c = T.chain(sample)
    mag, src = c["magnify"], c["source"]
    assert mag.shape == (512, 512)
    assert np.array_equal(mag["label.id"], c["guide"]["label.id"])
    # >= 99.5 % of output pixels read a source pixel of their guide label
    assert T.label_fidelity(src, mag) >= 0.995


def test_patches_are_magnified_and_colours_looked_up():
    c = T.chain("renoir")
    cor, src = c["correct"], c["source"]
    mag = run_node("Magnify", {"seam_passes": 0}, {"synth": cor, "source": src, "guide": c["guide"]})
    # inside a synthesis pixel the source position advances one source pixel per output pixel
    sx, sy = mag["source.x"], mag["source.y"]
    blocks_x = sx.reshape(128, 4, 128, 4)
    assert (np.diff(blocks_x, axis=3) == 1).mean() > 0.98
    assert np.allclose(mag.rgb(), lookup(src.rgb(), sx, sy))
    # source.x/y are whole source pixels at scale 1
    assert np.all(sx == np.rint(sx)) and np.all(sy == np.rint(sy))
    # a magnified synthesis pixel starts at 4 x its exemplar position
    F = cor.meta["synthesis"]["exemplar_factor"]
    ex = np.rint((cor["source.x"] + 0.5) / F - 0.5)
    same = sx[::4, ::4] == 4 * ex
    assert same.mean() > 0.98
    assert mag.meta["source"] == src.meta["source"] and mag.meta["labels"] == src.meta["labels"]


def test_seams_move_to_where_patches_agree():
    from proxyshade.kernels.seams import seam_cost
    from proxyshade.synthesis import labels as L
    from proxyshade.synthesis.patches import working_colours
    c = T.chain("renoir")
    cor, src, g, moved = c["correct"], c["source"], c["guide"], c["magnify"]
    stair = run_node("Magnify", {"seam_passes": 0}, {"synth": cor, "source": src, "guide": g})
    table = L.source_table(src)
    img = working_colours(src.rgb(), L.source_dense(src, table), 1.0, len(table))
    tgt = L.dense_guide(g["label.id"], table)

    def cost(p):
        return seam_cost(np.stack([p["source.y"], p["source.x"]], -1).astype(np.int32), img, tgt)

    # the total seam cost falls to under half the staircase's (0.17 on this chain), and no
    # fewer pixels read their own label
    assert cost(moved) < 0.5 * cost(stair)
    assert T.label_fidelity(src, moved) >= T.label_fidelity(src, stair)
    assert 0.02 < (moved["source.x"] != stair["source.x"]).mean() < 0.3


def test_seam_runs_shift_seams_the_pixel_moves_leave():
    import numba

    from proxyshade.kernels.seams import seam_cost
    from proxyshade.synthesis import labels as L
    from proxyshade.synthesis.patches import working_colours
    c = T.chain("renoir")
    cor, src, g = c["correct"], c["source"], c["guide"]
    table = L.source_table(src)
    img = working_colours(src.rgb(), L.source_dense(src, table), 1.0, len(table))
    tgt = L.dense_guide(g["label.id"], table)

    def cost(p):
        return seam_cost(np.stack([p["source.y"], p["source.x"]], -1).astype(np.int32), img, tgt)

    stair = run_node("Magnify", {"seam_passes": 0}, {"synth": cor, "source": src, "guide": g})
    pixel = run_node("Magnify", {"seam_runs": False}, {"synth": cor, "source": src, "guide": g})
    runs = []
    for t in (1, 2):
        numba.set_num_threads(t)
        try:
            runs.append(run_node("Magnify", {"seam_runs": True}, {"synth": cor, "source": src, "guide": g}))
        finally:
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    # one result for any thread count
    assert all(np.array_equal(runs[0][n], runs[1][n]) for n in ("R", "G", "B", "source.x", "source.y", "patch.id"))
    # the run moves take the seam cost well under the one-pixel moves' local minimum (on
    # this chain 0.17 -> 0.12 of the staircase's), every pixel still on its label
    assert cost(runs[0]) < 0.85 * cost(pixel) < 0.85 * 0.5 * cost(stair)
    assert T.label_fidelity(src, runs[0]) >= T.label_fidelity(src, stair)


def test_patch_shifts_align_patches_at_the_output_resolution():
    import numba

    from proxyshade.kernels.seams import seam_cost
    from proxyshade.synthesis import labels as L
    from proxyshade.synthesis.patches import working_colours
    c = T.chain("renoir")
    cor, src, g, plain = c["correct"], c["source"], c["guide"], c["magnify"]
    table = L.source_table(src)
    img = working_colours(src.rgb(), L.source_dense(src, table), 1.0, len(table))
    tgt = L.dense_guide(g["label.id"], table)

    def cost(p):
        return seam_cost(np.stack([p["source.y"], p["source.x"]], -1).astype(np.int32), img, tgt)

    runs = []
    for t in (1, 2):
        numba.set_num_threads(t)
        try:
            runs.append(run_node("Magnify", {"patch_shift": 5, "patch_adopt": 64}, {"synth": cor, "source": src, "guide": g}))
        finally:
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    shifted = runs[0]
    assert all(np.array_equal(runs[0][n], runs[1][n]) for n in ("R", "G", "B", "source.x", "source.y", "patch.id"))
    # whole patches moved by up to 5 px (or joining a neighbour) lower the seam cost below the seam moves' own
    # local minimum, every pixel still on its label, the patches' colours read at their place
    assert cost(shifted) < 0.9 * cost(plain)
    assert T.label_fidelity(src, shifted) >= T.label_fidelity(src, plain)
    assert np.allclose(shifted.rgb(), lookup(src.rgb(), shifted["source.x"], shifted["source.y"]))
    moved = (shifted["source.x"] != plain["source.x"]) | (shifted["source.y"] != plain["source.y"])
    assert 0.05 < moved.mean() < 0.9


def test_depth_is_carried_and_checked():
    c = T.chain("renoir")
    z = np.linspace(1, 50, 512 * 512, dtype=np.float32).reshape(512, 512)
    z[:10] = np.inf  # sky: allowed
    depth = Plate({"Z": z, "P.Y": z * 0.5})
    out = run_node("Magnify", {}, {"synth": c["correct"], "source": c["source"], "guide": c["guide"], "depth": depth})
    assert np.array_equal(out["Z"], z) and np.array_equal(out["P.Y"], z * 0.5)
    z2 = z.copy()
    z2[100, 3] = np.nan
    with pytest.raises(NodeInputError, match=r"^mag: input 'depth' channel Z has 1 NaN pixel"):
        run_node("Magnify", {}, {"synth": c["correct"], "source": c["source"], "guide": c["guide"],
                                 "depth": Plate({"Z": z2})}, name="mag")


def test_guide_of_another_size_is_refused():
    c = T.chain("renoir")
    g = T.guide("renoir", (256, 256))
    with pytest.raises(NodeInputError, match=r"^mag: guide is 256x256 but synth is 128x128 at factor 4"):
        run_node("Magnify", {}, {"synth": c["correct"], "source": c["source"], "guide": g}, name="mag")


def test_scale_reads_the_source_between_pixels():
    """With scale 0.5 the texture is twice as large: source.x advances half a pixel."""
    src, g = T.source("creek"), T.guide("creek", (256, 256))
    init = run_node("PatchInit", {"scale": 0.5, "factor": 2}, {"guide": g, "source": src})
    mag = run_node("Magnify", {}, {"synth": init, "source": src, "guide": g})
    assert np.median(np.diff(mag["source.x"], axis=1)) == 0.5
    assert T.label_fidelity(src, mag) >= 0.995


def test_odd_non_square_output_size():
    """A guide whose sides are not multiples of the factor: synthesis rounds up, the
    output is cropped back to the guide."""
    src, g = T.source("renoir"), T.guide("renoir", (301, 517))
    init = run_node("PatchInit", {}, {"guide": g, "source": src})
    assert init.shape == (76, 130)
    cor = run_node("Correct", {}, {"init": init, "source": src})
    mag = run_node("Magnify", {}, {"synth": cor, "source": src, "guide": g})
    assert mag.shape == (301, 517)
    assert T.label_fidelity(src, mag) >= 0.995


def test_spread_loss_bounds_what_the_patch_shifts_take_from_a_labels_tone_spread():
    from proxyshade.synthesis import labels as L
    from proxyshade.synthesis.patches import working_colours
    c = T.chain("renoir")
    cor, src, g = c["correct"], c["source"], c["guide"]
    table = L.source_table(src)
    img = working_colours(src.rgb(), L.source_dense(src, table), 1.0, len(table)).astype(np.float64)
    tone, lab = img.sum(-1), L.source_dense(src, table)
    tgt = L.dense_guide(g["label.id"], table)

    def ratios(p):  # each label's tone variance in the output over the photo label's
        t = tone[p["source.y"].astype(int), p["source.x"].astype(int)]
        return np.array([t[tgt == k].var() / tone[lab == k].var() for k in np.unique(tgt)])

    # the patch shifts' spread budget: none kept (1) loses more than none lost (0)
    shifted = {q: ratios(run_node("Magnify", {"patch_shift": 5, "patch_adopt": 64, "spread_loss": q},
                                  {"synth": cor, "source": src, "guide": g})) for q in (0.0, 1.0)}
    assert (shifted[0.0] >= shifted[1.0] - 1e-3).all() and (shifted[0.0] - shifted[1.0]).max() > 0.01


@pytest.mark.parametrize("one", [True, False], ids=["guide-is-depth", "guide-and-depth"])
def test_pass_through_channels_read_back_after_the_magnification_are_the_same_plate(tmp_path, monkeypatch, one):
    """In a run the channels Magnify only passes through (the guide's label.id, the depth
    channels) are let go through the magnification and read back from their cache entries
    (``Context.read_back``; one read where guide and depth are one plate, as DepthExtend's
    in graphs/first_frame.yaml): the plate is bit for bit the one computed holding them
    (``run_node``, no cache)."""
    from proxyshade.graph.graph import Graph

    c = T.chain("renoir", shape=(96, 128))
    g, rng = c["guide"], np.random.default_rng(3)
    extra = {n: rng.standard_normal(g.shape).astype(np.float32) for n in ("Z", "P.X", "N.X")}
    extra["object.id"] = rng.integers(0, 9, g.shape, dtype=np.uint32)
    depth = Plate({**({"label.id": g["label.id"]} if one else {}), **extra}, {**g.meta, "camera": {"fov": 40.0}})
    guide = depth if one else g
    want = run_node("Magnify", {}, {"synth": c["correct"], "source": c["source"], "guide": guide, "depth": depth})
    asked = T.spy_read_back(monkeypatch)
    T.Given.plates = {"depth": depth, "guide": guide, "cor": c["correct"], "src": c["source"]}
    gr = Graph(graph_dir=tmp_path, frames=(1, 1), cache=tmp_path / "cache")
    for n in T.Given.plates:
        gr.add(n, T.Given, {"name_": n})
    gr.add("mag", "Magnify", {}, {"synth": "cor", "source": "src", "guide": "depth" if one else "guide", "depth": "depth"})
    gr.run()
    depth_names = ["N.X", "P.X", "Z", "object.id"]
    assert asked == ([sorted(["label.id", *depth_names])] if one else [["label.id"], depth_names])
    got = gr.value("mag")
    assert sorted(got.names()) == sorted(want.names()) and got.equals(want) and got.meta == want.meta
    assert np.array_equal(got["Z"], extra["Z"]) and np.array_equal(got["label.id"], g["label.id"])
