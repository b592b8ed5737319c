"""Progressive update after a proxy edit vs the whole first frame, 1024² output / 256²
synthesis, lake from renoir (graphs/edit.yaml's nodes, plates in memory: no cache I/O).

Whole frame: guide synthesis, depth extension, colour synthesis (EditSynth's first run).
Update: the proxy render of the edited scene, then the three progressive steps on the
region the edit changed (synthesis.edit); also with the source read back as new arrays
(what the engine does at each run of an interactive loop, ``run --watch``; the copy is
timed with it). Target: an edit covering ~5% of the frame updates in <= 20% of the whole
frame's time and <= 0.3 s on 2 cores. Wall medians with
every numba thread, and CPU seconds with one.

Then the edit carried through a camera move (graphs/edit_move.yaml's nodes, 512², 12 frames,
plates in memory): after the stroke, the first frame's progressive update and, per later
frame, ConsistentDepth, then Reproject and Resynthesize progressive (``temporal.
carry_update``, ``resynthesis.resynthesize_update``) against a whole re-run of the move's
later frames from the edited first frame: seconds, pixels carried again / changed /
resynthesized, and the edited shot's seams and detail relative to its first frame (issue
#10's bars: seams <= 1.5x, detail >= 0.9). ``python bench/run.py edit`` runs both;
``python bench/bench_edit.py move [size] [frames]`` the move only, ``first`` the first frame only."""
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

import numba
import numpy as np

from harness import measure, table

from proxyshade.graph.graph import Graph
from proxyshade.graph.plate import Plate
from proxyshade.kernels import quality as Q
from proxyshade.graph.testing import run_node
from proxyshade.scene.edit import add_stroke
from proxyshade.synthesis.depth import depth_plate
from proxyshade.synthesis.edit import changed_region, update_guide
from proxyshade.synthesis.edit_colour import edit_synthesis
from proxyshade.synthesis.guide import synthesize_guide
from proxyshade.synthesis.params import Guidance

ROOT = Path(__file__).resolve().parents[1]
EDITS = [("island", (5, -40), 7.0, 9.0), ("hill in the lake", (0, -38), 10.0, 9.0)]


def main():
    if len(sys.argv) > 1 and sys.argv[1] == "move":
        return move(*(int(a) for a in sys.argv[2:4]))
    if len(sys.argv) > 1 and sys.argv[1] == "first":
        return first_frame()
    first_frame()
    move()


