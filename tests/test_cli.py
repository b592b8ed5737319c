"""The command line: exit codes, explain, inspect, nodes, cache."""
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from proxyshade.cli import main

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def demo(tmp_path):
    """The demo graph copied beside a copy of the renoir sample."""
    (tmp_path / "graphs").mkdir()
    shutil.copytree(ROOT / "samples" / "renoir", tmp_path / "samples" / "renoir")
    shutil.copy(ROOT / "graphs" / "demo.yaml", tmp_path / "graphs" / "demo.yaml")
    return tmp_path / "graphs" / "demo.yaml"


def test_run_then_rerun_reuses_everything(demo, capsys):
    assert main(["run", str(demo), "-q"]) == 0
    assert "4 computed, 0 reused" in capsys.readouterr().out
    assert (demo.parent.parent / "out" / "demo" / "source.exr").is_file()
    assert main(["run", str(demo), "--explain", "-q"]) == 0
    text = capsys.readouterr().out
    assert "0 computed, 4 reused" in text and "cache hit" in text


def test_bad_input_exits_2_with_one_line(demo, capsys):
    assert main(["run", str(demo), "--set", "src.far_distance=-1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "src.far_distance: expected float >= 0.0, got -1" in err
    assert main(["run", str(demo.parent / "missing.yaml")]) == 2
    assert main(["run", str(demo), "--frames", "7"]) == 2  # outside the graph's frames
    assert "outside the graph's frames 1-1" in capsys.readouterr().err


def test_missing_source_file_is_bad_input(demo, capsys):
    (demo.parent.parent / "samples" / "renoir" / "style.png").unlink()
    assert main(["run", str(demo), "-q"]) == 2
    assert "style.png: no such image file" in capsys.readouterr().err


def test_inspect_nodes_graph_and_cache(demo, capsys):
    main(["run", str(demo), "-q"])
    capsys.readouterr()
    assert main(["inspect", str(demo.parent.parent / "out" / "demo" / "source.exr")]) == 0
    text = capsys.readouterr().out
    assert "label.id" in text and "uint" in text and "proxyshade/node: write" in text
    assert main(["nodes"]) == 0
    assert "SourceRead" in capsys.readouterr().out
    assert main(["graph", str(demo)]) == 0
    assert "write [ExrWrite] image<-src" in capsys.readouterr().out
    assert main(["cache", "info", str(demo)]) == 0
    assert "5 entries" in capsys.readouterr().out
    assert main(["cache", "clean", str(demo)]) == 0
    assert main(["run", str(demo), "-q"]) == 0
    assert "4 computed" in capsys.readouterr().out


def test_console_script_exit_code(demo):
    exe = Path(sys.executable).parent / "proxyshade"
    r = subprocess.run([str(exe), "run", str(demo), "--set", "nope.x=1"], capture_output=True, text=True)
    assert r.returncode == 2 and "no node 'nope'" in r.stderr and "Traceback" not in r.stderr
