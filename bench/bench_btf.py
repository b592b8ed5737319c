"""View-consistent BTF stack synthesis (Neubeck, Zalesny and Van Gool 2004) on btf_bumps.

Speed (medians after JIT, 2 threads): support view 256² (r = 3) ≤ 3 s; each other view
(r = 2) ≤ 1.5 s; a 15-view stack ≤ 30 s. Quality, one 15-view stack synthesized three ways
(independent views, whole columns, sequential), on the non-support views: consistency
E_c = mean ‖A(q_v(p)) − A′(p)‖ and seams E_s = mean colour jump across edges whose sources
are not neighbours; pass: E_c(sequential) < E_c(independent), E_s(sequential) < E_s(columns).
Alignment: the chosen plane against the sample's heights, and the RMSE of a 27.5° view
interpolated from 25° and 30° with that plane and with planes outside the heights.
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
    else:
        main()
