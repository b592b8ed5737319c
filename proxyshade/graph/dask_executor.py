"""Run graphs on Dask's distributed scheduler: instances (node x frame) of one or several
graphs (shots, variants) as tasks on worker processes sharing one cache folder.

    with DaskExecutor() as ex:                      # a LocalCluster on loopback, closed at the end
        report = graph.run(executor=ex)
    with DaskExecutor("tcp://farm:8786") as ex:     # a running scheduler
        reports = run_graphs([(shot_a, None), (shot_b, None)], executor=ex)   # graph.shots.run_graphs

Every instance the cache lacks is one task whose Dask key is ``proxyshade-<cache key>``,
depending on the tasks of the instances it reads: what needs the previous frame waits for
it, everything else (proxy renders of all frames, independent shots) spreads over the
workers; independent shots each prefer one worker, shots sharing keys the same one
(``_homes``). The scheduler runs a key once however many graphs or clients (other runs on
the same scheduler) submit it: the others wait for it. Plates never travel through Dask: a
task reads its inputs from its worker's memory or the cache, writes its entry to the cache
before it ends and returns a small record (its row of the report, warnings, the worker's
peak memory), so the cache folder must be one folder for every worker (a shared
filesystem on a farm). A worker plugin (``Preload``) loads the native libraries on each
worker's main thread before its first task, as ``graph.load_native_libraries`` does for a
local run.

A worker that dies mid-task leaves at most a temporary (removed once its process is gone)
and never an entry (entries are renamed into place, the record last, first writer wins);
the scheduler runs the task again on another worker. An input found missing or corrupt by
a task is computed under a Dask lock named by its key, so two workers never compute it
together (the second loads the first's result).

``--scheduler``'s address is checked first (``probe_scheduler``): something other than a
Dask scheduler listening there is a one-line error within the connect timeout.

Dask is an optional extra: without it, ``DaskExecutor`` raises a one-line ``UserError``
naming ``pip install 'proxyshade[dask]'``.
"""
from __future__ import annotations

import collections
import contextlib
import dataclasses
import functools
import logging
import os
import resource
import socket
import struct
import threading
import time
import uuid
import warnings

import networkx as nx

from proxyshade.errors import UserError

EXTRA = "pip install 'proxyshade[dask]'"

try:  # the worker plugin's base class (``Preload``); without Dask, DaskExecutor names the extra
    from distributed import WorkerPlugin as _PluginBase
except ImportError:
    _PluginBase = object


def _distributed():
    """The ``distributed`` module, or a one-line error naming the extra to install."""
    try:
        import distributed
    except ImportError as e:
        raise UserError(f"--executor dask needs Dask's distributed scheduler, which is not installed ({e}); "
                        f"install the extra: {EXTRA}") from None
    return distributed


# a LocalCluster's housekeeping, made rarer: by default each worker samples its threads' stacks
# every 10 ms (the dashboard's profile), every server runs an event-loop watchdog every 20 ms and
# reads psutil every 500 ms; together about 5 % of a core while the cluster is idle
LOCAL_CONFIG = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
    "distributed.worker.memory.monitor-interval": "1s",
    # Dask's nanny sets MALLOC_TRIM_THRESHOLD_=65536 in its workers' environment (so that freed
    # memory goes back to the system at once): glibc then maps every array over 128 KiB afresh
    # and unmaps it when freed, and the kernel zeroes its pages again on each use. With numpy's
    # temporaries that was 9x the page faults of a local run (1.5 M vs 0.17 M, 3.5 vs 1.0 CPU s
    # of system time, 4 shots at 256 wide); without it a worker allocates like a local run
    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
}
# the module the forkserver of a LocalCluster's workers imports before it forks them
# (``load_worker_image``); the environment variables it is loaded under, by their prefixes
IMAGE_MODULE = "proxyshade.graph.worker_image"
IMAGE_ENV = ("PROXYSHADE_", "NUMBA_", "OMP_", "MKL_", "OPENBLAS_", "MALLOC_", "PXR_", "OPENIMAGEIO_", "OPENEXR_",
             "DASK_", "PYTHONHASHSEED", "XDG_CACHE_HOME", "HOME", "PATH", "LD_")
_IMAGE: dict = {}  # the forkserver this process started: "env" it started with, "users" (open clusters)


def _first_line(e: BaseException) -> str:
    text = str(e).strip()
    return text.splitlines()[0][:200] if text else type(e).__name__


def _connect_timeout() -> float:
    """Dask's connect timeout in seconds (``distributed.comm.timeouts.connect``, 30 s by default)."""
    import dask
    from dask.utils import parse_timedelta

    return float(parse_timedelta(dask.config.get("distributed.comm.timeouts.connect"), default="seconds"))


def _recv(sock: socket.socket, n: int, deadline: float) -> bytes:
    """Exactly ``n`` bytes before ``deadline`` (``time.monotonic``): TimeoutError, or EOFError
    when the peer closes first."""
    buf = bytearray()
    while len(buf) < n:
        left = deadline - time.monotonic()
        if left <= 0:
            raise TimeoutError
        sock.settimeout(left)
        try:
            chunk = sock.recv(n - len(buf))
        except socket.timeout:
            raise TimeoutError from None
        if not chunk:
            raise EOFError(bytes(buf))
        buf += chunk
    return bytes(buf)


