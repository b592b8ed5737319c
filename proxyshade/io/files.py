"""Output files written atomically: where a write lands, temporary names, stale temporaries.

Every file proxyshade writes (cache entries, EXR, PNG and GIF outputs, run records) is
written to ``.<name>.<pid>-<host>.<n>.tmp<.ext>`` beside its target and renamed over it, so a
reader sees the old file or the new one, never a part. A symlink is written through to
its target; a device, FIFO or folder at the output path is refused. A process killed
mid-write leaves its temporary behind: ``stale_temps`` finds those whose process is gone
(or that are older than a day) and ``remove_stale_temps`` deletes them. Whether a process is
gone is known only on its own machine: another machine's temporaries in a shared folder (a
farm's cache) are removed only once a day old.
"""
from __future__ import annotations

import errno
import hashlib
import io
import itertools
import os
import re
import socket
import stat
import time
import tokenize
from pathlib import Path

from proxyshade.errors import UserError, WriteError

_TMP = re.compile(r"^\.(?P<name>.+)\.(?P<pid>\d+)(?:-(?P<host>[0-9a-f]{8}))?\.(?P<n>\d+)\.tmp(?:\.[A-Za-z0-9]+)?$")
_OLD_TMP = re.compile(r"^\.(?P<name>.+)\.tmp\d+\.png$")  # PNG temporaries before pids were in the name
_counter = itertools.count()
MAX_AGE_S = 24 * 3600.0
READ_ONLY = (errno.EROFS, errno.EACCES, errno.EPERM)

_KINDS = ((stat.S_ISDIR, "folder"), (stat.S_ISCHR, "character device"), (stat.S_ISBLK, "block device"),
          (stat.S_ISFIFO, "FIFO"), (stat.S_ISSOCK, "socket"))


def output_target(path: str | Path) -> Path:
    """The file a write to ``path`` replaces: ``path`` itself, or a symlink's final target.
    Raises a one-line ``UserError`` when something other than a regular file is there."""
    path = Path(path)
    target = Path(os.path.realpath(path)) if path.is_symlink() else path
    try:
        st = os.stat(target)
    except FileNotFoundError:
        return target
    except OSError as e:
        raise WriteError(f"{path}: cannot check the output path ({e.strerror}); check the folder") from None
    if not stat.S_ISREG(st.st_mode):
        kind = next((k for test, k in _KINDS if test(st.st_mode)), "special file")
        via = f" (through the symlink to {target})" if target != path else ""
        raise UserError(f"{path}: is a {kind}{via}, not a regular file; proxyshade will not replace it: "
                        "give an output file path")
    return target


def output_problem(path: Path) -> str | None:
    """Why no file can be written at ``path``, checked before anything is computed, or None:
    a file (or a device) where one of its folders must be, a symlink loop on the way, or a
    folder, device or loop at ``path`` itself. Folders that do not exist yet are fine (the
    writer makes them)."""
    path = Path(os.path.abspath(path))
    for p in [*reversed(path.parents), path]:
        try:
            st = os.stat(p)
        except FileNotFoundError:
            if os.path.islink(p):  # a symlink to nothing: the write goes through it
                continue
            return None  # made by the writer, with everything below it
        except OSError as e:
            if e.errno == errno.ELOOP:
                return f"{p}: is a symlink loop; remove it or point the output elsewhere"
            if e.errno == errno.ENOTDIR:
                return f"{p}: a part of it is a file, not a folder; point the output at a folder"
            return None  # permissions and the like: the writer says what the system says
        if p != path and not stat.S_ISDIR(st.st_mode):
            return f"{p}: is a file, not a folder; point the output at a folder (or move the file)"
        if p == path and not stat.S_ISREG(st.st_mode):
            kind = next((k for test, k in _KINDS if test(st.st_mode)), "special file")
            return f"{p}: is a {kind}, not a regular file; proxyshade will not replace it: give an output file path"
    return None


def _host() -> str:
    """This machine, in temporaries' names: 8 hex digits of a hash of its host name."""
    return hashlib.sha256(socket.gethostname().encode()).hexdigest()[:8]


HOST = _host()


def temp_for(target: Path, suffix: str = "") -> Path:
    """A temporary name beside ``target`` for this process on this machine (``suffix``: the
    format's extension): ``.<name>.<pid>-<host>.<n>.tmp<suffix>``."""
    return target.with_name(f".{target.name}.{os.getpid()}-{HOST}.{next(_counter)}.tmp{suffix}")


