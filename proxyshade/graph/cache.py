"""A content-addressed plate store on disk, with an in-memory layer for one run.

Layout: ``<root>/<key[:2]>/<key>.exr`` holds the plate and ``<key>.json`` a small record
(node, type, frame, params, upstream keys, compute time, the EXR's size and sha256).
Both are written to temporary names and renamed into place, the record last, so a killed
write leaves no entry. A truncated or corrupt entry (size or hash mismatch, unreadable
EXR) is reported with a warning and treated as missing, so it is recomputed.

Sink nodes (writers) store a record only: it says which files they wrote.
"""
from __future__ import annotations

import hashlib
import json
import os
import shutil
import threading
import time
import warnings
from concurrent.futures import Future, ThreadPoolExecutor, wait
from pathlib import Path

from proxyshade.graph.plate import Plate
from proxyshade.io.exr import read_plate, write_plate


class CacheWarning(UserWarning):
    pass


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _atomic_write_text(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{threading.get_ident()}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


class Cache:
    """Disk store of plates by key. ``memory`` keeps plates of the current run."""

    def __init__(self, root: str | Path, *, background: bool = True):
        self.root = Path(root)
        self.memory: dict[str, Plate] = {}
        self._lock = threading.Lock()
        # entries are compressed and written on a writer thread while the next nodes compute;
        # ``flush`` waits for them (the engine calls it at the end of every run)
        self._writer = ThreadPoolExecutor(max_workers=1, thread_name_prefix="proxyshade-cache") if background else None
        self._pending: list[Future] = []
        self._pinned: set[str] = set()
        self._forgotten: set[str] = set()

    # -- paths -------------------------------------------------------------
    def _paths(self, key: str) -> tuple[Path, Path]:
        d = self.root / key[:2]
        return d / f"{key}.exr", d / f"{key}.json"

    def record(self, key: str) -> dict | None:
        _, js = self._paths(key)
        try:
            return json.loads(js.read_text())
        except (OSError, ValueError):
            return None

    # -- queries -----------------------------------------------------------
    def has(self, key: str) -> tuple[bool, str]:
        """Whether a usable entry exists; otherwise why not ('missing', 'corrupt ...')."""
        if key in self.memory:
            return True, "in memory"
        rec = self.record(key)
        if rec is None:
            return False, "not in cache"
        if rec.get("sink"):
            missing = [p for p, size in rec.get("files", {}).items() if not Path(p).is_file() or Path(p).stat().st_size != size]
            return (False, "output file missing or changed") if missing else (True, "written before")
        exr, _ = self._paths(key)
        if not exr.is_file() or exr.stat().st_size != rec.get("size"):
            self._warn_corrupt(key, rec, "size mismatch (truncated?)")
            return False, "corrupt cache entry"
        return True, "cache hit"

    def _warn_corrupt(self, key: str, rec: dict | None, why: str) -> None:
        who = f"node {rec.get('node')!r} frame {rec.get('frame')}" if rec else "unknown node"
        warnings.warn(f"cache entry {key[:12]} for {who} is corrupt ({why}); recomputing", CacheWarning, stacklevel=3)

    def load(self, key: str) -> Plate | None:
        """The plate for ``key`` or None when missing/corrupt (after a warning)."""
        with self._lock:
            if key in self.memory:
                return self.memory[key]
        rec = self.record(key)
        exr, _ = self._paths(key)
        if rec is None or not exr.is_file():
            return None
        if _sha256(exr) != rec.get("sha256"):
            self._warn_corrupt(key, rec, "content hash mismatch")
            return None
        try:
            plate = read_plate(exr)
        except Exception as e:  # noqa: BLE001 - any unreadable entry is recomputed
            self._warn_corrupt(key, rec, str(e))
            return None
        with self._lock:
            self.memory[key] = plate
        return plate

    # -- writes ------------------------------------------------------------
    def store(self, key: str, plate: Plate, record: dict) -> None:
        with self._lock:
            self.memory[key] = plate
            self._pinned.add(key)  # kept in memory until written
        if self._writer is None:
            self._write(key, plate, record)
        else:
            self._pending.append(self._writer.submit(self._write, key, plate, record))

    def _write(self, key: str, plate: Plate, record: dict) -> None:
        exr, js = self._paths(key)
        exr.parent.mkdir(parents=True, exist_ok=True)
        try:
            write_plate(exr, plate, extra={"proxyshade/node": str(record.get("node")), "proxyshade/key": key,
                                           "proxyshade/frame": str(record.get("frame"))})
            rec = dict(record, key=key, size=exr.stat().st_size, sha256=_sha256(exr), created=time.time())
            _atomic_write_text(js, json.dumps(rec, sort_keys=True, default=str))
        finally:
            with self._lock:
                self._pinned.discard(key)
                if key in self._forgotten:
                    self._forgotten.discard(key)
                    self.memory.pop(key, None)

    def flush(self) -> None:
        """Wait for every pending write; re-raise the first failure."""
        pending, self._pending = self._pending, []
        wait(pending)  # every write finishes (or fails) before anything is reported
        for f in pending:
            f.result()

    def store_sink(self, key: str, files: list[Path], record: dict) -> None:
        _, js = self._paths(key)
        js.parent.mkdir(parents=True, exist_ok=True)
        rec = dict(record, key=key, sink=True, files={str(p): p.stat().st_size for p in files}, created=time.time())
        _atomic_write_text(js, json.dumps(rec, sort_keys=True, default=str))

    def forget(self, key: str) -> None:
        """Drop a plate from the in-memory layer (the disk entry stays; a plate still being
        written is dropped once written)."""
        with self._lock:
            if key in self._pinned:
                self._forgotten.add(key)
            else:
                self.memory.pop(key, None)

    # -- maintenance -------------------------------------------------------
    def info(self) -> dict:
        n, size = 0, 0
        if self.root.is_dir():
            for p in self.root.glob("*/*.json"):
                n += 1
                size += p.stat().st_size
                exr = p.with_suffix(".exr")
                if exr.is_file():
                    size += exr.stat().st_size
        return {"root": str(self.root), "entries": n, "bytes": size}

    def clean(self) -> int:
        n = self.info()["entries"]
        if self.root.is_dir():
            shutil.rmtree(self.root)
        return n

    # -- per-graph memory of the last run's key components (for --explain) --
    def last_run(self, graph_id: str) -> dict:
        p = self.root / "runs" / f"{graph_id}.json"
        try:
            return json.loads(p.read_text())
        except (OSError, ValueError):
            return {}

    def save_run(self, graph_id: str, components: dict) -> None:
        p = self.root / "runs" / f"{graph_id}.json"
        p.parent.mkdir(parents=True, exist_ok=True)
        old = self.last_run(graph_id)
        old.update(components)
        _atomic_write_text(p, json.dumps(old, sort_keys=True, default=str))
