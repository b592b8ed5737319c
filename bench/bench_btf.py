"""View-consistent BTF stack synthesis (Neubeck, Zalesny and Van Gool 2004) on btf_bumps.

Speed (medians after JIT, 2 threads): support view 256² (r = 3) ≤ 3 s; each other view
(r = 2) ≤ 1.5 s; a 15-view stack ≤ 30 s. Quality, one 15-view stack synthesized three ways
(independent views, whole columns, sequential), on the non-support views: consistency
E_c = mean ‖A(q_v(p)) − A′(p)‖ and seams E_s = mean colour jump across edges whose sources
are not neighbours; pass: E_c(sequential) < E_c(independent), E_s(sequential) < E_s(columns).
Alignment: the chosen plane against the sample's heights, and the RMSE of a 27.5° view
interpolated from 25° and 30° with that plane and with planes outside the heights.
Shaded move (``--move``, also after the rest): graphs/btf_move.yaml's stack (57 views, tilts
around the circle) synthesized sequentially and as independent views, each shading the 12
frames of btf_move (BtfShade, 256²): frame-to-frame warp error of the shaded surface, seams
E_s of the stacks, and the shard share at 60–70° slant for the stacks and the shaded frames.
"""
import os
import sys
from pathlib import Path

import numba
import numpy as np

from harness import measure, table
from proxyshade.graph.testing import run_node
from proxyshade.synthesis import btf

ROOT = Path(__file__).resolve().parents[1]
SCENE = str(ROOT / "samples/scenes/btf_bumps.usda")


def alignment():
    stack = run_node("BtfRender", {"scene": SCENE, "size": 128, "slant_step": 2.5, "slant_max": 30,
                                   "tilts": [0, 90]})
    aligned = run_node("BtfAlign", {}, {"stack": stack})
    lo, hi = stack.meta["btf"]["heights"]
    plane = aligned.meta["btf"]["plane"]
    views, imgs = btf.stack_arrays(stack)
    pixel = stack.meta["btf"]["pixel"]
    idx = {(v["slant"], v["tilt"]): n for n, v in enumerate(views)}
    sel = [idx[(25.0, 0.0)], idx[(27.5, 0.0)], idx[(30.0, 0.0)]]
    m = btf.max_shift(views, 2 * (hi - lo) + abs(lo), pixel) + 2

    def rmse(h):
        r = btf.rectify(imgs[sel], [views[n] for n in sel], h, pixel)
        return float(np.sqrt(((0.5 * (r[0] + r[2]) - r[1])[m:-m, m:-m] ** 2).mean()))

    print("\n## alignment (slants 0-30 step 2.5, tilts 0 and 90, 128²)")
    print(f"heights [{lo:.4f}, {hi:.4f}], chosen plane {plane:.4f}: "
          f"{'within' if lo <= plane <= hi else 'OUTSIDE'}")
    for name, h in (("chosen plane", plane), ("above the heights", hi + 0.5 * (hi - lo)),
                    ("below the heights", lo - 0.5 * (hi - lo)), ("rendered plane (0)", 0.0)):
        print(f"27.5° from 25° and 30°, {name:<20} h = {h:+.4f}: RMSE {rmse(h):.5f}")


