"""TextureSynth: plain exemplar texture synthesis, an image in, a larger texture out: the
yardstick each synthesis core that can make a plain texture is held to
(``bench/bench_texture.py``, ``graphs/texture.yaml``).

References: O. Diamanti, C. Barnes, S. Paris, E. Shechtman, O. Sorkine-Hornung, "Synthesis
of Complex Image Appearance from Limited Exemplars", ACM TOG 34(2), 2015. E. Risser, C. Han,
R. Dahyot, E. Grinspun, "Synthesizing Structured Image Hybrids", SIGGRAPH 2010."""
from __future__ import annotations

from pathlib import Path

import lazy_loader

from proxyshade.graph.node import Node, Param
from proxyshade.graph.plate import Plate
from proxyshade.synthesis.annotated import PatchOptimisation

np = lazy_loader.load("numpy")  # on first use: a fully cached run never loads numpy

METHODS = ("annotated", "hybrid")


class TextureSynth(PatchOptimisation, Node):
    """Synthesize a ``size``×``size`` texture from an exemplar image (PNG/JPEG, sRGB-decoded
    to linear, or an EXR plate's ``R,G,B``). ``method``: the synthesis core, ``annotated``
    (``AnnotatedSynth``'s coarse-to-fine PatchMatch + voting with constant annotations:
    docs/annotated.md) or ``hybrid`` (``HybridSynth``'s pointer synthesis on one exemplar,
    ``synthesis.hybrid.plain_texture``: docs/hybrids.md). Out: ``R,G,B,A`` and ``source.x/y`` (the exemplar pixel each output
    pixel's patch centre copies)."""

    version = 1
    exemplar = Param(Path, doc="exemplar image: PNG, JPEG or EXR (R,G,B)")
    # text, as a graph's --var gives it ("--var size=512"); checked in compute
    size = Param(str, "256", doc="output width and height in pixels, 16..4096")
    method = Param(str, "annotated", choices=METHODS, doc="synthesis core")
    seed = Param(int, 0, min=0, doc="seed of the initialisation and searches")

    def compute(self, ctx) -> Plate:
        from proxyshade.synthesis.annotated import AnnotatedParams, auto_levels, plain_texture

        p = ctx.p
        path = ctx.path(p.exemplar)
        if p.patch % 2 == 0:
            raise ctx.error(f"patch {p.patch} is even; use an odd size like 5")
        size = str(p.size).strip()
        if not size.isdigit() or not 16 <= int(size) <= 4096:
            raise ctx.error(f"size {p.size!r} is not a whole number of pixels in 16..4096; give one like 256")
        size = int(size)
        rgb = _read(path, ctx)
        levels = p.levels or auto_levels(rgb.shape, (size, size))
        need = (p.patch + 1) * 2 ** (levels - 1)
        if p.method == "annotated" and min(rgb.shape[:2]) < need:
            raise ctx.error(f"exemplar {path.name} is {rgb.shape[1]}x{rgb.shape[0]}, too small for {levels} scales "
                            f"of {p.patch}-pixel patches; use an exemplar of at least {need} pixels a side or "
                            f"fewer levels")
        if p.method == "hybrid":
            from proxyshade.synthesis import hybrid

            r = hybrid.plain_texture(rgb, (size, size), seed=p.seed)
        else:
            a = AnnotatedParams.of(p, PatchOptimisation, "seed", levels=levels)
            r = plain_texture(rgb, (size, size), a)
        out = r["rgb"]
        ch = {"R": out[..., 0].copy(), "G": out[..., 1].copy(), "B": out[..., 2].copy(),
              "A": np.ones(out.shape[:2], np.float32), "source.x": r["sx"], "source.y": r["sy"]}
        return Plate(ch, {"texture": {"exemplar": str(path), "method": p.method, "exemplar_size": list(rgb.shape[:2])}})


def _read(path: Path, ctx) -> "np.ndarray":
    """(H, W, 3) float32 linear RGB of an image file."""
    if not path.is_file():
        raise ctx.error(f"exemplar {path} does not exist; give a PNG, JPEG or EXR file")
    if path.suffix.lower() == ".exr":
        from proxyshade.io.exr import read_plate

        plate = read_plate(path)
        if not all(c in plate for c in ("R", "G", "B")):
            raise ctx.error(f"exemplar {path} has no R,G,B channels; write the colour as R,G,B")
        return np.ascontiguousarray(plate.rgb(), np.float32)
    from proxyshade.io.images import read_u8
    from proxyshade.io.source import srgb_to_linear

    rgb8 = read_u8(path)
    if rgb8.ndim == 2:
        rgb8 = rgb8[..., None]
    if rgb8.shape[2] == 1:
        rgb8 = np.repeat(rgb8, 3, axis=2)
    return srgb_to_linear(np.ascontiguousarray(rgb8[..., :3]))
