"""Structured image hybrids (Risser, Han, Dumas, Lefebvre 2010): the layer shared by the
``ExemplarAtlas`` and ``HybridSynth`` nodes and ``bench/bench_hybrids.py``.

An *atlas* packs 1..8 annotated exemplars of one size side by side in a row: exemplar
``k`` (``exemplar.id`` k + 1) owns the box of columns ``k w .. (k + 1) w - 1``. Each
exemplar is centre-cropped to the atlas aspect and area-resampled (colour) and
mode-resampled (labels) to ``w × h`` with ``kernels.features``' resamplers. A synthesis
state is an (H, W, 2) int32 map of atlas (row, column): the column names the exemplar
(the paper's "coordinate pointers ... augmented with exemplar indices").

References
----------
L. Risser, C. Han, L. Dumas, S. Lefebvre. Synthesizing structured image hybrids.
SIGGRAPH 2010.
"""
from __future__ import annotations

import numpy as np

from proxyshade.errors import NodeInputError
from proxyshade.graph.plate import Plate

MAX_EXEMPLARS = 8


def _table_key(labels) -> list[tuple[str, int]]:
    return sorted((str(t["name"]), int(t["id"])) for t in labels)


def fit_exemplar(rgb: np.ndarray, dense: np.ndarray, n: int, size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """(M, N, 3) float32 colour and (M, N) dense labels -> ``size`` = (h, w): the centred
    crop of the source with the aspect of ``size``, box-filtered to it (labels: majority)."""
    from proxyshade.kernels.features import _area_resample, _mode_resample

    oh, ow = size
    M, N = dense.shape
    f = min(M / oh, N / ow)
    y0 = int((M - f * oh) // 2)
    x0 = int((N - f * ow) // 2)
    crop_rgb = np.ascontiguousarray(rgb[y0:, x0:], np.float32)
    crop_lab = np.ascontiguousarray(dense[y0:, x0:], np.int32)
    out_rgb = np.empty((oh, ow, 3), np.float32)
    out_lab = np.empty((oh, ow), np.int32)
    _area_resample(crop_rgb, oh, ow, float(f), out_rgb)
    _mode_resample(crop_lab, oh, ow, float(f), n, out_lab)
    return out_rgb, out_lab


def pack_atlas(plates: list[tuple[str, Plate]], size: tuple[int, int]) -> Plate:
    """Pack named source plates (R, G, B, label.id and meta['labels']) into one atlas plate
    of ``size`` = (h, w) boxes in a row.

    Channels ``R, G, B`` (float32), ``label.id`` and ``exemplar.id`` (uint32, 1..n); meta
    ``labels`` (the shared table), ``atlas`` (one box per exemplar: ``id``, ``input``,
    ``x``, ``y``, ``w``, ``h``, ``source`` provenance) and ``source`` (the first
    exemplar's provenance, with the atlas size).
    """
    from proxyshade.kernels.features import dense_labels

    if not plates:
        raise NodeInputError("no exemplar connected; connect 1 to 8 SourceRead nodes to exemplar1..exemplar8")
    if len(plates) > MAX_EXEMPLARS:
        raise NodeInputError(f"{len(plates)} exemplars connected; an atlas holds at most {MAX_EXEMPLARS}, "
                             "connect fewer")
    h, w = size
    first_name, first = plates[0]
    labels = first.meta.get("labels")
    if not labels:
        raise NodeInputError(f"input '{first_name}' has no label table (meta['labels']); read it with SourceRead")
    key = _table_key(labels)
    table = np.array([int(t["id"]) for t in labels], np.int64)
    n = len(table)
    rgbs, labs, boxes = [], [], []
    for k, (name, p) in enumerate(plates):
        other = p.meta.get("labels")
        if not other or _table_key(other) != key:
            have = ", ".join(f"{a}={b}" for a, b in _table_key(other or []))
            want = ", ".join(f"{a}={b}" for a, b in key)
            raise NodeInputError(f"input '{name}': its label table ({have or 'none'}) disagrees with "
                                 f"'{first_name}' ({want}); give every exemplar the same label names and ids")
        dense, missing = dense_labels(p["label.id"], table)
        dense[missing] = 0
        rgb = np.stack([p["R"], p["G"], p["B"]], -1).astype(np.float32)
        r, l = fit_exemplar(rgb, dense, n, (h, w))
        rgbs.append(r)
        labs.append(l)
        prov = dict(p.meta.get("source", {})) if isinstance(p.meta.get("source"), dict) else {}
        boxes.append({"id": k + 1, "input": name, "x": k * w, "y": 0, "w": w, "h": h, "source": prov})
    rgb = np.concatenate(rgbs, axis=1)
    lab = table[np.concatenate(labs, axis=1)].astype(np.uint32)
    ex = np.repeat(np.arange(1, len(plates) + 1, dtype=np.uint32), w)[None, :].repeat(h, 0)
    source = dict(boxes[0]["source"])
    source["size"] = [int(w * len(plates)), int(h)]
    meta = {"labels": [dict(t) for t in labels], "atlas": boxes, "source": source}
    return Plate({"R": rgb[..., 0].copy(), "G": rgb[..., 1].copy(), "B": rgb[..., 2].copy(), "label.id": lab,
                  "exemplar.id": np.ascontiguousarray(ex)}, meta)


def atlas_boxes(atlas: Plate) -> tuple[int, int, int]:
    """(number of exemplars, box height, box width) of an atlas plate; boxes are equal and
    in a row (as ``pack_atlas`` writes them)."""
    boxes = atlas.meta.get("atlas")
    if not isinstance(boxes, list) or not boxes:
        raise NodeInputError("input 'atlas' has no meta['atlas'] boxes; connect an ExemplarAtlas node")
    h, w = int(boxes[0]["h"]), int(boxes[0]["w"])
    for k, b in enumerate(boxes):
        if (int(b["x"]), int(b["y"]), int(b["w"]), int(b["h"])) != (k * w, 0, w, h):
            raise NodeInputError("input 'atlas': its boxes are not equal boxes in a row; connect an ExemplarAtlas node")
    if atlas.shape != (h, w * len(boxes)):
        raise NodeInputError("input 'atlas': its size does not match meta['atlas']; connect an ExemplarAtlas node")
    return len(boxes), h, w