def main():
    numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
    print(f"load average {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f} {os.getloadavg()[2]:.2f}, "
          f"{numba.get_num_threads()} threads")
    stack = run_node("BtfRender", {"scene": SCENE, "size": 160, "slant_step": 10, "slant_max": 70,
                                   "tilts": [0, 90]})
    aligned = run_node("BtfAlign", {}, {"stack": stack})
    views, imgs = btf.stack_arrays(aligned)
    V = len(views)
    s = btf.check_views(views)["index"][(0, 0.0)]
    out = (256, 256)
    qay, qax, _ = btf.synthesize_view(imgs[s], out, radius=3, T=4, levels=3, seed=1)
    one = [s, (s + 1) % V]
    rows = [
        (f"support view 256² (r = 3), input {imgs.shape[2]}²",
         measure(lambda: btf.synthesize_view(imgs[s], out, radius=3, T=4, levels=3, seed=1), repeat=5), 3.0),
        ("one other view 256² (r = 2)",
         measure(lambda: btf.synthesize_others(imgs[one], 0, qay, qax, radius=2, T=4, c=0.25, seed=1), repeat=5),
         1.5),
        (f"{V - 1} other views 256², parallel (per view)",
         {k: v / (V - 1) if k != "n" else v for k, v in
          measure(lambda: btf.synthesize_others(imgs, s, qay, qax, radius=2, T=4, c=0.25, seed=1),
                  repeat=3).items()}, 1.5),
        (f"{V}-view stack 256² (sequential)",
         measure(lambda: btf.synthesize_stack(imgs, s, out, seed=1), repeat=3), 30.0),
    ]
    big = run_node("BtfRender", {"scene": SCENE, "size": 288, "window": 2.16 * 288 / 320, "slant_step": 70,
                                 "slant_max": 70, "tilts": [0]})
    _, bimgs = btf.stack_arrays(big)
    bimgs = bimgs[:, 16:-16, 16:-16]
    rows.append((f"paper size: support 512² (r = 3), input {bimgs.shape[2]}²",
                 measure(lambda: btf.synthesize_view(bimgs[0], (512, 512), radius=3, T=4, levels=3, seed=1),
                         repeat=3), None))
    table("BTF synthesis speed", rows)

    others = [n for n in range(V) if n != s]
    res = {}
    for mode in btf.MODES:
        qy, qx = btf.synthesize_stack(imgs, s, out, mode=mode, seed=1)
        res[mode] = (btf.consistency_error(imgs, s, qy, qx)[others].mean(), btf.seam_error(imgs, qy, qx)[others].mean())
    print(f"\n## BTF synthesis quality, {V} views {imgs.shape[2]}² -> 256², non-support views")
    print(f"{'mode':<14} {'E_c':>8} {'E_s':>8}")
    for mode, (ec, es) in res.items():
        print(f"{mode:<14} {ec:8.4f} {es:8.4f}")
    ec_ratio = res["sequential"][0] / res["independent"][0]
    es_ratio = res["sequential"][1] / res["columns"][1]
    print(f"E_c(sequential) / E_c(independent) = {ec_ratio:.3f} ({'pass' if ec_ratio < 1 else 'FAIL'})")
    print(f"E_s(sequential) / E_s(columns)     = {es_ratio:.3f} ({'pass' if es_ratio < 1 else 'FAIL'})")
    alignment()


MOVE_TILTS = [0, 45, 90, 135, 180, 225, 270, 315]
SHARD_MARGIN = 0.05  # of the luminance range of the input views at 60-70°


def warp_error(frames, cams):
    """Mean over consecutive frames of the mean RGB distance between a surface pixel of frame
    t + 1 and frame t at the same surface point (P of frame t + 1 projected into camera t,
    read at the nearest pixel, where that pixel is on the surface too)."""
    errs = []
    for a, b, ca in zip(frames, frames[1:], cams):
        on_b = b["A"] == 1
        P = np.stack([b[f"P.{x}"] for x in "XYZ"], -1)[on_b].astype(np.float64)
        col, row, d = ca.project(P)
        j, i = np.floor(col).astype(np.int64), np.floor(row).astype(np.int64)
        ok = (d > 0) & (i >= 0) & (i < a.height) & (j >= 0) & (j < a.width)
        i, j = i[ok], j[ok]
        ok2 = a["A"][i, j] == 1
        ra = np.stack([a[c][i, j] for c in "RGB"], -1)[ok2]
        rb = np.stack([b[c][on_b][ok] for c in "RGB"], -1)[ok2]
        errs.append(float(np.sqrt(((ra - rb) ** 2).sum(-1)).mean()))
    return float(np.mean(errs)), errs


