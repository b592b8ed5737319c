"""Issue 36: shared caches, full disks and hostile inputs, each probed with the real failure where
one can be made here: a real full filesystem (a small tmpfs, mounted when the tests run as root,
else skipped with the reason), a real read-only cache, two real processes on one cache."""
from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

from proxyshade.errors import EXIT_BAD_INPUT
from tests.faults.test_faults import _entries, cli, write_graph


# -- 3: cache clean deletes only a cache ------------------------------------------------------------------
def _victim(tmp_path: Path) -> Path:
    v = tmp_path / "v"
    (v / "docs").mkdir(parents=True)
    (v / "docs" / "a").write_text("x")
    (v / "notes.txt").write_text("keep me")
    return v


def test_cache_clean_refuses_a_folder_that_is_not_a_cache(tmp_path, capsys, monkeypatch):
    v = _victim(tmp_path)
    code, out, err = cli(capsys, "cache", "clean", "--cache", v)
    assert code == EXIT_BAD_INPUT and len(err) == 1, err
    assert err[0].startswith(f"error: --cache {v}: not a proxyshade plate cache (no CACHEDIR.TAG") and "nothing removed" in err[0]
    assert (v / "docs" / "a").read_text() == "x" and (v / "notes.txt").read_text() == "keep me"
    monkeypatch.setenv("PROXYSHADE_CACHE", str(v))  # through the environment as well
    code, out, err = cli(capsys, "cache", "clean")
    assert code == EXIT_BAD_INPUT and len(err) == 1 and f"$PROXYSHADE_CACHE={v}: not a proxyshade plate cache" in err[0]
    assert (v / "docs" / "a").read_text() == "x"
    f = tmp_path / "file"
    f.write_text("x")
    code, out, err = cli(capsys, "cache", "clean", "--cache", f)
    assert code == EXIT_BAD_INPUT and "not a folder" in err[0] and f.read_text() == "x"


def test_cache_clean_removes_only_what_it_recognises(tmp_path, registry, capsys):
    g = write_graph(tmp_path)
    cache = tmp_path / "c"
    assert cli(capsys, "run", g, "-q", "--cache", cache)[0] == 0
    assert (cache / "CACHEDIR.TAG").read_text().startswith("Signature: 8a477f597d28d172789f06886806bc55")
    n = len(_entries(cache))
    (cache / "mine.txt").write_text("a file someone put in the cache")
    code, out, err = cli(capsys, "cache", "clean", "--cache", cache)
    assert code == 0 and f"removed {n} entries" in out, err
    assert sorted(p.name for p in cache.rglob("*")) == ["CACHEDIR.TAG", "mine.txt"]
    (cache / "mine.txt").unlink()
    assert cli(capsys, "cache", "clean", "--cache", cache)[0] == 0 and not cache.exists()
    # a cache of a version before the tag: nothing but entries in it, so it is one
    assert cli(capsys, "run", g, "-q", "--cache", cache)[0] == 0
    (cache / "CACHEDIR.TAG").unlink()
    code, out, err = cli(capsys, "cache", "clean", "--cache", cache)
    assert code == 0 and f"removed {n} entries" in out and not cache.exists()


# -- 1: two runs on one cache -----------------------------------------------------------------------------
ROOT = Path(__file__).resolve().parents[2]
USD_GRAPH = f"""\
format: proxyshade/1
frames: 1
nodes:
  src:   {{type: SourceRead, params: {{table: {ROOT}/samples/renoir/source.yaml}}}}
  proxy: {{type: ProxyRender, inputs: {{source: src}}, params: {{scene: {ROOT}/samples/scenes/lake.usda, resolution: [32, null]}}}}
  w:     {{type: ExrWrite, inputs: {{image: proxy}}, params: {{path: out/proxy.exr}}}}
"""


