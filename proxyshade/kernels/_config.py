"""numba flags for every kernel, in one place.

Kernels are pure functions on arrays: ``@njit(**JIT)`` for serial code,
``@njit(**PJIT)`` with ``prange`` where each thread writes only what it owns. A parallel
kernel compiles slower than a serial one (about 0.4 s more for a short loop, and its loop
body's callees compile twice, for an int64 and a uint64 index): a loop whose work is a few
milliseconds a frame is serial, and a long loop body is a serial kernel the parallel loop
calls with ``np.int64(index)`` (``guide._subpass_row``, ``bench/bench_compile.py --mode
entries`` measures each).
``nogil`` lets the graph executor run independent nodes on threads.

Threads wait passively between parallel loops (``OMP_WAIT_POLICY=PASSIVE`` unless the
environment sets it): numba's OpenMP layer otherwise spins after every parallel loop, and
on cores shared with other processes a spinning thread holds the core the thread with the
work needs. Set ``OMP_WAIT_POLICY=ACTIVE`` (or ``GOMP_SPINCOUNT``) on a machine of one's own
(measurements: docs/temporal.md, "Tried and not kept").

LLVM optimises at ``-O2`` unless ``NUMBA_OPT`` is set (below).

Every kernel is cached (``cache=True``) in the folder of this version of the kernels
package (``_cache.folder()``): importing this module puts ``KernelsLocator`` first among
numba's cache locators, for the files of this package only.
"""
import os
import tempfile
from pathlib import Path

from numba.core import caching, config

from proxyshade.kernels import _cache

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # read when the OpenMP runtime starts

# LLVM optimises at -O2, not numba's -O3, unless the environment sets NUMBA_OPT: the first
# frame's kernels compile in 6-10 % fewer CPU seconds (bench/bench_compile.py --mode entries),
# run as fast (the forced lake frame on one thread: 4.49-4.59 CPU s against 4.51-4.61) and
# give the same bytes (no kernel uses fastmath, so neither level may reorder arithmetic).
# Set in the environment, so worker processes (precompile, Dask) compile at the same level.
if "NUMBA_OPT" not in os.environ:
    os.environ["NUMBA_OPT"] = "2"
    config.reload_config()

# error_model="numpy": a float division by zero gives inf or nan as numpy does instead of
# raising, so no check and exception path is compiled at each division (8% less compile
# time over the first frame's kernels; no kernel divides by zero on purpose)
JIT = dict(cache=True, nogil=True, fastmath=False, error_model="numpy")
PJIT = dict(cache=True, nogil=True, fastmath=False, error_model="numpy", parallel=True)




class KernelsLocator(caching._SourceFileBackedLocatorMixin, caching._CacheLocator):
    """numba's cache locator for the kernels of this package: ``_cache.folder()``, named by
    the version of the whole package, so a kernel inlining another module's never loads
    machine code compiled against that module's old source. Where that folder cannot be
    written, a folder of this user's in the temporary directory named the same way."""

    def __init__(self, py_func, py_file, path=None):
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        self._cache_path = str(path or _cache.folder())

    def get_cache_path(self):
        return self._cache_path

    @classmethod
    def from_function(cls, py_func, py_file):
        if Path(py_file).resolve().parent != _cache.HERE:
            return None  # not a kernel of this package: numba's own locators
        for path in (None, Path(tempfile.gettempdir(), f"proxyshade-{os.getuid()}", "kernels", _cache.version())):
            self = cls(py_func, py_file, path)
            try:
                self.ensure_cache_path()
                return self
            except OSError:
                continue
        return None


if KernelsLocator not in caching.CacheImpl._locator_classes:
    caching.CacheImpl._locator_classes.insert(0, KernelsLocator)
