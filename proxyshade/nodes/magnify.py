"""Magnify: upsample the synthesized patches to the output size (no correction).

Reference: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010.

Bonneel et al. 2010, §5 step 3: "a synthesis magnification to the resolution of the
input image ... by upsampling patches without correction passes". Each synthesis pixel
becomes ``factor``×``factor`` output pixels reading the source at full detail along its
patch's translation; pixels whose source label differs from the detailed guide's are
moved onto the right label. Layer: ``proxyshade.synthesis.patches.magnify_map``; kernels
``proxyshade.kernels.magnify``; colours looked up through the map
(``proxyshade.kernels.lookup``).
"""
from __future__ import annotations

import lazy_loader

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate
from proxyshade.synthesis.params import source_input

np = lazy_loader.load("numpy")  # on first use: a fully cached run never loads numpy

DEPTH_CHANNELS = ("Z", "P.X", "P.Y", "P.Z", "N.X", "N.Y", "N.Z", "object.id")  # geometry AOVs passed on


class Magnify(Node):
    """Synthesis-size map -> output-size plate: ``R,G,B`` (linear, looked up in the
    source), ``label.id`` (the detailed guide), ``source.x/y``, ``patch.id``, and ``Z``
    (and ``P.X/Y/Z``, ``N.X/Y/Z``, ``object.id``) from ``depth`` when connected. Metadata: the label table and the
    source's photo and label-map paths (provenance of every pixel)."""

    version = 1
    synth = Input("synthesis-size map: Correct's (or PatchInit's) output", channels=("source.x", "source.y"),
                  finite=True, fix="connect Correct's output")
    source = source_input()
    guide = Input("detailed guide at output size: label.id", channels=("label.id",),
                  fix="connect the detailed guide (GuideSynth)")
    depth = Input("extended depth (DepthExtend): Z and optionally P.X/P.Y/P.Z, N.X/N.Y/N.Z, object.id", optional=True,
                  channels=("Z",), finite=("Z",), inf_ok=("Z",), dtype={"object.id": "uint32"},
                  fix="connect DepthExtend's output")
    repair = Param(bool, True, doc="move pixels whose source label differs from the guide's onto the right label")
    seam_passes = Param(int, 4, min=0, max=64,
                        doc="passes moving patch seams, one output pixel at a time, to where the patches on "
                            "either side agree (Kwatra et al. 2003's seam cost; needs repair); 0 = the "
                            "factor-pixel staircase of the synthesis")
    seam_runs = Param(bool, True,
                      doc="with seam_passes, also move runs of pixels along a seam at once (the part of a "
                          "straight seam that gains most shifts by a pixel); false = one-pixel moves only")
    patch_shift = Param(int, 0, min=0, max=8,
                        doc="with seam_passes, each whole patch may then move by up to this many output pixels "
                            "each way to where its seams cost least (a magnified patch is placed to a whole "
                            "synthesis pixel, factor output pixels), and the seams move again; 0 = off")
    patch_adopt = Param(int, 0, min=0,
                        doc="with patch_shift, a patch of at most this many pixels may also take the offset of a "
                            "patch beside it (their seam goes) where that costs least; 0 = none")

    spread_loss = Param(float, 0.1, min=0.0, max=1.0,
                        doc="with patch_shift, the most share of a label's summed squared tone deviation from "
                            "its mean the shifts may lose (they draw a label's light and dark patches to its mode)")

    def compute(self, ctx) -> Plate:
        from proxyshade.kernels.lookup import lookup
        from proxyshade.synthesis import labels as L
        from proxyshade.synthesis.exemplar import provenance, source_to_grid
        from proxyshade.synthesis.patches import magnify_map, working_colours

        synth, source, guide, depth = ctx.synth, ctx.source, ctx.guide, ctx.depth
        syn = synth.meta.get("synthesis")
        if not isinstance(syn, dict) or "factor" not in syn:
            raise ctx.error("input 'synth' has no synthesis metadata; connect Correct's or PatchInit's output")
        f, scale, F = int(syn["factor"]), float(syn["scale"]), float(syn["exemplar_factor"])
        Ho, Wo = guide.shape
        Ht, Wt = synth.shape
        if (Ht - 1) * f >= Ho or Ht * f < Ho or (Wt - 1) * f >= Wo or Wt * f < Wo:
            raise ctx.error(f"guide is {Wo}x{Ho} but synth is {Wt}x{Ht} at factor {f}; connect the guide PatchInit used")
        if depth is not None and depth.shape != (Ho, Wo):
            raise ctx.error(f"depth is {depth.shape[1]}x{depth.shape[0]}, guide {Wo}x{Ho}; "
                            "connect DepthExtend's output for this guide")
        table = L.source_table(source)
        g = L.dense_guide(guide["label.id"], table)
        # what only passes through: the guide's label.id, the depth channels, their metadata; then
        # the guide and depth plates are released, and where the engine can read those channels
        # back from the plate's cache entry after the magnification they are not held through it
        # (DepthExtend's plate, guide and depth alike in graphs/first_frame.yaml: 48 MiB at 1024
        # wide, 405 MiB at 4K)
        one = depth is guide  # one plate (graphs/first_frame.yaml): its channels read back in one pass
        passed = {"label.id": ("depth" if one else "guide", guide["label.id"])}
        if depth is not None:
            passed.update((c, ("depth", depth[c])) for c in DEPTH_CHANNELS if c in depth)
        pmeta = {k: pl.meta[k] for k in ("camera", "up_axis", "objects")  # depth's first, as before
                 for pl in (guide, depth) if pl is not None and k in pl.meta}
        del guide, depth
        again = {}
        for name in ("guide", "depth"):
            ctx.release(name, wait_written=True)
            again[name] = ctx.read_back(name)
        back = {c: src for c, (src, _) in passed.items() if again.get(src) is not None}
        kept = {c: a for c, (_, a) in passed.items() if c not in back}
        del passed
        S = np.stack([source_to_grid(synth["source.y"], F), source_to_grid(synth["source.x"], F)], -1)
        wl = L.source_working_labels(source, table, scale, ctx.memo)
        colours = None
        if ctx.p.seam_passes and ctx.p.repair:
            colours = working_colours(source.rgb(), L.source_dense(source, table), scale, len(table), ctx.memo)
        sx, sy, patch, npatch, rep = magnify_map(S.astype(np.int32), f, (Ho, Wo), scale=scale,
                                                 target=g if ctx.p.repair else None, labels=wl, memo=ctx.memo,
                                                 colours=colours, seam_passes=ctx.p.seam_passes,
                                                 seam_runs=ctx.p.seam_runs, patch_shift=ctx.p.patch_shift,
                                                 patch_adopt=ctx.p.patch_adopt,
                                                 spread_loss=ctx.p.spread_loss)
        if ctx.p.repair:
            ctx.note(f"{rep['wrong']} pixels landed on another label: {rep['extended']} continued a neighbour's "
                     f"patch, {rep['nearest']} took the nearest right-label source pixel; "
                     f"{rep['seam_moves']} seam moves, {rep['patch_shifts']} patches shifted")
        rgb = lookup(source.rgb(), sx, sy)
        ch = {"R": rgb[..., 0].copy(), "G": rgb[..., 1].copy(), "B": rgb[..., 2].copy()}
        del rgb, S, g
        for src in dict.fromkeys(back.values()):
            kept.update(again[src]([c for c in back if back[c] == src]))
        ch.update({"label.id": kept["label.id"].astype(np.uint32, copy=False), "source.x": sx, "source.y": sy,
                   "patch.id": patch})
        for c in DEPTH_CHANNELS:
            if c in kept:
                ch[c] = kept[c] if c == "object.id" else kept[c].astype(np.float32, copy=False)
        meta = provenance(source)
        meta["synthesis"] = dict(syn, patches=npatch, magnified=True, repaired=int(rep["wrong"]))
        meta.update(pmeta)
        return Plate(ch, meta)

