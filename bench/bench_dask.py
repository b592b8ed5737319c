"""The Dask executor against the local one (issue: run the same graphs on Dask).

  shots      the issue's four independent shots as the command a user types: ``proxyshade run
             graphs/camera_move.yaml --frames 1-12 --sweep source=renoir,creek --sweep
             scene=lake,farm --threads 1`` at ``--size`` wide (default the graph's 512; smaller:
             synthesis a quarter of it), each time from a fresh plate cache (numba's kernel cache
             warm), local executor (``--jobs 1``) and ``--executor dask --workers 2``,
             interleaved. Wall time, CPU of the command (the client: scheduler and nannies live
             in it) and of the processes it reaped (the forkserver and the workers it forked);
             how busy the workers were while the tasks ran (the run's note: each worker's tasks'
             time over that span); medians, the ratios, and whether the two runs' outputs are
             byte-identical; the Dask run's split of its workers' CPU (its note: compute, cache
             reads and writes, before the first task, between tasks) and the wall ceiling on
             this machine's cores (cores x local wall / Dask CPU). Bars: >= 1.7x wall, CPU <= 1.1x.
  overhead   a chain of 100 tiny instances (each reads the previous frame's, nothing else to
             run): per task, the time between a task's end and the next one's start on the
             workers (the scheduler's round trip), median. Bar: <= 5 ms. The wall time per task
             (with the engine's own work: inputs loaded, entry stored) is printed beside it.
  tiles      the lake's first frame at 4096x2160: its correction on the local executor (2
             numba threads) against 2 Dask workers of 1 thread with the sub-passes in row
             bands over both (``synthesis.tiles``) and without (bit-identical results).
  farm       8 worker processes on this machine, 3 shots x 12 frames, each shot submitted by
             two clients at once with overlapping frame ranges (1-8 and 5-12), one cache
             folder: every computed key is counted from the runs' rows and from the cache's
             records; no key may be computed twice.

Run: ``python bench/run.py dask`` (``python bench/bench_dask.py --only shots --size 256 --frames 6``).
The machine's load is printed with each figure (2 shared cores: medians of several runs).
"""
from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from proxyshade.graph.dask_executor import DaskExecutor
from proxyshade.graph.shots import run_graphs  # noqa: E402
from proxyshade.graph.executor import make_executor  # noqa: E402
from proxyshade.graph.graph import Graph  # noqa: E402
from proxyshade.graph.node import REGISTRY, InputRef  # noqa: E402

SHOTS = [("lake", "renoir", 1), ("cliffs", "monet", 1), ("farm", "creek", 1), ("lake", "renoir", 2)]


def load() -> str:
    return "load %.2f %.2f %.2f" % os.getloadavg()


def shot(scene: str, source: str, seed: int, size: int, cache: Path, out: Path) -> Graph:
    over = [f"proxy.resolution=[{size},null]", f"guide.size={size // 4}", "guide.start=16",
            "preview.enabled=false", "flags.enabled=false", "labels.enabled=false"]
    over += [f"{n}.seed={seed}" for n in ("guide", "init", "correct", "final")]
    return Graph.load(ROOT / "graphs" / "camera_move.yaml", cache=cache, overrides=over,
                      variables={"scene": scene, "source": source, "out": str(out / f"seed{seed}")})


# the command's own CPU and that of the processes it started and reaped, written when it returns:
# the client's share and the workers' apart. A LocalCluster's workers are forked by Python's
# forkserver (a child of the command), which reaps them: it is stopped and reaped first, so its
# CPU (the libraries it loads for all workers) and theirs are counted
WRAP = """import json, resource, sys
import multiprocessing.forkserver as fs
from proxyshade.cli import main
rc = main(sys.argv[2:])
fs._forkserver._stop()
s, c = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
open(sys.argv[1], "w").write(json.dumps({"client": s.ru_utime + s.ru_stime, "children": c.ru_utime + c.ru_stime}))
sys.exit(rc)
"""


