"""AnnotatedSynth: fill a target with an annotated source's material following per-pixel
annotation maps, interpolating combinations the source never shows (Diamanti et al. 2015).

Reference: O. Diamanti, C. Barnes, S. Paris, E. Shechtman, O. Sorkine-Hornung, "Synthesis of
Complex Image Appearance from Limited Exemplars", ACM TOG 34(2), 2015."""
from __future__ import annotations

import lazy_loader

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate
from proxyshade.synthesis.annotated import AnnotatedMatching

np = lazy_loader.load("numpy")  # on first use: a fully cached run never loads numpy


def _ann_names(plate) -> list[str]:
    return sorted(n[4:] for n in plate.names() if n.startswith("ann."))


class AnnotatedSynth(AnnotatedMatching, Node):
    """Annotated-exemplar synthesis, one annotated source plate (``R,G,B``, ``ann.*``,
    optional ``A`` and ``mask``, e.g. from ``AnnotatedSourceRead``) and a target plate with
    the same ``ann.*`` channels (e.g. from ``AnnotationRender``).

    Source annotation points are clustered (mean shift); for each target pixel and
    cluster an ε-ball (axis-aligned ellipsoid, grown until it holds N_i source pixels)
    gives the cluster's weight (eq. 2) and restricts that cluster's PatchMatch; the
    per-cluster results are merged in CIELAB with a screened Poisson solve of L*.
    Out: ``R,G,B,A``, ``source.x/y`` (of the heaviest cluster), ``cluster.id`` (uint32,
    heaviest, 1..C) and ``missing`` (1 where no cluster holds N_i source pixels inside the
    ε-ball: appearance interpolated). A source with ``exemplar.id`` (an atlas of several
    exemplars, given ``ann.*`` channels) copies only patches lying inside one exemplar.
    With a ``background`` (a frame of the target's size, e.g. the first frame's final
    plate), the result goes over it by the target mask: the frame's channels with R,G,B
    replaced inside the mask. See docs/annotated.md.
    """

    version = 4
    source = Input("annotated source plate", channels=("R", "G", "B"), finite=("R", "G", "B"),
                   fix="connect an AnnotatedSourceRead node")
    target = Input("target annotation plate (ann.* channels)", fix="connect an AnnotationRender node")
    background = Input("optional frame (R,G,B) the result is composited over by the target mask", optional=True,
                       channels=("R", "G", "B"), finite=("R", "G", "B"),
                       fix="connect the first frame's final node (a Poisson or Magnify plate)")
    seed = Param(int, 0, min=0, doc="seed of the PatchMatch initialisation and searches")

    def compute(self, ctx) -> Plate:
        from proxyshade.synthesis.annotated import AnnotatedParams, synthesize

        src, tgt = ctx.inputs["source"], ctx.inputs["target"]
        names, tnames = _ann_names(src), _ann_names(tgt)
        if not names:
            raise ctx.error("source has no ann.* channels; read it with AnnotatedSourceRead and list "
                            "'annotations' in its source.yaml")
        if names != tnames:
            raise ctx.error(f"annotation channels differ: source has {', '.join('ann.' + n for n in names)}, target "
                            f"has {', '.join('ann.' + n for n in tnames) or 'none'}; render the same names")
        if ctx.p.patch % 2 == 0:
            raise ctx.error(f"patch {ctx.p.patch} is even; use an odd size like 5")
        usable = np.ones(src.shape, bool)
        if "mask" in src:
            usable &= src["mask"] > 0.5
        if "exemplar.id" in src:  # an ExemplarAtlas plate: patches stay inside one exemplar
            from proxyshade.synthesis.annotated import within_one_exemplar

            usable &= within_one_exemplar(src["exemplar.id"], ctx.p.patch // 2)
        alpha = src["A"].astype(np.float32) if "A" in src else np.ones(src.shape, np.float32)
        p = AnnotatedParams.of(ctx.p, AnnotatedMatching, "seed")
        tgt_ann = tgt.layer(["ann." + n for n in names], np.float64)
        tmask = tgt["mask"] > 0.5 if "mask" in tgt else None
        if tmask is not None:  # only the masked pixels are a target; the others take the masked mean
            if not tmask.any():
                raise ctx.error("target mask is empty; render a label the view shows")
            tgt_ann = np.where(tmask[..., None], tgt_ann, tgt_ann[tmask].mean(axis=0))
        box = (slice(None), slice(None))
        if tmask is not None:  # only the mask's bounding box is synthesized
            rows, cols = np.flatnonzero(tmask.any(axis=1)), np.flatnonzero(tmask.any(axis=0))
            box = (slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1))
        r = synthesize(src.rgb(), alpha, src.layer(["ann." + n for n in names], np.float64), usable,
                       np.ascontiguousarray(tgt_ann[box]), p, names=names)
        if tmask is not None:
            for k in ("rgb", "alpha", "sx", "sy", "cluster", "missing"):
                full = np.zeros(tmask.shape + r[k].shape[2:], r[k].dtype)
                full[box] = r[k]
                r[k] = full
        share = r["missing"][tmask].mean() if tmask is not None else r["missing"].mean()
        ctx.note(f"{r['n_clusters']} clusters; {100 * share:.1f}% of the target outside every "
                 f"cluster's ε-ball (interpolated)")
        rgb = r["rgb"]
        if tmask is not None:
            rgb = rgb * tmask[..., None]
            r["alpha"] = r["alpha"] * tmask
        ch = {"R": rgb[..., 0].copy(), "G": rgb[..., 1].copy(), "B": rgb[..., 2].copy(), "A": r["alpha"],
              "source.x": r["sx"], "source.y": r["sy"], "cluster.id": r["cluster"], "missing": r["missing"]}
        meta = {k: v for k, v in src.meta.items() if k in ("labels", "source")}
        meta["annotations"] = names
        bg = ctx.inputs.get("background")
        if bg is not None:
            if bg.shape != tgt.shape:
                raise ctx.error(f"background is {bg.shape[1]}x{bg.shape[0]}, the target {tgt.shape[1]}x{tgt.shape[0]}; "
                                f"render the proxy of the annotations at the frame's resolution")
            k = (tmask if tmask is not None else np.ones(tgt.shape, bool)).astype(np.float32) * r["alpha"]
            over = {c: ch[c] + (1.0 - k) * bg[c] for c in ("R", "G", "B")}  # ch is premultiplied by the mask
            over["A"] = k + (1.0 - k) * (bg["A"] if "A" in bg else 1.0)
            ch = {**{c: bg[c] for c in bg.names()}, **ch, **over}
            meta = {**bg.meta, "annotations": names}
        return Plate(ch, meta)
