"""The one YAML reader of every file and value proxyshade reads (graph files, source tables,
scene descriptions, BTF specs, ``--set`` and ``--var`` values), with the same limits:

- a file that is not UTF-8 text, or larger than ``MAX_BYTES``;
- a key given twice in one mapping (both lines named; merge keys ``<<`` are not duplicates);
- a document that expands to more than ``MAX_ITEMS`` items through aliases (an alias bomb:
  counted on the composed nodes, before any Python value is built, in time linear in the
  distinct nodes), or nests deeper than ``MAX_DEPTH``;
- YAML syntax errors.

Each is a one-line error naming the file (or the option), the line and the fix, raised as
the caller's error class (``UserError`` by default: exit 2). ``short`` cuts a value for a
message.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from proxyshade.errors import UserError

MAX_ITEMS = 100_000  # items once aliases are expanded: far beyond any real file, far below exhausting memory
MAX_DEPTH = 100  # nesting of mappings and lists
MAX_BYTES = 16 * 2**20


class LineMap(dict):
    """A dict that remembers the line of each key (1-based): ``lines`` and its own ``line``."""

    lines: dict
    line: int


class _DuplicateKey(Exception):
    pass


class _TooBig(Exception):
    pass


class _Loader(yaml.SafeLoader):
    line_maps = False


class _LineLoader(_Loader):
    line_maps = True


def _construct_mapping(loader, node):
    seen = {}
    for knode, _ in node.value:  # before merge keys (<<) are flattened in: an override is not a duplicate
        if knode.tag == "tag:yaml.org,2002:merge":
            continue
        k = loader.construct_object(knode, deep=True)
        line = knode.start_mark.line + 1
        try:
            first = seen.get(k)
        except TypeError:  # an unhashable key: PyYAML reports it below
            continue
        seen[k] = line
        if first is not None:
            raise _DuplicateKey(f"{line}: key {short(k, 80)} appears twice in one mapping (lines {first} and {line}); "
                                "remove or rename one")
    loader.flatten_mapping(node)
    out = LineMap() if loader.line_maps else {}
    lines = {}
    for knode, vnode in node.value:
        k = loader.construct_object(knode, deep=True)
        try:
            out[k] = loader.construct_object(vnode, deep=True)
        except TypeError:
            raise yaml.constructor.ConstructorError(None, None, "found an unhashable key", knode.start_mark) from None
        lines[k] = knode.start_mark.line + 1
    if loader.line_maps:
        out.lines = lines
        out.line = node.start_mark.line + 1
    return out


_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)


def _check_expansion(root) -> None:
    """Raise ``_TooBig(line)`` when the composed document expands past MAX_ITEMS items through
    aliases, or nests deeper than MAX_DEPTH (a recursive alias does)."""
    memo: dict[int, int] = {}

    def count(node, depth: int) -> int:
        if depth > MAX_DEPTH:
            raise _TooBig(node.start_mark.line + 1)
        got = memo.get(id(node))
        if got is not None:
            return got
        n = 1
        if isinstance(node, yaml.SequenceNode):
            for child in node.value:
                n += count(child, depth + 1)
        elif isinstance(node, yaml.MappingNode):
            for k, v in node.value:
                n += count(k, depth + 1) + count(v, depth + 1)
        memo[id(node)] = n
        return n

    total = count(root, 0)
    if total > MAX_ITEMS and total > len(memo):  # aliases, not a big plain file, make it so
        node = root
        while True:  # down to the smallest part that is too big by itself: the alias or its anchor
            children = node.value if isinstance(node, yaml.SequenceNode) else \
                [c for kv in node.value for c in kv] if isinstance(node, yaml.MappingNode) else []
            big = [c for c in children if memo[id(c)] > MAX_ITEMS]
            if not big:
                raise _TooBig(node.start_mark.line + 1)
            node = big[0]


def parse(text: str, where: str, *, error: type[UserError] = UserError, line_maps: bool = False,
          what: str = "YAML") -> Any:
    """``text`` as YAML (``where``: the file or option, for messages), with the limits above.
    ``line_maps``: mappings as ``LineMap`` (the line of each key)."""
    loader = (_LineLoader if line_maps else _Loader)(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        _check_expansion(node)
        return loader.construct_document(node)
    except _DuplicateKey as e:
        raise error(f"{where}:{e}") from None
    except _TooBig as e:
        raise error(f"{where}:{e.args[0]}: the value expands to more than {MAX_ITEMS} items (or nests deeper than "
                    f"{MAX_DEPTH}), e.g. through YAML aliases; give a plain value") from None
    except RecursionError:
        raise error(f"{where}: nested too deeply to read (over {MAX_DEPTH} levels); check for runaway "
                    "brackets") from None
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        line = f":{mark.line + 1}" if mark else ""
        problem = getattr(e, "problem", None) or str(e).splitlines()[0]
        raise error(f"{where}{line}: not valid {what} ({problem}); fix the syntax") from None
    finally:
        loader.dispose()


def load(path: str | Path, *, what: str = "YAML file", error: type[UserError] = UserError,
         line_maps: bool = False) -> Any:
    """The YAML file at ``path``, read with the limits above (``what`` names it in messages:
    'graph file', 'source table', ...)."""
    path = Path(path)
    try:
        size = path.stat().st_size
        if size > MAX_BYTES:
            raise error(f"{path}: {size} bytes, more than a {what} can be ({MAX_BYTES // 2**20} MiB); check the path")
        raw = path.read_bytes()
    except IsADirectoryError:
        raise error(f"{path}: is a folder, not a {what}; check the path") from None
    except OSError as e:
        raise error(f"{path}: cannot read {what} ({e.strerror}); check the path") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        line = raw[:e.start].count(b"\n") + 1
        raise error(f"{path}:{line}: not a UTF-8 text file (byte 0x{raw[e.start]:02x} at offset {e.start}); "
                    f"give a YAML {what}") from None
    return parse(text, str(path), error=error, line_maps=line_maps)


def short(value: Any, limit: int = 200) -> str:
    """``repr(value)`` for a message, cut to ``limit`` characters (a value may be large)."""
    text = repr(value) if not isinstance(value, str) or len(value) <= limit else repr(value[:limit])
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} characters)"


def cut(text: str, limit: int = 200) -> str:
    """Text as it is for a message (no quotes), cut to ``limit`` characters."""
    text = str(text)
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} characters)"
