"""The Dask executor against the local one (issue: run the same graphs on Dask).

  shots      4 shots x 12 frames of graphs/camera_move.yaml at ``--size`` (default 256 wide;
             synthesis 64, start 16): lake/renoir, cliffs/monet, farm/creek and lake/renoir
             with other seeds (a variant). Local executor (this process, the graphs one after
             the other, every core to each kernel) against a LocalCluster of 2 worker
             processes (the 4 graphs at once, one numba thread per worker); fresh cache each
             repetition, median wall time and the ratio. Bar: >= 1.6x on 2 cores.
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

Run: ``python bench/run.py dask`` (``python bench/bench_dask.py --size 256 --repeat 3``).
The machine's load is printed with each figure (2 shared cores: medians of several runs).
"""
from __future__ import annotations

import argparse
import json
import os
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


def cpu_seconds(executor) -> float:
    """CPU seconds used so far by this process and, on Dask, by the workers."""
    import resource

    def own() -> float:
        r = resource.getrusage(resource.RUSAGE_SELF)
        return r.ru_utime + r.ru_stime

    workers = executor.client.run(own).values() if isinstance(executor, DaskExecutor) else ()
    return own() + sum(workers)


def shots_wall(executor, size: int, frames: list[int], cpu: list | None = None) -> float:
    with tempfile.TemporaryDirectory() as d:
        gs = [(shot(*s, size, Path(d) / "cache", Path(d) / "out"), frames) for s in SHOTS]
        c = cpu_seconds(executor)
        t = time.perf_counter()
        run_graphs(gs, executor=executor)
        wall = time.perf_counter() - t
        if cpu is not None:
            cpu.append(cpu_seconds(executor) - c)
        return wall


def bench_shots(size: int, repeat: int, frames: int) -> None:
    fl = list(range(1, frames + 1))
    print(f"\n## 4 shots x {frames} frames, camera_move at {size} wide (synthesis {size // 4})")
    local = make_executor(1)
    shots_wall(local, size, fl[:2])  # warm-up: numba kernels loaded in this process
    c_local, c_dask = [], []
    t_local = [shots_wall(local, size, fl, c_local) for _ in range(repeat)]
    print(f"local executor (1 job, every core per kernel): median {statistics.median(t_local):7.2f} s "
          f"(min {min(t_local):.2f}, max {max(t_local):.2f}; CPU {statistics.median(c_local):.1f} s; {load()})")
    t0 = time.perf_counter()
    with DaskExecutor(workers=2) as ex:
        print(f"LocalCluster of 2 workers started in {time.perf_counter() - t0:.2f} s")
        shots_wall(ex, size, fl[:2])  # warm-up: each worker loads the kernels from numba's cache
        t_dask = [shots_wall(ex, size, fl, c_dask) for _ in range(repeat)]
    print(f"dask, 2 workers:                            median {statistics.median(t_dask):7.2f} s "
          f"(min {min(t_dask):.2f}, max {max(t_dask):.2f}; CPU {statistics.median(c_dask):.1f} s, client and "
          f"workers; {load()})")
    print(f"ratio local / dask: {statistics.median(t_local) / statistics.median(t_dask):.2f}x (bar >= 1.6x)")


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
            chain = [x for x in recs if by_key[x["key"].removeprefix("proxyshade-")].node == "s"]
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
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--frames", type=int, default=12)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--only", choices=("shots", "overhead", "farm", "tiles"), action="append")
    a = ap.parse_known_args(argv)[0]  # bench/run.py passes bench names too
    only = set(a.only or ("shots", "overhead", "farm"))
    if "overhead" in only:
        bench_overhead()
    if "shots" in only:
        bench_shots(a.size, a.repeat, a.frames)
    if "farm" in only:
        bench_farm(a.size, a.frames)
    if "tiles" in only:
        bench_tiles(max(1, a.repeat // 2))


if __name__ == "__main__":
    main()
