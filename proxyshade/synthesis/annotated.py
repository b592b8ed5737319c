"""Annotated-exemplar synthesis (Diamanti et al. 2015) on arrays: clusters of the source's
annotation points (mean shift), ε-ball scales and eq. 2 weights per cluster, coarse-to-fine
constrained PatchMatch + voting in each cluster, the clusters melded at every scale (CIELAB
merge and a screened Poisson reconstruction of L*).

Reference: O. Diamanti, C. Barnes, S. Paris, E. Shechtman, O. Sorkine-Hornung, "Synthesis of
Complex Image Appearance from Limited Exemplars", ACM TOG 34(2), 2015.

Choices the paper leaves open (docs/annotated.md): annotations are quantised to 1/32 for
the ε-balls and the PatchMatch constraint (the balls are then exact on the quantised
points); mean shift runs on points binned so that at most ~1024 distinct points remain;
5×5 patches; scales as many as keep the coarsest exemplar at least 8 pixels a side (at most
5); 4 EM rounds (vote, then 3 PatchMatch iterations) per scale (with one cluster 2 at the
second finest and none at the finest, which votes the upsampled map); the output is the
vote of the central 3×3 of each patch; an occurrence penalty (Kaspar et al. 2015, as
EbSynth counts it) against large flat copies.
"""
from __future__ import annotations

from dataclasses import dataclass

import lazy_loader

from proxyshade.errors import NodeInputError
from proxyshade.declare import Param
from proxyshade.synthesis.params import ParamGroup

np = lazy_loader.load("numpy")  # on first use: the nodes read PatchOptimisation on a cached run

QUANTUM = 32
MODES = ("full", "binary", "single", "analogies")


class PatchOptimisation(ParamGroup):
    """Coarse-to-fine PatchMatch + voting of one cluster (docs/annotated.md, Method 4)."""

    patch = Param(int, 5, min=3, max=15, doc="patch size (odd)")
    levels = Param(int, 0, min=0, max=6, doc="scales (coarse to fine, factor 2); 0: as many as keep the coarsest "
                                             "exemplar at least 8 pixels a side, at most 5")
    em = Param(int, 4, min=1, max=10, doc="search + vote rounds per scale; with one cluster the finest scale "
                                          "runs none (it votes the next scale's map, upsampled), the next 2")
    iterations = Param(int, 3, min=1, max=20,
                       doc="PatchMatch iterations per round (with one cluster half at the finest scale)")
    uniformity = Param(float, 0.001, min=0.0, max=1.0,
                       doc="weight of the penalty on source patches used more often than an even use (Kaspar et al. "
                           "2015); 0: none (large flat copies, washed-out texture)")


class AnnotatedMatching(PatchOptimisation):
    """The clusters and ε-balls of the annotated method (docs/annotated.md, Methods 1-3), and
    the ablations (``mode``)."""

    eps = Param(float, 0.1, min=0.01, max=1.0,
                doc="ε-ball radius per annotation (0.05: closer match, 0.2: less repetition)")
    bandwidth = Param(float, 0.5, min=0.01, max=2.0, doc="mean-shift bandwidth of the clusters (the paper's 0.5)")
    ann_distance = Param(float, 0.0, min=0.0, max=100.0,
                         doc="weight of the annotations in the patch distance (copies stay near their annotation "
                             "inside an ε-ball); 0 = the paper: annotations only through the ε-balls")
    mode = Param(str, "full", choices=MODES,
                 doc="full method, or a baseline: binary weights, a single cluster, image analogies")


_M = AnnotatedMatching  # the defaults below are its Params' (one declaration)


