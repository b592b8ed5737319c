"""YAML graph files: plain data first, validated against the node registry, then built.

    format: proxyshade/1          # required header
    frames: 1-48                  # the sequence's frame range (default 1)
    vars: {sample: ../samples/renoir}
    nodes:
      src:     {type: SourceRead, params: {table: "${sample}/source.yaml"}}
      guide:   {type: GuideSynth, inputs: {source: src, proxy: proxy}, params: {k: 5}}
      reproj:  {type: Reproject, inputs: {depth: depth, source: src, prev: {node: final, frame: -1},
                                          first: {node: first, frame: first}}}
      final:   {type: Resynthesize, inputs: {image: reproj, source: src}}
      write:   {type: ExrWrite, inputs: {image: final}, params: {path: out/lake.####.exr}, enabled: true}
      movie:   {type: Movie, inputs: {image: {node: final, frame: all}}, params: {path: out/lake.gif}}

Relative paths resolve against the graph file's folder; ``${name}`` is replaced by a
variable (``--var name=value`` sets one defined under ``vars``); ``####`` in a path is the
zero-padded frame. Every error names the file, the line, the key path and the fix:
``graphs/lake.yaml:12: nodes.guide.params.k: expected int >= 1, got 0``. A key given twice
in one mapping (two nodes of one name), a value that expands to more than ``MAX_ITEMS``
items (YAML aliases), nesting deeper than ``MAX_DEPTH``, a file that is not UTF-8 text and a
frame range of more than ``MAX_FRAMES`` frames are such errors too.
"""
from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

from proxyshade.errors import GraphFileError, ParamError
from proxyshade.io import files, yamlfile

FORMAT = "proxyshade/1"
MAX_FRAMES = 100_000  # frames in one range: far beyond a shot, far below exhausting memory
MAX_ITEMS = yamlfile.MAX_ITEMS  # list/dict items in one value once aliases are expanded
MAX_DEPTH = yamlfile.MAX_DEPTH  # nesting of mappings and lists
_NODE_KEYS = ("type", "inputs", "params", "enabled", "doc")
_VAR = re.compile(r"\$\{([A-Za-z_][A-Za-z0-9_]*)\}")


def _line(d: Any, key: Any = None) -> int:
    if isinstance(d, yamlfile.LineMap):
        return d.lines.get(key, d.line) if key is not None else d.line
    return 0


def parse_frames(value: Any, where: str) -> tuple[int, int]:
    """'1-48', 12 or [1, 48] -> (first, last)."""
    if isinstance(value, bool):
        raise GraphFileError(f"{where}: expected a frame range like 1-48, got {yamlfile.short(value)}")
    if isinstance(value, int):
        return value, value
    if isinstance(value, (list, tuple)) and len(value) == 2 and all(isinstance(v, int) for v in value):
        lo, hi = value
    elif isinstance(value, str) and re.fullmatch(r"\s*-?\d+\s*(-\s*-?\d+\s*)?", value):
        m = re.fullmatch(r"\s*(-?\d+)\s*(?:-\s*(-?\d+)\s*)?", value)
        lo = int(m.group(1))
        hi = int(m.group(2)) if m.group(2) is not None else lo
    else:
        raise GraphFileError(f"{where}: expected a frame range like 1-48, got {yamlfile.short(value)}")
    if hi < lo:
        raise GraphFileError(f"{where}: frame range {yamlfile.short(value)} ends before it starts; write first-last")
    if hi - lo + 1 > MAX_FRAMES:
        raise GraphFileError(f"{where}: frame range {lo}-{hi} has {hi - lo + 1} frames, more than {MAX_FRAMES}; "
                             "give a shorter range")
    return lo, hi


