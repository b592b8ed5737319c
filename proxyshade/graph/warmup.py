"""Compile the numba kernels ahead of the first run (``proxyshade compile``, run by ``make
demo``): numba compiles a kernel for the argument types of its first call and keeps it in
its on-disk cache, so the warm-up runs the bundled demo graphs (the lake's first frame,
the farm composite, the lake camera move's first update frame) at their real sizes, every
branch the demo takes included, without their writers. Their results go to each graph's
default cache, so the demo that follows reuses them instead of computing them again.
"""
from __future__ import annotations

import time
from pathlib import Path

# (graph file, frames, variables): the demo's graphs, each kernel type signature they reach
WARMUP = [
    ("first_frame.yaml", [1], {"scene": "lake", "source": "renoir"}),
    ("composite.yaml", [1], {}),
    ("camera_move.yaml", [1, 2], {}),
]


def graphs_dir() -> Path:
    """The bundled graphs (a source checkout's ``graphs/``)."""
    return Path(__file__).resolve().parents[2] / "graphs"


def warm_up(hooks=None) -> dict:
    """Run the warm-up graphs (writers disabled); returns {'seconds', 'signatures'}: wall
    time and how many kernel signatures numba holds afterwards (compiled or loaded)."""
    from proxyshade.graph.graph import Graph

    t0 = time.perf_counter()
    for name, frames, variables in WARMUP:
        g = Graph.load(graphs_dir() / name, variables=variables)
        for node, n in g.nodes.items():
            if n.sink:
                g.set(f"{node}.enabled", False)
        g.run(frames, hooks=hooks)
    return {"seconds": time.perf_counter() - t0, "signatures": kernel_signatures()}


def kernel_dispatchers() -> dict:
    """'module.function' -> numba dispatcher, for every kernel defined in a
    ``proxyshade.kernels`` module imported in this process."""
    import sys

    from numba.core.registry import CPUDispatcher

    out = {}
    for name, mod in list(sys.modules.items()):
        if name.startswith("proxyshade.kernels."):
            for v in vars(mod).values():
                if isinstance(v, CPUDispatcher) and v.py_func.__module__ == name:
                    out[f"{name.rpartition('.')[2]}.{v.py_func.__name__}"] = v
    return out


def kernel_signatures() -> int:
    """Signatures numba holds (compiled or loaded from its cache) over ``kernel_dispatchers``."""
    return sum(len(d.signatures) for d in kernel_dispatchers().values())
