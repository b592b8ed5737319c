"""Faults a studio meets (issue 13): each test gives the CLI one fault and asserts the exit code,
the one line on stderr, and what is on disk afterwards. Full disks and read-only caches are
injected by monkeypatching the writers (no tmpfs can be mounted here)."""
from __future__ import annotations

import errno
import json
import os
import shutil
import stat
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import OpenImageIO as oiio
import pytest

from proxyshade.cli import main
from proxyshade.errors import EXIT_BAD_INPUT, EXIT_INTERNAL, EXIT_INTERRUPTED, EXIT_IO
from proxyshade.io.exr import read_plate

ROOT = Path(__file__).resolve().parents[2]

# TConst (4x4) + TFrame summed, written per frame; a preview PNG of the constant's label ids
NODES = """\
  a: {type: TConst, params: {value: "${value}", size: 4}}
  f: {type: TFrame}
  s: {type: TAdd, inputs: {a: a, b: f}}
  w: {type: ExrWrite, inputs: {image: s}, params: {path: "${out}/s.####.exr"}}
  p: {type: Preview, inputs: {image: a}, params: {path: "${out}/a.png", channels: [label.id]}}
"""


def write_graph(tmp_path: Path, nodes: str = NODES, frames: str = "1-3", vars_: str = "value: 1.0, out: out") -> Path:
    p = tmp_path / "g.yaml"
    p.write_text(f"format: proxyshade/1\nframes: {frames}\nvars: {{{vars_}}}\nnodes:\n{nodes}")
    return p


@pytest.fixture(autouse=True)
def wide(monkeypatch):
    """A wide console, so --explain's table keeps each row on one line."""
    from rich.console import Console

    monkeypatch.setattr("proxyshade.cli.out", Console(width=300))


def explain_rows(out: str) -> dict[tuple[str, str], list[str]]:
    """--explain's table as {(node, frame): [status, why, seconds]}."""
    rows = {}
    for line in out.splitlines():
        cells = [c.strip() for c in line.split("│")[1:-1]]
        if len(cells) == 5 and cells[1].isdigit():
            rows[(cells[0], cells[1])] = cells[2:]
    return rows


# what a run prints first on a cold numba cache (a fresh checkout): not what these tests check
COMPILE_LINES = ("compiling the numba kernels", "kernels compiled in")


def cli(capsys, *args) -> tuple[int, str, list[str]]:
    """(exit code, stdout, stderr's lines less the cold-cache compile step's)."""
    code = main([str(a) for a in args])
    cap = capsys.readouterr()
    return code, cap.out, [line for line in cap.err.splitlines() if line.strip() and not line.startswith(COMPILE_LINES)]


def temps(folder: Path) -> list[Path]:
    return sorted(p for p in folder.rglob(".*") if ".tmp" in p.name)


def listing(folder: Path) -> dict[str, tuple[int, int]]:
    return {str(p.relative_to(folder)): (p.stat().st_size, p.stat().st_mtime_ns) for p in sorted(folder.rglob("*"))
            if p.is_file()}


def subprocess_cli(args: list[str], *, timeout: float = 120, block_click: bool = True) -> subprocess.CompletedProcess:
    """The CLI in a fresh interpreter (the test node types registered); ``click`` made unimportable
    when typer itself does not load it, so a hidden dependency on it fails here."""
    code = ("import sys; sys.path.insert(0, sys.argv.pop(1)); import typer\n"
            f"if {block_click} and 'click' not in sys.modules: sys.modules['click'] = None\n"
            "import proxyshade.nodes; from proxyshade.graph.node import REGISTRY; from tests.conftest import TYPES\n"
            "REGISTRY.update(TYPES); from proxyshade.cli import main; sys.exit(main(sys.argv[1:]))")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-c", code, str(ROOT), *args], capture_output=True, text=True,
                          timeout=timeout, env=env, cwd=str(ROOT))


