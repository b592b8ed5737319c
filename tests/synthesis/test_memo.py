"""ArrayMemo: results kept for the arrays of one run, by identity and key."""
import gc

import numpy as np

from proxyshade.synthesis.memo import ArrayMemo


def test_same_arrays_and_key_reuse_the_result_and_anything_else_recomputes():
    memo, calls = ArrayMemo(2), []

    def compute(v):
        calls.append(v)
        return v

    a, b = np.zeros(4), np.ones(4)
    assert memo.get((a, b), 1, lambda: compute("x")) == "x"
    assert memo.get((a, b), 1, lambda: compute("y")) == "x"  # reused
    assert memo.get((a.copy(), b), 1, lambda: compute("z")) == "z"  # equal content, another array: recomputed
    assert memo.get((a, b), 2, lambda: compute("k")) == "k"  # another key
    assert calls == ["x", "z", "k"]


def test_keeps_no_array_alive_and_forgets_old_entries():
    memo = ArrayMemo(2)
    a = np.zeros(4)
    memo.get((a,), 0, lambda: 1)
    del a
    gc.collect()
    b = np.zeros(4)
    assert memo.get((b,), 0, lambda: 2) == 2  # a freed array is never mistaken for a new one
    for k in range(3, 6):
        memo.get((b,), k, lambda k=k: k)
    assert memo.get((b,), 0, lambda: "again") == "again"  # only the newest 2 entries are kept