def first_frame():
    tmp = Path(tempfile.mkdtemp())
    try:
        shutil.copy(ROOT / "samples/scenes/lake.yaml", tmp / "lake.yaml")
        add_stroke(tmp / "lake.yaml", "Ground", (150, 150), 1.0, 0.0)
        g = Graph.load(ROOT / "graphs/edit.yaml", cache=tmp / "cache", variables={"scene": str(tmp / "lake.usda")})
        P = {n: SimpleNamespace(**g.nodes[n].params) for n in ("proxy", "guide", "depth", "final")}
        src = g.value("src", 1)
        render = lambda: run_node("ProxyRender", vars(P["proxy"]), {"source": src}, graph_dir=tmp)  # noqa: E731
        proxy0 = render()
        gp = Guidance.of(P["guide"])

        def whole():
            gd, _ = synthesize_guide(proxy0, src, gp)
            dp = depth_plate(proxy0, gd, penalty=P["depth"].penalty)
            return gd, dp, edit_synthesis(dp, src, P["final"], previous=None, region=None)

        guide0, depth0, final0 = whole()
        rows = []
        cpu_upd = {}
        for name, centre, radius, amount in EDITS:
            shutil.copy(tmp / "lake.yaml", tmp / "before.yaml")
            add_stroke(tmp / "lake.yaml", "Ground", centre, radius, amount)
            proxy1 = render()

            def update(s=src):
                p1 = render()
                r = changed_region({"proxy": proxy0}, {"proxy": p1}, {"proxy": ("label.id",)}, P["guide"].dilate)
                gd, ginfo = update_guide(guide0, r, p1, s, gp, context=P["guide"].context)
                r = changed_region({"proxy": proxy0, "guide": guide0}, {"proxy": p1, "guide": gd},
                                   {"proxy": ("label.id", "Z"), "guide": ("label.id",)}, P["depth"].dilate)
                dp = depth_plate(p1, gd, penalty=P["depth"].penalty, region=r, previous=depth0)
                r = changed_region({"guide": depth0}, {"guide": dp}, {"guide": ("label.id",)}, P["final"].dilate)
                return edit_synthesis(dp, s, P["final"], previous=final0, region=r), ginfo

            def update_reread():
                """as the engine runs it (``run --watch``): the source read back from the cache, new arrays"""
                return update(Plate({c: src[c].copy() for c in src.names()}, dict(src.meta)))

            out, ginfo = update()
            e = out.meta["edit"]
            changed = float((proxy0["label.id"] != proxy1["label.id"]).mean())
            print(f"{name}: proxy labels changed {100 * changed:.2f}%, colour synthesized {100 * e['share']:.2f}% "
                  f"({e['synthesis_pixels']} synthesis px), guide windows {ginfo['windows']}")
            rows.append((f"update: {name} (wall, all threads)", measure(update, repeat=5), 0.3))
            rows.append((f"  the same, source read back", measure(update_reread, repeat=5), 0.3))
            cpu_upd[name] = _cpu(update)
            rows.append((f"update: render alone", measure(render, repeat=5), None))
            shutil.copy(tmp / "before.yaml", tmp / "lake.yaml")
            add_stroke(tmp / "lake.yaml", "Ground", (150, 150), 1.0, 0.0)
        full = measure(whole, repeat=3)
        # the update renders the proxy (to diff it); a first frame renders it too
        full_r = measure(lambda: (render(), whole()), repeat=3)
        rows.insert(0, ("whole first frame (wall, all threads)", full, None))
        rows.insert(1, ("whole first frame + proxy render", full_r, None))
        table("edit update vs whole first frame, lake 1024² (bench_edit)", rows)
        for name, m, _ in rows[2:]:
            if "render alone" not in name:
                print(f"{name}: {m['median'] / full['median']:.1%} of the whole frame "
                      f"({m['median'] / full_r['median']:.1%} of the whole frame with its proxy render)")
        numba.set_num_threads(1)
        cpu = {}
        for label, fn in (("whole", whole), ("whole+render", lambda: (render(), whole()))):
            ts = []
            for _ in range(3):
                t = time.process_time()
                fn()
                ts.append(time.process_time() - t)
            cpu[label] = float(np.median(ts))
        print(f"CPU, one numba thread: whole first frame {cpu['whole']:.3f} s; "
              + ", ".join(f"update {k} {v:.3f} s ({v / cpu['whole']:.1%})" for k, v in cpu_upd.items())
              + f"; with the proxy render in the whole frame ({cpu['whole+render']:.3f} s): "
              + ", ".join(f"{k} {v / cpu['whole+render']:.1%}" for k, v in cpu_upd.items()))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def move(size: int = 512, frames: int = 12):
    """The island stroke carried through the lake's move, progressive vs a whole re-run."""
    from proxyshade.synthesis.resynthesis import resynthesize_update
    from proxyshade.synthesis.temporal import carry_update

    tmp = Path(tempfile.mkdtemp())
    try:
        shutil.copy(ROOT / "samples/scenes/lake.yaml", tmp / "lake.yaml")
        add_stroke(tmp / "lake.yaml", "Ground", (150, 150), 1.0, 0.0)
        g = Graph.load(ROOT / "graphs/edit_move.yaml", cache=tmp / "cache", variables={"scene": str(tmp / "lake.usda")},
                       overrides=[f"proxy.resolution=[{size},{size}]", f"guide.size={size // 4}",
                                  f"guide.start={size // 16}"])
        P = {n: g.nodes[n].params for n in ("proxy", "guide", "depth", "first", "cd", "reproject", "final")}
        NS = {n: SimpleNamespace(**v) for n, v in P.items()}
        src = g.value("src", 1)
        fr = range(1, frames + 1)
        render = lambda f: run_node("ProxyRender", P["proxy"], {"source": src}, frame=f, graph_dir=tmp)  # noqa: E731
        gp = Guidance.of(NS["guide"])

        def later(proxies, guide, depth, first):
            """cd, Reproject, Resynthesize of every later frame: the whole move from its first frame."""
            out = {1: {"final": first}}
            for f in fr:
                cd = run_node("ConsistentDepth", P["cd"], {"proxy": proxies[f], "guide": guide, "depth": depth,
                                                           "ref_proxy": proxies[1]}, frame=f)
                rp = run_node("Reproject", dict(P["reproject"], progressive=False),
                              {"depth": cd, "prev": out[f - 1]["final"] if f > 1 else None, "first": first,
                               "source": src}, frame=f)
                fin = run_node("Resynthesize", dict(P["final"], progressive=False), {"image": rp, "source": src}, frame=f)
                out[f] = {"cd": cd, "reproject": rp, "final": fin}
            return out

        proxies0 = {f: render(f) for f in fr}
        guide0, _ = synthesize_guide(proxies0[1], src, gp)
        depth0 = depth_plate(proxies0[1], guide0, penalty=NS["depth"].penalty)
        first0 = edit_synthesis(depth0, src, NS["first"], previous=None, region=None)
        before = later(proxies0, guide0, depth0, first0)

        add_stroke(tmp / "lake.yaml", "Ground", (5, -40), 7.0, 9.0)
        t = time.perf_counter()
        proxies1 = {f: render(f) for f in fr}
        t_render = time.perf_counter() - t
        r = changed_region({"proxy": proxies0[1]}, {"proxy": proxies1[1]}, {"proxy": ("label.id",)}, NS["guide"].dilate)
        guide1, _ = update_guide(guide0, r, proxies1[1], src, gp, context=NS["guide"].context)
        r = changed_region({"proxy": proxies0[1], "guide": guide0}, {"proxy": proxies1[1], "guide": guide1},
                           {"proxy": ("label.id", "Z"), "guide": ("label.id",)}, NS["depth"].dilate)
        depth1 = depth_plate(proxies1[1], guide1, penalty=NS["depth"].penalty, region=r, previous=depth0)
        r = changed_region({"guide": depth0}, {"guide": depth1}, {"guide": ("label.id",)}, NS["first"].dilate)
        first1 = edit_synthesis(depth1, src, NS["first"], previous=first0, region=r)

        def progressive():
            out, rows = {1: {"final": first1}}, []
            for f in fr:
                cd = run_node("ConsistentDepth", P["cd"], {"proxy": proxies1[f], "guide": guide1, "depth": depth1,
                                                           "ref_proxy": proxies1[1]}, frame=f)
                b = before[f]
                old_in = {"depth": b["cd"], "prev": before[f - 1]["final"] if f > 1 else None, "source": src}
                prev = out[f - 1]["final"] if f > 1 else None
                up = carry_update(b["reproject"], old_in, cd, prev, first1, src, NS["reproject"], frame=f,
                                  first_frame=1)
                rp = up[0] if up is not None else run_node("Reproject", dict(P["reproject"], progressive=False),
                                                           {"depth": cd, "prev": prev, "first": first1, "source": src},
                                                           frame=f)
                fin = resynthesize_update(b["final"], b["reproject"], rp, src, src, NS["final"], f)
                if fin is None:
                    fin = run_node("Resynthesize", dict(P["final"], progressive=False), {"image": rp, "source": src},
                                   frame=f)
                out[f] = {"cd": cd, "reproject": rp, "final": fin}
                rows.append({"frame": f, "carried": int(up[1].sum()) if up is not None else size * size,
                             "changed": fin.meta.get("resynthesis", {}).get("edit", {}).get("pixels", size * size),
                             "resynthesized": fin.meta.get("resynthesis", {}).get("pixels", 0)})
            return out, rows

        prog, rows = progressive()
        whole = later(proxies1, guide1, depth1, first1)
        # alternately, 3 times each: wall with every numba thread, and CPU seconds with one (steadier on a
        # shared machine)
        wall = {"p": [], "w": []}
        cpu = {"p": [], "w": []}
        runs = {"p": progressive, "w": lambda: later(proxies1, guide1, depth1, first1)}
        threads = numba.get_num_threads()
        for _ in range(3):
            for k, fn in runs.items():
                wall[k].append(_timed(fn))
                numba.set_num_threads(1)
                c = time.process_time()
                fn()
                cpu[k].append(time.process_time() - c)
                numba.set_num_threads(threads)
        t_prog, t_whole = statistics.median(wall["p"]), statistics.median(wall["w"])
        c_prog, c_whole = statistics.median(cpu["p"]), statistics.median(cpu["w"])
        n = size * size
        reached = [r for r in rows if r["frame"] > 1 and r["carried"] > 0]
        print(f"\n## the island stroke through the lake's move, {size}², frames 1-{frames} (bench_edit move)")
        print(f"proxy renders of the edited scene: {t_render:.3f} s ({frames} frames; the same for both)")
        print(f"frames 1-{frames} (the first passes through), ConsistentDepth + Reproject + Resynthesize (medians of 3): whole re-run "
              f"{t_whole:.3f} s wall / {c_whole:.3f} s CPU (one thread), progressive {t_prog:.3f} s wall "
              f"({t_prog / t_whole:.0%}) / {c_prog:.3f} s CPU ({c_prog / c_whole:.0%})")
        print(f"frames the edit reaches: {len(reached)} of {frames - 1}; pixels per later frame (median): carried again "
              f"{statistics.median(r['carried'] for r in rows[1:]) / n:.1%}, state changed "
              f"{statistics.median(r['changed'] for r in rows[1:]) / n:.1%}, resynthesized "
              f"{statistics.median(r['resynthesized'] for r in rows[1:]) / n:.2%} (whole re-run: every pixel carried, "
              f"{statistics.median(float((whole[f]['reproject']['flag'] > 0).mean()) for f in fr if f > 1):.2%} "
              "flagged and resynthesized)")
        for name, shot in (("progressive", prog), ("whole re-run", whole)):
            f1 = shot[1]["final"]
            s0, d0 = Q.seam_share(f1["source.x"], f1["source.y"], f1["label.id"]), Q.detail(f1.rgb(), f1["label.id"])
            s = max(Q.seam_share(shot[f]["final"]["source.x"], shot[f]["final"]["source.y"], shot[f]["final"]["label.id"])
                    for f in fr if f > 1) / s0
            d = min(Q.detail(shot[f]["final"].rgb(), shot[f]["final"]["label.id"]) for f in fr if f > 1) / d0
            print(f"edited shot, {name}: seams max {s:.2f}x frame 1's (bar 1.5), detail min {d:.3f} (bar 0.9)")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _cpu(fn, repeat: int = 3) -> float:
    """Median CPU seconds of ``fn`` with one numba thread (steadier than wall time on a shared machine)."""
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        ts = []
        for _ in range(repeat):
            t = time.process_time()
            fn()
            ts.append(time.process_time() - t)
        return float(np.median(ts))
    finally:
        numba.set_num_threads(threads)


def _timed(fn) -> float:
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


if __name__ == "__main__":
    main()
