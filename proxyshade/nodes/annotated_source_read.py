"""AnnotatedSourceRead: a source photo with per-pixel annotation maps (Diamanti et al. 2015).

Reference: O. Diamanti, C. Barnes, S. Paris, E. Shechtman, O. Sorkine-Hornung, "Synthesis of
Complex Image Appearance from Limited Exemplars", ACM TOG 34(2), 2015."""
from __future__ import annotations

from pathlib import Path

import lazy_loader

from proxyshade.graph import keys
from proxyshade.graph.node import Node, Param
from proxyshade.graph.plate import Plate
from proxyshade.io.source import load_source, load_table
from proxyshade.synthesis.params import LabelMapSnap

np = lazy_loader.load("numpy")  # on first use: a fully cached run never loads numpy


class AnnotatedSourceRead(LabelMapSnap, Node):
    """Read an annotated source: ``R,G,B``, ``label.id`` (as ``SourceRead``), one
    ``ann.<name>`` channel per entry of the table's ``annotations: {light: light.png, ...}``
    (grey maps, 0..255 -> [0, 1]), ``A`` from the optional ``alpha`` map (1 without one)
    and ``mask`` (float 1/0; pixels > 127 of the optional ``mask`` map, all without one).
    """

    version = 2
    table = Param(Path, doc="label table YAML (source.yaml) with an 'annotations' mapping")
    annotations = Param(list, None, doc="names of the table's annotations to read, e.g. [light] (default: all)")

    def key_extra(self, frame, graph_dir):
        from proxyshade.graph.node import resolve_path

        try:
            path = resolve_path(self.params["table"], graph_dir, frame)
            t = load_table(path)
        except Exception:  # noqa: BLE001 - reported properly by compute
            return None
        files = [t["image"], t["labels_map"]] + [str(path.parent / v) for v in (t.get("annotations") or {}).values()
                                                 if isinstance(v, str)]
        files += [str(path.parent / t[k]) for k in ("mask", "alpha") if isinstance(t.get(k), str)]
        return {f: keys.file_hash(Path(f)) for f in files if Path(f).is_file()}

    def compute(self, ctx) -> Plate:
        from proxyshade.errors import UserError
        from proxyshade.io.source import load_annotations

        path = ctx.path(ctx.p.table)
        plate = load_source(path, far_distance=ctx.p.far_distance, max_far_fraction=ctx.p.max_far_fraction,
                            where=self.name)
        try:
            extra = load_annotations(path, plate.shape)
        except UserError as e:
            raise ctx.error(str(e)) from None
        ch = {k: v for k, v in extra.items() if k.startswith("ann.")}
        if ctx.p.annotations is not None:
            have = [k[4:] for k in ch]
            for n in ctx.p.annotations:
                if n not in have:
                    raise ctx.error(f"annotations: {n!r} is not in {path.name}'s annotations ({', '.join(have)}); "
                                    f"pick some of those")
            ch = {f"ann.{n}": ch[f"ann.{n}"] for n in ctx.p.annotations}
        ch["A"] = extra.get("A", np.ones(plate.shape, np.float32))
        ch["mask"] = extra.get("mask", np.ones(plate.shape, bool)).astype(np.float32)
        meta = dict(plate.meta)
        meta["annotations"] = [k[4:] for k in ch if k.startswith("ann.")]
        return plate.with_channels(ch, meta=meta)
