"""ExrRead: a multichannel EXR (one per frame with ``####``) as a plate."""
from __future__ import annotations

from pathlib import Path

from proxyshade.graph.node import Node, Param
from proxyshade.graph.plate import Plate
from proxyshade.io.exr import read_plate


class ExrRead(Node):
    """Read an EXR; each channel keeps its stored type (half, float, uint)."""

    version = 1
    path = Param(Path, doc="EXR file; '####' is replaced by the frame number")
    channels = Param(list, None, doc="channels to keep (default: all)")

    def compute(self, ctx) -> Plate:
        plate = read_plate(ctx.path(ctx.p.path))
        if ctx.p.channels:
            missing = [c for c in ctx.p.channels if c not in plate]
            if missing:
                raise ctx.error(f"channels {missing} are not in {ctx.p.path}; it has {', '.join(plate.names())}")
            plate = plate.select(ctx.p.channels)
        return plate
