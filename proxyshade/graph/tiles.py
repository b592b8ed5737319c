"""The Dask executor's tile runner: row bands of the correction's sub-passes as tasks on the
cluster (the contract and the in-process reference: ``synthesis.tiles``). The engine hands
one to each node instance a Dask task computes (``ctx.tiles``)."""
from __future__ import annotations


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
