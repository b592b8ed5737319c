"""The node contract, after Gaffer's ComputeNode.

A node type is a class that declares

* its inputs (``Input``), each an upstream plate,
* its parameters (``Param``): typed, with a default, bounds or choices, and whether
  they change the result (``hashed``),
* a ``version`` to bump when its output changes for the same inputs,
* ``compute(ctx) -> Plate``.

The engine, not the node, builds each output's cache key (see ``proxyshade.graph.keys``)
from the node type, version, a hash of its implementation source (its module and every
``proxyshade`` module it reaches through imports: ``keys.import_closure``), its
canonical hashed parameters, its upstream keys, the frame when the node depends on
time, the content of the files it reads (``Param(Path, ...)``) and whatever
``key_extra`` adds. Keys never touch pixels.

Node types register themselves by class name in ``REGISTRY`` when their module is
imported: ``proxyshade.nodes.node_type`` imports the module of a type a graph names,
``proxyshade.nodes.load_all`` every one.
"""
from __future__ import annotations

import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, ClassVar, Iterable

import lazy_loader

from proxyshade.declare import Input, Param  # noqa: F401 - declared there, for the synthesis layer's groups too
from proxyshade.errors import NodeInputError, ParamError
from proxyshade.graph.plate import Plate

np = lazy_loader.load("numpy")  # on first use: a fully cached run never loads numpy

REGISTRY: dict[str, type["Node"]] = {}
# where node types live: a plugin package the engine imports by name when a graph names a
# type (never by an import statement: the engine is below the nodes, docs/engine.md "Layers")
NODE_PACKAGE = "proxyshade.nodes"


def load_all() -> dict:
    """Import every module of ``NODE_PACKAGE``; returns the registry (name -> class)."""
    import importlib
    import pkgutil

    package = importlib.import_module(NODE_PACKAGE)
    for m in pkgutil.iter_modules(package.__path__):
        if not m.name.startswith("_"):
            importlib.import_module(f"{NODE_PACKAGE}.{m.name}")
    return REGISTRY


def find_type(name: str):
    """The node class registered as ``name`` (its module, ``name`` in snake case in
    ``NODE_PACKAGE``, imported first), or None (then every type is registered, for the
    message listing them)."""
    import importlib
    import importlib.util
    import re

    if not isinstance(name, str):
        load_all()
        return None
    if name not in REGISTRY and re.fullmatch(r"[A-Z][A-Za-z0-9]*", name):
        module = re.sub(r"(?<!^)(?=[A-Z])", "_", name).lower()
        if importlib.util.find_spec(f"{NODE_PACKAGE}.{module}") is not None:
            importlib.import_module(f"{NODE_PACKAGE}.{module}")
    if name not in REGISTRY:
        load_all()  # a type in a module of another name
    return REGISTRY.get(name)


@dataclass
class Previous:
    """What a progressive node gets from the engine (``ctx.previous``): its own result at
    this frame in the last run of the graph and the input plates that run read, by input
    name (one-frame inputs only). The node diffs those inputs against this run's and
    recomputes only where they differ."""

    plate: Plate
    inputs: dict[str, Plate]


class Progressive:
    """Mixin of the nodes that can update their last result where their inputs changed
    (Bonneel et al. 2010, §7: progressive update after an edit of the proxy). With
    ``progressive: true`` the engine hands ``compute`` the last run's result at this frame
    (``ctx.previous``) when the node's code, parameters, frame, files and extra key data
    are the same as then and only its inputs changed; the key then includes that result's
    key, so a cached result is always the one this history computes."""

    progressive = Param(bool, False, doc="update the last run's result at this frame where the inputs changed "
                                         "(after a proxy edit) instead of recomputing it whole; the result then "
                                         "depends on the edit history")


