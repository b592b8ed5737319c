"""Where a run's time goes (``proxyshade run --profile``, proxyshade/graph/profile.py), the
order writers run in, and which kernels a graph's first run precompiles."""
from __future__ import annotations

import mmap
import re
import shutil
from pathlib import Path

import networkx as nx
import pytest

from proxyshade.cli import main
from proxyshade.graph import profile, warmup
from proxyshade.graph.executor import SerialExecutor, ThreadExecutor
from proxyshade.kernels import _cache

ROOT = Path(__file__).resolve().parents[2]


def _graph(tmp_path: Path) -> Path:
    (tmp_path / "graphs").mkdir()
    shutil.copytree(ROOT / "samples" / "renoir", tmp_path / "samples" / "renoir")
    shutil.copy(ROOT / "graphs" / "import_source.yaml", tmp_path / "graphs" / "import_source.yaml")
    return tmp_path / "graphs" / "import_source.yaml"


def test_profile_splits_the_wall_time_and_names_the_peak(tmp_path, capsys):
    """The profile's rows add up to its total (the process's age at the report), every
    computed node has a row, and the memory part names a node and the plates held."""
    graph = _graph(tmp_path)
    assert main(["run", str(graph), "-q", "--profile", "--cache", str(tmp_path / "c")]) == 0
    text = capsys.readouterr().out
    rows = dict(re.findall(r"^ +(\S[^\n]*?)\s{2,}(\d+\.\d{3})  ", text, re.M))
    for name in ("process start + imports", "kernel loading", "output writes (waited)", "cache writes (waited)", "total"):
        assert name in rows, text  # the writer ran beside the nodes: the run's wait for it is on its path
    assert "src@1" in rows and float(rows["src@1"]) > 0
    parts = sum(float(v) for k, v in rows.items() if k not in ("total",))
    assert abs(parts - float(rows["total"])) <= 0.01 + 0.01 * float(rows["total"]), text
    m = re.search(r"peak (\d+) MiB while (.+?); plates held then \(MiB resident[^)]*\): (.*)", text)
    assert m and int(m[1]) > 50 and "@1" in m[2], text  # nodes side by side, or after one
    held = re.findall(r"(\S+@1) (\d+) \((\d+)\)", m[3])
    assert held and all(int(r) <= int(a) + 1 for _, r, a in held), text  # resident within allocated
    # what the peak holds: mapped libraries, the heap at the first node, plates, what stayed loaded
    # since, the node's working arrays; adding up to it
    parts = re.search(r"the peak holds: libraries \(mapped files\) (\d+), heap before the first node (\d+), "
                      r"plates held (\d+), loaded since \(kernels, modules\) (\d+), working memory(?: of \S+@1)? "
                      r"(-?\d+) MiB", text)
    assert parts and int(parts[1]) > 10 and int(parts[2]) > 10, text
    assert abs(sum(int(x) for x in parts.groups()) - int(m[1])) <= 3, text
    # the mapped files by package, the largest first, adding up to about the libraries' part
    libs = re.search(r"mapped files at the end, by package: (.*) MiB", text)
    sizes = [int(x) for x in re.findall(r" (\d+)(?:,|$)", libs[1])]
    assert libs and "numpy" in libs[1] and sizes[:-1] == sorted(sizes[:-1], reverse=True), text
    assert "4 computed" in text  # the run itself as without --profile
    assert main(["run", str(graph), "-q", "--cache", str(tmp_path / "c")]) == 0
    assert "0 computed, 4 reused" in capsys.readouterr().out


def test_plates_are_counted_by_resident_pages_each_page_once():
    """``plate_memory``: a plate's arrays count for the pages they hold in the resident set,
    once: pages of arrays a plate shares with one before it (a view of its buffer) count
    for the first; pages allocated but never written count nothing, nor (where the kernel
    can tell the zero page: PAGEMAP_SCAN) pages only read."""
    import numpy as np

    from proxyshade.graph.plate import Plate

    # 4 MiB never written: a private anonymous mapping of its own (np.zeros may reuse freed heap that
    # calloc then clears, writing every page, in a process that has run other tests)
    anon = mmap.mmap(-1, 4 << 20, flags=mmap.MAP_PRIVATE | mmap.MAP_ANONYMOUS)
    zeros = np.frombuffer(anon, np.float32).reshape(2, 512, 1024)
    data = np.ones((2, 512, 1024), np.float32)  # 4 MiB, written
    first = Plate({"a": data[0], "z": zeros[0]})
    second = Plate({"a": data[0], "b": data[1], "z": zeros[1]})  # shares first's buffers
    (n1, r1, a1), (n2, r2, a2) = profile.plate_memory([("first", first), ("second", second)])
    assert (n1, n2) == ("first", "second")
    assert abs(a1 - 4.0) < 0.01 and abs(a2 - 4.0) < 0.01  # allocated, each page once
    assert abs(r1 - 2.0) < 0.05 and abs(r2 - 2.0) < 0.05  # resident: data[0] for the first, data[1]
    (n2, r2, _), (n1, r1, _) = profile.plate_memory([("second", second), ("first", first)])
    assert (n2, n1) == ("second", "first") and abs(r2 - 4.0) < 0.05 and r1 < 0.05
    assert profile.resident_bytes([]) == []
    if profile._pagemap_scan([]) is None:
        pytest.skip("no PAGEMAP_SCAN (Linux < 6.7): a page only read cannot be told from one written")
    assert float(zeros.sum()) == 0.0  # read: the zero page mapped, nothing resident
    (_, r1, _), (_, r2, _) = profile.plate_memory([("first", first), ("second", second)])
    assert abs(r1 - 2.0) < 0.05 and abs(r2 - 2.0) < 0.05


