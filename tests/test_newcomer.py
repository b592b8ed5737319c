"""A newcomer's first hour: their own photo and label map (written here, not a bundled
sample), `source new`, a bundled scene rendered through the first-frame graph with only
--var, scene labels mapped onto the photo's."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import OpenImageIO as oiio
import yaml

from proxyshade.cli import main
from proxyshade.io.exr import read_plate
from proxyshade.io.source import load_source

ROOT = Path(__file__).resolve().parents[1]


def write_png(path: Path, a: np.ndarray) -> None:
    b = oiio.ImageBuf(oiio.ImageSpec(a.shape[1], a.shape[0], 3, oiio.UINT8))
    b.set_pixels(oiio.ROI(), np.ascontiguousarray(a))
    assert b.write(str(path))


def own_photo(folder: Path) -> tuple[Path, Path]:
    """A 'photo' of three textured bands (bright sky, green land, blue water) and its label
    map in three flat colours, with anti-aliased borders (noise to snap)."""
    rng = np.random.default_rng(7)
    H, W = 180, 240
    i = np.arange(H)[:, None] + 6 * np.sin(np.arange(W)[None, :] / 17)
    band = np.where(i < 70, 0, np.where(i < 120, 1, 2))
    base = np.array([[200, 210, 230], [70, 120, 40], [40, 70, 150]], float)
    photo = base[band] + rng.normal(0, 18, (H, W, 3)) + 25 * np.sin(np.arange(W) / 5)[None, :, None]
    colours = np.array([[255, 255, 255], [0, 200, 0], [0, 0, 255]], np.uint8)
    lab = colours[band].copy()
    edge = np.abs(np.diff(band, axis=0, prepend=band[:1])) > 0
    t = rng.random((int(edge.sum()), 1))  # anti-aliasing at the borders: blends of the two sides
    lab[edge] = (t * lab[edge] + (1 - t) * colours[np.roll(band, 1, axis=0)[edge]]).astype(np.uint8)
    folder.mkdir(parents=True, exist_ok=True)
    write_png(folder / "my_photo.png", np.clip(photo, 0, 255).astype(np.uint8))
    write_png(folder / "my_labels.png", lab)
    return folder / "my_photo.png", folder / "my_labels.png"


def test_own_photo_through_source_new_and_a_bundled_scene(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)  # the user's folder: --var paths are relative to it
    photo, labels = own_photo(Path("shoot"))
    assert main(["source", "new", str(photo), str(labels), "-o", "shoot/source.yaml"]) == 0
    table = yaml.safe_load(Path("shoot/source.yaml").read_text())
    assert [v["color"] for v in table["labels"].values()] == ["#ffffff", "#0000ff", "#00c800"]  # by area
    assert list(table["labels"]) == ["label_1", "label_2", "label_3"]
    src = load_source("shoot/source.yaml")
    assert src["label.id"].shape == (180, 240) and src.meta["snap"]["snapped"] > 0  # the borders snapped
    assert main(["source", "new", str(photo), str(labels), "-o", "shoot/source.yaml"]) == 2  # no overwrite
    # the lake scene's sky, vegetation, water and trees drawn from the photo's three labels
    mapping = "{sky: label_1, water: label_2, vegetation: label_3, tree: label_3}"
    rc = main(["run", str(ROOT / "graphs" / "first_frame.yaml"), "--frames", "1", "--var", "scene=lake",
               "--var", "source=shoot/source.yaml", "--var", f"labels={mapping}", "--var", "out=renders",
               "--set", "proxy.resolution=[192,128]", "--set", "guide.size=64", "--set", "guide.start=16",
               "--cache", "cache"])
    assert rc == 0, capsys.readouterr().err
    exr = Path("renders/lake_shoot.0001.exr")  # named by shot: scene and source
    assert exr.is_file() and Path("renders/lake_shoot.0001.png").is_file()
    plate = read_plate(exr)
    assert plate.shape == (128, 192)  # the requested aspect, 3:2
    assert set(np.unique(plate["label.id"])) <= {1, 2, 3} and np.isfinite(plate.rgb()).all()
    # a scene label left unmapped is a one-line error that says how to map it
    rc = main(["run", str(ROOT / "graphs" / "first_frame.yaml"), "--frames", "1",
               "--var", "source=shoot/source.yaml", "--var", "out=renders", "--cache", "cache"])
    err = capsys.readouterr().err
    assert rc == 2 and "map them with the labels parameter" in err


# kernels, USD, colour science, the EXR bindings, Dask's runtime; rich's progress bars and
# tables (nothing to draw); numpy is checked apart: it may sit in sys.modules as a lazy module
HEAVY = ("numba", "llvmlite", "pxr", "scipy", "colour", "OpenEXR", "asyncio", "rich.progress", "rich.table")


def test_a_cached_rerun_imports_no_kernels_usd_colour_science_or_numpy(tmp_path, monkeypatch):
    """Item 9: an unchanged re-run answers from the cache in a fraction of a second, so it
    must not load numba, USD, colour-science, the EXR bindings, numpy or asyncio (Dask's)
    (about 0.6 s of imports): keys come from the sources and, for the scene, from its files'
    hashes."""
    monkeypatch.setenv("PROXYSHADE_CODE_CACHE", str(tmp_path / "code"))
    monkeypatch.chdir(tmp_path)
    args = ["run", str(ROOT / "graphs" / "first_frame.yaml"), "--frames", "1", "--var", "out=renders",
            "--set", "proxy.resolution=[96,64]", "--set", "guide.size=32", "--set", "guide.start=16",
            "--set", "init.factor=2", "--cache", str(tmp_path / "cache"), "-q"]
    assert main(args) == 0  # fills the cache
    code = ("import sys, types; from proxyshade.cli import main; rc = main(sys.argv[1:]); "
            f"loaded = sorted(m for m in {HEAVY!r} if m in sys.modules); "
            "loaded += ['numpy'] * (type(sys.modules.get('numpy')) is types.ModuleType); print(rc, loaded)")
    r = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, cwd=tmp_path,
                       env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "0 computed, 13 reused" in r.stdout
    assert r.stdout.strip().splitlines()[-1] == "0 []"
