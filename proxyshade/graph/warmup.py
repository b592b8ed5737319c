"""Compile the numba kernels ahead of the first run.

numba compiles a kernel for the argument types of its first call and keeps the machine code
in its on-disk cache. Compiling lazily, one kernel after another as a run reaches them,
uses one core for over a minute; so the first run compiles first, in parallel:

- ``kernel_manifest.py`` (beside this module) lists the kernel signatures the demo graphs
  reach: each kernel called from Python with its numba argument types, the seconds it took
  to compile (kernels it calls included) and the signatures those calls compiled. It is
  written by ``python -m proxyshade.graph.warmup --write-manifest`` from a cold-cache run.
- ``precompile`` compiles the listed signatures of the kernel modules not yet marked
  precompiled on one process per core (this one and spawned workers, each taking the
  slowest left) into the kernel cache of this version of the kernels package
  (``proxyshade/kernels/_cache.py``: one folder per hash of the whole package and of
  numba's and numpy's versions), then marks those modules; the run then only loads what
  the workers compiled. A signature the manifest lacks (a stale manifest, a branch the
  demo does not take) compiles lazily when first called, as before: the manifest only
  moves compile work, never changes a result.
- ``proxyshade compile`` (run by ``make demo``) precompiles every listed signature, then runs
  the bundled demo graphs (the lake's first frame, the farm composite, the lake camera
  move's first update frame) without their writers: their results go to each graph's
  default cache (the per-user one), so the demo that follows reuses them. ``proxyshade run`` on a cold cache
  precompiles the signatures of the kernel modules its graphs' nodes import.
"""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path

MANIFEST = Path(__file__).with_name("kernel_manifest.py")


def kernel_dispatchers() -> dict:
    """'module.function' -> numba dispatcher, for every kernel defined in a
    ``proxyshade.kernels`` module imported in this process."""
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


# --- the manifest -----------------------------------------------------------------------

def manifest() -> list[tuple[str, str, float, tuple]]:
    """The manifest's entries: (kernel 'proxyshade.kernels.module.function', argument types
    as text, compile seconds when written, (kernel, types) it compiled inside); [] when
    there is none."""
    try:
        from proxyshade.graph import kernel_manifest
    except ImportError:
        return []
    return list(kernel_manifest.ENTRIES)


def callers() -> dict[tuple[str, str], str]:
    """(kernel, argument types) -> the node type whose compute first called it when the
    manifest was recorded; {} for a manifest without them."""
    try:
        from proxyshade.graph import kernel_manifest
    except ImportError:
        return {}
    entries, found = list(kernel_manifest.ENTRIES), getattr(kernel_manifest, "CALLERS", {})
    return {(entries[i][0], entries[i][1]): t for i, t in found.items() if i < len(entries)}


def variants() -> dict[tuple[str, str], str]:
    """(kernel, argument types) -> the variant (``node_variant``) of the node whose compute
    first called it when the manifest was recorded; {} for a manifest without them."""
    try:
        from proxyshade.graph import kernel_manifest
    except ImportError:
        return {}
    entries, found = list(kernel_manifest.ENTRIES), getattr(kernel_manifest, "VARIANTS", {})
    return {(entries[i][0], entries[i][1]): v for i, v in found.items() if i < len(entries)}


def node_unit(node_type: str, variant: str | None = None) -> str:
    """The precompile unit (and mark) of a node type's manifest entries; with ``variant``,
    of those a node of that variant needs (``variant_units``)."""
    return f"node.{node_type}" + (f"@{variant}" if variant else "")


def node_variant(graph, name: str) -> str:
    """What decides which kernels a node calls beyond its type: a digest of its parameters
    (those naming files aside: a scene's path, a source table) and of which of its inputs
    are connected. Poisson with ``layout: false, grain: 1`` never calls the layout and
    grain kernels that Poisson with the defaults does."""
    import hashlib
    import json

    node = graph.nodes[name]
    spec = getattr(type(node), "params_spec", {})
    params = {k: v for k, v in getattr(node, "params", {}).items() if k not in spec or spec[k].type is not Path}
    conn = getattr(graph, "connections", {}).get(name, {})
    inputs = sorted(k for k, ref in conn.items() if ref is not None)
    return hashlib.sha256(json.dumps([params, inputs], sort_keys=True, default=str).encode()).hexdigest()[:12]


