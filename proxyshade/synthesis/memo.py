"""Results that depend only on arrays every frame of a run passes again (the source, the
first frame's plates), kept while those arrays live instead of being rebuilt each frame.

An entry is found by the identity of its arrays (weak references: nothing is kept alive
by the memo, and an array freed and reallocated at the same address is not mistaken for
the old one) and by a key of every other value the result depends on.
"""
from __future__ import annotations

import threading
import weakref
from typing import Any, Callable


class ArrayMemo:
    """The newest ``size`` results of ``compute`` by (arrays, key)."""

    def __init__(self, size: int = 2):
        self.size = size
        self._entries: list = []
        self._lock = threading.Lock()

    def get(self, arrays: tuple, key: Any, compute: Callable[[], Any]) -> Any:
        with self._lock:
            for refs, k, value in self._entries:
                if k == key and all((r() if r is not None else None) is a for r, a in zip(refs, arrays)):
                    return value
        value = compute()
        try:
            refs = tuple(weakref.ref(a) if a is not None else None for a in arrays)
        except TypeError:
            return value
        with self._lock:
            self._entries.append((refs, key, value))
            del self._entries[:-self.size]
        return value
