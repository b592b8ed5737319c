"""BtfRead: stacks read back from renders written to disk, and its bad inputs (one line, exit 2)."""
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from proxyshade.graph.plate import Plate
from proxyshade.graph.testing import run_node
from proxyshade.io.exr import write_plate
from proxyshade.io.images import write_png
from proxyshade.kernels.display import to_display
from tests.nodes._btf import ROOT, capture



@pytest.fixture(scope="module")
def render():
    return capture(32, 30, 60, [0, 90])


def _write(folder: Path, render, fmt: str, edit=None) -> Path:
    views = []
    for n, v in enumerate(render.meta["views"]):
        img = Plate({c: render[f"v{n}.{c}"] for c in "RGB"})
        name = f"v{n}.{fmt}"
        if fmt == "exr":
            write_plate(folder / name, img)
        else:
            write_png(folder / name, to_display(img, ["R", "G", "B"]))
        views.append({"image": name, "slant": v["slant"], "tilt": v["tilt"], "light": v["light"]})
    spec = {"pixel": render.meta["btf"]["pixel"], "plane": 0.0, "views": views}
    if edit:
        edit(spec, folder)
    (folder / "btf.yaml").write_text(yaml.safe_dump(spec))
    return folder / "btf.yaml"


def test_exr_photos_read_back_exactly_png_to_8_bits(tmp_path, render):
    (tmp_path / "exr").mkdir()
    (tmp_path / "png").mkdir()
    a = run_node("BtfRead", {"path": str(_write(tmp_path / "exr", render, "exr"))})
    b = run_node("BtfRead", {"path": str(_write(tmp_path / "png", render, "png"))})
    assert a.meta["views"] == render.meta["views"]
    assert a.meta["btf"]["pixel"] == render.meta["btf"]["pixel"]
    for n in range(len(render.meta["views"])):
        for c in "RGB":
            assert np.array_equal(a[f"v{n}.{c}"], render[f"v{n}.{c}"])
            # sRGB 8-bit: half a code value, at most ~0.4% of the value at the top of the range
            assert np.allclose(b[f"v{n}.{c}"], np.clip(render[f"v{n}.{c}"], 0, 1), atol=0.003)


def _drop_tilt(spec, folder):
    spec["views"] = [v for v in spec["views"] if not (v["slant"] == 60 and v["tilt"] == 90)]


def _no_frontal(spec, folder):
    spec["views"] = spec["views"][1:]


def _off_step(spec, folder):
    for v in spec["views"]:
        if v["slant"] == 60:
            v["slant"] = 70


def _grazing(spec, folder):
    spec["views"][-1]["slant"] = 90


def _small(spec, folder):
    img = Plate({c: np.full((20, 32), 0.2, np.float32) for c in "RGB"})
    write_plate(folder / "v2.exr", img)


def _nan(spec, folder):
    a = np.full((32, 32), 0.2, np.float32)
    a[3, 5] = np.nan
    write_plate(folder / "v1.exr", Plate({"R": a, "G": a, "B": a}))


@pytest.mark.parametrize("edit,message", [
    (_drop_tilt, r"off a regular grid: slant 60° has no view at tilt 90°.*add it"),
    (_no_frontal, r"0 frontal views .*add a view at slant 0"),
    (_off_step, r"off a regular grid \(70° is not 2 × 30°\)"),
    (_grazing, r"slant 90° is outside \[0°, 90°\).*drop it"),
    (_small, r"views\[2\] \(v2.exr\) is 32x20, views\[0\] is 32x32; give photos of one size"),
    (_nan, r"views\[1\] \(v1.exr\) has 1 NaN/Inf pixel\(s\), first at x=5 y=3; clean the image"),
])
def test_bad_stacks_are_one_line_errors_with_exit_2(tmp_path, render, edit, message):
    path = _write(tmp_path, render, "exr", edit)
    graph = tmp_path / "g.yaml"
    graph.write_text(yaml.safe_dump({"format": "proxyshade/1", "frames": 1, "nodes": {
        "read": {"type": "BtfRead", "params": {"path": str(path)}},
        "write": {"type": "ExrWrite", "inputs": {"image": "read"}, "params": {"path": str(tmp_path / "o.exr")}}}}))
    r = subprocess.run([sys.executable, "-m", "proxyshade.cli", "run", str(graph), "--cache", str(tmp_path / "c")],
                       capture_output=True, text=True, cwd=ROOT, env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})
    assert r.returncode == 2, r.stderr + r.stdout
    err = [ln for ln in r.stderr.splitlines() if ln.strip()
           and not ln.startswith(("compiling the numba kernels", "kernels compiled in"))]  # a first run's progress
    assert len(err) == 1 and re.search(r"g\.yaml:\d+: read(@1)?: ", err[0]), r.stderr  # the node, then the field
    assert re.search(message, err[0]), err[0]
