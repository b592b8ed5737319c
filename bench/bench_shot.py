"""A whole shot as good as its first frame: seams, detail, coherence, resynthesis, speed.

For each bundled scene's 48-frame camera move (GuideSynth's detailed guide, DepthExtend's
depth, the first frame's full synthesis, then ConsistentDepth -> Reproject ->
Resynthesize every frame), at each output size, per frame:

  seams     share of same-label 4-adjacent pixel pairs whose source positions are not
            neighbours (``kernels.quality.seam_share``), relative to frame 1's
  detail    mean colour difference of same-label 4-adjacent pairs (``quality.detail``),
            relative to frame 1's
  warp      mean |I_N - warp(I_N-1)| over pixels kept and validly reprojected, coherent /
            independent per-frame synthesis (warp with Lanczos-4, as the renderer reads the
            source; the bilinear-warp ratio is printed too)
  share     share of pixels flagged (resynthesized or re-anchored) in the frame
  update s  seconds of the frame after the first (proxy render + ConsistentDepth +
            Reproject + Resynthesize)

Bars (issue: a whole shot as good as its first frame): seams <= 1.5x frame 1's and detail
>= 0.9 at every frame, warp ratio <= 0.1, median share <= 10 %, update frame at 1024²
<= 0.5 s (median).

Run: ``python bench/run.py shot`` (``--sizes 512 1024 --scenes lake cliffs farm --frames 48``).
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from harness import peak_rss_mb

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from proxyshade.graph.testing import run_node  # noqa: E402
from proxyshade.io.usd import CameraInfo  # noqa: E402
from proxyshade.kernels import quality as Q  # noqa: E402
from proxyshade.kernels import reproject as kr  # noqa: E402
from tests.nodes import _temporal as T  # noqa: E402


def warp_errors(cur, prev, cd, flag, indep_cur, indep_prev) -> dict:
    c1 = CameraInfo.from_meta(cd.meta["camera"])
    c0 = CameraInfo.from_meta(prev.meta["camera"])
    w1 = kr.inverse_depth(cd["Z"])
    u, v, q, ok = kr.transfer(w1, kr.relative_matrix(c1, c0), kr.intrinsics(c1), kr.intrinsics(c0), c0.near)
    z = np.zeros(prev.shape, np.float32)
    valid = kr.gather_prev(u, v, q, ok, np.ascontiguousarray(cd["label.id"]), kr.inverse_depth(prev["Z"]),
                           np.ascontiguousarray(prev["label.id"]), np.ascontiguousarray(prev["patch.id"]), z, z,
                           np.zeros(prev.shape + (3,), np.float32), z, 0.02, 1.0)[0]
    mask = valid & (flag == 0)
    out = {}
    for f in ("lanczos4", "bilinear"):
        out[f] = (kr.warp_error(cur.rgb(), prev.rgb(), u, v, mask, f),
                  kr.warp_error(indep_cur.rgb(), indep_prev.rgb(), u, v, mask, f))
    return out


def shot(scene: str, size: int, frames: int, every: int = 1) -> list[dict]:
    src = T.source(T.SCENES[scene])
    p0 = T.proxy(scene, 1, size)
    g0, d0 = T.detailed(scene, 1, size)
    f0 = T.first_frame(scene, size, frame=1, detail=True)
    scale = float(f0.meta.get("synthesis", {}).get("scale", 1.0))
    s0 = Q.seam_share(f0["source.x"], f0["source.y"], f0["label.id"], scale=scale)
    det0 = Q.detail(f0.rgb(), f0["label.id"])
    rows = [{"frame": 1, "seams": 1.0, "detail": 1.0, "share": 0.0, "update": None, "warp": None}]
    prev, indep_prev, indep_frame = f0, f0, 1
    for fr in range(2, frames + 1):
        t = time.perf_counter()
        pN = run_node("ProxyRender", {"scene": str(ROOT / "samples" / "scenes" / f"{scene}.usda"),
                                      "resolution": [size, size]}, {"source": src}, frame=fr)
        cd = run_node("ConsistentDepth", {}, {"proxy": pN, "guide": g0, "depth": d0, "ref_proxy": p0}, frame=fr)
        rp = run_node("Reproject", {}, {"depth": cd, "prev": prev, "first": f0, "source": src}, frame=fr)
        fin = run_node("Resynthesize", {}, {"image": rp, "source": src}, frame=fr)
        upd = time.perf_counter() - t
        row = {"frame": fr, "update": upd, "share": float((rp["flag"] > 0).mean()),
               "seams": Q.seam_share(fin["source.x"], fin["source.y"], fin["label.id"], scale=scale) / s0,
               "detail": Q.detail(fin.rgb(), fin["label.id"]) / det0, "warp": None}
        if every and ((fr - 2) % every == 0 or indep_frame == fr - 1):
            indep = T.first_frame(scene, size, seed=fr, frame=fr, detail=True)
            if indep_frame == fr - 1:
                row["warp"] = warp_errors(fin, prev, cd, rp["flag"], indep, indep_prev)
            indep_prev, indep_frame = indep, fr
        rows.append(row)
        prev = fin
    return rows


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[512, 1024])
    ap.add_argument("--scenes", nargs="*", default=list(T.SCENES))
    ap.add_argument("--frames", type=int, default=48)
    ap.add_argument("--warp-every", type=int, default=1,
                    help="independent synthesis for the warp ratio every N frames (0: none)")
    ap.add_argument("--per-frame", action="store_true", help="print every frame's row")
    args = ap.parse_args(sys.argv[2:] if argv is None and len(sys.argv) > 1 and sys.argv[1] == "shot" else argv)
    summary = []
    for size in args.sizes:
        for scene in args.scenes:
            rows = shot(scene, size, args.frames, args.warp_every)
            T.proxy.cache_clear()  # the per-frame proxies and guides of the independent runs
            T.detailed.cache_clear()
            print(f"\n## {scene} {size}² ({args.frames} frames)")
            print(f"{'frame':>5} {'seams':>6} {'detail':>7} {'share':>7} {'update s':>9} {'warp L4':>8} {'warp bil':>8}")
            for r in rows:
                if args.per_frame or r["frame"] in (1, 2, 8, 12, 16, 24, 32, 40, 48) or r["frame"] == args.frames:
                    w = r["warp"]
                    wl = f"{w['lanczos4'][0] / max(w['lanczos4'][1], 1e-12):8.4f}" if w else f"{'':>8}"
                    wb = f"{w['bilinear'][0] / max(w['bilinear'][1], 1e-12):8.4f}" if w else f"{'':>8}"
                    upd = f"{r['update']:9.3f}" if r["update"] is not None else f"{'':>9}"
                    print(f"{r['frame']:>5} {r['seams']:6.2f} {r['detail']:7.3f} {100 * r['share']:6.2f}% {upd} {wl} {wb}")
            later = rows[1:]
            ws = [r["warp"] for r in later if r["warp"]]
            ratio = {f: (float(np.mean([w[f][0] for w in ws])) / max(float(np.mean([w[f][1] for w in ws])), 1e-12)
                         if ws else float("nan")) for f in ("lanczos4", "bilinear")}
            s = {"scene": scene, "size": size, "seams_max": max(r["seams"] for r in rows),
                 "detail_min": min(r["detail"] for r in rows), "share_median": statistics.median(r["share"] for r in later),
                 "share_max": max(r["share"] for r in later),
                 "update_median": statistics.median(r["update"] for r in later[1:]), "warp": ratio}
            summary.append(s)
    print("\n## Summary (bars: seams <= 1.5x, detail >= 0.9, warp <= 0.1, share median <= 10 %, update 1024² <= 0.5 s)")
    print(f"{'scene':<7} {'size':>5} {'seams max':>9} {'detail min':>10} {'warp L4':>8} {'warp bil':>8} "
          f"{'share med':>9} {'share max':>9} {'update med':>10}")
    for s in summary:
        print(f"{s['scene']:<7} {s['size']:>5} {s['seams_max']:8.2f}x {s['detail_min']:10.3f} {s['warp']['lanczos4']:8.4f} "
              f"{s['warp']['bilinear']:8.4f} {100 * s['share_median']:8.2f}% {100 * s['share_max']:8.2f}% "
              f"{s['update_median']:9.3f}s")
    print(f"peak RSS {peak_rss_mb():.0f} MiB")


if __name__ == "__main__":
    main(sys.argv[1:])
