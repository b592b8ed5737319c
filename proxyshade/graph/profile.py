"""Where a run's time and memory go (``proxyshade run --profile``).

``start()`` (before the run) installs timers; the engine tells the active profile when
each node instance starts and ends (``node_start``/``node_end``), the cache when it
encodes a plate (``cache_write``). ``table()`` then splits the process's wall time into:
process start and imports (before the command runs), graph load and keys, each node's
compute with what it spent importing modules, loading numba kernels from their cache
and compiling numba code (typed containers, a kernel not in the cache), the cache's
EXR writes (on the writer thread: how long it was busy, and how long the run waited
for it at the end) and the output writers. A sampler thread reads the resident set size
every few milliseconds: the node running at the peak (or the cache entry being written, or the
node that ended last), the peak during each node, the
plates held in memory at the peak (node and MiB), and what the peak holds (``peak_parts``:
mapped library files, the heap when the first node started, plates, the rest). A plate's
MiB are its resident pages (``plate_memory``): each page of its arrays counted once, for the
first plate in the run's order that holds it (a plate that shares another's arrays counts
only its own), and only pages the resident set counts (not a zero-filled page nobody wrote:
``resident_bytes``), so the plates' part of the peak is what they hold in it. With the
writers on threads of their own (``executor.SerialExecutor``) the output writes row is the
run's wait for them.

Nothing here changes a result: timers wrap numba's cache loading, its compile events and
Python's ``__import__``, only while a profile is active.
"""
from __future__ import annotations

import builtins
import heapq
import os
import sys
import threading
import time
from dataclasses import dataclass, field

ACTIVE: "Profile | None" = None
_PAGE = os.sysconf("SC_PAGE_SIZE")


def process_age() -> float:
    """Seconds since this process started (``/proc/self/stat``; 0 where there is none)."""
    try:
        with open("/proc/self/stat") as f:
            fields = f.read().rpartition(")")[2].split()
        start = int(fields[19]) / os.sysconf("SC_CLK_TCK")
        return max(0.0, time.clock_gettime(time.CLOCK_BOOTTIME) - start)
    except (OSError, ValueError, IndexError, AttributeError):
        return 0.0


def rss_mb() -> float:
    """This process's resident set size now, MiB."""
    return rss_split()[0]


def rss_split() -> tuple[float, float]:
    """(resident set size, its file-backed part: pages of mapped files, the shared
    libraries' code and data above all), MiB; the rest is anonymous memory (the heap:
    arrays, Python objects, compiled kernels)."""
    try:
        with open("/proc/self/statm") as f:
            fields = f.read().split()
        return int(fields[1]) * _PAGE / 2**20, int(fields[2]) * _PAGE / 2**20
    except (OSError, ValueError, IndexError):
        return 0.0, 0.0


# -- resident pages ----------------------------------------------------------------
# PAGEMAP_SCAN (Linux 6.7+): the pages of a range present in memory and not the zero page (a
# page read but never written maps the shared zero page, or the huge zero page, which the
# resident set does not count and /proc/self/pagemap's bits do not tell apart)
_PAGEMAP_SCAN = (3 << 30) | (96 << 16) | (ord("f") << 8) | 16  # _IOWR('f', 16, struct pm_scan_arg)
_IS_PRESENT, _IS_PFNZERO = 1 << 3, 1 << 5
_scan_state: dict = {}