def variant_units() -> dict[tuple[str, str], list[str]]:
    """(kernel, argument types) -> the variant units holding it. The manifest is recorded
    from the warm-up graphs in order, each entry with the node type and variant that first
    called it: a node of a recorded variant needs at most its type's entries up to the
    last one its variant called (the earlier instances' included: they may have compiled
    what it calls too), ``node.<type>@<variant>``. A variant holding every entry of its
    type is not one (the type's unit serves it)."""
    found, var = callers(), variants()
    order = [(k, t) for k, t, *_ in manifest() if (k, t) in found]
    by_type: dict[str, list] = {}
    for e in order:
        by_type.setdefault(found[e], []).append(e)
    out: dict[tuple[str, str], list[str]] = {}
    for t, entries in by_type.items():
        last = {var[e]: i for i, e in enumerate(entries) if e in var}
        for v, i in last.items():
            if i < len(entries) - 1:
                for e in entries[:i + 1]:
                    out.setdefault(e, []).append(node_unit(t, v))
    return out


def _unit_of(graph, name: str, held: set) -> str:
    """A node's precompile unit: its variant's where ``held`` (the variant units) has it,
    else its type's."""
    t = type(graph.nodes[name]).__name__
    if any(u.startswith(node_unit(t) + "@") for u in held):
        mine = node_unit(t, node_variant(graph, name))
        if mine in held:
            return mine
    return node_unit(t)


def manifest_modules(graph) -> set[str]:
    """What a graph's run precompiles: its enabled nodes' units (``node_unit``: the
    manifest entries their node types called when it was recorded, nothing else: a kernel
    module the graph imports but never calls is not compiled; a node of a variant recorded
    calling fewer, ``variant_units``, those), and the kernel modules its nodes import
    (``import_closure``, read from sources) where the manifest names no caller."""
    from proxyshade.graph.keys import import_closure

    held = {u for units in variant_units().values() for u in units}
    units = {_unit_of(graph, name, held) for name in graph.nodes if graph.enabled.get(name, True)}
    if not callers():
        for mod in {type(n).__module__ for n in graph.nodes.values()}:
            units.update(m for m in import_closure(mod) if m.startswith("proxyshade.kernels."))
    return units


class Prefetch:
    """Loads the manifest's kernels of the node types a run computes from numba's cache on a
    background thread, in the order the nodes run, while the first nodes compute (a load is
    mostly LLVM work that releases the GIL): a node then finds its kernels loaded instead of
    loading them on the run's critical path. Only where every one of those node types was
    precompiled into this version's kernel cache (loads, never compiles; a kernel missing
    from the cache compiles when first called, on the thread calling it). The kernel modules
    are imported on the calling thread (imports on two threads at once went wrong before:
    ``graph.load_array_libraries``). Loading code changes no result."""

    def __init__(self, graph, todo):
        import threading

        from proxyshade.kernels import _cache

        self.thread, self._stop = None, threading.Event()
        found, held = callers(), variant_units()
        every = {u for units in held.values() for u in units}
        try:  # the order the nodes run: the instances' DAG topologically (ties by name)
            import networkx as nx

            order = list(nx.lexicographical_topological_sort(todo, key=str))
        except Exception:  # noqa: BLE001 - not a DAG: by name
            order = sorted(todo, key=str)
        units = []  # the nodes' units, in the order the nodes run
        for name, _ in order:
            u = _unit_of(graph, name, every)
            if u not in units:
                units.append(u)
        if not found or not units or not _cache.kernels_cached(units):
            return
        rank = {u: i for i, u in enumerate(units)}
        entries = []
        for kernel, text, *_ in manifest():
            mine = [rank[u] for u in _units(kernel, text, found, held) if u in rank]
            if mine:
                entries.append((min(mine), kernel, text))
        self.jobs = []
        for _, kernel, text in sorted(entries):
            try:
                self.jobs.append((_dispatcher(kernel), parse_types(text)))
            except Exception:  # noqa: BLE001 - a stale entry: left to the call
                continue
        if self.jobs:
            self.thread = threading.Thread(target=self._load, name="proxyshade-kernels", daemon=True)
            self.thread.start()

    def _load(self) -> None:
        for disp, sig in self.jobs:
            if self._stop.is_set():
                return
            try:
                disp.compile(sig)
            except Exception:  # noqa: BLE001 - the call compiles it, or says what is wrong
                continue

    def stop(self) -> None:
        """Stop after the load under way and wait for it (before the run returns)."""
        self._stop.set()
        if self.thread is not None:
            self.thread.join()


