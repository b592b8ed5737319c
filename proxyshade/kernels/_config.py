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
    (``proxyshade.kernels.X`` names): an index file of the module written after its source
    changed, or one that holds the source's SHA-256 (numba's freshness stamp, so a file
    rewritten with the same content, as a git checkout does, still counts). False on the
    first run after an install, when they compile, and after an upgrade that changed a
    kernel module (numba then ignores its cache). Reads files only: no numba."""
    import hashlib
    from pathlib import Path

    here = Path(__file__).parent
    indexes = {}  # module stem -> [(mtime, path)] of its index files, over the cache folders
    for d in _cache_dirs(here / "random.py"):
        try:
            with os.scandir(d) as it:
                for e in it:
                    if e.name.endswith(".nbi"):
                        indexes.setdefault(e.name.partition(".")[0], []).append((e.stat().st_mtime, e.path))
        except OSError:
            continue
    for m in modules:
        stem = m.rpartition(".")[2]
        src = here / f"{stem}.py"
        try:
            mtime = src.stat().st_mtime
        except OSError:
            continue  # no such module
        found = indexes.get(stem, [])
        if any(t >= mtime for t, _ in found):
            continue  # an index written since the source last changed
        if stem.startswith("_") or "@njit" not in src.read_text():
            continue  # no compiled kernels there
        digest = hashlib.sha256(src.read_bytes()).digest()
        if not any(digest in Path(path).read_bytes() for _, path in found):
            return False
    return True
