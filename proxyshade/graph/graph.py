"""The engine: a graph of nodes over a frame range, run incrementally against a cache.

A run unrolls the graph over the requested frames into a DAG of (node, frame)
instances (inputs may name a node at a frame offset, at the first frame, or, for a
sequence node such as Movie, at every frame up to the last requested one: a sequence
node has one instance per run, at that last frame), rejects cycles, computes every instance's key top-down without touching pixels, then computes
exactly the keys the cache lacks, on an executor, loading cached inputs only when a
computed node needs them. Instances whose keys coincide (a time-independent node at
several frames) are computed once.

    g = Graph.load("graphs/demo.yaml")
    g.set("guide.k", 3)
    report = g.run(frames=[1], jobs=2)
    plate = g.value("guide", frame=1)
"""
from __future__ import annotations

import contextlib
import functools
import os
import resource
import threading
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, ContextManager

import networkx as nx

from proxyshade.errors import CycleError, GraphFileError, ParamError, UserError
from proxyshade.graph import keys as K
from proxyshade.graph import profile as _profile
from proxyshade.graph.cache import Cache, CacheWarning, size_limit
from proxyshade.graph.executor import make_executor
from proxyshade.graph.memo import Memo, RunMemo
from proxyshade.graph.node import (REGISTRY, Context, InputRef, Node, PlateSequence, Previous, find_type,
                                   resolve_path)
from proxyshade.graph.plate import Plate
from proxyshade.io.files import output_target, remove_stale_temps, user_cache_dir
from proxyshade.io.graphfile import load_graph


def _no_lock(key: str) -> ContextManager:
    return contextlib.nullcontext()


def _ignore(run: "NodeRun") -> None:
    pass


_ARRAYS_LOCK = threading.Lock()


def load_array_libraries() -> None:
    """Load numpy and the OpenEXR bindings now, one thread at a time. The engine and the node
    modules load them on first use (a fully cached run never needs them), but a first use on
    two threads at once goes wrong: Python's lazy modules before 3.11.9 / 3.12.3 can hand a
    half-loaded numpy to the second thread, and the bindings (a C extension that imports
    numpy) deadlocked against USD's import on another thread (the cache writer's first
    entry while a node imported pxr). Every compute calls this first."""
    with _ARRAYS_LOCK:
        import numpy

        numpy.ndarray  # an attribute: loads a lazy module on any Python version
        from proxyshade.io.exr import compressions

        compressions()
        _numba_array_math_without_blas()


def _numba_array_math_without_blas() -> None:
    """Load numba's array-math module (its CPU target loads it with the first kernel) with
    BLAS reported missing. On import it looks for a BLAS for ``np.dot``/``np.vdot`` of
    vectors in jitted code by importing scipy.linalg (with numpy.f2py and OpenBLAS: 0.15-0.3 s
    on the run's path and 15 MiB resident at 1024 wide), where no kernel calls either: each
    kernel's machine code is the same (and loads from the same cache entry). A kernel that
    called ``np.dot`` on vectors would get numba's loop; ``np.linalg`` and matrix products
    still find scipy when compiled. Once per process, before any kernel loads."""
    import sys

    if "numba.np.arraymath" in sys.modules:
        return
    from numba.np import linalg

    check = linalg.ensure_blas

    def no_blas():
        raise ImportError("proxyshade: BLAS not looked for when numba's array math loads")

    linalg.ensure_blas = no_blas
    try:
        import numba.np.arraymath as arraymath
    finally:
        linalg.ensure_blas = check
    arraymath.ensure_blas = check  # the name it imported, called only by that check


def load_native_libraries(graph: "Graph", todo) -> None:
    """Before a run computes ``todo`` (instances), on the calling (main) thread, before any
    node or cache-writer thread starts: numpy and the OpenEXR bindings, and USD with all its
    plugins when a node to compute reads USD (its module reaches ``proxyshade.io.usd``). A
    library whose loading takes the dynamic loader's lock and then waits for the GIL (USD's
    plugins) deadlocked against another thread holding the GIL in a C++ library that needed
    that lock (issue 36: two runs on one cache). A fully cached run (nothing to compute)
    loads nothing."""
    if not todo:
        return
    load_array_libraries()
    types = {type(graph.nodes[name]) for name, _ in todo}
    if any("proxyshade.io.usd" in K.import_closure(t.__module__) for t in types):
        with _ARRAYS_LOCK:
            from proxyshade.io.usd import load_plugins

            load_plugins()


HEAP_MMAP_THRESHOLD = 4 << 20  # bytes: a 1024-wide float32 channel and up