def parse_frame_list(text: str, where: str = "--frames", bounds: tuple[int, int] | None = None) -> list[int]:
    """'1-48', '30', '1,5,9-12' -> sorted frames, each range checked against ``bounds`` (the
    graph's frames) before any list is built."""
    if not str(text).strip():
        raise GraphFileError(f"{where}: no frames given; write frames like 1-48, 30 or 1,5,9-12 "
                             "(or leave the option out for the graph's range)")
    ranges = [parse_frames(part.strip(), where) for part in str(text).split(",")]
    for lo, hi in ranges:
        if bounds is not None and (lo < bounds[0] or hi > bounds[1]):
            raise GraphFileError(f"{where}: frames {lo}-{hi} are outside the graph's frames {bounds[0]}-{bounds[1]}; "
                                 "pick frames inside the range or widen 'frames'")
    out: set[int] = set()
    for lo, hi in ranges:
        out.update(range(lo, hi + 1))
        if len(out) > MAX_FRAMES:
            raise GraphFileError(f"{where}: more than {MAX_FRAMES} frames; run a shorter range")
    return sorted(out)


def _subst(value: Any, variables: dict[str, Any], where: str) -> Any:
    if isinstance(value, str):
        whole = _VAR.fullmatch(value)
        if whole and whole.group(1) in variables:
            return variables[whole.group(1)]  # "${v}" alone keeps the variable's type

        def rep(m):
            if m.group(1) not in variables:
                raise GraphFileError(f"{where}: unknown variable ${{{m.group(1)}}}; defined: "
                                     f"{', '.join(sorted(variables)) or 'none'} (add it under vars)")
            return str(variables[m.group(1)])

        return _VAR.sub(rep, value)
    if isinstance(value, list):
        return [_subst(v, variables, where) for v in value]
    if isinstance(value, dict):
        return {k: _subst(v, variables, where) for k, v in value.items()}
    return value


def _resolve_vars(declared: dict, given: dict, f: str, line: int) -> dict:
    """The graph's variables with the command line's (``--var``) over them.

    A variable declared as ``{default: renoir, bundled: "../samples/{}/source.yaml"}``
    takes a bundled name or a path: a value with a path separator or a file suffix (or
    naming an existing file) is a path of the user's, made absolute against the current
    folder; anything else is a bundled name, put into the pattern (which resolves against
    the graph file's folder like any path parameter). ``${NAME_name}`` is the short name
    outputs are named after (the bundled name, or the file's stem). One declared as
    ``{default: ../out, path: true}`` is a path: the default resolves against the graph
    file's folder, a ``--var`` value against the current folder."""
    out = {}
    for name, spec in declared.items():
        if isinstance(spec, dict) and spec.get("path") is True and set(spec) <= {"default", "path", "doc"}:
            # a folder or file: the graph's default resolves against the graph file, a value
            # given on the command line against the current folder
            out[name] = str(_absolute(Path(given[name]).expanduser())) if name in given else spec.get("default")
        elif isinstance(spec, dict) and "bundled" in spec:
            extra = set(spec) - {"default", "bundled", "doc"}
            if extra or not isinstance(spec["bundled"], str) or "{}" not in spec["bundled"]:
                raise GraphFileError(f"{f}:{line}: vars.{name}: expected {{default: NAME, bundled: \"path/{{}}/...\"}} "
                                     f"(the pattern holds {{}} where the name goes), got {yamlfile.short(dict(spec))}")
            value = given.get(name, spec.get("default"))
            out[name] = _bundled_or_path(value, spec["bundled"])
            out[f"{name}_name"] = _short_name(value)
        else:
            out[name] = _typed_var(name, given[name], spec) if name in given else spec
    for name, value in given.items():
        out.setdefault(name, value)
    return out


def _absolute(p: Path) -> Path:
    """``p`` made absolute with its symlinks resolved; a symlink loop (which ``resolve`` raises on)
    left as it is, for the output check or the reader to name."""
    try:
        return p.resolve()
    except (RuntimeError, OSError):
        return Path(os.path.abspath(p))


