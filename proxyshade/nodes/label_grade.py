"""A colour grade restricted to one texture label (a different sky colour, warmer grass).

Reference: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010.

Bonneel et al. 2010, §7: the layered representation "allows for image manipulation (e.g.,
changing the sky color)". The grade works in linear light on the plate's scene-linear
Rec.709/sRGB primaries, with colour-science for the colourimetry:

1. white balance: von Kries chromatic adaptation (CAT02 by default) that moves the white
   of a 6504 K Planckian light to the white of ``temperature`` (Kang et al. 2002 CCT->xy),
   so ``temperature < 6504`` warms and ``> 6504`` cools;
2. exposure: times ``2**exposure``;
3. ASC CDL slope / offset / power per channel: ``(c*slope + offset)**power`` (values <= 0
   pass the power unchanged, so negative linear values do not become NaN);
4. saturation about Rec.709 luminance: ``L + s*(c - L)``.
"""
from __future__ import annotations


import lazy_loader

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate
from proxyshade.io.colourlib import colour_science

np = lazy_loader.load("numpy")  # on first use: a fully cached run never loads numpy


REFERENCE_CCT = 6504.0
ADAPTATIONS = ("CAT02", "CAT16", "Bradford", "Von Kries")


def white_balance_matrix(temperature: float, transform: str = "CAT02") -> np.ndarray:
    """(3, 3) linear-sRGB matrix adapting the white of 6504 K to that of ``temperature`` K."""
    cs = colour_science().RGB_COLOURSPACES["sRGB"]
    xy_ref = colour_science().temperature.CCT_to_xy_Kang2002(REFERENCE_CCT)
    xy_new = colour_science().temperature.CCT_to_xy_Kang2002(float(temperature))
    cat = colour_science().adaptation.matrix_chromatic_adaptation_VonKries(
        colour_science().xy_to_XYZ(xy_ref), colour_science().xy_to_XYZ(xy_new), transform=transform)
    return np.asarray(cs.matrix_XYZ_to_RGB @ cat @ cs.matrix_RGB_to_XYZ, np.float64)


def luminance_weights() -> np.ndarray:
    """Rec.709 / sRGB luminance weights (the Y row of RGB->XYZ)."""
    return np.asarray(colour_science().RGB_COLOURSPACES["sRGB"].matrix_RGB_to_XYZ[1], np.float64)


def grade(rgb: np.ndarray, *, temperature: float = REFERENCE_CCT, adaptation: str = "CAT02",
          exposure: float = 0.0, slope=(1, 1, 1), offset=(0, 0, 0), power=(1, 1, 1),
          saturation: float = 1.0) -> np.ndarray:
    """Grade (N, 3) linear colours; returns float64 (N, 3). See the module docstring."""
    c = np.asarray(rgb, np.float64)
    if temperature != REFERENCE_CCT:
        c = c @ white_balance_matrix(temperature, adaptation).T
    if exposure != 0.0:
        c = c * 2.0 ** exposure
    c = c * np.asarray(slope, np.float64) + np.asarray(offset, np.float64)
    pw = np.asarray(power, np.float64)
    if np.any(pw != 1.0):
        pos = c > 0
        c = np.where(pos, np.power(np.where(pos, c, 1.0), pw), c)
    if saturation != 1.0:
        lum = c @ luminance_weights()
        c = lum[:, None] + saturation * (c - lum[:, None])
    return c


def _triple(ctx, name: str, value) -> list[float]:
    try:
        out = [float(v) for v in value]
    except (TypeError, ValueError):
        out = []
    if len(out) != 3 or not all(np.isfinite(out)):
        raise ctx.error(f"{name} {value!r} is not three finite numbers (R, G, B); write e.g. [1.0, 1.0, 1.0]")
    return out


class LabelGrade(Node):
    """Grade the pixels of one texture label in linear light; all other pixels are untouched."""

    version = 1
    image = Input("plate with R,G,B, label.id and meta['labels']", channels=("R", "G", "B", "label.id"))
    label = Param(str, doc="name of the label to grade (from meta['labels'])")
    temperature = Param(float, REFERENCE_CCT, min=1667.0, max=25000.0,
                        doc="white balance: 6504 K white becomes this CCT's white (lower = warmer)")
    adaptation = Param(str, "CAT02", choices=ADAPTATIONS, doc="chromatic adaptation transform")
    exposure = Param(float, 0.0, min=-16.0, max=16.0, doc="stops")
    slope = Param(list, [1.0, 1.0, 1.0], length=3, doc="ASC CDL slope (R, G, B)")
    offset = Param(list, [0.0, 0.0, 0.0], length=3, doc="ASC CDL offset (R, G, B), linear units")
    power = Param(list, [1.0, 1.0, 1.0], length=3, doc="ASC CDL power (R, G, B), > 0")
    saturation = Param(float, 1.0, min=0.0, max=10.0, doc="about Rec.709 luminance; 0 = grey")

    def compute(self, ctx) -> Plate:
        img: Plate = ctx.image
        p = ctx.p
        table = img.meta.get("labels") or []
        ids = {t["name"]: int(t["id"]) for t in table}
        if p.label not in ids:
            known = ", ".join(ids) or "none (the plate has no label table)"
            raise ctx.error(f"label {p.label!r} is not in this plate's labels; its labels are {known}")
        slope, offset, power = (_triple(ctx, n, getattr(p, n)) for n in ("slope", "offset", "power"))
        if min(power) <= 0:
            raise ctx.error(f"power {power} must be > 0 in every channel")
        mask = img["label.id"] == ids[p.label]
        if not mask.any():
            ctx.note(f"label {p.label!r} covers no pixel; nothing graded")
            return img
        rgb = img.layer("RGB")
        sel = rgb[mask]
        graded = grade(sel, temperature=p.temperature, adaptation=p.adaptation, exposure=p.exposure,
                       slope=slope, offset=offset, power=power, saturation=p.saturation)
        out = {}
        for i, c in enumerate("RGB"):
            ch = img[c].astype(np.float32, copy=True)
            ch[mask] = graded[:, i].astype(np.float32)
            out[c] = ch
        return img.with_channels(out)
