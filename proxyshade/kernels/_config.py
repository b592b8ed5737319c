"""numba flags for every kernel, in one place.

Kernels are pure functions on arrays: ``@njit(**JIT)`` for serial code,
``@njit(**PJIT)`` with ``prange`` where each thread writes only what it owns.
``nogil`` lets the graph executor run independent nodes on threads.

Threads wait passively between parallel loops (``OMP_WAIT_POLICY=PASSIVE`` unless the
environment sets it): numba's OpenMP layer otherwise spins at every barrier, and on
cores shared with other processes a spinning thread holds the core the thread with the
work needs. A lake update frame at 1024² on 2 busy cores: 0.74 s passive, 3.7–8.3 s
spinning (docs/temporal.md). Set ``OMP_WAIT_POLICY=ACTIVE`` for a machine of one's own.
"""
import os

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # read when the OpenMP runtime starts

JIT = dict(cache=True, nogil=True, fastmath=False)
PJIT = dict(cache=True, nogil=True, fastmath=False, parallel=True)