def return_freed_memory() -> bool:
    """Have glibc give every freed block of ``HEAP_MMAP_THRESHOLD`` or more back to the system
    (``mallopt(M_MMAP_THRESHOLD)``, process-wide; False where there is no glibc). By default
    glibc raises that threshold to the largest block freed so far (up to 32 MiB) and keeps
    the trimmed heap high: a first frame's arrays then come from its heaps, their pages stay
    resident once freed, and the resident set only grows node after node (at 1024 wide, 669
    -> 578 MiB peak with a fixed threshold, for about 0.1-0.2 CPU s of page faults). The
    command line sets it for ``run``; it changes no result."""
    import ctypes
    import ctypes.util

    try:
        mallopt = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6").mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes, mallopt.restype = [ctypes.c_int, ctypes.c_int], ctypes.c_int
    return bool(mallopt(-3, HEAP_MMAP_THRESHOLD))  # M_MMAP_THRESHOLD (malloc.h)


def set_kernel_threads(threads: int) -> int:
    """Threads the numba kernels called from this thread use: ``threads`` (0: every one
    numba has, ``NUMBA_NUM_THREADS``), at most that many. Returns the count set. numba is
    imported here, when a node computes: a fully cached run never imports it."""
    import numba

    n = numba.config.NUMBA_NUM_THREADS
    n = min(threads, n) if threads > 0 else n
    numba.set_num_threads(n)
    return n


@dataclass
class NodeRun:
    node: str
    frame: int
    key: str
    status: str  # computed | reused | passthrough
    reason: str
    seconds: float = 0.0
    notes: list[str] = field(default_factory=list)
    memo_hits: int = 0  # results of the synthesis layer found in the run's memo (graph.memo)
    memo_misses: int = 0  # ... and computed, then kept


@dataclass
class RunReport:
    """What a run did: one row per (node, frame), wall time and peak memory."""

    runs: list[NodeRun]
    wall: float
    peak_rss_mb: float
    cleaned: list[tuple[Path, int]] = field(default_factory=list)  # stale temporaries of killed runs, removed
    run_notes: list[str] = field(default_factory=list)  # notes about the run as a whole

    @property
    def computed(self) -> set[str]:
        return {r.node for r in self.runs if r.status == "computed"}

    @property
    def reused(self) -> set[str]:
        return {r.node for r in self.runs if r.status == "reused"}

    @property
    def memo(self) -> tuple[int, int]:
        """Hits and misses of the memo (``graph.memo``) over the run's instances."""
        return sum(r.memo_hits for r in self.runs), sum(r.memo_misses for r in self.runs)

    def rows(self, node: str | None = None) -> list[NodeRun]:
        return [r for r in self.runs if node is None or r.node == node]

    @property
    def notes(self) -> list[str]:
        return self.run_notes + [f"{r.node}@{r.frame}: {n}" for r in self.runs for n in r.notes]


class NodeError(RuntimeError):
    """A node's compute failed for a reason that is not bad input (an internal error)."""


def default_cache_dir() -> Path:
    """The plate cache when a run names none: ``$PROXYSHADE_CACHE``, else ``plates/`` in
    the per-user cache folder (``$XDG_CACHE_HOME/proxyshade`` or ``~/.cache/proxyshade``),
    outside the source tree, shared by every graph (keys are content addresses)."""
    env = os.environ.get("PROXYSHADE_CACHE")
    return Path(env) if env else user_cache_dir() / "plates"


