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


if __name__ == "__main__":
    main()
