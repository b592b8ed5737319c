"""BtfSynth: sources and colours agree, the support comes first and the others follow it,
the three modes differ as the method says, bad inputs, and 1 vs 2 threads (CLI, EXR)."""
import subprocess
import sys

import numpy as np
import pytest
import yaml

from proxyshade.errors import UserError
from proxyshade.graph.plate import Plate
from proxyshade.graph.testing import run_node
from proxyshade.io.exr import read_plate
from proxyshade.synthesis import btf
from tests.nodes._btf import ROOT, SCENE, capture

SMALL = {"size": [64, 64], "levels": 2, "seed": 5}


@pytest.fixture(scope="module")
def stack():
    return capture(48, 35, 70, [0, 90])


@pytest.fixture(scope="module")
def results(stack):
    return {m: run_node("BtfSynth", dict(SMALL, mode=m), {"stack": stack}) for m in btf.MODES}


def _maps(plate):
    V = len(plate.meta["views"])
    return (np.stack([plate[f"v{n}.sy"] for n in range(V)]).astype(np.int64),
            np.stack([plate[f"v{n}.sx"] for n in range(V)]).astype(np.int64))


def test_each_view_is_its_input_at_its_sources(stack, results):
    views, imgs = btf.stack_arrays(stack)
    for plate in results.values():
        assert plate.shape == (64, 64) and plate.meta["views"] == views
        qy, qx = _maps(plate)
        for n in range(len(views)):
            for c, ch in enumerate("RGB"):
                assert np.array_equal(plate[f"v{n}.{ch}"], imgs[n, qy[n], qx[n], c])


def test_modes_share_the_support_and_differ_as_the_method_says(stack, results):
    views, imgs = btf.stack_arrays(stack)
    maps = {m: _maps(p) for m, p in results.items()}
    s = results["sequential"].meta["btf"]["support"]
    assert views[s]["slant"] == 0  # the frontal view by default
    for m in btf.MODES:  # the support is synthesized first, the same way in every mode
        assert np.array_equal(maps[m][0][s], maps["sequential"][0][s])
    cy, cx = maps["columns"]
    assert all(np.array_equal(cy[n], cy[s]) and np.array_equal(cx[n], cx[s]) for n in range(len(views)))
    others = [n for n in range(len(views)) if n != s]
    ec = {m: btf.consistency_error(imgs, s, *maps[m])[others].mean() for m in btf.MODES}
    es = {m: btf.seam_error(imgs, *maps[m])[others].mean() for m in btf.MODES}
    assert ec["columns"] == 0.0
    assert ec["sequential"] < 0.5 * ec["independent"], ec
    assert es["sequential"] < es["columns"], es
    # sequential views are their own: not the support's sources everywhere
    qy, qx = maps["sequential"]
    assert any((qy[n] != qy[s]).any() or (qx[n] != qx[s]).any() for n in others)


def test_measures_on_hand_made_maps():
    img = np.zeros((1, 4, 4, 3), np.float32)
    img[0, :, 2:] = 1.0  # right half white
    qy = np.zeros((1, 2, 2), np.int64)
    qx = np.array([[[0, 1], [2, 2]]], np.int64)  # top row coherent, bottom row repeats a pixel
    es = btf.seam_error(img, qy, qx)
    # seams: both vertical edges (source rows differ by 0, not 1: black over white, a jump of √3 each)
    # and the bottom horizontal edge (source columns differ by 0, not 1: white next to white)
    assert es[0] == pytest.approx((np.sqrt(3) + np.sqrt(3) + 0) / 3)
    assert btf.consistency_error(img, 0, qy, qx)[0] == 0.0


def test_bad_inputs_are_one_line_errors(stack):
    tiny = capture(16, 35, 70, [0], 64)
    with pytest.raises(UserError, match=r"node: stack: the 16x16 views are smaller than the disk at the coarsest "
                                        r"level \(25 pixels across.*use fewer levels"):
        run_node("BtfSynth", {"levels": 3, "radius": 3}, {"stack": tiny})
    bad = stack.with_channels({"v2.G": np.where(np.arange(48)[None] == 7, np.nan, stack["v2.G"]).astype(np.float32)})
    with pytest.raises(UserError, match=r"node: stack: view 2 has 48 NaN/Inf value\(s\), first at x=7 y=0; clean"):
        run_node("BtfSynth", SMALL, {"stack": bad})
    with pytest.raises(UserError, match=r"meta\['views'\].*connect a BtfRender or BtfRead"):
        run_node("BtfSynth", SMALL, {"stack": Plate({"R": stack["v0.R"]})})