def _typed_var(name: str, value: Any, default: Any) -> Any:
    """A ``--var`` value (text from the command line) as the type of the variable's default:
    a number for a number (``vars: {value: 1.0}``, ``--var value=2.0``), true/false for a bool;
    text for text or no default."""
    if not isinstance(value, str) or isinstance(default, str) or default is None:
        return value
    if isinstance(default, bool):
        kind, ok = "true or false", lambda v: isinstance(v, bool)
    elif isinstance(default, int):
        kind, ok = "an integer", lambda v: isinstance(v, int) and not isinstance(v, bool)
    elif isinstance(default, float):
        kind, ok = "a number", lambda v: isinstance(v, (int, float)) and not isinstance(v, bool)
    else:
        return value  # a list or mapping: given in YAML flow style (the CLI parses it)
    try:
        parsed = yamlfile.parse(value, f"--var {name}", error=GraphFileError)
    except GraphFileError:
        parsed = value
    if isinstance(parsed, str) and isinstance(default, float):  # 1e3: a number YAML 1.1 reads as text
        try:
            parsed = float(parsed)
        except ValueError:
            pass
    if not ok(parsed):
        raise GraphFileError(f"--var {name}={yamlfile.cut(value, 80)}: the variable {name} is "
                             f"{kind} (its default is {default!r}); give {kind}, e.g. --var {name}={default!r}")
    return float(parsed) if isinstance(default, float) else parsed


def _bundled_or_path(value: Any, pattern: str) -> Any:
    if not isinstance(value, str) or not value:
        return value
    p = Path(value).expanduser()
    if p.is_absolute() or "/" in value or "\\" in value or p.suffix or p.is_file():
        return str(_absolute(p))
    return pattern.replace("{}", value)


def _short_name(value: Any) -> str:
    """What outputs are named after: a bundled name itself, a path's file stem (its folder's
    name for a generic file name such as source.yaml)."""
    p = Path(str(value))
    return p.parent.name if p.stem in ("source", "scene") and p.parent.name else p.stem


def _size(value: Any, seen: dict, depth: int = 0) -> int:
    """Items in ``value`` with YAML aliases expanded, counted in time linear in the distinct
    objects (a shared sub-value is counted once per use, from a memo); stops past MAX_ITEMS."""
    if not isinstance(value, (list, dict)):
        return 1
    if id(value) in seen:
        return seen[id(value)]
    if depth > MAX_DEPTH:
        return MAX_ITEMS + 1
    items = value.values() if isinstance(value, dict) else value
    n = 1
    for v in items:
        n += _size(v, seen, depth + 1)
        if n > MAX_ITEMS:
            break
    seen[id(value)] = n
    return n


def _short(text: str, limit: int = 400) -> str:
    """A message about a long value, cut to ``limit`` characters."""
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} characters)"


def _check_size(value: Any, where: str) -> None:
    if _size(value, {}) > MAX_ITEMS:
        raise GraphFileError(f"{where}: the value expands to more than {MAX_ITEMS} items (or nests deeper than "
                             f"{MAX_DEPTH}), e.g. through YAML aliases; give a plain value")


def read_yaml(path: Path) -> Any:
    """A graph file's data, its mappings ``LineMap``s (the line of each key), read with the limits
    of every YAML file (``io.yamlfile``: UTF-8, size, duplicate keys, aliases, depth)."""
    return yamlfile.load(path, what="graph file", error=GraphFileError, line_maps=True)


def _input_ref(value: Any, where: str, InputRef: type) -> Any:
    if isinstance(value, str):
        return InputRef(value)
    if isinstance(value, dict):
        extra = set(value) - {"node", "frame"}
        if extra or "node" not in value or not isinstance(value["node"], str):
            raise GraphFileError(f"{where}: expected a node name or {{node: NAME, frame: -1|first|all}}, got {yamlfile.short(dict(value))}")
        frame = value.get("frame", 0)
        if frame == "first":
            return InputRef(value["node"], first=True)
        if frame == "all":
            return InputRef(value["node"], all=True)
        if isinstance(frame, bool) or not isinstance(frame, int):
            raise GraphFileError(f"{where}.frame: expected an integer offset (e.g. -1), 'first' or 'all', got {yamlfile.short(frame)}")
        return InputRef(value["node"], offset=frame)
    raise GraphFileError(f"{where}: expected a node name or {{node: NAME, frame: -1|first|all}}, got {yamlfile.short(value)}")


