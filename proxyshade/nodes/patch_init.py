"""PatchInit: cover the detailed guide with source patches by flood fill.

Bonneel et al. 2010, §5 step 1: at the synthesis resolution (the guide divided by
``factor``, typically 1024 → 256), random uncovered guide pixels seed patches whose best
source match under eq. 1 (contour-distance neighbourhoods + w · Chamfer) is grown by a
flood fill in both images. Kernels: ``proxyshade.kernels.patch``, features in
``proxyshade.kernels.features``.

The synthesis state is a coordinate map into the source (``source.x/y`` in full-size
source pixels) and ``patch.id``; colours are looked up through it
(``proxyshade.kernels.lookup``).

This module also holds the set-up shared by the synthesis nodes (``SynthesisSetup``):
checking inputs, resampling the source to the exemplar and building the levels.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate
from proxyshade.kernels import features as kf
from proxyshade.kernels import patch as kpatch
from proxyshade.kernels.lookup import lookup

SYNTH_CHANNELS = ("R", "G", "B", "label.id", "source.x", "source.y", "patch.id")


# ---------------------------------------------------------------------------
# checks shared by the synthesis nodes


def require(ctx, plate: Plate | None, name: str, channels, what: str) -> Plate:
    """The input plate, or a one-line error naming what is missing and the fix."""
    if plate is None:
        raise ctx.error(f"input '{name}' is not connected; connect {what}")
    missing = [c for c in channels if c not in plate]
    if missing:
        raise ctx.error(f"input '{name}' has no {', '.join(missing)} channel(s) (it has "
                        f"{', '.join(plate.names()) or 'none'}); connect {what}")
    return plate


def check_finite(ctx, plate: Plate, name: str, channels, *, allow_inf: bool = False) -> None:
    """Fail on NaN (and Inf unless allowed) in float channels, naming the first pixel."""
    for c in channels:
        if c not in plate:
            continue
        a = plate[c]
        if a.dtype == np.uint32:
            continue
        bad = np.isnan(a) if allow_inf else ~np.isfinite(a)
        if bad.any():
            y, x = np.argwhere(bad)[0]
            kind = "NaN" if allow_inf else "NaN/Inf"
            raise ctx.error(f"input '{name}' channel {c} has {int(bad.sum())} {kind} pixel(s), first at x={x} y={y}; "
                            "fix the upstream node or clean the image (e.g. clamp or inpaint those pixels)")


def source_table(ctx, source: Plate) -> np.ndarray:
    labels = source.meta.get("labels")
    if not labels:
        raise ctx.error("input 'source' has no label table in its metadata (meta['labels']); "
                        "read it with SourceRead from a source.yaml")
    return np.array([int(t["id"]) for t in labels], dtype=np.int64)


def dense_guide(ctx, guide_ids: np.ndarray, table: np.ndarray, name: str = "guide") -> np.ndarray:
    """Guide ids -> dense label indices; a label missing from the table is an error."""
    dense, missing = kf.dense_labels(guide_ids, table)
    if missing.any():
        ids, counts = np.unique(guide_ids[missing], return_counts=True)
        which = ", ".join(f"{int(i)}{' (none)' if i == 0 else ''}: {int(c)} px" for i, c in zip(ids[:5], counts[:5]))
        raise ctx.error(f"input '{name}' has label ids missing from the source's label table ({which}); the table has "
                        f"ids {', '.join(map(str, table.tolist()))}: add the labels to source.yaml or relabel the "
                        "proxy so every guide pixel has a source label")
    return dense


@dataclass
class SynthesisSetup:
    """What the synthesis nodes share: the label table, the exemplar and the levels."""

    table: np.ndarray          # label ids, dense index -> id
    factor: int                # output pixels per synthesis pixel
    scale: float               # source pixels per output pixel
    ex_factor: float           # source pixels per exemplar pixel (= scale * factor)
    ex_rgb: np.ndarray         # (He, We, 3) linear
    ex_lab: np.ndarray         # (He, We) dense labels
    tgt_lab: np.ndarray        # (Ht, Wt) dense guide labels at the synthesis size
    levels: list               # features.Level, coarsest first

    def to_source(self, S: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Exemplar (row, column) -> source.x, source.y (float32, source pixels)."""
        F = self.ex_factor
        sx = ((S[..., 1].astype(np.float64) + 0.5) * F - 0.5).astype(np.float32)
        sy = ((S[..., 0].astype(np.float64) + 0.5) * F - 0.5).astype(np.float32)
        return sx, sy

    def from_source(self, sx: np.ndarray, sy: np.ndarray) -> np.ndarray:
        """source.x, source.y -> exemplar (row, column) int32, clamped into the exemplar."""
        F = self.ex_factor
        He, We = self.ex_lab.shape
        c = np.clip(np.floor((sx.astype(np.float64) + 0.5) / F - 0.5 + 0.5), 0, We - 1)
        r = np.clip(np.floor((sy.astype(np.float64) + 0.5) / F - 0.5 + 0.5), 0, He - 1)
        return np.stack([r, c], axis=-1).astype(np.int32)

    def plate(self, S: np.ndarray, patch: np.ndarray, source: Plate, extra_meta: dict) -> Plate:
        """The synthesis-size plate: R,G,B looked up in the exemplar, ids, coordinates."""
        rgb = lookup(self.ex_rgb, S[..., 1].astype(np.float32), S[..., 0].astype(np.float32))
        sx, sy = self.to_source(S)
        ch = {"R": rgb[..., 0].copy(), "G": rgb[..., 1].copy(), "B": rgb[..., 2].copy(),
              "label.id": self.table[self.tgt_lab].astype(np.uint32), "source.x": sx, "source.y": sy,
              "patch.id": patch.astype(np.uint32)}
        meta = provenance(source)
        meta["synthesis"] = dict(factor=self.factor, scale=self.scale, exemplar_factor=self.ex_factor,
                                 exemplar=list(self.ex_lab.shape), **extra_meta)
        return Plate(ch, meta)