def shaded_move():
    from proxyshade.io.usd import CameraInfo

    numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
    capture = run_node("BtfRender", {"scene": SCENE, "size": 160, "slant_step": 10, "slant_max": 70,
                                     "tilts": MOVE_TILTS})
    aligned = run_node("BtfAlign", {}, {"stack": capture})
    views, imgs = btf.stack_arrays(aligned)
    meta = aligned.meta["btf"]
    lo_h, hi_h = capture.meta["btf"]["heights"]
    reach = max(abs(lo_h - meta["plane"]), abs(hi_h - meta["plane"])) / meta["pixel"]
    g = btf.check_views(views)
    steep = [n for n, v in enumerate(views) if 60 <= v["slant"] <= 70]
    lum_in = imgs[steep].astype(np.float64) @ btf.LUMA
    margin = SHARD_MARGIN * float(lum_in.max() - lum_in.min())
    ranges = {n: btf.parallax_range(imgs[n], views[n]["slant"], views[n]["tilt"], reach) for n in steep}
    src = run_node("SourceRead", {"table": str(ROOT / "samples/renoir/source.yaml")})
    shot = str(ROOT / "samples/scenes/btf_move.usda")
    proxies = [run_node("ProxyRender", {"scene": shot, "resolution": [256, 256], "labels": {"bumps": "vegetation"}},
                        {"source": src}, frame=f) for f in range(1, 13)]
    cams = [CameraInfo.from_meta(p.meta["camera"]) for p in proxies]
    rows = {}
    for mode in ("sequential", "independent"):
        synth = run_node("BtfSynth", {"size": [256, 256], "seed": 1, "mode": mode}, {"stack": aligned})
        V = len(views)
        qy = np.stack([synth[f"v{n}.sy"] for n in range(V)]).astype(np.int64)
        qx = np.stack([synth[f"v{n}.sx"] for n in range(V)]).astype(np.int64)
        s = synth.meta["btf"]["support"]
        others = [n for n in range(V) if n != s]
        es = float(btf.seam_error(imgs, qy, qx)[others].mean())
        # shards of the stack: each steep view against its input view's parallax range at
        # the surface point the support shows there
        st = np.mean([btf.shard_share(imgs[n][qy[n], qx[n]].astype(np.float64) @ btf.LUMA,
                                      ranges[n][0][qy[s], qx[s]], ranges[n][1][qy[s], qx[s]], margin)
                      for n in steep])
        frames = [run_node("BtfShade", {"label": "bumps", "origin": [-0.96, -0.96]}, {"stack": synth, "proxy": p})
                  for p in proxies]
        we, per = warp_error(frames, cams)
        # shards of the shaded frames: pixels at 60-70° against the union of the ranges of
        # the views around them, at the surface point the support shows there
        bad = tot = 0
        for f in frames:
            on = (f["A"] == 1) & (f["btf.slant"] >= 60) & (f["btf.slant"] <= 70)
            if not on.any():
                continue
            H, W = qy.shape[1:]
            ty = np.rint(f["btf.v"][on]).astype(np.int64) % H
            tx = np.rint(f["btf.u"][on]).astype(np.int64) % W
            ay, ax = qy[s][ty, tx], qx[s][ty, tx]
            phi = np.mod(f["btf.tilt"][on], 360.0)
            j0 = np.floor(phi / 45.0).astype(np.int64) % 8
            lo = np.full(on.sum(), np.inf)
            hi = np.full(on.sum(), -np.inf)
            for k in (6, 7):
                for jj in (j0, (j0 + 1) % 8):
                    for t in range(8):
                        sel = jj == t
                        n = g["index"][(k, float(MOVE_TILTS[t]))]
                        lo[sel] = np.minimum(lo[sel], ranges[n][0][ay[sel], ax[sel]])
                        hi[sel] = np.maximum(hi[sel], ranges[n][1][ay[sel], ax[sel]])
            lum = np.stack([f[c][on] for c in "RGB"], -1).astype(np.float64) @ btf.LUMA
            bad += int(((lum > hi + margin) | (lum < lo - margin)).sum())
            tot += int(on.sum())
        rows[mode] = (we, es, st, bad / max(tot, 1), tot, per)
    print(f"\n## shaded move: btf_move, 12 frames 256², stack {len(views)} views -> 256² "
          f"(shard margin {margin:.4f} = {SHARD_MARGIN:g} × the 60-70° input luminance range, "
          f"parallax reach {reach:.1f} px)")
    print(f"{'stack':<12} {'warp err':>9} {'E_s':>8} {'shards stack 60-70':>19} {'shards move 60-70':>18} {'px':>7}")
    for mode, (we, es, st, sm, tot, _) in rows.items():
        print(f"{mode:<12} {we:9.4f} {es:8.4f} {100 * st:18.2f}% {100 * sm:17.2f}% {tot:7d}")
    print("warp error per frame pair (sequential): " + " ".join(f"{e:.3f}" for e in rows["sequential"][5]))
    print("warp error per frame pair (independent): " + " ".join(f"{e:.3f}" for e in rows["independent"][5]))
    r = rows["sequential"][0] / rows["independent"][0]
    print(f"warp error sequential / independent = {r:.3f} ({'pass' if r < 1 else 'FAIL'})")


