"""Grain: the photo's detail, scale by scale, label by label (issue 19).

An option of the Poisson step (§5 step 3) of N. Bonneel, M. van de Panne, S. Lefebvre, G.
Drettakis, "Proxy-Guided Texture Synthesis for Rendering Natural Scenes", INRIA RR-7298,
2010; the paper has no such step.

A first frame copies each label's texture from the photo, but the correction favours the
blander parts of a region and the Poisson step smooths near seams: renoir's sky came out
with half the photo's contrast at every scale, creek's sky with two thirds of its pixel
gradient. ``gain_table`` compares the blended frame with the photo, label by label and by
relative height in the label (``features.label_heights``, ``BINS`` bins), in band-pass
layers of the sRGB-encoded colours (``kernels.grain``: box means within the label of radii
``RADII``), and returns the gain each layer needs for its energy to match the photo's
(clamped to [1 / max_gain, max_gain]). ``graded`` applies those gains to the *source*:
the frame is then read again through its coordinate map and blended again. Because the
gains live in the source, every later frame reads the same graded source through its
carried map (``source_colours`` with the plate's ``meta["grain"]``): the detail stays put
on the surface over a shot, where an output-side boost would be resampled frame after
frame and fade. ``spread`` measures the coarser layers (box radii ``SPREAD_RADII``) and
raises the frame's own, on the frame's side: a region of another shape holds less of the
photo's large-scale variation, and which parts of the photo a map reads, not the photo's
own layers, makes the frame's (the layout step applies it, ``blend.layout_move``).
"""
from __future__ import annotations

import json

import numpy as np

from proxyshade.kernels import grain as kgrain
from proxyshade.kernels import layout as klayout
from proxyshade.kernels.features import label_heights
from proxyshade.synthesis.labels import joint_dense
from proxyshade.synthesis.memo import kept

RADII = (1, 2, 4, 8, 16, 32)  # box radii (px) between the layers: 3, 5, 9, 17, 33, 65 px windows
SPREAD_RADII = (32, 64, 128, 256)  # the large-scale layers ``spread`` matches (what lies under RADII's last)
BINS = 4                      # height bins of a label
MIN_PIXELS = 64               # a (label, bin) with fewer pixels (either side) takes the label's gain


def _bins(dense: np.ndarray, bins: int = BINS) -> np.ndarray:
    """Each pixel's height bin in its label's vertical run."""
    return np.minimum((label_heights(dense) * bins).astype(np.int32), bins - 1)