def provenance(source: Plate) -> dict:
    """Metadata every synthesized plate carries: the label table and the source's paths."""
    return {"labels": source.meta.get("labels", []), "source": dict(source.meta.get("source", {}))}


def levels_for(size: int, coarse_size: int) -> int:
    """Number of pyramid levels from ``coarse_size`` up to ``size`` (factor 2 each)."""
    if size <= coarse_size:
        return 1
    return 1 + int(round(math.log2(size / coarse_size)))


def setup(ctx, source: Plate, tgt_lab_synth: np.ndarray, table: np.ndarray, *, factor: int, scale: float,
          coarse_size: int, max_distance: float | None, with_rgb: bool, finest_only: bool = False) -> SynthesisSetup:
    """Exemplar and levels for a guide already at the synthesis size (dense labels)."""
    src_dense, missing = kf.dense_labels(source["label.id"], table)
    if missing.any():
        raise ctx.error("input 'source' has label ids that are not in its own label table; re-read it with SourceRead")
    n = len(table)
    F = float(scale) * factor
    Hs, Ws = src_dense.shape
    ex_rgb, ex_lab = kf.build_exemplar(source.rgb(), src_dense, F, n)
    nlev = levels_for(max(tgt_lab_synth.shape), coarse_size)
    h = 2 ** (nlev - 1)
    need = 4 * h + 1
    He, We = ex_lab.shape
    if min(He, We) < need:
        raise ctx.error(f"source {Ws}x{Hs} px at scale {scale:g} x factor {factor} is a {We}x{He} exemplar, smaller than "
                        f"a 5x5 neighbourhood at the coarsest level (spacing {h}: needs {need}x{need}); lower 'scale', "
                        f"raise 'coarse_size' or use a larger source photo")
    present = np.zeros(n, bool)
    present[np.unique(ex_lab)] = True
    need_labels = np.unique(tgt_lab_synth)
    lacking = [int(table[l]) for l in need_labels if not present[l]]
    if lacking:
        names = {int(t["id"]): t["name"] for t in source.meta.get("labels", [])}
        which = ", ".join(f"{i} ({names.get(i, '?')})" for i in lacking)
        raise ctx.error(f"guide label(s) {which} have no pixel in the source at this scale; paint them in the "
                        "source's label map, lower 'scale', or relabel the proxy")
    levels = kf.build_levels(ex_rgb, ex_lab, tgt_lab_synth, n, nlev, max_distance=max_distance, with_rgb=with_rgb,
                             finest_only=finest_only)
    return SynthesisSetup(table, factor, float(scale), F, ex_rgb, ex_lab, tgt_lab_synth, levels)


