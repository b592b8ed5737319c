"""Preview: a PNG of chosen channels for people to look at (not for pipelines)."""
from __future__ import annotations

from pathlib import Path

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate
from proxyshade.io.images import write_png
from proxyshade.kernels.display import DEFAULT_CHANNELS, VIEWS, channels_problem, to_display


class Preview(Node):
    """Write a PNG of ``channels`` of ``image``: colour as sRGB, ``label.id`` and other id
    channels in distinct colours (the label table's own where known), depth as grey."""

    version = 2
    sink = True
    image = Input("the plate to look at")
    path = Param(Path, doc="output PNG; '####' is replaced by the frame number")
    channels = Param(list, list(DEFAULT_CHANNELS), doc="one id/depth channel, or three colour channels")
    exposure = Param(float, 0.0, doc="stops of exposure for colour channels")
    view = Param(str, "shoulder", choices=VIEWS,
                 doc="colour view transform (kernels.display.view_transform): 'shoulder' rolls values above 0.9 "
                     "off smoothly toward white (a plate may exceed 1), 'clip' shows them all as white")

    def compute(self, ctx) -> Plate:
        plate = ctx.image
        problem = channels_problem(plate.names(), ctx.p.channels)
        if problem:
            raise ctx.error(problem)
        write_png(ctx.path(ctx.p.path), to_display(plate, ctx.p.channels, ctx.p.exposure, ctx.p.view))
        return plate
