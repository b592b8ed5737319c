"""``_config.rows``: a serial kernel over row bands on the kernels' threads."""
import threading

import numba
import numpy as np
import pytest
from numba import njit

from proxyshade.kernels._config import JIT, rows


@njit(**JIT)
def _count_rows(out, r0, r1):
    for r in range(r0, r1):
        out[r] += 1


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("n", [0, 1, 2, 7, 8, 9, 100])
def test_every_row_once_for_any_thread_count(n, threads):
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    try:
        out = np.zeros(n, np.int64)
        rows(_count_rows, n, out)
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    assert (out == 1).all()


def test_bands_run_on_as_many_threads_as_the_caller_has():
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("one thread")
    seen, lock = [], threading.Lock()
    barrier = threading.Barrier(2, timeout=10)

    def kernel(r0, r1):
        with lock:
            seen.append(threading.get_ident())
        if r0 < 2:  # the first band of each of the two shares waits for the other: both run at once
            barrier.wait()

    numba.set_num_threads(2)
    rows(kernel, 8)
    assert len(seen) == 8 and len(set(seen)) == 2
    numba.set_num_threads(1)
    try:
        seen.clear()
        rows(lambda r0, r1: seen.append((r0, r1, threading.get_ident())), 8)
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    assert seen == [(0, 8, threading.get_ident())]  # one thread: one call over every row, in the caller's thread


def test_an_error_in_a_band_reaches_the_caller():
    def kernel(r0, r1):
        if r0 <= 5 < r1:
            raise ValueError("row 5")

    with pytest.raises(ValueError, match="row 5"):
        rows(kernel, 16)