def probe_scheduler(address: str, timeout: float) -> None:
    """Check that ``address`` (tcp://host:port) is a Dask scheduler before Dask's client
    connects to it: a scheduler greets first, with a small handshake frame (its Python and
    compression options). Anything else listening there (a service that speaks first, like
    SSH, would make the client allocate whatever length its first 8 bytes spell; one that
    waits, like HTTP, would leave it waiting for ever) is a one-line ``UserError`` within
    ``timeout`` seconds. The scheduler's handshake is echoed back, so it sees a client that
    came and left. Other schemes (tls://, ucx://) are left to Dask."""
    from distributed.comm.addressing import parse_address, parse_host_port

    def refuse(why: str, fix: str = "give the address the scheduler printed when it started "
                                   "(dask scheduler: 'Scheduler at: tcp://host:8786')"):
        return UserError(f"--scheduler {address}: not a Dask scheduler at {address} ({why}); {fix}")

    try:
        scheme, loc = parse_address(address, strict=False)
        if scheme != "tcp":
            return
        host, port = parse_host_port(loc)
    except (ValueError, TypeError) as e:
        raise UserError(f"--scheduler {address}: not a scheduler address ({_first_line(e)}); "
                        "give one like tcp://host:8786") from None
    deadline = time.monotonic() + timeout
    try:
        sock = socket.create_connection((host, port), timeout=timeout)
    except OSError as e:
        raise UserError(f"--scheduler {address}: cannot connect ({_first_line(e)}); "
                        "start one (dask scheduler) and give its address, e.g. tcp://host:8786") from None
    with sock:
        try:
            head = _recv(sock, 8, deadline)
            (size,) = struct.unpack("Q", head)  # the byte count of the frames that follow (distributed.comm.tcp)
            if not 0 < size <= 1 << 16:
                with contextlib.suppress(OSError, TimeoutError, EOFError):
                    head += _recv(sock, 16, min(deadline, time.monotonic() + 0.2))
                raise refuse(f"it sent {head[:24]!r}, not Dask's handshake")
            body = _recv(sock, size, deadline)
        except TimeoutError:
            raise refuse(f"no Dask handshake within {timeout:g} s (distributed.comm.timeouts.connect)") from None
        except EOFError as e:
            raise refuse(f"it closed the connection after {e.args[0][:24]!r}") from None
        except OSError as e:
            raise refuse(f"reading its greeting failed: {_first_line(e)}") from None
        try:
            from distributed.protocol import loads
            from distributed.protocol.utils import unpack_frames

            msg = loads(unpack_frames(body))
        except Exception:  # noqa: BLE001 - any undecodable greeting
            msg = None
        if not (isinstance(msg, dict) and "compression" in msg and "python" in msg):
            raise refuse(f"it sent {(head + body)[:24]!r}, not Dask's handshake")
        with contextlib.suppress(OSError):
            sock.sendall(head + body)


class _SameKeyFilter(logging.Filter):
    """The scheduler warns when a key is submitted again with other dependencies; for
    proxyshade keys that is two runs on one scheduler that found different parts of the
    cache done when they planned, and the key's result is the same: not a problem."""

    def filter(self, record: logging.LogRecord) -> bool:
        msg = record.getMessage()
        return not (msg.startswith("Detected different `run_spec`") and "proxyshade-" in msg)