def _start(folder: Path, cache: Path, jobs: int) -> subprocess.Popen:
    import sys

    return subprocess.Popen([sys.executable, "-m", "proxyshade.cli", "run", "g.yaml", "-q", "--cache", str(cache),
                             "--jobs", str(jobs)], cwd=folder, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def test_two_runs_on_one_cache_both_finish(tmp_path):
    """Two processes computing a USD graph at once on one cache: one of them finds the entry the
    other just stored (the cache writer checks it) while its node thread loads USD. That
    deadlocked (GIL against the dynamic loader's lock) in 2 of 3 tries; a hang fails here."""
    (tmp_path / "g.yaml").write_text(USD_GRAPH)
    warm = _start(tmp_path, tmp_path / "warm", 1)  # compiles the kernels once, outside the race
    assert warm.wait(timeout=600) == 0, warm.stderr.read()
    for i in range(3):
        cache = tmp_path / f"c{i}"
        runs = [_start(tmp_path, cache, 1), _start(tmp_path, cache, 2)]
        try:
            for p in runs:
                out, err = p.communicate(timeout=90)
                assert p.returncode == 0, err
        except subprocess.TimeoutExpired:
            pytest.fail(f"try {i + 1}: a run on the shared cache hung (over 90 s)")
        finally:
            for p in runs:
                if p.poll() is None:
                    p.kill()
                    p.wait()
        assert len(_entries(cache)) == 3  # each entry whole, from one of the two writers


# -- 2: a full disk, for real ----------------------------------------------------------------------------
@pytest.fixture
def small_disk(tmp_path):
    """A real 256 KiB filesystem (tmpfs), mounted for the test and unmounted after it; skipped where
    mounting is not permitted (not root, or no mount privilege in a container)."""
    mnt = tmp_path / "disk"
    mnt.mkdir()
    if os.geteuid() != 0:
        pytest.skip("a real full disk needs a tmpfs mount, which needs root")
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=256k", "tmpfs", str(mnt)], capture_output=True, text=True)
    if r.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here ({r.stderr.strip() or r.returncode})")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], check=False)


def fill(disk: Path, leave: int) -> Path:
    """Fill ``disk`` but ``leave`` bytes (rounded to its 4 KiB pages)."""
    st = os.statvfs(disk)
    free = st.f_bavail * st.f_frsize
    filler = disk / "filler"
    filler.write_bytes(os.urandom(max(0, free - leave)))
    return filler


# noise plates (incompressible): a 128x128 EXR is ~70 KiB, its PNG preview and GIF ~20-50 KiB
NOISY = """\
  a: {type: TConst, params: {value: 0.0, size: 128, seed: 7}}
  w: {type: ExrWrite, inputs: {image: a}, params: {path: "${out}/a.exr"}}
  p: {type: Preview, inputs: {image: a}, params: {path: "${out}/a.png", channels: [R, R, R]}}
  m: {type: Movie, inputs: {image: {node: a, frame: all}}, params: {path: "${out}/a.gif", channels: [R, R, R]}}
"""


def _whole(path: Path) -> bool:
    import OpenImageIO as oiio

    from proxyshade.io.exr import read_plate

    if path.suffix == ".exr":
        read_plate(path)
        return True
    buf = oiio.ImageBuf(str(path))
    return not buf.has_error and buf.get_pixels(oiio.UINT8) is not None and not buf.has_error


@pytest.mark.parametrize("output", ["w", "p", "m"])
def test_outputs_on_a_full_disk_exit_74_and_leave_nothing(tmp_path, registry, capsys, small_disk, output):
    """ExrWrite, Preview and Movie on a real full filesystem: the library reports success when its
    last buffered write fails, so the written file is checked (whole by its format, fsync'd)
    before it is renamed into place; nothing cut short is left or recorded; after space is
    freed the re-run writes it (not 'written before')."""
    others = [n for n in "wpm" if n != output]
    nodes = NOISY.replace("${out}", str(small_disk / "out"))
    for n in others:  # only the writer under test writes
        nodes = nodes.replace(f"  {n}: {{", f"  {n}: {{enabled: false, ")
    g = write_graph(tmp_path, nodes, frames="1")
    (small_disk / "out").mkdir()
    filler = fill(small_disk, 16 * 1024)
    code, out, err = cli(capsys, "run", g, "-q")
    assert code == 74 and len(err) == 1, (code, err)
    assert "free space" in err[0] and str(small_disk / "out" / "a.") in err[0], err
    assert sorted(p.name for p in (small_disk / "out").iterdir()) == []  # no output, no temporary
    filler.unlink()
    code, out, err = cli(capsys, "run", g, "--explain")
    assert code == 0, err
    assert [p.name for p in (small_disk / "out").iterdir()] == [f"a.{ {'w': 'exr', 'p': 'png', 'm': 'gif'}[output]}"]
    assert _whole(next((small_disk / "out").iterdir()))
    from tests.faults.test_faults import explain_rows

    assert explain_rows(out)[(output, "1")][0] == "computed"


def test_cache_on_a_full_disk_exits_74_and_stores_nothing_cut_short(tmp_path, registry, capsys, small_disk):
    nodes = NOISY.replace("${out}", str(tmp_path / "out"))
    g = write_graph(tmp_path, nodes, frames="1")
    cache = small_disk / "cache"
    filler = fill(small_disk, 24 * 1024)
    code, out, err = cli(capsys, "run", g, "-q", "--cache", cache)
    assert code == 74 and len(err) == 1, (code, err)
    assert f"{cache}/" in err[0] and "cannot write cache entry" in err[0] and "free space" in err[0], err
    assert ".tmp" not in err[0]  # the entry's name, not a temporary's
    for exr in cache.glob("*/*.exr"):  # no EXR without its record, none cut short
        assert exr.with_suffix(".json").is_file() and _whole(exr)
    assert not [p for p in cache.rglob(".*") if ".tmp" in p.name]
    filler.unlink()
    code, out, err = cli(capsys, "run", g, "-q", "--cache", cache)
    assert code == 0, err
    code, out, err = cli(capsys, "run", g, "-q", "--cache", cache)
    assert code == 0 and "0 computed" in out


# -- 4: a read-only cache, for real ----------------------------------------------------------------------
def test_read_only_cache_miss_is_computed_and_noted(tmp_path, registry, capsys, small_disk):
    """A cache on a filesystem mounted read-only (a farm's shared cache), every shard folder there:
    hits are served, a miss is computed, kept in memory and noted, and the run exits 0."""
    g = write_graph(tmp_path)
    cache = small_disk / "cache"
    assert cli(capsys, "run", g, "-q", "--cache", cache)[0] == 0
    for i in range(256):  # the shard of any key exists: the write fails in the EXR library, not at mkdir
        (cache / f"{i:02x}").mkdir(exist_ok=True)
    r = subprocess.run(["mount", "-o", "remount,ro", str(small_disk)], capture_output=True, text=True)
    if r.returncode != 0:
        pytest.skip(f"cannot remount the tmpfs read-only ({r.stderr.strip()})")
    code, out, err = cli(capsys, "run", g, "-q", "--cache", cache)
    assert code == 0 and err == [] and "0 computed" in out, err
    code, out, err = cli(capsys, "run", g, "-q", "--cache", cache, "--set", "a.value=5.0")
    assert code == 0 and err == [], err
    assert f"note cache {cache} is read-only: " in out and "were not stored" in out
    from proxyshade.io.exr import read_plate

    assert read_plate(tmp_path / "out" / "s.0002.exr")["R"][0, 0] == 7.0


# -- 6 and 5: bad source tables are bad input (exit 2), never internal errors --------------------------
LABELS = 'labels_map: style_mask.png\nlabels:\n  sky: {id: 2, color: "#ffffff"}\n'
# anchors l0..l5, each eight aliases of the one before (l5: 8**5 items, within the limit by itself);
# a value of four *l5 is the bomb, so each probe is refused at its own line, not at the anchors
BOMB = "".join(f"l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * 8)}]\n" for i in range(1, 6))
USE = "[*l5, *l5, *l5, *l5]"


@pytest.mark.parametrize("table,expect", [
    ("image: 5\n" + LABELS, "s.yaml: image: expected the file name of the photo (relative to the table), got 5;"),
    ("image: [a]\n" + LABELS, "s.yaml: image: expected the file name of the photo"),
    ("image: {a: 1}\n" + LABELS, "s.yaml: image: expected the file name of the photo"),
    ("image: null\n" + LABELS, "s.yaml: image: expected the file name of the photo (relative to the table), got None"),
    ("image: .\n" + LABELS, "s.yaml: image: '.' is a folder; name the photo's image file"),
    ("image: style.png\nlayout: 5\n" + LABELS, "s.yaml: layout: expected the file name of a second label map"),
    ('image: style.png\nlabels_map: style_mask.png\nlabels:\n  sky: {id: 99999999999, color: "#ffffff"}\n',
     "s.yaml: labels.sky.id: expected an int from 1 to 4294967295"),
    (b"image: style.png\n\xff\xfe\n", "s.yaml:2: not a UTF-8 text file (byte 0xff at offset 17)"),
    ("image: style.png\nlabels_map: style_mask.png\nlabels: " + "[" * 20000 + "]" * 20000 + "\n", "s.yaml: nested too deeply"),
    ("image: style.png\nlabels_map: style_mask.png\nlabels: " + "[" * 150 + "]" * 150 + "\n", "nests deeper than 100"),
    ("l0: &l0 [x]\n" + BOMB + f"image: {USE}\n" + LABELS, "s.yaml:7: the value expands to more than 100000 items"),
    ("image: style.png\nimage: style.png\n" + LABELS, "s.yaml:2: key 'image' appears twice in one mapping (lines 1 and 2)"),
])
def test_bad_source_tables_are_bad_input(tmp_path, capsys, table, expect):
    import shutil

    for name in ("style.png", "style_mask.png"):
        shutil.copy(ROOT / "samples" / "renoir" / name, tmp_path / name)
    (tmp_path / "s.yaml").write_bytes(table if isinstance(table, bytes) else table.encode())
    g = write_graph(tmp_path, "  src: {type: SourceRead, params: {table: s.yaml}}\n", frames="1", vars_="")
    code, out, err = cli(capsys, "run", g, "-q")
    assert code == EXIT_BAD_INPUT and len(err) == 1, err
    assert expect in err[0] and len(err[0]) < 600, err


def _bomb_lines(indent: str) -> str:
    return f"{indent}l0: &l0 [x]\n" + "".join(f"{indent}{line}" for line in BOMB.splitlines(keepends=True))


@pytest.mark.parametrize("where,line", [("frames", 9), ("format", 8), ("type", 10), ("enabled", 10), ("input", 11),
                                        ("set", 1), ("var", 1)])
def test_alias_bombs_are_refused_everywhere_quickly(tmp_path, where, line):
    """A value that expands past 100000 items through aliases, anywhere in a graph file or in a
    --set or --var value: refused by the one YAML loader before anything walks it (it hung
    before), at the line of the value."""
    from tests.faults.test_faults import subprocess_cli

    head = "format: proxyshade/1\ndoc:\n" + _bomb_lines("  ")  # anchors in the free-form doc, lines 3-8
    nodes = {"c": "{type: TConst}", "d": "{type: TAdd, inputs: {a: c}}"}
    args = []
    if where == "frames":
        head += f"frames: {USE}\n"
    elif where == "format":
        head = head.replace("format: proxyshade/1\n", "") + f"format: {USE}\n"
    elif where == "type":
        nodes["c"] = f"{{type: {USE}}}"
    elif where == "enabled":
        nodes["c"] = f"{{type: TConst, enabled: {USE}}}"
    elif where == "input":
        nodes["d"] = f"{{type: TAdd, inputs: {{a: {USE}}}}}"
    text = head + "nodes:\n" + "".join(f"  {k}: {v}\n" for k, v in nodes.items())
    if where in ("set", "var"):
        text = "format: proxyshade/1\nvars: {v: 1.0}\nnodes:\n  c: {type: TConst, params: {value: \"${v}\"}}\n"
        bomb = "{l0: &l0 [x], " + ", ".join(f"l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * 8)}]" for i in range(1, 6)) + \
            f", use: {USE}}}"
        args = ["--set", f"c.value={bomb}"] if where == "set" else ["--var", f"v={bomb}"]
    g = tmp_path / "g.yaml"
    g.write_text(text)
    r = subprocess_cli(["run", str(g), "-q", *args], timeout=60)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == EXIT_BAD_INPUT and len(lines) == 1, r.stderr[-2000:]
    assert f":{line}: the value expands to more than 100000 items" in lines[0] and len(lines[0]) < 600, lines[0][:2000]


# -- 6: scene descriptions beyond what can be built -------------------------------------------------------
@pytest.mark.parametrize("old,new,expect", [
    ("cells: [128, 128]", "cells: [100000, 100000]", "x.yaml: terrains[1].cells: expected 2 integers from 1 to 4096"),
    ("frames: [1, 48]", "frames: [1, 99999999999]", "x.yaml: frames: expected 2 integers"),
    ("count: 7", "count: 100000000", "x.yaml: spheres[0].count: expected an integer from 1 to 10000"),
    ("radius: [5, 6]", "radius: .nan", "x.yaml: spheres[1].radius: nan is not a finite number"),
    ("focal_length: 24", "focal_length: .inf", "x.yaml: cameras[0].focal_length: inf is not a finite number"),
    ("name: lake", "name: lake\nname: again", "x.yaml:3: key 'name' appears twice in one mapping (lines 2 and 3)"),
])
def test_scene_build_refuses_what_cannot_be_built(tmp_path, capsys, old, new, expect):
    text = (ROOT / "samples" / "scenes" / "lake.yaml").read_text()
    assert old in text
    (tmp_path / "x.yaml").write_text(text.replace(old, new, 1))
    code, out, err = cli(capsys, "scene", "build", tmp_path / "x.yaml")
    assert code == EXIT_BAD_INPUT and len(err) == 1 and expect in err[0], err
    assert not (tmp_path / "x.usda").exists()


def test_a_record_of_nested_brackets_is_a_corrupt_entry(tmp_path, registry, capsys):
    g = write_graph(tmp_path)
    assert cli(capsys, "run", g, "-q")[0] == 0
    cache = tmp_path / ".proxyshade" / "cache"
    records = _entries(cache) + list((cache / "runs").glob("*.json"))
    for p in records:
        p.write_text("[" * 100000 + "]" * 100000)
    code, out, err = cli(capsys, "run", g, "-q")
    assert code == 0 and err and all(line.startswith("warning: cache entry ") for line in err), err
    code, out, err = cli(capsys, "run", g, "-q")
    assert code == 0 and err == [] and "0 computed" in out


# -- 6 and 8: USD values no render can use ---------------------------------------------------------------
@pytest.mark.parametrize("case,expect", [
    ("index_out_of_range", "mesh /World/Plane at frame 1: faceVertexIndices[3] is 9, outside the 4 points"),
    ("index_negative", "mesh /World/Plane at frame 1: faceVertexIndices[3] is -1, outside the 4 points"),
    ("too_few_indices", "faceVertexCounts add up to 4 but faceVertexIndices has 3"),
    ("two_vertex_face", "face 0 has 2 vertices; every face needs 3 or more"),
    ("nan_point", "mesh /World/Plane at frame 1: points[1] is (nan, -9.0, -5.0)"),
    ("nan_radius", "sphere /World/Ball at frame 1: radius is nan; give a radius > 0"),
    ("inf_radius", "sphere /World/Ball at frame 1: radius is inf; give a radius > 0"),
    ("nan_focal", "camera /World/Cam at frame 1: focalLength is nan; give a focal length > 0"),
    ("nan_position", "camera /World/Cam at frame 1: its transform (position or rotation) holds a NaN"),
    ("zero_aperture", "camera /World/Cam at frame 1: horizontalAperture is 0; give an aperture > 0"),
    ("zero_clipping", "camera /World/Cam at frame 1: clippingRange is (0, 0); give 0 < near < far"),
])
def test_bad_usd_values_are_bad_input(tmp_path, capsys, case, expect):
    from pxr import Gf, Usd, UsdGeom, UsdSemantics, Vt

    from tests.faults.test_faults import _scene_graph

    s = Usd.Stage.CreateNew(str(tmp_path / "s.usda"))
    world = UsdGeom.Xform.Define(s, "/World")
    s.SetDefaultPrim(world.GetPrim())
    cam = UsdGeom.Camera.Define(s, "/World/Cam")
    cam.CreateFocalLengthAttr(float("nan") if case == "nan_focal" else 35.0)
    cam.CreateHorizontalApertureAttr(0.0 if case == "zero_aperture" else 36.0)
    cam.CreateVerticalApertureAttr(36)
    cam.CreateClippingRangeAttr(Gf.Vec2f(0, 0) if case == "zero_clipping" else Gf.Vec2f(0.1, 1000))
    if case == "nan_position":
        cam.AddTranslateOp().Set(Gf.Vec3d(float("nan"), 0, 0))
    m = UsdGeom.Mesh.Define(s, "/World/Plane")
    pts = [(-9, -9, -5), (9, -9, -5), (9, 9, -5), (-9, 9, -5)]
    if case == "nan_point":
        pts[1] = (float("nan"), -9, -5)
    m.CreatePointsAttr(pts)
    counts, idx = {"index_out_of_range": ([4], [0, 1, 2, 9]), "index_negative": ([4], [0, 1, 2, -1]),
                   "too_few_indices": ([4], [0, 1, 2]), "two_vertex_face": ([2, 2], [0, 1, 2, 3])}.get(case, ([4], [0, 1, 2, 3]))
    m.CreateFaceVertexCountsAttr(counts)
    m.CreateFaceVertexIndicesAttr(idx)
    UsdSemantics.LabelsAPI.Apply(m.GetPrim(), "texture").CreateLabelsAttr().Set(Vt.TokenArray(["water"]))
    if case.endswith("radius"):
        ball = UsdGeom.Sphere.Define(s, "/World/Ball")
        ball.CreateRadiusAttr(float(case.split("_")[0]))
        ball.AddTranslateOp().Set(Gf.Vec3d(0, 0, -20))
        UsdSemantics.LabelsAPI.Apply(ball.GetPrim(), "texture").CreateLabelsAttr().Set(Vt.TokenArray(["water"]))
    s.Save()
    code, out, err = cli(capsys, "run", _scene_graph(tmp_path, "s.usda"), "-q")
    assert code == EXIT_BAD_INPUT and len(err) == 1, err
    assert expect in err[0] and "s.usda" in err[0], err


# -- 9: smaller things ------------------------------------------------------------------------------------
def test_a_numeric_var_takes_its_defaults_type(tmp_path, registry, capsys):
    """``vars: {value: 1.0}`` and ``--var value=2.5``: the text is read as the default's type."""
    from proxyshade.io.exr import read_plate

    g = write_graph(tmp_path, frames="1")
    code, out, err = cli(capsys, "run", g, "-q", "--var", "value=2.5")
    assert code == 0, err
    assert (read_plate(tmp_path / "out" / "s.0001.exr")["R"] == 3.5).all()  # 2.5 + frame 1
    code, out, err = cli(capsys, "run", g, "-q", "--var", "value=1e3")
    assert code == 0 and (read_plate(tmp_path / "out" / "s.0001.exr")["R"] == 1001).all(), err
    code, out, err = cli(capsys, "run", g, "-q", "--var", "value=lots")
    assert code == EXIT_BAD_INPUT and err == ["error: --var value=lots: the variable value is a number (its default "
                                              "is 1.0); give a number, e.g. --var value=1.0"], err
    nodes = "  a: {type: TConst, params: {size: \"${n}\"}}\n"
    g = write_graph(tmp_path, nodes, frames="1", vars_="n: 4")
    assert cli(capsys, "run", g, "-q", "--var", "n=6")[0] == 0
    code, out, err = cli(capsys, "run", g, "-q", "--var", "n=6.5")
    assert code == EXIT_BAD_INPUT and "the variable n is an integer (its default is 4)" in err[0], err


@pytest.mark.parametrize("case", ["file", "inside_file", "loop", "folder", "loop_path_var"])
def test_an_output_that_cannot_be_written_is_refused_before_any_compute(tmp_path, registry, capsys, case):
    from tests.conftest import COMPUTES

    (tmp_path / "afile").write_text("keep")
    (tmp_path / "loop").symlink_to("loop")
    (tmp_path / "s.0001.exr").mkdir()
    out = {"file": "afile", "inside_file": "afile/sub", "loop": "loop", "folder": ".",
           "loop_path_var": f"{tmp_path}/loop"}[case]
    expect = {"file": f"{tmp_path}/afile: is a file, not a folder", "inside_file": f"{tmp_path}/afile: is a file",
              "folder": f"{tmp_path}/s.0001.exr: is a folder"}.get(case, f"{tmp_path}/loop: is a symlink loop")
    COMPUTES.clear()
    # the bundled graphs' out is a path variable (made absolute when given): a loop there raised RuntimeError
    g = write_graph(tmp_path, frames="1", vars_="value: 1.0, out: {default: out, path: true}"
                    if case == "loop_path_var" else "value: 1.0, out: out")
    code, _, err = cli(capsys, "run", g, "-q", "--var", f"out={out}")
    assert code == EXIT_BAD_INPUT and len(err) == 1, err
    assert f"g.yaml:8: nodes.w.params.path: cannot write {out}/s.####.exr: {expect}" in err[0], err
    assert not COMPUTES and not (tmp_path / ".proxyshade").exists()  # nothing computed, nothing cached
    assert (tmp_path / "afile").read_text() == "keep"


def test_a_reader_closing_the_pipe_early_is_not_an_error():
    """``proxyshade nodes | head -1``: a pipe of one page, closed after the first line, so the
    writer meets the closed pipe for certain."""
    import fcntl
    import sys

    r, w = os.pipe()
    fcntl.fcntl(w, 1031, 4096)  # F_SETPIPE_SZ: one page
    p = subprocess.Popen([sys.executable, "-m", "proxyshade.cli", "nodes"], stdout=w, stderr=subprocess.PIPE,
                         text=True)
    os.close(w)
    with os.fdopen(r, "rb") as reader:
        first = reader.readline()
    _, errors = p.communicate(timeout=120)
    assert p.returncode == 0 and errors == "" and first.startswith(b"AnnotatedSourceRead"), (first, errors)


def test_usd_warnings_are_one_line_each(tmp_path):
    """A reference to a missing file: USD printed a C++ diagnostic ('Warning: in _ReportErrors
    at line ... of .../stage.cpp -- ...'); now one 'warning:' line naming the stage and prim."""
    from tests.faults.test_faults import _scene_graph, subprocess_cli

    scene = tmp_path / "s.usda"
    scene.write_text('#usda 1.0\n(\n    defaultPrim = "World"\n)\ndef Xform "World"\n{\n'
                     '    def Camera "Cam"\n    {\n        float2 clippingRange = (0.1, 1000)\n    }\n'
                     '    def Mesh "Missing" (\n        references = @./nothere.usda@\n    )\n    {\n    }\n}\n')
    r = subprocess_cli(["run", str(_scene_graph(tmp_path, "s.usda")), "-q"])
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 0, r.stderr
    usd = [line for line in lines if "nothere.usda" in line]
    assert len(usd) == 1 and usd[0].startswith(f"warning: {scene}: USD: In </World/Missing>: Could not open asset "
                                               f"@{tmp_path}/nothere.usda@ for reference"), lines
    assert all(line.startswith("warning: ") for line in lines), lines
    assert "stage.cpp" not in r.stderr and "0x" not in r.stderr and "pxrInternal" not in r.stderr


def test_a_first_frame_under_8_px_suggests_a_fix_that_works(tmp_path, capsys):
    """Below the guide's smallest size the suggestion was 'a power of two up to 4', which the
    size parameter (>= 8) then refused; each suggestion now runs."""
    nodes = (f"  src:   {{type: SourceRead, params: {{table: {ROOT}/samples/renoir/source.yaml}}}}\n"
             f"  proxy: {{type: ProxyRender, inputs: {{source: src}}, params: {{scene: {ROOT}/samples/scenes/lake.usda, "
             "resolution: [4, null]}}\n"
             "  guide: {type: GuideSynth, inputs: {proxy: proxy, source: src}, params: {size: 256, start: 64}}\n")
    g = write_graph(tmp_path, nodes, frames="1", vars_="")
    code, _, err = cli(capsys, "run", g, "-q")
    assert code == EXIT_BAD_INPUT and len(err) == 1, err
    assert "guide@1: the output 4x4 is smaller than the smallest guide (8 pixels on the long side); render at " \
           "least 8 pixels wide or high (the proxy's resolution)" in err[0], err
    code, _, err = cli(capsys, "run", g, "-q", "--set", "proxy.resolution=[8, null]")
    assert code == EXIT_BAD_INPUT and "set size 8 and start at most that (e.g. start 8)" in err[0], err
    code, _, err = cli(capsys, "run", g, "-q", "--set", "proxy.resolution=[8, null]", "--set", "guide.size=8",
                       "--set", "guide.start=8")
    assert code == 0, err
    code, _, err = cli(capsys, "run", g, "-q", "--set", "proxy.resolution=[40, null]")
    assert "set size a power of two from 8 to 32 (e.g. 32) and start at most that (e.g. start 32)" in err[0], err
    assert cli(capsys, "run", g, "-q", "--set", "proxy.resolution=[40, null]", "--set", "guide.size=32",
               "--set", "guide.start=32")[0] == 0
