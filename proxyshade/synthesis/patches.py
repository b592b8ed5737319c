"""Patch synthesis on the coordinate map (Bonneel et al. 2010, §5): flood fill of source
patches, k-coherent correction coarse to fine, magnification to the output size and the
label repair after it. Each step works on the whole map or, with a ``mask``, only on the
masked pixels (the others are fixed context): the first frame and the local
resynthesis of later frames (§6.3) run the same functions. The map ``coords`` is the
paper's S: (H, W, 2) int32, the exemplar (row, column) each synthesis pixel reads;
``setup`` is the ``exemplar.SynthesisSetup`` the steps share.

Kernels: ``proxyshade.kernels.patch`` (flood fill, components), ``kernels.correct``,
``kernels.magnify``.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from proxyshade.kernels import correct as kcorrect
from proxyshade.kernels.distance import nearest_site
from proxyshade.kernels.features import Metric
from proxyshade.kernels import magnify as kmag
from proxyshade.kernels import patch as kpatch
from proxyshade.kernels import seams as kseams
from proxyshade.synthesis.exemplar import SynthesisSetup, grid_to_source
from proxyshade.synthesis.memo import kept


def fill_patches(setup: SynthesisSetup, fill: SimpleNamespace, *, seed: int, mask: np.ndarray | None = None,
                 coords: np.ndarray | None = None, patch: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, int]:
    """Cover the synthesis-size guide (or its ``mask`` pixels, keeping ``coords``/``patch``
    elsewhere) with patches grown by flood fill at the finest level. ``fill``: the
    ``FloodFill`` parameters. Returns (coords exemplar (row, col) int32, patch ids, count)."""
    return kpatch.flood_fill(setup.levels[-1], metric(fill), seed=seed, threshold_scale=fill.threshold_scale,
                             threshold_offset=fill.threshold_offset, mask=mask, coords=coords, patch=patch)


def metric(group: SimpleNamespace) -> Metric:
    """The weights of eq. 1 (``features.Metric``) of a ``PatchMetric`` group's values."""
    return Metric(float(group.w), float(group.height_weight))


def similarity_sets(setup: SynthesisSetup, corr: SimpleNamespace, *, seed: int) -> list:
    """The exemplar's similarity sets per level (k nearest windows), for ``correct_map``."""
    return kcorrect.level_similarity_sets(setup.levels, corr.k, metric(corr), seed=seed,
                                          knn_iterations=corr.knn_iterations)


def correct_map(setup: SynthesisSetup, coords0: np.ndarray, corr: SimpleNamespace, *, seed: int,
                mask: np.ndarray | None = None, similarity: list | None = None,
                near_copy: int = 0, tiles=None, rare_budget: float = 0.0,
                rare_tail: float = kcorrect.RARE_TAIL, copy_spacing: float = 0.0) -> tuple[np.ndarray, list, dict]:
    """k-coherent correction of the map ``coords0`` (or of its ``mask`` pixels) from the
    coarsest level up to the synthesis size, then ``repair_map``. ``corr``: the
    ``Correction`` parameters; ``near_copy``: the smallest near-copy radius in exemplar
    pixels (Correct's parameter, capped by ``near_copy_radius``; 0, the rule's radius
    alone, for the resyntheses of Resynthesize and EditSynth, whose windows would cap it
    differently from the whole frame). ``tiles``: the executor's row-band runner (``ctx.tiles``,
    ``synthesis.tiles``), which runs large levels' sub-passes on other workers (bit-identical;
    None: here). ``rare_budget``, ``rare_tail``: Correct's rare-look budget
    (``kernels.correct.correct_level``; 0: off); ``copy_spacing``: Correct's least distance
    between two copies of one spot in a frame larger than the photo (0: off). Returns (coords,
    per-level stats, the repair's counts)."""
    coords, stats = kcorrect.synthesize(setup.levels, coords0, corr, seed=seed, mask=mask, similarity=similarity,
                                        min_radius=near_copy_radius(setup, near_copy), tiles=tiles,
                                        rare_budget=rare_budget, rare_tail=rare_tail, copy_spacing=copy_spacing)
    coords, rep = repair_map(setup, coords)
    return coords, stats, rep


