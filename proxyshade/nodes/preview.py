"""Preview: a PNG of chosen channels for people to look at (not for pipelines)."""
from __future__ import annotations

from pathlib import Path

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate
from proxyshade.io.images import write_png
from proxyshade.kernels.display import channels_problem
from proxyshade.synthesis.params import DisplayView


class Preview(DisplayView, Node):
    """Write a PNG of ``channels`` of ``image``: colour as sRGB, ``label.id`` and other id
    channels in distinct colours (the label table's own where known), depth as grey."""

    version = 2
    sink = True
    image = Input("the plate to look at")
    path = Param(Path, doc="output PNG; '####' is replaced by the frame number")

    def compute(self, ctx) -> Plate:
        """Write the PNG; the plate returned holds the channels shown. The input is released
        once the picture is made: the PNG's encoding does not hold the whole plate (at 4K the
        detailed guide's 371 MiB while its label preview was encoded)."""
        plate = ctx.image
        problem = channels_problem(plate.names(), ctx.p.channels)
        if problem:
            raise ctx.error(problem)
        picture = DisplayView.show(plate, ctx.p)
        shown = plate.select(dict.fromkeys(ctx.p.channels))
        del plate
        ctx.release("image")
        write_png(ctx.path(ctx.p.path), picture)
        return shown