@dataclass
class AnnotatedParams:
    eps: float = _M.eps.default
    patch: int = _M.patch.default
    levels: int = _M.levels.default  # 0: auto_levels
    em: int = _M.em.default
    iterations: int = _M.iterations.default
    bandwidth: float = _M.bandwidth.default
    alpha_weight: float = 10.0
    gradient_screen: float = 0.2
    # weight of the occurrence penalty (Kaspar et al. 2015), per patch pixel, in squared feature units
    uniformity: float = _M.uniformity.default
    ann_weight: float = 1.0  # analogies baseline only
    # the annotations in the patch distance of the full method (and the binary and single
    # ablations), weight against the CIELAB/alpha/gradient features: copies stay near
    # their annotation inside an ε-ball; 0 = the paper (annotations only through the balls)
    ann_distance: float = _M.ann_distance.default
    mode: str = _M.mode.default
    min_pixels: int = 1000
    seed: int = 0

    @classmethod
    def of(cls, p, group: type = AnnotatedMatching, *also: str, **given) -> "AnnotatedParams":
        """The record a node hands the layer: ``group``'s parameters and the node's own named in
        ``also`` read from ``p`` (its ``ctx.p``), as ``ParamGroup.of`` reads them, with values the
        node derived in ``given`` (e.g. ``levels``); the other fields keep their defaults."""
        return cls(**{**vars(group.of(p, *also)), **given})


def check_annotations(src_ann, usable, tgt_ann, names, *, min_pixels=1000, where_src="source", where_tgt="target"):
    """The bad inputs of annotated synthesis, each a one-line NodeInputError."""
    for arr, where in ((src_ann, where_src), (tgt_ann, where_tgt)):
        for k, n in enumerate(names):
            a = arr[..., k][usable] if where == where_src else arr[..., k]
            if not np.all(np.isfinite(a)):
                raise NodeInputError(f"{where} channel ann.{n} has NaN or inf values; fill them or mask those pixels out")
            if a.size and (a.min() < 0 or a.max() > 1):
                raise NodeInputError(f"{where} channel ann.{n} has values outside [0, 1] "
                                     f"({a.min():.3g}..{a.max():.3g}); rescale the annotation map to [0, 1]")
    if int(usable.sum()) < min_pixels:
        raise NodeInputError(f"{where_src} has {int(usable.sum())} usable pixels (mask, alpha, borders), fewer than "
                             f"{min_pixels}; use a larger source or a larger mask")
    for k, n in enumerate(names):
        lo, hi = src_ann[..., k][usable].min(), src_ann[..., k][usable].max()
        t = tgt_ann[..., k]
        tol = 1.0 / QUANTUM
        if t.min() < lo - tol or t.max() > hi + tol:
            raise NodeInputError(f"{where_tgt} channel ann.{n} spans {t.min():.3g}..{t.max():.3g}, outside the "
                                 f"source's range {lo:.3g}..{hi:.3g}; the method only interpolates: rescale the "
                                 f"target map or annotate a source that covers it")


def within_one_exemplar(ids: np.ndarray, half_width: int) -> np.ndarray:
    """(H, W) bool: pixels whose (2·half_width+1)² patch lies in one exemplar of an atlas
    (``exemplar.id`` all equal and non-zero), so no copied patch straddles two exemplars."""
    H, W = ids.shape
    pad = np.pad(ids, half_width, mode="edge")
    ok = ids > 0
    for dy in range(2 * half_width + 1):
        for dx in range(2 * half_width + 1):
            ok &= pad[dy:dy + H, dx:dx + W] == ids
    return ok


def auto_levels(src_shape, tgt_shape, *, coarsest: int = 8, most: int = 5) -> int:
    """Scales (factor 2) for ``levels = 0``: as many as keep the coarsest exemplar and
    target at least ``coarsest`` pixels a side, at most ``most``. The coarsest scale is
    where the layout of the texture's large features is decided: starting on a fine grid
    leaves them to the random start (blobs, lattices)."""
    n = min(*src_shape[:2], *tgt_shape[:2])
    L = 1
    while L < most and n // 2 ** L >= coarsest:
        L += 1
    return L


def _quant(a):
    return np.round(np.asarray(a, np.float64) * QUANTUM) / QUANTUM


