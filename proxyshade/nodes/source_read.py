"""SourceRead: an annotated source photo (photo + label map + label table) as a plate.

Reference: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010."""
from __future__ import annotations

from pathlib import Path

from proxyshade.graph import keys
from proxyshade.graph.node import Node, Param
from proxyshade.graph.plate import Plate
from proxyshade.io.source import load_source, load_table
from proxyshade.synthesis.params import LabelMapSnap


class SourceRead(LabelMapSnap, Node):
    """Read an annotated source: linear ``R,G,B`` (sRGB decoded with colour-science) and
    ``label.id`` (uint32 ids of the label table, the map snapped to the nearest table colour).

    The label table YAML names the photo, the label map and each label's id and colour,
    and optionally other photos of the same view (``images: {noon: a.jpg, dusk: b.jpg}``, a
    time-lapse series sharing the label map); ``photo`` reads one of those instead of
    ``image``. The plate's metadata carries the table (``labels``), the paths (``source``)
    and how many pixels were snapped (``snap``).
    """

    version = 3  # 2: variants; 3: variant_labels (even by default)
    table = Param(Path, doc="label table YAML (source.yaml) naming the photo and label map")
    photo = Param(str, None, doc="name of one of the table's 'images' (a photo of the same view at another time) "
                                 "to read instead of 'image'")
    variants = Param(int, 0, min=0, max=8, doc="widen the source by this many hybrid variants of itself, side by "
                                               "side (synthesis.hybrid.with_variants, docs/hybrids.md): a large "
                                               "region of a big frame draws on more arrangements; 0: the photo only")
    variant_labels = Param(str, "even", choices=("even", "photo"),
                           doc="what the variants hold: 'even', one strip per label, each a texture of the photo's "
                               "window richest in that label (a label small in the photo gets as many variant pixels "
                               "as a large one, so a frame showing much of it repeats less); 'photo', hybrids of the "
                               "whole photo (its label shares)")

    def key_extra(self, frame, graph_dir):
        # the table's own content is hashed by the engine; add the files it names
        try:
            t = load_table(self._table_path(graph_dir, frame))
        except Exception:  # noqa: BLE001 - reported properly by compute
            return None
        out = {k: keys.file_hash(Path(t[k])) for k in ("image", "labels_map") if t.get(k)}
        if self.params["photo"] is not None and self.params["photo"] in t["images"]:
            out["photo"] = keys.file_hash(Path(t["images"][self.params["photo"]]))
        return out

    def _table_path(self, graph_dir, frame):
        from proxyshade.graph.node import resolve_path

        return resolve_path(self.params["table"], graph_dir, frame)

    def compute(self, ctx) -> Plate:
        plate = load_source(ctx.path(ctx.p.table), far_distance=ctx.p.far_distance,
                            max_far_fraction=ctx.p.max_far_fraction, where=self.name, photo=ctx.p.photo)
        if ctx.p.variants:
            from proxyshade.synthesis.hybrid import with_variants

            plate = with_variants(plate, ctx.p.variants, even=ctx.p.variant_labels == "even", memo=ctx.memo)
        s = plate.meta["snap"]
        ctx.note(f"snapped {s['snapped']} of {s['pixels']} label-map pixels to the nearest table colour "
                 f"({s['far']} far from every colour)")
        return plate
