"""Where numba keeps the compiled kernels: one folder per version of the kernels package.

numba keys a cached kernel by its own source file only, and kernels inline the jitted
functions of other kernel modules (``correct.py`` calls ``random.rand``): after an edit to
``random.py`` a kernel of ``correct.py`` would load its old machine code. So every kernel of
the package is cached in one folder named by ``version()``, the hash of the whole
``proxyshade/kernels/`` package (each ``.py`` file, comments stripped) and of numba's and
numpy's versions: an edit to any kernel module, or an upgrade of either library, starts
an empty folder where every kernel compiles afresh, and two versions of the package never
share compiled code. ``_config`` points numba's cache locator at it.

The folder is ``<root>/<version>``, ``root()`` being ``$NUMBA_CACHE_DIR/proxyshade-kernels``
when the user set numba's cache folder, else ``kernels/`` in the per-user cache folder
(``$XDG_CACHE_HOME/proxyshade`` or ``~/.cache/proxyshade``). ``proxyshade cache clean``
removes the other versions' folders (``remove_old``).

``warmup.precompile`` marks each kernel module whose manifest signatures it compiled into
the folder (``precompiled/<module>``): ``kernels_cached`` reads those marks, never numba's
index. This module reads files only: no numba.
"""
from __future__ import annotations

import functools
import hashlib
import json
import os
import shutil
import time
from pathlib import Path

from proxyshade.io.files import strip_comments, user_cache_dir, write_text_atomic

HERE = Path(__file__).resolve().parent
_MEMO = "versions.json"  # in root(): the last version computed, by the files' stat signatures
_MARKS = "precompiled"


def root() -> Path:
    """The folder holding one subfolder per version of the kernels package."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return Path(os.environ["NUMBA_CACHE_DIR"], "proxyshade-kernels")
    return user_cache_dir() / "kernels"


def _library_versions() -> list:
    from importlib import metadata

    out = []
    for name in ("numba", "numpy"):
        try:
            out.append([name, metadata.version(name)])
        except metadata.PackageNotFoundError:
            out.append([name, None])
    return out


@functools.lru_cache(maxsize=1)  # one version per process: the one its kernels were imported at
def version() -> str:
    """Hash (20 hex digits) of every ``.py`` file of the kernels package, comments stripped,
    and of numba's and numpy's versions. Kept in ``root()/versions.json`` by the files'
    stat signatures (size, mtime, ctime, inode), so a cached run does not tokenize them."""
    files = sorted(HERE.glob("*.py"))
    libs = _library_versions()
    stats = []
    for f in files:
        st = f.stat()
        stats.append([f.name, st.st_size, st.st_mtime_ns, st.st_ctime_ns, st.st_ino])
    sig = hashlib.sha256(json.dumps([str(HERE), stats, libs]).encode()).hexdigest()
    memo = root() / _MEMO
    try:
        rec = json.loads(memo.read_text())
        rec = rec if isinstance(rec, dict) else {}
    except (OSError, ValueError):
        rec = {}
    if isinstance(rec.get(sig), str):
        return rec[sig]
    parts = [[f.name, hashlib.sha256(strip_comments(f.read_text(encoding="utf-8")).encode()).hexdigest()]
             for f in files]
    v = hashlib.sha256(json.dumps([parts, libs]).encode()).hexdigest()[:20]
    try:
        memo.parent.mkdir(parents=True, exist_ok=True)
        keep = dict(list(rec.items())[-7:], **{sig: v})  # a few checkouts side by side
        write_text_atomic(memo, json.dumps(keep))
    except OSError:
        pass  # an unwritable cache: computed again next time
    return v


def folder() -> Path:
    """This version's folder: numba's cache of every kernel of the package."""
    return root() / version()


def modules() -> list[str]:
    """Every module of the kernels package, as ``proxyshade.kernels.X`` names."""
    return sorted(f"proxyshade.kernels.{f.stem}" for f in HERE.glob("*.py") if f.stem != "__init__")


def mark_precompiled(names) -> None:
    """Mark ``names`` (kernel modules) as precompiled into this version's folder."""
    d = folder() / _MARKS
    d.mkdir(parents=True, exist_ok=True)
    for m in names:
        if not (d / m).exists():
            write_text_atomic(d / m, "")


def kernels_cached(names=()) -> bool:
    """Whether each of ``names`` (``proxyshade.kernels.X`` modules) was precompiled into this
    version's folder (``mark_precompiled``): False after an install, an upgrade of numba or
    numpy, or an edit to any kernel module, when the kernels compile again."""
    d = folder() / _MARKS
    return all((d / m).exists() for m in names)


def _bytes(path: Path) -> int:
    total = 0
    for base, _, files in os.walk(path):
        for f in files:
            try:
                total += os.lstat(os.path.join(base, f)).st_size
            except OSError:
                continue
    return total


def _in_tree() -> list[Path]:
    """numba's cache files beside the sources (``__pycache__/*.nbi, *.nbc``), where versions
    before this folder kept them: never read now."""
    try:
        return sorted(p for p in (HERE / "__pycache__").iterdir() if p.suffix in (".nbi", ".nbc"))
    except OSError:
        return []


def info() -> dict:
    """{'folder', 'bytes', 'old': [(path, bytes)]}: this version's folder and its size; the
    folders of other versions and numba's files left beside the sources."""
    here, old = folder(), []
    try:
        with os.scandir(root()) as it:
            old = [Path(e.path) for e in it if e.is_dir(follow_symlinks=False) and e.path != str(here)]
    except OSError:
        pass
    return {"folder": here, "bytes": _bytes(here) if here.is_dir() else 0,
            "old": [(p, _bytes(p)) for p in sorted(old)] + [(p, p.stat().st_size) for p in _in_tree()]}


def _last_used(path: Path) -> float:
    """The newest modification time of a folder or of any file in it (0 when unreadable)."""
    newest = 0.0
    for base, _, files in os.walk(path):
        for f in [base, *(os.path.join(base, f) for f in files)]:
            try:
                newest = max(newest, os.lstat(f).st_mtime)
            except OSError:
                continue
    return newest


def remove_old(idle: float = 3600.0) -> tuple[list[tuple[Path, int]], list[Path]]:
    """Delete what ``info`` lists as old, except folders written to in the last ``idle``
    seconds: another checkout or install of proxyshade on this machine (a second version)
    may be compiling into it or running from it right now, and numba would fail on a folder
    removed under it. Returns ((path, bytes) of each removed, the folders kept in use)."""
    removed, in_use = [], []
    now = time.time()
    for p, n in info()["old"]:
        if p.is_dir() and now - _last_used(p) < idle:
            in_use.append(p)
            continue
        if p.is_dir():
            shutil.rmtree(p, ignore_errors=True)
        else:
            p.unlink(missing_ok=True)
        removed.append((p, n))
    return removed, in_use
