"""The engine's memo: results of synthesis steps that every frame of a run would compute
again from the same data (a source's similarity sets, the first frame's grid), kept and
handed to the nodes as ``ctx.memo``.

An entry is keyed like a plate: the step's name, the code version of the module that
computes it (``keys.import_closure``, sources and library versions) and its explicit
parameters, where a plate or an array stands for its content address: an input plate the
engine handed to the node is its cache key (and each of its channels that key and the
channel's name), an earlier entry's result its entry key, anything else the digest of its
bytes. So an entry is never found for other data or other parameters, whichever arrays
hold them, and a later run of the same data (an edit loop reading the source back from the
cache) finds it again. The newest ``size`` entries of each step are kept, in this process.

The synthesis layer takes the memo as an argument (``synthesis.memo.kept``; None: nothing
kept). Each node instance gets a ``RunMemo``: the store plus the counts of its hits and
misses, which the run report carries and ``--explain`` shows.
"""
from __future__ import annotations

import collections
import functools
import hashlib
import threading
import weakref
from typing import Any, Callable


@functools.lru_cache(maxsize=None)
def _code(module: str) -> str:
    """The code version of ``module``: its import closure's sources and the libraries."""
    from proxyshade.graph import keys as K

    return K.digest([K.library_versions(), [(m, K.module_hash(m)) for m in K.import_closure(module)]])


def _digest_bytes(a) -> str:
    import numpy as np

    a = np.ascontiguousarray(a)
    h = hashlib.blake2b(digest_size=16)
    h.update(str((a.dtype.str, a.shape)).encode())
    h.update(a.view(np.uint8).reshape(-1))
    return h.hexdigest()


class Memo:
    """The store: entries by key, the newest ``size`` per step; and the content addresses
    of the plates and arrays it has been told (``bind``) or has made."""

    def __init__(self):
        self._steps: dict[str, collections.OrderedDict] = {}
        self._known: dict[int, tuple[weakref.ref, str]] = {}  # id -> (ref, token)
        self._lock = threading.Lock()
        self._computing: dict[str, threading.Lock] = {}
        self._ref_ids: dict[int, int] = {}  # id of a reference in _known -> its key there
        self._gone: list = []  # weak references whose objects were freed, to drop from _known

    # -- content addresses ---------------------------------------------------
    def _remember(self, obj: Any, token: str) -> None:
        gone = self._gone
        try:
            ref = weakref.ref(obj, lambda r: gone.append(r))  # no lock in a callback: it may run in any locked section
        except TypeError:
            return
        with self._lock:
            while gone:  # the references of freed objects: their ids may name new objects now
                r = gone.pop()
                i = self._ref_ids.pop(id(r), None)
                if i is not None and self._known.get(i, (None,))[0] is r:
                    del self._known[i]
            old = self._known.get(id(obj))
            if old is not None:
                self._ref_ids.pop(id(old[0]), None)
            self._known[id(obj)] = (ref, token)
            self._ref_ids[id(ref)] = id(obj)

    def _known_token(self, obj: Any) -> str | None:
        with self._lock:
            got = self._known.get(id(obj))
        if got is not None and got[0]() is obj:
            return got[1]
        return None

    def bind(self, plate: Any, key: str) -> None:
        """``plate`` (and each of its channels) has the content of cache entry ``key``."""
        self._remember(plate, f"plate:{key}")
        for name, arr in plate.channels.items():
            self._remember(arr, f"plate:{key}:{name}")

    def token(self, value: Any) -> str:
        """A string that names ``value``'s content (see the module's docstring)."""
        import numpy as np

        if value is None or isinstance(value, (bool, int, str)):
            return repr(value)
        if isinstance(value, float):
            return f"f{value!r}"
        if isinstance(value, np.generic):
            return self.token(value.item())
        if isinstance(value, (tuple, list)):
            return "(" + ",".join(self.token(v) for v in value) + ")"
        if isinstance(value, dict):
            return "{" + ",".join(f"{self.token(k)}:{self.token(v)}" for k, v in
                                  sorted(value.items(), key=lambda kv: repr(kv[0]))) + "}"
        known = self._known_token(value)
        if known is not None:
            return known
        if isinstance(value, np.ndarray):
            return f"bytes:{_digest_bytes(value)}"
        channels = getattr(value, "channels", None)
        if isinstance(channels, dict):  # a Plate the engine did not hand in: its content
            from proxyshade.graph import keys as K

            return ("plate{" + ",".join(f"{n}:{_digest_bytes(a)}" for n, a in sorted(channels.items()))
                    + "}" + K.digest(value.meta))
        raise TypeError(f"memo key part of type {type(value).__name__}: pass plates, arrays or plain values")

    # -- entries -------------------------------------------------------------
    def get(self, step: str, parts: Any, compute: Callable[[], Any], *, size: int = 2,
            counts: "RunMemo | None" = None) -> Any:
        """The kept result of ``step`` for ``parts``, else ``compute()`` kept (the newest
        ``size`` of the step)."""
        module = getattr(compute, "__module__", None) or "?"
        key = hashlib.sha256(f"{step}|{_code(module)}|{self.token(parts)}".encode()).hexdigest()
        with self._lock:
            entries = self._steps.setdefault(step, collections.OrderedDict())
            lock = self._computing.setdefault(key, threading.Lock())
        with lock:  # one thread computes an entry; another asking meanwhile waits for it
            with self._lock:
                if key in entries:
                    entries.move_to_end(key)
                    value = entries[key]
                    hit = True
                else:
                    hit = False
            if not hit:
                value = compute()
                self._made(value, key)
                with self._lock:
                    entries[key] = value
                    while len(entries) > size:
                        entries.popitem(last=False)
        with self._lock:
            self._computing.pop(key, None)
        if counts is not None:
            counts.count(hit)
        return value

    def _made(self, value: Any, key: str) -> None:
        """An entry's result (an array, or arrays in a tuple or list) is known by its key."""
        import numpy as np

        if isinstance(value, np.ndarray):
            self._remember(value, f"memo:{key}")
        elif isinstance(value, (tuple, list)):
            for i, v in enumerate(value):
                if isinstance(v, np.ndarray):
                    self._remember(v, f"memo:{key}:{i}")

    def clear(self) -> None:
        with self._lock:
            self._steps.clear()


STORE = Memo()  # this process's: shared by its graphs and runs (keys are content addresses)


class RunMemo:
    """What a node instance sees as ``ctx.memo``: the store, counting its hits and misses."""

    def __init__(self, store: Memo | None = None):
        self.store = STORE if store is None else store
        self.hits = 0
        self.misses = 0
        self._lock = threading.Lock()

    def count(self, hit: bool) -> None:
        with self._lock:
            if hit:
                self.hits += 1
            else:
                self.misses += 1

    def get(self, step: str, parts: Any, compute: Callable[[], Any], *, size: int = 2) -> Any:
        return self.store.get(step, parts, compute, size=size, counts=self)

    def bind(self, plate: Any, key: str) -> None:
        self.store.bind(plate, key)
