"""ExrWrite: write the input plate as a multichannel EXR (``####`` frame padding)."""
from __future__ import annotations

import fnmatch
from pathlib import Path

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate
from proxyshade.io.exr import COMPRESSION_NAMES, write_plate


class ExrWrite(Node):
    """Write ``image`` to ``path`` (temporary name, then renamed into place).

    The header carries ``proxyshade/node``, ``proxyshade/frame`` and the plate's metadata.
    """

    version = 1
    sink = True
    image = Input("the plate to write")
    path = Param(Path, doc="output EXR; '####' is replaced by the frame number")
    channels = Param(list, None, doc="channels to write (default: all); shell patterns select several "
                                     "('Crypto*', 'P.*')")
    compression = Param(str, "zip", choices=COMPRESSION_NAMES, doc="EXR compression")

    def compute(self, ctx) -> Plate:
        plate = ctx.image
        if ctx.p.channels:
            names = plate.names()
            chosen, missing = [], []
            for c in ctx.p.channels:
                hits = fnmatch.filter(names, c) if any(ch in c for ch in "*?[") else [c] if c in plate else []
                chosen += [h for h in hits if h not in chosen]
                if not hits:
                    missing.append(c)
            if missing:
                raise ctx.error(f"channels {missing} are not in the input; it has {', '.join(names)}")
            plate = plate.select(chosen)
        write_plate(ctx.path(ctx.p.path), plate, compression=ctx.p.compression,
                    extra={"proxyshade/node": self.name, "proxyshade/frame": str(ctx.frame)})
        return plate
