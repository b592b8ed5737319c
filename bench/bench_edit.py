"""Progressive update after a proxy edit vs the whole first frame, 1024² output / 256²
synthesis, lake from renoir (graphs/edit.yaml's nodes, plates in memory: no cache I/O).

Whole frame: guide synthesis, depth extension, colour synthesis (EditSynth's first run).
Update: the proxy render of the edited scene, then the three progressive steps on the
region the edit changed (synthesis.edit). Target: an edit covering ~5% of the frame
updates in <= 20% of the whole frame's time and <= 0.3 s on 2 cores. Wall medians with
every numba thread, and CPU seconds with one."""
import shutil
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

import numba
import numpy as np

from harness import measure, table

from proxyshade.graph.graph import Graph
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
        for name, centre, radius, amount in EDITS:
            shutil.copy(tmp / "lake.yaml", tmp / "before.yaml")
            add_stroke(tmp / "lake.yaml", "Ground", centre, radius, amount)
            proxy1 = render()

            def update():
                p1 = render()
                r = changed_region({"proxy": proxy0}, {"proxy": p1}, {"proxy": ("label.id",)}, P["guide"].dilate)
                gd, ginfo = update_guide(guide0, r, p1, src, gp, context=P["guide"].context)
                r = changed_region({"proxy": proxy0, "guide": guide0}, {"proxy": p1, "guide": gd},
                                   {"proxy": ("label.id", "Z"), "guide": ("label.id",)}, P["depth"].dilate)
                dp = depth_plate(p1, gd, penalty=P["depth"].penalty, region=r, previous=depth0)
                r = changed_region({"guide": depth0}, {"guide": dp}, {"guide": ("label.id",)}, P["final"].dilate)
                return edit_synthesis(dp, src, P["final"], previous=final0, region=r), ginfo

            out, ginfo = update()
            e = out.meta["edit"]
            changed = float((proxy0["label.id"] != proxy1["label.id"]).mean())
            print(f"{name}: proxy labels changed {100 * changed:.2f}%, colour synthesized {100 * e['share']:.2f}% "
                  f"({e['synthesis_pixels']} synthesis px), guide windows {ginfo['windows']}")
            rows.append((f"update: {name} (wall, all threads)", measure(update, repeat=5), 0.3))
            rows.append((f"update: render alone", measure(render, repeat=5), None))
            shutil.copy(tmp / "before.yaml", tmp / "lake.yaml")
            add_stroke(tmp / "lake.yaml", "Ground", (150, 150), 1.0, 0.0)
        full = measure(whole, repeat=3)
        rows.insert(0, ("whole first frame (wall, all threads)", full, None))
        table("edit update vs whole first frame, lake 1024² (bench_edit)", rows)
        for name, m, _ in rows[1:]:
            if "render alone" not in name:
                print(f"{name}: {m['median'] / full['median']:.1%} of the whole frame")
        numba.set_num_threads(1)
        cpu = {}
        for label, fn in (("whole", whole),):
            ts = []
            for _ in range(3):
                t = time.process_time()
                fn()
                ts.append(time.process_time() - t)
            cpu[label] = float(np.median(ts))
        print(f"CPU, one numba thread: whole first frame {cpu['whole']:.3f} s")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
