"""Movie: an animated GIF of the whole sequence, for a supervisor to watch a shot."""
from __future__ import annotations

from pathlib import Path

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate
from proxyshade.io.images import resize_u8, write_gif
from proxyshade.kernels.display import channels_problem
from proxyshade.synthesis.params import DisplayView


class Movie(DisplayView, Node):
    """Write a looping animated GIF of ``channels`` of ``image``, first to last requested frame.

    Pictures as Preview makes them, downscaled to ``max_size``. A sequence node: computed once
    per run, at the last requested frame; a changed frame rewrites the movie. GIF keeps 256
    colours per frame (dithered) and delays in hundredths of a second, so 24 fps plays at 25."""

    version = 2
    sink = True
    image = Input("the plates to show: connect {node: X, frame: all}", sequence=True)
    path = Param(Path, doc="output animated GIF")
    fps = Param(int, 24, min=1, max=50, doc="frames per second (GIF plays 100 / int(100 / fps))")
    max_size = Param(int, 512, min=16, doc="long edge of the movie's frames; larger plates are downscaled")

    def compute(self, ctx) -> Plate:
        frames, shape = [], None
        for frame, plate in zip(ctx.image.frames, ctx.image):
            problem = channels_problem(plate.names(), ctx.p.channels)
            if problem:
                raise ctx.error(f"frame {frame}: {problem}")
            shape = shape or plate.shape
            if plate.shape != shape:
                raise ctx.error(f"frame {frame} is {plate.width}x{plate.height}, frame {ctx.image.frames[0]} is "
                                f"{shape[1]}x{shape[0]}; a movie needs one size for every frame")
            frames.append(resize_u8(DisplayView.show(plate, ctx.p), ctx.p.max_size))
        path = write_gif(ctx.path(ctx.p.path), frames, ctx.p.fps)
        return Plate(meta={"movie": str(path), "frames": [ctx.image.frames[0], ctx.image.frames[-1]]})
