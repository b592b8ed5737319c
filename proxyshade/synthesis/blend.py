"""Poisson blending of patch seams (Bonneel et al. 2010, §5 step 3, §6.3, §7): the whole
frame, or only the newly synthesized regions with Dirichlet values around them.

Reference: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010.

Solve Δu = Δ(f∘s) in Ω, ∇u = 0 across patch boundaries (Γ1: with ``seams: source`` the
source's own gradient read through the map on both sides of the seam instead), u = f∘s on
boundaries between label ids (Γ2). The restricted solve (``poisson_regions``) splits
the free pixels into their 4-connected regions: narrow ones by SOR on their own pixels,
the others in windows by multigrid-preconditioned CG. Kernels:
``proxyshade.kernels.poisson`` (with ``kernels.multigrid`` and ``kernels.sor``), ``proxyshade.kernels.temporal.components4``.

With ``layout`` (``layout_move``) the synthesized colours are first moved, label by
label and by relative height in the label, onto the source photo's mean colours there:
the solve keeps the texture's gradients and takes the low frequencies (a region's mean,
a sky's top-to-horizon gradient) from the photo.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from proxyshade.kernels import layout as klayout
from proxyshade.kernels.lookup import lookup
from proxyshade.kernels import poisson as kpoisson
from proxyshade.kernels import sor as ksor
from proxyshade.kernels import temporal as kt
from proxyshade.kernels.features import label_heights
from proxyshade.synthesis import grain
from proxyshade.synthesis.labels import joint_dense

LAYOUT_BINS = 8          # height bins of a label's colour profile
LAYOUT_MIN_PIXELS = 64   # a bin with fewer pixels (either side) takes its neighbours' value
LAYOUT_MIN_RUN = 64      # runs shorter than this (pixels) take the label's mean offset: in a band a few
                         # pixels high the height bins are the texture's own rows, not a gradient
GRAIN_TOL = 1e-2         # the solve whose detail the grain gains are measured on (gains within 0.4 % of the exact solve's)


def _bin_mean(v: np.ndarray, w: np.ndarray) -> np.ndarray:
    """(labels, 3): each label's mean of ``v`` (labels, bins, 3) over its bins, weighted by
    ``w`` (labels, bins; 0 = left out, NaN values then ignored)."""
    return (np.nan_to_num(v) * w[..., None]).sum(1) / np.maximum(w.sum(1), 1.0)[:, None]


def _tables(d: np.ndarray, ok: np.ndarray) -> np.ndarray:
    """``d`` (labels, bins, 3) with each label's bins outside ``ok`` interpolated from its
    ``ok`` ones (labels with none: 0)."""
    centres = np.arange(d.shape[1])
    table = np.zeros_like(d)
    for l in range(len(d)):
        if ok[l].any():
            for c in range(3):
                table[l, :, c] = np.interp(centres, centres[ok[l]], d[l, ok[l], c])
    return table


def floor_light(u: np.ndarray, info: dict, solved: np.ndarray | None = None) -> tuple[np.ndarray, dict]:
    """A solve's colours with negative values set to 0 where it solved (``solved``, (H, W)
    bool; None = everywhere), in place: a scene-referred plate may exceed 1, never go below
    0 (a gradient carried into a dark region overshoots there); the pixels it kept are left
    as they came. ``info["negative"]`` counts the values raised."""
    neg = u < 0
    if solved is not None:
        neg &= solved[..., None]
    info["negative"] = int(neg.sum())
    u[neg] = 0.0
    return u, info


def layout_move(colors: np.ndarray, labels: np.ndarray, source_rgb: np.ndarray,
                source_labels: np.ndarray, *, keep: float, spread: float = 1.0, scale: float = 1.0) -> np.ndarray:
    """The linear ``colors`` (H, W, 3) with each label's mean colour moved, by relative
    height in its vertical runs (``features.label_heights``, ``LAYOUT_BINS`` bins), onto
    the source photo's, as a smooth field within each label
    (``kernels.layout.smooth_offset``) applied by ``kernels.layout.move_luma_chroma``:
    the luminance by an offset on the sRGB-encoded scale (it keeps the contrast a viewer
    sees: a constant added to linear colours would flatten a brightened dark region),
    the hue by a white balance of R and B against G (the photo's chromaticity; an offset
    per channel would tint a region's shadows: dark vegetation turned blue where the
    photo's is less yellow). ``keep`` is the share of the synthesized luminance's own
    profile (about its mean) that stays: 0 gives the photo's profile exactly, 1 adds the
    photo's to it (a pond's dark band under its bank stays while the pond's mean moves
    onto the photo's water; a synthesis that already follows the photo's profile gets
    it twice). ``spread`` > 1: then each label's large-scale variation is raised toward the
    photo's (``grain.spread``, gains up to ``spread``; ``scale`` source pixels per output
    pixel)."""
    lut, ids = joint_dense(labels, source_labels)
    n = len(ids)
    out_lab, src_lab = lut[labels], lut[source_labels]
    ts = label_heights(src_lab)
    t, runs = label_heights(out_lab, lengths=True)
    ys, cs = klayout.profile(klayout.luma_encoded(source_rgb), src_lab, ts, n, LAYOUT_BINS)
    yo, co = klayout.profile(klayout.luma_encoded(colors), out_lab, t, n, LAYOUT_BINS)
    ms = klayout.profile(source_rgb, src_lab, ts, n, LAYOUT_BINS)[0]
    mo = klayout.profile(colors, out_lab, t, n, LAYOUT_BINS)[0]
    ok = (cs >= LAYOUT_MIN_PIXELS) & (co >= LAYOUT_MIN_PIXELS)
    own_mean = _bin_mean(yo, np.where(ok, co, 0.0))
    d = np.empty_like(ys)
    d[..., 0] = (ys - yo + keep * (yo - own_mean[:, None, :]))[..., 0]  # keep: the own profile stays
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = lambda m, c: np.log(np.maximum(m[..., c], 1e-6) / np.maximum(m[..., 1], 1e-6))
        for k, c in ((1, 0), (2, 2)):  # log of (R/G, B/G) of the photo over the synthesis's
            d[..., k] = ratio(ms, c) - ratio(mo, c)
    finite = np.isfinite(d).all(-1)  # both sides have pixels in the bin
    off = klayout.at_height(_tables(d, ok & finite), out_lab, t)
    short = runs < LAYOUT_MIN_RUN
    if short.any():  # the label's mean (over its output pixels)
        off[short] = _bin_mean(d, np.where(finite, co, 0.0))[out_lab[short]]
    moved = klayout.move_luma_chroma(colors, klayout.smooth_offset(off, out_lab, n))
    if spread <= 1.0:
        return moved
    return grain.spread(moved, labels, source_rgb, source_labels, max_gain=spread, scale=scale)


def blend_frame(rgb: np.ndarray, patch: np.ndarray, labels: np.ndarray | None, solve: SimpleNamespace, *,
                source_rgb: np.ndarray | None = None, sx: np.ndarray | None = None, sy: np.ndarray | None = None,
                scale: float = 1.0, fixed: np.ndarray | None = None,
                values: np.ndarray | None = None, source_labels: np.ndarray | None = None,
                source=None, memo=None) -> tuple[np.ndarray, dict]:
    """The whole-frame solve (``fixed`` pixels keep ``values``). ``solve``: the
    ``PoissonSolve`` parameters; ``seams: source`` reads ``source_rgb`` through ``sx, sy``
    (source pixels; ``scale`` source pixels per output pixel); ``layout`` moves ``rgb``
    by ``layout_move`` first (needs ``labels``, ``source_rgb``, ``source_labels``).

    With ``source`` (the SourceRead plate ``source_rgb`` and ``source_labels`` come from),
    ``solve.grain`` > 1, ``sx, sy``, no ``fixed`` pixels and ``scale`` 1 (an output pixel
    is a source pixel: the two images' layers compare radius for radius), the blended
    frame's detail is measured against the photo's (``grain.gain_table``), the frame is
    read again through its map from the graded source (``grain.graded``: ``rgb`` is
    replaced, it must be Magnify's bilinear lookup of the source) and blended again, the
    layout and the seams then taken from the graded source too; ``info["grain"]`` is the
    table, for the plate's ``meta["grain"]`` (later frames and Relight read the same
    graded source)."""
    def solved(colours, src, tol=solve.tol, spread=getattr(solve, "layout_spread", 1.0)):
        if solve.layout:
            colours = layout_move(colours, labels, src, source_labels, keep=solve.layout_keep, spread=spread,
                                  scale=scale)
        seams = None
        if solve.seams == "source":  # only the edges across a seam: the only ones the solve reads
            # made inside the transfer and dropped before its solve (not held here through it)
            seams = lambda: kpoisson.seam_gradients_at(src, sx, sy, patch, np.ones(patch.shape, np.bool_), scale)  # noqa: E731
        u, info = kpoisson.poisson_transfer(colours, patch, labels, fixed=fixed, values=values,
                                            label_dirichlet=solve.label_dirichlet, seam_gradients=seams,
                                            screen=solve.screen, tol=tol, max_iter=solve.max_iter)
        return floor_light(u, info, None if fixed is None else ~fixed)

    graded = (source is not None and getattr(solve, "grain", 1.0) > 1.0 and fixed is None and scale == 1.0
              and labels is not None and source_labels is not None and sx is not None and sy is not None)
    if not graded:
        return solved(rgb, source_rgb)
    # the gains need the blended frame's detail to a few per mille, not the final solve's
    # precision: GRAIN_TOL takes 3 iterations where the default tolerance takes 8; nor the
    # layout's spread, which moves only scales coarser than the grain's layers
    u, _ = solved(rgb, source_rgb, tol=max(solve.tol, GRAIN_TOL), spread=1.0)
    table = grain.gain_table(u, labels, source_rgb, source_labels, max_gain=solve.grain)
    src = grain.graded(source, table, memo)
    u, info = solved(lookup(src, sx, sy), src)
    info["grain"] = table
    return u, info


def blend_regions(rgb: np.ndarray, patch: np.ndarray, labels: np.ndarray, free: np.ndarray, solve: SimpleNamespace,
                  *, source_rgb: np.ndarray | None, sx: np.ndarray, sy: np.ndarray, scale: float,
                  filter: str, thin: float | None = None) -> tuple[np.ndarray, dict]:
    """The solve restricted to the ``free`` pixels, the rest Dirichlet (§6.3), region by
    region; seam gradients read with ``filter`` (the reconstruction the colours used).
    ``solve.layout`` is not applied here (yet): a later frame's new pixels keep their
    synthesized low frequencies. ``thin``: see ``poisson_regions``."""
    seams = ksor.Seams(source_rgb, sx, sy, scale, filter) if solve.seams == "source" and source_rgb is not None \
        else None
    u, info = poisson_regions(rgb, patch, labels, free, seams=seams, label_dirichlet=solve.label_dirichlet,
                              screen=solve.screen, tol=solve.tol, max_iter=solve.max_iter, thin=thin)
    return floor_light(u, info, free)


def group_boxes(boxes: np.ndarray, shape: tuple[int, int], *, margin: int = 1, slack: int = 4096) -> list[tuple]:
    """Merge component boxes (``components4``) into solve windows: each box grown by
    ``margin`` and clipped to ``shape``; two windows merge when they overlap or when their
    union's area is at most the sum of their areas + ``slack`` (fewer, cheaper solves).
    Returns [(row0, row1, col0, col1 exclusive ends, [component ids 1..])]."""
    h, w = shape
    wins = [[max(0, b[0] - margin), min(h, b[1] + 1 + margin), max(0, b[2] - margin), min(w, b[3] + 1 + margin),
             [k + 1]] for k, b in enumerate(np.asarray(boxes).tolist())]
    changed = True
    while changed and len(wins) > 1:
        changed = False
        out: list = []
        for win in wins:
            for o in out:
                r0, r1 = min(o[0], win[0]), max(o[1], win[1])
                c0, c1 = min(o[2], win[2]), max(o[3], win[3])
                overlap = o[0] < win[1] and win[0] < o[1] and o[2] < win[3] and win[2] < o[3]
                area = (o[1] - o[0]) * (o[3] - o[2]) + (win[1] - win[0]) * (win[3] - win[2])
                if overlap or (r1 - r0) * (c1 - c0) <= area + slack:
                    o[:4] = [r0, r1, c0, c1]
                    o[4] = o[4] + win[4]
                    changed = True
                    break
            else:
                out.append(win)
        wins = out
    return [(a, b, c, d, sorted(ids)) for a, b, c, d, ids in wins]


def region_thickness(mask: np.ndarray, comp: np.ndarray, n: int) -> np.ndarray:
    """Thickness of each component (1..n of ``comp``) of ``mask``: 2 × area / perimeter
    (edges to a pixel outside ``mask`` or to the image border), at least 1: a band's
    width, half a square's side. (no distance transform of the
    frame needed)."""
    area, per = kt.area_perimeter(np.ascontiguousarray(mask, np.bool_), np.ascontiguousarray(comp, np.int64), n + 1)
    # a 4-neighbour in the mask is in the same component: every edge counted is to the outside
    return np.maximum(2.0 * area[1:] / np.maximum(per[1:].astype(np.float64), 1.0), 1.0)


def poisson_regions(colors: np.ndarray, patch: np.ndarray, labels: np.ndarray | None, free: np.ndarray, *,
                    seams: ksor.Seams | None = None, label_dirichlet: bool = True, screen: float = 0.0, tol: float,
                    max_iter: int, slack: int = 4096, small: int = 64,
                    thin: float | None = None) -> tuple[np.ndarray, dict]:
    """``kernels.poisson.poisson_transfer`` restricted to the ``free`` pixels (Dirichlet
    ``colors`` everywhere else).

    With every other pixel fixed, each 4-connected component of ``free`` is an
    independent problem whose only data outside it is its one-pixel ring of fixed
    neighbours. Components whose bounding box is at most ``small`` pixels across (its
    shorter side; smaller than the frame) are solved together by red-black SOR on their
    own pixels (``sor.solve_sor_at``, its system built at those pixels only: the
    work follows the free pixels, however scattered, and each region is swept until its
    own residual has fallen by ``tol``, at the pace of its width); the
    others in windows around them (``group_boxes``), each the same linear system as the
    whole frame at the cost of its area, by multigrid-preconditioned CG. Pixels of other
    components inside a window are fixed there (they are never 4-neighbours of the
    component). With ``seams`` (``sor.Seams``: source, map, step, filter) the seam gradients
    are the source's (``poisson.seam_gradients``), else zero. With ``thin``, a
    component at most that thick (``region_thickness``) is solved by SOR too, however
    large its box: an edit's band along a moved shoreline, whose window would be several
    times its pixels (SOR's sweeps follow the thickness; the same system to ``tol``).

    Returns (u (H, W, 3) float32, info: windows, solved pixels, window pixels, most
    iterations, largest residual, SOR pixels and sweeps).
    """
    colors = np.ascontiguousarray(colors, np.float32)
    u = colors.copy()
    h, w = free.shape
    comp, boxes = kt.components4(np.ascontiguousarray(free, np.bool_))
    info = {"windows": 0, "free": int(free.sum()), "window_pixels": 0, "iterations": 0, "residual": 0.0,
            "sor_pixels": 0, "sor_sweeps": 0}
    if not len(boxes):
        return u, info
    bh = boxes[:, 1] - boxes[:, 0] + 1
    bw = boxes[:, 3] - boxes[:, 2] + 1
    is_small = (np.minimum(bh, bw) <= small) & (bh * bw < h * w)
    if thin is not None:
        is_small |= region_thickness(free, comp, len(boxes)) <= thin
    if is_small.any():
        # on the box of the SOR regions and a ring of their fixed neighbours, its origin even (the
        # red-black parity of the frame's): every pixel the solve reads, the same numbers as on
        # the whole frame, at the cost of that box (an edit's update: its bands, not the window)
        sb = boxes[is_small]
        y0, y1 = max(0, int(sb[:, 0].min()) - 1), min(h, int(sb[:, 1].max()) + 2)
        x0, x1 = max(0, int(sb[:, 2].min()) - 1), min(w, int(sb[:, 3].max()) + 2)
        y0, x0 = y0 - y0 % 2, x0 - x0 % 2
        box = (slice(y0, y1), slice(x0, x1))
        cb, colors_b, patch_b = comp[box], colors[box], np.ascontiguousarray(patch[box])
        sel = np.concatenate([[False], is_small])[cb]
        fixed = ~sel
        if labels is not None and label_dirichlet:
            fixed |= kpoisson.contour_mask(np.ascontiguousarray(labels[box]))
        todo = ~fixed
        rows, cols = np.nonzero(todo)
        k = cb[rows, cols] - 1
        # each region converged on its own; omega of a square 2.5 x its thickness: fewest sweeps on
        # lake (as few as from the inscribed width, without a distance transform of the frame)
        width = region_thickness(todo, np.ascontiguousarray(cb), len(boxes))
        omega = ksor.sor_omega(2.5 * width, 2.5 * width)[k]  # per region, then per pixel
        # right-hand side, seam gradients and operator at the listed pixels only (the frame-sized
        # rhs / seam_gradients_at / solve_sor_regions numbers)
        seams_b = None if seams is None else seams._replace(sx=seams.sx[box], sy=seams.sy[box])
        v, inf = ksor.solve_sor_at(colors_b, patch_b, rows, cols, omega, k, seams=seams_b, screen=screen, tol=tol)
        u[rows + y0, cols + x0] = colors_b[rows, cols] + v
        info.update(sor_pixels=int(len(rows)), sor_sweeps=int(inf["iterations"]), sor_mean_sweeps=inf["sweeps"])
        info["residual"] = max(info["residual"], float(inf["residual"]))
    large = np.nonzero(~is_small)[0]
    for r0, r1, c0, c1, idx in group_boxes(boxes[large], free.shape, slack=slack):
        ids = [int(large[i - 1]) + 1 for i in idx]
        sub = comp[r0:r1, c0:c1]
        mine = np.isin(sub, ids) if len(ids) > 1 else sub == ids[0]
        gx = gy = None
        if seams is not None:  # only the seam edges the solve reads: those touching its free pixels
            gx, gy = kpoisson.seam_gradients_at(seams.source, seams.sx[r0:r1, c0:c1], seams.sy[r0:r1, c0:c1],
                                                patch[r0:r1, c0:c1], mine, seams.step, filter=seams.filter)
        lab = labels[r0:r1, c0:c1] if labels is not None else None
        out, inf = kpoisson.poisson_transfer(colors[r0:r1, c0:c1], patch[r0:r1, c0:c1], lab, fixed=~mine,
                                             values=colors[r0:r1, c0:c1], label_dirichlet=label_dirichlet,
                                             seam_gx=gx, seam_gy=gy, screen=screen, tol=tol, max_iter=max_iter)
        u[r0:r1, c0:c1][mine] = out[mine]
        info["windows"] += 1
        info["window_pixels"] += (r1 - r0) * (c1 - c0)
        info["iterations"] = max(info["iterations"], int(inf["iterations"]))
        info["residual"] = max(info["residual"], float(inf["residual"]))
    return u, info
