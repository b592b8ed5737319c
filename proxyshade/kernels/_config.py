"""numba flags for every kernel, in one place.

Kernels are pure functions on arrays: ``@njit(**JIT)`` for serial code,
``@njit(**PJIT)`` with ``prange`` where each thread writes only what it owns.
``nogil`` lets the graph executor run independent nodes on threads.
"""
JIT = dict(cache=True, nogil=True, fastmath=False)
PJIT = dict(cache=True, nogil=True, fastmath=False, parallel=True)
