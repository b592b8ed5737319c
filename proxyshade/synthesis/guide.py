"""Guidance synthesis (Bonneel et al. 2010, §4): a detailed label guide from the rendered
proxy guide and the source's label map, by k-coherent label synthesis with the Chamfer
metric and a voting stack, coarse to fine, magnified through the source coordinates.

Reference: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010.

"To synthesize a 256×256 guide, we start the synthesis at the 64×64 level ... We use 5×5
neighborhoods and k = 5 coherent matches ... We do not use the jittering step."
Kernels: ``proxyshade.kernels.guide``, ``proxyshade.kernels.voting``.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from proxyshade.errors import NodeInputError
from proxyshade.plate import Plate
from proxyshade.kernels import guide as kg
from proxyshade.kernels.correct import downsample_mask
from proxyshade.kernels.random import mix_seed
from proxyshade.kernels.voting import vote_down, vote_filter
from proxyshade.synthesis.labels import dense_guide, source_table
from proxyshade.synthesis import memo as M



def _pow2(v: int) -> bool:
    return v >= 1 and (v & (v - 1)) == 0


def _exemplar(src: np.ndarray, g: float, n: int) -> np.ndarray:
    """The source's dense labels at the synthesis scale (``g`` source pixels per pixel)."""
    if abs(g - round(g)) < 1e-9 and g >= 1:
        return vote_down(src, int(round(g)), n)
    ys = np.minimum(((np.arange(int(src.shape[0] / g)) + 0.5) * g).astype(int), src.shape[0] - 1)
    xs = np.minimum(((np.arange(int(src.shape[1] / g)) + 0.5) * g).astype(int), src.shape[1] - 1)
    return src[ys][:, xs].astype(np.int32)


