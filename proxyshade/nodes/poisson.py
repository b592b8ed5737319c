"""Poisson: gradient-domain transfer of the magnified synthesis.

Reference: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010.

Bonneel et al. 2010, §5 step 3 and §7: solve Δu = Δ(f∘s) in Ω, ∇u = 0 across patch
boundaries (Γ1), u = f∘s on boundaries between label ids (Γ2), with a multigrid solver
(layer ``proxyshade.synthesis.blend``, kernels ``proxyshade.kernels.poisson``). Seams between patches are blended away while label
borders and each patch's inner detail stay as synthesized.

Across a seam the target gradient is, with ``seams: zero``, zero (the literal Γ1
condition; it also flattens the texture where patches are small), or, with ``seams:
source`` (the default), the source's own gradient read through the coordinate map on
both sides of the seam: the colour jump goes, the texture's contrast stays.

With ``grain`` (default 2, 1 = off) the blended frame's detail is then matched to the
photo's, label by label and scale by scale: the source is graded by the gains
(``synthesis.grain``), the frame read again through its map and blended again, and the
gains go into ``meta["grain"]`` so that later frames (Reproject, Resynthesize) and Relight
read the same graded source.

For a later frame (§6.3) the solve can be restricted to newly synthesized pixels: connect
``keep`` (a plate with ``R,G,B`` and a mask channel) and pixels where the mask is 0 keep
``keep``'s colours as Dirichlet values.
"""
from __future__ import annotations

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate
from proxyshade.synthesis.params import PoissonSolve


SOLVE_READS = ("R", "G", "B", "patch.id", "label.id", "source.x", "source.y")  # the image's channels blend_frame reads


class Poisson(PoissonSolve, Node):
    """Blend patch seams: ``R,G,B`` replaced by the Poisson solution; every other
    channel and the metadata pass through."""

    version = 4
    image = Input("magnified synthesis (Magnify): R,G,B, patch.id, label.id", channels=("R", "G", "B", "patch.id"),
                  finite=("R", "G", "B"), fix="connect Magnify's output")
    source = Input("annotated source (SourceRead), for seams: source", optional=True, channels=("R", "G", "B"),
                   finite=True, fix="connect a SourceRead node")
    keep = Input("optional: R,G,B values and a mask channel; pixels with mask 0 stay fixed", optional=True,
                 channels=("R", "G", "B"), finite=("R", "G", "B"), fix="connect a plate with R,G,B and the mask channel")
    mask_channel = Param(str, "flag", doc="channel of 'keep' whose non-zero pixels are solved for")

    def compute(self, ctx) -> Plate:
        from proxyshade.synthesis.blend import blend_frame

        p, img = ctx.p, ctx.image
        labels = img["label.id"] if "label.id" in img else None
        if p.label_dirichlet and labels is None:
            raise ctx.error("image has no label.id for the label-boundary condition; connect Magnify's output "
                            "or set label_dirichlet: false")
        fixed = values = None
        if ctx.keep is not None:
            keep = ctx.keep
            if p.mask_channel not in keep:
                raise ctx.error(f"input 'keep' has no channel {p.mask_channel} (it has {', '.join(keep.names())}); "
                                f"connect a plate with R,G,B and {p.mask_channel} or set mask_channel")
            if keep.shape != img.shape:
                raise ctx.error(f"keep is {keep.shape[1]}x{keep.shape[0]}, image {img.shape[1]}x{img.shape[0]}; "
                                "they must be the same size")
            fixed = keep[p.mask_channel] == 0
            values = keep.rgb()
        src = ctx.source
        if p.layout and (src is None or "label.id" not in src or labels is None):
            raise ctx.error("layout: true needs the 'source' input (SourceRead: R,G,B, label.id) and the image's "
                            "label.id; connect SourceRead and Magnify's output or set layout: false")
        if p.seams == "source":
            if src is None:
                raise ctx.error("seams: source needs the 'source' input; connect SourceRead or set seams: zero")
            for c in ("source.x", "source.y"):
                if c not in img:
                    raise ctx.error(f"image has no {c} for seams: source; connect Magnify's output or set seams: zero")
        # the channels the solve reads and those that pass through, taken from the plate; then
        # the plate is released (its R, G, B, replaced by the solution, leave memory before the
        # solve where nothing else reads them: 101 MiB at 4K; a cache write of the plate still
        # running holds them until it is done: the solve waits for it, else its peak would
        # come on top of them)
        rgb, order, kept, meta_in = img.rgb(), list(img.channels), {}, img.meta
        for n in order:
            if n not in ("R", "G", "B"):
                kept[n] = img[n]
        scale = float(meta_in.get("synthesis", {}).get("scale", 1.0))
        del img
        ctx.release("image", wait_written=True)
        # the float channels only passed through (depth: Z, P, N) are not held through the solve
        # where the engine can read them back from Magnify's cache entry after it (one
        # decompression pass of that file; 7 channels, 28 MiB at 1024 wide, 232 MiB at 4K)
        again = ctx.read_back("image")
        gone = [n for n in order if n not in SOLVE_READS and kept[n].dtype.kind == "f"] if again else []
        for n in gone:
            del kept[n]
        # everything at hand is passed; blend_frame takes what layout, seams and grain need (grain:
        # the source's labels and the map on a whole frame, quietly off without them or with keep)
        u, info = blend_frame(rgb, kept["patch.id"], labels, PoissonSolve.of(p),
                              source_rgb=src.rgb() if src is not None else None,
                              sx=kept.get("source.x"), sy=kept.get("source.y"), scale=scale, fixed=fixed,
                              values=values,
                              source_labels=src["label.id"] if src is not None and "label.id" in src else None,
                              source=src, memo=ctx.memo)
        del rgb
        ctx.note(f"{info['iterations']} iterations, relative residual {info['residual']:.1e}, "
                 f"{info['fixed']} fixed pixels")
        meta = dict(meta_in)
        if "grain" in info:
            meta["grain"] = info["grain"]
            g = [v for rows in info["grain"]["gains"].values() for row in rows for v in row]
            ctx.note(f"grain: detail gains {min(g):.2f}-{max(g):.2f}")
        if info.get("negative"):
            ctx.note(f"{info['negative']} negative values raised to 0")
        for c, n in enumerate("RGB"):
            kept[n] = u[..., c].copy()
        del u
        if gone:
            kept.update(again(gone))
        return Plate({n: kept[n] for n in order}, meta)
