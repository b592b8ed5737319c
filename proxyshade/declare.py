"""What a node type declares: its ``Input``s (upstream plates, checked before ``compute``)
and ``Param``s (typed, defaults, bounds or choices). Kept beside ``proxyshade.plate`` and
``proxyshade.errors`` so that the engine (``graph.node``, which re-exports them) and the
synthesis layer's parameter groups (``synthesis.params``) both declare with them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import lazy_loader

from proxyshade.errors import ParamError
from proxyshade.plate import Plate

np = lazy_loader.load("numpy")  # on first use: a fully cached run never loads numpy

_UNSET = object()


@dataclass
class Input:
    """An upstream plate, checked by the engine before ``compute`` runs.

    ``channels`` the node reads (missing ones are a one-line error); ``finite``: True
    (every declared float channel) or the channels that must hold no NaN or Inf, except
    the ``inf_ok`` ones (Inf marks empty pixels there, only NaN is refused); ``dtype``:
    channel -> numpy dtype name the channel must have (ids are ``uint32``); ``fix``: what
    to connect, said in those errors (e.g. ``"connect a SourceRead node"``).

    ``optional`` inputs may be unconnected (or fall before the first frame when connected
    at a negative frame offset) and arrive as ``None``. A ``sequence`` input takes the
    whole sequence (connected as ``{node: X, frame: all}``) and arrives as a
    ``PlateSequence``; a node with one is a sequence node, instantiated once per run, at
    the last requested frame."""

    doc: str = ""
    optional: bool = False
    name: str = ""
    channels: tuple[str, ...] = ()
    sequence: bool = False
    finite: bool | tuple[str, ...] = False
    inf_ok: tuple[str, ...] = ()
    dtype: dict[str, str] | None = None
    fix: str = ""

    def problem(self, plate: Plate, node_type: str) -> str | None:
        """What is wrong with ``plate`` for this input of a ``node_type`` node, in words, or None."""
        missing = [c for c in self.channels if c not in plate]
        if missing:
            return (f"has no channel {', '.join(missing)}; {node_type} needs {', '.join(self.channels)} there, "
                    f"it has {', '.join(plate.names()) or 'none'}" + (f"; {self.fix}" if self.fix else ""))
        for c, want in (self.dtype or {}).items():
            if c in plate and plate[c].dtype != np.dtype(want):
                return (f"channel {c} is {plate[c].dtype}, not {want}" + (f"; {self.fix}" if self.fix else
                        f"; write it as {want}"))
        check = self.channels if self.finite is True else (self.finite or ())
        for c in check:
            if c not in plate:
                continue
            a = plate[c]
            if not np.issubdtype(a.dtype, np.floating):
                continue
            nan_only = c in self.inf_ok
            bad = np.isnan(a) if nan_only else ~np.isfinite(a)
            if bad.any():
                y, x = np.argwhere(bad)[0]
                kind = "NaN" if nan_only else "NaN/Inf"
                return (f"channel {c} has {int(bad.sum())} {kind} pixel(s), first at x={x} y={y}; fix the upstream "
                        "node or clean the image (e.g. clamp or inpaint those pixels)")
        return None


class Param:
    """A typed node parameter.

    ``type`` is one of int, float, bool, str, list, dict or ``pathlib.Path``. A Path
    parameter is resolved against the graph file's folder, may hold ``####`` frame
    padding, and the content of the file it names is part of the node's key.
    ``hashed=False`` marks parameters that do not change the result (threads, verbosity).
    """

    def __init__(self, type, default=_UNSET, *, min=None, max=None, choices=None,
                 hashed: bool = True, doc: str = "", length: int | None = None,
                 optional: bool = False):
        self.type = type
        self.default = default
        self.min = min
        self.max = max
        self.choices = tuple(choices) if choices is not None else None
        self.hashed = hashed
        self.doc = doc
        self.length = length
        self.optional = optional  # None is accepted
        self.name = ""

    @property
    def required(self) -> bool:
        return self.default is _UNSET

    def describe(self) -> str:
        t = "path" if self.type is Path else getattr(self.type, "__name__", str(self.type))
        bits = [t]
        if self.choices:
            bits.append("one of " + ", ".join(map(repr, self.choices)))
        if self.min is not None:
            bits.append(f">= {self.min}")
        if self.max is not None:
            bits.append(f"<= {self.max}")
        if self.length is not None:
            bits.append(f"of length {self.length}")
        return " ".join(bits)

    def validate(self, value: Any) -> Any:
        """Coerce and check ``value``; raise ParamError('expected ..., got ...')."""
        if value is None and (self.optional or self.default is None):
            return None
        expected = f"expected {self.describe()}, got {value!r}"
        t = self.type
        if t is bool:
            if not isinstance(value, bool):
                raise ParamError(expected)
        elif t is int:
            if isinstance(value, bool) or not isinstance(value, int):
                if isinstance(value, float) and value.is_integer():
                    value = int(value)
                else:
                    raise ParamError(expected)
        elif t is float:
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ParamError(expected)
            value = float(value)
            if not math.isfinite(value):
                raise ParamError(expected)
        elif t is str or t is Path:
            if not isinstance(value, str) or (t is Path and not value):
                raise ParamError(expected)
        elif t is list:
            if not isinstance(value, (list, tuple)):
                raise ParamError(expected)
            value = list(value)
            if self.length is not None and len(value) != self.length:
                raise ParamError(expected)
        elif t is dict:
            if not isinstance(value, dict):
                raise ParamError(expected)
        if self.choices is not None and value not in self.choices:
            raise ParamError(expected)
        if self.min is not None and value < self.min:
            raise ParamError(expected)
        if self.max is not None and value > self.max:
            raise ParamError(expected)
        return value