# -- 2: usage errors on the newest typer -----------------------------------------------------------------
@pytest.mark.parametrize("args,expect", [
    (["run"], "Missing argument 'GRAPH'"),
    (["run", "g.yaml", "--jobs", "0"], "Invalid value for '--jobs'"),
    (["run", "g.yaml", "--bogus"], "No such option: --bogus"),
])
def test_usage_errors_exit_2_with_one_line(args, expect):
    r = subprocess_cli(args)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == EXIT_BAD_INPUT, r.stderr
    assert len(lines) == 1 and lines[0].startswith("error: ") and expect in lines[0], r.stderr
    assert "Usage: proxyshade run" in lines[0] and "Traceback" not in r.stderr


def test_internal_error_is_one_line_exit_1(tmp_path, registry, capsys, monkeypatch):
    from tests.conftest import _TAdd

    def broken(self, ctx):
        raise ZeroDivisionError("division by zero in a node")

    monkeypatch.setattr(_TAdd, "compute", broken)
    code, _, err = cli(capsys, "run", write_graph(tmp_path), "-q")
    assert code == EXIT_INTERNAL and len(err) == 1
    assert err[0].startswith("internal error: NodeError: ") and "ZeroDivisionError: division by zero" in err[0]
    assert "g.yaml:7: node 's'" in err[0]  # the graph file and the node's line
    assert not list(tmp_path.glob("out/s.*")) and temps(tmp_path) == []


# -- 1: Ctrl-C -------------------------------------------------------------------------------------------
def test_ctrl_c_exits_130_with_no_partial_output(tmp_path, registry, capsys, monkeypatch):
    from tests.conftest import _TAdd

    real = _TAdd.compute

    def interrupted_at_frame_2(self, ctx):
        if ctx.frame == 2:
            raise KeyboardInterrupt
        return real(self, ctx)

    monkeypatch.setattr(_TAdd, "compute", interrupted_at_frame_2)
    code, _, err = cli(capsys, "run", write_graph(tmp_path), "-q")
    assert code == EXIT_INTERRUPTED and err == ["interrupted"]
    assert temps(tmp_path) == []
    written = sorted(p.name for p in (tmp_path / "out").iterdir())
    assert "s.0002.exr" not in written and "s.0003.exr" not in written
    for name in written:  # what is there is whole
        if name.endswith(".exr"):
            assert read_plate(tmp_path / "out" / name)["R"].shape == (4, 4)
    monkeypatch.setattr(_TAdd, "compute", real)
    code, out, _ = cli(capsys, "run", write_graph(tmp_path), "-q")
    assert code == 0 and sorted(p.name for p in (tmp_path / "out").iterdir()) == [
        "a.png", "s.0001.exr", "s.0002.exr", "s.0003.exr"]


# -- 5: frame lists --------------------------------------------------------------------------------------
@pytest.mark.parametrize("frames,expect", [
    ("1-99999999999", "--frames: frame range 1-99999999999 has 99999999999 frames"),
    ("1,5-99999", "--frames: frames 5-99999 are outside the graph's frames 1-3"),
    ("", "--frames: no frames given"),
    ("  ", "--frames: no frames given"),
])
def test_frame_lists_are_checked_before_they_are_built(tmp_path, registry, capsys, frames, expect):
    t = time.perf_counter()
    code, _, err = cli(capsys, "run", write_graph(tmp_path), "--frames", frames, "-q")
    assert time.perf_counter() - t < 5
    assert code == EXIT_BAD_INPUT and len(err) == 1 and err[0].startswith(f"error: {expect}"), err
    assert not (tmp_path / "out").exists() and not (tmp_path / ".proxyshade").exists()


def test_graph_frame_range_too_long_is_bad_input(tmp_path, registry, capsys):
    code, _, err = cli(capsys, "run", write_graph(tmp_path, frames="1-99999999999"), "-q")
    assert code == EXIT_BAD_INPUT and len(err) == 1 and "g.yaml:2: frames: frame range 1-99999999999" in err[0]


