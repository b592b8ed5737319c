"""numba flags for every kernel, in one place.

Kernels are pure functions on arrays: ``@njit(**JIT)`` for serial code,
``@njit(**PJIT)`` with ``prange`` where each thread writes only what it owns.
``nogil`` lets the graph executor run independent nodes on threads.

Threads wait passively between parallel loops (``OMP_WAIT_POLICY=PASSIVE`` unless the
environment sets it): numba's OpenMP layer otherwise spins for milliseconds after every
parallel loop, and on cores shared with other processes a spinning thread holds the core
the thread with the work needs. Lake update frame at 1024² on 2 cores (docs/temporal.md):
one other job running, 0.73 s passive against 0.98 s with a 0.1 ms spin
(``GOMP_SPINCOUNT=10000``) and 3.7–10.7 s with the default spin; idle cores, 0.58–0.61 s
passive against 0.50–0.54 s spinning (waking a sleeping thread costs ~50 µs per parallel
loop). Set ``OMP_WAIT_POLICY=ACTIVE`` (or ``GOMP_SPINCOUNT``) on a machine of one's own.
"""
import os

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # read when the OpenMP runtime starts

JIT = dict(cache=True, nogil=True, fastmath=False)
PJIT = dict(cache=True, nogil=True, fastmath=False, parallel=True)


def _cache_dirs(src):
    """Where numba keeps the cache of the kernels in source file ``src`` (its locators, in
    order): ``$NUMBA_CACHE_DIR``, else ``__pycache__`` beside the source, else the user-wide
    cache folder (an install whose package folder is not writable)."""
    import hashlib
    from pathlib import Path

    folder = os.path.dirname(os.path.abspath(src))
    sub = f"{os.path.basename(folder)}_{hashlib.sha1(folder.encode()).hexdigest()}"
    if os.environ.get("NUMBA_CACHE_DIR"):
        return [Path(os.environ["NUMBA_CACHE_DIR"], sub)]
    user = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache", "numba", sub)
    return [Path(folder, "__pycache__"), user]


def kernels_cached(modules=()) -> bool:
    """Whether numba's on-disk cache holds compiled kernels of each of ``modules``
    (``proxyshade.kernels.X`` names): an index file of the module newer than its source.
    False on the first run after an install, when they compile, and after an upgrade that
    changed a kernel module (numba then ignores its cache). Reads folders only: no numba."""
    from pathlib import Path

    here = Path(__file__).parent
    newest = {}  # module stem -> newest index file's mtime, over the cache folders
    for d in _cache_dirs(here / "random.py"):
        try:
            with os.scandir(d) as it:
                for e in it:
                    if e.name.endswith(".nbi"):
                        stem = e.name.partition(".")[0]
                        newest[stem] = max(newest.get(stem, 0.0), e.stat().st_mtime)
        except OSError:
            continue
    for m in modules:
        stem = m.rpartition(".")[2]
        src = here / f"{stem}.py"
        try:
            if newest.get(stem, -1.0) >= src.stat().st_mtime:
                continue  # a fresh index
        except OSError:
            continue  # no such module
        if not stem.startswith("_") and "@njit" in src.read_text():  # a module with kernels
            return False
    return True
