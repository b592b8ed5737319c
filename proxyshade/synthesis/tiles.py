"""Row bands of the correction's sub-passes on other workers (Dask), where that is exact.

A correction sub-pass (``kernels.correct``) updates one parity class of pixels, each from
the state before the sub-pass and a usage term computed from that state: its rows can be
computed anywhere, in any grouping, and come out bit-identical
(``kernels.correct.subpass_rows``). An executor that has other workers to offer sets a
runner for the task it computes (``running``); ``correct_map`` passes it to the kernels,
which split each sub-pass of a large level into ``runner.bands`` row bands. Without a
runner (the local executor: numba's threads already share every sub-pass's rows) nothing
changes.

    with running(DaskTiles(bands=2)):     # inside a Dask task
        S, stats, rep = correct_map(...)
"""
from __future__ import annotations

import contextlib
import threading

_LOCAL = threading.local()


def current():
    """The runner set for this thread's task, or None."""
    return getattr(_LOCAL, "runner", None)


@contextlib.contextmanager
def running(runner):
    """Set ``runner`` (``runner(fn, shared, jobs)`` with a ``bands`` count) for this thread."""
    before = current()
    _LOCAL.runner = runner
    try:
        yield runner
    finally:
        _LOCAL.runner = before


class InProcess:
    """Bands run here one after the other: the reference the distributed runner must match."""

    def __init__(self, bands: int = 2):
        self.bands = bands

    def __call__(self, fn, shared, jobs):
        return [fn(*shared, *job) for job in jobs]


class DaskTiles:
    """Bands as tasks on the Dask cluster of the worker running this task: the task secedes
    (``distributed.worker_client``) while they run, so its own worker computes bands too.
    The shared arguments (a level of the exemplar pyramid, its similarity sets) are sent
    once per level and reused by its sub-passes."""

    def __init__(self, bands: int | None = None, setup=None):
        self._bands = bands
        self.setup = setup  # called on the band's worker thread first (picklable; e.g. numba's thread count)
        self._shared = (None, None)  # (ids of the shared objects, their futures)

    @property
    def bands(self) -> int:
        """The band count: given, or the cluster's workers (asked when a level first needs it)."""
        if self._bands is None:
            from distributed import get_client

            self._bands = max(1, len(get_client().scheduler_info().get("workers", {})))
        return self._bands

    def __call__(self, fn, shared, jobs):
        from distributed import worker_client

        with worker_client() as client:
            ids = tuple(id(x) for x in shared)
            if self._shared[0] != ids:
                self._shared = (ids, [client.scatter(x, broadcast=True, hash=False) for x in shared])
            futs = [client.submit(_band, fn, self.setup, *self._shared[1], *job, pure=False) for job in jobs]
            return client.gather(futs)


def _band(fn, setup, *args):
    """``fn(*args)`` after ``setup()`` on the worker thread that runs it."""
    if setup is not None:
        setup()
    return fn(*args)