# -- 7: duplicate keys -----------------------------------------------------------------------------------
@pytest.mark.parametrize("extra,lines", [
    ("  a: {type: TConst, params: {value: 2.0, size: 4}}\n", "lines 5 and 10"),  # a second node 'a'
    ("nodes:\n  b: {type: TConst}\n", "lines 4 and 10"),  # a second nodes: block
    ("  w2: {type: TConst, params: {value: 1.0, value: 2.0}}\n", "lines 10 and 10"),
])
def test_duplicate_keys_are_one_line_errors_with_both_lines(tmp_path, registry, capsys, extra, lines):
    code, _, err = cli(capsys, "run", write_graph(tmp_path, NODES + extra), "-q")
    assert code == EXIT_BAD_INPUT and len(err) == 1 and "appears twice" in err[0] and lines in err[0], err
    assert err[0].startswith(f"error: {tmp_path / 'g.yaml'}:10: key ")
    assert not (tmp_path / "out").exists()


def test_merge_keys_are_not_duplicates(tmp_path, registry, capsys):
    nodes = NODES.replace('  a: {type: TConst, params: {value: "${value}", size: 4}}',
                          '  a: {type: TConst, params: &base {value: 1.0, size: 4}}\n'
                          '  b: {type: TConst, params: {<<: *base, value: 2.0}}')
    code, _, err = cli(capsys, "run", write_graph(tmp_path, nodes), "-q")
    assert code == 0, err


# -- 13: typos in --var ----------------------------------------------------------------------------------
def test_unknown_var_names_the_graphs_variables(tmp_path, registry, capsys):
    code, _, err = cli(capsys, "run", write_graph(tmp_path), "--var", "outt=elsewhere", "-q")
    assert code == EXIT_BAD_INPUT and len(err) == 1
    assert err[0] == (f"error: --var outt: {tmp_path / 'g.yaml'} defines no variable 'outt'; its variables are "
                      "out, value (add it under vars, or fix the name)")
    assert not (tmp_path / "out").exists() and not (tmp_path / "elsewhere").exists()
    assert cli(capsys, "run", write_graph(tmp_path), "--var", "out=elsewhere", "-q")[0] == 0
    assert (tmp_path / "elsewhere" / "s.0001.exr").is_file() and not (tmp_path / "out").exists()


# -- 4: writers know what they wrote ---------------------------------------------------------------------
def test_writer_rewrites_after_another_input_of_the_same_size(tmp_path, registry, capsys):
    nodes = ("  r: {type: TRead, params: {path: value.txt}}\n"
             "  w: {type: ExrWrite, inputs: {image: r}, params: {path: out/r.exr}}\n")
    g = write_graph(tmp_path, nodes, frames="1")
    for value, want_reason in (("1", None), ("2", None), ("1", "output file changed since written: r.exr")):
        (tmp_path / "value.txt").write_text(value)
        code, out, err = cli(capsys, "run", g, "--explain")
        assert code == 0 and err == []
        assert read_plate(tmp_path / "out" / "r.exr")["R"][0, 0] == float(value)
        if want_reason:
            assert explain_rows(out)[("w", "1")][:2] == ["computed", want_reason]
    size = (tmp_path / "out" / "r.exr").stat().st_size
    (tmp_path / "out" / "r.exr").write_bytes(b"\0" * size)  # same size, other content
    code, out, _ = cli(capsys, "run", g, "--explain")
    assert code == 0 and explain_rows(out)[("w", "1")][:2] == ["computed", "output file changed since written: r.exr"]
    assert read_plate(tmp_path / "out" / "r.exr")["R"][0, 0] == 1.0


# -- 3 and 12: a full output disk ------------------------------------------------------------------------
class _FullDiskOutput:
    """An OpenImageIO output whose data does not fit: close() truncates the file and fails."""

    def __init__(self, real):
        self.real, self.path = real, None

    def open(self, path, *a):
        self.path = path
        return self.real.open(path, *a)

    def write_image(self, px):
        return self.real.write_image(px)

    def close(self):
        self.real.close()
        with open(self.path, "r+b") as f:
            f.truncate(20)
        return False

    def geterror(self):
        return "Could not write\nPNG: No space left on device\n  at line 3"