def unique_points(pts, q=QUANTUM):
    """``np.unique(pts, axis=0, return_inverse=True, return_counts=True)`` for (n, d)
    points whose coordinates are multiples of 1/q in [0, 1] (quantised annotations): the
    same arrays, from one integer key per point (a histogram of the keys where they are
    few, a sort otherwise) instead of a sort of the rows."""
    pts = np.asarray(pts, np.float64)
    n, d = pts.shape
    if (q + 1) ** d >= 2 ** 62:
        u, inv, cnt = np.unique(pts, axis=0, return_inverse=True, return_counts=True)
        return u, inv.ravel(), cnt
    k = np.round(pts * q).astype(np.int64)
    key = np.zeros(n, np.int64)
    for col in k.T:  # lexicographic, first coordinate most significant: np.unique's order
        key = key * (q + 1) + col
    if (q + 1) ** d <= 1 << 22:
        hist = np.bincount(key, minlength=(q + 1) ** d)
        ukey = np.flatnonzero(hist)
        rank = np.zeros(len(hist), np.int64)
        rank[ukey] = np.arange(len(ukey))
        inv, cnt = rank[key], hist[ukey]
    else:
        ukey, inv, cnt = np.unique(key, return_inverse=True, return_counts=True)
    digits = np.empty((len(ukey), d), np.int64)
    rest = ukey.copy()
    for c in range(d - 1, -1, -1):
        digits[:, c] = rest % (q + 1)
        rest //= q + 1
    return digits / q, inv.ravel(), cnt


def _down(a, f):
    """Box-average by ``f`` (crops to a multiple of ``f``)."""
    if f == 1:
        return a
    h, w = a.shape[0] // f, a.shape[1] // f
    a = a[:h * f, :w * f]
    return a.reshape(h, f, w, f, *a.shape[2:]).mean(axis=(1, 3))


def clusters(src_ann, usable, bandwidth):
    """Mean-shift clusters of the usable source pixels' annotation points: (H, W) int32
    (-1 where not usable), number of clusters."""
    from proxyshade.kernels import annotated as ka

    d = src_ann.shape[2]
    nb = max(2, min(QUANTUM, int(1024 ** (1.0 / d))))
    pts = np.round(src_ann[usable] * nb) / nb
    u, inv, cnt = unique_points(pts, nb)
    modes = ka.mean_shift(u, cnt, bandwidth)
    lab, centres = ka.group_modes(modes, cnt, bandwidth / 2)
    out = np.full(usable.shape, -1, np.int32)
    out[usable] = lab[inv.ravel()]
    return out, len(centres)


def _bins(ann_q, sel):
    """Distinct annotation points of the selected pixels, sorted member lists."""
    bins, inv, cnt = unique_points(ann_q[sel])
    members = np.flatnonzero(sel)
    order = members[np.argsort(inv.ravel(), kind="stable")]
    start = np.concatenate([[0], np.cumsum(cnt)[:-1]]).astype(np.int64)
    return bins, cnt, order, start


def _scales(bins, cnt, eps, tgt_q, n_hold):
    from proxyshade.kernels import annotated as ka

    h, w, d = tgt_q.shape
    tu, tinv, _ = unique_points(tgt_q.reshape(-1, d))
    s = ka.ball_scale(bins, cnt, eps, tu, n_hold)
    nb = ka.nearest_bins(bins, tu, eps)
    return s[tinv.ravel()].reshape(h, w), nb[tinv.ravel()].reshape(h, w)


def _features(rgb, alpha, p: AnnotatedParams):
    """PatchMatch's features: RGB, weighted alpha (``alpha`` None: left out, for a source
    whose alpha is constant, where it adds the same to every candidate's distance), RGB
    gradients."""
    gx = np.zeros_like(rgb)
    gy = np.zeros_like(rgb)
    gx[:, :-1] = rgb[:, 1:] - rgb[:, :-1]
    gy[:-1] = rgb[1:] - rgb[:-1]
    a = [] if alpha is None else [p.alpha_weight * alpha[..., None]]
    return np.concatenate([rgb, *a, gx, gy], axis=2).astype(np.float32)


def _lab(rgb):
    from proxyshade.io.colourlib import colour_science

    c = colour_science()
    cs = c.RGB_COLOURSPACES["sRGB"]
    xyz = c.RGB_to_XYZ(np.maximum(rgb, 0), cs, apply_cctf_decoding=False)
    return c.XYZ_to_Lab(xyz, cs.whitepoint)


