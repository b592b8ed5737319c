"""A content-addressed plate store on disk, with an in-memory layer for one run.

Layout: ``<root>/<key[:2]>/<key>.exr`` holds the plate (ZSTD-compressed where OpenEXR has
it, else ZIP; entries of either codec are read) and ``<key>.json`` a small record
(its key, node, type, frame, params, upstream keys, compute time, the EXR's size and
sha256); the EXR's header carries the key too (``proxyshade/key``). Both are written to
temporary names and renamed into place, the record last, so a killed write leaves no
entry; the renames happen under an exclusive lock of the shard folder and the first writer
wins (an intact entry stored meanwhile by another process is kept), so processes sharing
the folder (Dask workers) never mix two writers' files in one entry. An entry is used only when its record is a JSON object naming the key asked for,
its size matches, and (when loaded) its sha256 and header key match: anything else (a
truncated file, another entry's files copied under the key, a damaged record) is reported
with a warning and recomputed.

Sink nodes (writers) store a record only: the files they wrote with each file's size and
sha256, so a re-run is a hit only while every file still holds what was written.

A read-only cache (a render farm's shared one) serves its hits; what a run computes is
kept in memory only, with a note. Temporaries of killed runs are removed by
``remove_stale_temps`` (the engine calls it at the start of every run) and counted by
``info``.
"""
from __future__ import annotations

import atexit
import contextlib
import fcntl
import hashlib
import json
import os
import re
import threading
import time
import warnings
import weakref
from concurrent.futures import Future, ThreadPoolExecutor, wait
from pathlib import Path

from proxyshade.errors import UserError, WriteError
from proxyshade.graph import profile as _profile
from proxyshade.graph.plate import Plate
from proxyshade.io.exr import cache_compression, header_strings, read_channels, read_plate, write_plate_temp
from proxyshade.io.files import READ_ONLY, io_error, remove_stale_temps, stale_temps, temp_of, write_text_atomic


class CacheWarning(UserWarning):
    pass


LIMIT_ENV = "PROXYSHADE_CACHE_LIMIT"
# the tag every plate cache holds at its root (the Cache Directory Tagging Specification, which
# backup tools honour): 'cache clean' empties only a folder that has it (or that holds nothing
# but entries, as caches of versions before it did), so a wrong --cache never deletes a folder
MARKER = "CACHEDIR.TAG"
MARKER_TEXT = ("Signature: 8a477f597d28d172789f06886806bc55\n"
               "# This folder is a proxyshade plate cache: 'proxyshade cache clean' empties it.\n"
               "# For information about cache directory tags see https://bford.info/cachedir/\n")
_SHARD = re.compile(r"[0-9a-f]{2}")
_ENTRY = re.compile(r"[0-9a-f]{64}\.(?:exr|json)")
DEFAULT_LIMIT = 20 * 2**30  # bytes: 20 GiB
_SIZE = re.compile(r"(\d+(?:\.\d*)?)\s*([kmgt]?)(?:i?b)?", re.IGNORECASE)


def size_limit() -> int:
    """The plate cache's size past which a run warns (bytes; 0: never): ``$PROXYSHADE_CACHE_LIMIT``
    (``20G``, ``500M``, ``1.5T``, a number of bytes; binary units), default 20 GiB."""
    text = os.environ.get(LIMIT_ENV, "").strip()
    if not text:
        return DEFAULT_LIMIT
    m = _SIZE.fullmatch(text)
    if not m:
        raise UserError(f"{LIMIT_ENV}={text}: not a size; set it like 20G, 500M or 0 (no warning)")
    return int(float(m[1]) * 1024 ** " KMGT".index(m[2].upper() or " "))


def size_text(n: int) -> str:
    """Bytes in binary units, for messages: '2.4 GiB', '312.0 MiB', '1.0 KiB'."""
    for unit, scale in (("TiB", 2**40), ("GiB", 2**30), ("MiB", 2**20)):
        if n >= scale:
            return f"{n / scale:.1f} {unit}"
    return f"{n / 1024:.1f} KiB"


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _read_only(e: BaseException) -> bool:
    """Whether a failed write means the cache cannot be written at all (read-only)."""
    while e is not None and not isinstance(e, OSError):
        e = e.__cause__ or e.__context__
    return e is not None and e.errno in READ_ONLY


