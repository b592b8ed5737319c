"""Poisson: gradient-domain transfer of the magnified synthesis.

Bonneel et al. 2010, §5 step 3 and §7: solve Δu = Δ(f∘s) in Ω, ∇u = 0 across patch
boundaries (Γ1), u = f∘s on boundaries between label ids (Γ2), with a multigrid solver
(``proxyshade.kernels.poisson``). Seams between patches are blended away while label
borders and each patch's inner detail stay as synthesized.

Across a seam the target gradient is, with ``seams: zero``, zero (the literal Γ1
condition; it also flattens the texture where patches are small), or, with ``seams:
source`` (the default), the source's own gradient read through the coordinate map on
both sides of the seam: the colour jump goes, the texture's contrast stays.

For a later frame (§6.3) the solve can be restricted to newly synthesized pixels: connect
``keep`` (a plate with ``R,G,B`` and a mask channel) and pixels where the mask is 0 keep
``keep``'s colours as Dirichlet values.
"""
from __future__ import annotations

import numpy as np

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate
from proxyshade.kernels import poisson as kpoisson
from proxyshade.nodes.patch_init import check_finite, require


class Poisson(Node):
    """Blend patch seams: ``R,G,B`` replaced by the Poisson solution; every other
    channel and the metadata pass through."""

    version = 1
    image = Input("magnified synthesis (Magnify): R,G,B, patch.id, label.id")
    source = Input("annotated source (SourceRead), for seams: source", optional=True)
    keep = Input("optional: R,G,B values and a mask channel; pixels with mask 0 stay fixed", optional=True)
    seams = Param(str, "source", choices=("source", "zero"),
                  doc="target gradient across patch seams: the source's through the map, or zero")
    screen = Param(float, 0.01, min=0.0,
                   doc="λ of a data term λ(u - f)²: 0 = pure Poisson (the paper; drifts far from label borders)")
    label_dirichlet = Param(bool, True, doc="keep pixels on boundaries between label ids (Γ2) unchanged")
    mask_channel = Param(str, "flag", doc="channel of 'keep' whose non-zero pixels are solved for")
    tol = Param(float, 1e-5, min=1e-12, max=1.0, doc="relative residual at which the solver stops")
    max_iter = Param(int, 100, min=1, doc="most conjugate-gradient iterations")

    def compute(self, ctx) -> Plate:
        p = ctx.p
        img = require(ctx, ctx.image, "image", ["R", "G", "B", "patch.id"], "Magnify's output")
        check_finite(ctx, img, "image", ["R", "G", "B"])
        labels = img["label.id"] if "label.id" in img else None
        if p.label_dirichlet and labels is None:
            raise ctx.error("image has no label.id for the label-boundary condition; connect Magnify's output "
                            "or set label_dirichlet: false")
        fixed = values = None
        if ctx.keep is not None:
            keep = require(ctx, ctx.keep, "keep", ["R", "G", "B", p.mask_channel],
                           f"a plate with R,G,B and {p.mask_channel}")
            if keep.shape != img.shape:
                raise ctx.error(f"keep is {keep.shape[1]}x{keep.shape[0]}, image {img.shape[1]}x{img.shape[0]}; "
                                "they must be the same size")
            check_finite(ctx, keep, "keep", ["R", "G", "B"])
            fixed = keep[p.mask_channel] == 0
            values = keep.rgb()
        gx = gy = None
        if p.seams == "source":
            source = ctx.source
            if source is None:
                raise ctx.error("seams: source needs the 'source' input; connect SourceRead or set seams: zero")
            source = require(ctx, source, "source", ["R", "G", "B"], "a SourceRead node")
            check_finite(ctx, source, "source", ["R", "G", "B"])
            for c in ("source.x", "source.y"):
                if c not in img:
                    raise ctx.error(f"image has no {c} for seams: source; connect Magnify's output or set seams: zero")
            scale = float(img.meta.get("synthesis", {}).get("scale", 1.0))
            gx, gy = kpoisson.seam_gradients(source.rgb(), img["source.x"], img["source.y"], scale)
        u, info = kpoisson.poisson_transfer(img.rgb(), img["patch.id"], labels, fixed=fixed, values=values,
                                            label_dirichlet=p.label_dirichlet, seam_gx=gx, seam_gy=gy,
                                            screen=p.screen, tol=p.tol, max_iter=p.max_iter)
        ctx.note(f"{info['iterations']} iterations, relative residual {info['residual']:.1e}, "
                 f"{info['fixed']} fixed pixels")
        return img.with_channels({"R": u[..., 0].copy(), "G": u[..., 1].copy(), "B": u[..., 2].copy()})
