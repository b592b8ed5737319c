"""Guidance synthesis 256² (target ≤ 0.5 s on 2 cores; the paper: 2 s with a GPU) and depth
extension at 1024² (target ≤ 0.15 s), medians after JIT, on the bundled scenes."""
from pathlib import Path

from harness import measure, table
from proxyshade.graph.testing import run_node

ROOT = Path(__file__).resolve().parents[1]


def main():
    rows = []
    for scene, source in (("lake", "renoir"), ("cliffs", "monet")):
        src = run_node("SourceRead", {"table": f"samples/{source}/source.yaml"}, graph_dir=ROOT)
        proxy = run_node("ProxyRender", {"scene": f"samples/scenes/{scene}.usda", "resolution": [1024, 1024]},
                         {"source": src}, graph_dir=ROOT)
        params = {"size": 256, "start": 64, "seed": 1}
        guide = run_node("GuideSynth", params, {"proxy": proxy, "source": src})
        rows.append((f"GuideSynth 256² -> 1024², {scene}",
                     measure(lambda: run_node("GuideSynth", params, {"proxy": proxy, "source": src}), repeat=5), 0.5))
        rows.append((f"DepthExtend 1024², {scene}",
                     measure(lambda: run_node("DepthExtend", {}, {"proxy": proxy, "guide": guide}), repeat=5), 0.15))
    table("guidance synthesis and depth extension", rows)


if __name__ == "__main__":
    main()
