"""numba flags for every kernel, in one place.

Kernels are pure functions on arrays: ``@njit(**JIT)`` for serial code,
``@njit(**PJIT)`` with ``prange`` where each thread writes only what it owns.
``nogil`` lets the graph executor run independent nodes on threads.
"""
JIT = dict(cache=True, nogil=True, fastmath=False)
PJIT = dict(cache=True, nogil=True, fastmath=False, parallel=True)


def kernels_cached() -> bool:
    """Whether numba's on-disk cache holds compiled kernels (index files beside the kernel
    modules): False on the first run after an install, when every kernel compiles."""
    from pathlib import Path

    cache = Path(__file__).parent / "__pycache__"
    return cache.is_dir() and any(cache.glob("*.nbi"))
