"""Cache keys: computed top-down from declarations, never from pixels.

key = sha256 of the canonical JSON of
  node type, version, code hash (the source of the node's module and of every proxyshade
  module it reaches through imports at any level, comments stripped: ``import_closure``,
  and the versions of numpy, numba, OpenEXR, colour-science and usd-core, also kept as
  the ``libraries`` component so ``--explain`` names them), hashed parameters, upstream keys by input name, the frame
  (only when the node depends on time), the content hashes of the files its Path
  parameters name, and the node's ``key_extra``. A sequence input's upstream keys are the
  list of its frames' keys, so changing one frame changes the key.

The components are kept so ``--explain`` can say which one changed.
"""
from __future__ import annotations

import ast
import atexit
import functools
import hashlib
import importlib.util
import inspect
import json
import os
import sys
import threading
from pathlib import Path
from typing import Any, Callable

from proxyshade.io.files import strip_comments as _strip_comments, user_cache_dir


def canonical(obj: Any) -> str:
    """Canonical JSON (sorted keys, no spaces): equal values give equal strings."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), default=str)


def digest(obj: Any) -> str:
    return hashlib.sha256(canonical(obj).encode()).hexdigest()


@functools.lru_cache(maxsize=None)  # per process, as ``import_closure`` and ``module_hash``
def module_file(module_name: str, root: Path | None = None) -> Path | None:
    """The source file of a module: under ``root`` (a folder holding the ``proxyshade``
    package) when given, else where Python imports it from; None when it has none. Never
    imports anything: a ``proxyshade`` module not imported yet is looked up beside the
    imported package (``find_spec`` would import its parent, a kernel module and numba)."""
    if root is None and module_name.split(".")[0] == "proxyshade" and module_name not in sys.modules:
        root = Path(sys.modules["proxyshade"].__file__).parent.parent
    if root is not None:
        base = Path(root, *module_name.split("."))
        for cand in (base.with_suffix(".py"), base / "__init__.py"):
            if cand.is_file():
                return cand
        return None
    mod = sys.modules.get(module_name)
    origin = getattr(mod, "__file__", None) if mod is not None else None
    if origin is None:
        try:
            spec = importlib.util.find_spec(module_name)
        except (ImportError, ValueError):
            return None
        origin = spec.origin if spec is not None else None
    return Path(origin) if origin and origin.endswith(".py") else None


def _is_module(name: str, root: Path | None) -> bool:
    return module_file(name, root) is not None


def _raw_imports(source: str) -> list:
    """The import statements of ``source`` at every level, as plain data: ``[0, name, []]``
    for ``import name``, ``[level, module, [names]]`` for ``from ...module import names``."""
    out = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            out += [[0, a.name, []] for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            out.append([node.level, node.module or "", [a.name for a in node.names]])
    return out


def _resolve(raw: list, module_name: str, is_package: bool, root: Path | None) -> set[str]:
    package = module_name if is_package else module_name.rpartition(".")[0]
    found: set[str] = set()
    for level, module, names in raw:
        if level:
            parts = package.split(".")
            base = ".".join(parts[:len(parts) - level + 1])
            base = f"{base}.{module}" if module else base
        else:
            base = module
        if base.split(".")[0] != "proxyshade":
            continue
        if not names:  # import a.b.c
            found.add(base)
        for n in names:
            sub = f"{base}.{n}"
            found.add(sub if n != "*" and _is_module(sub, root) else base)
    return {m for m in found if _is_module(m, root)}


def imported_modules(source: str, module_name: str, is_package: bool, root: Path | None = None) -> set[str]:
    """``proxyshade`` modules imported anywhere in ``source`` (module level, inside functions
    or classes, relative or absolute). ``from pkg import mod`` names ``pkg.mod``;
    ``from pkg import name`` (a name defined in the package) names ``pkg`` itself. A
    package is not counted merely for holding an imported module: what its
    ``__init__`` defines is used only when imported by name."""
    return _resolve(_raw_imports(source), module_name, is_package, root)


# What a source file says (its comment-stripped hash, its import statements) is kept on
# disk between processes, keyed by the file's path and stat signature (size, mtime, ctime,
# inode: any edit changes it): a run of a fully cached graph does not parse every module
# again. Only the files of this checkout of the package are kept, in a file named after
# this module's own source and the checkout's folder; other roots (a test's edited copy)
# are kept in memory only, so the file stays small and quick to read. Deleted files are
# dropped when it is written. Unwritable: kept in memory only.
_FACTS: dict | None = None
_FACTS_DIRTY = False
_FACTS_LOCK = threading.Lock()
_OWN_ROOT = str(Path(__file__).resolve().parents[1]) + os.sep  # .../proxyshade/


def _user_cache() -> Path:
    """The per-user folder of the code facts and the file-bound memos."""
    return Path(os.environ.get("PROXYSHADE_CODE_CACHE") or user_cache_dir())


def _facts_path() -> Path:
    me = hashlib.sha256(Path(__file__).read_bytes()).hexdigest()[:16]
    where = hashlib.sha256(_OWN_ROOT.encode()).hexdigest()[:12]
    return _user_cache() / f"code-facts-{me}-{where}.json"


def _save_facts() -> None:
    if not _FACTS_DIRTY or _FACTS is None:
        return
    keep = {k: v for k, v in _FACTS.items() if k.startswith(_OWN_ROOT) and os.path.exists(k)}
    try:
        path = _facts_path()
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        tmp.write_text(json.dumps(keep))
        os.replace(tmp, path)
    except OSError:
        pass


def _file_facts(path: Path) -> dict:
    """{'sha': comment-stripped source hash, 'imports': _raw_imports} of a source file."""
    global _FACTS, _FACTS_DIRTY
    st = path.stat()
    sig = [st.st_size, st.st_mtime_ns, st.st_ctime_ns, st.st_ino]
    key = str(path.resolve())
    with _FACTS_LOCK:
        if _FACTS is None:
            try:
                _FACTS = json.loads(_facts_path().read_text())
                if not isinstance(_FACTS, dict):
                    _FACTS = {}
            except (OSError, ValueError):
                _FACTS = {}
            atexit.register(_save_facts)
        hit = _FACTS.get(key)
        if isinstance(hit, dict) and hit.get("sig") == sig:
            return hit
    src = path.read_text(encoding="utf-8")
    facts = {"sig": sig, "sha": hashlib.sha256(_strip_comments(src).encode()).hexdigest(),
             "imports": _raw_imports(src)}
    with _FACTS_LOCK:
        _FACTS[key] = facts
        _FACTS_DIRTY = _FACTS_DIRTY or key.startswith(_OWN_ROOT)
    return facts


def module_source(module_name: str, root: Path | None = None) -> str:
    path = module_file(module_name, root)
    if path is None:
        mod = sys.modules.get(module_name)
        try:
            return inspect.getsource(mod) if mod is not None else ""
        except (OSError, TypeError):
            return ""
    return path.read_text(encoding="utf-8")


@functools.lru_cache(maxsize=None)
def module_hash(module_name: str, root: Path | None = None) -> str:
    """sha256 of a module's source with comments stripped ('nosource' when it has none)."""
    path = module_file(module_name, root)
    if path is not None:
        return _file_facts(path)["sha"]
    src = module_source(module_name, root)
    return hashlib.sha256(_strip_comments(src).encode()).hexdigest() if src else "nosource"


