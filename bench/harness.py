"""Benchmark helpers shared by every bench module: medians, never single timings.

Each ``bench/bench_*.py`` defines ``main()`` that calls ``measure`` and prints rows with
``table``. ``bench/run.py`` runs them all (or those named on its command line).
"""
from __future__ import annotations

import resource
import statistics
import time


def measure(fn, *, repeat: int = 5, warmup: int = 1) -> dict:
    """Run ``fn`` ``warmup`` times (JIT), then ``repeat`` times; median and spread in seconds."""
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return {"median": statistics.median(times), "min": min(times), "max": max(times), "n": repeat}


def measure_interleaved(fns, *, repeat: int = 5, warmup: int = 1) -> list[dict]:
    """``measure`` for several functions run in turn (each ``warmup`` times, then rounds of
    one run of each, ``repeat`` rounds), so a load change on a shared machine falls on all
    of them alike and their ratios hold: one ``measure``-style dict per function."""
    for _ in range(warmup):
        for fn in fns:
            fn()
    times = [[] for _ in fns]
    for _ in range(repeat):
        for fn, ts in zip(fns, times):
            t0 = time.perf_counter()
            fn()
            ts.append(time.perf_counter() - t0)
    return [{"median": statistics.median(ts), "min": min(ts), "max": max(ts), "n": repeat} for ts in times]


def peak_rss_mb() -> float:
    """Peak resident memory of this process so far, in MiB."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def table(title: str, rows: list[tuple[str, dict, float | None]]) -> None:
    """Print ``(name, measure-result, target seconds or None)`` rows with the ratio to target."""
    print(f"\n## {title}")
    print(f"{'stage':<40} {'median s':>10} {'min s':>9} {'target s':>9} {'ratio':>7}")
    for name, m, target in rows:
        ratio = f"{m['median'] / target:7.2f}" if target else "      -"
        tgt = f"{target:9.3f}" if target else "        -"
        print(f"{name:<40} {m['median']:10.4f} {m['min']:9.4f} {tgt} {ratio}")
    print(f"peak RSS {peak_rss_mb():.0f} MiB")


def graph_node_medians(graph_path, *, repeat: int = 3, frames=None, jobs: int = 1, overrides=(), variables=None) -> dict:
    """Per-node median compute seconds of a YAML graph (every node forced each repetition,
    after one warm-up run for the JIT), and the median wall time of a cache-hit re-run."""
    import tempfile

    from proxyshade.graph.graph import Graph

    with tempfile.TemporaryDirectory() as cache:
        g = Graph.load(graph_path, cache=cache, overrides=list(overrides), variables=variables)
        g.run(frames, jobs=jobs)  # warm-up: JIT compile and fill the cache
        per: dict[str, list[float]] = {}
        walls = []
        for _ in range(repeat):
            r = g.run(frames, jobs=jobs, force=tuple(g.nodes))
            walls.append(r.wall)
            sums: dict[str, float] = {}
            for row in r.runs:
                if row.status == "computed":
                    sums[row.node] = sums.get(row.node, 0.0) + row.seconds
            for k, v in sums.items():
                per.setdefault(k, []).append(v)
        hits = []
        for _ in range(max(repeat, 5)):
            fresh = Graph.load(graph_path, cache=cache, overrides=list(overrides), variables=variables)
            t0 = time.perf_counter()
            fresh.run(frames, jobs=jobs)
            hits.append(time.perf_counter() - t0)
    return {
        "nodes": {k: statistics.median(v) for k, v in per.items()},
        "wall": statistics.median(walls),
        "cache_hit_rerun": statistics.median(hits),
    }


def print_graph_medians(title: str, res: dict, targets: dict | None = None) -> None:
    rows = [(name, {"median": s, "min": s}, (targets or {}).get(name)) for name, s in res["nodes"].items()]
    rows.append(("whole graph (forced)", {"median": res["wall"], "min": res["wall"]}, (targets or {}).get("whole")))
    rows.append(("cache-hit re-run (load + plan)", {"median": res["cache_hit_rerun"], "min": res["cache_hit_rerun"]}, None))
    table(title, rows)


def write_jpeg(path, rgb, *, quality: int = 90, view: str = "shoulder") -> None:
    """A linear (H, W, 3) image as an sRGB JPEG (a docs figure): the preview's display
    transform (``kernels.display.to_display`` with ``view``), then OpenImageIO."""
    import numpy as np
    import OpenImageIO as oiio

    from proxyshade.kernels.display import to_display
    from proxyshade.plate import Plate

    rgb = np.asarray(rgb, np.float32)
    img = np.ascontiguousarray(to_display(Plate({c: np.ascontiguousarray(rgb[..., i]) for i, c in enumerate("RGB")}),
                                          ["R", "G", "B"], view=view))
    buf = oiio.ImageBuf(oiio.ImageSpec(img.shape[1], img.shape[0], 3, oiio.UINT8))
    buf.set_pixels(oiio.ROI(), img)
    buf.specmod().attribute("Compression", f"jpeg:{quality}")
    if not buf.write(str(path)):
        raise SystemExit(f"{path}: {buf.geterror()}")
    print(f"wrote {path}")