def near_copy_radius(setup: SynthesisSetup, near_copy: int) -> int:
    """The smallest near-copy radius of the correction, in exemplar pixels: ``near_copy``,
    at most a sixteenth of the exemplar's shorter side (a small exemplar, e.g. a 24-pixel
    one with 8-pixel label bands, cannot spare a wide exclusion around every neighbour)
    and at most the mean use of an exemplar pixel (synthesis pixels per exemplar pixel,
    rounded down): near copies are the repetition of a magnified frame, where each source
    spot appears many times; a synthesis at about the photo's own size (each pixel used
    about once) keeps the rule's radius, which matches its small labels better."""
    uses = int(setup.tgt_lab.size // max(setup.ex_lab.size, 1))
    return int(max(0, min(int(near_copy), min(setup.ex_lab.shape) // 16, uses)))


def repair_map(setup: SynthesisSetup, coords: np.ndarray) -> tuple[np.ndarray, dict]:
    """Pixels of the synthesis-size map that landed on an exemplar pixel of another label
    than the guide's moved onto theirs (``kernels.magnify.repair_labels``)."""
    return kmag.repair_labels(coords, setup.tgt_lab, setup.ex_lab)


SHIFT_PASSES = 2  # passes of whole-patch shifts in magnify_map (a third moves under 1 % of the patches)


def magnify_map(coords: np.ndarray, factor: int, shape: tuple[int, int], *, scale: float,
                target: np.ndarray | None = None, labels: np.ndarray | None = None,
                only: np.ndarray | None = None, memo=None, colours: np.ndarray | None = None,
                seam_passes: int = 0, seam_runs: bool = False, patch_shift: int = 0, patch_adopt: int = 0,
                spread_loss: float | None = None):
    """The exemplar map ``coords`` magnified by ``factor`` to the output size ``shape`` (each
    patch keeps its translation, the source is read at full detail). With ``target``,
    pixels whose ``labels`` (the source's on the output-scale grid,
    ``labels.working_labels``) differ from ``target`` are moved onto theirs; with
    ``only``, just those pixels are (the others are taken to be where they land). ``memo``
    (``synthesis.memo``) keeps the nearest sites of each label of ``labels``. With
    ``colours`` (the source on the same grid as ``labels``) and ``seam_passes``, the seams
    between patches then move to where their colours agree (``kernels.seams``; needs
    ``target``), with ``seam_runs`` also as runs along a seam; with ``patch_shift`` each whole
    patch then moves by up to that many output pixels to where its seams cost least, a patch
    of at most ``patch_adopt`` pixels may take a neighbour's offset (``kernels.seams.
    shift_patches``, ``SHIFT_PASSES`` passes), and the seams move again. ``spread_loss``: the most
    share of a label's tone spread the shifts may lose (None: ``kernels.seams.SPREAD_LOSS``).

    Returns (source.x, source.y float32, patch ids uint32 from 1, patch count, the
    repair's counts, with ``seam_moves`` and ``patch_shifts``)."""
    coords_out = kmag.magnify(coords, factor, shape)
    rep = {"wrong": 0, "extended": 0, "nearest": 0}
    if target is not None:
        if only is not None:
            target = kmag.only_target(coords_out, labels, only, target)
        coords_out, rep = kmag.repair_labels(coords_out, target, labels, sites_of=lambda lab: nearest_sites(labels, lab, memo))
    rep["seam_moves"] = rep["patch_shifts"] = 0
    if seam_passes > 0 and colours is not None and target is not None:
        seams = kseams.SeamMemory()  # the second seam moves try again only what the shifts changed
        coords_out, rep["seam_moves"] = kseams.refine_seams(coords_out, colours, target, labels, seam_passes,
                                                             runs=seam_runs, memory=seams)
        if patch_shift > 0:
            patch, _ = patch_ids(coords_out)
            coords_out, rep["patch_shifts"] = kseams.shift_patches(coords_out, colours, target, labels, patch,
                                                                   patch_shift, SHIFT_PASSES, patch_adopt,
                                                                   spread_loss=spread_loss)
            coords_out, _ = kseams.refine_seams(coords_out, colours, target, labels, seam_passes, runs=seam_runs,
                                                memory=seams)
    patch, npatch = patch_ids(coords_out)
    return grid_to_source(coords_out[..., 1], scale), grid_to_source(coords_out[..., 0], scale), patch, npatch, rep


def working_colours(source_rgb: np.ndarray, labels_dense: np.ndarray, scale: float, n: int, memo=None) -> np.ndarray:
    """The source's colours on the output-scale grid (``labels.working_labels``' grid),
    display-like (√ of linear, so a seam's cost weighs shadows as the eye does), kept in
    ``memo`` for the frames of a run."""
    def compute():
        from proxyshade.kernels.features import build_exemplar
        rgb = build_exemplar(np.ascontiguousarray(source_rgb, np.float32), labels_dense, scale, n)[0]
        out = np.sqrt(np.maximum(rgb, 0.0)).astype(np.float32)
        out.flags.writeable = False
        return out

    return kept(memo, "patches.working_colours", (source_rgb, labels_dense, float(scale)), compute)


def nearest_sites(labels: np.ndarray, lab: int, memo=None) -> np.ndarray | None:
    """``distance.nearest_site(labels == lab)`` (None where the label is absent), kept in
    ``memo``: the same working-label grid serves every frame of a run."""
    def compute():
        sites = labels == lab
        if not sites.any():
            return None
        ft = nearest_site(sites)
        ft.flags.writeable = False
        return ft

    return kept(memo, "patches.nearest_sites", (labels, int(lab)), compute, size=32)


def patch_ids(coords: np.ndarray) -> tuple[np.ndarray, int]:
    """Patches of a map: 4-connected regions of one translation (uint32 ids from 1), and
    their count."""
    return kpatch.offset_components(coords)
