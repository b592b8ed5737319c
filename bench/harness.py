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