def test_full_disk_png_exits_74_and_leaves_nothing(tmp_path, registry, capsys, monkeypatch):
    real_create = oiio.ImageOutput.create
    monkeypatch.setattr(oiio.ImageOutput, "create", staticmethod(lambda p: _FullDiskOutput(real_create(p))))
    g = write_graph(tmp_path)
    code, _, err = cli(capsys, "run", g, "-q")
    assert code == EXIT_IO and len(err) == 1, err
    assert err[0].startswith(f"error: {tmp_path / 'g.yaml'}:9: p@1: ") and "a.png: cannot write PNG" in err[0]
    assert "(Could not write; PNG: No space left on device; at line 3)" in err[0]  # the library's lines, joined
    assert not (tmp_path / "out" / "a.png").exists() and temps(tmp_path) == []
    monkeypatch.undo()
    code, out, _ = cli(capsys, "run", g, "--explain")
    assert code == 0 and explain_rows(out)[("p", "1")][0] == "computed"
    assert oiio.ImageBuf(str(tmp_path / "out" / "a.png")).get_pixels(oiio.UINT8).shape == (4, 4, 3)
    # a truncated output (a full disk before this fix, or a copy that failed) is written again
    png = tmp_path / "out" / "a.png"
    png.write_bytes(png.read_bytes()[:30])
    code, out, _ = cli(capsys, "run", g, "--explain")
    assert code == 0 and explain_rows(out)[("p", "1")][:2] == ["computed", "output file changed since written: a.png"]
    assert oiio.ImageBuf(str(png)).get_pixels(oiio.UINT8).shape == (4, 4, 3)


def test_full_disk_exr_exits_74(tmp_path, registry, capsys, monkeypatch):
    import OpenEXR

    real_file = OpenEXR.File

    class FullDisk:
        def __init__(self, *a, **k):
            self.f = real_file(*a, **k)

        def __enter__(self):
            return self

        def __exit__(self, *a):
            return False

        def __getattr__(self, name):
            return getattr(self.f, name)

        def write(self, path):
            if "/out/" in path:
                Path(path).write_bytes(b"\x76\x2f\x31\x01partial")
                raise OSError(errno.ENOSPC, "No space left on device")
            self.f.write(path)

    monkeypatch.setattr(OpenEXR, "File", FullDisk)
    code, _, err = cli(capsys, "run", write_graph(tmp_path), "-q")
    assert code == EXIT_IO and len(err) == 1 and "cannot write EXR (No space left on device)" in err[0], err
    assert not list((tmp_path / "out").glob("*.exr")) and temps(tmp_path) == []


# -- 11: symlinks and devices at the output path ---------------------------------------------------------
def test_symlinked_output_is_written_through(tmp_path, registry, capsys):
    (tmp_path / "out").mkdir()
    (tmp_path / "elsewhere").mkdir()
    target = tmp_path / "elsewhere" / "a.png"
    target.write_bytes(b"old")
    (tmp_path / "out" / "a.png").symlink_to(target)
    code, _, err = cli(capsys, "run", write_graph(tmp_path), "-q")
    assert code == 0 and err == []
    assert (tmp_path / "out" / "a.png").is_symlink() and os.readlink(tmp_path / "out" / "a.png") == str(target)
    assert oiio.ImageBuf(str(target)).get_pixels(oiio.UINT8).shape == (4, 4, 3)
    assert temps(tmp_path) == []