def _pagemap_scan(ranges: list[tuple[int, int]]) -> list[int] | None:
    """Bytes of each page-aligned (start, end) address range of this process that are in its
    resident set, with the PAGEMAP_SCAN ioctl; None where the kernel lacks it."""
    import ctypes

    st = _scan_state
    if st.get("broken"):
        return None
    try:
        if st.get("pid") != os.getpid():  # first use, or a forked child (its own pagemap)
            st["libc"] = ctypes.CDLL(None, use_errno=True)
            st["vec"] = (ctypes.c_uint64 * (3 * 256))()  # struct page_region {start, end, categories}
            st["fd"], st["pid"] = os.open("/proc/self/pagemap", os.O_RDONLY), os.getpid()
        libc, vec, fd = st["libc"], st["vec"], st["fd"]
        out = []
        for lo, hi in ranges:
            n, start = 0, lo
            while start < hi:
                # struct pm_scan_arg: size, flags, start, end, walk_end, vec, vec_len, max_pages,
                # category_inverted, category_mask, category_anyof_mask, return_mask
                arg = (ctypes.c_uint64 * 12)(96, 0, start, hi, 0, ctypes.addressof(vec), 256, 0, _IS_PFNZERO,
                                             _IS_PRESENT | _IS_PFNZERO, 0, _IS_PRESENT)
                got = libc.ioctl(fd, ctypes.c_ulong(_PAGEMAP_SCAN), ctypes.byref(arg))
                if got < 0:
                    raise OSError(ctypes.get_errno(), "PAGEMAP_SCAN")
                n += sum(vec[3 * i + 1] - vec[3 * i] for i in range(got))
                if arg[4] <= start:
                    break
                start = arg[4]  # walk_end: where the walk stopped (the regions' vector was full)
            out.append(n)
        return out
    except (OSError, AttributeError):
        st["broken"] = True
        return None