def temp_of(name: str) -> str | None:
    """The file name a temporary's name ``name`` was made for (``temp_for``), None when it is not one."""
    m = _TMP.match(name) or _OLD_TMP.match(name)
    return m["name"] if m else None


def io_error(path: Path | str, e: BaseException, what: str = "cannot write") -> WriteError:
    """A one-line WriteError for an OSError while writing ``path`` (disk full, I/O error)."""
    reason = e.strerror if isinstance(e, OSError) and e.strerror else str(e).splitlines()[0] if str(e) else type(e).__name__
    return WriteError(f"{path}: {what} ({reason}); free space or fix the disk, then run again")


def commit_temp(tmp: Path, target: Path, path: Path, what: str, problem=None, *, durable: bool = True) -> None:
    """Put a written temporary in place: ``fsync`` it (``durable``: a write the disk could not
    take fails here, not later), check it is whole by its format (``problem(tmp)``: why it is
    not, or None: image libraries report success when their last buffered write fails on a full
    disk), then rename it over ``target``. ``path``: the name the user gave, for messages.
    Raises ``WriteError`` (and leaves ``tmp`` for the caller to remove) when any step fails."""
    verify_temp(tmp, path, what, problem, durable=durable)
    try:
        os.replace(tmp, target)
    except OSError as e:
        raise io_error(path, e, what) from None


def verify_temp(tmp: Path, path: Path, what: str, problem=None, *, durable: bool = True) -> None:
    """``commit_temp``'s checks without the rename: ``fsync`` (``durable``), then the format's
    own check of the whole file (``problem``)."""
    try:
        if durable:
            fd = os.open(tmp, os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
        why = problem(tmp) if problem is not None else None
    except OSError as e:
        raise io_error(path, e, what) from None
    if why:
        raise WriteError(f"{path}: {what} (the file written is incomplete: {why}; the disk is probably full); "
                         "free space or fix the disk, then run again")


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def stale_temps(folder: Path, names: set[str] | None = None, *, max_age: float = MAX_AGE_S) -> list[Path]:
    """Temporaries in ``folder`` (for the files ``names``, or any) left by a process that is gone,
    or older than ``max_age`` seconds."""
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return []
    now = time.time()
    out = []
    for e in entries:
        m = _TMP.match(e.name) or _OLD_TMP.match(e.name)
        if not m or (names is not None and m.group("name") not in names):
            continue
        try:
            age = now - e.stat(follow_symlinks=False).st_mtime
        except OSError:
            continue
        pid = int(m.group("pid")) if "pid" in m.groupdict() else None
        if m.groupdict().get("host") not in (None, HOST):
            pid = None  # another machine's (a farm sharing the folder): only its age tells
        if age > max_age or (pid is not None and not _alive(pid)):
            out.append(Path(e.path))
    return sorted(out)


def remove_stale_temps(folder: Path, names: set[str] | None = None) -> list[tuple[Path, int]]:
    """Delete the stale temporaries ``stale_temps`` finds; returns (path, bytes) of each removed."""
    removed = []
    for p in stale_temps(folder, names):
        try:
            size = p.stat().st_size
            p.unlink()
        except OSError:
            continue
        removed.append((p, size))
    return removed


def write_text_atomic(path: Path, text: str) -> None:
    """Write ``text`` to a temporary name beside ``path`` and rename it into place."""
    tmp = temp_for(path)
    try:
        tmp.write_text(text)
        os.replace(tmp, path)
    finally:
        if os.path.lexists(tmp):
            tmp.unlink()


def user_cache_dir() -> Path:
    """proxyshade's per-user cache folder, where pip and numba keep theirs:
    ``$XDG_CACHE_HOME/proxyshade``, else ``~/.cache/proxyshade``."""
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache", "proxyshade")


def strip_comments(source: str) -> str:
    """A Python source as its tokens without comments and blank lines: what the code hashes
    read, so editing a comment changes no hash. The source as it is when it does not tokenize."""
    out = []
    try:
        for tok in tokenize.generate_tokens(io.StringIO(source).readline):
            if tok.type not in (tokenize.COMMENT, tokenize.NL):
                out.append(tok.string)
    except (tokenize.TokenError, IndentationError):
        return source
    return " ".join(out)
