"""The first run after an install: the lake's first frame (graphs/first_frame.yaml) with a
cold numba cache (``NUMBA_CACHE_DIR`` at a fresh temporary folder) and a cold graph cache,
in a fresh process. Prints its wall time, how many kernel signatures compiled (compiled
signatures of every numba dispatcher defined in ``proxyshade.kernels``, counted in that
process after the run) and the kernels whose compiles took longest (numba's compile
events). ``--repeat N`` (default 1: each run compiles for about a minute on 2 cores)."""
from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from harness import table

ROOT = Path(__file__).resolve().parents[1]

# run in the child: the first frame, then the kernel signatures and compile times as JSON
CHILD = r"""
import json, sys, time
from numba.core import event

class Rec(event.Listener):
    # compile seconds per kernel, its own (less the kernels it calls compiling inside)
    def __init__(self):
        self.stack, self.spent = [], {}
    def on_start(self, ev):
        self.stack.append([time.perf_counter(), 0.0])
    def on_end(self, ev):
        t0, inner = self.stack.pop()
        t = time.perf_counter() - t0
        if self.stack:
            self.stack[-1][1] += t
        d = ev.data["dispatcher"]
        name = f"{d.py_func.__module__.rpartition('.')[2]}.{d.py_func.__name__}"
        if d.targetoptions.get("parallel"):
            name += " (parallel)"
        self.spent[name] = self.spent.get(name, 0.0) + t - inner

rec = Rec()
event.register("numba:compile", rec)
from proxyshade.graph.graph import Graph
t0 = time.perf_counter()
g = Graph.load(sys.argv[1], cache=sys.argv[2], variables={"scene": "lake", "source": "renoir", "out": sys.argv[3]})
g.run([1])
wall = time.perf_counter() - t0
from proxyshade.graph.warmup import kernel_dispatchers
sigs = {k: len(d.signatures) for k, d in kernel_dispatchers().items()}
print(json.dumps({"wall": wall, "sigs": sigs, "spent": rec.spent}))
"""


def cold_first_frame() -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=f"{tmp}/numba", PYTHONPATH=str(ROOT))
        t0 = time.perf_counter()
        res = subprocess.run([sys.executable, "-c", CHILD, str(ROOT / "graphs" / "first_frame.yaml"),
                              f"{tmp}/cache", f"{tmp}/out"], env=env, capture_output=True, text=True, check=True)
        wall = time.perf_counter() - t0
    r = json.loads(res.stdout.strip().splitlines()[-1])
    r["process"] = wall
    return r


def main(repeat: int = 1):
    runs = [cold_first_frame() for _ in range(repeat)]
    process = [r["process"] for r in runs]
    graph = [r["wall"] for r in runs]
    last = runs[-1]
    n = sum(last["sigs"].values())
    table(f"cold numba cache, lake first frame (fresh process, {repeat} run(s), load {os.getloadavg()[0]:.1f})", [
        ("process wall (imports + compile + run)", {"median": statistics.median(process), "min": min(process)}, None),
        ("Graph.load + run", {"median": statistics.median(graph), "min": min(graph)}, None),
    ])
    print(f"kernel signatures compiled: {n} in {sum(1 for v in last['sigs'].values() if v)} dispatchers "
          f"({len(last['sigs'])} dispatchers loaded)")
    multi = {k: v for k, v in last["sigs"].items() if v > 1}
    if multi:
        print("dispatchers with more than one signature: " + ", ".join(f"{k} {v}" for k, v in sorted(multi.items())))
    print(f"compile seconds: {sum(last['spent'].values()):.1f}; slowest (own seconds, less the kernels they call):")
    for name, s in sorted(last["spent"].items(), key=lambda kv: -kv[1])[:12]:
        print(f"  {name:<40} {s:7.2f}")


if __name__ == "__main__":
    main(int(sys.argv[sys.argv.index("--repeat") + 1]) if "--repeat" in sys.argv else 1)