def _rgb(lab):
    from proxyshade.io.colourlib import colour_science

    c = colour_science()
    cs = c.RGB_COLOURSPACES["sRGB"]
    return c.XYZ_to_RGB(c.Lab_to_XYZ(lab, cs.whitepoint), cs, apply_cctf_encoding=False)


def analyse(src_ann, usable, tgt_ann, p: AnnotatedParams):
    """Clusters of the usable source pixels, eq. 2 weights of each target pixel and the
    missing map: ((H, W) int32 clusters, C, (h, w, C) weights, (h, w) float32 missing)."""
    from proxyshade.kernels import annotated as ka

    h, w, d = tgt_ann.shape
    eps = np.full(d, p.eps)
    if p.mode in ("single", "analogies"):
        cl = np.where(usable, 0, -1).astype(np.int32)
        C = 1
    else:
        cl, C = clusters(src_ann, usable, p.bandwidth)
    src_q = _quant(src_ann)
    tgt_q = _quant(tgt_ann)
    # ε-ball scales and weights at the finest scale
    S = np.empty((h, w, C))
    for i in range(C):
        sel = usable & (cl == i)
        n_i = int(sel.sum())
        bins, cnt, _, _ = _bins(src_q, sel)
        S[..., i], _ = _scales(bins, cnt, eps, tgt_q, min(n_i, max(1000, n_i // 30)))
    if C == 1:
        Wt = np.ones((h, w, 1))
    else:
        Wt = ka.eq2_weights(S.reshape(-1, C), eps).reshape(h, w, C)
        if p.mode == "binary":
            Wt = np.eye(C)[np.argmax(Wt, axis=2)]
    missing = (S.min(axis=2) > 1.0).astype(np.float32)

    return cl, C, Wt, missing


def _up2(img, shape):
    """Bilinear ×2 upsampling of (h, w, F) to ``shape`` (rows, columns) (pixel centres
    aligned, edges clamped)."""
    h, w = img.shape[:2]
    H, W = shape

    def axis(n_out, n_in):
        c = np.clip((np.arange(n_out) + 0.5) / 2 - 0.5, 0, n_in - 1)
        i0 = np.floor(c).astype(int)
        i1 = np.minimum(i0 + 1, n_in - 1)
        return i0, i1, (c - i0)

    y0, y1, fy = axis(H, h)
    x0, x1, fx = axis(W, w)
    top = img[y0][:, x0] * (1 - fx)[None, :, None] + img[y0][:, x1] * fx[None, :, None]
    bot = img[y1][:, x0] * (1 - fx)[None, :, None] + img[y1][:, x1] * fx[None, :, None]
    return (top * (1 - fy)[:, None, None] + bot * fy[:, None, None]).astype(np.float32)


def _upsample_nnf(ny, nx, shape):
    """The coarser map on the finer grid: child (2y+a, 2x+b) of (y, x) reads 2·src + (a, b)
    (-1 outside the coarser map's cover)."""
    hl, wl = shape
    uy = np.full((hl, wl), -1, np.int32)
    ux = np.full((hl, wl), -1, np.int32)
    ph, pw = min(hl, 2 * ny.shape[0]), min(wl, 2 * ny.shape[1])
    yy, xx = np.mgrid[0:ph, 0:pw]
    uy[:ph, :pw] = 2 * ny[yy // 2, xx // 2] + yy % 2
    ux[:ph, :pw] = 2 * nx[yy // 2, xx // 2] + xx % 2
    return uy, ux


def _lab_grad(lab):
    """(H, W, 2) forward differences of L* (x, y), zero on the last column / row."""
    g = np.zeros(lab.shape[:2] + (2,), np.float32)
    g[:, :-1, 0] = lab[:, 1:, 0] - lab[:, :-1, 0]
    g[:-1, :, 1] = lab[1:, :, 0] - lab[:-1, :, 0]
    return g


def meld(votes, Wt, p: AnnotatedParams):
    """The merge of C cluster votes at one scale: votes (C, h, w, 6) of (R, G, B, α, ∂L*/∂x,
    ∂L*/∂y); Wt (h, w, C). L*, a*, b*, α are W-weighted means, the L* gradient the
    cluster's with the largest ‖W_i ∇L*_i‖, L* rebuilt by screened Poisson. Returns
    ((h, w, 3) linear RGB, (h, w) α)."""
    from proxyshade.kernels import annotated as ka

    vals = np.stack([np.concatenate([_lab(v[..., :3]), v[..., 3:4]], axis=2) for v in votes])
    mean, g = ka.merge_channels(vals, votes[..., 4:6], Wt)
    mean[..., 0] = ka.screened_poisson(mean[..., 0], g[..., 0], g[..., 1], p.gradient_screen)
    return _rgb(mean[..., :3]).astype(np.float32), mean[..., 3].astype(np.float32)


def synthesize(src_rgb, src_alpha, src_ann, usable, tgt_ann, p: AnnotatedParams, names=None) -> dict:
    """Fill a target with the source's material following the annotations.

    src_rgb (H, W, 3) linear; src_alpha (H, W); src_ann (H, W, d) and tgt_ann (h, w, d) in
    [0, 1]; usable (H, W) bool. Returns a dict of arrays: rgb (h, w, 3), alpha, sx, sy
    (source pixel of the heaviest cluster), cluster (h, w) uint32 (1..C, heaviest),
    missing (h, w) float32 (1 where no cluster holds N_i points inside the ε-ball:
    interpolated appearance), weights (h, w, C), n_clusters, and melds (the scales at which
    the clusters were merged: every scale when C > 1, none with one cluster).

    Melding (the paper's §5): scales run coarse to fine with all clusters in step; at the
    end of each scale the clusters' votes are merged (``meld``) and the merged image,
    upsampled, is the first target every cluster matches at the next scale, so the
    clusters' textures stay registered where their weights overlap.
    """
    from proxyshade.kernels import annotated as ka

    if p.mode not in MODES:
        raise NodeInputError(f"mode {p.mode!r} is not one of {', '.join(MODES)}")
    names = names or [str(k) for k in range(src_ann.shape[2])]
    H, W, d = src_ann.shape
    h, w = tgt_ann.shape[:2]
    half_width = p.patch // 2
    check_annotations(src_ann, usable, tgt_ann, names, min_pixels=p.min_pixels)
    usable = usable.copy()  # patch centres: whole patches inside the source
    m = half_width
    usable[:m], usable[H - m:], usable[:, :m], usable[:, W - m:] = False, False, False, False
    eps = np.full(d, p.eps)
    cl, C, Wt, missing = analyse(src_ann, usable, tgt_ann, p)
    aw = p.ann_weight if p.mode == "analogies" else p.ann_distance
    nnfs = [None] * C
    merged = None  # (rgb, alpha) of the previous scale's meld
    melds = 0
    n_levels = p.levels or auto_levels((H, W), (h, w))
    for lev in range(n_levels - 1, -1, -1):
        f = 2 ** lev
        # one cluster: the finest scales refine what the coarser ones laid out (the finest takes
        # the upsampled map of the next as it is); several: each scale starts from a merged
        # (blended) image and takes every round to sharpen again
        if C > 1:
            rounds = p.em
        else:
            rounds = 0 if lev == 0 and n_levels > 1 else min(p.em, f)
        iters = p.iterations if lev or C > 1 else max(1, p.iterations // 2)
        s_rgb, s_a = _down(src_rgb, f), _down(src_alpha, f)
        s_ann = _quant(_down(src_ann, f))
        Hl, Wl = s_rgb.shape[:2]
        s_use = _down(usable.astype(np.float64), f) == 1.0
        s_cl = cl[:Hl * f:f, :Wl * f:f].copy()
        t_ann = _quant(_down(tgt_ann, f))
        hl, wl = t_ann.shape[:2]
        flat_alpha = bool(np.all(s_a == s_a.flat[0]))
        feat = _features(s_rgb, None if flat_alpha else s_a, p)
        if aw:
            feat = np.concatenate([feat, aw * s_ann.astype(np.float32)], axis=2)
        out_src = np.concatenate([s_rgb, s_a[..., None], _lab_grad(_lab(s_rgb))], axis=2).astype(np.float32)
        start = None
        if merged is not None and C > 1:  # the common start of every cluster at this scale
            up = _up2(np.concatenate([merged[0], merged[1][..., None]], axis=2), (hl, wl))
            start = _features(up[..., :3], None if flat_alpha else up[..., 3], p)
            if aw:
                start = np.concatenate([start, aw * t_ann.astype(np.float32)], axis=2)
        votes, present = [], []
        for i in range(C):
            sel = s_use & (s_cl == i)
            sel[:m], sel[Hl - m:], sel[:, :m], sel[:, Wl - m:] = False, False, False, False
            if not sel.any():
                votes.append(np.zeros((hl, wl, out_src.shape[2]), np.float32))
                present.append(False)
                continue
            bins, cnt, order, bstart = _bins(s_ann, sel)
            n_i = int(sel.sum())
            n_hold = max(1, min(n_i, max(1000, n_i // 30) // (f * f)))
            s_l, tb = _scales(bins, cnt, eps, t_ann, n_hold)
            if p.mode == "analogies":
                s_l = np.full((hl, wl), np.inf)
            seed = p.seed * 7919 + i * 101 + lev
            iy, ix = ka.draw_members(tb, bstart, cnt, order, Wl, seed)
            ball = ka.Ball.of(s_ann, s_cl, i, sel, eps, t_ann, s_l)
            if nnfs[i] is None:
                ny, nx = iy, ix
            else:
                ny, nx = _upsample_nnf(*nnfs[i], (hl, wl))
                ka.repair(ball, ny, nx, iy, ix)
            for e in range(rounds):
                if e == 0 and start is not None:
                    tgt = start
                else:
                    tgt = ka.vote(feat, ny, nx, half_width)
                    if aw:
                        tgt[..., -d:] = aw * t_ann
                ny, nx, _ = ka.patchmatch(feat, tgt, ball, ny, nx, half_width=half_width, iterations=iters,
                                          seed=seed * 16 + e, members=order,
                                          uniformity=p.uniformity * p.patch * p.patch)
            nnfs[i] = (ny, nx)
            votes.append(ka.vote(out_src, ny, nx, min(half_width, 1) if lev == 0 else half_width))
            present.append(True)
        if C == 1:  # one cluster: its vote is the result; its next scale starts from its own map
            merged = (votes[0][..., :3], votes[0][..., 3])
            continue
        Wl_ = _down(Wt, f)[:hl, :wl] * np.asarray(present, np.float64)
        Wl_ /= np.maximum(Wl_.sum(axis=2, keepdims=True), 1e-12)
        merged = meld(np.stack(votes), Wl_, p)
        melds += 1
    for i in range(C):
        if nnfs[i] is None:
            nnfs[i] = (np.full((h, w), half_width, np.int32), np.full((h, w), half_width, np.int32))
    rgb, alpha = merged
    heavy = np.argmax(Wt, axis=2)
    sy = np.choose(heavy, [n[0] for n in nnfs]).astype(np.float32)
    sx = np.choose(heavy, [n[1] for n in nnfs]).astype(np.float32)
    return dict(rgb=rgb.astype(np.float32), alpha=alpha.astype(np.float32), sx=sx, sy=sy,
                cluster=(heavy + 1).astype(np.uint32), missing=missing, weights=Wt, n_clusters=C, melds=melds)


def plain_texture(src_rgb, size: tuple[int, int], p: AnnotatedParams) -> dict:
    """Plain exemplar synthesis with this core: constant annotations on both sides, one
    cluster. src_rgb (H, W, 3) linear; size (rows, columns). Returns ``synthesize``'s dict."""
    H, W = src_rgb.shape[:2]
    q = AnnotatedParams(**{**p.__dict__, "mode": "single", "min_pixels": 1})
    one = np.full((H, W, 1), 0.5)
    return synthesize(np.asarray(src_rgb, np.float32), np.ones((H, W), np.float32), one, np.ones((H, W), bool),
                      np.full((int(size[0]), int(size[1]), 1), 0.5), q, names=["const"])