@pytest.mark.parametrize("kind", ["fifo", "device", "folder"])
def test_non_regular_output_is_refused(tmp_path, registry, capsys, kind):
    (tmp_path / "out").mkdir()
    name = "shot[v2]_[left].png"  # brackets survive in the message (rich markup would eat them)
    target = tmp_path / "out" / name
    if kind == "fifo":
        os.mkfifo(target)
    elif kind == "folder":
        target.mkdir()
    else:  # a null device of its own: a regression replaces this node, never the machine's /dev/null
        try:
            os.mknod(target, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
        except (PermissionError, OSError):
            pytest.skip("creating a device node needs root")
    nodes = NODES.replace("${out}/a.png", str(target))
    code, _, err = cli(capsys, "run", write_graph(tmp_path, nodes), "-q")
    what = {"fifo": "is a FIFO", "device": "is a character device", "folder": "is a folder"}[kind]
    assert code == EXIT_BAD_INPUT and len(err) == 1 and f"{target}: {what}" in err[0], err
    mode = target.stat().st_mode
    assert {"fifo": stat.S_ISFIFO, "device": stat.S_ISCHR, "folder": stat.S_ISDIR}[kind](mode)
    assert temps(tmp_path) == []


# -- 8: damaged records, read-only caches ----------------------------------------------------------------
def _entries(cache: Path) -> list[Path]:
    return sorted(p for p in cache.glob("*/*.json") if p.parent.name != "runs")


@pytest.mark.parametrize("content", ["[1, 2]", '"text"', "null", "{not json"])
def test_damaged_records_are_recomputed(tmp_path, registry, capsys, content):
    g = write_graph(tmp_path)
    assert cli(capsys, "run", g, "-q")[0] == 0
    cache = tmp_path / ".proxyshade" / "cache"
    for p in _entries(cache) + list((cache / "runs").glob("*.json")):
        p.write_text(content)
    code, out, err = cli(capsys, "run", g, "-q")
    assert code == 0, err
    assert all(line.startswith("warning: cache entry ") for line in err)
    for p in _entries(cache):  # every record is whole again
        assert isinstance(json.loads(p.read_text()), dict)
    code, out, err = cli(capsys, "run", g, "-q")
    assert code == 0 and err == [] and "0 computed" in out


def _read_only(monkeypatch, attempts: list):
    import proxyshade.graph.cache as cache_mod

    def refuse(path, *a, **k):
        attempts.append(str(path))
        raise OSError(errno.EROFS, "Read-only file system", str(path))

    monkeypatch.setattr(cache_mod, "write_text_atomic", refuse)
    monkeypatch.setattr(cache_mod, "write_plate_temp", refuse)


def test_read_only_cache_serves_hits(tmp_path, registry, capsys, monkeypatch):
    g = write_graph(tmp_path)
    assert cli(capsys, "run", g, "-q")[0] == 0
    before = listing(tmp_path)
    attempts = []
    _read_only(monkeypatch, attempts)
    code, out, err = cli(capsys, "run", g, "-q")
    assert code == 0 and err == [] and "0 computed" in out
    assert attempts == [] and listing(tmp_path) == before
    # a miss is computed, kept in memory, and said so; nothing is written to the cache
    code, out, err = cli(capsys, "run", g, "--set", "a.value=5.0", "-q")
    assert code == 0 and err == [], err
    assert "is read-only: " in out and "were not stored" in out
    assert read_plate(tmp_path / "out" / "s.0002.exr")["R"][0, 0] == 7.0
    assert {k: v for k, v in listing(tmp_path).items() if not k.startswith("out")} == \
        {k: v for k, v in before.items() if not k.startswith("out")}


# -- 10: an entry's files under another key; content hash mismatch ---------------------------------------
def test_another_entrys_files_under_a_key_are_not_used(tmp_path, registry, capsys):
    g = write_graph(tmp_path)
    assert cli(capsys, "run", g, "-q")[0] == 0
    from proxyshade.graph.graph import Graph

    plan = Graph.load(g).plan()
    k1, k2 = plan.keys[("s", 1)], plan.keys[("s", 2)]
    cache = tmp_path / ".proxyshade" / "cache"
    for ext in (".exr", ".json"):  # frame 2's entry becomes a copy of frame 1's
        shutil.copy(cache / k1[:2] / f"{k1}{ext}", cache / k2[:2] / f"{k2}{ext}")
    (tmp_path / "out" / "s.0002.exr").unlink()
    code, out, err = cli(capsys, "run", g, "--explain")
    assert code == 0 and len(err) == 1 and err[0].startswith(f"warning: cache entry {k2[:12]}")
    assert f"its record is for key {k1[:12]}" in err[0]
    assert explain_rows(out)[("s", "2")][:2] == ["computed", "corrupt cache entry (record of another key)"]
    assert read_plate(tmp_path / "out" / "s.0002.exr")["R"][0, 0] == 3.0  # 1 + frame 2, not frame 1's 2
    # the record rewritten to name the key, the EXR still frame 1's: its header's key gives it away
    rec = json.loads((cache / k1[:2] / f"{k1}.json").read_text())
    shutil.copy(cache / k1[:2] / f"{k1}.exr", cache / k2[:2] / f"{k2}.exr")
    (cache / k2[:2] / f"{k2}.json").write_text(json.dumps(dict(rec, key=k2)))
    (tmp_path / "out" / "s.0002.exr").unlink()
    code, out, err = cli(capsys, "run", g, "--explain")
    assert code == 0 and len(err) == 1 and "header proxyshade/key is" in err[0], err
    assert explain_rows(out)[("s", "2")][:2] == ["computed", "corrupt cache entry (unreadable)"]
    assert read_plate(tmp_path / "out" / "s.0002.exr")["R"][0, 0] == 3.0


def test_content_hash_mismatch_is_reported_as_computed(tmp_path, registry, capsys):
    g = write_graph(tmp_path)
    assert cli(capsys, "run", g, "-q")[0] == 0
    from proxyshade.graph.graph import Graph

    key = Graph.load(g).plan().keys[("s", 1)]
    exr = tmp_path / ".proxyshade" / "cache" / key[:2] / f"{key}.exr"
    data = bytearray(exr.read_bytes())
    data[-8:] = b"\xff" * 8
    exr.write_bytes(bytes(data))
    (tmp_path / "out" / "s.0001.exr").unlink()  # the writer must read s@1 again
    code, out, err = cli(capsys, "run", g, "--explain")
    assert code == 0 and len(err) == 1 and "content hash mismatch" in err[0], err
    assert explain_rows(out)[("s", "1")][:2] == ["computed", "corrupt cache entry (content hash)"]
    assert "2 computed" in out  # s@1 and w@1


# -- 9: temporaries of killed runs -----------------------------------------------------------------------
def test_stale_temporaries_are_counted_and_removed(tmp_path, registry, capsys):
    g = write_graph(tmp_path)
    assert cli(capsys, "run", g, "-q")[0] == 0
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    cache = tmp_path / ".proxyshade" / "cache"
    sub = next(p for p in cache.iterdir() if p.name != "runs")
    from proxyshade.io.files import HOST

    stale = [sub / f".{'a' * 64}.exr.{dead.pid}.0.tmp.exr", cache / "runs" / f".x.json.{dead.pid}.3.tmp",
             cache / f".CACHEDIR.TAG.{dead.pid}-{HOST}.0.tmp",  # a run killed as it tagged the cache folder
             tmp_path / "out" / f".s.0001.exr.{dead.pid}.7.tmp.exr", tmp_path / "out" / ".a.png.1.2.tmp.png"]
    live = tmp_path / "out" / ".a.png.1.3.tmp.png"  # pid 1 is alive: another run's write in progress
    for p in stale + [live]:
        p.write_bytes(b"x" * 1000)
    old = time.time() - 2 * 24 * 3600
    os.utime(stale[-1], (old, old))  # but a day old: stale all the same
    code, out, _ = cli(capsys, "cache", "info", g)
    assert code == 0 and "2 temporary file(s) (0.0 MB, 2 left by killed runs" in out
    code, out, err = cli(capsys, "run", g, "-q")
    assert code == 0 and err == [] and "note removed 5 temporary file(s) left by killed runs" in out
    assert temps(tmp_path) == [live]
    assert "temporary" not in cli(capsys, "cache", "info", g)[1]


# -- 6: hostile YAML -------------------------------------------------------------------------------------
def bomb(indent: str) -> str:
    """YAML anchors l0..l11, each eight aliases of the one before: 8**11 items once expanded."""
    lines = [f"{indent}l0: &l0 [x]"] + [f"{indent}l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * 8)}]" for i in range(1, 12)]
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("where", ["param", "var"])
def test_alias_bomb_is_refused_quickly(tmp_path, where):
    if where == "param":
        text = "format: proxyshade/1\nnodes:\n  c:\n    type: TConst\n    params:\n      value:\n" + bomb(" " * 8)
    else:
        text = ("format: proxyshade/1\nvars:\n  bomb:\n" + bomb(" " * 4) + "  use: *l11\n"
                "nodes:\n  c: {type: TConst, params: {value: \"${use}\"}}\n")
    g = tmp_path / "g.yaml"
    g.write_text(text)
    t = time.perf_counter()
    r = subprocess_cli(["run", str(g), "-q"], timeout=60)
    assert time.perf_counter() - t < 30
    lines = r.stderr.strip().splitlines()
    assert r.returncode == EXIT_BAD_INPUT and len(lines) == 1, r.stderr
    assert "expands to more than 100000 items" in lines[0]
    assert not (tmp_path / ".proxyshade").exists()


def test_deep_nesting_and_binary_files_are_one_line_errors(tmp_path, capsys):
    deep = tmp_path / "deep.yaml"
    deep.write_text("format: proxyshade/1\nnodes: " + "[" * 20000 + "]" * 20000 + "\n")
    code, _, err = cli(capsys, "run", deep)
    assert code == EXIT_BAD_INPUT and len(err) == 1 and "deep.yaml: nested too deeply" in err[0], err
    binary = tmp_path / "bin.yaml"
    binary.write_bytes(b"format: proxyshade/1\n\x89PNG\r\n\x1a\n\x00\xff\xfe")
    code, _, err = cli(capsys, "run", binary)
    assert code == EXIT_BAD_INPUT and len(err) == 1 and "bin.yaml:2: not a UTF-8 text file" in err[0], err


# -- 12: messages keep their parts -----------------------------------------------------------------------
def test_bracketed_values_survive_in_messages(tmp_path, registry, capsys):
    code, _, err = cli(capsys, "run", write_graph(tmp_path), "--set", "a.size=[.nan, 64]", "-q")
    assert code == EXIT_BAD_INPUT and len(err) == 1 and "got [nan, 64]" in err[0], err


def test_node_errors_name_the_graph_file_and_line(tmp_path, registry, capsys):
    nodes = NODES.replace("channels: [label.id]", "channels: [nope]")
    code, _, err = cli(capsys, "run", write_graph(tmp_path, nodes), "-q")
    assert code == EXIT_BAD_INPUT and len(err) == 1 and err[0].startswith(f"error: {tmp_path / 'g.yaml'}:9: p@1: "), err


def test_cache_warning_is_one_line(tmp_path, registry, capsys):
    g = write_graph(tmp_path)
    assert cli(capsys, "run", g, "-q")[0] == 0
    from proxyshade.graph.graph import Graph

    key = Graph.load(g).plan().keys[("s", 3)]
    exr = tmp_path / ".proxyshade" / "cache" / key[:2] / f"{key}.exr"
    exr.write_bytes(exr.read_bytes()[:40])
    code, _, err = cli(capsys, "run", g, "-q")
    assert code == 0 and err == [f"warning: cache entry {key[:12]} for node 's' frame 3 is corrupt "
                                 "(size mismatch (truncated?)); recomputing"]


def test_truncated_png_is_one_line(tmp_path, capfd):
    shutil.copytree(ROOT / "samples" / "renoir", tmp_path / "samples" / "renoir")
    (tmp_path / "graphs").mkdir()
    shutil.copy(ROOT / "graphs" / "import_source.yaml", tmp_path / "graphs" / "import_source.yaml")
    png = tmp_path / "samples" / "renoir" / "style.png"
    png.write_bytes(png.read_bytes()[: png.stat().st_size // 3])
    code, _, err = cli(capfd, "run", tmp_path / "graphs" / "import_source.yaml", "-q")  # capfd: the libraries' output too
    assert code == EXIT_BAD_INPUT and len(err) == 1, err
    assert "style.png: cannot read image (truncated: the file ends inside its IDAT chunk" in err[0]


# -- 13 and 12: scenes that render nothing, malformed USD ------------------------------------------------
def _scene_graph(tmp_path: Path, scene: str) -> Path:
    from proxyshade.graph.plate import Plate
    from proxyshade.io.exr import write_plate

    table = [{"name": "sky", "id": 2, "color": "#ffffff"}, {"name": "water", "id": 3, "color": "#0000ff"}]
    write_plate(tmp_path / "src.exr", Plate({"label.id": np.zeros((2, 2), np.uint32)}, {"labels": table}))
    nodes = ("  src: {type: ExrRead, params: {path: src.exr}}\n"
             f"  proxy: {{type: ProxyRender, inputs: {{source: src}}, params: {{scene: {scene}, resolution: [8, 8]}}}}\n"
             "  w: {type: ExrWrite, inputs: {image: proxy}, params: {path: out/proxy.exr}}\n")
    return write_graph(tmp_path, nodes, frames="1", vars_="")


@pytest.mark.parametrize("case,expect", [
    ("empty", "the scene has no proxy prims (labelled meshes or spheres not marked CG), so the render is all 'sky'; "
              "add labelled geometry"),
    ("behind", "no proxy prim is in view of the camera at frame 1, so the render is all 'sky'; check the camera"),
])
def test_scene_that_renders_only_sky_warns(tmp_path, capsys, case, expect):
    from pxr import Gf, Usd, UsdGeom, UsdSemantics, Vt

    s = Usd.Stage.CreateNew(str(tmp_path / "s.usda"))
    world = UsdGeom.Xform.Define(s, "/World")
    s.SetDefaultPrim(world.GetPrim())
    cam = UsdGeom.Camera.Define(s, "/World/Cam")
    cam.CreateHorizontalApertureAttr(36)
    cam.CreateVerticalApertureAttr(36)
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.1, 1000))
    if case == "behind":  # a labelled plane behind the camera (it looks down -Z)
        m = UsdGeom.Mesh.Define(s, "/World/Plane")
        m.CreatePointsAttr([(-9, -9, 5), (9, -9, 5), (9, 9, 5), (-9, 9, 5)])
        m.CreateFaceVertexCountsAttr([4])
        m.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
        UsdSemantics.LabelsAPI.Apply(m.GetPrim(), "texture").CreateLabelsAttr().Set(Vt.TokenArray(["water"]))
    s.Save()
    code, out, err = cli(capsys, "run", _scene_graph(tmp_path, "s.usda"), "-q")
    assert code == 0 and err == [f"warning: proxy: s.usda: {expect}"], err
    assert f"note proxy@1: proxy: s.usda: {expect}" in out
    assert (read_plate(tmp_path / "out" / "proxy.exr")["label.id"] == 2).all()


def test_malformed_usd_keeps_usds_parse_error(tmp_path, capsys):
    scene = tmp_path / "bad.usda"
    scene.write_text('#usda 1.0\ndef Xform "World" {\n  def Mesh "M" {\n    point3f[] points = [(0, 0, 0), (1, 1\n  }\n}\n')
    code, _, err = cli(capsys, "run", _scene_graph(tmp_path, "bad.usda"), "-q")
    assert code == EXIT_BAD_INPUT and len(err) == 1, err
    assert f"{scene}: cannot open USD stage: {scene}:5:3: parse error" in err[0], err
    assert "pxrInternal" not in err[0] and not (tmp_path / "out").exists()


def test_a_long_bad_value_is_cut_in_its_message(tmp_path, registry, capsys):
    nodes = NODES.replace("size: 4}", "size: [" + ", ".join(["64"] * 50000) + "]}")
    code, _, err = cli(capsys, "run", write_graph(tmp_path, nodes), "-q")
    assert code == EXIT_BAD_INPUT and len(err) == 1 and len(err[0]) < 700, err[0][:300]
    assert "nodes.a.params.size: expected int >= 1, got [64, 64" in err[0] and "characters)" in err[0]
