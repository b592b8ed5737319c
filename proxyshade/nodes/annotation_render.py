"""AnnotationRender: per-pixel annotation maps of a proxy render (light, distance, slope).

Reference: O. Diamanti, C. Barnes, S. Paris, E. Shechtman, O. Sorkine-Hornung, "Synthesis of
Complex Image Appearance from Limited Exemplars", ACM TOG 34(2), 2015."""
from __future__ import annotations

import lazy_loader

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate

np = lazy_loader.load("numpy")  # on first use: a fully cached run never loads numpy

KINDS = ("light", "depth", "up")


class AnnotationRender(Node):
    """``ann.<name>`` channels in [0, 1] from a ``ProxyRender`` plate, for ``AnnotatedSynth``:

    - ``light``: max(N·L, 0), times 1 − ``shadow`` when the optional ``shadow`` input (a
      ``ShadowMap`` plate) is connected; L is that plate's ``meta['light']`` direction, else
      the ``sun`` parameter (direction towards the sun, world space); ``light_range`` maps
      [shaded, lit] to [0, 1] (clipped);
    - ``depth``: camera depth Z mapped linearly from ``depth_range`` (default: the finite
      Z of the masked pixels) to [0, 1] (near 0, far 1);
    - ``up``: (N.Y + 1) / 2 (1 facing up, 0.5 a vertical wall).

    ``label`` restricts the target to one label of the proxy (``mask`` = 1 there); the
    other pixels get the masked pixels' mean values (inside the source's range).
    """

    version = 2
    proxy = Input("proxy render with N.X/N.Y/N.Z, Z and label.id", channels=("N.X", "N.Y", "N.Z", "Z", "label.id"),
                  finite=("N.X", "N.Y", "N.Z"), inf_ok=("Z",), fix="connect a ProxyRender node")
    shadow = Input("optional ShadowMap plate (its 'shadow' AOV and meta['light'])", optional=True,
                   channels=("shadow",), fix="connect a ShadowMap node")
    annotations = Param(dict, {"light": "light", "scale": "depth"},
                        doc="annotation name -> what it is (light, depth, up), e.g. {light: light, scale: depth}")
    sun = Param(list, [0.3, 0.8, 0.5], length=3, doc="direction towards the sun (world) when no shadow plate gives one")
    depth_range = Param(list, None, length=2, doc="[near, far] camera depth mapped to 0 and 1 (default: the masked range)")
    light_range = Param(list, None, length=2,
                        doc="[shaded, lit] light values mapped to 0 and 1, e.g. [0.2, 0.75] where a painted source "
                            "light map spans 0..1 for the shade and the full sun its photo shows (default: as is)")
    label = Param(str, None, doc="only this proxy label is a target (mask); default: every non-empty pixel")

    def compute(self, ctx) -> Plate:
        proxy = ctx.inputs["proxy"]
        shadow = ctx.inputs.get("shadow")
        for name, kind in ctx.p.annotations.items():
            if kind not in KINDS:
                raise ctx.error(f"annotations.{name}: {kind!r} is not one of {', '.join(KINDS)}; pick one of those")
        Z = proxy["Z"]
        mask = np.isfinite(Z)
        if ctx.p.label is not None:
            ids = {t["name"]: t["id"] for t in proxy.meta.get("labels", [])}
            if ctx.p.label not in ids:
                raise ctx.error(f"label {ctx.p.label!r} is not in the proxy's label table ({', '.join(ids)}); "
                                f"pick one of those")
            mask &= proxy["label.id"] == ids[ctx.p.label]
        if not mask.any():
            raise ctx.error("no target pixel (empty proxy or label absent from the view); check 'label' and the camera")
        N = proxy.layer(["N.X", "N.Y", "N.Z"], np.float64)
        light = (shadow.meta.get("light") or {}) if shadow is not None else {}
        if light.get("direction") is not None:
            L = -np.asarray(light["direction"], np.float64)  # the light travels along 'direction'
        else:
            L = np.asarray(ctx.p.sun, np.float64)
        if not np.all(np.isfinite(L)) or np.linalg.norm(L) == 0:
            raise ctx.error(f"sun {ctx.p.sun!r} is not a direction; write three finite numbers, e.g. [0.3, 0.8, 0.5]")
        L = L / np.linalg.norm(L)
        out = {}
        for name, kind in ctx.p.annotations.items():
            if kind == "light":
                v = np.clip(N @ L, 0.0, 1.0)
                if shadow is not None:
                    v = v * (1.0 - np.clip(shadow["shadow"], 0.0, 1.0))
                if ctx.p.light_range is not None:
                    lo, hi = (float(x) for x in ctx.p.light_range)
                    if not 0 <= lo < hi <= 1:
                        raise ctx.error(f"light_range {ctx.p.light_range!r} is not [shaded, lit] with 0 <= shaded < "
                                        f"lit <= 1; write e.g. [0.2, 0.75]")
                    v = np.clip((v - lo) / (hi - lo), 0.0, 1.0)
            elif kind == "up":
                v = np.clip((N[..., 1] + 1.0) / 2.0, 0.0, 1.0)
            else:
                zr = ctx.p.depth_range or [float(Z[mask].min()), float(Z[mask].max())]
                span = max(zr[1] - zr[0], 1e-12)
                v = np.clip((np.where(np.isfinite(Z), Z, zr[1]) - zr[0]) / span, 0.0, 1.0)
            v = np.where(mask, v, v[mask].mean())
            out[f"ann.{name}"] = v.astype(np.float32)
        out["mask"] = mask.astype(np.float32)
        return Plate(out, {k: v for k, v in proxy.meta.items() if k == "labels"})