def figures(folder: Path):
    """The images of docs/btf.md: three views (input, then sequential, columns,
    independent) as 120² crops at 100%, and the contact sheet of a sequential stack
    (80² crops)."""
    from proxyshade.graph.plate import Plate
    from proxyshade.io.images import write_png
    from proxyshade.kernels.display import to_display

    def png(path, rgb):
        write_png(path, to_display(Plate({c: np.ascontiguousarray(rgb[..., i]) for i, c in enumerate("RGB")}),
                                   ["R", "G", "B"]))

    stack = run_node("BtfRender", {"scene": SCENE, "size": 160, "slant_step": 10, "slant_max": 70,
                                   "tilts": [0, 90]})
    aligned = run_node("BtfAlign", {}, {"stack": stack})
    views, imgs = btf.stack_arrays(aligned)
    idx = {(v["slant"], v["tilt"]): n for n, v in enumerate(views)}
    pick = [idx[(0.0, 0.0)], idx[(40.0, 0.0)], idx[(70.0, 90.0)]]
    s = pick[0]
    gap = np.zeros((128, 4, 3), np.float32)
    rows = [np.concatenate(sum([[imgs[n, :120, :120], gap[:120]] for n in pick], [])[:-1], 1)]
    for mode in btf.MODES:
        qy, qx = btf.synthesize_stack(imgs, s, (256, 256), mode=mode, seed=1)
        out = btf.gather_stack(imgs, qy, qx)
        rows.append(np.concatenate(sum([[out[n, 64:184, 64:184], gap[:120]] for n in pick], [])[:-1], 1))
    hgap = np.zeros((4, rows[0].shape[1], 3), np.float32)
    png(folder / "btf_modes.png", np.concatenate(sum([[r, hgap] for r in rows], [])[:-1], 0))
    # the graph's grid (tilts 0, 30, 60, 90), sequential: 80² crops of every view
    stack = run_node("BtfRender", {"scene": SCENE, "size": 160, "slant_step": 10, "slant_max": 70,
                                   "tilts": [0, 30, 60, 90]})
    views, imgs = btf.stack_arrays(run_node("BtfAlign", {}, {"stack": stack}))
    qy, qx = btf.synthesize_stack(imgs, 0, (256, 256), seed=1)
    out = btf.gather_stack(imgs, qy, qx)
    png(folder / "btf_sheet.png", btf.contact_sheet(out[:, 80:160, 80:160], views, gap=2))


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--figures":
        figures(Path(sys.argv[2]))
    elif len(sys.argv) > 1 and sys.argv[1] == "--move":
        shaded_move()
    else:
        main()
        shaded_move()
