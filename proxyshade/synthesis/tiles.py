"""Row bands of the correction's sub-passes on other workers (Dask), where that is exact:
the contract of a tile runner, and the in-process reference.

A correction sub-pass (``kernels.correct``) updates one parity class of pixels, each from
the state before the sub-pass and a usage term computed from that state: its rows can be
computed anywhere, in any grouping, and come out bit-identical
(``kernels.correct.subpass_rows``). An executor that has other workers to offer hands the
node a runner (``ctx.tiles``; the Dask executor's is ``graph.tiles.DaskTiles``), the node
passes it to ``patches.correct_map(tiles=...)`` and that to the kernels, which split each
sub-pass of a large level into ``runner.bands`` row bands: ``runner(fn, shared, jobs)``
returns ``[fn(*shared, *job) for job in jobs]``, computed anywhere. Without a runner (the
local executor: numba's threads already share every sub-pass's rows) nothing changes.

    S, stats, rep = correct_map(..., tiles=ctx.tiles)
"""
from __future__ import annotations


class InProcess:
    """Bands run here one after the other: the reference the distributed runner must match."""

    def __init__(self, bands: int = 2):
        self.bands = bands

    def __call__(self, fn, shared, jobs):
        return [fn(*shared, *job) for job in jobs]