def guide_at_synthesis(ctx, guide_dense: np.ndarray, factor: int, n: int) -> np.ndarray:
    """The guide voted down by ``factor`` (a power of two)."""
    if factor & (factor - 1):
        raise ctx.error(f"factor {factor} is not a power of two; use 1, 2, 4 or 8")
    if factor == 1:
        return guide_dense
    H, W = guide_dense.shape
    Hp, Wp = -(-H // factor) * factor, -(-W // factor) * factor
    if (Hp, Wp) != (H, W):  # replicate the last rows/columns up to a multiple of factor
        guide_dense = np.pad(guide_dense, ((0, Hp - H), (0, Wp - W)), mode="edge")
    nlev = int(round(math.log2(factor))) + 1
    out = kf.vote_pyramid(guide_dense, nlev, n)[0]
    assert out.shape == (Hp // factor, Wp // factor), out.shape
    return np.ascontiguousarray(out)


class PatchInit(Node):
    """Cover the guide with source patches grown by flood fill (Bonneel et al. 2010, §5).

    Output at the synthesis size (guide / factor): ``source.x/y`` (float32 source
    pixels), ``patch.id``, ``label.id`` (the guide voted down), ``R,G,B`` looked up in
    the exemplar; metadata: the label table, the source paths and ``synthesis``
    (factor, scale, exemplar size, patch count).
    """

    version = 1
    guide = Input("detailed guide at output size: label.id (GuideSynth or DepthExtend)")
    source = Input("annotated source (SourceRead): R,G,B, label.id and its label table")
    factor = Param(int, 4, min=1, max=64, doc="output pixels per synthesis pixel (power of two; 1024 -> 256 is 4)")
    scale = Param(float, 1.0, min=0.01, max=100.0, doc="source pixels per output pixel (texture scale)")
    w = Param(float, 90.0, min=0.0, doc="weight of the Chamfer distance in eq. 1")
    threshold_scale = Param(float, 1.25, min=1.0, doc="flood fill stops above threshold_scale * best + threshold_offset")
    threshold_offset = Param(float, 5.0, min=0.0, doc="see threshold_scale")
    max_distance = Param(float, 8.0, min=0.0, optional=True,
                         doc="clamp contour distances (synthesis pixels); null = unclamped")
    coarse_size = Param(int, 32, min=4, doc="coarsest pyramid level (long edge) of the later correction")
    seed = Param(int, 0, doc="order of the patch seeds")

    def compute(self, ctx) -> Plate:
        p = ctx.p
        guide = require(ctx, ctx.guide, "guide", ["label.id"], "the detailed guide (GuideSynth)")
        source = require(ctx, ctx.source, "source", ["R", "G", "B", "label.id"], "a SourceRead node")
        check_finite(ctx, source, "source", ["R", "G", "B"])
        table = source_table(ctx, source)
        g_dense = dense_guide(ctx, guide["label.id"], table)
        tgt = guide_at_synthesis(ctx, g_dense, p.factor, len(table))
        st = setup(ctx, source, tgt, table, factor=p.factor, scale=p.scale, coarse_size=p.coarse_size,
                   max_distance=p.max_distance, with_rgb=False, finest_only=True)
        fin = st.levels[-1]
        S, patch, npatch = kpatch.flood_fill(fin.src_lab, fin.src_dist, fin.src_masks, fin.tgt_lab, fin.tgt_dist,
                                             fin.tgt_masks, seed=p.seed, w=p.w, threshold_scale=p.threshold_scale,
                                             threshold_offset=p.threshold_offset)
        ctx.note(f"{npatch} patches over {tgt.shape[1]}x{tgt.shape[0]} synthesis pixels "
                 f"(exemplar {st.ex_lab.shape[1]}x{st.ex_lab.shape[0]})")
        return st.plate(S, patch, source, {"output": list(guide.shape), "patches": int(npatch),
                                           "max_distance": p.max_distance, "coarse_size": p.coarse_size})