def _exemplar_level(ex: np.ndarray, h: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The exemplar's voted labels at spacing ``h`` and their window masks."""
    e_l = vote_filter(ex, h, n) if h > 1 else ex.astype(np.int32)
    return e_l, kg.exemplar_masks(e_l, h, n)


def _previous_state(previous: Plate, active: np.ndarray, f: int, scale: float, g: float, ex_shape,
                    shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """The synthesis-size state (``shape``, int32 exemplar coordinates) of a guide whose
    output pixel (i, j) has source position S(i // f, j // f) · g + (i % f + 0.5) · scale
    − 0.5 (read at each block's first pixel; edges repeated into the padding), and the
    blocks holding an ``active`` pixel (bool, ``shape``)."""
    sy = previous["source.y"][::f, ::f].astype(np.float64)
    sx = previous["source.x"][::f, ::f].astype(np.float64)
    S = np.empty(sy.shape + (2,), np.int32)
    S[..., 0] = np.clip(np.rint((sy + 0.5 - 0.5 * scale) / g), 0, ex_shape[0] - 1)
    S[..., 1] = np.clip(np.rint((sx + 0.5 - 0.5 * scale) / g), 0, ex_shape[1] - 1)
    S = np.pad(S, ((0, shape[0] - S.shape[0]), (0, shape[1] - S.shape[1]), (0, 0)), mode="edge")
    return np.ascontiguousarray(S), downsample_mask(active, f, shape)


def _label_colours(labels: list[dict], table: np.ndarray) -> np.ndarray:
    by_id = {int(t["id"]): t["color"].lstrip("#") for t in labels}
    return np.array([[int(by_id[int(i)][k:k + 2], 16) / 255.0 for k in (0, 2, 4)] for i in table], np.float64)


def _blur(img: np.ndarray, sigma: float) -> np.ndarray:
    """Separable Gaussian blur of an (H, W, C) image with clamped borders."""
    if sigma <= 0:
        return img
    r = int(np.ceil(3 * sigma))
    x = np.arange(-r, r + 1)
    k = np.exp(-x * x / (2 * sigma * sigma))
    k /= k.sum()
    out = img
    for axis in (0, 1):
        pad = [(0, 0)] * 3
        pad[axis] = (r, r)
        p = np.pad(out, pad, mode="edge")
        out = sum(k[t] * np.take(p, np.arange(t, t + out.shape[axis]), axis=axis) for t in range(2 * r + 1))
    return out


def _block_mean(img: np.ndarray, g: int, shape) -> np.ndarray:
    """(H, W, C) -> mean over g × g blocks (edge-padded), cropped to ``shape``: the proxy's
    label colours taken down to a pyramid level (the l2 baseline's guide side)."""
    H, W, C = img.shape
    Hp, Wp = -(-H // g) * g, -(-W // g) * g
    if (Hp, Wp) != (H, W):
        img = np.pad(img, ((0, Hp - H), (0, Wp - W), (0, 0)), mode="edge")
    out = img.reshape(Hp // g, g, Wp // g, g, C).mean(axis=(1, 3))
    return np.ascontiguousarray(out[:shape[0], :shape[1]])


def _windows(col: np.ndarray) -> np.ndarray:
    """(H, W, 3) -> (H, W, 75): each pixel's 5×5 window (clamped) of colours."""
    H, W, _ = col.shape
    ii, jj = np.mgrid[0:H, 0:W]
    parts = [col[np.clip(ii + dy, 0, H - 1), np.clip(jj + dx, 0, W - 1)] for dy in range(-2, 3) for dx in range(-2, 3)]
    return np.ascontiguousarray(np.concatenate(parts, axis=-1))


def synthesize_guide(proxy: Plate, source: Plate, gp: SimpleNamespace, *, previous: Plate | None = None,
                     active: np.ndarray | None = None, memo=None) -> tuple[Plate, str]:
    """The detailed guide of ``proxy`` (its ``label.id`` replaced, ``source.x/y`` added,
    metadata ``guide``) and a one-line summary for the run report. ``gp``: the
    ``Guidance`` parameters.

    With ``previous`` (the last guide on this pixel grid, synthesized at this
    magnification: its ``source.x/y``) and ``active`` (H, W bool), the masked correction
    of an edit's update (§7): at every level the state is the previous one (read back from
    its source positions) except on the active pixels' blocks, which are initialized with
    the new labels (the previous coordinates where their label is still the target's,
    fresh ones of the target's label elsewhere) and corrected with the rest as fixed
    context. Only the active pixels' results are meant to be used. ``memo``
    (``synthesis.memo``) keeps what depends on the source and the parameters only."""
    table = source_table(source)
    n = len(table)
    names = {int(t["id"]): t["name"] for t in source.meta["labels"]}
    tkey = tuple(table.tolist())

    def per_source(what: tuple, compute):  # kept for this source's label map and table
        return M.kept(memo, f"guide.{what[0]}", (source["label.id"], tkey) + what[1:], compute, size=4)

    src = per_source(("dense",), lambda: dense_guide(source["label.id"], table, "source"))
    tgt = dense_guide(proxy["label.id"], table, "proxy")
    present = per_source(("present",), lambda: np.unique(src))
    if len(present) < 2:
        raise NodeInputError(f"the source label map has a single label ({names[int(table[present[0]])]}); "
                             "guidance synthesis needs at least two labels: paint the label map's regions")
    absent = sorted(set(np.flatnonzero(np.bincount(tgt.ravel(), minlength=n))) - set(present))
    if absent:
        which = ", ".join(names[int(table[a])] for a in absent)
        raise NodeInputError(f"proxy label(s) {which} are in the table but painted nowhere in the source; "
                             "paint them in the source's label map or relabel the proxy")
    H, W = tgt.shape
    if not _pow2(gp.size) or not _pow2(gp.start) or gp.start > gp.size:
        raise NodeInputError(f"size {gp.size} and start {gp.start} must be powers of two with start <= size "
                             "(e.g. size 256, start 64)")
    if gp.size > max(H, W):
        smallest = 8  # Guidance.size and .start's minimum
        if max(H, W) < smallest:
            raise NodeInputError(f"the output {W}x{H} is smaller than the smallest guide ({smallest} pixels on the "
                                 f"long side); render at least {smallest} pixels wide or high (the proxy's resolution)")
        fit = 2 ** int(np.log2(max(H, W)))
        sizes = f"size {fit}" if fit == smallest else f"size a power of two from {smallest} to {fit} (e.g. {fit})"
        raise NodeInputError(f"size {gp.size} is larger than the output {W}x{H}; set {sizes}"
                             + (f" and start at most that (e.g. start {fit})" if gp.start > fit else ""))
    # magnification: the power of two nearest to output / size; the proxy guide is padded
    # (edge pixels repeated) to a multiple of every level's block and the result cropped,
    # so any output size and aspect works
    f = 2 ** max(0, int(round(np.log2(max(H, W) / gp.size))))
    g = f * gp.scale  # source pixels per synthesis (exemplar) pixel
    ex = per_source(("ex", float(g)), lambda: _exemplar(src, g, n))
    levels = int(np.log2(gp.size // gp.start)) + 1
    block_px = f * 2 ** (levels - 1)
    Hp, Wp = -(-H // block_px) * block_px, -(-W // block_px) * block_px
    tgt_full = tgt
    tgt = np.pad(tgt, ((0, Hp - H), (0, Wp - W)), mode="edge") if (Hp, Wp) != (H, W) else tgt
    if min(ex.shape) < 8:
        raise NodeInputError(f"the source is {ex.shape[1]}x{ex.shape[0]} at the synthesis scale, smaller than a "
                             "useful exemplar; lower 'scale' or use a larger source")
    t0 = vote_down(tgt, f, n) if f > 1 else tgt.astype(np.int32)
    # the l2 baseline is kept as the paper's Fig. 3 describes it: no adjacency rule
    keep_adj = gp.keep_adjacency and gp.metric == "chamfer"
    # the source's adjacencies are the source's (kept), the proxy's this call's: the same union
    allowed = (per_source(("adj",), lambda: kg.adjacency(src, n=n))
               | kg.adjacency(tgt_full, n=n)) if keep_adj else np.ones((n, n), bool)
    lock_pairs = []
    by_name = {t["name"]: i for i, t in enumerate(sorted(source.meta["labels"], key=lambda t: list(table).index(int(t["id"]))))}
    for pair in gp.locked:
        if not (isinstance(pair, (list, tuple)) and len(pair) == 2 and all(x in by_name for x in pair)):
            raise NodeInputError(f"locked pair {pair!r} must be two label names of the source ({', '.join(by_name)})")
        lock_pairs.append((by_name[pair[0]], by_name[pair[1]]))
    metric = 0 if gp.metric == "chamfer" else 1
    pal = _label_colours(source.meta["labels"], table)
    S = None
    prev0 = act0 = None
    if previous is not None:
        prev0, act0 = _previous_state(previous, active, f, gp.scale, g, ex.shape, (Hp // f, Wp // f))
    for l in range(levels - 1, -1, -1):
        h = 2 ** l
        e_l, masks = per_source(("level", float(g), h), lambda: _exemplar_level(ex, h, n))
        t_l = vote_down(t0, h, n) if h > 1 else t0.astype(np.int32)
        tmasks = kg.grid_masks(t_l, n)
        if metric == 1:
            ex_col = np.ascontiguousarray(_blur(pal[ex], h / 2.0))
            tgt_col = _windows(_blur(_block_mean(pal[tgt], f * h, t_l.shape), 0.5))
        else:
            ex_col = np.zeros((1, 1, 3))
            tgt_col = np.zeros((1, 1, 75))
        # they depend on the source and the parameters only: an edit's update or a later
        # frame of the run finds them (shared: not written to)
        sim = M.kept(memo, "guide.similarity_sets",
                   (source["label.id"], tkey, float(g), h, gp.k, gp.sample, mix_seed(gp.seed, l), metric,
                    pal if metric == 1 else None),
                   lambda: kg.similarity_sets(e_l, masks, ex_col, h, gp.k, gp.sample, mix_seed(gp.seed, l), metric),
                   size=8)
        if S is None:
            S = kg.init_state(t_l, e_l, gp.seed)
        else:
            S = kg.upsample_state(S, h, ex.shape[0], ex.shape[1], t_l.shape[0], t_l.shape[1])
        locked = kg.locked_border(t_l, lock_pairs) if lock_pairs else np.zeros(t_l.shape, bool)
        ex_level = kg.Exemplar(e_l, masks, ex_col, sim)
        guide_level = kg.Guide(tmasks, tgt_col, t_l, locked, allowed)
        rule = kg.Rule(h, gp.proxy_weight, metric, n)
        if prev0 is None:
            S = kg.correct(S, ex_level, guide_level, rule, passes=gp.passes)
            continue
        prev_l = np.ascontiguousarray(prev0[::h, ::h])
        act_l = downsample_mask(act0, h, t_l.shape)
        # outside the active blocks the previous state; inside, its coordinates where the label
        # they read is still the target's and the coarser level kept its own, the new ones elsewhere
        same = e_l[prev_l[..., 0], prev_l[..., 1]] == t_l
        if l < levels - 1:
            same &= np.repeat(np.repeat(kept, 2, 0), 2, 1)[:t_l.shape[0], :t_l.shape[1]]
        keep = ~act_l | same
        S[keep] = prev_l[keep]
        S = kg.correct(S, ex_level, guide_level, rule, passes=gp.passes, active=act_l)
        kept = (S == prev_l).all(-1)
    syn = ex[S[..., 0], S[..., 1]]  # labels at the synthesis size
    # magnify through the source coordinates: output pixel (i, j) sits (i % f, j % f)
    # output pixels into its synthesis pixel's exemplar cell of g x g source pixels
    ri, ci = np.arange(H), np.arange(W)
    Sy, Sx = (np.ascontiguousarray(S[..., k][ri // f][:, ci // f]) for k in (0, 1))
    sy = Sy * g + ((ri % f + 0.5) * gp.scale)[:, None] - 0.5
    sx = Sx * g + ((ci % f + 0.5) * gp.scale)[None, :] - 0.5
    hs, ws = src.shape
    sy = np.clip(sy, 0, hs - 1)
    sx = np.clip(sx, 0, ws - 1)
    fine = src[np.rint(sy).astype(int), np.rint(sx).astype(int)].astype(np.int32)
    block = np.repeat(np.repeat(syn, f, 0), f, 1)[:H, :W]
    tgt = tgt_full
    out = _respect_adjacency(fine, block, allowed) if keep_adj else fine
    if lock_pairs:  # locked borders stay exactly as in the proxy at the output size
        keep = kg.locked_border(tgt, lock_pairs, radius=2 * f)
        out[keep] = tgt[keep]
    note = (f"{levels} levels from {gp.start} to {gp.size}, label exemplar {ex.shape[1]}x{ex.shape[0]}, "
            f"magnified x{f}; {int((out != tgt).sum())} pixels changed label from the proxy")
    ch = {"label.id": table[out].astype(np.uint32), "source.x": sx.astype(np.float32),
          "source.y": sy.astype(np.float32)}
    meta = {"labels": source.meta["labels"],
            "guide": {"size": gp.size, "start": gp.start, "k": gp.k, "metric": gp.metric, "seed": gp.seed,
                      "magnify": f, "synth_labels_shape": list(syn.shape), "padded": [Wp, Hp]}}
    return proxy.with_channels(ch, meta=meta), note


def _respect_adjacency(fine: np.ndarray, block: np.ndarray, allowed: np.ndarray, max_iter: int = 32) -> np.ndarray:
    """Where the fine (source-resolution) labels put two labels side by side that are not
    allowed, fall back to the synthesis-resolution labels, until no such pair is left (the
    synthesis-resolution labels themselves respect ``allowed``)."""
    out = fine.copy()
    for _ in range(max_iter):
        bad = np.zeros(out.shape, bool)
        for a, b, sl_a, sl_b in ((out[:, :-1], out[:, 1:], (slice(None), slice(0, -1)), (slice(None), slice(1, None))),
                                 (out[:-1, :], out[1:, :], (slice(0, -1), slice(None)), (slice(1, None), slice(None)))):
            hit = ~allowed[a, b]
            bad[sl_a] |= hit
            bad[sl_b] |= hit
        bad &= out != block
        if not bad.any():
            break
        out[bad] = block[bad]
    return out