def test_writers_run_as_soon_as_their_input_is_ready():
    """Among ready instances the writers (marked ``first``) run before the others, in both
    local executors, so the plate they read leaves memory sooner; the order is the same
    every time."""
    dag = nx.DiGraph()
    dag.add_node(("a", 1))
    dag.add_node(("b", 1))
    dag.add_node(("preview", 1), first=True)
    dag.add_node(("z_write", 1), first=True)
    dag.add_edges_from([(("a", 1), ("b", 1)), (("a", 1), ("preview", 1)), (("b", 1), ("z_write", 1))])
    for ex in (SerialExecutor(), ThreadExecutor(1)):
        seen = []
        ex.run(dag, seen.append)
        assert seen == [("a", 1), ("preview", 1), ("b", 1), ("z_write", 1)]


class _G:
    def __init__(self, types):
        self.nodes = {t.lower(): type(t, (), {})() for t in types}
        self.enabled = {n: True for n in self.nodes}


def test_a_graph_precompiles_the_kernels_its_node_types_called_only(monkeypatch):
    """With callers in the manifest, a graph's precompile units are its node types, and
    ``pending`` lists the entries those types called, not the other entries of the same
    kernel modules (kernels the graph never calls are not compiled)."""
    e1 = ("proxyshade.kernels.random._keys", "(int64, int64)", 0.5, ())
    e2 = ("proxyshade.kernels.random._mix", "(uint64,)", 0.5, ())
    monkeypatch.setattr(warmup, "manifest", lambda: [e1, e2])
    monkeypatch.setattr(warmup, "callers", lambda: {e1[:2]: "SourceRead", e2[:2]: "Correct"})
    monkeypatch.setattr(_cache, "kernels_cached", lambda names=(): False)
    units = warmup.manifest_modules(_G(["SourceRead", "ExrWrite"]))
    assert units == {"node.SourceRead", "node.ExrWrite"}
    assert [e[0] for e in warmup.pending(units)] == [e1[0]]
    assert sorted(e[0] for e in warmup.pending()) == sorted([e1[0], e2[0]])


HEAP = """
import sys, numpy as np
from proxyshade.graph.graph import return_freed_memory
from proxyshade.graph.profile import rss_split
if sys.argv[1] == "1":
    assert return_freed_memory()
big = np.ones(5 << 18); del big  # a 10 MiB block freed: glibc's own threshold rises past 8 MiB
before = rss_split()[0] - rss_split()[1]
arrays = []
for i in range(30):
    arrays.append(np.ones(1 << 20))  # 8 MiB each, touched
    arrays.append(np.ones(8000))  # small blocks between them keep the heap from shrinking at its top
del arrays[::2]
print(round(rss_split()[0] - rss_split()[1] - before))
"""


@pytest.mark.skipif(__import__("platform").libc_ver()[0] != "glibc", reason="glibc's allocator")
def test_freed_arrays_leave_the_resident_set_with_the_commands_heap_setting():
    """``graph.return_freed_memory`` (set by ``proxyshade run``): 30 freed 8 MiB arrays between
    small live blocks leave the resident set; with glibc's default they stay (240 MiB)."""
    import os
    import subprocess
    import sys

    # glibc's defaults: no MALLOC_*_ settings (Dask's LocalCluster leaves MALLOC_TRIM_THRESHOLD_ in
    # os.environ, which fixes the thresholds too)
    env = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_") and k != "GLIBC_TUNABLES"}

    def held(setting: str) -> int:
        out = subprocess.run([sys.executable, "-c", HEAP, setting], capture_output=True, text=True, check=True, env=env)
        return int(out.stdout)

    assert held("0") > 200
    assert held("1") < 20
