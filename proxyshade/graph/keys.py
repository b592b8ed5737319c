"""Cache keys: computed top-down from declarations, never from pixels.

key = sha256 of the canonical JSON of
  node type, version, code hash (the node's module and the proxyshade.kernels modules it
  uses, comments stripped), hashed parameters, upstream keys by input name, the frame
  (only when the node depends on time), the content hashes of the files its Path
  parameters name, and the node's ``key_extra``. A sequence input's upstream keys are the
  list of its frames' keys, so changing one frame changes the key.

The components are kept so ``--explain`` can say which one changed.
"""
from __future__ import annotations

import functools
import hashlib
import inspect
import io
import json
import sys
import tokenize
import types
from pathlib import Path
from typing import Any


def canonical(obj: Any) -> str:
    """Canonical JSON (sorted keys, no spaces): equal values give equal strings."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), default=str)


def digest(obj: Any) -> str:
    return hashlib.sha256(canonical(obj).encode()).hexdigest()


def _strip_comments(source: str) -> str:
    out = []
    try:
        for tok in tokenize.generate_tokens(io.StringIO(source).readline):
            if tok.type not in (tokenize.COMMENT, tokenize.NL):
                out.append(tok.string)
    except (tokenize.TokenError, IndentationError):
        return source
    return " ".join(out)


@functools.lru_cache(maxsize=None)
def module_hash(module_name: str) -> str:
    mod = sys.modules[module_name]
    try:
        src = inspect.getsource(mod)
    except (OSError, TypeError):
        return "nosource"
    return hashlib.sha256(_strip_comments(src).encode()).hexdigest()


def used_kernel_modules(module: types.ModuleType) -> list[str]:
    """proxyshade.kernels modules a node module uses: imported as modules or via functions."""
    names = set()
    for v in vars(module).values():
        mod_name = v.__name__ if isinstance(v, types.ModuleType) else getattr(v, "__module__", None)
        if isinstance(mod_name, str) and mod_name.startswith("proxyshade.kernels.") and mod_name in sys.modules:
            names.add(mod_name)
    return sorted(names)


def _kernel_closure(name: str, seen: set[str]) -> None:
    if name in seen:
        return
    seen.add(name)
    for dep in used_kernel_modules(sys.modules[name]):
        _kernel_closure(dep, seen)


def code_hash(node_cls: type) -> str:
    """Hash of a node type's implementation: its module and the kernels it (transitively) uses."""
    mod = sys.modules[node_cls.__module__]
    seen: set[str] = set()
    for dep in used_kernel_modules(mod):
        _kernel_closure(dep, seen)
    parts = [(node_cls.__module__, module_hash(node_cls.__module__))]
    parts += [(m, module_hash(m)) for m in sorted(seen)]
    return digest(parts)


@functools.lru_cache(maxsize=4096)
def _file_hash_cached(path: str, size: int, mtime_ns: int) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def file_hash(path: Path) -> str:
    """Content hash of a file (memoised on size and mtime: a touch does not change the key)."""
    try:
        st = path.stat()
    except OSError:
        return "missing"
    return _file_hash_cached(str(path), st.st_size, st.st_mtime_ns)


def make_key(components: dict) -> str:
    return digest(components)


def _input_change(name: str, old: Any, new: Any) -> str:
    """'image' for a one-frame input; for a sequence input (a list of keys, one per frame)
    how many frames changed: 'image: 2 of 30 frames' or 'image: 29 -> 30 frames'."""
    if not (isinstance(old, list) and isinstance(new, list)):
        return name
    if len(old) != len(new):
        return f"{name}: {len(old)} -> {len(new)} frames"
    return f"{name}: {sum(a != b for a, b in zip(old, new))} of {len(new)} frames"


def diff_components(old: dict | None, new: dict) -> str:
    """Why a key changed, in words: 'new params (k: 5 -> 3)', 'new input (proxy)', ..."""
    if not old:
        return "not computed before"
    reasons = []
    if old.get("type") != new.get("type"):
        reasons.append("new node type")
    if old.get("version") != new.get("version") or old.get("code") != new.get("code"):
        reasons.append("new code")
    op, np_ = old.get("params", {}), new.get("params", {})
    changed = [k for k in sorted(set(op) | set(np_)) if op.get(k) != np_.get(k)]
    if changed:
        reasons.append("new params (" + ", ".join(f"{k}: {op.get(k)!r} -> {np_.get(k)!r}" for k in changed) + ")")
    oi, ni = old.get("inputs", {}), new.get("inputs", {})
    changed = [_input_change(k, oi.get(k), ni.get(k)) for k in sorted(set(oi) | set(ni)) if oi.get(k) != ni.get(k)]
    if changed:
        reasons.append("new input (" + ", ".join(changed) + ")")
    if old.get("files") != new.get("files"):
        reasons.append("new file content")
    if old.get("extra") != new.get("extra"):
        reasons.append("new scene content")
    if old.get("frame") != new.get("frame"):
        reasons.append("new frame")
    return "; ".join(reasons) or "not in cache"
