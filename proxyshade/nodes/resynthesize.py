"""Resynthesize: texture synthesis restricted to the pixels Reproject flagged (paper §6.3).

"In areas flagged for resynthesis due to excessive distortion, texture synthesis is
initialized with the existing distorted pixel colors. In the remaining areas flagged for
resynthesis, floodfill is used. The rest of the texture synthesis process remains the
same, except the Poisson solve being restricted to the newly synthesized areas with
Dirichlet boundary conditions in order to avoid global changes in the image."

The first-frame kernels run with their masks, nothing is copied: at the synthesis size
(output / ``factor``) a pixel is active when any of its output pixels is flagged;
``kernels.patch.flood_fill(mask=...)`` covers the active pixels flagged disoccluded or
newly occluded (the others keep the carried coordinates: distorted areas start from their
distorted map), ``kernels.correct.synthesize(mask=...)`` corrects all active pixels with
the unflagged ones as fixed context, then the map is magnified (``kernels.magnify``) and
written into the flagged output pixels only. Unflagged pixels keep Reproject's colours and
map exactly; follow with ``Poisson`` with ``keep`` = this plate (mask channel ``flag``) for
the restricted solve.
"""
from __future__ import annotations

import weakref

import numpy as np

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate
from proxyshade.kernels import correct as kcorrect
from proxyshade.kernels import features as kf
from proxyshade.kernels import magnify as kmag
from proxyshade.kernels import patch as kpatch
from proxyshade.kernels import temporal as kt
from proxyshade.kernels.lookup import lookup
from proxyshade.nodes.magnify import working_labels
from proxyshade.nodes.patch_init import (check_finite, dense_guide, guide_at_synthesis, require, setup,
                                         source_table)
from proxyshade.nodes.reproject import CORRECTION, FLAG, frame_seed


_SIMILARITY: list = []  # [(weakrefs to the source's arrays, key, similarity sets)], newest last


def similarity_for(source: Plate, st, p) -> list:
    """The similarity sets of the exemplar (``correct.level_similarity_sets``). They depend
    on the source and the parameters only, not on the frame: within one run they are
    searched once per source (kept by identity of its arrays, two entries) and reused."""
    key = (st.factor, st.scale, len(st.levels), st.ex_lab.shape, p.max_distance, p.use_rgb, p.k, p.w,
           p.knn_iterations, p.seed)
    arrays = (source["R"], source["label.id"])
    for refs, k, sims in _SIMILARITY:
        if k == key and all(r() is a for r, a in zip(refs, arrays)):
            return sims
    sims = kcorrect.level_similarity_sets(st.levels, p.k, seed=p.seed, knn_iterations=p.knn_iterations, w=p.w)
    try:
        refs = tuple(weakref.ref(a) for a in arrays)
    except TypeError:
        return sims
    _SIMILARITY.append((refs, key, sims))
    del _SIMILARITY[:-2]
    return sims