def _units(kernel: str, text: str, found: dict, held: dict | None = None) -> list[str]:
    """The precompile units an entry belongs to: its module, its caller's node type and the
    variants of it that need it (``held``: ``variant_units()``, computed when not given)."""
    caller = found.get((kernel, text))
    held = variant_units() if held is None else held
    return [kernel.rpartition(".")[0]] + ([node_unit(caller)] if caller else []) + held.get((kernel, text), [])


def type_text(args) -> str:
    """Argument types (numba types) as the text ``parse_types`` reads back: ``repr`` of
    their tuple, a named tuple (a kernel's record, e.g. ``features.Level``) written as
    ``Named('module.Class', (field types))`` (numba's ``repr`` of it does not read back)."""
    from numba.core import types

    def text(t) -> str:
        if isinstance(t, tuple):
            return "(" + ", ".join(text(x) for x in t) + ("," if len(t) == 1 else "") + ")"
        if isinstance(t, types.BaseNamedTuple):
            cls = t.instance_class
            return f"Named({cls.__module__ + '.' + cls.__qualname__!r}, {text(tuple(t.types))})"
        if isinstance(t, types.Tuple):
            return f"Tuple({text(tuple(t.types))})"
        if isinstance(t, types.UniTuple):
            return f"UniTuple({text(t.dtype)}, {t.count})"
        return repr(t)

    return text(tuple(args))


def _named(cls: str, fields: tuple):
    """The numba type of a named tuple of class ``cls`` ('module.Class') with ``fields``."""
    import importlib

    from numba.core import types

    mod, _, name = cls.rpartition(".")
    return types.BaseTuple.from_types(list(fields), getattr(importlib.import_module(mod), name))


def parse_types(text: str) -> tuple:
    """Argument types written by ``type_text``, back to the tuple of numba types."""
    from numba.core import types

    ns = {k: getattr(types, k) for k in dir(types) if not k.startswith("_")}
    ns.update(omitted=types.Omitted, Named=_named)
    sig = eval(text, {"__builtins__": {}}, ns)  # text written by record_manifest, in the package
    if not isinstance(sig, tuple) or not all(isinstance(t, types.Type) for t in sig):
        raise ValueError(f"not a tuple of numba types: {text}")
    return sig


def _dispatcher(kernel: str):
    import importlib

    mod, _, fn = kernel.rpartition(".")
    return getattr(importlib.import_module(mod), fn)


_locked = False


def _lock_cache_writes() -> None:
    """Make numba's cache writes safe between processes: an index lists a kernel's
    signatures, and two processes adding one each to the same index at once could lose one
    (numba reads, extends and replaces the index without a lock). Each save holds an
    exclusive lock on the cache folder (POSIX ``flock``)."""
    global _locked
    if _locked:
        return
    import fcntl

    from numba.core import caching

    save = caching.IndexDataCacheFile.save

    def locked_save(self, key, data):
        fd = os.open(self._cache_path, os.O_RDONLY)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX)
            save(self, key, data)
        finally:
            os.close(fd)  # releases the lock

    caching.IndexDataCacheFile.save = locked_save
    _locked = True


def _compile_job(kernel: str, text: str) -> tuple[str, str, float, str | None]:
    """In a worker: compile one manifest entry into numba's cache."""
    t0 = time.perf_counter()
    try:
        disp = _dispatcher(kernel)
        disp.compile(parse_types(text))
    except Exception as e:  # a stale entry: the kernel compiles lazily when called
        return kernel, text, time.perf_counter() - t0, f"{type(e).__name__}: {e}"
    return kernel, text, time.perf_counter() - t0, None


def default_workers() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:
        return max(1, os.cpu_count() or 1)