class Graph:
    """Nodes, their connections and a frame range; runs against a Cache."""

    def __init__(self, *, graph_dir: str | Path = ".", frames: tuple[int, int] = (1, 1),
                 cache: str | Path | Cache | None = None, name: str = "graph", source: str | None = None):
        self.graph_dir = Path(graph_dir).resolve()
        self.frames = (int(frames[0]), int(frames[1]))
        self.name = name
        self.source = source  # the graph file, for messages
        self.nodes: dict[str, Node] = {}
        self.connections: dict[str, dict[str, InputRef]] = {}
        self.enabled: dict[str, bool] = {}
        self.lines: dict[str, int] = {}  # node -> line in the graph file, for messages
        if isinstance(cache, Cache):
            self.cache = cache
        else:
            self.cache = Cache(Path(cache) if cache else default_cache_dir())
        self._locks: dict[str, threading.Lock] = {}
        self._locks_guard = threading.Lock()
        # held while computing a key that an input's load found missing or corrupt: a lock
        # shared between processes where several compute (a Dask worker sets one)
        self.key_lock: Callable[[str], ContextManager] = _no_lock
        self.on_recompute: Callable[[NodeRun], None] = _ignore  # an input computed again (its entry missing or corrupt)
        self.memo: Memo | None = None  # the memo's store (None: this process's, graph.memo.STORE)
        self.tile_runner: Callable[[], Any] | None = None  # makes ctx.tiles for an instance (the Dask executor's)
        self.store_all = False  # store every plate, Node.stored or not (an unpickled graph: a Dask worker's)

    def __getstate__(self) -> dict:
        """A graph pickles (to a Dask worker) with its cache's folder, not its memory or locks."""
        return dict(self.__dict__, cache=str(self.cache.root.absolute()), _locks=None, _locks_guard=None)

    def __setstate__(self, state: dict) -> None:
        """An unpickled graph opens the same cache folder (its writes in the background)."""
        self.__dict__.update(state, cache=Cache(state["cache"]), _locks={}, _locks_guard=threading.Lock(),
                             store_all=True)  # another process may read any plate from the cache

    # -- building ----------------------------------------------------------
    find_type = staticmethod(find_type)  # a node type by name (graph files name them: io.graphfile)
    InputRef = InputRef

    @staticmethod
    def known_types() -> list[str]:
        return sorted(REGISTRY)

    @classmethod
    def load(cls, path: str | Path, *, cache: str | Path | None = None, overrides: list[str] = (),
             variables: dict[str, str] | None = None) -> "Graph":
        """Load a YAML graph file (see ``proxyshade.io.graphfile``); ``overrides`` are 'node.param=value'."""
        return load_graph(path, cls, cache=cache, overrides=overrides, variables=variables)

    def add(self, name: str, node_type: str | type[Node], params: dict | None = None,
            inputs: dict[str, str | InputRef] | None = None, enabled: bool = True) -> Node:
        if isinstance(node_type, str):
            cls = find_type(node_type)
            if cls is None:
                raise GraphFileError(f"unknown node type {node_type!r}; known types: {', '.join(sorted(REGISTRY))}")
            node_type = cls
        node = node_type(name, params or {})
        self.nodes[name] = node
        conns = {}
        for k, v in (inputs or {}).items():
            if k not in node_type.inputs_spec:
                raise GraphFileError(f"{name}: {node_type.__name__} has no input {k!r}; its inputs are "
                                     f"{', '.join(node_type.inputs_spec) or 'none'}")
            conns[k] = v if isinstance(v, InputRef) else InputRef(v)
        self.connections[name] = conns
        self.enabled[name] = enabled
        return node

    def set(self, dotted: str, value: Any) -> None:
        """Set a parameter, ``graph.set("guide.k", 3)`` (validated); ``node.enabled`` toggles a node."""
        name, _, param = dotted.partition(".")
        if name not in self.nodes:
            raise ParamError(f"{dotted}: no node {name!r}; nodes are {', '.join(self.nodes)}")
        if param == "enabled":
            if not isinstance(value, bool):
                raise ParamError(f"{dotted}: expected true or false, got {value!r}")
            self.enabled[name] = value
            return
        node = self.nodes[name]
        params = dict(node.params)
        params[param] = value
        node.params = node.validate_params(params, where=f"{name}.")

    def ref_problem(self, name: str, inp: str, ref: InputRef) -> str | None:
        """Why ``name.inp`` cannot read ``ref`` (a message ending with the fix), or None."""
        cls = type(self.nodes[name])
        spec = cls.inputs_spec[inp]
        src = self.nodes.get(ref.node)
        if src is None:
            return f"no node {ref.node!r}; nodes are {', '.join(self.nodes)}"
        if ref.all and (ref.offset or ref.first):
            return "frame: all reads every frame up to this one; drop the offset or 'first'"
        if ref.all and not spec.sequence:
            return (f"{cls.__name__} input {inp!r} takes one plate, not the whole sequence; drop 'frame: all' "
                    "(or read one frame: -1 or first)")
        if spec.sequence and not ref.all:
            return f"{cls.__name__} reads the whole sequence here; connect it as {{node: {ref.node}, frame: all}}"
        if src.sequence:
            return (f"{ref.node} ({type(src).__name__}) reads the whole sequence and runs once per run, so no node "
                    f"can read it; connect {name}.{inp} to what {ref.node} reads instead")
        return None

    # -- unrolling ---------------------------------------------------------
    def _check_frame(self, frame: int) -> None:
        lo, hi = self.frames
        if not lo <= frame <= hi:
            raise UserError(f"{self.source or self.name}: frame {frame} is outside the graph's frames {lo}-{hi}; "
                            "pick frames inside the range or widen 'frames'")

    def instances(self, frames: list[int]) -> nx.DiGraph:
        """The unrolled DAG of (node, frame) for ``frames``; edges carry the input name.

        A sequence node has one instance, at the last of ``frames`` (none when disabled)."""
        dag = nx.DiGraph()
        first = self.frames[0]
        for f in frames:
            self._check_frame(f)
        for name, conns in self.connections.items():
            for inp, ref in conns.items():
                problem = self.ref_problem(name, inp, ref)
                if problem:
                    raise GraphFileError(f"{self.source or self.name}: nodes.{name}.inputs.{inp}: {problem}")
        stack = []
        for name, node in self.nodes.items():
            if not node.sequence:
                stack += [(name, f) for f in frames]
            elif self.enabled[name]:
                stack.append((name, max(frames)))  # once per run: a movie is not rewritten at every frame
        seen = set()
        while stack:
            inst = stack.pop()
            if inst in seen:
                continue
            seen.add(inst)
            dag.add_node(inst)
            name, frame = inst
            for inp, ref in self.connections[name].items():
                for f2 in ref.frames(frame, first):
                    if f2 < first or f2 > self.frames[1]:
                        continue  # before the first frame: the input arrives as None
                    dag.add_edge((ref.node, f2), inst, inputs=dag.get_edge_data((ref.node, f2), inst, {}).get("inputs", ()) + (inp,))
                    stack.append((ref.node, f2))
        try:
            cycle = nx.find_cycle(dag)
        except nx.NetworkXNoCycle:
            return dag
        path = " -> ".join(f"{a}@{fa}" for (a, fa), _ in cycle) + f" -> {cycle[0][0][0]}@{cycle[0][0][1]}"
        raise CycleError(f"{self.source or self.name}: cycle {path}; break it with a frame offset "
                         "(e.g. prev: {node: X, frame: -1})")

    def input_files(self, frames: list[int] | None = None) -> set[Path]:
        """The files the graph's computing nodes read (``Node.read_files``: their ``Path``
        parameters, a proxy's USD scene) at ``frames`` (default: the graph's range): what
        ``proxyshade run --watch`` watches."""
        frames = frames or list(range(self.frames[0], self.frames[1] + 1))
        out = set()
        for node in self.nodes.values():
            if not node.sink:
                out.update(p for f in frames for p in node.read_files(f, self.graph_dir))
        return out

    # -- keys --------------------------------------------------------------
    def _components(self, name: str, frame: int, input_keys: dict[str, str | None]) -> dict:
        node = self.nodes[name]
        cls = type(node)
        hashed = {k: v for k, v in node.params.items() if cls.params_spec[k].hashed}
        files = {}
        if not node.sink:
            for k, spec in cls.params_spec.items():
                if spec.type is Path and node.params.get(k):
                    files[k] = K.file_hash(resolve_path(node.params[k], self.graph_dir, frame))
        else:
            for k, spec in cls.params_spec.items():
                if spec.type is Path and node.params.get(k):
                    hashed[k] = str(resolve_path(node.params[k], self.graph_dir, frame))
        time_dep = node.depends_on_frame()
        return {
            "type": cls.__name__,
            "version": cls.version,
            "code": K.code_hash(cls),
            "libraries": K.library_versions(),
            "params": hashed,
            "inputs": input_keys,
            "frame": frame if time_dep else None,
            "files": files,
            "extra": node.key_extra(frame, self.graph_dir),
        }

    def plan(self, frames: list[int] | None = None, force: tuple[str, ...] = ()) -> "Plan":
        """Keys and what would be computed, without computing anything."""
        frames = list(frames) if frames else list(range(self.frames[0], self.frames[1] + 1))
        for f in force:
            if f not in self.nodes:
                raise ParamError(f"--force {f}: no node {f!r}; nodes are {', '.join(self.nodes)}")
        dag = self.instances(frames)
        first = self.frames[0]
        last = self.cache.last_run(self._graph_id()) if any(n.is_progressive() for n in self.nodes.values()) else {}
        previous: dict[tuple[str, int], tuple[str, dict]] = {}
        inst_key: dict[tuple[str, int], str] = {}
        comps: dict[tuple[str, int], dict] = {}
        passthrough: dict[tuple[str, int], tuple[str, int] | None] = {}
        for inst in nx.lexicographical_topological_sort(dag, key=str):
            name, frame = inst
            node = self.nodes[name]
            input_keys: dict[str, str | list[str] | None] = {}
            for inp, spec in type(node).inputs_spec.items():
                ref = self.connections[name].get(inp)
                if ref is None:
                    if not spec.optional:
                        raise GraphFileError(f"{self.source or self.name}: nodes.{name}.inputs.{inp}: not connected; "
                                             f"connect it to a node ({type(node).__name__} needs it)")
                    input_keys[inp] = None
                    continue
                if ref.all:  # a sequence input: the keys of every frame, in order
                    input_keys[inp] = [inst_key[(ref.node, f2)] for f2 in ref.frames(frame, first)]
                    continue
                f2 = ref.frame(frame, first)
                if (ref.node, f2) not in inst_key:
                    if not spec.optional:
                        raise UserError(f"{name}@{frame}: input {inp} at frame {f2} is outside the graph's frames; "
                                        "make the input optional or start later")
                    input_keys[inp] = None
                else:
                    input_keys[inp] = inst_key[(ref.node, f2)]
            if not self.enabled[name]:
                pin = node.passthrough_input()
                if pin is None or input_keys.get(pin) is None:
                    raise GraphFileError(f"{name}: disabled but has no connected input to pass through; "
                                         "enable it or remove it")
                ref = self.connections[name][pin]
                passthrough[inst] = (ref.node, ref.frame(frame, first))
                inst_key[inst] = input_keys[pin]
                continue
            c = self._components(name, frame, input_keys)
            if node.is_progressive() and name not in force:
                prev = self._previous(last.get(f"{name}@{frame}"), c)
                if prev:
                    previous[inst] = prev
            comps[inst] = c
            inst_key[inst] = K.make_key(c)
        return Plan(self, dag, frames, inst_key, comps, passthrough, set(force), previous=previous)

    def _previous(self, old: dict | None, c: dict) -> tuple[str, dict] | None:
        """For a progressive instance with components ``c``: its last run's key and input keys
        when that run differs only in its inputs and its result and inputs are in the cache
        (``c`` then gets ``previous``: that key); when the inputs are the same as then, ``c``
        becomes the last run's components (the same key: a cache hit). None otherwise."""
        if not isinstance(old, dict) or not isinstance(old.get("inputs"), dict):
            return None
        rest = lambda d: K.canonical({k: v for k, v in d.items() if k not in ("inputs", "previous")})  # noqa: E731
        if rest(old) != rest(c):
            return None  # new code, parameters, files or data: recompute whole
        if K.canonical(old["inputs"]) == K.canonical(c["inputs"]):
            if "previous" in old:
                c["previous"] = old["previous"]
            return None
        key = K.make_key(old)
        needed = [key] + [k for k in old["inputs"].values() if isinstance(k, str)]
        if not all(self.cache.has(k)[0] for k in needed):
            return None
        c["previous"] = key
        return key, {n: k for n, k in old["inputs"].items() if isinstance(k, str)}

    # -- running -----------------------------------------------------------
    def _lock(self, key: str) -> threading.Lock:
        with self._locks_guard:
            return self._locks.setdefault(key, threading.Lock())

    def run(self, frames: list[int] | None = None, *, jobs: int = 1, force: tuple[str, ...] = (),
            hooks: "Hooks | None" = None, threads: int = 0, executor=None) -> RunReport:
        """Compute what the cache lacks for ``frames`` (default: all); returns the report.
        ``executor``: where the instances run (default: ``make_executor(jobs)``, this process;
        ``proxyshade.graph.dask_executor.DaskExecutor`` for Dask workers)."""
        job = self.prepare(frames, force=force, hooks=hooks, threads=threads)
        (executor or make_executor(jobs)).run_jobs([job])
        return job.finish()

    def prepare(self, frames: list[int] | None = None, *, force: tuple[str, ...] = (),
                hooks: "Hooks | None" = None, threads: int = 0) -> "RunJob":
        """A run up to its computing: the plan, a row per instance, stale temporaries removed
        and the DAG of the instances the cache lacks (``RunJob.todo``)."""
        t0 = time.perf_counter()
        size_limit()  # a bad PROXYSHADE_CACHE_LIMIT: an error before anything runs
        plan = self.plan(frames, force)
        plan.threads = threads
        hooks = hooks or Hooks()
        hooks.plan(plan)
        cleaned = self._remove_stale_temps(plan)
        runs: dict[tuple[str, int], NodeRun] = {}
        key_owner: dict[str, tuple[str, int]] = {}
        todo = nx.DiGraph()
        last = self.cache.last_run(self._graph_id())
        for inst in nx.lexicographical_topological_sort(plan.dag, key=str):
            key = plan.keys[inst]
            name, frame = inst
            if inst in plan.passthrough:
                runs[inst] = NodeRun(name, frame, key, "passthrough", "disabled: passes its input through")
                continue
            if key in key_owner:
                o = key_owner[key]
                runs[inst] = NodeRun(name, frame, key, "reused", f"same key as {o[0]}@{o[1]}")
                continue
            key_owner[key] = inst
            ok, why = (False, "forced") if name in plan.force else self.cache.has(key)
            if ok:
                runs[inst] = NodeRun(name, frame, key, "reused", why)
                plan.rows[key] = runs[inst]  # turned into "computed" if loading it finds it corrupt
            else:
                reason = why if why not in ("not in cache",) else K.diff_components(last.get(f"{name}@{frame}"), plan.components[inst])
                if inst in plan.previous:
                    reason += "; progressive: updates the last run's result"
                runs[inst] = NodeRun(name, frame, key, "computed", reason)
                todo.add_node(inst, first=self.nodes[name].sink)  # writers run once ready: their input is freed
        # edges between instances to compute, through reused/passthrough ones
        for inst in todo:
            for pred in plan.dag.predecessors(inst):
                p = key_owner.get(plan.keys[pred], pred)
                if p in todo:
                    todo.add_edge(p, inst)
        self._drop_unneeded(plan, runs, todo)
        load_native_libraries(self, todo)
        return RunJob(self, plan, runs, todo, hooks, cleaned, t0)

    def _stored(self, name: str) -> bool:
        """Whether ``name``'s plates go to the cache (``Node.stored``; always on a Dask worker,
        where another worker reads them from the cache, and for a progressive node)."""
        node = self.nodes[name]
        return type(node).stored or node.is_progressive() or self.store_all

    def _drop_unneeded(self, plan: "Plan", runs: dict, todo: nx.DiGraph) -> None:
        """Leave out of ``todo`` the instances of node types that are not stored
        (``Node.stored``) when no instance to compute reads them (their readers are in the
        cache: a fully cached re-run computes nothing); readers first, so a chain of them goes."""
        for inst in reversed(list(nx.lexicographical_topological_sort(todo, key=str))):
            name = inst[0]
            if (self._stored(name) or self.nodes[name].sink or todo.out_degree(inst)
                    or plan.keys[inst] in plan.keep or name in plan.force):
                continue
            todo.remove_node(inst)
            nr = runs[inst]
            nr.status, nr.reason = "reused", (f"not needed: nothing to compute reads it ({type(self.nodes[name]).__name__} "
                                              "is not stored: computed again when read)")

    def _work(self, job: "RunJob", consumers: dict[str, int], guard: threading.Lock, inst) -> None:
        """Compute one instance in this process, then drop from memory the plates no
        instance still to compute reads."""
        plan, nr = job.plan, job.runs[inst]
        job.hooks.start(nr)
        prof = _profile.ACTIVE
        if prof is not None:
            prof.watch(self, plan)
            prof.node_start(nr.node, nr.frame, self.nodes[nr.node].sink)
        def release(key: str):  # the instance released an input (ctx.release): the last reader?
            with guard:
                if consumers.get(key, 0) == 1 and key not in plan.keep:
                    self.cache.forget(key)
                    return self.cache.writing(key)  # its cache write, while it still holds the plate
            return None

        t = time.perf_counter()
        try:
            self._compute(plan, inst, nr, release)
        finally:
            nr.seconds = time.perf_counter() - t
            if prof is not None:
                prof.node_end(nr.node, nr.frame, nr.seconds)
        with guard:
            for k in plan.held_keys(inst):
                consumers[k] -= 1
                if consumers[k] == 0 and k not in plan.keep:
                    self.cache.forget(k)
            if consumers.get(nr.key, 0) == 0 and nr.key not in plan.keep:
                self.cache.forget(nr.key)
        job.hooks.done(nr)

    def output_files(self, dag: nx.DiGraph) -> list[Path]:
        """The files the writers (sinks) among ``dag``'s instances write (symlinks followed)."""
        out = []
        for name, frame in dag:
            node = self.nodes[name]
            if not node.sink or not self.enabled[name]:
                continue
            for k, spec in type(node).params_spec.items():
                if spec.type is Path and node.params.get(k):
                    try:
                        out.append(output_target(resolve_path(node.params[k], self.graph_dir, frame)))
                    except UserError:
                        continue  # refused when the writer runs, with its message
        return out

    def _remove_stale_temps(self, plan: "Plan") -> list[tuple[Path, int]]:
        """Delete temporaries that killed runs left in the cache and beside this run's outputs."""
        removed = self.cache.remove_stale_temps()
        outputs: dict[Path, set[str]] = {}  # folder -> names of this run's outputs in it
        for target in self.output_files(plan.dag):
            outputs.setdefault(target.parent, set()).add(target.name)
        for folder, names in outputs.items():
            removed += remove_stale_temps(folder, names)
        return removed

    def where(self, name: str) -> str:
        """'graph.yaml:12: ' for a node loaded from a file (the start of its messages), else ''."""
        line = self.lines.get(name)
        return f"{self.source}:{line}: " if self.source and line else ""

    def _graph_id(self) -> str:
        return K.digest([str(self.source or self.name), str(self.graph_dir)])[:16]

    def _value(self, plan: "Plan", inst: tuple[str, int]) -> Plate:
        """The plate of an instance: memory, disk, or computed now (corrupt entries are recomputed)."""
        key = plan.keys[inst]
        if inst in plan.passthrough:
            return self._value(plan, plan.passthrough[inst])
        with self._lock(key):
            if self.nodes[inst[0]].sink:
                problem = "a writer's plate is not cached"
            else:
                problem = self.cache.load_problem(key)
                if problem is None:
                    return self.cache.memory[key]
            with self.key_lock(key):  # a process computing this key meanwhile (a Dask worker) finishes first
                if not self.nodes[inst[0]].sink and self.cache.intact(key) and self.cache.load_problem(key) is None:
                    return self.cache.memory[key]
                nr = plan.rows.get(key)
                if nr is not None and nr.status == "reused":  # the report says what happened, not what was planned
                    nr.status, nr.reason = "computed", problem
                else:
                    nr = NodeRun(inst[0], inst[1], key, "computed", problem)
                t = time.perf_counter()
                plate = self._compute_locked(plan, inst, nr)
                nr.seconds = time.perf_counter() - t
                self.on_recompute(nr)
                return plate

    def _sequence_plate(self, plan: "Plan", name: str, frame: int) -> Plate:
        """One plate of a sequence input, dropped from memory again unless it was held there."""
        key = plan.keys[(name, frame)]
        held = key in self.cache.memory
        plate = self._value(plan, (name, frame))
        if not held and key not in plan.keep:
            self.cache.forget(key)
        return plate

    def _compute(self, plan: "Plan", inst, nr: NodeRun, release: Callable[[str], None] | None = None) -> Plate:
        load_array_libraries()
        with self._lock(nr.key):
            if nr.key in self.cache.memory:
                return self.cache.memory[nr.key]
            return self._compute_locked(plan, inst, nr, release)

    def _compute_locked(self, plan: "Plan", inst, nr: NodeRun, release: Callable[[str], None] | None = None) -> Plate:
        """Compute an instance from its inputs and store (or keep) its plate. ``release(key)``:
        called when the node releases the input of that key (``Context.release``); the
        caller drops it from memory where this instance is its last reader (a recompute of
        a missing input passes none: nothing dropped early)."""
        name, frame = inst
        node = self.nodes[name]
        inputs: dict[str, Plate | PlateSequence | None] = {}
        first = self.frames[0]
        for inp in type(node).inputs_spec:
            ref = self.connections[name].get(inp)
            if ref is not None and ref.all:
                inputs[inp] = PlateSequence(ref.frames(frame, first), functools.partial(self._sequence_plate, plan, ref.node),
                                            functools.partial(node.check_plate, inp))
                continue
            src = (ref.node, ref.frame(frame, first)) if ref else None
            inputs[inp] = self._value(plan, src) if src in plan.keys else None
        ctx = Context(node, frame, first, inputs, dict(node.params), self.graph_dir, plan.threads, nr.notes)
        ctx.memo = memo = RunMemo(self.memo)
        for inp, ref in self.connections[name].items():  # the input plates stand for their keys in the memo's keys
            src = (ref.node, ref.frame(frame, first))
            if isinstance(inputs.get(inp), Plate) and src in plan.keys:
                memo.bind(inputs[inp], plan.keys[src])
        ctx.tiles = self.tile_runner() if self.tile_runner is not None else None
        if release is not None:
            held = plan.input_keys(inst)  # the keys the run counts this instance's reads of (held_keys)

            def on_release(inp: str):
                return release(held[inp]) if isinstance(held.get(inp), str) else None

            ctx.on_release = on_release

            def on_read_back(inp: str):
                k = held.get(inp)
                if not isinstance(k, str) or k in self.cache.memory or not self.cache.usable(k):
                    return None
                return functools.partial(self.cache.read_back, k)

            ctx.on_read_back = on_read_back
        if inst in plan.previous:
            ctx.previous = self._load_previous(*plan.previous[inst])
            memo.bind(ctx.previous.plate, plan.previous[inst][0])
            for n, k in plan.previous[inst][1].items():
                if ctx.previous.inputs.get(n) is not None:
                    memo.bind(ctx.previous.inputs[n], k)
        set_kernel_threads(plan.threads)  # numba's thread count is per calling thread: set it in this worker
        t = time.perf_counter()
        try:
            node.check_inputs(inputs)
            plate = node.compute(ctx)
        except UserError as e:
            msg = str(e)
            if self.source and msg.startswith(f"{self.source}:"):
                raise  # raised by an upstream node read inside this compute (a sequence input): named already
            # one form for every bad-input error of a node: "name@frame: ..." (ctx.error's and the
            # input checks' "name: ..." and a layer's bare message alike)
            for own in (f"{name}@{frame}: ", f"{name}: "):
                if msg.startswith(own):
                    msg = msg[len(own):]
                    break
            raise type(e)(self.where(name) + f"{name}@{frame}: {msg}") from None
        except Exception as e:
            summary = ", ".join(f"{k}=None" if v is None else f"{k}={len(v)} frames" if isinstance(v, PlateSequence)
                                else f"{k}={v.width}x{v.height}[{','.join(v.names()[:6])}]" for k, v in inputs.items())
            raise NodeError(f"{self.where(name)}node {name!r} ({type(node).__name__}) failed at frame {frame} with inputs "
                            f"{summary or 'none'}: {type(e).__name__}: {e}") from e
        finally:
            nr.memo_hits, nr.memo_misses = memo.hits, memo.misses
        if not isinstance(plate, Plate):
            raise NodeError(f"node {name!r} ({type(node).__name__}) returned {type(plate).__name__}, not a Plate")
        record = {"node": name, "type": type(node).__name__, "frame": frame, "params": node.params,
                  "inputs": plan.input_keys(inst), "compute_s": time.perf_counter() - t}
        if node.sink:
            self.cache.store_sink(nr.key, node.written_files(ctx), record)
            self.cache.memory[nr.key] = plate
        elif self._stored(name):
            self.cache.store(nr.key, plate, record, replace=name in plan.force)
        else:
            self.cache.memory[nr.key] = plate
        return plate

    def _load_previous(self, key: str, input_keys: dict[str, str]) -> Previous:
        """The last run's result and inputs of a progressive instance, read from the cache."""
        plates = {}
        for k in [key, *input_keys.values()]:
            held = k in self.cache.memory
            problem = self.cache.load_problem(k)
            if problem is not None:
                raise NodeError(f"the last run's result {k[:12]} could not be read back ({problem}); "
                                "run again to recompute it whole")
            plates[k] = self.cache.memory[k]
            if not held:
                self.cache.forget(k)
        return Previous(plates[key], {n: plates[k] for n, k in input_keys.items()})

    def value(self, name: str, frame: int | None = None, *, jobs: int = 1) -> Plate:
        """The plate a node produces at ``frame`` (running what is missing first)."""
        frame = self.frames[0] if frame is None else frame
        plan = self.plan([frame])
        if (name, frame) not in plan.keys:
            raise ParamError(f"no node {name!r}; nodes are {', '.join(self.nodes)}")
        plan.keep.add(plan.keys[(name, frame)])
        try:
            return self._value(plan, (name, frame))
        finally:
            self.cache.flush()