def _yield_cpu() -> None:
    """The writer thread runs at a lower CPU priority (nice + 10, Linux threads have their
    own): it encodes while a core is free (a node's Python steps, imports, the writers)
    instead of taking one from a parallel kernel; ``flush`` waits for what is left."""
    try:
        tid = threading.get_native_id()
        os.setpriority(os.PRIO_PROCESS, tid, min(19, os.getpriority(os.PRIO_PROCESS, tid) + 10))
    except (OSError, AttributeError):
        pass


_WRITERS: "weakref.WeakSet[ThreadPoolExecutor]" = weakref.WeakSet()  # every live cache's writer


@atexit.register
def _finish_writes() -> None:
    """At exit, each cache's writer finishes the entry it is writing (renamed into place, or
    its temporary removed) and drops the queued ones. The interpreter's own shutdown does
    this for thread pools; the console script's fast exit (``cli._exit_now``) runs only the
    ``atexit`` functions, so a Ctrl-C during a write would otherwise leave a temporary."""
    for writer in list(_WRITERS):
        writer.shutdown(wait=True, cancel_futures=True)


class Cache:
    """Disk store of plates by key. ``memory`` keeps plates of the current run."""

    def __init__(self, root: str | Path, *, background: bool = True):
        self.root = Path(root)
        self.memory: dict[str, Plate] = {}
        self._lock = threading.Lock()
        # entries are compressed and written on a writer thread while the next nodes compute;
        # ``flush`` waits for them (the engine calls it at the end of every run)
        self._writer = ThreadPoolExecutor(max_workers=1, thread_name_prefix="proxyshade-cache",
                                          initializer=_yield_cpu) if background else None
        if self._writer is not None:
            _WRITERS.add(self._writer)
        self._pending: list[Future] = []
        self._writing: dict[str, Future] = {}  # key -> its background write, until done
        self._pinned: set[str] = set()
        self._forgotten: set[str] = set()
        # key -> (size, inode, ns mtime) of an entry this process wrote or checked whole (``usable``)
        self._trusted: dict[str, tuple[int, int, int]] = {}
        self._marked = False  # the root's MARKER is known to be there
        self.read_only = False  # set when a write fails with EROFS/EACCES: hits are served, results kept in memory
        self.unstored = 0  # results of this process not stored because the cache is read-only

    # -- paths -------------------------------------------------------------
    def _paths(self, key: str) -> tuple[Path, Path]:
        d = self.root / key[:2]
        return d / f"{key}.exr", d / f"{key}.json"

    def record(self, key: str) -> dict | None:
        """The entry's record, or None when missing or not a JSON object."""
        _, js = self._paths(key)
        try:
            rec = json.loads(js.read_text())
        except (OSError, ValueError, RecursionError):  # RecursionError: a record of deeply nested brackets
            return None
        return rec if isinstance(rec, dict) else None

    # -- queries -----------------------------------------------------------
    def has(self, key: str) -> tuple[bool, str]:
        """Whether a usable entry exists; otherwise why not ('not in cache', 'corrupt ...')."""
        if key in self.memory:
            return True, "in memory"
        _, js = self._paths(key)
        rec = self.record(key)
        if rec is None:
            if js.exists():
                self._warn_corrupt(key, None, "its record is not a JSON object")
                return False, "corrupt cache entry (record)"
            return False, "not in cache"
        if rec.get("key") != key:
            self._warn_corrupt(key, rec, f"its record is for key {str(rec.get('key'))[:12]}")
            return False, "corrupt cache entry (record of another key)"
        if rec.get("sink"):
            why = _sink_files_problem(rec.get("files"))
            return (False, f"output {why}") if why else (True, "written before")
        exr, _ = self._paths(key)
        if not exr.is_file() or exr.stat().st_size != rec.get("size"):
            self._warn_corrupt(key, rec, "size mismatch (truncated?)")
            return False, "corrupt cache entry (size)"
        return True, "cache hit"

    def _warn_corrupt(self, key: str, rec: dict | None, why: str) -> None:
        who = f"node {rec.get('node')!r} frame {rec.get('frame')}" if rec else "unknown node"
        warnings.warn(f"cache entry {key[:12]} for {who} is corrupt ({why}); recomputing", CacheWarning, stacklevel=3)

    def load(self, key: str) -> Plate | None:
        """The plate for ``key`` or None when missing/corrupt (after a warning)."""
        with self._lock:
            if key in self.memory:
                return self.memory[key]
        problem = self.load_problem(key)
        if problem is not None:
            return None
        with self._lock:
            return self.memory[key]

    def load_problem(self, key: str) -> str | None:
        """Load the entry into memory; None when it loaded, else why not ('not in cache',
        'corrupt cache entry (content hash)', ...), after a warning for a corrupt one."""
        with self._lock:
            if key in self.memory:
                return None
        rec = self.record(key)
        exr, _ = self._paths(key)
        if rec is None or not exr.is_file():
            return "not in cache"
        if rec.get("key") != key:
            self._warn_corrupt(key, rec, f"its record is for key {str(rec.get('key'))[:12]}")
            return "corrupt cache entry (record of another key)"
        if _sha256(exr) != rec.get("sha256"):
            self._warn_corrupt(key, rec, "content hash mismatch")
            return "corrupt cache entry (content hash)"
        try:
            plate = read_plate(exr, expect={"proxyshade/key": key})
        except Exception as e:  # noqa: BLE001 - any unreadable entry is recomputed
            self._warn_corrupt(key, rec, str(e))
            return "corrupt cache entry (unreadable)"
        with self._lock:
            self.memory[key] = plate
        return None

    # -- writes ------------------------------------------------------------
    def store(self, key: str, plate: Plate, record: dict, *, replace: bool = False) -> None:
        """Keep ``plate`` in memory and write its entry (on the writer thread when in the
        background). An intact entry stored meanwhile by another process is kept unless
        ``replace`` (a forced recompute)."""
        with self._lock:
            self.memory[key] = plate
            self._pinned.add(key)  # kept in memory until written
        if self._writer is None:
            self._write(key, plate, record, replace)
        else:
            fut = self._writer.submit(self._write, key, plate, record, replace)
            self._pending.append(fut)
            self._writing[key] = fut
            fut.add_done_callback(lambda f, k=key: self._writing.pop(k, None))

    def writing(self, key: str) -> Future | None:
        """The background write of ``key`` while it is not done (None once done, or never begun)."""
        return self._writing.get(key)

    def _write(self, key: str, plate: Plate, record: dict, replace: bool = False) -> None:
        exr, js = self._paths(key)
        tmp = None
        t = time.perf_counter()
        if _profile.ACTIVE is not None:
            _profile.ACTIVE.cache_write_start(record.get("node"), record.get("frame"))
        try:
            if self.read_only:
                self.unstored += 1
                return
            self._mark()
            # ZSTD: the writer thread competes with the nodes for the cores, and at 4K ZIP cost it
            # ~3.6 CPU s per 15-channel plate (ZSTD 2.1 s, and 40 % smaller files to hash). Checked
            # whole, not fsync'd: every load checks an entry's size and sha256 (a write the disk
            # lost later is recomputed), where an output has no such reader
            tmp = write_plate_temp(exr, plate, compression=cache_compression(), what="cannot write cache entry",
                                   durable=False, extra={"proxyshade/node": str(record.get("node")),
                                                         "proxyshade/key": key,
                                                         "proxyshade/frame": str(record.get("frame"))})
            rec = dict(record, key=key, size=tmp.stat().st_size, sha256=_sha256(tmp), created=time.time())
            self._publish(key, tmp, rec, replace)
        except (OSError, WriteError) as e:
            if not _read_only(e):
                raise e if isinstance(e, WriteError) else io_error(exr, e, "cannot write cache entry") from None
            self.read_only = True
            self.unstored += 1
        finally:
            if tmp is not None and os.path.lexists(tmp):
                tmp.unlink()
            if _profile.ACTIVE is not None:
                _profile.ACTIVE.cache_write(record.get("node"), record.get("frame"), time.perf_counter() - t)
            with self._lock:
                self._pinned.discard(key)
                if key in self._forgotten:
                    self._forgotten.discard(key)
                    self.memory.pop(key, None)

    def _publish(self, key: str, tmp: Path, rec: dict, replace: bool) -> None:
        """Rename a written EXR and its record into place under the shard's lock: the first
        writer wins (an intact entry another process stored meanwhile is kept, ours dropped:
        same key, same plate), so an entry's EXR and record always come from one writer."""
        exr, js = self._paths(key)
        with _shard_lock(exr.parent):
            if not replace and self.intact(key):
                return
            os.replace(tmp, exr)
            try:
                self._write_record(js, rec)
            except BaseException:  # no EXR without its record
                with contextlib.suppress(OSError):
                    exr.unlink()
                raise
            st = exr.stat()
            self._trusted[key] = (st.st_size, st.st_ino, st.st_mtime_ns)

    def usable(self, key: str) -> bool:
        """Whether ``key`` has an entry on disk to read channels back from (``read_back``):
        quietly, without hashing an entry this process wrote or already checked and nobody
        touched since (same size, inode and ns modification time); any other is checked as
        ``intact`` does, once (the engine asks before it offers a read-back, ``read_back``
        again when it reads)."""
        rec = self.record(key)
        exr, _ = self._paths(key)
        if rec is None or rec.get("key") != key or rec.get("sink"):
            return False
        try:
            st = exr.stat()
        except OSError:
            return False
        seen = (st.st_size, st.st_ino, st.st_mtime_ns)
        if self._trusted.get(key) == seen:
            return True
        if not self.intact(key):
            return False
        self._trusted[key] = seen  # as it was before the hash: a later change has another stat
        return True

    def read_back(self, key: str, names: list[str]) -> dict | None:
        """Channels ``names`` of ``key``'s entry, read again from disk and not kept in memory
        (a node that let them go while it needed the memory: ``Context.read_back``), the
        arrays a load gives; None where the entry is not ``usable`` or cannot be read."""
        if not self.usable(key):
            return None
        try:
            return read_channels(self._paths(key)[0], names, expect={"proxyshade/key": key})
        except Exception:  # noqa: BLE001 - unreadable: the caller says so
            return None

    def intact(self, key: str) -> bool:
        """Whether a whole entry is stored under ``key``: its record names it, the EXR's size
        and sha256 are the record's and its header names the key (quietly: no warning). Runs
        on the writer thread: the header is read in Python (``header_strings``), not through
        an image library."""
        rec = self.record(key)
        exr, _ = self._paths(key)
        try:
            return (rec is not None and rec.get("key") == key and not rec.get("sink")
                    and exr.stat().st_size == rec.get("size") and _sha256(exr) == rec.get("sha256")
                    and header_strings(exr, ("proxyshade/key",)).get("proxyshade/key") == key)
        except Exception:  # noqa: BLE001 - unreadable: not intact
            return False

    def _write_record(self, js: Path, rec: dict) -> None:
        try:
            write_text_atomic(js, json.dumps(rec, sort_keys=True, default=str))
        except OSError as e:
            if _read_only(e):
                raise
            raise io_error(js, e, "cannot write cache record") from None

    def _mark(self) -> None:
        """Tag the root as a proxyshade cache (``MARKER``) before anything is written into it."""
        if self._marked:
            return
        tag = self.root / MARKER
        if not tag.is_file():
            self.root.mkdir(parents=True, exist_ok=True)
            write_text_atomic(tag, MARKER_TEXT)
        self._marked = True

    def flush(self) -> None:
        """Wait for every pending write; re-raise the first failure."""
        pending, self._pending = self._pending, []
        wait(pending)  # every write finishes (or fails) before anything is reported
        for f in pending:
            f.result()

    def store_sink(self, key: str, files: list[Path], record: dict) -> None:
        """Record the files a writer wrote, with each file's size and sha256."""
        _, js = self._paths(key)
        rec = dict(record, key=key, sink=True, created=time.time(), files={str(p): _file_state(p) for p in files})
        if self.read_only:
            self.unstored += 1
            return
        try:
            self._mark()
            js.parent.mkdir(parents=True, exist_ok=True)
            self._write_record(js, rec)
        except OSError as e:
            if not _read_only(e):
                raise io_error(js, e, "cannot write cache record") from None
            self.read_only = True
            self.unstored += 1

    def forget(self, key: str) -> None:
        """Drop a plate from the in-memory layer (the disk entry stays; a plate still being
        written is dropped once written)."""
        with self._lock:
            if key in self._pinned:
                self._forgotten.add(key)
            else:
                self.memory.pop(key, None)

    # -- maintenance -------------------------------------------------------
    def _folders(self) -> list[Path]:
        if not self.root.is_dir():
            return []
        return sorted(p for p in self.root.iterdir() if p.is_dir())

    def info(self) -> dict:
        """Entries and bytes, and the temporaries of killed runs (``stale``: removable now)."""
        n, size, temps, temp_bytes, stale = 0, 0, 0, 0, 0
        for d in self._folders():
            stale_here = set(stale_temps(d))
            for p in d.iterdir():
                try:
                    if p.name.startswith(".") and ".tmp" in p.name:
                        temp_bytes += p.stat().st_size
                        temps += 1
                        stale += p in stale_here
                    elif p.suffix == ".json" and d.name != "runs":
                        size += p.stat().st_size
                        n += 1
                        exr = p.with_suffix(".exr")
                        if exr.is_file():
                            size += exr.stat().st_size
                except FileNotFoundError:  # removed by a run meanwhile
                    continue
        return {"root": str(self.root), "entries": n, "bytes": size, "temps": temps, "temp_bytes": temp_bytes,
                "stale_temps": stale}

    def size(self) -> int:
        """Bytes of every file in the cache (entries, records, temporaries), read from the
        folders' listings: quick enough after every run that computed."""
        total = 0
        for d in self._folders():
            try:
                with os.scandir(d) as it:
                    for e in it:
                        try:
                            total += e.stat(follow_symlinks=False).st_size
                        except FileNotFoundError:
                            continue
            except OSError:
                continue
        return total

    def over_limit(self) -> str | None:
        """A one-line warning when the cache holds more than ``size_limit()``, else None."""
        limit = size_limit()
        if not limit:
            return None
        n = self.size()
        if n <= limit:
            return None
        return (f"cache {self.root} holds {size_text(n)}, over its limit of {size_text(limit)}: 'proxyshade cache clean' "
                f"empties it (the next runs recompute what they need), or set {LIMIT_ENV} (e.g. 50G, 0 for no "
                "warning)")

    def remove_stale_temps(self) -> list[tuple[Path, int]]:
        """Delete temporaries left by killed runs (their process is gone, or a day old): in
        the entry folders, and the root's ``MARKER`` written by a run killed as it tagged the
        folder."""
        removed = remove_stale_temps(self.root, {MARKER}) if self.root.is_dir() else []
        for d in self._folders():
            removed += remove_stale_temps(d)
        return removed

    def marked(self) -> bool:
        """Whether the root holds a proxyshade cache's ``MARKER``."""
        try:
            text = (self.root / MARKER).read_text(errors="replace")
        except OSError:
            return False
        return text.startswith(MARKER_TEXT.splitlines()[0]) and "proxyshade" in text

    def _contents(self) -> tuple[list[Path], list[Path], list[Path]]:
        """What ``clean`` would remove: (files, folders), and what it does not recognise as the
        cache's (anything but shard folders of entries, locks and temporaries, run records and
        the marker). Symlinks are never followed."""
        files, folders, foreign = [], [], []
        for p in sorted(self.root.iterdir()):
            if p.name == MARKER and p.is_file() and not p.is_symlink():
                continue  # removed last
            if temp_of(p.name) == MARKER and p.is_file() and not p.is_symlink():
                files.append(p)
                continue
            if p.is_symlink() or not p.is_dir() or not (_SHARD.fullmatch(p.name) or p.name == "runs"):
                foreign.append(p)
                continue
            mine = _ENTRY if p.name != "runs" else re.compile(r"[0-9a-f]{16}\.json")
            ok = True
            for q in sorted(p.iterdir()):
                made_for = temp_of(q.name)
                if (q.is_symlink() or not q.is_file()) or not (
                        mine.fullmatch(q.name) or q.name == ".lock" or (made_for and mine.fullmatch(made_for))):
                    foreign.append(q)
                    ok = False
                else:
                    files.append(q)
            if ok:
                folders.append(p)
        return files, folders, foreign

    def clean(self, where: str | None = None) -> int:
        """Remove every entry, run record and temporary (and the marker, and the folders left
        empty); returns the entries removed. Refuses (``UserError``, nothing removed) a folder
        that is not a proxyshade cache: no ``MARKER`` and something there that is not an entry
        (``where``: how the user named the folder, for the message). In a marked cache, files
        it does not recognise are left where they are."""
        label = where or str(self.root)
        if not os.path.lexists(self.root):
            return 0
        if self.root.is_symlink() or not self.root.is_dir():
            raise UserError(f"{label}: not a folder, so not a proxyshade plate cache; nothing removed: name the "
                            "cache folder (proxyshade cache info shows it)")
        files, folders, foreign = self._contents()
        if foreign and not self.marked():
            raise UserError(f"{label}: not a proxyshade plate cache (no {MARKER}, and it holds "
                            f"{str(foreign[0].relative_to(self.root))[:80]!r}); nothing removed: name the cache folder "
                            "(proxyshade cache info shows it)")
        n = sum(p.suffix == ".json" and p.parent.name != "runs" and not p.name.startswith(".") for p in files)
        for p in files:
            with contextlib.suppress(FileNotFoundError):
                p.unlink()
        for d in folders:
            with contextlib.suppress(OSError):
                d.rmdir()
        if not foreign:
            for step in ((self.root / MARKER).unlink, self.root.rmdir):
                with contextlib.suppress(OSError):
                    step()
        return n

    # -- per-graph memory of the last run's key components (for --explain) --
    def last_run(self, graph_id: str) -> dict:
        p = self.root / "runs" / f"{graph_id}.json"
        try:
            rec = json.loads(p.read_text())
        except (OSError, ValueError, RecursionError):
            return {}
        return rec if isinstance(rec, dict) else {}

    def save_run(self, graph_id: str, components: dict) -> None:
        """Remember the key components of a run (for --explain); skipped when nothing changed
        or the cache is read-only."""
        old = self.last_run(graph_id)
        new = dict(old, **components)
        if self.read_only or json.loads(json.dumps(new, sort_keys=True, default=str)) == old:
            return
        p = self.root / "runs" / f"{graph_id}.json"
        try:
            self._mark()
            p.parent.mkdir(parents=True, exist_ok=True)
            write_text_atomic(p, json.dumps(new, sort_keys=True, default=str))
        except OSError as e:
            if not _read_only(e):
                raise io_error(p, e, "cannot write the run record") from None
            self.read_only = True


