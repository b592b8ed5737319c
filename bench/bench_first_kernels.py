"""Where Correct's and Magnify's time goes on the first frame, kernel by kernel: each kernel
entry point (as the Python layer calls it) timed per call, wall and process CPU seconds
(CPU > wall: both threads worked; CPU ≈ wall: serial), with 1 and 2 numba threads.

The inputs are graphs/first_frame.yaml's (lake, renoir, 1024 wide), computed once into a
plate cache of their own (``--cache``, default ``$TMPDIR/proxyshade-first-kernels``); the
nodes then run through ``run_node`` with the graph's parameters. ``--dump FILE`` saves
Correct's and Magnify's maps (npz) and ``--compare FILE`` checks them bit for bit against
such a file (e.g. one written from another checkout).

Run: ``python bench/bench_first_kernels.py --repeat 3``; another checkout's kernels with
``PYTHONPATH=/work/main python bench/bench_first_kernels.py`` (run from outside both).
"""
from __future__ import annotations

import argparse
import os
import resource
import statistics
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if not os.environ.get("PYTHONPATH"):
    sys.path.insert(0, str(ROOT))

WRAP = {  # module: entry points the Python layer calls
    "proxyshade.kernels.correct": ["_knn_pass", "_subpass", "_usage_excess", "_tone_balance", "_downsample",
                                   "_upsample"],
    "proxyshade.kernels.magnify": ["_magnify", "_label_ok", "_front_steps", "repair_labels"],
    "proxyshade.kernels.seams": ["_sub_pass", "_run_pass", "_shift_passes"],
    "proxyshade.kernels.patch": ["offset_components"],
    "proxyshade.kernels.lookup": ["lookup"],
    "proxyshade.synthesis.exemplar": ["synthesis_setup"],
    "proxyshade.synthesis.patches": ["working_colours", "patch_ids"],
}

STATS: dict = defaultdict(lambda: [0, 0.0, 0.0])  # name: calls, wall, cpu
DEPTH = [0]


def cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def wrap():
    import importlib
    for modname, names in WRAP.items():
        mod = importlib.import_module(modname)
        for name in names:
            fn = getattr(mod, name)

            def timed(*a, __fn=fn, __name=f"{modname.rsplit('.', 1)[1]}.{name}", **k):
                DEPTH[0] += 1
                t0, c0 = time.perf_counter(), cpu()
                try:
                    return __fn(*a, **k)
                finally:
                    s = STATS[__name]
                    s[0] += 1
                    s[1] += time.perf_counter() - t0
                    s[2] += cpu() - c0
                    DEPTH[0] -= 1
            setattr(mod, name, timed)


def inputs(cache: Path):
    from proxyshade.graph.graph import Graph
    g = Graph.load(ROOT / "graphs" / "first_frame.yaml", cache=cache,
                   variables={"out": str(cache / "out")})
    return {n: g.value(n, 1) for n in ("src", "depth", "init", "correct")}, g


def main(argv=()):
    """``bench/run.py first_kernels`` runs it with the defaults; the command line adds options."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "proxyshade-first-kernels")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--nodes", default="correct,magnify")
    ap.add_argument("--dump", type=Path)
    ap.add_argument("--compare", type=Path)
    a = ap.parse_args(argv)
    import numpy as np
    import numba
    from proxyshade.graph.testing import run_node

    ins, g = inputs(a.cache)
    wrap()
    cparams = {"seed": 1, "passes_finest": 6, "tone_balance": 0.25, "tone_spacing": 2}
    mparams = {"patch_shift": 5, "patch_adopt": 64}
    out = {}

    def correct():
        out["correct"] = run_node("Correct", cparams, {"init": ins["init"], "source": ins["src"]})

    def magnify():
        out["magnify"] = run_node("Magnify", mparams, {"synth": ins["correct"], "source": ins["src"],
                                                       "guide": ins["depth"], "depth": ins["depth"]})

    fns = {"correct": correct, "magnify": magnify}
    for n in a.nodes.split(","):  # warm: compile/load the kernels
        fns[n]()
    print(f"load {os.getloadavg()[0]:.1f}")
    for threads in [int(t) for t in a.threads.split(",")]:
        numba.set_num_threads(threads)
        for n in a.nodes.split(","):
            walls, cpus, per = [], [], defaultdict(list)
            for _ in range(a.repeat):
                STATS.clear()
                t0, c0 = time.perf_counter(), cpu()
                fns[n]()
                walls.append(time.perf_counter() - t0)
                cpus.append(cpu() - c0)
                for k, (calls, w, c) in STATS.items():
                    per[k].append((calls, w, c))
            print(f"\n{n}, {threads} thread(s): wall {statistics.median(walls):.3f} s (min {min(walls):.3f}), "
                  f"CPU {statistics.median(cpus):.3f} s; load {os.getloadavg()[0]:.1f}")
            for k, v in sorted(per.items(), key=lambda kv: -statistics.median(x[2] for x in kv[1])):
                print(f"  {k:32s} calls {v[0][0]:4d}  wall {statistics.median(x[1] for x in v):7.3f}  "
                      f"CPU {statistics.median(x[2] for x in v):7.3f}")
    maps = {}
    for n in ("correct", "magnify"):
        if n in out:
            for c in ("source.x", "source.y", "patch.id", "R", "G", "B"):
                maps[f"{n}/{c}"] = out[n][c]
    if a.dump:
        np.savez(a.dump, **maps)
    if a.compare:
        ref = np.load(a.compare)
        bad = [k for k in maps if k in ref and not np.array_equal(ref[k], maps[k])]
        print("compare:", "identical" if not bad else f"DIFFER: {bad}", f"({len(maps)} arrays)")
        if bad:
            sys.exit(1)


if __name__ == "__main__":
    main(sys.argv[1:])
