"""kill -9 and Ctrl-C (SIGINT) at random points of a small graph's run, 10 times each: an
interrupted run exits 130 with one line and leaves only whole outputs and no temporaries; after
either, a re-run gives outputs bit-identical to an uninterrupted run and leaves no temporaries."""
from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from proxyshade.cli import main

ROOT = Path(__file__).resolve().parents[2]
GRAPH = """\
format: proxyshade/1
frames: 1-6
nodes:
  a: {type: TConst, params: {value: 0.5, size: 192, seed: 3}}
  s: {type: TAdd, inputs: {a: a, prev: {node: s, frame: -1}}, params: {gain: 0.5}}
  w: {type: ExrWrite, inputs: {image: s}, params: {path: out/s.####.exr}}
  p: {type: Preview, inputs: {image: a}, params: {path: out/a.####.png, channels: [label.id]}}
  m: {type: Movie, inputs: {image: {node: a, frame: all}}, params: {path: out/a.gif, channels: [label.id], max_size: 64}}
"""
# the CLI as the console script runs it, in a fresh interpreter with the test node types; "ready"
# once everything is imported. Ctrl-C raises KeyboardInterrupt as in a terminal, also where the
# tests run as a background job (the shell starts those with SIGINT ignored, which children inherit)
RUNNER = ("import signal, sys; signal.signal(signal.SIGINT, signal.default_int_handler)\n"
          "sys.path.insert(0, sys.argv.pop(1)); sys.argv[0] = 'proxyshade'\n"
          "import proxyshade.nodes, proxyshade.graph.graph; from proxyshade.graph.node import REGISTRY\n"
          "from tests.conftest import TYPES; REGISTRY.update(TYPES); from proxyshade.cli import main\n"
          "print('ready', flush=True); sys.exit(main())")


def start(folder: Path, jobs: int) -> subprocess.Popen:
    p = subprocess.Popen([sys.executable, "-c", RUNNER, str(ROOT), "run", str(folder / "g.yaml"), "-q",
                          "--jobs", str(jobs)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         env=dict(os.environ, PYTHONPATH=str(ROOT), PROXYSHADE_CACHE=str(folder / ".cache")),
                         cwd=str(folder))  # each run its own plate cache: every run computes
    assert p.stdout.readline().strip() == "ready"
    return p


def files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def temps(folder: Path) -> list[str]:
    return sorted(str(p) for p in folder.rglob(".*") if ".tmp" in p.name)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """Outputs of an uninterrupted run, and how long the run takes from the imports to its summary."""
    warm = tmp_path_factory.mktemp("warm-up")  # a first run may precompile kernels: not part of a run's time
    (warm / "g.yaml").write_text(GRAPH)
    start(warm, 1).communicate(timeout=300)
    folder = tmp_path_factory.mktemp("reference")
    (folder / "g.yaml").write_text(GRAPH)
    p = start(folder, 1)
    t = time.perf_counter()
    while "computed," not in p.stdout.readline():
        pass
    seconds = time.perf_counter() - t
    _, err = p.communicate(timeout=120)
    assert p.returncode == 0, err
    return files(folder / "out"), seconds


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGINT], ids=["kill-9", "sigint"])
def test_interrupted_runs_rerun_bit_identical(tmp_path, registry, capsys, reference, sig):
    want, seconds = reference
    rng = random.Random(13 + sig)
    interrupted = 0
    for i in range(20):  # ten runs, more while fewer than five were cut mid-run (a load that varies)
        if i >= 10 and interrupted >= 5:
            break
        folder = tmp_path / f"run{i}"
        folder.mkdir()
        (folder / "g.yaml").write_text(GRAPH)
        delay = rng.uniform(0.0, 0.7 * seconds)  # mid-run: a signal in the last tenths can land after the work
        p = start(folder, jobs=1 + i % 2)
        time.sleep(delay)
        p.send_signal(sig)
        _, err = p.communicate(timeout=120)
        lines = [line for line in err.splitlines() if line.strip()]
        got = files(folder / "out") if (folder / "out").is_dir() else {}
        interrupted += p.returncode != 0
        if p.returncode == 0:
            seconds *= 0.7  # the run was done before the signal: the machine is faster now than at the reference
        if sig == signal.SIGINT:
            assert (p.returncode, lines) in ((130, ["interrupted"]), (0, [])), (delay, p.returncode, err)
            assert temps(folder) == [], delay  # an interrupted run cleans up after itself
            assert all(got[k] == want[k] for k in got), delay  # what is there is whole
        else:
            assert p.returncode in (-signal.SIGKILL, 0), (delay, err)
        rerun = ["run", str(folder / "g.yaml"), "-q", "--cache", str(folder / ".cache")]  # the interrupted run's cache
        assert main(rerun) == 0, (delay, capsys.readouterr())
        capsys.readouterr()
        assert files(folder / "out") == want, delay
        assert temps(folder) == [], delay
        assert main(rerun) == 0
        assert "0 computed" in capsys.readouterr().out, delay  # and the cache holds everything
    assert interrupted >= 5  # the signals landed mid-run, not after it