def test_same_stack_exr_with_one_and_two_threads(tmp_path):
    graph = tmp_path / "g.yaml"
    graph.write_text(yaml.safe_dump({"format": "proxyshade/1", "frames": 1, "nodes": {
        "capture": {"type": "BtfRender", "params": {"scene": SCENE, "size": 40, "slant_step": 35, "slant_max": 70,
                                                    "tilts": [0, 45, 90], "shadow_size": 256}},
        "align": {"type": "BtfAlign", "inputs": {"stack": "capture"}, "params": {"steps": 5}},
        "synth": {"type": "BtfSynth", "inputs": {"stack": "align"}, "params": {"size": [48, 40], "levels": 2}},
        "write": {"type": "ExrWrite", "inputs": {"image": "synth"}, "params": {"path": "out/s.exr"}}}}))
    plates = []
    for threads in (1, 2):
        r = subprocess.run([sys.executable, "-m", "proxyshade.cli", "run", str(graph), "--threads", str(threads),
                            "--cache", str(tmp_path / f"c{threads}")], capture_output=True, text=True, cwd=ROOT,
                           env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})
        assert r.returncode == 0, r.stderr
        plates.append(read_plate(tmp_path / "out/s.exr"))
        (tmp_path / "out/s.exr").unlink()
    assert plates[0].names() == plates[1].names() and "v6.sx" in plates[0].names()
    assert all(np.array_equal(plates[0][c], plates[1][c]) for c in plates[0].names())


def test_the_graph_writes_the_stack_exr_and_a_contact_sheet(tmp_path):
    from proxyshade.io.images import read_u8

    small = ["--set", "capture.size=48", "--set", "capture.slant_step=35", "--set", "capture.tilts=[0,90]",
             "--set", "synth.size=[64,64]", "--set", "synth.levels=2", "--set", "sheet.crop=32"]
    r = subprocess.run([sys.executable, "-m", "proxyshade.cli", "run", str(ROOT / "graphs/btf.yaml"), "--var",
                        f"out={tmp_path / 'out'}", "--cache", str(tmp_path / "c"), *small], capture_output=True,
                       text=True, cwd=ROOT, env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})
    assert r.returncode == 0, r.stderr
    stack = read_plate(tmp_path / "out/btf_stack.exr")
    views, imgs = btf.stack_arrays(stack)
    assert len(views) == 5 and imgs.shape == (5, 64, 64, 3) and "v4.sx" in stack and "v4.sy" in stack
    sheet = read_u8(tmp_path / "out/btf_sheet.png")
    assert sheet.shape == (3 * 32 + 2 * 2, 2 * 32 + 2, 3)  # slants 0, 35, 70 by tilts 0, 90
    assert sheet[:32, :32].std() > 2  # a picture of the frontal view
    assert (tmp_path / "out/btf_input_sheet.png").is_file()


def test_a_tiled_stack_repeats_without_a_seam(stack, results):
    """tile (the default): the output wraps, so the edges its repeats add jump no more than
    its own edges do; with tile off the border is a seam (sources unrelated across it)."""
    off = run_node("BtfSynth", dict(SMALL, mode="sequential", tile=False), {"stack": stack})
    views = results["sequential"].meta["views"]
    on_b, off_b, inner = [], [], []
    for n in range(len(views)):
        a = np.stack([results["sequential"][f"v{n}.{c}"] for c in "RGB"], -1)
        b = np.stack([off[f"v{n}.{c}"] for c in "RGB"], -1)
        on_b.append(btf.tile_jumps(a)[0])
        inner.append(btf.tile_jumps(a)[1])
        off_b.append(btf.tile_jumps(b)[0])
    assert results["sequential"].meta["btf"]["tile"] is True and off.meta["btf"]["tile"] is False
    assert np.mean(on_b) < 1.5 * np.mean(inner) and np.mean(off_b) > 2 * np.mean(inner)
    assert np.mean(on_b) < 0.6 * np.mean(off_b)


def test_parallax_off_gives_the_views_the_support_sources_at_the_same_pixel(stack, results):
    """parallax off (the paper): the other views start from the support's sources at each
    pixel; on: from the support's surface cast along their direction. The support is the
    same; the steep views differ, and where a view keeps its start it copies the cast."""
    off = run_node("BtfSynth", dict(SMALL, parallax=False), {"stack": stack})
    on = results["sequential"]
    assert on.meta["btf"]["parallax"] and not off.meta["btf"]["parallax"]
    (qy1, qx1), (qy0, qx0) = _maps(on), _maps(off)
    s = on.meta["btf"]["support"]
    assert np.array_equal(qy1[s], qy0[s]) and np.array_equal(qx1[s], qx0[s])
    views, imgs = btf.stack_arrays(stack)
    steep = [n for n, v in enumerate(views) if v["slant"] == 70.0]
    assert any(not np.array_equal(qx1[n], qx0[n]) for n in steep)