@contextlib.contextmanager
def _shard_lock(folder: Path):
    """An exclusive lock on one shard folder of the cache (``flock`` on its ``.lock`` file),
    between the threads and processes of every machine that shares the folder."""
    fd = os.open(folder / ".lock", os.O_RDWR | os.O_CREAT, 0o666)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # releases the lock


def _file_state(path: Path) -> dict:
    """What a writer records of a file it wrote: size and sha256, and the stat that lets a re-run
    skip hashing a file nobody touched (same size, inode and modification time to the ns)."""
    st = path.stat()
    return {"size": st.st_size, "sha256": _sha256(path), "mtime_ns": st.st_mtime_ns, "ino": st.st_ino}


def _sink_files_problem(files) -> str | None:
    """Why a writer's recorded files no longer hold what it wrote, or None."""
    if not isinstance(files, dict) or not files:
        return "record has no files"
    for p, want in files.items():
        path = Path(p)
        if not isinstance(want, dict):
            return f"record of {path.name} has no content hash"
        try:
            st = path.stat()
        except OSError:
            st = None
        if st is None or not path.is_file():
            return f"file missing: {path.name}"
        if st.st_size != want.get("size"):
            return f"file changed since written: {path.name}"
        untouched = st.st_mtime_ns == want.get("mtime_ns") and st.st_ino == want.get("ino")
        if not untouched and _sha256(path) != want.get("sha256"):
            return f"file changed since written: {path.name}"
    return None
