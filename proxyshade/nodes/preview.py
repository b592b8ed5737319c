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
        plate = ctx.image
        problem = channels_problem(plate.names(), ctx.p.channels)
        if problem:
            raise ctx.error(problem)
        write_png(ctx.path(ctx.p.path), DisplayView.show(plate, ctx.p))
        return plate
