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
        for job in jobs:
            try:
                self.run(job.todo, job.work)
            finally:
                t = time.perf_counter()
                job.graph.cache.flush()  # every background cache write done (or failed)
                if profile.ACTIVE is not None:
                    profile.ACTIVE.flush_wait += time.perf_counter() - t


class SerialExecutor(LocalExecutor):
    """One vertex at a time, in a deterministic topological order."""

    def run(self, dag: nx.DiGraph, fn: Callable[[Hashable], None]) -> None:
        for v in nx.lexicographical_topological_sort(dag, key=str):
            fn(v)


class ThreadExecutor(LocalExecutor):
    """Independent vertices run concurrently on ``jobs`` threads (numba kernels release the GIL)."""

    def __init__(self, jobs: int = 2):
        self.jobs = max(1, int(jobs))

    def run(self, dag: nx.DiGraph, fn: Callable[[Hashable], None]) -> None:
        if self.jobs == 1:
            return SerialExecutor().run(dag, fn)
        remaining = {v: dag.in_degree(v) for v in dag}
        ready = sorted((v for v, d in remaining.items() if d == 0), key=str)
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
                    ready.sort(key=str)
            except BaseException:
                for fut in running:
                    fut.cancel()
                raise


def make_executor(jobs: int = 1):
    return SerialExecutor() if jobs <= 1 else ThreadExecutor(jobs)
