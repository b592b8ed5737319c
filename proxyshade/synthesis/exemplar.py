"""The exemplar, its pyramid levels and the coordinate conversions of the synthesis state.

§5 of N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010.

Three pixel grids meet in synthesis: the source photo (``source.x/y``, pixel centres at
integer values), the exemplar (the source resampled by ``ex_factor`` = scale × factor
source pixels per pixel: what the synthesis-size kernels search) and the output-scale
grid (``scale`` source pixels per pixel: what magnification writes). A grid pixel ``i``
of a grid of ``step`` source pixels per pixel is centred at source coordinate
``(i + 0.5) * step - 0.5`` (``grid_to_source``); ``source_to_grid`` is its nearest
inverse.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from proxyshade.errors import NodeInputError
from proxyshade.plate import Plate
from proxyshade.kernels import features as kf
from proxyshade.kernels.lookup import lookup
from proxyshade.synthesis.labels import source_dense

SYNTH_CHANNELS = ("R", "G", "B", "label.id", "source.x", "source.y", "patch.id")


def grid_to_source(index: np.ndarray, step: float) -> np.ndarray:
    """Source coordinates (float32) of the centres of grid pixels ``index`` (any int or
    float array) on a grid of ``step`` source pixels per pixel."""
    return ((index.astype(np.float64) + 0.5) * step - 0.5).astype(np.float32)


def source_to_grid(coord: np.ndarray, step: float) -> np.ndarray:
    """The grid pixel (float64, integral) whose centre is nearest to source coordinate
    ``coord``; the inverse of ``grid_to_source``."""
    return np.floor((coord.astype(np.float64) + 0.5) / step - 0.5 + 0.5)


def levels_for(size: int, coarse_size: int) -> int:
    """Number of pyramid levels from ``coarse_size`` up to ``size`` (factor 2 each)."""
    if size <= coarse_size:
        return 1
    return 1 + int(round(math.log2(size / coarse_size)))


def provenance(source: Plate) -> dict:
    """Metadata every synthesized plate carries: the label table and the source's paths."""
    return {"labels": source.meta.get("labels", []), "source": dict(source.meta.get("source", {}))}


@dataclass
class SynthesisSetup:
    """What the synthesis steps share: the label table, the exemplar and the levels."""

    table: np.ndarray          # label ids, dense index -> id
    factor: int                # output pixels per synthesis pixel
    scale: float               # source pixels per output pixel
    ex_factor: float           # source pixels per exemplar pixel (= scale * factor)
    ex_rgb: np.ndarray         # (He, We, 3) linear
    ex_lab: np.ndarray         # (He, We) dense labels
    tgt_lab: np.ndarray        # (Ht, Wt) dense guide labels at the synthesis size
    levels: list               # features.Level, coarsest first

    def to_source(self, coords: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Exemplar (row, column) -> source.x, source.y (float32, source pixels)."""
        return grid_to_source(coords[..., 1], self.ex_factor), grid_to_source(coords[..., 0], self.ex_factor)

    def from_source(self, sx: np.ndarray, sy: np.ndarray) -> np.ndarray:
        """source.x, source.y -> exemplar (row, column) int32, clamped into the exemplar."""
        He, We = self.ex_lab.shape
        c = np.clip(source_to_grid(sx, self.ex_factor), 0, We - 1)
        r = np.clip(source_to_grid(sy, self.ex_factor), 0, He - 1)
        return np.stack([r, c], axis=-1).astype(np.int32)

    def plate(self, coords: np.ndarray, patch: np.ndarray, source: Plate, extra_meta: dict) -> Plate:
        """The synthesis-size plate: R,G,B looked up in the exemplar, ids, coordinates."""
        rgb = lookup(self.ex_rgb, coords[..., 1].astype(np.float32), coords[..., 0].astype(np.float32))
        sx, sy = self.to_source(coords)
        ch = {"R": rgb[..., 0].copy(), "G": rgb[..., 1].copy(), "B": rgb[..., 2].copy(),
              "label.id": self.table[self.tgt_lab].astype(np.uint32), "source.x": sx, "source.y": sy,
              "patch.id": patch.astype(np.uint32)}
        meta = provenance(source)
        meta["synthesis"] = dict(factor=self.factor, scale=self.scale, exemplar_factor=self.ex_factor,
                                 exemplar=list(self.ex_lab.shape), **extra_meta)
        return Plate(ch, meta)


def synthesis_setup(source: Plate, tgt_lab_synth: np.ndarray, table: np.ndarray, *, factor: int, scale: float,
          coarse_size: int, max_distance: float | None, with_rgb: bool, finest_only: bool = False,
          interior: float = 0.0) -> SynthesisSetup:
    """Exemplar and levels for a guide already at the synthesis size (dense labels)."""
    src_dense = source_dense(source, table)
    n = len(table)
    F = float(scale) * factor
    Hs, Ws = src_dense.shape
    ex_rgb, ex_lab = kf.build_exemplar(source.rgb(), src_dense, F, n)
    He, We = ex_lab.shape
    # the coarsest level's 5x5 neighbourhood (spacing h) must fit in the exemplar: a large
    # output from a small source starts the correction at a finer level instead
    fit = 1 + int(np.floor(np.log2(max(min(He, We) - 1, 4) / 4)))
    nlev = max(1, min(levels_for(max(tgt_lab_synth.shape), coarse_size), fit))
    h = 2 ** (nlev - 1)
    need = 4 * h + 1
    if min(He, We) < need:
        raise NodeInputError(
            f"source {Ws}x{Hs} px at scale {scale:g} x factor {factor} is a {We}x{He} exemplar, smaller than "
            f"a 5x5 neighbourhood at the coarsest level (spacing {h}: needs {need}x{need}); lower 'scale', "
            f"raise 'coarse_size' or use a larger source photo")
    present = np.zeros(n, bool)
    present[np.unique(ex_lab)] = True
    need_labels = np.unique(tgt_lab_synth)
    lacking = [int(table[l]) for l in need_labels if not present[l]]
    if lacking:
        names = {int(t["id"]): t["name"] for t in source.meta.get("labels", [])}
        which = ", ".join(f"{i} ({names.get(i, '?')})" for i in lacking)
        raise NodeInputError(f"guide label(s) {which} have no pixel in the source at this scale; paint them in the "
                             "source's label map, lower 'scale', or relabel the proxy")
    levels = kf.build_levels(ex_rgb, ex_lab, tgt_lab_synth, n, nlev, max_distance=max_distance, with_rgb=with_rgb,
                             finest_only=finest_only, interior=interior)
    return SynthesisSetup(table, factor, float(scale), F, ex_rgb, ex_lab, tgt_lab_synth, levels)
