"""Structured image hybrids (Risser et al. 2010): variation D, quality C and label error of
structure-preserving jitter against the baseline (spatial jitter, single-scale
descriptor), L = 8 against L = 1 on brick, and the speed bars on 2 cores:

* analysis of 2 exemplars at 256²: ≤ 10 s;
* one 256² hybrid: ≤ 1 s;
* overhead over the baseline: ≤ 1.5×.

Measures (over seeds 1..8 of one configuration):

* D: the share of pixels whose (exemplar, position) differs by more than 2 px between two
  seeds, averaged over the 28 pairs;
* C: mean distance from each output 5×5 sRGB patch to its nearest exemplar patch (RMS
  per value, 8-bit units; PatchMatch ``kernels.hybrid.candidates``, tested against
  exhaustive search, started at each output pixel's own pointer, 8 iterations; the bench
  prints it against exhaustive search on 200 pixels), at full and ½ size; on seeds 1..4;
* label error: mean symmetric Chamfer (``kernels.chamfer``) of each output 5×5 label
  window to its nearest exemplar window (exhaustive over the distinct windows); seeds 1..4.

Matched D (within ``D_TOL`` = 0.005; D over seeds 1..8, synthesis only, syntheses cached):

* baseline against SP: the jittered levels of the grid point (``BASE_LEVELS`` × ``BASE_R``)
  whose D is nearest SP's, then the radius r bisected (``match_d``) until the baseline's D
  is within 0.005 of SP's (the next jittered-levels count if r cannot reach it);
* L = 1 against L = 8 on brick: L = 1 with the same jittered levels and its J bisected
  geometrically (1e-7 .. 1) to L = 8's D (L = 1's D is higher at the same J); one level
  fewer, then more, if J cannot reach it. The same-J row is printed too.

The printed dD is the matched point's D minus the target's, and the number of D
evaluations the search took. Previous rounds matched to the nearest grid point only
(D up to 0.025 apart) and compared L = 8 with L = 1 at the same J.

Run: .venv/bin/python bench/run.py hybrids, or .venv/bin/python bench/bench_hybrids.py [--quick | --sheet |
--before-after | --align | --speed] [--brick] (``--quick``: seeds 1-4; ``--brick``: the brick comparisons only; ``--speed``: the speed bars only; ``--sheet`` writes docs/img/hybrids_sheet.jpg instead,
``--before-after`` docs/img/hybrids_before_after.jpg; ``--align`` prints how brick's two crops, ``BRICK_CROPS``,
were chosen)
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np

from harness import measure_interleaved, table

ROOT = Path(__file__).resolve().parents[1]
SIZE = 256
LEVELS, L, Q, ITERATIONS, PASSES, J_DEFAULT = 6, 8, 2, 4, 2, 0.1  # HybridSynth's defaults
SP_POINTS = [(3, 0.01), (4, 0.01), (5, 0.01)]  # (jitter levels, J); before: J = 0.05 at 2, 3, 4 levels
BASE_LEVELS = (1, 2, 3, 4, 5)  # baseline grid: jittered levels x radius (r <= 0.5: no jitter at h = 1)
BASE_R = (0.55, 0.6, 0.75, 1.0)
PREVIOUS = dict(stack="box", coarser=True)  # the previous round's analysis (before / after)


def renoir_creek():
    from proxyshade.io.source import load_source
    from proxyshade.synthesis.hybrid import pack_atlas

    plates = [(n, load_source(ROOT / f"samples/{n}/source.yaml")) for n in ("renoir", "creek")]
    return pack_atlas(plates, (SIZE, SIZE))


# brick's two crops (y, x, mirrored), 256² at 100 %: the left half's crop at row 136 and the
# right half's at row 168, mirrored left-right. The photograph is in perspective: the brick
# columns lean right in its left half and left in its right half, so crops from the two
# halves (as before: (0, 0) and (256, 256)) had their joints at different tilts and phases.
# Mirrored, the right half's columns lean like the left half's; the rows are the ones whose
# joint maps correlate best (``brick_alignment``: normalised cross-correlation of the
# horizontal- and vertical-gradient maps, summed: 0.59 against 0.07 for the old pair), so the two
# exemplars are roughly aligned, as the method assumes (Risser et al. use aligned examples).
BRICK_CROPS = ((136, 0, False), (168, 256, True))


def brick_image():
    from proxyshade.io.images import read_u8
    from proxyshade.io.source import srgb_to_linear

    return srgb_to_linear(read_u8(ROOT / "samples/textures/brick.png"))


def brick_crop(img, y, x, mirrored):
    c = img[y:y + SIZE, x:x + SIZE]
    return c[:, ::-1] if mirrored else c


def brick(crops=BRICK_CROPS):
    """Two 256² crops at 100% of the bundled brick (grey, one label): ``BRICK_CROPS``."""
    from proxyshade.graph.plate import Plate
    from proxyshade.synthesis.hybrid import pack_atlas

    img = brick_image()
    table_ = [{"name": "brick", "id": 1, "color": "#ff0000"}]
    plates = []
    for k, (y, x, m) in enumerate(crops):
        c = brick_crop(img, y, x, m)
        plates.append((f"exemplar{k + 1}", Plate({"R": c[..., 0].copy(), "G": c[..., 1].copy(), "B": c[..., 2].copy(),
                                                  "label.id": np.ones(c.shape[:2], np.uint32)}, {"labels": table_})))
    return pack_atlas(plates, (SIZE, SIZE))


def brick_alignment(step=4):
    """How ``BRICK_CROPS`` were chosen: the first crop in the left half at (y1, 0), the second
    in the right half at (y2, 256), mirrored or not (no overlap); score = normalised
    cross-correlation of the two crops' |horizontal gradient| maps plus that of their
    |vertical gradient| maps (the joints), over y1, y2 in steps of ``step``. Prints the best
    and the old pair ((0, 0), (256, 256))."""
    g = brick_image()[..., 0].astype(np.float64)

    def grads(a):
        return np.abs(np.diff(a, axis=1, append=a[:, -1:])), np.abs(np.diff(a, axis=0, append=a[-1:]))

    def ncc(a, b):
        a = a - a.mean()
        b = b - b.mean()
        return float((a * b).sum() / np.sqrt((a * a).sum() * (b * b).sum()))

    def score(c1, c2):
        (ax, ay), (bx, by) = grads(brick_crop(g, *c1)), grads(brick_crop(g, *c2))
        return ncc(ax, bx) + ncc(ay, by)

    best = max(((score((y1, 0, False), (y2, SIZE, m)), y1, y2, m) for m in (False, True)
                for y1 in range(0, SIZE + 1, step) for y2 in range(0, SIZE + 1, step)))
    print(f"best: ({best[1]}, 0) and ({best[2]}, {SIZE}{', mirrored' if best[3] else ''}): {best[0]:.3f}")
    print(f"chosen {BRICK_CROPS}: {score(BRICK_CROPS[0], BRICK_CROPS[1]):.3f}; "
          f"old ((0, 0), (256, 256)): {score((0, 0, False), (SIZE, SIZE, False)):.3f}")


def atlas_rgb(atlas):
    return np.stack([atlas["R"], atlas["G"], atlas["B"]], -1).astype(np.float32)


def variation(states) -> float:
    v = []
    for a in range(len(states)):
        for b in range(a + 1, len(states)):
            v.append((np.abs(states[a].astype(np.int64) - states[b]).max(-1) > 2).mean())
    return float(np.mean(v))


def half(rgb, bw):
    """2 × 2 box mean (linear), box by box (sizes are even)."""
    H, W, _ = rgb.shape
    return rgb.reshape(H // 2, 2, W // 2, 2, 3).mean((1, 3)).astype(np.float32)


C_ITERATIONS = 8  # PatchMatch iterations of the C search (started at the output's own pointers)


def pointer_init(S, bw, nb, f=1):
    """The C search's start: each output pixel's own pointer (scaled by 1/f for the ½-size
    measure), and the same box position in every other exemplar. A copied region is then
    found at once (distance 0); the parallel PatchMatch, whose propagation moves only a few
    pixels per iteration, missed 72 % of an exact copy's patches from random starts at 4
    iterations (C 7.47 instead of 0 for creek itself)."""
    S = S[::f, ::f]
    loc = np.stack([S[..., 0] // f, (S[..., 1] % bw) // f], -1)
    return np.ascontiguousarray(np.stack([loc + np.array([0, b * (bw // f)]) for b in range(nb)], 2)[:, :, :, None, :],
                                np.int32)


def patch_distance(out_rgb, ex_rgb, bw, init=None, iterations=C_ITERATIONS) -> float:
    from proxyshade.kernels import hybrid as kh
    from proxyshade.kernels.features import srgb_features

    Qd = kh.gather(srgb_features(out_rgb), out_rgb.shape[1], 1)
    Ad = kh.gather(srgb_features(ex_rgb), bw, 1)
    _, d = kh.candidates(Qd, Ad, bw, 1, 1, own_box=False, iterations=iterations, seed=0, init=init)
    return float(np.sqrt(d[..., 0].min(-1) / Qd.shape[2]).mean())


def check_c_search(meas, S, n=200):
    """The C search against exhaustive search on n random output pixels of one hybrid
    (printed: the search's mean over the exhaustive mean; 1 is exact)."""
    from proxyshade.kernels import hybrid as kh
    from proxyshade.kernels.features import srgb_features

    out = meas.rgb[S[..., 0], S[..., 1]]
    Qd = kh.gather(srgb_features(out), out.shape[1], 1)
    Ad = kh.gather(srgb_features(meas.rgb), SIZE, 1)
    _, d = kh.candidates(Qd, Ad, SIZE, 1, 1, own_box=False, iterations=C_ITERATIONS, seed=0,
                         init=pointer_init(S, SIZE, meas.rgb.shape[1] // SIZE))
    got = np.sqrt(d[..., 0].min(-1) / Qd.shape[2])
    flat = Ad.reshape(-1, Ad.shape[2]).astype(np.float64)
    idx = np.random.default_rng(0).integers(0, SIZE, (n, 2))
    ex = np.array([np.sqrt(((flat - Qd[i, j]) ** 2).sum(1).min() / Qd.shape[2]) for i, j in idx])
    print(f"C search vs exhaustive on {n} pixels of one hybrid: {got[idx[:, 0], idx[:, 1]].mean():.3f} / "
          f"{ex.mean():.3f} = {got[idx[:, 0], idx[:, 1]].mean() / max(ex.mean(), 1e-9):.3f}")


class Measures:
    def __init__(self, atlas):
        from proxyshade.kernels.features import dense_labels, window_masks

        self.atlas = atlas
        self.rgb = atlas_rgb(atlas)
        self.bw = SIZE
        self.table = np.array([t["id"] for t in atlas.meta["labels"]])
        self.n = len(self.table)
        dense, _ = dense_labels(atlas["label.id"], self.table)
        ex = np.concatenate([window_masks(dense[:, x:x + SIZE], 1, self.n) for x in range(0, dense.shape[1], SIZE)], 1)
        self.ex_windows = np.unique(ex.reshape(-1, self.n), axis=0)
        self.half_rgb = half(self.rgb, SIZE)

    def quality(self, S):
        from proxyshade.kernels import hybrid as kh
        from proxyshade.kernels.features import dense_labels, window_masks

        out = self.rgb[S[..., 0], S[..., 1]]
        nb = self.rgb.shape[1] // SIZE
        c_full = patch_distance(out, self.rgb, SIZE, pointer_init(S, SIZE, nb))
        c_half = patch_distance(half(out, None), self.half_rgb, SIZE // 2, pointer_init(S, SIZE, nb, 2))
        dense, _ = dense_labels(self.atlas["label.id"][S[..., 0], S[..., 1]], self.table)
        win, counts = np.unique(window_masks(dense, 1, self.n).reshape(-1, self.n), axis=0, return_counts=True)
        lab = float((kh.nearest_chamfer(win, self.ex_windows) * counts).sum() / counts.sum())
        return c_full, c_half, lab


_STATES: dict = {}  # (analysis, seeds, settings) -> states: a matching search and a quality run share syntheses
_QUALITY: dict = {}


def _key(an, seeds, kw):
    return (id(an), tuple(seeds), tuple(sorted(kw.items())))


def states_of(an, seeds, **kw):
    from proxyshade.synthesis.hybrid import synthesize

    k = _key(an, seeds, kw)
    if k not in _STATES:
        _STATES[k] = [synthesize(an, (SIZE, SIZE), seed=s, weights=np.ones(an.nb), passes=PASSES, **kw) for s in seeds]
    return _STATES[k]


def d_of(an, seeds, **kw) -> float:
    return variation(states_of(an, seeds, **kw))


def quality_of(meas, states):
    q = np.array([meas.quality(S) for S in states[:len(states) // 2]])
    return variation(states), *q.mean(0)


def run_config(an, meas, seeds, **kw):
    k = _key(an, seeds, kw)
    if k not in _QUALITY:
        _QUALITY[k] = quality_of(meas, states_of(an, seeds, **kw))
    return _QUALITY[k]


D_TOL = 0.005  # matched D: within this of the target
MATCH_STEPS = 14  # at most this many syntheses of seeds 1..8 per matched point


def match_d(target, d_at, lo, hi, *, log=False, hi_max=None, known=()):
    """The setting x in [lo, hi] (a radius r or a threshold J) whose D (``d_at(x)``) is
    within ``D_TOL`` of ``target``: bisection (geometric with ``log``) on a bracket with
    D(lo) <= target <= D(hi), D being nondecreasing in x up to noise; ``hi`` is doubled up
    to ``hi_max`` while D(hi) < target. ``known``: (x, D) pairs already measured (grid
    points), which narrow the first bracket. Deterministic. Returns (x, D, steps, ok): the
    closest of the settings tried; ``ok`` False when none came within ``D_TOL`` (D jumps
    there, or the target is out of reach)."""
    tried = list(known)

    def at(x):
        d = d_at(x)
        tried.append((x, d))
        return d

    steps = 0
    below = [(x, d) for x, d in tried if d <= target and lo <= x <= hi]
    above = [(x, d) for x, d in tried if d >= target and lo <= x <= hi]
    if below:
        lo = max(below)[0]
    if above:
        hi = min(above)[0]
    else:
        while True:
            steps += 1
            if at(hi) >= target or hi_max is None or hi >= hi_max:
                break
            lo, hi = hi, min(2 * hi, hi_max)
    while steps < MATCH_STEPS:
        best = min(tried, key=lambda t: abs(t[1] - target))
        if abs(best[1] - target) <= D_TOL:
            break
        x = np.sqrt(lo * hi) if log else 0.5 * (lo + hi)
        steps += 1
        if at(x) < target:
            lo = x
        else:
            hi = x
    x, d = min(tried, key=lambda t: abs(t[1] - target))
    return x, d, steps, abs(d - target) <= D_TOL


def match_baseline(an1, seeds, target, grid):
    """The baseline (spatial jitter, L = 1) at D = target: the jittered levels of the grid
    point whose D is nearest, then its radius r bisected between 0.5 / h (h = 2^(levels − 1),
    the coarsest jittered level's spacing: no pointer moves, D = 0) and the grid's largest r
    (doubled up to 4 while D is short); if that many jittered levels cannot reach the
    target, the next count."""
    bl0 = min(grid, key=lambda g: abs(g[2] - target))[0]
    for bl in [bl0] + [b for b in BASE_LEVELS if b > bl0]:
        known = [(r, d) for b, r, d in grid if b == bl]
        lo = 0.5 / 2 ** (bl - 1)
        r, d, steps, ok = match_d(target, lambda r: d_of(an1, seeds, J=0.0, jitter="spatial", r=float(r),
                                                         jitter_levels=bl),
                                  lo, max(BASE_R), hi_max=4.0, known=known + [(lo, 0.0)])
        if d >= target - D_TOL or bl == BASE_LEVELS[-1]:
            return bl, float(r), d, steps, ok
    raise AssertionError("unreachable")


def compare(name, atlas, seeds, out):
    from proxyshade.synthesis.hybrid import analyse

    rgb = atlas_rgb(atlas)
    an8 = analyse(rgb, SIZE, levels=LEVELS, L=L, q=Q, iterations=ITERATIONS, seed=0)
    an1 = analyse(rgb, SIZE, levels=LEVELS, L=1, q=Q, iterations=ITERATIONS, seed=0)
    meas = Measures(atlas)
    print(f"\n## {name}: structure-preserving jitter (L = {L}) vs baseline (spatial jitter, L = 1), seeds {seeds[0]}-{seeds[-1]}")
    print(f"baseline matched to each SP point's D within {D_TOL}: jittered levels from the grid, radius r bisected")
    print(f"{'config':<40} {'D':>6} {'C full':>8} {'C half':>8} {'label err':>10}")
    wins = []
    # the baseline's D over its grid (synthesis only): each SP point takes the jittered levels of the nearest
    grid = [(bl, r, d_of(an1, seeds, J=0.0, jitter="spatial", r=r, jitter_levels=bl))
            for bl in BASE_LEVELS for r in BASE_R]
    for jl, J in SP_POINTS:
        sp = run_config(an8, meas, seeds, J=J, jitter_levels=jl)
        bl, r, d, steps, ok = match_baseline(an1, seeds, sp[0], grid)
        b = run_config(an1, meas, seeds, J=0.0, jitter="spatial", r=r, jitter_levels=bl)
        print(f"{f'SP  J={J} levels<{jl}':<40} {sp[0]:6.3f} {sp[1]:8.2f} {sp[2]:8.2f} {sp[3]:10.3f}")
        print(f"{f'base r={r:.5g} levels<{bl}':<40} {b[0]:6.3f} {b[1]:8.2f} {b[2]:8.2f} {b[3]:10.3f}"
              f"   dD {b[0] - sp[0]:+.4f} ({steps} D evaluations{'' if ok else ', NOT within tolerance'})")
        wins.append((sp, b))
        out.append((name, jl, J, (bl, r), sp, b))
    check_c_search(meas, states_of(an8, seeds[:1], J=SP_POINTS[-1][1], jitter_levels=SP_POINTS[-1][0])[0])
    lower_c = sum(sp[1] < b[1] for sp, b in wins)
    lower_l = sum(sp[3] < b[3] for sp, b in wins)
    lower_h = sum(sp[2] < b[2] for sp, b in wins)
    print(f"SP lower C at {lower_c}/3 matched D (½ size: {lower_h}/3), lower label error at {lower_l}/3 "
          f"(ties at 0 count as not lower)")
    return an8, an1, meas


J_MIN = 1e-7  # the L = 1 threshold search's lower end (J = 0: every seed gives one result, D = 0)


def l8_vs_l1(an8, an1, meas, seeds):
    """L = 8 against L = 1 at matched D: at each SP point (L = 8, J, jittered levels), L = 1
    with the same jittered levels and its J bisected (geometrically, J_MIN .. 1) to L = 8's
    D; if J alone cannot reach it (D out of reach within the tolerance), one jittered level
    fewer, then one more. The same-J row is printed too (L = 1's D is higher there)."""
    print("\n## brick: L = 8 vs L = 1, structure-preserving jitter, L = 1's J matched to L = 8's D")
    print(f"{'config':<40} {'D':>6} {'C full':>8} {'C half':>8}")
    better = better_half = 0
    for jl, J in SP_POINTS:
        a = run_config(an8, meas, seeds, J=J, jitter_levels=jl)
        same = run_config(an1, meas, seeds, J=J, jitter_levels=jl)
        tries = []
        for lv in (jl, jl - 1, jl + 1):
            tries.append((lv, *match_d(a[0], lambda x: d_of(an1, seeds, J=float(x), jitter_levels=lv), J_MIN, 1.0,
                                       log=True, known=[(J, same[0])] if lv == jl else [])))
            if tries[-1][-1]:
                break
        lv, j1, d, steps, ok = min(tries, key=lambda t: (not t[-1], abs(t[2] - a[0])))
        steps = sum(t[3] for t in tries)
        b = run_config(an1, meas, seeds, J=j1, jitter_levels=lv)
        print(f"{f'L=8 J={J} levels<{jl}':<40} {a[0]:6.3f} {a[1]:8.2f} {a[2]:8.2f}")
        print(f"{f'L=1 J={j1:.3g} levels<{lv} (matched D)':<40} {b[0]:6.3f} {b[1]:8.2f} {b[2]:8.2f}"
              f"   dD {b[0] - a[0]:+.4f} ({steps} D evaluations{'' if ok else ', NOT within tolerance'})")
        print(f"{f'L=1 J={J} levels<{jl} (same J)':<40} {same[0]:6.3f} {same[1]:8.2f} {same[2]:8.2f}")
        better += a[1] < b[1]
        better_half += a[2] < b[2]
    print(f"L = 8 lower C than L = 1 at matched D: {better}/3 (full), {better_half}/3 (½ size)")


def speed(atlas):
    from proxyshade.synthesis.hybrid import analyse, synthesize

    rgb = atlas_rgb(atlas)
    an8 = analyse(rgb, SIZE, levels=LEVELS, L=L, q=Q, iterations=ITERATIONS, seed=0)
    an1 = analyse(rgb, SIZE, levels=LEVELS, L=1, q=Q, iterations=ITERATIONS, seed=0)
    w = np.ones(2)
    # interleaved, so the ratios hold on a shared machine
    a8, a1, af = measure_interleaved([
        lambda: analyse(rgb, SIZE, levels=LEVELS, L=L, q=Q, iterations=ITERATIONS, seed=0),
        lambda: analyse(rgb, SIZE, levels=LEVELS, L=1, q=Q, iterations=ITERATIONS, seed=0),
        lambda: analyse(rgb, SIZE, levels=LEVELS, L=L, q=Q, iterations=ITERATIONS, seed=0, **PREVIOUS)], repeat=3)
    seeds = iter(range(1000))
    h_sp, h_base = measure_interleaved([
        lambda: synthesize(an8, (SIZE, SIZE), J=J_DEFAULT, seed=next(seeds), weights=w, passes=PASSES),
        lambda: synthesize(an1, (SIZE, SIZE), J=0.0, seed=next(seeds), weights=w, passes=PASSES, jitter="spatial",
                           r=1.0)], repeat=15)
    table("hybrids: speed (renoir + creek, 2 exemplars at 256²)", [
        ("analysis, 2 exemplars 256², L=8", a8, 10.0),
        ("analysis, baseline L=1", a1, None),
        ("analysis, L=8 box stack, coarser (before)", af, None),
        (f"one 256² hybrid, SP jitter J={J_DEFAULT}", h_sp, 1.0),
        ("one 256² hybrid, baseline spatial r=1", h_base, None),
    ])
    print(f"overhead over the baseline: hybrid {h_sp['median'] / h_base['median']:.2f}x, analysis "
          f"{a8['median'] / a1['median']:.2f}x, analysis + 8 hybrids "
          f"{(a8['median'] + 8 * h_sp['median']) / (a1['median'] + 8 * h_base['median']):.2f}x (target <= 1.5x)")
    print(f"load: {os.getloadavg()[0]:.2f} (1-min average, 2 cores shared)")


def save_jpeg(rows, path: Path):
    """Rows of linear tiles stacked, sRGB-encoded, written as a small JPEG (a docs image)."""
    from proxyshade.kernels.features import srgb_features
    import OpenImageIO as oiio

    img = np.ascontiguousarray(np.clip(srgb_features(np.concatenate(rows, 0)) + 0.5, 0, 255).astype(np.uint8))
    buf = oiio.ImageBuf(oiio.ImageSpec(img.shape[1], img.shape[0], 3, oiio.UINT8))
    buf.set_pixels(oiio.ROI(), img)
    buf.specmod().attribute("Compression", "jpeg:88")  # a docs image: JPEG keeps it small
    if not buf.write(str(path)):
        raise SystemExit(f"{path}: {buf.geterror()}")
    print(f"wrote {path}")


def write_jpeg(tiles, per_row, path: Path):
    rows = [np.concatenate([np.pad(t, ((2, 2), (2, 2), (0, 0)), constant_values=1.0) for t in tiles[k:k + per_row]], 1)
            for k in range(0, len(tiles), per_row)]
    save_jpeg(rows, path)


def before_after(path: Path):
    """Before (the previous round: the box-filtered stack, the candidates' descriptor of
    the coarser levels) and after (the Gaussian stack, the finer levels; both each level
    scaled): renoir + creek hybrids of seeds 1 and 2 at HybridSynth's defaults (J = 0.1),
    brick's of seed 1 at the bench's middle SP point (J = 0.01, the finest 4 levels
    jittered), 256² at 100 %."""
    from proxyshade.synthesis.hybrid import analyse, synthesize

    rows = {False: [], True: []}
    for atlas, seeds, J, jl in ((renoir_creek(), (1, 2), J_DEFAULT, None), (brick(), (1,), 0.01, 4)):
        rgb = atlas_rgb(atlas)
        for after in (False, True):
            an = analyse(rgb, SIZE, levels=LEVELS, L=L, q=Q, iterations=ITERATIONS, seed=0,
                         **({} if after else PREVIOUS))
            for s in seeds:
                S = synthesize(an, (SIZE, SIZE), J=J, seed=s, weights=np.ones(2), passes=PASSES, jitter_levels=jl)
                rows[after].append(rgb[S[..., 0], S[..., 1]])
    write_jpeg(rows[False] + rows[True], 3, path)


def sheet(path: Path):
    """The docs' contact sheet, all at 100%: renoir and creek, then hybrids of seeds 1-8
    (HybridSynth's defaults: J = 0.1, every level jittered); hybrids 1-5 at J = 0.3 (more
    mixing); brick's two crops, 2 hybrids at J = 0.1, then 1 at J = 0.05."""
    from proxyshade.synthesis.hybrid import analyse, synthesize

    rows = []
    # (atlas, [(J, jitter levels, seeds)]): rows of 5 tiles, the two exemplars first
    for atlas, runs in ((renoir_creek(), [(J_DEFAULT, None, range(1, 9)), (0.3, None, range(1, 6))]),
                        (brick(), [(J_DEFAULT, None, range(1, 3)), (0.05, None, range(1, 2))])):
        rgb = atlas_rgb(atlas)
        an = analyse(rgb, SIZE, levels=LEVELS, L=L, q=Q, iterations=ITERATIONS, seed=0)
        tiles = [rgb[:, :SIZE], rgb[:, SIZE:]]
        for J, jl, seeds in runs:
            for s in seeds:
                S = synthesize(an, (SIZE, SIZE), J=J, seed=s, weights=np.ones(2), passes=PASSES, jitter_levels=jl)
                tiles.append(rgb[S[..., 0], S[..., 1]])
        for k in range(0, len(tiles), 5):
            rows.append(np.concatenate([np.pad(t, ((2, 2), (2, 2), (0, 0)), constant_values=1.0)
                                        for t in tiles[k:k + 5]], 1))
    save_jpeg(rows, path)


def main():
    if "--sheet" in sys.argv:
        sheet(ROOT / "docs/img/hybrids_sheet.jpg")
        return
    if "--align" in sys.argv:
        brick_alignment()
        return
    if "--before-after" in sys.argv:
        before_after(ROOT / "docs/img/hybrids_before_after.jpg")
        return
    if "--speed" in sys.argv:
        speed(renoir_creek())
        return
    quick = "--quick" in sys.argv
    seeds = list(range(1, 5 if quick else 9))
    out = []
    if "--brick" not in sys.argv:  # --brick: only the brick comparisons
        rc = renoir_creek()
        speed(rc)
        compare("renoir + creek", rc, seeds, out)
    an8, an1, meas = compare("brick (two 256² crops)", brick(), seeds, out)
    l8_vs_l1(an8, an1, meas, seeds)


if __name__ == "__main__":
    main()
