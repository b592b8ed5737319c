"""Small counting nodes for engine tests: each counts its computes so caching is asserted directly."""
from __future__ import annotations

import collections
from pathlib import Path

import numpy as np
import pytest

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate

COMPUTES: collections.Counter = collections.Counter()


class _TConst(Node, register=False):
    """A constant plate of ``value`` (seeded noise when seed is set)."""

    value = Param(float, 1.0)
    size = Param(int, 8, min=1)
    seed = Param(int, None)
    threads = Param(int, 0, hashed=False)

    def compute(self, ctx):
        COMPUTES[self.name] += 1
        a = np.full((ctx.p.size, ctx.p.size), ctx.p.value, np.float32)
        if ctx.p.seed is not None:
            a += np.random.default_rng(ctx.p.seed).random(a.shape, dtype=np.float32)
        return Plate({"R": a, "label.id": np.arange(a.size, dtype=np.uint32).reshape(a.shape)})


class _TAdd(Node, register=False):
    """a + b (+ prev when connected), optional ``prev`` at a frame offset."""

    a = Input(channels=("R",))
    b = Input(optional=True, channels=("R",))
    prev = Input(optional=True)
    gain = Param(float, 1.0)

    def compute(self, ctx):
        COMPUTES[self.name] += 1
        r = ctx.a["R"] * ctx.p.gain
        if ctx.b is not None:
            r = r + ctx.b["R"]
        if ctx.prev is not None:
            r = r + ctx.prev["R"]
        return Plate({"R": r.astype(np.float32)})


class _TFrame(Node, register=False):
    """A plate holding the frame number: a time-dependent node."""

    time_dependent = True

    def compute(self, ctx):
        COMPUTES[self.name] += 1
        return Plate({"R": np.full((4, 4), ctx.frame, np.float32)})


class _TRead(Node, register=False):
    """A plate holding the number in a text file ('####': one file per frame)."""

    path = Param(Path)

    def compute(self, ctx):
        COMPUTES[self.name] += 1
        return Plate({"R": np.full((4, 4), float(ctx.path(ctx.p.path).read_text()), np.float32)})


class _TSeq(Node, register=False):
    """A sequence node: R = the sum over the sequence of R; meta lists the frames it read."""

    image = Input(channels=("R",), sequence=True)

    def compute(self, ctx):
        COMPUTES[self.name] += 1
        total = sum(p["R"] for p in ctx.image)
        return Plate({"R": total.astype(np.float32)}, {"frames": list(ctx.image.frames)})


TYPES = {"TConst": _TConst, "TAdd": _TAdd, "TFrame": _TFrame, "TRead": _TRead, "TSeq": _TSeq}


@pytest.fixture(scope="session", autouse=True)
def _session_plate_cache(tmp_path_factory):
    """The default plate cache of module- and session-scoped fixtures (set up before any
    test's own): a folder of the session's, never the user's."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("PROXYSHADE_CACHE", str(tmp_path_factory.mktemp("plates")))
        yield


@pytest.fixture(autouse=True)
def _own_plate_cache(tmp_path, monkeypatch):
    """Every test's default plate cache is its own, ``tmp_path/.proxyshade/cache``
    (``$PROXYSHADE_CACHE``, inherited by the subprocesses it starts): never the user's."""
    monkeypatch.setenv("PROXYSHADE_CACHE", str(tmp_path / ".proxyshade" / "cache"))
    monkeypatch.delenv("PROXYSHADE_CACHE_LIMIT", raising=False)


@pytest.fixture
def computes():
    COMPUTES.clear()
    return COMPUTES


@pytest.fixture
def registry():
    """Register the test node types for YAML graphs, and remove them afterwards."""
    from proxyshade.graph.node import REGISTRY
    import proxyshade.nodes  # noqa: F401

    REGISTRY.update(TYPES)
    yield TYPES
    for k in TYPES:
        REGISTRY.pop(k, None)