def _energy(rgb: np.ndarray, dense: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    return kgrain.band_energy(klayout.srgb_encode(rgb), dense, _bins(dense), np.array(RADII), n, BINS)


def _gains(eo: np.ndarray, co: np.ndarray, es: np.ndarray, cs: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """(n, bins, R) gains √(photo's mean layer energy / frame's) from ``band_energy``'s sums
    and counts (frame ``eo, co``, photo ``es, cs``), clamped to [lo, hi]; a (label, bin) with
    fewer than ``MIN_PIXELS`` pixels on either side takes its label's overall gain, a label
    missing on either side 1."""
    g = np.ones(eo.shape, np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        for k in range(len(eo)):
            if co[k].sum() == 0 or cs[k].sum() == 0:
                continue
            whole = np.sqrt((es[k].sum(0) / cs[k].sum()) / (eo[k].sum(0) / co[k].sum()))
            ok = (co[k] >= MIN_PIXELS) & (cs[k] >= MIN_PIXELS)
            gk = np.sqrt((es[k] / np.maximum(cs[k], 1)[:, None]) / (eo[k] / np.maximum(co[k], 1)[:, None]))
            gk = np.where(ok[:, None] & np.isfinite(gk), gk, whole[None, :])
            g[k] = np.clip(np.nan_to_num(gk, nan=1.0, posinf=hi), lo, hi)
    return g


def gain_table(rgb: np.ndarray, labels: np.ndarray, source_rgb: np.ndarray, source_labels: np.ndarray, *,
               max_gain: float) -> dict:
    """The gains that bring the layers of ``rgb`` (linear (H, W, 3), labels ``labels``)
    to the energy of the photo's (``source_rgb``, ``source_labels``), per label id, height
    bin and layer: {"radii", "bins", "gains": {id: [[gain per layer] per bin]}} (JSON).
    A (label, bin) with fewer than ``MIN_PIXELS`` pixels on either side takes the label's
    overall gain; a label the frame does not show keeps gain 1."""
    lut, ids = joint_dense(labels, source_labels)
    n = len(ids)
    out_lab, src_lab = lut[labels], lut[source_labels]
    eo, co = _energy(rgb, out_lab, n)
    es, cs = _energy(source_rgb, src_lab, n)
    g = _gains(eo, co, es, cs, 1.0 / max_gain, max_gain)
    table = {str(int(lid)): [[float(v) for v in row] for row in g[k]]
             for k, lid in enumerate(ids) if co[k].sum() and cs[k].sum()}
    return {"radii": list(RADII), "bins": BINS, "gains": table}


def spread(rgb: np.ndarray, labels: np.ndarray, source_rgb: np.ndarray, source_labels: np.ndarray, *,
           max_gain: float, scale: float = 1.0) -> np.ndarray:
    """``rgb`` (linear (H, W, 3), labels ``labels``) with the large-scale layers of each
    label (between its box means of radii ``SPREAD_RADII``, windows of 65 to 513 px, taken
    on 4 × 4 blocks: ``kernels.grain.spread_energy``) raised, by (label, height bin),
    toward the photo's energy there (one pass goes most of the way; gains in
    [1, max_gain]; never lowered). A region of another shape than the photo's holds less
    of the photo's large-scale variation (a pond: fewer of the river's bank reflections
    and far-to-near darkening); this gives the frame's own large-scale variation the
    photo's spread. Frame-side: the layout step's business, like the means it moves
    (``blend.layout_move``); later frames carry it with the frame's colours. ``scale``:
    source pixels per output pixel (the photo's layers are measured at radii × scale)."""
    lut, ids = joint_dense(labels, source_labels)
    n = len(ids)
    out_lab, src_lab = lut[labels], lut[source_labels]
    radii = np.array(SPREAD_RADII, np.int64)
    src_radii = np.maximum(np.round(radii * scale), 1).astype(np.int64)
    enc = klayout.srgb_encode(rgb)
    hbin = _bins(out_lab)
    # the layers are smooth: their means are taken on blocks of an eighth of the first radius
    f, fs = max(1, int(radii[0]) // 8), max(1, int(src_radii[0]) // 8)
    eo, co = kgrain.spread_energy(enc, out_lab, hbin, radii, n, BINS, f)
    es, cs = kgrain.spread_energy(klayout.srgb_encode(source_rgb), src_lab, _bins(src_lab), src_radii, n, BINS, fs)
    g = _gains(eo, co, es, cs, 1.0, max_gain)
    if not (g > 1.0).any():
        return rgb
    return klayout.srgb_decode(kgrain.spread_regrade(enc, out_lab, hbin, radii, g, f))


def graded(source, table: dict, memo=None) -> np.ndarray:
    """The colours of ``source`` (a Plate with ``R,G,B``, ``label.id``), linear (H, W, 3)
    float32, with each layer of each label scaled by ``table`` (``gain_table``), by the
    source pixel's height bin; labels the table does not name are unchanged. Kept in ``memo`` (``synthesis.memo``:
    shared, not to be written to)."""
    source_labels = source["label.id"]

    def compute():
        lut, ids = joint_dense(source_labels)
        n = len(ids)
        dense = lut[source_labels]
        bins, radii = int(table["bins"]), np.array(table["radii"], np.int64)
        gains = np.ones((n, bins, len(radii)), np.float64)
        for lid, g in table["gains"].items():
            if int(lid) in ids:
                gains[lut[int(lid)]] = np.asarray(g, np.float64)
        return klayout.srgb_decode(kgrain.regrade(klayout.srgb_encode(source.rgb()), dense, _bins(dense, bins),
                                                  radii, gains))

    parts = (source["R"], source["G"], source["B"], source_labels, json.dumps(table, sort_keys=True))
    return kept(memo, "grain.graded", parts, compute, size=4)


def source_colours(source, meta: dict, memo=None) -> np.ndarray:
    """The colours a frame reads through its map: the source graded by the first frame's
    ``meta["grain"]`` table when it has one, else the source as it is (a Plate with
    ``R,G,B`` and ``label.id``)."""
    table = meta.get("grain") if isinstance(meta, dict) else None
    if not table:
        return source.rgb()
    return graded(source, table, memo)