def block_sample(a: np.ndarray, f: int, shape: tuple[int, int]) -> np.ndarray:
    """The output pixel at the middle of each f×f block (clamped at the border)."""
    rows = np.minimum(np.arange(shape[0]) * f + f // 2, a.shape[0] - 1)
    cols = np.minimum(np.arange(shape[1]) * f + f // 2, a.shape[1] - 1)
    return np.ascontiguousarray(a[rows][:, cols])


class Resynthesize(Node):
    """Flagged pixels resynthesized with the first-frame kernels; the rest kept.

    Output at the input's size: the input's channels with ``R,G,B`` (the source through
    the new map), ``source.x/y`` and ``patch.id`` (new ids above the carried ones)
    replaced where ``flag`` is non-zero; metadata ``resynthesis`` (pixel counts).
    """

    version = 1
    time_dependent = True  # seeds vary per frame
    image = Input("Reproject's output: flag, label.id, source.x/y, patch.id, R,G,B")
    source = Input("annotated source (SourceRead), the one of the first frame")
    factor = Param(int, None, min=1, max=64, doc="output pixels per synthesis pixel (default: the first frame's)")
    scale = Param(float, None, min=0.01, max=100.0, doc="source pixels per output pixel (default: the first frame's)")
    w = Param(float, 90.0, min=0.0, doc="weight of the Chamfer distance in eq. 1")
    threshold_scale = Param(float, 1.25, min=1.0, doc="flood fill stops above threshold_scale * best + threshold_offset")
    threshold_offset = Param(float, 5.0, min=0.0, doc="see threshold_scale")
    max_distance = Param(float, 8.0, min=0.0, optional=True, doc="clamp contour distances (synthesis pixels)")
    coarse_size = Param(int, 32, min=4, doc="long edge of the coarsest correction level")
    passes = Param(int, 5, min=0, doc="correction passes per level")
    passes_finest = Param(int, 3, min=0, doc="correction passes at the synthesis size")
    k = Param(int, 2, min=0, max=16, doc="similarity set size; 0 = coherent candidates only")
    kappa = Param(float, 0.0, min=0.0, doc="penalty on similarity-set candidates")
    knn_iterations = Param(int, 2, min=0, doc="PatchMatch iterations for the similarity sets")
    use_rgb = Param(bool, True, doc="colour neighbourhoods in the correction metric")
    radius = Param(str, "spacing", choices=("spacing", "level"), doc="near-copy rejection radius rule")
    seed = Param(int, 0, doc="seed of the flood fill (combined with the frame number) and of the similarity sets")
    solve = Param(bool, True, doc="finish with the restricted Poisson solve (Dirichlet outside the flagged pixels); "
                                  "false leaves it to a Poisson node with keep")
    seams = Param(str, "source", choices=("source", "zero"), doc="Poisson: target gradient across patch seams")
    screen = Param(float, 0.01, min=0.0, doc="Poisson: weight of the data term")
    label_dirichlet = Param(bool, True, doc="Poisson: keep pixels on label boundaries")
    tol = Param(float, 1e-5, min=1e-12, max=1.0, doc="Poisson: relative residual at which CG stops")
    max_iter = Param(int, 100, min=1, doc="Poisson: most CG iterations")

    def compute(self, ctx) -> Plate:
        img = require(ctx, ctx.image, "image", ["flag", "label.id", "source.x", "source.y", "patch.id", "R", "G", "B"],
                      "Reproject's output")
        source = require(ctx, ctx.source, "source", ["R", "G", "B", "label.id"], "a SourceRead node")
        return resynthesize(ctx, img, source, ctx.p, ctx.frame)


def resynthesize(ctx, img: Plate, source: Plate, p, frame: int, timings: dict | None = None) -> Plate:
    """What ``Resynthesize.compute`` does, with optional per-stage seconds in ``timings``
    (features, flood fill, corrections, magnify, Poisson) for the bench."""
    import time

    tm = timings if timings is not None else {}
    t = time.perf_counter()

    def lap(name):
        nonlocal t
        now = time.perf_counter()
        tm[name] = tm.get(name, 0.0) + now - t
        t = now

    flag = img["flag"]
    flagged = flag != 0
    nflag = int(flagged.sum())
    if nflag == 0:
        ctx.note("nothing flagged")
        return img.with_channels(meta={"resynthesis": {"pixels": 0, "share": 0.0}})
    check_finite(ctx, source, "source", ["R", "G", "B"])
    check_finite(ctx, img, "image", ["source.x", "source.y", "R", "G", "B"])
    syn = img.meta.get("synthesis", {}) if isinstance(img.meta.get("synthesis"), dict) else {}
    f = p.factor if p.factor is not None else int(syn.get("factor", 4))
    scale = p.scale if p.scale is not None else float(syn.get("scale", 1.0))
    seed = frame_seed(p.seed, frame)
    redo = flagged & (flag != FLAG["reanchored"])  # re-anchored patches keep their map: Poisson only
    sx, sy, patch, rgb = img["source.x"], img["source.y"], img["patch.id"], img.rgb()
    info = {"pixels": nflag, "share": nflag / flagged.size, "resynthesized": int(redo.sum()),
            "synthesis_pixels": 0, "flood_filled": 0, "patches": 0, "repaired": 0}
    ex_factor = syn.get("exemplar_factor")
    if redo.any():
        sx, sy, patch, rgb, ex_factor = _synthesize(ctx, img, source, p, redo, f, scale, seed, info, lap)
    lap("magnify")
    out = {}
    filt = img.meta.get("temporal", {}).get("filter", "bilinear")
    if p.solve:
        src_rgb = source.rgb() if p.seams == "source" else None
        before = rgb
        rgb, pinfo = kt.poisson_regions(rgb, patch, img["label.id"], flagged, source=src_rgb, sx=sx, sy=sy,
                                        step=scale, label_dirichlet=p.label_dirichlet, screen=p.screen,
                                        tol=p.tol, max_iter=p.max_iter, filter=filt)
        if all(c in img for c in CORRECTION):  # flagged pixels were the source through the map: add the solve's change
            corr = np.where(flagged[..., None], rgb - before, img.layer(CORRECTION))
            out.update({c: corr[..., k].astype(np.float32) for k, c in enumerate(CORRECTION)})
        ctx.note(f"Poisson on {pinfo['windows']} windows ({pinfo['window_pixels']} px), at most "
                 f"{pinfo['iterations']} iterations, residual {pinfo['residual']:.1e}")
    lap("Poisson")
    ctx.note(f"flagged {100 * info['share']:.2f}% ({nflag} px; {info['resynthesized']} resynthesized, "
             f"{info['synthesis_pixels']} synthesis px, {info['flood_filled']} flood-filled)")
    meta = dict(img.meta)
    meta["resynthesis"] = info
    meta["synthesis"] = dict(syn, factor=f, scale=scale, exemplar_factor=ex_factor)
    out.update({"R": rgb[..., 0].copy(), "G": rgb[..., 1].copy(), "B": rgb[..., 2].copy(), "source.x": sx,
                "source.y": sy, "patch.id": patch})
    # without the solve here the correction is a later Poisson node's: drop it rather than carry it stale
    return img.with_channels(out, meta=meta, drop=() if p.solve else CORRECTION)


def _synthesize(ctx, img: Plate, source: Plate, p, redo: np.ndarray, f: int, scale: float, seed: int, info: dict,
                lap):
    """The first-frame kernels on the pixels in ``redo`` (flood fill of the disoccluded and
    newly occluded, masked corrections, magnify, label repair, colour lookup); the rest
    keep the carried map. Returns source.x, source.y, patch.id, RGB and the exemplar factor."""
    flag = img["flag"]
    table = source_table(ctx, source)
    n = len(table)
    H, W = img.shape
    g = dense_guide(ctx, img["label.id"], table, "image")
    tgt = guide_at_synthesis(ctx, g, f, n)
    st = setup(ctx, source, tgt, table, factor=f, scale=scale, coarse_size=p.coarse_size,
               max_distance=p.max_distance, with_rgb=p.use_rgb)
    shape = tgt.shape
    lap("features")
    active = kcorrect.downsample_mask(redo, f, shape)
    fresh = kcorrect.downsample_mask((flag == FLAG["disoccluded"]) | (flag == FLAG["newly_occluded"]), f, shape)
    S = st.from_source(block_sample(img["source.x"], f, shape), block_sample(img["source.y"], f, shape))
    patch_s = block_sample(img["patch.id"], f, shape).astype(np.int64, copy=False)
    npatch = 0
    if fresh.any():
        fin = st.levels[-1]
        S, patch_s, npatch = kpatch.flood_fill(fin.src_lab, fin.src_dist, fin.src_masks, fin.tgt_lab, fin.tgt_dist,
                                               fin.tgt_masks, seed=seed, w=p.w, threshold_scale=p.threshold_scale,
                                               threshold_offset=p.threshold_offset, mask=fresh, S=S,
                                               patch=patch_s)
    lap("flood fill")
    if p.passes > 0 or p.passes_finest > 0:
        S, _ = kcorrect.synthesize(st.levels, S, passes=p.passes, passes_finest=p.passes_finest, k=p.k, w=p.w,
                                   seed=p.seed, knn_iterations=p.knn_iterations, use_rgb=p.use_rgb, kappa=p.kappa,
                                   mask=active, radius_rule=p.radius, similarity=similarity_for(source, st, p))
    S, _ = kmag.repair_labels(S, tgt, st.ex_lab)
    lap("corrections")
    # magnify to the output size and repair labels against the detailed labels
    Sw = kmag.magnify(S, f, (H, W))
    src_dense, _ = kf.dense_labels(source["label.id"], table)
    wl = working_labels(src_dense, scale, n)
    # only redo pixels take the new map: the others are told the label they land on (nothing to repair)
    here = wl[np.clip(Sw[..., 0], 0, wl.shape[0] - 1), np.clip(Sw[..., 1], 0, wl.shape[1] - 1)]
    Sw, rep = kmag.repair_labels(Sw, np.where(redo, g, here), wl)
    new_patch, _ = kpatch.offset_components(Sw)
    base = np.uint32(int(img["patch.id"].max()) + 1)
    sx_new = ((Sw[..., 1].astype(np.float64) + 0.5) * scale - 0.5).astype(np.float32, copy=False)
    sy_new = ((Sw[..., 0].astype(np.float64) + 0.5) * scale - 0.5).astype(np.float32, copy=False)
    sx = np.where(redo, sx_new, img["source.x"]).astype(np.float32, copy=False)
    sy = np.where(redo, sy_new, img["source.y"]).astype(np.float32, copy=False)
    patch = np.where(redo, new_patch + base, img["patch.id"]).astype(np.uint32, copy=False)
    rgb = img.rgb()
    ii, jj = np.nonzero(redo)
    filt = img.meta.get("temporal", {}).get("filter", "bilinear")  # Reproject's, so kept and new pixels match
    rgb[ii, jj] = lookup(source.rgb(), sx[ii, jj][None], sy[ii, jj][None], filter=filt)[0]
    info.update(synthesis_pixels=int(active.sum()), flood_filled=int(fresh.sum()), patches=int(npatch),
                repaired=int(rep["wrong"]))
    return sx, sy, patch, rgb, st.ex_factor
