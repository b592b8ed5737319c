"""Temporal coherence under camera motion (Bonneel et al. 2010, §6): the update frame.

For each bundled scene's camera move, at 1024² output / 256² synthesis: the first frame
once (GuideSynth -> DepthExtend -> PatchInit -> Correct -> Magnify -> Poisson), then
frames 2..N, each timed stage by stage like the paper's Table 1:

  proxy        ProxyRender of the frame (label guide + depth)
  R&D          ConsistentDepth (frame-0 grid splatted into this camera) + Reproject
               (previous frame carried over, det J, distortion, flags)
  features     exemplar/guide levels of the frame (Resynthesize)
  flood fill   masked flood fill of disoccluded / newly occluded pixels
  corrections  masked k-coherent correction (similarity sets included)
  magnify      patch upsampling of the flagged pixels, label repair, colour lookup
  Poisson      restricted solve, window by window (Dirichlet outside flagged pixels)

The update frame is the sum (median over frames; target <= 0.5 s, must <= 1.2 s on 2
cores). Then, on each move, the median share of pixels resynthesized per frame over all
48 frames and the temporal warp-error ratio (mean |I_N - warp(I_N-1)| over kept pixels,
coherent / independent per-frame synthesis) over the first frames, at ``--metric-size``.

Run: ``python bench/run.py temporal`` (or ``python bench/bench_temporal.py --frames 8``);
``--cpu`` times the stages by CPU time on one thread (the work itself: on cores shared with
other jobs wall time measures their load as much as ours), ``--no-metrics`` skips the
share / warp-error runs.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import yaml

from harness import peak_rss_mb, table

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from proxyshade.nodes import node_type  # noqa: E402
from proxyshade.graph.testing import run_node  # noqa: E402
from tests.nodes import _temporal as T  # noqa: E402

STAGES = ("proxy", "R&D", "features", "flood fill", "corrections", "magnify", "Poisson")


class _Ctx:
    def error(self, msg):
        return RuntimeError(msg)

    def note(self, msg):
        pass


def update_frames(scene: str, size: int, frames: int, sets: dict | None = None) -> tuple[dict, list[float]]:
    """Per-stage seconds of frames 2..frames+1 of a scene's move (after a warm-up frame);
    ``sets``: {'reproject': {...}, 'final': {...}} parameters of Reproject and Resynthesize."""
    sets = sets or {}
    from proxyshade.synthesis.resynthesis import resynthesize

    src = T.source(T.SCENES[scene])
    p0 = T.proxy(scene, 1, size)
    g0, d0 = T.detailed(scene, 1, size)
    prev = first = T.first_frame(scene, size, detail=True)
    params = node_type("Resynthesize").validate_params(dict({"seed": 1}, **sets.get("final", {})))

    class P:
        pass

    for k, v in params.items():
        setattr(P, k, v)
    per = {s: [] for s in STAGES}
    totals, shares = [], []
    for fr in range(2, frames + 3):
        tm: dict = {}
        t = time.perf_counter()
        pN = run_node("ProxyRender", {"scene": str(ROOT / "samples" / "scenes" / f"{scene}.usda"),
                                      "resolution": [size, size]}, {"source": src}, frame=fr)
        tm["proxy"] = time.perf_counter() - t
        t = time.perf_counter()
        cd = run_node("ConsistentDepth", {}, {"proxy": pN, "guide": g0, "depth": d0, "ref_proxy": p0}, frame=fr)
        rp = run_node("Reproject", sets.get("reproject", {}), {"depth": cd, "prev": prev, "first": first, "source": src},
                      frame=fr)  # first: the graph's (seams anchored to it; creep_gate measures against it)
        tm["R&D"] = time.perf_counter() - t
        prev = resynthesize(rp, src, P, fr, timings=tm)
        if fr == 2:
            continue  # warm-up (compiled kernels loaded, caches filled)
        for s in STAGES:
            per[s].append(tm.get(s, 0.0))
        totals.append(sum(tm.get(s, 0.0) for s in STAGES))
        shares.append(float((rp["flag"] > 0).mean()))
    med = {s: {"median": statistics.median(v), "min": min(v), "max": max(v), "n": len(v)} for s, v in per.items()}
    med["update frame"] = {"median": statistics.median(totals), "min": min(totals), "max": max(totals),
                           "n": len(totals)}
    return med, shares


def move_shares(scene: str, size: int, last: int = 48) -> list[float]:
    """Share of pixels flagged per frame over the whole move (coherent run only)."""
    run = T.run_move(scene, range(1, last + 1), size=size, detail=True)
    return [float((r["reproject"]["flag"] > 0).mean()) for r in run[1:]]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=1024, help="output size of the timed frames")
    ap.add_argument("--frames", type=int, default=8, help="timed update frames per scene")
    ap.add_argument("--metric-size", type=int, default=256, help="output size of the share / warp-error runs")
    ap.add_argument("--metric-frames", type=int, default=8, help="frames of the warp-error comparison")
    ap.add_argument("--scenes", nargs="*", default=list(T.SCENES))
    ap.add_argument("--threads", type=int, default=0, help="numba threads (0: numba's default)")
    ap.add_argument("--cpu", action="store_true",
                    help="time stages by the process's CPU time on one thread: the work, steady on cores shared "
                         "with other jobs (wall time there depends on their load)")
    ap.add_argument("--no-metrics", action="store_true", help="timings only (no 48-frame share / warp-error runs)")
    ap.add_argument("--set", action="append", default=[], metavar="NODE.PARAM=VALUE",
                    help="a parameter of the timed frames' reproject or final (Resynthesize) node, e.g. "
                         "final.solve_margin=8 (repeatable)")
    args = ap.parse_args(sys.argv[2:] if argv is None and len(sys.argv) > 1 and sys.argv[1] == "temporal" else argv)
    import numba

    if args.cpu:
        numba.set_num_threads(1)
        time.perf_counter = time.process_time  # every stage clock of this process, Resynthesize's included
    elif args.threads:
        numba.set_num_threads(args.threads)
    print(f"numba threads {numba.get_num_threads()}, clock {'CPU time' if args.cpu else 'wall'}, "
          f"OMP_WAIT_POLICY={os.environ.get('OMP_WAIT_POLICY')}")
    sets: dict = {}
    for item in args.set:
        key, _, val = item.partition("=")
        node, _, param = key.strip().partition(".")
        if node not in ("reproject", "final") or not param:
            raise SystemExit(f"--set {item}: expected reproject.param=value or final.param=value")
        sets.setdefault(node, {})[param] = yaml.safe_load(val)
    summary = []
    for scene in args.scenes:
        med, shares = update_frames(scene, args.size, args.frames, sets)
        rows = [(f"{scene}: {s}", med[s], None) for s in STAGES]
        rows.append((f"{scene}: update frame", med["update frame"], 0.5))
        table(f"Temporal update frame, {scene}, {args.size}² output ({args.frames} frames)", rows)
        print(f"must <= 1.2 s: median {med['update frame']['median']:.3f} s "
              f"({'ok' if med['update frame']['median'] <= 1.2 else 'OVER'}); "
              f"flagged per timed frame: median {100 * statistics.median(shares):.2f}%")
        if args.no_metrics:
            summary.append((scene, med["update frame"]["median"], float("nan"), float("nan"),
                            {"bilinear": float("nan")}))
            continue
        s48 = move_shares(scene, args.metric_size)
        m = T.coherence_metrics(scene, range(1, args.metric_frames + 1), args.metric_size, detail=True)
        summary.append((scene, med["update frame"]["median"], statistics.median(s48), max(s48), m["ratio"]))
        print(f"{scene}: share resynthesized per frame over 48 frames at {args.metric_size}²: median "
              f"{100 * statistics.median(s48):.2f}%, max {100 * max(s48):.2f}%")
        print(f"{scene}: warp-error ratio coherent / independent over frames 1-{args.metric_frames}: "
              + ", ".join(f"{k} warp {v:.4f}" for k, v in m["ratio"].items())
              + f" (coherent {np.mean(m['coherent']['bilinear']):.4f}, independent "
              f"{np.mean(m['independent']['bilinear']):.4f})")
    print("\n## Summary")
    print(f"{'scene':<8} {'update s':>9} {'share med':>10} {'share max':>10} {'warp ratio':>11}")
    for scene, upd, sm, sx, r in summary:
        print(f"{scene:<8} {upd:9.3f} {100 * sm:9.2f}% {100 * sx:9.2f}% {r['bilinear']:11.4f}")
    print(f"peak RSS {peak_rss_mb():.0f} MiB")


if __name__ == "__main__":
    main(sys.argv[1:])
