"""Progressive nodes: the engine hands a node its last result at the frame and the inputs it
was made from, only when nothing but the inputs changed, and keys the new result by that
history so a cache hit is always what this history computes."""
from __future__ import annotations

import numpy as np

from proxyshade.graph.graph import Graph
from proxyshade.graph.node import Input, Node, Param, Progressive
from proxyshade.graph.plate import Plate

from tests.conftest import _TConst

SEEN: list = []


class _TPatch(Progressive, Node, register=False):
    """R = a's R where it changed since the last run (or everywhere without one), else the
    last result: a pixel-level update, like the synthesis nodes' progressive paths."""

    a = Input(channels=("R",))
    gain = Param(float, 1.0)

    def compute(self, ctx):
        prev = ctx.previous
        SEEN.append(None if prev is None else (prev.plate["R"].copy(), prev.inputs["a"]["R"].copy()))
        new = ctx.a["R"] * ctx.p.gain
        if prev is None:
            return Plate({"R": new})
        changed = prev.inputs["a"]["R"] != ctx.a["R"]
        return Plate({"R": np.where(changed, new, prev.plate["R"] + 100).astype(np.float32)})


def graph(tmp_path, value=1.0, seed=0, gain=1.0, progressive=True):
    g = Graph(graph_dir=tmp_path, frames=(1, 2), cache=tmp_path / "cache")
    g.add("a", _TConst, {"value": value, "seed": seed})
    g.add("p", _TPatch, {"gain": gain, "progressive": progressive}, {"a": "a"})
    return g


def test_previous_result_and_inputs_reach_the_node_only_after_an_input_change(tmp_path):
    SEEN.clear()
    g = graph(tmp_path)
    g.run(frames=[1])
    assert SEEN == [None]  # first run: nothing to update
    first = g.value("p", 1)["R"].copy()
    # an unchanged re-run is a cache hit, not an update
    assert graph(tmp_path).run(frames=[1]).computed == set()
    # the input changes: the node gets its last result and the input it was made from
    g = graph(tmp_path, value=1.0, seed=1)
    r = g.run(frames=[1])
    assert r.computed == {"a", "p"}
    assert "progressive" in r.rows("p")[0].reason
    prev_plate, prev_a = SEEN[-1]
    np.testing.assert_array_equal(prev_plate, first)
    np.testing.assert_array_equal(prev_a, np.full((8, 8), 1.0, np.float32) + np.random.default_rng(0).random((8, 8), dtype=np.float32))
    second = g.value("p", 1)["R"].copy()
    # the same history again is a hit (its key holds the last result's key) ...
    n = len(SEEN)
    assert graph(tmp_path, value=1.0, seed=1).run(frames=[1]).computed == set()
    assert len(SEEN) == n
    np.testing.assert_array_equal(graph(tmp_path, value=1.0, seed=1).value("p", 1)["R"], second)
    # ... and the key differs from a fresh computation of the same inputs (another history)
    fresh = Graph(graph_dir=tmp_path, frames=(1, 2), cache=tmp_path / "other")
    fresh.add("a", _TConst, {"value": 1.0, "seed": 1})
    fresh.add("p", _TPatch, {"progressive": True}, {"a": "a"})
    assert fresh.plan([1]).keys[("p", 1)] != g.plan([1]).keys[("p", 1)]


def test_new_params_or_a_missing_last_result_recompute_whole(tmp_path):
    SEEN.clear()
    graph(tmp_path).run(frames=[1])
    graph(tmp_path, seed=1, gain=2.0).run(frames=[1])  # a parameter of the node changed
    assert SEEN[-1] is None
    g = graph(tmp_path, seed=2, gain=2.0)
    last = g.plan([1])
    assert ("p", 1) in last.previous  # the last result (gain 2) is there to update
    key = last.previous[("p", 1)][0]
    for f in (tmp_path / "cache").rglob(key + "*"):
        f.unlink()
    assert ("p", 1) not in graph(tmp_path, seed=2, gain=2.0).plan([1]).previous
    graph(tmp_path, seed=2, gain=2.0).run(frames=[1])
    assert SEEN[-1] is None


def test_not_progressive_never_gets_previous(tmp_path):
    SEEN.clear()
    graph(tmp_path, progressive=False).run(frames=[1])
    graph(tmp_path, seed=1, progressive=False).run(frames=[1])
    assert SEEN == [None, None]


def test_frames_are_updated_separately(tmp_path):
    SEEN.clear()
    graph(tmp_path).run(frames=[1, 2])
    graph(tmp_path, seed=1).run(frames=[2])
    assert SEEN[-1] is not None  # frame 2's own last result
    # frame 1 was not re-run: its record still names the first run, so it is updated from there
    assert ("p", 1) in graph(tmp_path, seed=1).plan([1]).previous
