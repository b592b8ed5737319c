"""Structured image hybrids (Risser, Han, Dahyot, Grinspun, SIGGRAPH 2010): the layer shared by the
``ExemplarAtlas`` and ``HybridSynth`` nodes and ``bench/bench_hybrids.py``.

An *atlas* packs 1..8 annotated exemplars of one size side by side in a row: exemplar
``k`` (``exemplar.id`` k + 1) owns the box of columns ``k w .. (k + 1) w - 1``. Each
exemplar is centre-cropped to the atlas aspect and area-resampled (colour) and
mode-resampled (labels) to ``w × h`` with ``kernels.features``' resamplers. A synthesis
state is an (H, W, 2) int32 map of atlas (row, column): the column names the exemplar
(the paper's "coordinate pointers ... augmented with exemplar indices").

References
----------
E. Risser, C. Han, R. Dahyot, E. Grinspun. Synthesizing structured image hybrids.
SIGGRAPH 2010 (ACM Transactions on Graphics 29(4)).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from proxyshade.errors import NodeInputError
from proxyshade.plate import Plate
from proxyshade.synthesis.memo import kept

MAX_EXEMPLARS = 8


def _table_key(labels) -> list[tuple[str, int]]:
    return sorted((str(t["name"]), int(t["id"])) for t in labels)


def fit_exemplar(rgb: np.ndarray, dense: np.ndarray, n: int, size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """(M, N, C) float32 colour (and any other continuous channels) and (M, N) dense
    labels -> ``size`` = (h, w): the centred crop of the source with the aspect of
    ``size``, box-filtered to it (labels: majority)."""
    from proxyshade.kernels.features import _area_resample, _mode_resample

    oh, ow = size
    M, N = dense.shape
    f = min(M / oh, N / ow)
    y0 = int((M - f * oh) // 2)
    x0 = int((N - f * ow) // 2)
    crop_rgb = np.ascontiguousarray(rgb[y0:, x0:], np.float32)
    crop_lab = np.ascontiguousarray(dense[y0:, x0:], np.int32)
    out_rgb = np.empty((oh, ow, rgb.shape[2]), np.float32)
    out_lab = np.empty((oh, ow), np.int32)
    _area_resample(crop_rgb, oh, ow, float(f), out_rgb)
    _mode_resample(crop_lab, oh, ow, float(f), n, out_lab)
    return out_rgb, out_lab


def split_plate(name: str, plate: Plate, n: int) -> list[tuple[str, Plate]]:
    """A source holding ``n`` exemplars side by side (a bundled set as one strip) -> ``n``
    named plates of equal width (the strip's width must divide by ``n``)."""
    H, W = plate.shape
    if n < 1 or W % n:
        raise NodeInputError(f"input '{name}' is {W} px wide, not {n} equal exemplars side by side; "
                             f"set split to a divisor of {W}")
    w = W // n
    return [(f"{name}.{k + 1}", Plate({c: np.ascontiguousarray(plate[c][:, k * w:(k + 1) * w]) for c in plate.channels},
                                      dict(plate.meta))) for k in range(n)]


def pack_atlas(plates: list[tuple[str, Plate]], size: tuple[int, int]) -> Plate:
    """Pack named source plates (R, G, B, label.id and meta['labels']) into one atlas plate
    of ``size`` = (h, w) boxes in a row.

    Channels ``R, G, B`` (float32), ``label.id`` and ``exemplar.id`` (uint32, 1..n), and
    the exemplars' annotation maps ``ann.*`` (box-filtered like the colour; every exemplar
    must have the same ones, AnnotatedSourceRead's plates for annotated synthesis); meta
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
    anns = sorted(c for c in first.channels if c.startswith("ann."))
    rgbs, labs, boxes = [], [], []
    for k, (name, p) in enumerate(plates):
        mine = sorted(c for c in p.channels if c.startswith("ann."))
        if mine != anns:
            raise NodeInputError(f"input '{name}': its annotations ({', '.join(mine) or 'none'}) differ from "
                                 f"'{first_name}''s ({', '.join(anns) or 'none'}); give every exemplar the same "
                                 "annotation maps")
        other = p.meta.get("labels")
        if not other or _table_key(other) != key:
            have = ", ".join(f"{a}={b}" for a, b in _table_key(other or []))
            want = ", ".join(f"{a}={b}" for a, b in key)
            raise NodeInputError(f"input '{name}': its label table ({have or 'none'}) disagrees with "
                                 f"'{first_name}' ({want}); give every exemplar the same label names and ids")
        dense, missing = dense_labels(p["label.id"], table)
        dense[missing] = 0
        rgb = np.stack([p["R"], p["G"], p["B"], *(p[c] for c in anns)], -1).astype(np.float32)
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
    channels = {"R": rgb[..., 0].copy(), "G": rgb[..., 1].copy(), "B": rgb[..., 2].copy(), "label.id": lab,
                "exemplar.id": np.ascontiguousarray(ex)}
    channels.update({c: rgb[..., 3 + i].copy() for i, c in enumerate(anns)})
    return Plate(channels, meta)


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


# ---------------------------------------------------------------------------
# analysis and synthesis


def coarsest_span(levels: int) -> int:
    """Exemplar pixels a 5 × 5 neighbourhood spans at the coarsest of ``levels`` levels."""
    return 4 * 2 ** (levels - 1) + 1


def check_levels(levels: int, bh: int, bw: int) -> None:
    span = coarsest_span(levels)
    if span > min(bh, bw):
        fit = max(l for l in range(1, 16) if coarsest_span(l) <= min(bh, bw)) if min(bh, bw) >= 5 else 0
        fix = f"lower levels to {fit} or " if fit else ""
        raise NodeInputError(f"the exemplars are {bw}x{bh}, too small for a 5x5 neighbourhood at the coarsest of "
                             f"{levels} levels (spacing {2 ** (levels - 1)} spans {span} px); {fix}raise "
                             f"ExemplarAtlas size")


def check_weights(weights, n: int) -> np.ndarray:
    """Per-exemplar weights (empty: all 1) -> float64 (n,); negative, NaN, all-zero or a
    wrong count are errors."""
    if not weights:
        return np.ones(n)
    w = np.array([float(v) for v in weights])
    if len(w) != n:
        raise NodeInputError(f"weights: {len(w)} given for {n} exemplars; give one per exemplar (or none)")
    if not np.isfinite(w).all() or (w < 0).any():
        raise NodeInputError(f"weights: {list(weights)} holds a negative or non-finite value; use weights >= 0")
    if not (w > 0).any():
        raise NodeInputError("weights: all zero; give at least one exemplar a positive weight")
    return w


def check_level_weights(rows, n: int) -> np.ndarray | None:
    """Per-level weights (rows of ``n`` weights >= 0, coarsest level first; empty: None) ->
    float64 (levels, n); a wrong row length, a negative or non-finite value, or a row of
    zeros are errors."""
    if not rows:
        return None
    out = []
    for k, row in enumerate(rows):
        if not isinstance(row, (list, tuple)) or len(row) != n:
            raise NodeInputError(f"level_weights: row {k + 1} is {row!r}, not {n} weights (one per exemplar); "
                                 f"write e.g. {[[1] * n, [1] * n]}")
        out.append(check_weights(row, n) if any(float(v) != 0 for v in row) else None)
        if out[-1] is None:
            raise NodeInputError(f"level_weights: row {k + 1} is all zero; give at least one exemplar a positive "
                                 "weight per level")
    return np.array(out)


def check_ramp(order, n: int) -> list[int]:
    """A ramp's exemplars (1-based, at least 2, each once) -> 0-based list."""
    if not order:
        return []
    if (len(order) < 2 or not all(isinstance(v, int) and not isinstance(v, bool) and 1 <= v <= n for v in order)
            or len(set(order)) != len(order)):
        raise NodeInputError(f"ramp: {order!r}; give 2 or more distinct exemplar numbers 1..{n}, e.g. [1, 2]")
    return [v - 1 for v in order]


def standardised(rgb: np.ndarray, bw: int) -> np.ndarray:
    """Per exemplar box: 255 sRGB colour, centred and divided by the square root of the
    dominant eigenvalue of its colour covariance (the paper's standardisation), float32."""
    from proxyshade.kernels.features import srgb_features

    f = srgb_features(rgb).astype(np.float64)
    out = np.empty(f.shape, np.float32)
    for x0 in range(0, f.shape[1], bw):
        box = f[:, x0:x0 + bw].reshape(-1, 3)
        c = box - box.mean(0)
        lam = float(np.linalg.eigvalsh(c.T @ c / len(c))[-1])
        out[:, x0:x0 + bw] = (c / np.sqrt(max(lam, 1e-12))).reshape(f.shape[0], -1, 3)
    return out


@dataclass
class Analysis:
    """What the synthesis needs of an atlas, per level s (h = 2^s, s = 0 finest): the
    standardised stack level, its PCA (mean, basis), the projected 6-D descriptors and the
    candidate sets (from the descriptor of ``descriptor_levels`` (the paper's L) successive
    levels, each scaled to unit RMS: the finer ones by default, the coarser ones with
    ``coarser=True``)."""

    bw: int
    bh: int
    nb: int
    descriptor_levels: int
    q: int
    sep: int
    stacks: list
    means: list
    bases: list
    P: list
    cands: list
    seconds: float = 0.0

    def level(self, s: int) -> tuple:
        """Level ``s``'s arrays as ``kernels.hybrid.run_pass`` takes them: (stack, PCA mean,
        PCA basis, descriptors, candidates)."""
        return self.stacks[s], self.means[s], self.bases[s], self.P[s], self.cands[s]


def analyse(rgb: np.ndarray, bw: int, *, levels: int, descriptor_levels: int, q: int, iterations: int, seed: int,
            separation: float = 0.05, coarser: bool = False, stack: str = "gaussian") -> Analysis:
    """The analysis of an (H, nb bw, 3) linear atlas (``levels`` stack levels).

    ``stack``: ``"gaussian"`` (the default), the per-exemplar Gaussian stack
    (``kernels.hybrid.gaussian_stack``); ``"box"``, level h the h × h box mean
    (``stack_level``, kept for comparison).

    The candidates' multiscale descriptor of level s concatenates the projections of
    levels s, s − 1, .., s − L + 1 (L = ``descriptor_levels``, the paper's "L successive
    finer levels", those that exist), each scaled to unit RMS (``kernels.hybrid.level_scales``):
    a candidate matches the pixel at its own level and in the detail it will become, each
    level weighing alike (unscaled, the finest level's larger variance drowns the others).
    At the finest level it is the single-scale descriptor. ``coarser=True``: levels s .. s +
    L − 1 instead (another reading of the paper; with the Gaussian stack its brick hybrids
    break columns, docs/hybrids.md)."""
    import time

    from proxyshade.kernels import hybrid as kh
    from proxyshade.kernels.random import mix_seed

    t0 = time.perf_counter()
    bh = rgb.shape[0]
    nb = rgb.shape[1] // bw
    sep = max(1, int(np.ceil(separation * max(bh, bw))))
    base = standardised(rgb, bw)
    if stack == "gaussian":
        levels_of = kh.gaussian_stack(base, bw, levels)
    elif stack == "box":
        levels_of = [kh.stack_level(base, bw, 2 ** s) for s in range(levels)]
    else:
        raise ValueError(f"stack: {stack!r}; use 'gaussian' or 'box'")
    stacks, means, bases, P = [], [], [], []
    for s in range(levels):
        st = levels_of[s]
        N = kh.gather(st, bw, 2 ** s)
        mean, basis = kh.pca_basis(N[::4, ::4].reshape(-1, N.shape[2]))
        stacks.append(st)
        means.append(mean)
        bases.append(basis)
        P.append(kh.project(N, mean, basis))
    scales = kh.level_scales(P) if descriptor_levels > 1 else None
    cands = []
    for s in range(levels):  # finest first; each level's search starts from the finer level's lists
        D = kh.multiscale(P, s, descriptor_levels, coarser=coarser, scales=scales)
        c, _ = kh.candidates(D, D, bw, q, sep, own_box=True, iterations=iterations if s == 0 else 1,
                             seed=mix_seed(seed, s), init=cands[-1] if cands else None)
        cands.append(np.ascontiguousarray(c))
    return Analysis(bw=bw, bh=bh, nb=nb, descriptor_levels=descriptor_levels, q=q, sep=sep, stacks=stacks,
                    means=means, bases=bases, P=P, cands=cands, seconds=time.perf_counter() - t0)


def ramp_map(shape: tuple[int, int], order, nb: int, axis: int = 1) -> np.ndarray:
    """A per-pixel weight map (Ht, Wt, nb) float64 for a smooth transition across the output:
    along ``axis`` (1: left to right, 0: top to bottom) the weight moves piecewise linearly
    through the exemplars ``order`` (0-based, e.g. (0, 1): all exemplar 0 at the first
    column, all exemplar 1 at the last); exemplars not in ``order`` weigh 0."""
    Ht, Wt = shape
    n = shape[axis]
    k = len(order)
    t = (np.arange(n) + 0.5) / n * (k - 1) if k > 1 else np.zeros(n)
    w = np.zeros((n, nb))
    for a, e in enumerate(order):
        w[:, e] += np.clip(1.0 - np.abs(t - a), 0.0, 1.0)
    return np.ascontiguousarray(np.broadcast_to(w[None, :, :] if axis == 1 else w[:, None, :], (Ht, Wt, nb)))


def smooth_noise(shape: tuple[int, int], cell: int, seed: int) -> np.ndarray:
    """(H, W) float64 noise, uniform on [0, 1) in distribution (rank-transformed), smooth
    over ``cell`` pixels: uniform numbers on a lattice of that spacing (``random.uniform_field``),
    interpolated with smoothstep weights."""
    from proxyshade.kernels.random import uniform_field

    H, W = shape
    cell = max(1, int(cell))
    gh, gw = H // cell + 2, W // cell + 2
    ii, jj = np.mgrid[0:gh, 0:gw]
    g = uniform_field(int(seed), (ii * gw + jj).astype(np.int64)).astype(np.float64)
    y = (np.arange(H) + 0.5) / cell
    x = (np.arange(W) + 0.5) / cell
    y0, x0 = y.astype(int), x.astype(int)
    fy, fx = y - y0, x - x0
    fy, fx = fy * fy * (3 - 2 * fy), fx * fx * (3 - 2 * fx)
    top = g[y0][:, x0] * (1 - fx) + g[y0][:, x0 + 1] * fx
    bot = g[y0 + 1][:, x0] * (1 - fx) + g[y0 + 1][:, x0 + 1] * fx
    v = (top * (1 - fy[:, None]) + bot * fy[:, None]).ravel()
    rank = np.empty(v.size)
    rank[np.argsort(v, kind="stable")] = np.arange(v.size)
    return ((rank + 0.5) / v.size).reshape(H, W)


def dithered_map(weight_map: np.ndarray, cell: int, seed: int, others: float) -> np.ndarray:
    """A per-pixel weight map whose exemplars' shares follow its weights in patches: each
    pixel prefers the exemplar that ``smooth_noise`` (feature size ``cell``) picks by the
    cumulative normalised weights there (so along a ramp each exemplar's share of a column
    is its weight), weight 1; the other exemplars with a positive weight get ``others``
    (0: only the preferred one; 1: every positive one alike), those at 0 stay 0."""
    w = np.asarray(weight_map, np.float64)
    total = w.sum(-1, keepdims=True)
    cum = np.cumsum(w, -1) / np.where(total > 0, total, 1.0)
    u = smooth_noise(w.shape[:2], cell, seed)
    pick = np.minimum((u[..., None] >= cum).sum(-1), w.shape[2] - 1)
    out = np.where(np.arange(w.shape[2]) == pick[..., None], 1.0, float(others))
    return np.ascontiguousarray(np.where(w > 0, out, 0.0))


RAMP_OTHERS = 0.5  # a dithered ramp's weight of the exemplars a pixel does not prefer


def ramp_weights(shape: tuple[int, int], order, nb: int, *, axis: int = 1, cell: int = 8, seed: int = 0) -> np.ndarray:
    """The per-pixel weights of a ramp through ``order``: ``ramp_map``, dithered
    (``dithered_map``, feature size ``cell``, the other exemplars at ``RAMP_OTHERS``) so
    each exemplar's share of a column follows its weight; ``cell`` 0: the plain map, whose
    cost divisor switches from one exemplar to the next over a narrow band."""
    from proxyshade.kernels.random import mix_seed

    w = ramp_map(shape, order, nb, axis)
    return dithered_map(w, cell, mix_seed(seed, 0xD17), RAMP_OTHERS) if cell > 0 else w


def level_field(weights: np.ndarray, level_row, weight_map, sh: tuple[int, int], h: int) -> np.ndarray:
    """One level's weights per state pixel and exemplar, (sh[0], sh[1], nb) float64:
    ``weights`` × ``level_row`` (that level's per-exemplar weights, or None) × ``weight_map``
    (None, or (Ht, Wt, nb) at the output size) sampled at each state pixel's centre output
    pixel (spacing ``h``)."""
    w = np.asarray(weights, np.float64)
    if level_row is not None:
        w = w * np.asarray(level_row, np.float64)
    field = np.broadcast_to(w, sh + (len(w),))
    if weight_map is not None:
        Hm, Wm = weight_map.shape[:2]
        ii = np.minimum(np.arange(sh[0]) * h + h // 2, Hm - 1)
        jj = np.minimum(np.arange(sh[1]) * h + h // 2, Wm - 1)
        field = field * weight_map[ii][:, jj]
    return np.ascontiguousarray(field, np.float64)


def mirror_state(coords: np.ndarray, bw: int) -> np.ndarray:
    """The symmetric option: the state's right half becomes the left half mirrored, each
    pointer's column reflected inside its exemplar's box (for exemplars symmetric about
    their vertical axis, like aligned faces)."""
    coords = coords.copy()
    Wt = coords.shape[1]
    left = coords[:, :Wt // 2][:, ::-1]
    x0 = (left[..., 1] // bw) * bw
    coords[:, Wt - Wt // 2:, 0] = left[..., 0]
    coords[:, Wt - Wt // 2:, 1] = x0 + bw - 1 - (left[..., 1] - x0)
    return coords


def synthesize(an: Analysis, shape: tuple[int, int], *, jitter_threshold: float, seed: int, weights: np.ndarray,
               passes: int, jitter: str = "structure", r: float = 0.0, jitter_levels: int | None = None,
               level_weights=None, weight_map: np.ndarray | None = None, symmetric: bool = False,
               coherence: float = 1.0, layout: str = "exemplar") -> np.ndarray:
    """A hybrid's state: (Ht, Wt, 2) int32 atlas (row, column), coarse to fine: identity
    pointers at the coarsest level into exemplars drawn by the weights; per level upsample
    (``correct.upsample_state`` on box-local coordinates), jitter (``structure``: one pass
    of the structure-preserving jitter with threshold ``jitter_threshold``, the paper's J;
    ``spatial``: the baseline's ⌊h r ξ + ½⌋), then ``passes`` correction passes. The coarsest exemplars are one fixed
    draw (by the weights): with the exemplar layout the seed acts through the jitter only,
    and J = 0 (or r = 0) gives one result whatever the seed. ``jitter_levels``: jitter only
    the finest that many levels (None: all); the coarser keep the exemplars' layout exactly.

    Weights (the paper's per-exemplar, per-level and per-pixel control): at level s a
    candidate from exemplar e at state pixel p costs d / (weights[e] × level_weights[row][e]
    × weight_map[p, e]), ``row`` counting from the coarsest level (the last row repeats for
    the finer levels); a zero product: never a candidate there. ``weight_map``: (Ht, Wt, nb)
    or None (``ramp_weights`` makes a transition across the output). ``symmetric``: after each
    level the right half mirrors the left (``mirror_state``). ``layout``: ``"exemplar"``, the
    coarsest pointers are the exemplars' own layout (tiled past a box); ``"random"``, each a
    random place of its box drawn from the seed (a texture larger than its exemplar without
    tiling it; ``with_variants``)."""
    from proxyshade.kernels import hybrid as kh
    from proxyshade.kernels.correct import upsample_state
    from proxyshade.kernels.random import mix_seed, uniform_field

    Ht, Wt = shape
    levels = len(an.stacks)
    lw = None if level_weights is None or not len(level_weights) else np.asarray(level_weights, np.float64)
    coords = None
    for s in range(levels - 1, -1, -1):
        h = 2 ** s
        sh = (-(-Ht // h), -(-Wt // h))
        w = level_field(weights, None if lw is None else lw[min(levels - 1 - s, len(lw) - 1)], weight_map, sh, h)
        inv_w = np.where(w > 0, 1.0 / np.maximum(w, 1e-300), np.inf)  # weight 0: never a candidate
        if coords is None:
            ii, jj = np.mgrid[0:sh[0], 0:sh[1]]
            # one fixed draw, not the seed's: with J = 0 every seed gives the same result
            u = uniform_field(0xE7, (ii * sh[1] + jj).astype(np.int64))
            total = w.sum(-1, keepdims=True)
            cum = np.cumsum(w, -1) / np.where(total > 0, total, 1.0)
            e = np.minimum((u[..., None] >= cum).sum(-1), an.nb - 1)
            if layout == "exemplar":  # the exemplar's own layout, tiled past its size (an output larger than the box)
                y, x = (h * ii + h // 2) % an.bh, (h * jj + h // 2) % an.bw
            else:  # "random": each pixel a random place of its box, from the seed (no tiling)
                ids = (ii * sh[1] + jj).astype(np.int64)
                y = (uniform_field(mix_seed(seed, 0x1A), ids) * an.bh).astype(np.int64)
                x = (uniform_field(mix_seed(seed, 0x1B), ids) * an.bw).astype(np.int64)
            coords = np.stack([y, x + e * an.bw], -1).astype(np.int32)
        else:
            e = coords[..., 1] // an.bw
            local = coords.copy()
            local[..., 1] -= e * an.bw
            up = upsample_state(local, h, sh, (an.bh, an.bw))
            Hp, Wp = e.shape
            ec = e[np.minimum(np.arange(sh[0]) // 2, Hp - 1)][:, np.minimum(np.arange(sh[1]) // 2, Wp - 1)]
            up[..., 1] += ec * an.bw
            coords = up
        level = an.level(s)
        lseed = mix_seed(seed, s)
        if jitter_levels is not None and s >= jitter_levels:
            pass  # only the finest ``jitter_levels`` levels are jittered
        elif jitter == "structure":
            coords = kh.run_pass(level, inv_w, coords, h=h, bw=an.bw, jitter_threshold=jitter_threshold, seed=lseed, salt=0)
        elif r > 0:
            coords = kh.spatial_jitter(coords, h=h, r=r, bw=an.bw, atlas_height=an.bh, seed=lseed)
        for k in range(passes):
            coords = kh.run_pass(level, inv_w, coords, h=h, bw=an.bw, jitter_threshold=0.0, seed=lseed, salt=k + 1,
                            coherence=coherence)
        if symmetric:
            coords = mirror_state(coords, an.bw)
    return coords


def hybrid_plate(atlas: Plate, coords: np.ndarray, extra: dict) -> Plate:
    """The hybrid as an annotated source: colour and labels looked up at the pointers,
    ``exemplar.id``, ``atlas.x/y`` (float32 atlas column, row) and the atlas's label table."""
    y, x = coords[..., 0], coords[..., 1]
    ch = {c: np.ascontiguousarray(atlas[c][y, x]) for c in ("R", "G", "B", "label.id", "exemplar.id")}
    ch["atlas.x"] = x.astype(np.float32)
    ch["atlas.y"] = y.astype(np.float32)
    meta = {"labels": atlas.meta.get("labels", []), "source": dict(atlas.meta.get("source", {})),
            "atlas": atlas.meta.get("atlas", []), "hybrid": extra}
    meta["source"]["size"] = [int(coords.shape[1]), int(coords.shape[0])]
    return Plate(ch, meta)


def analysis_of(atlas: Plate, bw: int, *, levels: int, descriptor_levels: int, q: int, iterations: int,
                memo=None) -> Analysis:
    """``analyse`` of an atlas plate, kept in ``memo`` (every frame of a run passes the
    same atlas: the analysis runs once)."""
    arrays = (atlas["R"], atlas["G"], atlas["B"])

    def run():
        rgb = np.stack(arrays, -1).astype(np.float32)
        return analyse(rgb, bw, levels=levels, descriptor_levels=descriptor_levels, q=q, iterations=iterations, seed=0)

    return kept(memo, "hybrid.analysis_of", (arrays, bw, levels, descriptor_levels, q, iterations), run)


def plain_texture(rgb: np.ndarray, size: tuple[int, int], *, seed: int, jitter_threshold: float = 0.1,
                  levels: int | None = None, passes: int = 3, descriptor_levels: int = 8, q: int = 2,
                  iterations: int = 4, coherence: float = 0.2) -> dict:
    """A texture of ``size`` = (h, w) from one exemplar image ((H, W, 3) linear): the
    hybrid synthesis with a single exemplar (``TextureSynth`` method ``hybrid``). Levels
    default to the most whose coarsest 5 × 5 neighbourhood fits the exemplar. Returns
    ``rgb`` (h, w, 3) float32 and ``sx``, ``sy`` (float32 exemplar column, row)."""
    rgb = np.ascontiguousarray(rgb, np.float32)
    bh, bw = rgb.shape[:2]
    if levels is None:
        levels = max(l for l in range(1, 13) if coarsest_span(l) <= min(bh, bw)) if min(bh, bw) >= 5 else 1
    check_levels(levels, bh, bw)
    an = analyse(rgb, bw, levels=levels, descriptor_levels=descriptor_levels, q=q, iterations=iterations, seed=0)
    coords = synthesize(an, size, jitter_threshold=jitter_threshold, seed=seed, weights=np.ones(1), passes=passes,
                   coherence=coherence)
    return {"rgb": rgb[coords[..., 0], coords[..., 1]], "sx": coords[..., 1].astype(np.float32), "sy": coords[..., 0].astype(np.float32)}


def label_window(ids: np.ndarray, label: int, area: float, smallest: int = 33, avoid=()) -> tuple[int, int, int, int]:
    """The window (y0, x0, h, w) of about ``area`` pixels (each side at least ``smallest``,
    at most the image's) holding the largest share of ``label`` in a label map, over the
    aspects 1:8 .. 8:1 and every position (summed-area table; the first best wins). With
    ``avoid`` (earlier windows), the share times 1 − the largest part of the window they
    cover: another variant reads another part of the photo where it can."""
    M, N = ids.shape
    sat = np.pad(np.cumsum(np.cumsum(ids == label, 0), 1), ((1, 0), (1, 0)))
    best = (-1.0, 0, 0, M, N)
    for aspect in (1 / 8, 1 / 4, 1 / 2, 1, 2, 4, 8):  # width / height
        h = int(min(M, max(smallest, round(np.sqrt(area / aspect)))))
        w = int(min(N, max(smallest, round(area / h))))
        score = (sat[h:, w:] - sat[:-h, w:] - sat[h:, :-w] + sat[:-h, :-w]) / float(h * w)
        y, x = np.arange(M - h + 1)[:, None], np.arange(N - w + 1)[None, :]
        for y1, x1, h1, w1 in avoid:
            oh = np.clip(np.minimum(y + h, y1 + h1) - np.maximum(y, y1), 0, None)
            ow = np.clip(np.minimum(x + w, x1 + w1) - np.maximum(x, x1), 0, None)
            score = score * (1.0 - oh * ow / float(h * w))
        k = int(np.argmax(score))
        if score.flat[k] > best[0]:
            best = (float(score.flat[k]), k // score.shape[1], k % score.shape[1], h, w)
    return best[1:]


def variant_states(rgb: np.ndarray, ids: np.ndarray, n: int, *, even: bool, seed: int, jitter_threshold: float,
                   coherence: float, passes: int, descriptor_levels: int, q: int, iterations: int) -> list:
    """``n`` hybrid variants of a photo ((Hs, Ws, 3) linear, label ids (Hs, Ws)) as
    photo (row, column) pointer maps (Hs, Ws, 2), seeds ``seed`` .. ``seed + n − 1``.
    ``even``: each variant is one vertical strip per label present, of equal widths, each a
    texture of the window richest in that label (``label_window``: half the label's share of
    the photo, at least an eighth; each variant's window avoids the earlier ones'), so every
    label gets an equal share of the variant, each strip grown from a random coarsest layout
    (a strip is larger than its window: the window's layout tiled would repeat); else each
    variant is a hybrid of the whole photo (the photo's label shares and layout)."""
    Hs, Ws = ids.shape
    analyses = {}

    def texture(y0, x0, h, w, width, k):
        if (y0, x0, h, w) not in analyses:
            levels = max(l for l in range(1, 9) if coarsest_span(l) <= min(h, w)) if min(h, w) >= 5 else 1
            analyses[y0, x0, h, w] = analyse(np.ascontiguousarray(rgb[y0:y0 + h, x0:x0 + w]), w, levels=levels,
                                             descriptor_levels=descriptor_levels, q=q, iterations=iterations, seed=0)
        coords = synthesize(analyses[y0, x0, h, w], (Hs, width), jitter_threshold=jitter_threshold, seed=seed + k,
                       weights=np.ones(1), passes=passes, coherence=coherence, layout="random" if even else "exemplar")
        return coords + np.array([y0, x0], np.int32)

    if not even:
        return [texture(0, 0, Hs, Ws, Ws, k) for k in range(n)]
    labels, counts = np.unique(ids, return_counts=True)
    edges = np.linspace(0, Ws, len(labels) + 1).astype(int)
    windows = [[] for _ in labels]
    for k in range(n):
        for t, lab in enumerate(labels):
            windows[t].append(label_window(ids, int(lab), max(counts[t] / 2.0, Hs * Ws / 8.0), avoid=windows[t]))
    strips = list(zip(edges[:-1], edges[1:]))
    return [np.concatenate([texture(*windows[t][k], b - a, k) for t, (a, b) in enumerate(strips)], 1) for k in range(n)]


def with_variants(source: Plate, n: int, *, even: bool = True, seed: int = 1, jitter_threshold: float = 0.3,
                  coherence: float = 0.5, passes: int = 2, descriptor_levels: int = 8, q: int = 2, iterations: int = 4,
                  memo=None) -> Plate:
    """An annotated source widened by ``n`` hybrid variants of itself (``variant_states``):
    the photo and its label map, then the variants, each of the photo's size, side by side;
    colour and labels looked up at the same pointers. A synthesis from the widened source
    draws a large region from more, differently arranged copies of each label; with
    ``even`` a label small in the photo gets as many variant pixels as a large one.
    Channels ``R, G, B, label.id`` and ``origin.x/y`` (float32, the photo pixel each pixel
    copies: the identity on the photo); meta ``source.variants`` = n, ``source.size`` the
    widened size. The states are kept in ``memo``. ``jitter_threshold`` (J) 0.3 and coherence 0.5 move about
    95 % of the pointers of a whole-photo variant of renoir (at J = 0.1, coherence 0.3,
    about 82 % stay put: near-copies, which would lower a repetition count on the widened
    source without showing the photo less)."""
    Hs, Ws = source.shape
    rgb = np.ascontiguousarray(source.rgb(), np.float32)
    ids = np.ascontiguousarray(source["label.id"], np.int64)

    def run():
        return variant_states(rgb, ids, n, even=even, seed=seed, jitter_threshold=jitter_threshold,
                              coherence=coherence, passes=passes, descriptor_levels=descriptor_levels, q=q,
                              iterations=iterations)

    parts = (rgb, ids, n, even, seed, jitter_threshold, coherence, passes, descriptor_levels, q, iterations)
    states = kept(memo, "hybrid.with_variants", parts, run)
    ii, jj = np.mgrid[0:Hs, 0:Ws]
    ys = [ii] + [coords[..., 0] for coords in states]
    xs = [jj] + [coords[..., 1] for coords in states]
    ch = {c: np.ascontiguousarray(np.concatenate([source[c][y, x] for y, x in zip(ys, xs)], 1))
          for c in ("R", "G", "B", "label.id")}
    ch["origin.x"] = np.concatenate(xs, 1).astype(np.float32)
    ch["origin.y"] = np.concatenate(ys, 1).astype(np.float32)
    meta = dict(source.meta)
    meta["source"] = dict(meta.get("source", {}), variants=int(n), size=[int(Ws * (n + 1)), int(Hs)])
    return Plate(ch, meta)
