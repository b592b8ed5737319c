"""synthesis.memo.kept: a step's result kept in the memo handed in, or computed (no memo)."""
import numpy as np

from proxyshade.graph.memo import Memo, RunMemo
from proxyshade.graph.plate import Plate
from proxyshade.synthesis import grain, temporal
from proxyshade.synthesis.memo import kept


def test_no_memo_computes_every_time():
    calls = []
    for _ in range(2):
        kept(None, "t.step", (1,), lambda: calls.append(1))
    assert len(calls) == 2


def test_an_entry_is_never_reused_across_a_parameter_change():
    memo = RunMemo(Memo())
    Z = np.linspace(1.0, 2.0, 64, dtype=np.float32).reshape(8, 8)
    lab = np.ones((8, 8), np.uint32)
    a = temporal.frame0_grid(Z, lab, Z * 1.01, 0.1, 0.005, memo=memo)
    assert temporal.frame0_grid(Z, lab, Z * 1.01, 0.1, 0.005, memo=memo) is a
    assert (memo.hits, memo.misses) == (1, 1)
    b = temporal.frame0_grid(Z, lab, Z * 1.01, 0.1, 0.02, memo=memo)  # another tolerance
    assert b is not a and not np.array_equal(a.on_proxy, b.on_proxy)
    c = temporal.frame0_grid(Z, lab, Z * 1.02, 0.1, 0.005, memo=memo)  # other data
    assert c is not a
    assert (memo.hits, memo.misses) == (1, 3)


def test_graded_source_kept_by_the_source_content_and_table():
    rng = np.random.default_rng(0)
    rgb = rng.random((16, 16, 3), dtype=np.float32)
    lab = np.where(np.arange(16)[:, None] < 8, 1, 3).astype(np.uint32) * np.ones((1, 16), np.uint32)
    src = Plate({"R": rgb[..., 0], "G": rgb[..., 1], "B": rgb[..., 2], "label.id": lab})
    table = {"radii": [1, 2], "bins": 1, "gains": {"3": [[2.0, 2.0]]}}
    memo = RunMemo(Memo())
    g = grain.graded(src, table, memo)
    again = Plate({c: a.copy() for c, a in src.channels.items()})  # read back: other arrays, same content
    assert grain.graded(again, table, memo) is g
    other = {"radii": [1, 2], "bins": 1, "gains": {"3": [[1.5, 2.0]]}}
    assert grain.graded(src, other, memo) is not g
    assert (memo.hits, memo.misses) == (1, 2)
