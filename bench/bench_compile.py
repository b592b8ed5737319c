"""The first run after an install: the lake's first frame (graphs/first_frame.yaml) with a
cold numba cache (``NUMBA_CACHE_DIR`` at a fresh temporary folder) and a cold graph cache,
in a fresh process, as ``proxyshade run`` does it: ``manifest``, the kernel signatures of
the manifest (proxyshade/graph/kernel_manifest.py) compiled first on one process per core
(the run's and spawned workers: ``warmup.precompile``), then the run, which loads what the
workers compiled from numba's cache; ``lazy``,
without the manifest: each kernel compiles in the run's process when first called (the
way before the manifest). Prints, to the end of the first frame: the process wall time,
the CPU seconds of the process (from its start) and of its workers (the work: less
dependent on other load than the wall time; on idle cores the wall time follows the
larger of the two), the precompile's wall time; a hash of the output EXRs (the same in
both modes: the manifest changes no result); how many kernel signatures the run's process
holds (compiled or loaded, over every numba dispatcher defined in ``proxyshade.kernels``;
a kernel loaded from the cache holds the kernels it calls inside it, so fewer show), how
many compiles it ran itself (numba's compile events, numba's own helpers included) and
the kernels whose compiles took longest there; then a forced re-run of the frame in that
process (the kernels' run time: the same whether compiled there or loaded).
``--mode lazy|manifest|both`` (default both), ``--repeat N`` (default 1: a lazy run
compiles for over a minute on 2 cores). ``--mode entries``: each manifest entry the first
frame's precompile compiles, one after another in one fresh process with a cold numba
cache (the work of one precompile worker that took them all): CPU seconds per entry
(kernels it calls included, where not compiled by an earlier entry), whether the kernel
is parallel, and their sum: the figures to cut and to balance the workers by."""
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
        self.stack, self.spent, self.n = [], {}, 0
    def on_start(self, ev):
        self.n += 1
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
from proxyshade.graph import warmup
import resource
def cpu(who=resource.RUSAGE_SELF):
    r = resource.getrusage(who)
    return r.ru_utime + r.ru_stime
c0 = cpu()
t0 = time.perf_counter()
g = Graph.load(sys.argv[1], cache=sys.argv[2], variables={"scene": "lake", "source": "renoir", "out": sys.argv[3]})
pre = warmup.precompile(warmup.manifest_modules(g)) if sys.argv[4] == "manifest" else None
t1, c1 = time.perf_counter(), cpu()
g.run([1])
c2, t_done = cpu(), time.perf_counter()
cw = cpu(resource.RUSAGE_CHILDREN)
wall = time.perf_counter() - t0
sigs = {k: len(d.signatures) for k, d in warmup.kernel_dispatchers().items()}
n_events = rec.n
reruns = []  # the kernels at run time: forced re-runs, everything compiled or loaded
for _ in range(2):
    t2 = time.perf_counter()
    g.run([1], force=tuple(g.nodes))
    reruns.append(time.perf_counter() - t2)
import hashlib, pathlib
h = hashlib.sha256()
for f in sorted(pathlib.Path(sys.argv[3]).rglob("*.exr")):
    h.update(f.name.encode() + f.read_bytes())
print(json.dumps({"wall": wall, "run": t_done - t1, "sigs": sigs, "spent": rec.spent,
                  "events": n_events, "cpu_split": [c0, c1 - c0, c2 - c1, cw],
                  "after": time.perf_counter() - t_done, "rerun": min(reruns), "exr": h.hexdigest()[:16],
                  "pre": pre and {k: pre[k] for k in ("compiled", "seconds", "workers")}}))
"""


# run in the child: the first frame's manifest entries compiled one after another, CPU seconds each
CHILD_ENTRIES = r"""
import json, sys, time
from proxyshade.graph.graph import Graph
from proxyshade.graph import warmup
g = Graph.load(sys.argv[1], cache=sys.argv[2], variables={"scene": "lake", "source": "renoir", "out": sys.argv[3]})
todo = warmup.pending(warmup.manifest_modules(g))
todo.sort(key=lambda e: [k for k, *_ in warmup.manifest()].index(e[0]))  # manifest (run) order
rows = []
for kernel, text, _ in todo:
    disp = warmup._dispatcher(kernel)
    c0 = time.process_time()
    disp.compile(warmup.parse_types(text))
    rows.append((kernel.rpartition("kernels.")[2], bool(disp.targetoptions.get("parallel")), time.process_time() - c0))