def pending(modules=None) -> list[tuple[str, str, float]]:
    """The manifest's entries of the kernel modules not yet precompiled into this version's
    kernel cache (``kernels._cache.kernels_cached``), slowest first; ``modules``: only
    kernels of these ``proxyshade.kernels`` modules. Imports those kernel modules (and
    numba) only when there are some; an entry naming a kernel that is gone is skipped."""
    from proxyshade.kernels import _cache

    todo, found, held = [], callers(), variant_units()
    for kernel, text, seconds, _ in manifest():
        mine = _units(kernel, text, found, held)
        if modules is not None:
            mine = [u for u in mine if u in modules]
        if not mine or _cache.kernels_cached(mine):
            continue
        try:
            _dispatcher(kernel)
            parse_types(text)
        except Exception:
            continue  # stale: left to lazy compiles
        todo.append((kernel, text, seconds))
    todo.sort(key=lambda e: -e[2])
    return todo


def mark_precompiled(modules=None) -> None:
    """Mark ``modules`` (default: every kernel module) precompiled in this version's kernel
    cache: later runs skip the precompile (``kernels._cache.kernels_cached``)."""
    from proxyshade.kernels import _cache

    if modules is None:
        modules = set(_cache.modules()) | {node_unit(t) for t in callers().values()}
        modules |= {u for units in variant_units().values() for u in units}
    _cache.mark_precompiled(modules)


def precompile(modules=None, progress=None, workers=None) -> dict:
    """Compile the manifest's signatures of the modules not yet precompiled (``pending``) on
    ``workers`` processes (default: one per core): this one and ``workers - 1`` spawned
    ones, each taking the slowest signature left when it is free (a signature numba's cache
    holds already only loads). ``progress(done, total, kernel)`` is called as each
    finishes. Then marks ``modules`` precompiled (``mark_precompiled``; a failed signature
    compiles lazily when first called). Returns {'compiled', 'failed', 'seconds', 'workers'}."""
    import collections
    import threading

    t0 = time.perf_counter()
    todo = pending(modules)
    workers = min(workers or default_workers(), len(todo))
    if sys.platform == "win32":
        workers = min(workers, 1)  # the cache lock below is POSIX
    queue = collections.deque((kernel, text) for kernel, text, _ in todo)
    failed, done, lock = [], [0], threading.Lock()

    def finished(r):
        with lock:
            done[0] += 1
            if r[3]:
                failed.append(r)
            if progress:
                progress(done[0], len(todo), r[0])

    if progress:
        progress(0, len(todo), None)
    pool = None
    if workers > 1:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        _lock_cache_writes()  # this process writes to the cache too
        ctx = multiprocessing.get_context("spawn")  # a fresh interpreter: no forked numba/OpenMP state

        def feed(fut=None, job=None):  # one job at a time per worker, the next when it is done
            if fut is not None:
                try:
                    finished(fut.result())
                except Exception:  # a broken worker: this process takes its job and the rest
                    queue.append(job)
                    return
            try:
                job = queue.popleft()
            except IndexError:
                return
            try:
                pool.submit(_compile_job, *job).add_done_callback(lambda f, job=job: feed(f, job))
            except Exception:  # no worker (a broken pool): this process compiles it
                queue.appendleft(job)
                raise

        try:
            pool = ProcessPoolExecutor(workers - 1, mp_context=ctx, initializer=_lock_cache_writes)
            for _ in range(workers - 1):
                feed()
        except Exception:  # no processes to be had here: this one compiles everything
            workers = 1
    try:
        while True:
            try:
                job = queue.popleft()
            except IndexError:
                break
            finished(_compile_job(*job))  # in this process: its kernels need no loading after
    finally:
        if pool is not None:
            pool.shutdown(wait=True, cancel_futures=True)
    mark_precompiled(modules)
    return {"compiled": len(todo) - len(failed), "failed": failed, "seconds": time.perf_counter() - t0,
            "workers": workers}


# --- writing the manifest ---------------------------------------------------------------

