"""Executors: run a function on every vertex of a DAG once its predecessors are done.

The engine hands an executor prepared runs (``run_jobs``: ``graph.RunJob``, each a
networkx DiGraph of instances and the function computing one in this process); the
executors here run each job's DAG in this process, ``dask_executor.DaskExecutor`` on
Dask workers. Results do not depend on scheduling order: every vertex's work is a pure
function of its inputs.
"""
from __future__ import annotations

import time
from concurrent.futures import FIRST_COMPLETED, Future, ThreadPoolExecutor, wait
from typing import Callable, Hashable

import networkx as nx

from proxyshade.graph import profile


class LocalExecutor:
    """Runs the jobs one after another in this process (``run``: one DAG)."""

    def run(self, dag: nx.DiGraph, fn: Callable[[Hashable], None]) -> None:
        raise NotImplementedError

    def run_jobs(self, jobs) -> None:
        from proxyshade.graph.warmup import Prefetch

        for job in jobs:
            prefetch = Prefetch(job.graph, job.todo) if len(job.todo) else None
            try:
                self.run(job.todo, job.work)
            finally:
                if prefetch is not None:
                    prefetch.stop()
                t = time.perf_counter()
                job.graph.cache.flush()  # every background cache write done (or failed)
                if profile.ACTIVE is not None:
                    profile.ACTIVE.flush_wait += time.perf_counter() - t


def order_key(dag: nx.DiGraph) -> Callable[[Hashable], tuple]:
    """Among vertices ready to run, those marked ``first`` (the engine marks writers: a
    preview or an EXR writer frees its input plate as soon as it has run) before the rest,
    then the earliest frame, then by name: a deterministic order that holds fewer plates in
    memory at once. By frame: a shot's frame is finished (and its writes begun) before the
    next frame's nodes start; by name alone every frame's ProxyRender and ConsistentDepth ran
    before the first Reproject (at 1024 wide, 40 MiB held per frame of the shot until its
    Reproject ran, and the writers idle until then)."""
    def key(v):
        frame = v[1] if isinstance(v, tuple) and len(v) == 2 and isinstance(v[1], int) else 0
        return (not dag.nodes[v].get("first", False), frame, str(v))
    return key


WRITER_THREADS = 2  # a first frame ends with its EXR (ZIP on one core, 0.45 s at 1024 wide) beside its preview


class SerialExecutor(LocalExecutor):
    """One computing vertex at a time, in a deterministic topological order (``order_key``).
    The writers (vertices marked ``first``: previews, EXR writers) start in that order on
    ``WRITER_THREADS`` threads of their own, beside the nodes that follow (an output's
    encoding and write are off the computing path; the last frame's EXR and its preview are
    written side by side); a vertex that reads a writer waits for it. What each vertex
    computes does not depend on the overlap, so the files are the same; the run raises the
    first failure in this order."""

    def run(self, dag: nx.DiGraph, fn: Callable[[Hashable], None]) -> None:
        order = list(nx.lexicographical_topological_sort(dag, key=order_key(dag)))
        if all(dag.nodes[v].get("first", False) for v in order) or not any(
                dag.nodes[v].get("first", False) for v in order):
            for v in order:
                fn(v)
            return
        writes: dict[Hashable, Future] = {}
        prof = profile.ACTIVE
        if prof is not None:
            prof.writes_beside = True

        def wait_for(f: Future) -> None:
            t = time.perf_counter()
            try:
                f.result()
            finally:
                if prof is not None:
                    prof.write_wait += time.perf_counter() - t

        with ThreadPoolExecutor(max_workers=WRITER_THREADS, thread_name_prefix="proxyshade-write") as pool:
            try:
                for v in order:
                    for u in dag.predecessors(v):
                        if u in writes:
                            wait_for(writes[u])
                    for f in writes.values():  # a failed write stops the run before the next node
                        if f.done() and f.exception() is not None:
                            f.result()
                    if dag.nodes[v].get("first", False):
                        writes[v] = pool.submit(fn, v)
                    else:
                        fn(v)
                for f in writes.values():
                    wait_for(f)
            except BaseException:
                for f in writes.values():
                    f.cancel()
                raise


class ThreadExecutor(LocalExecutor):
    """Independent vertices run concurrently on ``jobs`` threads (numba kernels release the GIL)."""

    def __init__(self, jobs: int = 2):
        self.jobs = max(1, int(jobs))

    def run(self, dag: nx.DiGraph, fn: Callable[[Hashable], None]) -> None:
        if self.jobs == 1:
            return SerialExecutor().run(dag, fn)
        remaining = {v: dag.in_degree(v) for v in dag}
        key = order_key(dag)
        ready = sorted((v for v, d in remaining.items() if d == 0), key=key)
        running: dict[Future, Hashable] = {}
        with ThreadPoolExecutor(max_workers=self.jobs, thread_name_prefix="proxyshade") as pool:
            try:
                while ready or running:
                    while ready and len(running) < self.jobs:
                        v = ready.pop(0)
                        running[pool.submit(fn, v)] = v
                    done, _ = wait(list(running), return_when=FIRST_COMPLETED)
                    for fut in sorted(done, key=lambda f: str(running[f])):
                        v = running.pop(fut)
                        fut.result()  # re-raise the first failure
                        for s in dag.successors(v):
                            remaining[s] -= 1
                            if remaining[s] == 0:
                                ready.append(s)
                    ready.sort(key=key)
            except BaseException:
                for fut in running:
                    fut.cancel()
                raise


def make_executor(jobs: int = 1):
    return SerialExecutor() if jobs <= 1 else ThreadExecutor(jobs)
