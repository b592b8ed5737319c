"""The warm-up graphs: the demo's graphs run with their writers off, so every kernel type
signature they reach is compiled (``proxyshade compile``) or recorded into the manifest
(``warmup.write_manifest``). Apart from ``graph.warmup`` because it runs graphs: the engine
imports ``warmup`` (kernel prefetch, precompile), and ``warmup`` importing the engine back
would be a cycle."""
from __future__ import annotations

import time
from pathlib import Path

from proxyshade.graph.graph import Graph
from proxyshade.graph import warmup

# (graph file, frames, variables): the demo's graphs, each kernel type signature they reach
WARMUP = [
    ("first_frame.yaml", [1], {"scene": "lake", "source": "renoir"}),
    ("composite.yaml", [1], {}),
    ("camera_move.yaml", [1, 2], {}),
]


def graphs_dir() -> Path:
    """The bundled graphs (a source checkout's ``graphs/``)."""
    return Path(__file__).resolve().parents[2] / "graphs"


def warm_up(hooks=None, cache=None, progress=None, workers=None, first=True) -> dict:
    """Precompile the manifest's signatures (``precompile``), then run the warm-up graphs
    (writers disabled; ``cache``: one cache folder instead of each graph's default;
    ``first=False``: no precompile, every kernel compiles lazily).
    Returns {'seconds', 'precompile', 'signatures'}: wall time, the precompile's report
    and how many kernel signatures numba holds afterwards (compiled or loaded)."""
    t0 = time.perf_counter()
    pre = warmup.precompile(progress=progress, workers=workers) if first else None
    for name, frames, variables in WARMUP:
        g = Graph.load(graphs_dir() / name, cache=cache, variables=variables)
        for node, n in g.nodes.items():
            if n.sink:
                g.set(f"{node}.enabled", False)
        g.run(frames, hooks=hooks)
    return {"seconds": time.perf_counter() - t0, "precompile": pre, "signatures": warmup.kernel_signatures()}
