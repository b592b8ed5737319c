"""The local executors' order: what a run holds in memory at once follows from it."""
from __future__ import annotations

from proxyshade.graph.graph import Graph, Hooks
from tests.conftest import _TAdd, _TFrame


class _Order(Hooks):
    def __init__(self):
        self.started = []

    def start(self, run) -> None:
        self.started.append((run.node, run.frame))


def test_a_shot_runs_frame_by_frame(tmp_path):
    """Ready nodes of the earliest frame first: a frame's chain finishes before the next frame's
    starts (by name alone every frame's 'p' ran before the first 'q', each plate held until then)."""
    g = Graph(graph_dir=tmp_path, frames=(1, 3), cache=tmp_path / "cache")
    g.add("p", _TFrame)
    g.add("q", _TAdd, {}, {"a": "p"})
    hooks = _Order()
    g.run(hooks=hooks)
    assert hooks.started == [("p", 1), ("q", 1), ("p", 2), ("q", 2), ("p", 3), ("q", 3)]