class Context:
    """What ``compute`` sees: input plates, parameter values, the frame and the run
    (``previous``: a progressive node's last result and inputs, or None; ``memo``: the
    run's memo, ``graph.memo``, for the synthesis layer's functions, None outside a run;
    ``tiles``: the executor's row-band runner of the correction, ``synthesis.tiles``, or
    None)."""

    def __init__(self, node: "Node", frame: int, first_frame: int, inputs: dict[str, Plate | None],
                 params: dict[str, Any], graph_dir: Path, threads: int, notes: list[str]):
        self.node = node
        self.frame = frame
        self.first_frame = first_frame
        self.inputs = inputs
        self.p = _Namespace(params)
        self.params = params
        self.graph_dir = graph_dir
        self.threads = threads
        self._notes = notes
        self.previous: Previous | None = None
        self.memo = None
        self.tiles = None
        # the engine's: an input released; returns the plate's cache write when it still holds the plate
        self.on_release: Callable[[str], Any] | None = None
        # the engine's: a released input's channels read back from its cache entry (or None)
        self.on_read_back: Callable[[str], Any] | None = None

    def release(self, name: str, *, wait_written: bool = False) -> None:
        """The node reads input ``name`` no more in this compute (what it keeps of it, it
        holds in its own arrays): ``ctx.<name>`` is None from now on and, where this
        instance is the plate's last reader in the run, the engine drops the plate from
        memory now instead of once ``compute`` returns (a 4K plate of half a GiB less through
        the rest of the compute). A plate whose cache entry is still being written stays
        in memory until the write is done; ``wait_written`` waits for that write here, so
        that what the node allocates next does not come on top of it (a node about to need
        several frames of memory: the Poisson solve). Changes no result."""
        self.inputs[name] = None
        if self.on_release is None:
            return
        pending = self.on_release(name)
        if wait_written and pending is not None:
            from concurrent.futures import wait

            from proxyshade.graph import profile

            t = time.perf_counter()
            wait([pending])  # a failed write is raised by the run's flush, as any other
            if profile.ACTIVE is not None:
                profile.ACTIVE.release_wait += time.perf_counter() - t

    def read_back(self, name: str) -> Callable[[list[str]], dict] | None:
        """After ``release(name, wait_written=True)``: a function that reads channels of that
        input again from its cache entry (``names -> {name: array}``, the arrays the plate
        held, bit for bit), or None where there is no such entry or the plate is still in
        memory (another reader holds it: what the node keeps of it costs nothing more), a
        read-only cache, outside a run. A node may then let channels it only passes through
        go while it needs the memory and read them back at the end (Poisson: the depth
        channels through the solve); the function raises (the node fails) where the entry
        can no longer be read."""
        fn = self.on_read_back(name) if self.on_read_back is not None else None
        if fn is None:
            return None

        def again(names: list[str]) -> dict:
            got = fn(list(names))
            if got is None:
                raise RuntimeError(f"input {name!r}: its cache entry could not be read back (removed or changed "
                                "during the run?); run again")
            return got

        return again

    def __getattr__(self, item):
        inputs = self.__dict__.get("inputs", {})
        if item in inputs:
            return inputs[item]
        raise AttributeError(item)

    def path(self, value: str) -> Path:
        """Resolve a Path parameter value (``####`` replaced by this frame)."""
        return resolve_path(value, self.graph_dir, self.frame)

    def note(self, message: str) -> None:
        """Add a line to the run report for this node and frame."""
        self._notes.append(message)

    def warn(self, message: str) -> None:
        """A warning: a line in the run report and a Python warning, naming this node."""
        message = f"{self.node.name}: {message}"
        self._notes.append(message)
        warnings.warn(message, stacklevel=2)

    def error(self, message: str) -> NodeInputError:
        """A one-line bad-input error naming this node: ``raise ctx.error('...')``."""
        return NodeInputError(f"{self.node.name}: {message}")


@dataclass(frozen=True)
class InputRef:
    """An input connection: ``node`` at this frame, at ``offset`` frames, at the first frame,
    or (``all``, for a sequence input) at every frame from the first one to this one."""

    node: str
    offset: int = 0
    first: bool = False
    all: bool = False

    def frame(self, frame: int, first_frame: int) -> int:
        return first_frame if self.first else frame + self.offset

    def frames(self, frame: int, first_frame: int) -> list[int]:
        """The upstream frames this input reads at ``frame``, in order."""
        return list(range(first_frame, frame + 1)) if self.all else [self.frame(frame, first_frame)]


class PlateSequence(Sequence):
    """What a sequence input delivers: the upstream plates of ``frames`` (first frame to the
    node's frame, in order). Each plate is loaded, and its declared channels checked, when
    it is read, so a long sequence is never held in memory at once."""

    def __init__(self, frames: Iterable[int], load: Callable[[int], Plate], check: Callable[[Plate], None]):
        self.frames = list(frames)
        self._load = load
        self._check = check

    def __len__(self) -> int:
        return len(self.frames)

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[j] for j in range(*i.indices(len(self)))]
        plate = self._load(self.frames[i])
        self._check(plate)
        return plate


class _Namespace:
    def __init__(self, d: dict):
        self.__dict__.update(d)


def frame_pad(value: str, frame: int) -> str:
    """Replace each run of '#' by the zero-padded frame number ('out.####.exr')."""
    import re

    return re.sub(r"#+", lambda m: f"{frame:0{len(m.group(0))}d}", value)


def resolve_path(value: str, graph_dir: Path, frame: int | None = None) -> Path:
    if frame is not None:
        value = frame_pad(value, frame)
    p = Path(value).expanduser()
    return p if p.is_absolute() else (graph_dir / p)


