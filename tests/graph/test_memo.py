"""The engine's memo (graph.memo): keyed like a plate, counted per instance in the run report."""
from __future__ import annotations

import gc

import numpy as np

from proxyshade.graph.graph import Graph
from proxyshade.graph.memo import Memo, RunMemo
from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate
from proxyshade.synthesis.memo import kept

from tests.conftest import _TConst

CALLS: list = []


class _TMemo(Node, register=False):
    """R * gain, the product kept in the run's memo (``shared`` is not hashed by the step)."""

    time_dependent = True
    a = Input(channels=("R",))
    gain = Param(float, 2.0)

    def compute(self, ctx):
        def step():
            CALLS.append(ctx.frame)
            return ctx.a["R"] * np.float32(ctx.p.gain)

        r = kept(ctx.memo, "test.scaled", (ctx.a["R"], ctx.p.gain), step)
        return Plate({"R": r + np.float32(ctx.frame)})


def graph(tmp_path, store):
    g = Graph(graph_dir=tmp_path, frames=(1, 3), cache=tmp_path / "cache")
    g.memo = store
    g.add("a", _TConst, {"value": 1.0})
    g.add("m", _TMemo, {}, {"a": "a"})
    return g


def test_hits_counted_in_the_report_and_never_reused_across_a_parameter_change(tmp_path):
    store = Memo()
    CALLS.clear()
    g = graph(tmp_path, store)
    r = g.run(frames=[1, 2, 3])
    assert CALLS == [1]  # frames 2 and 3 find frame 1's product
    assert r.memo == (2, 1)
    assert [(x.memo_hits, x.memo_misses) for x in r.rows("m")] == [(0, 1), (1, 0), (1, 0)]
    np.testing.assert_array_equal(g.value("m", 3)["R"], np.full((8, 8), 5.0, np.float32))
    g.set("m.gain", 3.0)
    r = g.run(frames=[1, 2])
    assert CALLS == [1, 1] and r.memo == (1, 1)  # a new gain: computed again, not the kept product
    np.testing.assert_array_equal(g.value("m", 2)["R"], np.full((8, 8), 5.0, np.float32))
    g.set("a.value", 2.0)
    r = g.run(frames=[1])
    assert CALLS == [1, 1, 1] and r.memo == (0, 1)  # new input data: computed again
    np.testing.assert_array_equal(g.value("m", 1)["R"], np.full((8, 8), 7.0, np.float32))


def test_input_plates_stand_for_their_keys_and_results_for_their_entries():
    memo = RunMemo(Memo())
    a = np.zeros((4, 4), np.float32)
    p = Plate({"R": a})
    memo.bind(p, "k1")
    assert memo.store.token(p) == "plate:k1" and memo.store.token(a) == "plate:k1:R"
    r = memo.get("t.double", (a,), lambda: a * 2)
    assert memo.store.token(r).startswith("memo:")
    b = np.zeros((4, 4), np.float32)  # not bound: its bytes
    assert memo.store.token(b).startswith("bytes:")
    del p, a
    gc.collect()
    assert memo.store.token(np.zeros((4, 4), np.float32)).startswith("bytes:")  # a freed array's token is dropped


def test_newest_entries_kept_per_step():
    memo = RunMemo(Memo())
    for k in range(3):
        memo.get("t.k", (k,), lambda k=k: k, size=2)
    assert memo.get("t.k", (0,), lambda: "again", size=2) == "again"
    assert memo.get("t.k", (2,), lambda: "again", size=2) == 2
    assert (memo.hits, memo.misses) == (1, 4)