def _pagemap_bits(ranges: list[tuple[int, int]]) -> list[int] | None:
    """As ``_pagemap_scan`` from /proc/self/pagemap's bits (older kernels): a page present
    and mapped by this process alone or from a file; a read-only huge zero page counts."""
    try:
        import numpy

        out = []
        with open("/proc/self/pagemap", "rb", buffering=0) as f:
            for lo, hi in ranges:
                words = numpy.frombuffer(os.pread(f.fileno(), 8 * ((hi - lo) // _PAGE), 8 * (lo // _PAGE)), numpy.uint64)
                present = (words >> numpy.uint64(63)) & numpy.uint64(1)
                mine = ((words >> numpy.uint64(56)) | (words >> numpy.uint64(61))) & numpy.uint64(1)
                out.append(int((present & mine).sum()) * _PAGE)
        return out
    except (OSError, ImportError, ValueError):
        return None


def resident_bytes(ranges: list[tuple[int, int]]) -> list[int] | None:
    """Bytes of each (start, end) address range (page-aligned) in this process's resident
    set: pages present, the zero page left out; None where neither the kernel's
    PAGEMAP_SCAN nor /proc/self/pagemap can tell."""
    out = _pagemap_scan(ranges)
    return out if out is not None else _pagemap_bits(ranges)


def _owned_ranges(plates: list[tuple[str, list]]) -> list[tuple[int, int, int]]:
    """(start, end, index of the plate) page ranges: the pages of each plate's arrays, each
    page given to the first plate (in ``plates``' order) whose arrays cover it."""
    import numpy

    bounds = getattr(getattr(numpy, "lib", None), "array_utils", None)
    byte_bounds = bounds.byte_bounds if bounds is not None else numpy.byte_bounds
    spans = []
    for i, (_, arrays) in enumerate(plates):
        for a in arrays:
            if a.nbytes:
                lo, hi = byte_bounds(a)
                spans.append((lo // _PAGE * _PAGE, -(-hi // _PAGE) * _PAGE, i))
    cuts = sorted({x for lo, hi, _ in spans for x in (lo, hi)})
    spans.sort()
    out: list[list[int]] = []
    active: list[tuple[int, int]] = []  # heap of (plate index, end)
    k = 0
    for a, b in zip(cuts, cuts[1:]):
        while k < len(spans) and spans[k][0] <= a:
            heapq.heappush(active, (spans[k][2], spans[k][1]))
            k += 1
        while active and active[0][1] <= a:
            heapq.heappop(active)
        if not active:
            continue
        owner = active[0][0]
        if out and out[-1][1] == a and out[-1][2] == owner:
            out[-1][1] = b
        else:
            out.append([a, b, owner])
    return [tuple(r) for r in out]


def plate_memory(plates: list[tuple[str, object]]) -> list[tuple[str, float, float]]:
    """(name, resident MiB, allocated MiB) of each (name, Plate): the pages of its arrays not
    already counted for a plate before it (arrays shared between plates, views of one
    buffer: counted once), resident ones (``resident_bytes``; allocated where that cannot be
    told) and all of them."""
    plates = [(n, [a for a in pl.channels.values() if hasattr(a, "__array_interface__")]) for n, pl in plates]
    owned = _owned_ranges(plates)
    res = resident_bytes([(lo, hi) for lo, hi, _ in owned])
    per = [[0, 0] for _ in plates]
    for j, (lo, hi, i) in enumerate(owned):
        per[i][1] += hi - lo
        per[i][0] += res[j] if res is not None else hi - lo
    return [(n, r / 2**20, a / 2**20) for (n, _), (r, a) in zip(plates, per)]


@dataclass
class NodeTimes:
    node: str
    frame: int
    seconds: float = 0.0
    imports: float = 0.0
    kernel_load: float = 0.0
    kernel_compile: float = 0.0
    cache_write: float = 0.0  # the writer thread's time for this node's plate
    rss_before: float = 0.0
    rss_peak: float = 0.0
    sink: bool = False
    anon_before: float = 0.0  # anonymous MiB when it started
    held_before: float = 0.0  # MiB of plates in the run's memory when it started


@dataclass
class Profile:
    t0: float = field(default_factory=time.perf_counter)
    before_command: float = 0.0  # process start to the command's start (interpreter, imports)
    plan_s: float = 0.0  # graph load, keys, plan (set by the caller)
    flush_wait: float = 0.0  # the run waiting for the cache writer at its end
    writes_beside: bool = False  # the writers ran on a thread of their own (executor.SerialExecutor)
    write_wait: float = 0.0  # ... and the run waited for them this long
    release_wait: float = 0.0  # nodes waiting for a released input's cache write (Context.release)
    precompile_s: float = 0.0  # the first run's kernel precompile (warmup.precompile), imports in it included
    nodes: dict = field(default_factory=dict)  # (node, frame) -> NodeTimes
    outside: NodeTimes = field(default_factory=lambda: NodeTimes("(outside nodes)", 0))
    peak_mb: float = 0.0
    peak_node: str = ""
    peak_held: list = field(default_factory=list)  # (node, resident MiB, allocated MiB) of plates in memory at the peak
    peak_file: float = 0.0  # MiB of the peak resident set that are mapped files (libraries)
    peak_started: "NodeTimes | None" = None  # the node computing at the peak that started first
    start_anon: float = 0.0  # anonymous MiB when the first node started (libraries, modules loaded)
    memory_of: object = None  # () -> [(node, resident MiB, allocated MiB)]: plates in memory now (``watch``)
    held_cost: float = 0.0  # seconds the sampler spent measuring the plates (off the run's threads)

    def __post_init__(self):
        self._local = threading.local()
        self._lock = threading.Lock()
        self._running: dict[int, NodeTimes] = {}  # thread id -> the node it computes
        self._writing: dict[int, str] = {}  # thread id -> 'node@frame' whose cache entry it encodes
        self._last = ""  # the node that ended last: the peak between nodes is named after it
        self._stop = threading.Event()

    # -- attribution ---------------------------------------------------------
    def add(self, what: str, seconds: float) -> None:
        nt = self._running.get(threading.get_ident())
        if nt is None:
            if threading.current_thread() is not threading.main_thread():
                return  # a helper thread (the precompile's): not on the run's path
            nt = self.outside
        with self._lock:
            setattr(nt, what, getattr(nt, what) + seconds)

    def watch(self, graph, plan) -> None:
        """The first node of a run: the time since the profile started is the graph's load
        and plan; the plates of ``graph``'s cache memory are named by ``plan``'s nodes."""
        if self.memory_of is not None:
            return
        self.plan_s = time.perf_counter() - self.t0
        r, f = rss_split()
        self.start_anon = r - f
        names = {k: f"{n}@{f}" for (n, f), k in plan.keys.items()}
        rank = {k: i for i, k in enumerate(plan.keys.values())}  # the plan's (topological) order

        def held():
            plates = sorted(list(graph.cache.memory.items()), key=lambda kv: rank.get(kv[0], len(rank)))
            return plate_memory([(names.get(k, k[:8]), pl) for k, pl in plates])

        self.memory_of = held

    def node_start(self, node: str, frame: int, sink: bool) -> None:
        nt = self.nodes.setdefault((node, frame), NodeTimes(node, frame, sink=sink))
        r, f = rss_split()
        nt.rss_before, nt.anon_before = r, r - f
        nt.rss_peak = max(nt.rss_peak, nt.rss_before)
        try:
            nt.held_before = sum(mb for _, mb, _ in self.memory_of()) if self.memory_of is not None else 0.0
        except RuntimeError:  # the dict changed size while read
            nt.held_before = 0.0
        self._running[threading.get_ident()] = nt

    def node_end(self, node: str, frame: int, seconds: float) -> None:
        nt = self._running.pop(threading.get_ident(), None)
        self._last = f"{node}@{frame}"
        if nt is not None:
            nt.seconds += seconds
            nt.rss_peak = max(nt.rss_peak, rss_mb())

    def cache_write_start(self, node: str, frame) -> None:
        """The cache's writer thread starts encoding ``node@frame``'s entry."""
        self._writing[threading.get_ident()] = f"{node}@{frame}"

    def cache_write(self, node: str, frame, seconds: float) -> None:
        self._writing.pop(threading.get_ident(), None)
        nt = self.nodes.get((node, frame))
        with self._lock:
            (nt or self.outside).cache_write += seconds

    # -- sampling ------------------------------------------------------------
    def _sample(self) -> None:
        while not self._stop.wait(0.005):
            r, f = rss_split()
            for nt in list(self._running.values()):
                nt.rss_peak = max(nt.rss_peak, r)
            if r > self.peak_mb:
                self.peak_mb, self.peak_file = r, f
                running = list(self._running.values())
                self.peak_started = min(running, key=lambda nt: nt.anon_before, default=None)
                busy = [f"{nt.node}@{nt.frame}" for nt in running]
                busy += [f"{w}(cache-write)" for w in list(self._writing.values())]  # after the last node: the flush
                self.peak_node = ", ".join(busy) or (f"(after {self._last})" if self._last else "(before the nodes)")
                if self.memory_of is not None:
                    t = time.perf_counter()
                    try:
                        self.peak_held = self.memory_of()
                    except RuntimeError:  # the dict changed size while read: the next sample
                        pass
                    self.held_cost += time.perf_counter() - t

    # -- report --------------------------------------------------------------
    def rows(self, wall: float) -> list[tuple[str, float, str]]:
        """(phase, seconds, note) rows; ``wall``: the command's time so far since process start."""
        before = self.outside.imports + self.outside.kernel_compile + self.outside.kernel_load - self.precompile_s
        out = [("process start + imports", self.before_command, "interpreter, CLI and engine modules")]
        if self.precompile_s:
            out.append(("kernel precompile", self.precompile_s, "first run after an install: the graph's kernels "
                                                                "compiled into numba's cache"))
        out += [
               ("imports before the nodes", max(0.0, before), "numba, OpenEXR, USD: loaded once a node is to compute"),
               ("graph load + keys", max(0.0, self.plan_s - max(0.0, before) - self.precompile_s),
                "YAML, variables, code hashes, cache lookups, USD plugins")]
        comp = lambda nt: nt.seconds - nt.imports - nt.kernel_load - nt.kernel_compile  # noqa: E731
        # writers beside the nodes: their whole time is the writer thread's, off the run's path
        path = [nt for nt in self.nodes.values() if not (self.writes_beside and nt.sink)]
        imports = sum(nt.imports for nt in path)
        load = sum(nt.kernel_load for nt in path)
        compile_ = sum(nt.kernel_compile for nt in path)
        out.append(("imports in nodes", imports, "modules a node loads on first use (USD, synthesis, colour-science for grading)"))
        out.append(("kernel loading", load, "numba cache loads of the kernels called"))
        if compile_ or self.outside.kernel_compile:
            out.append(("numba compiling", compile_, "code numba compiles at run time (not in its cache)"))
        for nt in self.nodes.values():
            if not nt.sink:
                out.append((f"  {nt.node}@{nt.frame}", comp(nt), f"compute (its cache write {nt.cache_write:.2f} s, "
                                                                 "writer thread)"))
        sinks = [nt for nt in self.nodes.values() if nt.sink]
        names = ", ".join(nt.node for nt in sinks)
        if self.writes_beside:
            out.append(("output writes (waited)", self.write_wait, f"{names}: the writer thread was busy "
                        f"{sum(nt.seconds for nt in sinks):.2f} s, beside the nodes"))
        else:
            out.append(("output writes", sum(comp(nt) for nt in sinks), names))
        busy = sum(nt.cache_write for nt in self.nodes.values()) + self.outside.cache_write
        out.append(("cache writes (waited)", self.flush_wait, f"the writer thread was busy {busy:.2f} s, beside the nodes"
                    + (f"; nodes waited {self.release_wait:.2f} s (in their compute) for a released input's write"
                       if self.release_wait else "")))
        accounted = sum(s for name, s, _ in out if not name.startswith("  ") and name != "cache writes (waited)")
        accounted += sum(s for name, s, _ in out if name.startswith("  ")) + self.flush_wait
        out.append(("rest", max(0.0, wall - accounted), "scheduling, report, cache bookkeeping"))
        out.append(("total", wall, "process start to the report"))
        return out

    def memory_rows(self) -> list[tuple[str, float, float, float]]:
        """(node@frame, RSS before, peak RSS during, plates resident when it started) in the order they ran."""
        return [(f"{nt.node}@{nt.frame}", nt.rss_before, nt.rss_peak, nt.held_before) for nt in self.nodes.values()]

    def text(self) -> str:
        wall = process_age() or (time.perf_counter() - self.t0 + self.before_command)
        lines = ["profile (seconds, wall of this process):"]
        for name, s, note in self.rows(wall):
            lines.append(f"  {name:<26} {s:7.3f}  {note}")
        lines.append("memory (MiB, resident): node, before, peak during, plates held at its start")
        for name, before, peak, plates in self.memory_rows():
            lines.append(f"  {name:<26} {before:7.0f} {peak:7.0f} {plates:7.0f}")
        lines.append(self.peak_text())
        return "\n".join(lines)

    def peak_parts(self) -> list[tuple[str, float]]:
        """What the peak resident set held, MiB: the mapped files (shared libraries), the
        anonymous memory already there when the first node started (modules and libraries
        loaded), the plates in the run's memory, what stayed loaded between the first node
        and the start of the node computing at the peak (kernels, modules, the memo, the
        allocator's free lists: its anonymous memory then less the plates held then), and
        the rest: that node's working arrays (with the writers' beside it)."""
        plates = sum(mb for _, mb, _ in self.peak_held)
        nt = self.peak_started
        since = max(0.0, nt.anon_before - self.start_anon - nt.held_before) if nt is not None else 0.0
        rest = self.peak_mb - self.peak_file - self.start_anon - plates - since
        return [("libraries (mapped files)", self.peak_file), ("heap before the first node", self.start_anon),
                ("plates held", plates), ("loaded since (kernels, modules)", since),
                (f"working memory of {nt.node}@{nt.frame}" if nt is not None else "working memory", rest)]

    @staticmethod
    def libraries(top: int = 6) -> list[tuple[str, float]]:
        """The mapped files resident now, MiB, by package (the folder under site-packages,
        else the file's name), largest first: ``top`` of them and the rest as 'other'."""
        sizes: dict[str, float] = {}
        name = None
        try:
            with open("/proc/self/smaps") as f:
                for line in f:
                    if line[0] in "0123456789abcdef" and "-" in line.split(" ", 1)[0]:
                        parts = line.split(None, 5)
                        path = parts[5].strip() if len(parts) > 5 else ""
                        if not path.startswith("/"):
                            name = None
                            continue
                        pkg = path.partition("site-packages/")[2].split("/", 1)[0] if "site-packages/" in path else ""
                        name = pkg.split(".libs")[0] or os.path.basename(path).split(".so")[0]
                    elif name is not None and line.startswith("Rss:"):
                        sizes[name] = sizes.get(name, 0.0) + int(line.split()[1]) / 1024.0
        except OSError:
            return []
        ranked = sorted(sizes.items(), key=lambda kv: -kv[1])
        return ranked[:top] + ([("other", sum(mb for _, mb in ranked[top:]))] if len(ranked) > top else [])

    def peak_text(self) -> str:
        held = sorted(self.peak_held, key=lambda x: -x[1])
        parts = ", ".join(f"{name} {mb:.0f}" for name, mb in self.peak_parts())
        libs = ", ".join(f"{n} {mb:.0f}" for n, mb in self.libraries())
        return (f"  peak {self.peak_mb:.0f} MiB while {self.peak_node}; plates held then (MiB resident, a page "
                "shared by plates counted once, for the first; allocated): "
                + (", ".join(f"{n} {mb:.0f} ({al:.0f})" for n, mb, al in held) or "none")
                + f" (= {sum(mb for _, mb, _ in held):.0f} MiB resident of {sum(al for _, _, al in held):.0f})"
                + f"\n  the peak holds: {parts} MiB (plates measured in {self.held_cost:.2f} s, sampler thread)"
                + (f"\n  mapped files at the end, by package: {libs} MiB" if libs else ""))

    def stop(self) -> None:
        self._stop.set()


# -- timers ----------------------------------------------------------------------
_orig_import = builtins.__import__
_depth = threading.local()


def _timed_import(name, globals=None, locals=None, fromlist=(), level=0):
    p = ACTIVE
    if p is None or getattr(_depth, "n", 0):
        return _orig_import(name, globals, locals, fromlist, level)
    if level == 0 and name in sys.modules and not fromlist:
        return _orig_import(name, globals, locals, fromlist, level)
    _depth.n = 1
    t = time.perf_counter()
    try:
        return _orig_import(name, globals, locals, fromlist, level)
    finally:
        _depth.n = 0
        p.add("imports", time.perf_counter() - t)


def _install_numba_timers(p: Profile) -> None:
    """Time numba's cache loads (``Cache.load_overload``) and its compiles (the
    ``numba:compile`` event, outermost only) on every thread."""
    from numba.core import caching, event

    if not getattr(caching.Cache.load_overload, "_profiled", False):
        orig = caching.Cache.load_overload

        def load_overload(self, *a, **k):
            t = time.perf_counter()
            try:
                return orig(self, *a, **k)
            finally:
                if ACTIVE is not None:
                    ACTIVE.add("kernel_load", time.perf_counter() - t)

        load_overload._profiled = True
        caching.Cache.load_overload = load_overload

    class Compiles(event.Listener):
        def __init__(self):
            self.depth = threading.local()

        def on_start(self, ev):
            d = getattr(self.depth, "n", 0)
            self.depth.n = d + 1
            if d == 0:
                self.depth.t = time.perf_counter()

        def on_end(self, ev):
            self.depth.n -= 1
            if self.depth.n == 0 and ACTIVE is not None:
                ACTIVE.add("kernel_compile", time.perf_counter() - self.depth.t)

    event.register("numba:compile", Compiles())


def start() -> Profile:
    """Start profiling this process's run (``ACTIVE``); imports numba."""
    global ACTIVE
    p = Profile(before_command=process_age())
    ACTIVE = p
    builtins.__import__ = _timed_import
    _install_numba_timers(p)
    from proxyshade.graph import warmup

    if not getattr(warmup.precompile, "_profiled", False):
        orig = warmup.precompile

        def precompile(*a, **k):
            t = time.perf_counter()
            try:
                return orig(*a, **k)
            finally:
                if ACTIVE is not None:
                    ACTIVE.precompile_s += time.perf_counter() - t

        precompile._profiled = True
        warmup.precompile = precompile
    threading.Thread(target=p._sample, name="proxyshade-profile", daemon=True).start()
    return p


def finish() -> Profile | None:
    """Stop the active profile and return it."""
    global ACTIVE
    p, ACTIVE = ACTIVE, None
    builtins.__import__ = _orig_import
    if p is not None:
        p.stop()
    return p