_RECORD = r"""
import json, sys, time
from numba.core import event
from proxyshade.graph import warmup, warmup_graphs

class Rec(event.Listener):
    # kernels compiled from Python (no compile under way) with their seconds and what they compiled inside
    def __init__(self):
        self.stack, self.roots = [], []
    def on_start(self, ev):
        self.stack.append([time.perf_counter(), []])
    def on_end(self, ev):
        t0, inner = self.stack.pop()
        d = ev.data["dispatcher"]
        me = (f"{d.py_func.__module__}.{d.py_func.__name__}", warmup.type_text(ev.data["args"]))
        if self.stack:
            self.stack[-1][1].extend([me] + inner)
        elif me[0].startswith("proxyshade.kernels."):
            self.roots.append((me[0], me[1], round(time.perf_counter() - t0, 2),
                               sorted({x for x in inner if x[0].startswith("proxyshade.kernels.")})))

rec = Rec()
event.register("numba:compile", rec)
# the node type computing when a kernel compiles: precompile compiles a graph's node types' kernels only
from proxyshade.graph.graph import Graph
_compute, _types = Graph._compute_locked, []
def _tracked(self, plan, inst, nr, *rest):
    _types.append((type(self.nodes[inst[0]]).__name__, warmup.node_variant(self, inst[0])))
    try:
        return _compute(self, plan, inst, nr, *rest)
    finally:
        _types.pop()
Graph._compute_locked = _tracked
_on_end = Rec.on_end
def on_end(self, ev):
    n = len(self.roots)
    _on_end(self, ev)
    if len(self.roots) > n:
        self.roots[-1] = (*self.roots[-1], *(_types[-1] if _types else (None, None)))
Rec.on_end = on_end
warmup_graphs.warm_up(cache=sys.argv[1], first=False)
print(json.dumps(rec.roots))
"""


def record_manifest(raw: Path | None = None) -> list:
    """Run the warm-up graphs in a fresh process with cold numba and graph caches and list
    the kernels compiled from Python (the manifest's entries); ``raw``: a JSON file kept
    from an earlier recording (written beside it otherwise)."""
    import json
    import subprocess
    import tempfile

    if raw is not None and raw.is_file():
        roots = json.loads(raw.read_text())
    else:
        with tempfile.TemporaryDirectory() as tmp:
            env = dict(os.environ, NUMBA_CACHE_DIR=f"{tmp}/numba")
            env["PYTHONPATH"] = os.pathsep.join([str(Path(__file__).resolve().parents[2])]
                                                + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
            res = subprocess.run([sys.executable, "-c", _RECORD, f"{tmp}/cache"], env=env, capture_output=True,
                                 text=True, check=True)
        roots = json.loads(res.stdout.strip().splitlines()[-1])
        if raw is not None:
            raw.write_text(json.dumps(roots))
    for kernel, text, *_ in roots:  # every entry must read back as written
        parse_types(text)
    return roots


def write_manifest(path: Path = MANIFEST, raw: Path | None = None) -> int:
    import numba

    roots = record_manifest(raw)
    lines = ['"""Kernel signatures the demo graphs reach, for ``warmup.precompile``: written by',
             "``python -m proxyshade.graph.warmup --write-manifest`` (numba "
             f"{numba.__version__}), do not edit.",
             "(kernel, argument types, compile seconds, (kernel, argument types) compiled inside);",
             "CALLERS: the node type whose compute first called each entry (by index); VARIANTS: that",
             "node's ``warmup.node_variant``.\"\"\"",
             "ENTRIES = ["]
    for kernel, text, seconds, inner, *_ in roots:
        lines.append(f"    ({kernel!r}, {text!r}, {seconds!r}, (")
        lines.extend(f"        ({k!r}, {t!r})," for k, t in inner)
        lines.append("    )),")
    lines.append("]")
    lines.append("CALLERS = {")
    lines.extend(f"    {i}: {r[4]!r}," for i, r in enumerate(roots) if len(r) > 4 and r[4])
    lines.append("}")
    lines.append("VARIANTS = {")
    lines.extend(f"    {i}: {r[5]!r}," for i, r in enumerate(roots) if len(r) > 5 and r[5])
    lines.append("}")
    path.write_text("\n".join(lines) + "\n")
    return len(roots)


if __name__ == "__main__":
    if "--write-manifest" in sys.argv:
        i = sys.argv.index("--raw") if "--raw" in sys.argv else None
        n = write_manifest(raw=Path(sys.argv[i + 1]) if i else None)
        print(f"{MANIFEST}: {n} kernel signatures")