@dataclass
class Plan:
    graph: Graph
    dag: nx.DiGraph
    frames: list[int]
    keys: dict[tuple[str, int], str]
    components: dict[tuple[str, int], dict]
    passthrough: dict[tuple[str, int], tuple[str, int]]
    force: set[str]
    threads: int = 0
    keep: set[str] = field(default_factory=set)
    rows: dict[str, NodeRun] = field(default_factory=dict)  # key -> the run's row of its reused instance
    previous: dict[tuple[str, int], tuple[str, dict]] = field(default_factory=dict)  # progressive: last key, input keys

    def input_keys(self, inst) -> dict[str, str | list[str] | None]:
        c = self.components.get(inst)
        return dict(c["inputs"]) if c else {}

    def held_keys(self, inst) -> set[str]:
        """Upstream keys whose plates the instance's compute reads at once: its one-frame inputs
        (a sequence input reads its plates one at a time, from disk once they are dropped)."""
        return {k for k in self.input_keys(inst).values() if isinstance(k, str)}


class RunJob:
    """One graph's run, prepared (``Graph.prepare``): the plan, a row per instance, and
    ``todo``, the DAG of the instances to compute. An executor computes them, in this
    process (``work``) or elsewhere (filling the rows); ``finish`` makes the report."""

    def __init__(self, graph: Graph, plan: Plan, runs: dict[tuple[str, int], NodeRun], todo: nx.DiGraph,
                 hooks: "Hooks", cleaned: list[tuple[Path, int]], t0: float):
        self.graph, self.plan, self.runs, self.todo, self.hooks = graph, plan, runs, todo, hooks
        self.cleaned = cleaned
        self.t0 = t0
        self.notes: list[str] = []  # about the run as a whole, from the executor
        self.label: str | None = None  # the graph's name in messages where several run together
        self.peak_rss_mb = 0.0  # of the processes that computed elsewhere (Dask workers)
        consumers: dict[str, int] = {}
        for inst in todo:
            for k in plan.held_keys(inst):
                consumers[k] = consumers.get(k, 0) + 1
        self.work = functools.partial(graph._work, self, consumers, threading.Lock())

    def finish(self) -> RunReport:
        """Report hooks for what was not computed, remember the key components, the report."""
        g, plan = self.graph, self.plan
        for nr in self.runs.values():
            if nr.status != "computed":
                self.hooks.done(nr)
        g.cache.save_run(g._graph_id(), {f"{n}@{f}": c for (n, f), c in plan.components.items()})
        order = {inst: i for i, inst in enumerate(nx.lexicographical_topological_sort(plan.dag, key=str))}
        rows = sorted(self.runs.values(), key=lambda r: (r.frame, order[(r.node, r.frame)]))
        peak = max(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, self.peak_rss_mb)
        notes = list(self.notes)
        if g.cache.unstored:
            notes.append(f"cache {g.cache.root} is read-only: {g.cache.unstored} result(s) computed by this "
                         "run were not stored")
            g.cache.unstored = 0
        if any(r.status == "computed" for r in rows) and not g.cache.read_only:  # only a computing run grows it
            too_big = g.cache.over_limit()
            if too_big:
                warnings.warn(too_big, CacheWarning, stacklevel=2)
        return RunReport(rows, time.perf_counter() - self.t0, peak, self.cleaned, notes)


class Hooks:
    """Progress callbacks (the CLI's progress bars implement them); all optional."""

    def plan(self, plan: Plan) -> None: ...

    def start(self, run: NodeRun) -> None: ...

    def done(self, run: NodeRun) -> None: ...