class DaskExecutor:
    """Runs prepared runs (``graph.RunJob``) on Dask workers.

    ``scheduler``: the address of a running scheduler (``tcp://host:8786``); None starts a
    ``LocalCluster`` of ``workers`` processes (default: one per core) on 127.0.0.1 with
    random ports (the scheduler's HTTP server too: distributed starts it even without a
    dashboard, on port 8787 of every interface unless told), closed by ``close``. On a local cluster, a run's
    ``threads`` of 0 becomes cores // workers numba threads per task (each worker computes
    one task at a time); on a scheduler of one's own, 0 keeps every thread numba has on the
    worker."""

    distributed = True

    def __init__(self, scheduler: str | None = None, workers: int | None = None):
        self.scheduler = scheduler
        self.workers = max(1, workers or os.cpu_count() or 1)
        self._client = None
        self.cluster = None
        self._starting: threading.Thread | None = None  # a LocalCluster starting (``start``)
        self._start_error: BaseException | None = None
        self.records: list[dict] = []  # the last run_jobs' task records (worker, pid, start, end, seconds)
        self._plugins: set[str] = set()  # worker plugins registered on the scheduler
        self._forked = False  # this executor's LocalCluster forks its workers (``_start_method``)

    def __enter__(self) -> "DaskExecutor":
        self.start(wait=False)
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @property
    def client(self):
        """Dask's client (once the cluster has started: ``start``), or None before ``start``."""
        self._wait()
        return self._client

    def start(self, wait: bool = True) -> None:
        """Connect to the scheduler, or start the LocalCluster: on a thread of its own with
        ``wait`` False (``with DaskExecutor()``), so that the run plans meanwhile (its
        workers' forkserver loads the libraries on the other core); the first use of
        ``client`` waits for it."""
        if self._client is not None or self._starting is not None:
            if wait:
                self._wait()
            return
        d = _distributed()
        logging.getLogger("distributed.scheduler").addFilter(_SameKeyFilter())
        if self.scheduler:
            timeout = _connect_timeout()
            probe_scheduler(self.scheduler, timeout)
            try:
                self._client = d.Client(self.scheduler, timeout=timeout)
            except (OSError, TimeoutError, ValueError) as e:
                raise UserError(f"--scheduler {self.scheduler}: cannot connect ({_first_line(e)}); "
                                "start one (dask scheduler) and give its address, e.g. tcp://host:8786") from None
            return
        self._starting = threading.Thread(target=self._start_local, name="proxyshade-dask-start", daemon=True)
        self._starting.start()
        if wait:
            self._wait()

    def _start_local(self) -> None:
        import dask

        d = _distributed()
        try:
            method = _start_method()
            self._forked = method == "forkserver"
            with dask.config.set(LOCAL_CONFIG):  # the nannies hand it to the workers they start (and restart)
                with dask.config.set({"distributed.worker.multiprocessing-method": method}):
                    self.cluster = d.LocalCluster(n_workers=self.workers, threads_per_worker=1, processes=True,
                                                  host="127.0.0.1", scheduler_port=0,
                                                  dashboard_address="127.0.0.1:0", silence_logs=logging.CRITICAL)
            self._client = d.Client(self.cluster)
            with _GUARD:
                if self._forked and _IMAGE["env"] is None:
                    _IMAGE["env"] = _image_env()
        except BaseException as e:  # noqa: BLE001 - raised where the client is first needed
            self._start_error = e
            self._close()

    def _wait(self) -> None:
        """Wait for a LocalCluster starting; raise what stopped it."""
        if self._starting is not None:
            self._starting.join()
            self._starting = None
        if self._start_error is not None:
            e, self._start_error = self._start_error, None
            raise e

    def close(self) -> None:
        if self._starting is not None:
            self._starting.join()
            self._starting = None
        self._close()

    def _close(self) -> None:
        if self._client is not None:
            self._client.close()
            self._client = None
        if self.cluster is not None:
            self.cluster.close()
            self.cluster = None
        if self._forked:
            self._forked = False
            _release_image()

    @property
    def address(self) -> str:
        client = self.client
        return client.scheduler.address if client is not None else str(self.scheduler)

    def run_jobs(self, jobs) -> None:
        """Submit every job's instances to compute, wait for all, fill the jobs' rows (a
        failure cancels the rest and is raised here)."""
        self.start()
        d = _distributed()
        client = self.client
        futures: dict[str, object] = {}  # Dask key -> future, once per key over every job
        dkeys: dict[str, str] = {}  # cache key -> its Dask key in this run
        # a scheduler other runs may submit to (_dask_key); a LocalCluster this executor started
        # serves this run alone: its tasks take no lock
        shared = self.cluster is None
        owners: dict[str, list] = collections.defaultdict(list)  # cache key -> [(job, instance)]
        plans = []
        self._preload(jobs)
        home = self._homes(jobs)
        # each shot on a worker of its own: a frame's instances as one task (_groups)
        multi = _shared_keys(jobs) if home and not shared else None
        for n, job in enumerate(jobs):
            plan = job.plan
            if self.cluster is not None and plan.threads == 0:
                plan.threads = max(1, (os.cpu_count() or 1) // self.workers)
            job.token = uuid.uuid4().hex
            job.workers = collections.Counter()  # worker -> instances of this job it computed
            if not len(job.todo):
                continue
            shipped = dataclasses.replace(plan, rows={})  # the rows are the client's report
            plans.append(client.scatter(shipped, broadcast=True, hash=False))
            order = list(nx.lexicographical_topological_sort(job.todo, key=str))
            group = _groups(job, order, multi) if multi is not None else {inst: inst for inst in order}
            members: dict = collections.defaultdict(list)  # the task's first instance -> its instances, in order
            tasks = nx.DiGraph()  # the tasks, each waiting for those of its instances' inputs
            for inst in order:
                members[group[inst]].append(inst)
                tasks.add_node(group[inst])
                tasks.add_edges_from((group[p], group[inst]) for p in job.todo.predecessors(inst) if group[p] != group[inst])
                owners[plan.keys[inst]].append((job, inst))
                job.hooks.start(job.runs[inst])
            for head in nx.lexicographical_topological_sort(tasks, key=str):
                insts = members[head]
                ck = plan.keys[head]
                if ck in dkeys:  # a key another job submitted (shared keys are groups of one)
                    continue
                inside = set(insts)
                deps = list(dict.fromkeys(futures[dkeys[plan.keys[group[p]]]] for inst in insts
                                          for p in job.todo.predecessors(inst) if p not in inside))
                # a plate kept in memory only (Node.stored False) when every reader is in the group
                memory = [i for i in insts if not _stored_type(job.graph, i[0])
                          and all(s in inside for s in job.todo.successors(i))]
                dkeys[ck] = _dask_key(ck, [f.key for f in deps] if shared else ())
                futures[dkeys[ck]] = client.submit(_task, plans[-1], job.token, insts,
                                                   [i[0] in plan.force for i in insts], memory, shared, *deps,
                                                   key=dkeys[ck], pure=False, priority=len(jobs) - n,
                                                   **home.get(id(job), {}))
        by_token = {job.token: job for job in jobs}
        self.records = []
        t0 = time.time()
        try:
            # this client's loop: as_completed's default is the process's default client's, another
            # executor's where several run at once (the farm bench's clients: some waited for ever)
            for fut in d.as_completed(list(futures.values()), loop=client.loop):
                for res in fut.result():  # re-raises the task's error
                    self.records.append(dict(res, key=fut.key))
                    for job, inst in owners[res["cache_key"]]:
                        _apply(job, inst, res, by_token)
        except BaseException:
            client.cancel(list(futures.values()))
            raise
        finally:
            for f in [*futures.values(), *plans]:
                f.release()  # the scheduler forgets them once no run wants them
        busy = [n for n in (self.busy(time.time() - t0), self.cpu()) if n]
        for job in jobs:
            if job.workers:
                job.notes.append(f"computed on Dask ({self.address}): "
                                 + ", ".join(f"{n} on {w}" for w, n in sorted(job.workers.items())))
                job.notes += busy
                busy = []  # once per run (its first graph with work)
            job.cleaned += job.graph.cache.remove_stale_temps()  # of workers lost mid-write

    def busy(self, span: float) -> str:
        """How busy each worker was during the run's ``span`` seconds (its tasks' time from
        start to end, over the last ``run_jobs``' records): 'workers busy 81 % of 12.3 s:
        tcp://...:1 10.9 s, tcp://...:2 9.1 s'; '' without records."""
        per: dict[str, float] = collections.defaultdict(float)
        for r in self.records:
            per[r["worker"]] += r["end"] - r["start"]
        if not per or span <= 0:
            return ""
        share = sum(per.values()) / (span * len(per))
        return (f"workers busy {share:.0%} of {span:.1f} s: "
                + ", ".join(f"{w} {t:.1f} s" for w, t in sorted(per.items())))

    def cpu(self) -> str:
        """Where the workers' CPU went over the last ``run_jobs`` (process CPU seconds, every
        thread, from its records): 'workers' CPU 44.7 s to their last task's end: tasks 43.5 s
        (compute 37.1, cache reads 0.9, cache writes 5.5), before their first task 0.4,
        between tasks 0.8'; '' without records. Before the first task: what a worker loaded
        after its fork (or start) and the idle event loop until then."""
        per: dict[int, list] = {}
        for r in self.records:
            c0, c1, rd, wr = r.get("cpu", (0.0, 0.0, 0.0, 0.0))
            w = per.setdefault(r["pid"], [c0, c1, 0.0, 0.0, 0.0])
            w[0], w[1] = min(w[0], c0), max(w[1], c1)
            w[2] += c1 - c0
            w[3] += rd
            w[4] += wr
        if not per:
            return ""
        first, last, tasks, reads, writes = (sum(w[i] for w in per.values()) for i in range(5))
        return (f"workers' CPU {last:.1f} s to their last task's end: tasks {tasks:.1f} s (compute "
                f"{tasks - reads - writes:.1f}, cache reads {reads:.1f}, cache writes {writes:.1f}), before their "
                f"first task {first:.1f}, between tasks {last - first - tasks:.1f}")

    def _preload(self, jobs) -> None:
        """Every worker (and any that joins or restarts later) loads numpy, the OpenEXR
        bindings and, when a node to compute reads USD, USD with its plugins on its main thread
        before it runs a task (``Preload``): what ``graph.load_native_libraries`` does before
        a local run's threads start (the loader/GIL deadlock of two runs on one cache)."""
        from proxyshade.graph import keys as K

        usd = any("proxyshade.io.usd" in K.import_closure(type(job.graph.nodes[name]).__module__)
                  for job in jobs for name, _ in job.todo)
        name = "proxyshade-preload" + ("-usd" if usd else "")
        if name not in self._plugins and any(len(job.todo) for job in jobs):
            self.client.register_plugin(Preload(usd, local=self.cluster is not None), name=name)
            self._plugins.add(name)

    def _homes(self, jobs) -> dict:
        """id(job) -> submit options placing its instances on one worker, when there are at
        least as many jobs with work as workers (independent shots), so a shot's chain stays
        where its source, first frame, previous frame and memoised analyses are in memory.
        Shots that share keys (one source for two scenes: its read and its analyses) are
        placed side by side in one list, which is cut into one run of consecutive shots per
        worker with about equal work (instances to compute): sharing shots land on one
        worker unless the balance needs them apart. A preference only
        (``allow_other_workers``): a lost worker's tasks run elsewhere. Fewer jobs than
        workers: no preference, so one shot's independent instances (proxy renders of every
        frame) spread."""
        busy = [job for job in jobs if len(job.todo)]
        workers = sorted(self.client.scheduler_info().get("workers", {}))
        if len(workers) < 2 or len(busy) < len(workers):
            return {}
        owner: dict[str, int] = {}  # key -> the first job having it
        group = list(range(len(busy)))  # union-find over jobs sharing a key

        def root(i: int) -> int:
            while group[i] != i:
                group[i] = group[group[i]]
                i = group[i]
            return i

        for i, job in enumerate(busy):
            for key in set(job.plan.keys.values()):
                j = owner.setdefault(key, i)
                if root(j) != root(i):
                    group[max(root(i), root(j))] = min(root(i), root(j))
        order = sorted(range(len(busy)), key=lambda i: (root(i), i))
        total, done, out = sum(len(busy[i].todo) for i in order), 0, {}
        for i in order:  # the worker whose share of the work holds the middle of this shot's
            w = min(len(workers) - 1, int((done + len(busy[i].todo) / 2) * len(workers) / total))
            out[id(busy[i])] = {"workers": [workers[w]], "allow_other_workers": True}
            done += len(busy[i].todo)
        return out


def _image_env() -> dict[str, str]:
    return {k: v for k, v in os.environ.items() if k.startswith(IMAGE_ENV)}


def _start_method() -> str:
    """How a LocalCluster starts its worker processes: forked from Python's forkserver, which
    has imported what every worker needs (``load_worker_image``: Dask, numpy, the node
    modules, the serial kernels from numba's cache) once for all of them, instead of
    each worker spawned afresh, importing and loading all that itself. The forkserver keeps
    the environment it started with: a cluster started when no other is open and the
    environment differs in what proxyshade and its libraries read (``IMAGE_ENV``: a threshold
    changed between two runs) starts a new forkserver; one started beside an open cluster
    with another environment spawns its workers. Restarted workers (a nanny replacing a dead
    one) are spawned, Dask's default. The forkserver ends with this process."""
    import multiprocessing
    import multiprocessing.forkserver as fs

    if "forkserver" not in multiprocessing.get_all_start_methods():
        return "spawn"
    env = _image_env()
    with _GUARD:
        if _IMAGE.get("env") == env:
            _IMAGE["users"] += 1
            return "forkserver"
        if _IMAGE.get("users"):
            return "spawn"
        if _IMAGE:  # a forkserver of another environment, no cluster of it open: a new one
            stop = getattr(fs._forkserver, "_stop", None)  # CPython's own (its tests use it)
            if stop is None:
                return "spawn"
            stop()
        import dask
        from distributed.utils import get_mp_context

        with dask.config.set({"distributed.worker.multiprocessing-method": "forkserver"}):
            ctx = get_mp_context()  # distributed sets the forkserver's preload list on its first call
        ctx.set_forkserver_preload(["distributed", IMAGE_MODULE])
        _IMAGE.update(env=None, users=1)  # the environment once it started (the nannies add theirs first)
        return "forkserver"


def _release_image() -> None:
    """A LocalCluster forked from the forkserver closed."""
    with _GUARD:
        _IMAGE["users"] -= 1


IMAGE_MARKED: set[str] = set()  # the precompile units whose serial kernels load_worker_image loaded (forked workers inherit it)


def load_worker_image() -> None:
    """Run by the forkserver of a LocalCluster's workers before it forks them (``IMAGE_MODULE``),
    on its only thread: Dask, numpy, the OpenEXR and USD modules, every node module and the
    serial kernels of every node type precompiled into numba's cache (never
    compiles). Nothing that starts a thread: a forked child has only the thread that forked
    it, so a library's thread pool started here would be dead in every worker (GNU OpenMP
    ends a forked child whose parent started it: loading a parallel kernel starts numba's
    threading layer, so those load in the worker). OpenEXR's pool and USD's plugins are
    loaded by each worker on its main thread (``Preload``). Never fails: a worker loads what
    is missing when it needs it."""
    try:
        import distributed  # noqa: F401
        import numpy

        numpy.ndarray  # noqa: B018 - an attribute: loads a lazy module
        import OpenEXR  # noqa: F401 - the module; its thread pool is set up in the worker (_openexr)

        from proxyshade.graph.node import load_all

        load_all()  # colour-science is not among them: a run converts 8-bit sRGB without it (io.colourlib)
        with contextlib.suppress(ImportError):
            import pxr.Usd  # noqa: F401
            import pxr.UsdGeom  # noqa: F401
        from proxyshade.graph import warmup
        from proxyshade.kernels import _cache

        found, held = warmup.callers(), warmup.variant_units()
        marks = {u: _cache.kernels_cached([u]) for t in set(found.values()) for u in [warmup.node_unit(t)]}
        marks.update((u, _cache.kernels_cached([u])) for units in held.values() for u in units)
        IMAGE_MARKED.update(u for u, ok in marks.items() if ok)
        for (kernel, text), t in found.items():
            # precompiled under its type's unit, or under a variant's (a first frame's Poisson)
            if marks[warmup.node_unit(t)] or any(marks[u] for u in held.get((kernel, text), ())):
                with contextlib.suppress(Exception):  # a stale entry: left to the call
                    disp = warmup._dispatcher(kernel)
                    if not disp.targetoptions.get("parallel"):
                        disp.compile(warmup.parse_types(text))
    except Exception:  # noqa: BLE001 - see above
        pass


def _dask_key(key: str, deps=()) -> str:
    """The Dask key of a cache key's task: ``proxyshade-<key>``, and on a scheduler that other
    runs share, a digest of the Dask keys it depends on. Two runs that planned alike submit
    the same key and share its task; two that found different inputs already stored (one
    planned after the other's tasks wrote them) submit different keys: Dask's scheduler does
    not support one key with two sets of dependencies (it warns of deadlocks, and a client
    waited for ever). Those tasks compute the key under a Dask lock named by it, the second
    finding the first's entry (``_task``)."""
    if not deps:
        return f"proxyshade-{key}"
    import hashlib

    return f"proxyshade-{key}-{hashlib.sha256(' '.join(sorted(deps)).encode()).hexdigest()[:12]}"


def _shared_keys(jobs) -> set[str]:
    """The cache keys that several jobs compute (one source read by two shots, its analyses)."""
    seen: dict[str, int] = {}
    for i, job in enumerate(jobs):
        for inst in job.todo:
            k = job.plan.keys[inst]
            seen[k] = i if seen.get(k, i) == i else -1
    return {k for k, i in seen.items() if i < 0}


def _groups(job, order: list, shared: set[str]) -> dict:
    """Instance -> the first instance of its task: a shot's instances of one frame as one task
    (its frame's proxy, carried frame, resynthesis, Cryptomatte and writers run back to back
    on one worker, their plates in its memory), where the shots keep to one worker each
    (``_homes``): one task per frame instead of one per instance (each costs the client's
    scheduler and the worker about 2 ms of CPU), and a plate no other task reads
    (``Node.stored`` False: Cryptomatte) is not stored, as in a local run. Keys several jobs
    share (``shared``) stay tasks of their own. ``order``: the job's instances, topological.
    An instance joins the task of a predecessor of its frame unless that would make the tasks
    wait in a circle (a task waiting, through others, for the one it joins)."""
    keys, todo = job.plan.keys, job.todo
    head: dict = {}
    waits: dict = {}  # head -> the heads of the tasks its task waits for

    def reaches(a, b) -> bool:
        seen, stack = set(), [a]
        while stack:
            x = stack.pop()
            if x == b:
                return True
            if x not in seen:
                seen.add(x)
                stack.extend(waits[x])
        return False

    for inst in order:
        preds = sorted(todo.predecessors(inst), key=str)
        heads = {head[p] for p in preds}
        into = inst
        if keys[inst] not in shared:
            for p in preds:
                h = head[p]
                if p[1] == inst[1] and keys[h] not in shared and not any(q != h and reaches(q, h) for q in heads):
                    into = h
                    break
        head[inst] = into
        waits.setdefault(into, set()).update(heads - {into})
    return head


def _apply(job, inst, res: dict, by_token: dict) -> None:
    """Fill a job's row from a task's record (computed by this job, or by another job or run
    that submitted the same key), re-raise the worker's warnings, call the progress hook."""
    nr = job.runs[inst]
    token, (name, frame) = res["by"]
    if (token, (name, frame)) == (job.token, inst):
        nr.status, nr.seconds, nr.notes[:] = res["status"], res["seconds"], res["notes"]
        nr.memo_hits, nr.memo_misses = res.get("memo", (0, 0))
        job.workers[res["worker"]] += res["status"] == "computed"
        if res["status"] != "computed":
            nr.reason = res["reason"]
        for w in res["warnings"]:
            warnings.warn(w, _warning_class(), stacklevel=2)
    else:
        other = by_token.get(token)
        who = f"{other.label or other.graph.source or other.graph.name}: " if other not in (None, job) else ""
        nr.status = "reused"
        nr.reason = (f"same key as {who}{name}@{frame}" if other is not None
                     else f"computed by another run on the scheduler ({name}@{frame})")
    for node, f, key, reason, seconds in res["recomputed"]:
        row = job.plan.rows.get(key)
        if row is not None and row.status == "reused":
            row.status, row.reason, row.seconds = "computed", reason, seconds
        else:
            nr.notes.append(f"input {node}@{f} computed again: {reason}")
    job.peak_rss_mb = max(job.peak_rss_mb, res["peak_rss_mb"])
    job.hooks.done(nr)


def _warning_class():
    from proxyshade.graph.cache import CacheWarning

    return CacheWarning


# -- on the workers ------------------------------------------------------------
_GUARD = threading.Lock()
_LOCAL = threading.local()  # this task's warnings and recomputed inputs
_USING: dict[int, set[str]] = {}  # thread -> keys its task reads or writes (kept in memory)
# plates kept in a worker's memory between tasks, most recently used last: the next task there
# often reads them again (the source, the first frame, the previous frame), without loading
# them from the cache
_RECENT: "collections.OrderedDict[tuple[int, str], object]" = collections.OrderedDict()  # (cache id, key) -> cache
_CACHES: dict[str, object] = {}  # cache folder -> this worker's Cache of it (``_worker_cache``)
KEEP_MB = float(os.environ.get("PROXYSHADE_WORKER_KEEP_MB", "1024"))


@contextlib.contextmanager
def _key_lock(key: str):
    """A Dask lock named by the cache key: one worker computes a key at a time (an input
    found missing or corrupt). Its lease refresh stops once released: each lock object
    would otherwise keep a periodic callback on the worker's event loop."""
    lock = _distributed().Lock(f"proxyshade-lock-{key}")
    try:
        with lock:
            yield
    finally:
        pc = getattr(lock, "refresh_callback", None)
        if pc is not None:
            pc.stop()


class Preload(_PluginBase):
    """A worker plugin: numpy, the OpenEXR bindings and (``usd``) USD with every plugin,
    loaded on the worker's main thread when it joins, before its first task
    (``DaskExecutor._preload``)."""

    idempotent = True

    def __init__(self, usd: bool, local: bool = False):
        self.usd = usd
        self.local = local  # a LocalCluster's worker: glibc's thresholds raised (adaptive_malloc)

    def setup(self, worker) -> None:
        from proxyshade.graph.graph import load_array_libraries

        adaptive_malloc(always=self.local)
        load_array_libraries()
        if self.usd:
            from proxyshade.io.usd import load_plugins

            load_plugins()


def adaptive_malloc(always: bool = False) -> bool:
    """Where ``MALLOC_TRIM_THRESHOLD_`` is set (Dask's nanny sets it for its workers, 64 KiB),
    or ``always`` (a LocalCluster's workers): glibc's mmap and trim thresholds raised to 32 and
    64 MiB, the ceiling its own adaptive thresholds reach in a long-running process, so an
    array is not mapped, zeroed and unmapped afresh each time (``LOCAL_CONFIG``): on the 4
    shots at 256 wide, 6 frames, the workers' page faults 0.54 M -> 0.31 M, their system time
    1.9 -> 1.5 s. True when changed; glibc only."""
    import ctypes

    if "MALLOC_TRIM_THRESHOLD_" not in os.environ and not always:
        return False
    try:
        mallopt = ctypes.CDLL("libc.so.6").mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes, mallopt.restype = [ctypes.c_int, ctypes.c_int], ctypes.c_int
    m_trim_threshold, m_mmap_threshold = -1, -3  # malloc.h
    return bool(mallopt(m_mmap_threshold, 32 << 20)) and bool(mallopt(m_trim_threshold, 64 << 20))


def _recomputed(run) -> None:
    getattr(_LOCAL, "recomputed", []).append((run.node, run.frame, run.key, run.reason, run.seconds))


_SHOW = []  # warnings.showwarning before _capture_warnings replaced it


def _capture_warnings() -> None:
    """Warnings raised by a task (a corrupt cache entry) go back to the client with its
    record, per thread (a worker may run several tasks at once)."""
    with _GUARD:
        if _SHOW:
            return
        _SHOW.append(warnings.showwarning)
        warnings.simplefilter("always", _warning_class())  # every corrupt entry is told, not once per process

        def show(message, category, filename, lineno, file=None, line=None):
            caught = getattr(_LOCAL, "warnings", None)
            if caught is None:
                return _SHOW[0](message, category, filename, lineno, file, line)
            caught.append(str(message))

        warnings.showwarning = show


_CODE: dict[type, str] = {}  # node type -> its code hash in this worker


def _check_code(cls: type, want: str) -> None:
    """A worker whose proxyshade code differs from the client's would store results under keys
    that name other code: a one-line error instead."""
    from proxyshade.graph.keys import code_hash

    have = _CODE.get(cls) or _CODE.setdefault(cls, code_hash(cls))
    if have != want:
        try:
            where = f"Dask worker {_distributed().get_worker().address}"
        except ValueError:  # not on a worker
            where = f"process {os.getpid()}"
        raise UserError(f"{where} runs other proxyshade code for "
                        f"{cls.__name__} than this run (code hash {have[:12]}, the run's {want[:12]}: sources or "
                        "library versions differ); install the same proxyshade and libraries on every worker")


def _task(plan, token: str, insts: list, forced: list, memory: list, shared: bool, *deps) -> list[dict]:
    """Compute instances of one run on a worker, in the order given (one, or a frame of a shot:
    ``_groups``), each unless another run stored its key meanwhile: its inputs from this
    worker's memory or the cache, its entry to the cache (``memory``: the instances whose
    plates stay in memory, not stored, as in a local run: every reader is in this task).
    Returns a record per instance for the client. ``plan`` is the run's (one copy per worker),
    ``deps`` the records of the tasks it waits for."""
    from proxyshade.graph.graph import NodeRun

    _capture_warnings()
    g = plan.graph
    g.cache = _worker_cache(g.cache)
    g.key_lock, g.on_recompute = _key_lock, _recomputed
    g.tile_runner = functools.partial(_tiles, plan.threads)  # each instance a runner of its own
    g._stored = functools.partial(_stored_here, g)
    keys = [plan.keys[i] for i in insts]
    for inst in insts:
        _check_code(type(g.nodes[inst[0]]), plan.components[inst]["code"])
    me = threading.get_ident()
    records = []
    _LOCAL.memory = {i[0] for i in memory}
    try:
        for n, (inst, key, force) in enumerate(zip(insts, keys, forced)):
            t_start, c_start = time.time(), time.process_time()
            nr = NodeRun(inst[0], inst[1], key, "computed", "")
            _LOCAL.warnings, _LOCAL.recomputed, _LOCAL.io = [], [], [0.0, 0.0]
            with _GUARD:  # what this task still reads or writes: kept in memory
                _USING[me] = set(keys[n:]).union(*(plan.held_keys(i) for i in insts[n:]))
            try:
                with _key_lock(key) if shared else contextlib.nullcontext():  # other runs' tasks of this key
                    ok, why = (False, "") if force else g.cache.has(key)
                    if ok:
                        nr.status, nr.reason = "reused", f"stored meanwhile by another run ({why})"
                    else:
                        t = time.perf_counter()
                        g._compute(plan, inst, nr)
                        nr.seconds = time.perf_counter() - t
                records.append({"by": (token, inst), "cache_key": key, "status": nr.status, "reason": nr.reason,
                                "seconds": nr.seconds, "notes": list(nr.notes), "memo": [nr.memo_hits, nr.memo_misses],
                                "warnings": _LOCAL.warnings, "recomputed": _LOCAL.recomputed,
                                "worker": _distributed().get_worker().address, "pid": os.getpid(),
                                "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
                                "start": t_start, "end": time.time(), "cpu": (c_start, time.process_time(), *_LOCAL.io)})
            finally:
                _LOCAL.warnings = _LOCAL.recomputed = _LOCAL.io = None
                with _GUARD:
                    _USING[me] = set(keys[n + 1:]).union(*(plan.held_keys(i) for i in insts[n + 1:]))
                    _keep_recent(g.cache, [*plan.held_keys(inst), key], set().union(*_USING.values()))
        return records
    finally:
        _LOCAL.memory = ()
        with _GUARD:
            _USING.pop(me, None)
            for k in (plan.keys[i] for i in memory):  # read by this task only
                g.cache.forget(k)
                _RECENT.pop((id(g.cache), k), None)


def _stored_here(g, name: str) -> bool:
    """``Graph._stored`` on a worker: every plate is stored (another worker may read it from
    the cache) but those of the nodes the running task keeps in memory (``_task``'s ``memory``)."""
    return _stored_type(g, name) or name not in getattr(_LOCAL, "memory", ())


def _stored_type(g, name: str) -> bool:
    """Whether a local run stores ``name``'s plates (``Node.stored``, or a progressive node)."""
    node = g.nodes[name]
    return type(node).stored or node.is_progressive()


def _tiles(threads: int):
    """The row-band runner of the correction's sub-passes (``graph.tiles``) for a node
    instance here: one band per worker of the cluster (counted when a level large enough first
    asks), each band a task with this run's numba threads."""
    from proxyshade.graph.graph import set_kernel_threads
    from proxyshade.graph.tiles import DaskTiles

    return DaskTiles(setup=functools.partial(set_kernel_threads, threads))


def _worker_cache(cache):
    """This worker's cache object for ``cache``'s folder, shared by every graph (shot) whose
    tasks run here: a plate one shot computed or loaded (a source two shots read) is in
    memory for the other. Its writes are synchronous: a task ends once its entry is on disk,
    so a task on another worker that reads it finds it whole (no lock to hand it over, no
    write left to wait for), and a failed write fails the task. The worker's cores are busy
    with the other tasks meanwhile (one task per core)."""
    from proxyshade.graph.cache import Cache

    if getattr(cache, "_worker_shared", False):
        return cache
    root = str(cache.root.absolute())
    with _GUARD:
        shared = _CACHES.get(root)
        if shared is None:
            shared = _CACHES[root] = Cache(root, background=False)
            shared._worker_shared = True
            shared.load_problem = _timed(shared.load_problem, 0)
            shared._write = _timed(shared._write, 1)
    return shared


def _timed(fn, slot: int):
    """``fn`` whose process CPU seconds go to the running task's cache reads (slot 0) or
    writes (slot 1): the task's record splits its CPU (``DaskExecutor.cpu``)."""
    @functools.wraps(fn)
    def timed(*args, **kw):
        io = getattr(_LOCAL, "io", None)
        if io is None:
            return fn(*args, **kw)
        t = time.process_time()
        try:
            return fn(*args, **kw)
        finally:
            io[slot] += time.process_time() - t
    return timed


def _keep_recent(cache, used: list[str], busy: set[str]) -> None:
    """Mark ``used`` plates as the most recent of ``cache``'s, then drop the least recent
    plates of every cache beyond ``KEEP_MB`` (never one a running task reads: ``busy``)."""
    for k in used:
        if k in cache.memory:
            _RECENT[(id(cache), k)] = cache
            _RECENT.move_to_end((id(cache), k))
    for (cid, k), c in list(_RECENT.items()):
        if k not in c.memory:
            del _RECENT[(cid, k)]  # forgotten by the engine (a sequence's plates)
    total = sum(c.memory[k].nbytes() for (_, k), c in _RECENT.items()) / 2**20
    for (cid, k), c in list(_RECENT.items()):
        if total <= KEEP_MB:
            break
        if k not in busy:
            total -= c.memory[k].nbytes() / 2**20
            c.forget(k)
            del _RECENT[(cid, k)]
    for k in [k for k in cache.memory if (id(cache), k) not in _RECENT and k not in busy]:
        cache.forget(k)  # loaded by the engine but not among this task's inputs or output
