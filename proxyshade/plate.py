"""Plates: the values that flow on the graph's edges.

A plate is a set of named 2-D channels of one size, each with its own dtype
(``float16``, ``float32`` or ``uint32``), plus JSON-able metadata. It maps one to
one onto a single-part multichannel EXR (see ``proxyshade.io.exr``). Channel names
follow Nuke's ``layer.channel`` convention; the names in use are listed in
``docs/aovs.md``.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any, Iterable, Mapping

import lazy_loader

np = lazy_loader.load("numpy")  # on first use: a fully cached run never loads numpy

DTYPES = ("float16", "float32", "uint32")  # names: numpy's dtypes would load numpy on import
_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z0-9_]+)*$")


class PlateError(ValueError):
    """A plate was built or used with channels it cannot hold."""


def check_channel_name(name: str) -> str:
    if not _NAME.match(name):
        raise PlateError(
            f"channel name {name!r} is not Nuke-compatible: use layer.channel with "
            "letters, digits and underscores (e.g. 'label.id', 'P.X')"
        )
    return name


@dataclass
class Plate:
    """Named channels of shape (H, W) and metadata.

    Parameters
    ----------
    channels : mapping of str to (H, W) ndarray
        Each array is float16, float32 or uint32; all share one shape.
    meta : dict
        JSON-serialisable metadata (label tables, provenance, ...).
    """

    channels: dict[str, np.ndarray] = field(default_factory=dict)
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        shape = None
        fixed: dict[str, np.ndarray] = {}
        for name, arr in self.channels.items():
            check_channel_name(name)
            arr = np.asarray(arr)
            if arr.ndim != 2:
                raise PlateError(f"channel {name!r} must be 2-D (H, W), got shape {arr.shape}")
            if arr.dtype.name not in DTYPES or not arr.dtype.isnative:
                raise PlateError(
                    f"channel {name!r} has dtype {arr.dtype}; valid dtypes are float16, float32 and uint32"
                )
            if shape is None:
                shape = arr.shape
            elif arr.shape != shape:
                raise PlateError(f"channel {name!r} has shape {arr.shape}, the plate is {shape}")
            fixed[name] = arr
        self.channels = fixed

    # -- shape -------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int]:
        for arr in self.channels.values():
            return arr.shape
        return (0, 0)

    @property
    def height(self) -> int:
        return self.shape[0]

    @property
    def width(self) -> int:
        return self.shape[1]

    # -- access ------------------------------------------------------------
    def __contains__(self, name: str) -> bool:
        return name in self.channels

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.channels[name]
        except KeyError:
            raise PlateError(
                f"plate has no channel {name!r}; it has {', '.join(sorted(self.channels)) or 'none'}"
            ) from None

    def names(self) -> list[str]:
        return list(self.channels)

    def layer(self, names: Iterable[str], dtype="float32") -> np.ndarray:
        """Stack channels into an (H, W, C) array, e.g. ``plate.layer("RGB")``."""
        names = list(names)
        return np.stack([self[n].astype(dtype, copy=False) for n in names], axis=-1)

    def rgb(self) -> np.ndarray:
        """(H, W, 3) float32 linear colour."""
        return self.layer(["R", "G", "B"])

    # -- building ----------------------------------------------------------
    def with_channels(self, channels: Mapping[str, np.ndarray] | None = None, meta: Mapping | None = None,
                      drop: Iterable[str] = ()) -> "Plate":
        """A new plate with channels added or replaced (arrays are shared, not copied)."""
        ch = {k: v for k, v in self.channels.items() if k not in set(drop)}
        ch.update(channels or {})
        md = dict(self.meta)
        md.update(meta or {})
        return Plate(ch, md)

    def select(self, names: Iterable[str]) -> "Plate":
        return Plate({n: self[n] for n in names}, dict(self.meta))

    def nbytes(self) -> int:
        return sum(a.nbytes for a in self.channels.values())

    def equals(self, other: "Plate") -> bool:
        """Bit-exact equality of channels (names, dtypes, values) and metadata."""
        if set(self.channels) != set(other.channels) or self.meta != other.meta:
            return False
        return all(
            self.channels[n].dtype == other.channels[n].dtype
            and self.channels[n].shape == other.channels[n].shape
            and self.channels[n].tobytes() == other.channels[n].tobytes()  # any strides; NaNs by their bits
            for n in self.channels
        )