def build_graph(data: Any, path: Path, graph_cls: type, *, cache=None, overrides: list[str] = (),
                variables: dict[str, str] | None = None):
    """Validate plain graph data (as loaded from ``path``) and build a ``graph_cls``
    (``proxyshade.graph.graph.Graph``, which calls this through ``Graph.load``; it names the
    node types, ``graph_cls.find_type``, and makes the input connections, ``graph_cls.InputRef``)."""
    f = str(path)

    def err(line: int, keypath: str, msg: str) -> GraphFileError:
        return GraphFileError(f"{f}:{line}: {keypath}: {msg}")

    if not isinstance(data, dict):
        raise GraphFileError(f"{f}:1: expected a mapping with 'format: {FORMAT}' and 'nodes'")
    unknown = set(data) - {"format", "frames", "vars", "nodes", "doc"}
    if unknown:
        k = sorted(unknown)[0]
        raise err(_line(data, k), k, "unknown top-level key; valid keys are format, frames, vars, nodes, doc")
    if data.get("format") != FORMAT:
        raise err(_line(data, "format"), "format", f"expected {FORMAT!r}, got {yamlfile.short(data.get('format'))}; "
                  f"put 'format: {FORMAT}' at the top")
    frames = parse_frames(data.get("frames", 1), f"{f}:{_line(data, 'frames')}: frames")
    vars_ = data.get("vars") or {}
    if not isinstance(vars_, dict):
        raise err(_line(data, "vars"), "vars", "expected a mapping name -> value")
    for k, v in vars_.items():
        _check_size(v, f"{f}:{_line(vars_, k)}: vars.{k}")
    for k in variables or {}:
        if k not in vars_:
            raise GraphFileError(f"--var {k}: {f} defines no variable {yamlfile.short(k)}; its variables are "
                                 f"{', '.join(sorted(map(str, vars_))) or 'none'} (add it under vars, or fix the name)")
    variables = _resolve_vars(vars_, variables or {}, f, _line(data, "vars"))
    nodes = data.get("nodes")
    if not isinstance(nodes, dict) or not nodes:
        raise err(_line(data, "nodes"), "nodes", "expected a mapping of node name -> {type, inputs, params}")

    g = graph_cls(graph_dir=path.parent, frames=frames, cache=cache, name=path.stem, source=f)
    pending_inputs = {}
    for name, spec in nodes.items():
        kp = f"nodes.{name}"
        line = _line(nodes, name)
        if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name):
            raise err(line, kp, "node names are letters, digits and underscores")
        if not isinstance(spec, dict):
            raise err(line, kp, "expected {type: NodeType, inputs: {...}, params: {...}}")
        for k in spec:
            if k not in _NODE_KEYS:
                raise err(_line(spec, k), f"{kp}.{k}", f"unknown key; valid keys are {', '.join(_NODE_KEYS)}")
        t = spec.get("type")
        cls = graph_cls.find_type(t)
        if cls is None:
            raise err(_line(spec, "type"), f"{kp}.type",
                      f"unknown node type {yamlfile.short(t)}; known types: {', '.join(graph_cls.known_types())}")
        params = spec.get("params") or {}
        if not isinstance(params, dict):
            raise err(_line(spec, "params"), f"{kp}.params", "expected a mapping param -> value")
        checked = {}
        for k, v in params.items():
            if k not in cls.params_spec:
                raise err(_line(params, k), f"{kp}.params.{k}",
                          f"{t} has no parameter {yamlfile.short(k)}; its parameters are {', '.join(cls.params_spec) or 'none'}")
            where = f"{f}:{_line(params, k)}: {kp}.params.{k}"
            _check_size(v, where)
            v = _subst(v, variables, where)
            _check_size(v, where)
            try:
                checked[k] = cls.params_spec[k].validate(v)
            except ParamError as e:
                raise err(_line(params, k), f"{kp}.params.{k}", _short(str(e))) from None
        missing = [k for k, s in cls.params_spec.items() if s.required and k not in checked]
        if missing:
            k = missing[0]
            raise err(_line(spec, "params") or line, f"{kp}.params.{k}",
                      f"required ({cls.params_spec[k].describe()}); add it under params")
        enabled = spec.get("enabled", True)
        if not isinstance(enabled, bool):
            raise err(_line(spec, "enabled"), f"{kp}.enabled", f"expected true or false, got {yamlfile.short(enabled)}")
        inputs = spec.get("inputs") or {}
        if not isinstance(inputs, dict):
            raise err(_line(spec, "inputs"), f"{kp}.inputs", "expected a mapping input -> node")
        refs = {}
        for k, v in inputs.items():
            if k not in cls.inputs_spec:
                raise err(_line(inputs, k), f"{kp}.inputs.{k}",
                          f"{t} has no input {yamlfile.short(k)}; its inputs are {', '.join(cls.inputs_spec) or 'none'}")
            refs[k] = (_input_ref(v, f"{f}:{_line(inputs, k)}: {kp}.inputs.{k}", graph_cls.InputRef), _line(inputs, k))
        for k, s in cls.inputs_spec.items():
            if not s.optional and k not in refs:
                raise err(_line(spec, "inputs") or line, f"{kp}.inputs.{k}", f"not connected; {t} needs it: connect it to a node")
        g.add(name, cls, checked, {}, enabled)
        if isinstance(getattr(g, "lines", None), dict):
            g.lines[name] = line
        pending_inputs[name] = refs
    for name, refs in pending_inputs.items():
        for k, (ref, line) in refs.items():
            problem = g.ref_problem(name, k, ref)
            if problem:
                raise err(line, f"nodes.{name}.inputs.{k}", problem)
            g.connections[name][k] = ref
    for o in overrides:
        target, eq, raw = o.partition("=")
        if not eq or "." not in target:
            raise GraphFileError(f"--set {o}: expected node.param=value")
        try:
            value = yamlfile.parse(raw, f"--set {_short(o, 200)}", error=GraphFileError)
        except GraphFileError as e:
            if "expands to more than" in str(e) or "nested too deeply" in str(e):
                raise
            value = raw  # not YAML: the text as it is
        try:
            g.set(target.strip(), value)
        except ParamError as e:
            raise GraphFileError(f"--set {_short(o)}: {_short(str(e))}") from None
    _check_outputs(g, nodes, f)
    return g