class Node:
    """Base class of every node type. Subclasses declare Inputs, Params and compute()."""

    version: ClassVar[int] = 1
    time_dependent: ClassVar[bool] = False  # output depends on the frame number
    sink: ClassVar[bool] = False  # writes files outside the cache (ExrWrite, Preview)
    # False: computing the plate again costs less than writing and reading its cache entry (a
    # re-packing such as Cryptomatte): kept in memory for the run, never stored; computed only
    # when an instance to compute reads it (a progressive node is stored all the same)
    stored: ClassVar[bool] = True
    sequence: ClassVar[bool] = False  # has a sequence input: one instance per run (set from the Inputs)
    inputs_spec: ClassVar[dict[str, Input]]
    params_spec: ClassVar[dict[str, Param]]

    def __init_subclass__(cls, register: bool = True, **kw):
        super().__init_subclass__(**kw)
        inputs, params = {}, {}
        for base in reversed(cls.__mro__):
            for k, v in vars(base).items():
                if isinstance(v, Input):
                    v.name = k
                    inputs[k] = v
                elif isinstance(v, Param):
                    v.name = k
                    params[k] = v
        cls.inputs_spec = inputs
        cls.params_spec = params
        cls.sequence = any(i.sequence for i in inputs.values())
        if register and not cls.__name__.startswith("_"):
            REGISTRY[cls.__name__] = cls

    def __init__(self, name: str, params: dict[str, Any] | None = None):
        self.name = name
        self.params = self.validate_params(params or {})

    @classmethod
    def validate_params(cls, params: dict[str, Any], where: str = "") -> dict[str, Any]:
        """Checked parameter values with defaults filled in. Errors name ``where.param``."""
        out = {}
        for k in params:
            if k not in cls.params_spec:
                known = ", ".join(cls.params_spec) or "none"
                raise ParamError(f"{where}{k}: {cls.__name__} has no parameter {k!r}; its parameters are {known}")
        for k, spec in cls.params_spec.items():
            if k in params:
                try:
                    out[k] = spec.validate(params[k])
                except ParamError as e:
                    raise ParamError(f"{where}{k}: {e}") from None
            elif spec.required:
                raise ParamError(f"{where}{k}: {cls.__name__} needs this parameter ({spec.describe()})")
            else:
                out[k] = spec.default
        return out

    # -- what the engine asks ----------------------------------------------
    def depends_on_frame(self) -> bool:
        """Whether the output changes with the frame (then the frame is in the key)."""
        if self.time_dependent:
            return True
        return any(
            spec.type is Path and isinstance(self.params.get(k), str) and "#" in self.params[k]
            for k, spec in self.params_spec.items()
        )

    def is_progressive(self) -> bool:
        """Whether the engine hands this instance its last result (``Progressive``)."""
        return bool(self.params.get("progressive", False))

    def key_extra(self, frame: int, graph_dir: Path) -> str | None:
        """Extra content for the key (e.g. the USD data seen at this frame). Default none."""
        return None

    def read_files(self, frame: int, graph_dir: Path) -> list[Path]:
        """The files this node reads at ``frame``: what ``run --watch`` watches. Default: its
        ``Path`` parameters; a node that reads a file named otherwise (a USD scene, keyed
        through ``key_extra``) adds it."""
        return [resolve_path(self.params[k], graph_dir, frame) for k, spec in self.params_spec.items()
                if spec.type is Path and self.params.get(k)]

    def check_inputs(self, inputs: dict[str, Plate | None]) -> None:
        """One-line errors for unconnected required inputs and for plates that fail their
        ``Input``'s declaration (a sequence input's plates are checked as they are read, by
        ``check_plate``)."""
        for k, spec in self.inputs_spec.items():
            plate = inputs.get(k)
            if plate is None:
                if not spec.optional:
                    raise NodeInputError(f"{self.name}: input {k!r} is not connected; "
                                         f"{spec.fix or 'connect a node to it'}")
                continue
            if not spec.sequence:
                self.check_plate(k, plate)

    def check_plate(self, input_name: str, plate: Plate) -> None:
        """A one-line error when ``plate`` fails the input's declaration (channels, dtypes,
        finite values)."""
        problem = self.inputs_spec[input_name].problem(plate, type(self).__name__)
        if problem:
            raise NodeInputError(f"{self.name}: input {input_name!r} {problem}")

    def passthrough_input(self) -> str | None:
        """The input a disabled node passes through (default: its first input)."""
        return next(iter(self.inputs_spec), None)

    def written_files(self, ctx: Context) -> list[Path]:
        """For sink nodes: the files ``compute`` wrote (the engine records them in the cache so
        a re-run is a hit only while they still exist). Default: the ``path`` parameter."""
        return [ctx.path(self.params["path"])]

    def compute(self, ctx: Context) -> Plate:  # pragma: no cover - abstract
        raise NotImplementedError

    @classmethod
    def doc(cls) -> str:
        return (cls.__doc__ or "").strip()