def command(size: int, frames: int, folder: Path, dask: bool) -> list[str]:
    """The issue's run: camera_move.yaml, frames 1-N, sources x scenes swept (4 shots), fresh
    cache in ``folder``; the local executor with 1 job and 1 thread, or 2 Dask workers of 1 thread."""
    args = ["run", str(ROOT / "graphs" / "camera_move.yaml"), "--frames", f"1-{frames}", "--sweep", "source=renoir,creek",
            "--sweep", "scene=lake,farm", "--cache", str(folder / "cache"), "--var", f"out={folder / 'out'}", "-q",
            "--threads", "1"]
    if size != 512:  # the graph's own width is 512 (synthesis 128); smaller: synthesis a quarter of it
        args += ["--set", f"proxy.resolution=[{size},null]", "--set", f"guide.size={size // 4}",
                 "--set", f"guide.start={min(32, size // 8)}"]
    return args + (["--executor", "dask", "--workers", "2"] if dask else ["--jobs", "1"])


def run_command(size: int, frames: int, folder: Path, dask: bool) -> dict:
    """Wall seconds, the command's CPU seconds and its children's (the workers), as a new
    process from a fresh cache: process start, imports, kernels loaded from numba's cache."""
    import subprocess

    cpu = folder / "cpu.json"
    t = time.perf_counter()
    r = subprocess.run([sys.executable, "-c", WRAP, str(cpu), *command(size, frames, folder, dask)],
                       cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - t
    if r.returncode != 0:
        raise SystemExit(f"proxyshade run failed ({r.returncode}): {r.stderr[-2000:]}")
    c = json.loads(cpu.read_text())
    busy = re.search(r"workers busy (\d+)% of ([\d.]+) s", r.stdout)  # the Dask run's note (dask_executor.busy)
    split = re.search(r"workers' CPU (.*)", r.stdout)  # and where the workers' CPU went (dask_executor.cpu)
    return {"wall": wall, "client": c["client"], "workers": c["children"], "cpu": c["client"] + c["children"],
            "busy": int(busy[1]) if busy else None, "phase": float(busy[2]) if busy else None,
            "split": split[1] if split else None}


def outputs(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def bench_shots(size: int, repeat: int, frames: int) -> None:
    """The issue's four shots as the command a user types, local (1 job, 1 thread) and on
    Dask (2 workers, 1 thread each), interleaved (L D L D ...), fresh caches each time."""
    print(f"\n## 4 shots x {frames} frames of camera_move.yaml at {size} wide (--sweep source=renoir,creek "
          f"--sweep scene=lake,farm), the command from a fresh cache, interleaved, {repeat} rounds")
    print("   " + " ".join(command(size, frames, Path("DIR"), True)))
    rows = {"local": [], "dask": []}
    same = None
    with tempfile.TemporaryDirectory() as d:
        run_command(128, 2, Path(d) / "warm", False)  # kernels compiled (numba's cache) before anything is timed
        for i in range(repeat):
            for mode in ("local", "dask"):
                folder = Path(d) / f"{mode}{i}"
                r = run_command(size, frames, folder, mode == "dask")
                r["load"] = os.getloadavg()[0]
                rows[mode].append(r)
                busy = f"  workers busy {r['busy']}% of the {r['phase']:.1f} s computing" if r["busy"] is not None else ""
                print(f"   round {i + 1} {mode:<5} wall {r['wall']:6.1f} s  CPU {r['cpu']:6.1f} s (client "
                      f"{r['client']:5.1f}, workers {r['workers']:5.1f}){busy}  load {r['load']:.1f}", flush=True)
                if r["split"]:
                    print(f"         workers' CPU {r['split']}; forkserver and after the last task "
                          f"{r['workers'] - float(r['split'].split(' s ', 1)[0]):.1f} s", flush=True)
            if i == 0:
                same = outputs(Path(d) / "local0" / "out") == outputs(Path(d) / "dask0" / "out")
            for mode in ("local", "dask"):
                shutil.rmtree(Path(d) / f"{mode}{i}")
    med = {m: {k: statistics.median(r[k] for r in rs) for k in ("wall", "cpu", "client", "workers", "load")}
           for m, rs in rows.items()}
    L, D = med["local"], med["dask"]
    print(f"local, 1 job x 1 thread:        wall {L['wall']:6.1f} s, CPU {L['cpu']:6.1f} s  (medians; load {L['load']:.1f})")
    print(f"dask, 2 workers x 1 thread:     wall {D['wall']:6.1f} s, CPU {D['cpu']:6.1f} s = client {D['client']:.1f} + "
          f"workers {D['workers']:.1f}  (load {D['load']:.1f})")
    print(f"wall: dask {L['wall'] / D['wall']:.2f}x faster (bar >= 1.7x); CPU: dask / local {D['cpu'] / L['cpu']:.2f}x "
          f"(bar <= 1.1x), client alone {D['client'] / L['cpu']:.2f}x; outputs identical: {'yes' if same else 'NO'}")
    cores = os.cpu_count() or 1
    print(f"ceiling: the local run keeps {L['cpu'] / L['wall']:.2f} cores busy; {cores} cores can run the Dask run's "
          f"{D['cpu']:.1f} CPU s in {D['cpu'] / cores:.1f} s at best: at most {cores * L['wall'] / D['cpu']:.2f}x "
          f"faster here ({cores} x local wall / Dask CPU; with the machine to itself)")


def chain_graph(cache: Path, frames: int) -> Graph:
    g = Graph(frames=(1, frames), cache=cache, name="chain")
    g.add("a", "TConst", {"size": 4})
    g.add("s", "TAdd", {}, {"a": "a", "prev": InputRef("s", -1)})
    return g


def bench_overhead(frames: int = 100, repeat: int = 3) -> None:
    from tests.conftest import TYPES

    REGISTRY.update(TYPES)
    print(f"\n## scheduler overhead: a chain of {frames} frames (s@N reads s@N-1), 2 workers")
    gaps, own, walls = [], [], []
    with DaskExecutor(workers=2) as ex:
        for i in range(repeat + 1):
            with tempfile.TemporaryDirectory() as d:
                t = time.perf_counter()
                r = chain_graph(Path(d), frames).run(executor=ex)
                wall = time.perf_counter() - t
            if i == 0:
                continue  # warm-up
            walls.append(wall / len([x for x in r.runs if x.status == "computed"]))
            recs = sorted((x for x in ex.records), key=lambda x: x["start"])
            by_key = {x.key: x for x in r.runs}
            chain = [x for x in recs if by_key[x["cache_key"]].node == "s"]
            gaps += [b["start"] - a["end"] for a, b in zip(chain, chain[1:])]
            own += [(x["end"] - x["start"]) - x["seconds"] for x in recs]
    print(f"between a task's end and the next one's start: median {1e3 * statistics.median(gaps):.2f} ms "
          f"(p90 {1e3 * sorted(gaps)[int(0.9 * len(gaps))]:.2f} ms, {len(gaps)} gaps; bar <= 5 ms; {load()})")
    print(f"in the task beyond the engine's compute (inputs loaded, node, entry stored): median "
          f"{1e3 * statistics.median(own):.2f} ms; wall per task {1e3 * statistics.median(walls):.2f} ms")


def bench_farm(size: int, frames: int) -> None:
    print(f"\n## simulated farm: 8 worker processes, 3 shots x {frames} frames at {size} wide, each shot "
          f"submitted by 2 clients at once (frames 1-{2 * frames // 3} and {frames // 3 + 1}-{frames}), one cache")
    half = [list(range(1, 2 * frames // 3 + 1)), list(range(frames // 3 + 1, frames + 1))]
    with tempfile.TemporaryDirectory() as d, DaskExecutor(workers=8) as farm:
        cache, out = Path(d) / "cache", Path(d) / "out"
        reports = []

        def submit(s, fl):
            with DaskExecutor(farm.address) as client:
                reports.append(shot(*s, size, cache, out).run(fl, executor=client))

        t = time.perf_counter()
        threads = [threading.Thread(target=submit, args=(s, fl)) for s in SHOTS[:3] for fl in half]
        for th in threads:
            th.start()
        for th in threads:
            th.join()
        wall = time.perf_counter() - t
        computed = [x.key for r in reports for x in r.runs if x.status == "computed"]
        records = [json.loads(p.read_text()) for p in cache.glob("??/*.json")]
        workers = {w.rpartition(" on ")[2] for r in reports for n in r.notes if n.startswith("computed on Dask")
                   for w in n.split(": ", 1)[1].split(", ")}
    twice = len(computed) - len(set(computed))
    print(f"{len(reports)} runs in {wall:.1f} s ({load()}); {len(computed)} instances computed, {len(set(computed))} "
          f"distinct keys, {len(records)} cache records: keys computed twice: {twice}, records != computed keys: "
          f"{len(records) - len(set(computed))}")
    print(f"computed on {len(workers)} of the 8 workers")


def first_frame_4k(cache: Path, out: Path) -> Graph:
    return Graph.load(ROOT / "graphs" / "first_frame.yaml", cache=cache,
                      overrides=["preview.enabled=false", "proxy_labels.enabled=false",
                                 "detail_labels.enabled=false", "write.enabled=false"],
                      variables={"scene": "lake", "source": "renoir", "format": "4k", "out": str(out)})


def tiles_run(executor) -> tuple[float, float]:
    """(wall of the lake's 4K first frame, seconds of its Correct node), fresh cache."""
    with tempfile.TemporaryDirectory() as d:
        t = time.perf_counter()
        r = first_frame_4k(Path(d) / "cache", Path(d) / "out").run([1], executor=executor)
        return time.perf_counter() - t, sum(x.seconds for x in r.runs if x.node == "correct")


def bench_tiles(repeat: int) -> None:
    """The 4K first frame's correction: the local executor (2 numba threads), and 2 Dask
    workers of 1 thread each with its sub-passes in row bands over both, and without."""
    print("\n## tiles: the lake's first frame at 4096x2160, its correction's sub-passes in row bands")
    local = make_executor(1)
    tiles_run(local)  # warm-up: kernels loaded in this process
    rows = [("local executor, 2 numba threads", [tiles_run(local) for _ in range(repeat)])]
    for label, threshold in (("dask, 2 workers x 1 thread, bands", None),
                             ("dask, 2 workers x 1 thread, whole sub-passes", str(10 ** 12))):
        if threshold:
            os.environ["PROXYSHADE_TILE_MIN_PIXELS"] = threshold  # the workers read it when they start
        try:
            with DaskExecutor(workers=2) as ex:
                tiles_run(ex)  # warm-up
                rows.append((label, [tiles_run(ex) for _ in range(repeat)]))
        finally:
            os.environ.pop("PROXYSHADE_TILE_MIN_PIXELS", None)
    for label, runs in rows:
        print(f"{label:<46} frame median {statistics.median(r[0] for r in runs):6.2f} s, correction median "
              f"{statistics.median(r[1] for r in runs):6.2f} s ({load()})")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--frames", type=int, default=12)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--farm-size", type=int, default=256)
    ap.add_argument("--only", choices=("shots", "overhead", "farm", "tiles"), action="append")
    a = ap.parse_known_args(argv)[0]  # bench/run.py passes bench names too
    only = set(a.only or ("shots", "overhead", "farm"))
    if "overhead" in only:
        bench_overhead()
    if "shots" in only:
        bench_shots(a.size, a.repeat, a.frames)
    if "farm" in only:
        bench_farm(a.farm_size, a.frames)
    if "tiles" in only:
        bench_tiles(max(1, a.repeat // 2))


if __name__ == "__main__":
    main()