@functools.lru_cache(maxsize=None)
def import_closure(module_name: str, root: Path | None = None) -> tuple[str, ...]:
    """Every ``proxyshade`` module ``module_name`` reaches through imports at any level,
    itself included, sorted: read from the sources (the import graph), not from names in
    a namespace, so a helper module, an io module or a kernel imported inside a function
    is covered."""
    seen: set[str] = set()
    todo = [module_name]
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        path = module_file(name, root)
        if path is not None:
            raw = _file_facts(path)["imports"]
        else:
            src = module_source(name, root)
            raw = _raw_imports(src) if src else []
        is_pkg = path is not None and path.name == "__init__.py"
        todo.extend(_resolve(raw, name, is_pkg, root) - seen)
    return tuple(sorted(seen))


# Libraries whose version can change a result (numerics, EXR encoding, colour maths, USD
# composition): their installed versions are part of every node's code version.
LIBRARIES = ("numpy", "numba", "OpenEXR", "colour-science", "usd-core")


@functools.lru_cache(maxsize=1)
def library_versions() -> dict[str, str | None]:
    """The installed version of each of ``LIBRARIES`` (None where not installed), read from
    the packages' metadata: nothing is imported."""
    from importlib import metadata

    out = {}
    for name in LIBRARIES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = None
    return out