print(json.dumps(rows))
"""


def compile_entries() -> list:
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=f"{tmp}/numba", PYTHONPATH=str(ROOT))
        res = subprocess.run([sys.executable, "-c", CHILD_ENTRIES, str(ROOT / "graphs" / "first_frame.yaml"),
                              f"{tmp}/cache", f"{tmp}/out"], env=env, capture_output=True, text=True, check=True)
    return json.loads(res.stdout.strip().splitlines()[-1])


def main_entries() -> None:
    load = os.getloadavg()[0]
    rows = compile_entries()
    print(f"first frame's manifest entries compiled one after another, cold numba cache (load {load:.1f} before, "
          f"{os.getloadavg()[0]:.1f} after): CPU seconds, slowest first")
    for name, par, s in sorted(rows, key=lambda r: -r[2]):
        print(f"  {name:<36} {'parallel' if par else 'serial  '} {s:6.2f}")
    par = sum(s for _, p, s in rows if p)
    print(f"{len(rows)} entries, {sum(s for *_, s in rows):.1f} CPU s ({sum(p for _, p, _ in rows)} parallel: {par:.1f} s)")


def cold_first_frame(mode: str) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=f"{tmp}/numba", PYTHONPATH=str(ROOT))
        t0 = time.perf_counter()
        res = subprocess.run([sys.executable, "-c", CHILD, str(ROOT / "graphs" / "first_frame.yaml"),
                              f"{tmp}/cache", f"{tmp}/out", mode], env=env, capture_output=True, text=True, check=True)
        wall = time.perf_counter() - t0
    r = json.loads(res.stdout.strip().splitlines()[-1])
    r["process"] = wall - r["after"]  # to the end of the first frame (less the re-runs after it)
    r["cpu"] = sum(r["cpu_split"])  # the process (from its start) and its workers, to the end of the first frame
    if mode == "manifest":
        r["command"] = cold_command()
    return r


def cold_command() -> dict:
    """``proxyshade run graphs/first_frame.yaml --frames 1`` timed from outside, as a user
    meets it after an install: cold numba and plate caches, the command's own precompile and
    its exit (which skips the interpreter's teardown: ``cli._exit_now``; the child above
    pays it after its figures). Wall and CPU seconds (the command and its workers, ``wait4``)."""
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=f"{tmp}/numba", PYTHONPATH=str(ROOT))
        argv = [sys.executable, "-c", "import sys; from proxyshade.cli import main; sys.exit(main())", "run",
                str(ROOT / "graphs" / "first_frame.yaml"), "--frames", "1", "--quiet", "--cache", f"{tmp}/cache",
                "--var", f"out={tmp}/out"]
        with open(f"{tmp}/stderr", "w+b") as log:  # a file, not a pipe the child could fill and block on
            t0 = time.perf_counter()
            pid = subprocess.Popen(argv, env=env, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=log).pid
            _, status, usage = os.wait4(pid, 0)
            wall = time.perf_counter() - t0
            if os.waitstatus_to_exitcode(status):
                log.seek(0)
                raise SystemExit(f"proxyshade run failed: {log.read().decode()[-2000:]}")
    return {"wall": wall, "cpu": usage.ru_utime + usage.ru_stime}


def main(repeat: int = 1, modes=("lazy", "manifest")):
    for mode in modes:
        load = os.getloadavg()[0]
        runs = [cold_first_frame(mode) for _ in range(repeat)]
        process = [r["process"] for r in runs]
        graph = [r["wall"] for r in runs]
        last = runs[-1]
        n = sum(last["sigs"].values())
        cpu = [r["cpu"] for r in runs]
        rows = [("process wall (imports + compile + run)", {"median": statistics.median(process), "min": min(process)}, None),
                ("CPU seconds (process and workers)", {"median": statistics.median(cpu), "min": min(cpu)}, None),
                ("Graph.load + precompile + run", {"median": statistics.median(graph), "min": min(graph)}, None)]
        if last["pre"]:
            pre = [r["pre"]["seconds"] for r in runs]
            rows.append((f"precompile ({last['pre']['compiled']} signatures, {last['pre']['workers']} workers)",
                         {"median": statistics.median(pre), "min": min(pre)}, None))
        rows.append(("run", {"median": statistics.median([r["run"] for r in runs]), "min": min(r["run"] for r in runs)}, None))
        if "command" in last:
            for what in ("wall", "cpu"):
                xs = [r["command"][what] for r in runs]
                rows.append((f"the command, cold caches: {'wall' if what == 'wall' else 'CPU s (and workers)'}",
                             {"median": statistics.median(xs), "min": min(xs)}, 30.0 if what == "wall" else None))
        rows.append(("forced re-run in that process (best of 2)", {"median": statistics.median([r["rerun"] for r in runs]),
                                                                   "min": min(r["rerun"] for r in runs)}, None))
        table(f"{mode}: cold numba cache, lake first frame (fresh process, {repeat} run(s), load {load:.1f} before, {os.getloadavg()[0]:.1f} after)", rows)
        c = last["cpu_split"]
        print(f"CPU seconds: the run's process {c[0] + c[1] + c[2]:.1f} (start and imports {c[0]:.1f}, Graph.load + "
              f"precompile {c[1]:.1f}, run {c[2]:.1f}), workers {c[3]:.1f}: on idle cores the wall time follows the "
              f"larger, {max(c[0] + c[1] + c[2], c[3]):.1f}")
        print(f"output EXRs sha256 {last['exr']}" + ("" if len({r['exr'] for r in runs}) == 1 else " (runs differ!)"))
        print(f"kernel signatures in the run's process: {n} in {sum(1 for v in last['sigs'].values() if v)} dispatchers "
              f"({len(last['sigs'])} dispatchers loaded); compiled there: {last['events']}")
        multi = {k: v for k, v in last["sigs"].items() if v > 1}
        if multi:
            print("dispatchers with more than one signature: " + ", ".join(f"{k} {v}" for k, v in sorted(multi.items())))
        print(f"compile seconds in the run's process: {sum(last['spent'].values()):.1f}; slowest (own seconds, less the kernels they call):")
        for name, s in sorted(last["spent"].items(), key=lambda kv: -kv[1])[:12]:
            print(f"  {name:<40} {s:7.2f}")


if __name__ == "__main__":
    mode = sys.argv[sys.argv.index("--mode") + 1] if "--mode" in sys.argv else "both"
    if mode == "entries":
        sys.exit(main_entries())
    main(int(sys.argv[sys.argv.index("--repeat") + 1]) if "--repeat" in sys.argv else 1,
         ("lazy", "manifest") if mode == "both" else (mode,))