def _check_outputs(g, nodes: dict, f: str) -> None:
    """Every enabled writer's output path (a sink node's ``path``, at the first frame) checked
    before anything computes: a file or a symlink loop where a folder of it must be, or a
    folder, device or loop at the file itself, is a one-line error now rather than an I/O
    error after the whole compute."""
    for name, node in g.nodes.items():
        value = getattr(node, "params", {}).get("path")
        if not (getattr(type(node), "sink", False) and g.enabled.get(name, True) and isinstance(value, (str, Path))):
            continue
        text = re.sub(r"#+", lambda m: f"{g.frames[0]:0{len(m.group(0))}d}", str(value))
        p = Path(text).expanduser()
        problem = files.output_problem(p if p.is_absolute() else Path(g.graph_dir) / p)
        if problem:
            raise GraphFileError(f"{f}:{_line(nodes, name)}: nodes.{name}.params.path: cannot write "
                                 f"{_short(str(value), 200)}: {problem}")


def load_graph(path: str | Path, graph_cls: type, *, cache=None, overrides: list[str] = (), variables=None):
    """The graph file at ``path`` as a ``graph_cls``: use ``Graph.load(path)``."""
    path = Path(path)
    return build_graph(read_yaml(path), path, graph_cls, cache=cache, overrides=overrides, variables=variables)