def code_hash(node_cls: type, root: Path | None = None) -> str:
    """Hash of a node type's implementation: the source of its module and of every
    ``proxyshade`` module it reaches through imports (``import_closure``), and the versions
    of the libraries that change results (``library_versions``). ``root`` reads the package
    from another folder (tests edit a copy)."""
    mods = import_closure(node_cls.__module__, root)
    return digest([library_versions(), [(m, module_hash(m, root)) for m in mods]])


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


def _dependency_state(deps: dict) -> dict:
    """What each dependency is now: a file's sha256 ('missing'), an installed package's
    version (None), an environment variable's value (None)."""
    from importlib import metadata

    def version(p):
        try:
            return metadata.version(p)
        except metadata.PackageNotFoundError:
            return None

    return {"files": {str(f): file_hash(Path(f)) for f in deps.get("files", ())},
            "packages": {p: version(p) for p in deps.get("packages", ())},
            "env": {e: os.environ.get(e) for e in deps.get("env", ())}}


def memo(what: Any, compute: Callable[[], tuple[Any, dict | None]]) -> Any:
    """A value that depends only on ``what`` (plain data: the code hash of what computes
    it, parameters) and on the dependencies ``compute`` names, kept on disk between
    processes. ``compute()`` returns ``(value, deps)``: ``value`` plain JSON data,
    ``deps`` ``{"files": [...], "packages": [...], "env": [...]}`` (every file it read,
    the installed packages and the environment variables it depends on), or None for a
    value not to keep (an error). A later call with an equal ``what`` returns the kept
    value without calling ``compute`` while every dependency is as it was (a file's
    sha256, a package's version, a variable's value, checked at every call): how a
    node's ``key_extra`` that reads a USD scene avoids loading USD on a cached run."""
    d = digest(what)
    path = _user_cache() / "memo" / d[:2] / f"{d}.json"
    try:
        rec = json.loads(path.read_text())
        if rec["what"] == d and _dependency_state({k: list(v) for k, v in rec["deps"].items()}) == rec["deps"]:
            return rec["value"]
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        pass
    value, deps = compute()
    if deps is not None:
        rec = {"what": d, "deps": _dependency_state(deps), "value": value}
        tmp = path.with_name(f".{path.name}.{os.getpid()}.{threading.get_ident()}.tmp")
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp.write_text(json.dumps(rec))
            os.replace(tmp, path)
        except OSError:
            tmp.unlink(missing_ok=True)
    return value


def node_memo(node, parts: Any, compute: Callable[[], tuple[Any, dict | None]]) -> Any:
    """``memo`` for a node's ``key_extra``: ``what`` is the node's type, version, code hash
    and parameters, and ``parts`` (the frame, resolved paths)."""
    cls = type(node)
    return memo(["node_memo", cls.__name__, cls.version, code_hash(cls), node.params, parts], compute)


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
    ol, nl = old.get("libraries") or {}, new.get("libraries") or {}
    libs = [f"{k} {ol.get(k)} -> {nl.get(k)}" for k in sorted(set(ol) | set(nl)) if ol.get(k) != nl.get(k)]
    if libs:
        reasons.append("new library version (" + ", ".join(libs) + ")")
    elif old.get("version") != new.get("version") or old.get("code") != new.get("code"):
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
