"""Structured image hybrids (E. Risser, C. Han, R. Dahyot, E. Grinspun, SIGGRAPH 2010):
do they read as one new texture, or as a collage of exemplar pieces? Per hybrid (seeds 1-4,
medians; HybridSynth's defaults unless the row says otherwise):

* ``region``: the area-weighted mean size of the connected single-exemplar regions (4-connected
  pixels whose pointers lie in one exemplar) as a share of the output, Σ aᵢ² / N². A collage has
  a few huge regions (near 1 / number of pieces); a mix of one class, many small ones. With one
  exemplar it is 1 by definition, so the rows with a ramp read it on the mixed middle third;
* ``border``: the mean |Δ luma| (sRGB) of 4-adjacent pixel pairs across a border between
  exemplars over that of pairs inside one exemplar. Hard seams raise it above 1;
* ``window``: the mean χ² of each 11×11 window's 16-bin luma histogram (every 4 px) to the
  nearest window of any exemplar (each exemplar's own windows, every pixel;
  ``kernels.quality``): plausibility, as bench_texture measures it;
* ``s``: the wall time of one hybrid (analysis excluded; printed with the analysis time).

Rows: ``renoir + creek`` is the graph main shipped before the sets (two 256² sources of four
labels, J = 0.1, no coherence factor): the collage the issue reports. Then the bundled sets
(samples/hybrids, three 128² exemplars each): free, ramp 1 → 3, brick per level.

Run: ``.venv/bin/python bench/run.py hybrids`` (or ``bench/bench_hybrids.py``; ``--sheet
[--before MAIN_SHEET.jpg]`` writes docs/img/hybrids_sheet.jpg and docs/img/hybrids_before_after.jpg).
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from proxyshade.kernels import quality as Q  # noqa: E402
from proxyshade.synthesis import hybrid as H  # noqa: E402
from harness import write_jpeg  # noqa: E402

SEEDS = (1, 2, 3, 4)
SETS = ("foliage", "gravel", "brick")
DEFAULTS = dict(jitter_threshold=0.1, passes=2, coherence=0.3)  # HybridSynth's
BEFORE = dict(jitter_threshold=0.1, passes=2, coherence=1.0)  # main's HybridSynth (no coherence factor)


def renoir_creek():
    from proxyshade.io.source import load_source

    plates = [(n, load_source(ROOT / f"samples/{n}/source.yaml")) for n in ("renoir", "creek")]
    return H.pack_atlas(plates, (256, 256)), 256, 6


def bundled(name):
    from proxyshade.io.source import load_source

    src = load_source(ROOT / f"samples/hybrids/{name}/source.yaml")
    return H.pack_atlas(H.split_plate(name, src, 3), (128, 128)), 128, 5


def atlas_rgb(atlas):
    return np.stack([atlas["R"], atlas["G"], atlas["B"]], -1).astype(np.float32)


def srgb(lin):
    from proxyshade.io.colourlib import colour_science

    return colour_science().cctf_encoding(np.clip(np.asarray(lin, np.float64), 0, 1), function="sRGB")


def region_share(ex: np.ndarray) -> float:
    """Σ aᵢ² / N² over the 4-connected regions of equal ``ex`` (area-weighted mean region
    size as a share of the image)."""
    from scipy import ndimage

    total = 0.0
    for e in np.unique(ex):
        lab, n = ndimage.label(ex == e)
        a = np.bincount(lab.ravel())[1:].astype(np.float64)
        total += (a * a).sum()
    return total / float(ex.size) ** 2


def border_ratio(lum: np.ndarray, ex: np.ndarray) -> float:
    """Mean |Δ luma| of 4-adjacent pairs across exemplar borders over inside ones (nan
    without borders)."""
    d = [np.abs(np.diff(lum, axis=a)) for a in (0, 1)]
    b = [np.diff(ex, axis=a) != 0 for a in (0, 1)]
    across = np.concatenate([x[m] for x, m in zip(d, b)])
    inside = np.concatenate([x[~m] for x, m in zip(d, b)])
    return float(across.mean() / inside.mean()) if len(across) and len(inside) else float("nan")


def ramp_shares(ex: np.ndarray, wmap: np.ndarray, bins: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Along a ramp (left to right): per column bin, each exemplar's share of the pixels and
    its share of the weight map (normalised per pixel), (bins, nb) each."""
    nb = wmap.shape[2]
    w = wmap / np.maximum(wmap.sum(-1, keepdims=True), 1e-300)
    edges = np.linspace(0, ex.shape[1], bins + 1).astype(int)
    share = np.array([np.bincount(ex[:, a:b].ravel(), minlength=nb)[:nb] / ex[:, a:b].size
                      for a, b in zip(edges[:-1], edges[1:])])
    want = np.array([w[:, a:b].mean((0, 1)) for a, b in zip(edges[:-1], edges[1:])])
    return share, want


def ramp_error(ex: np.ndarray, wmap: np.ndarray) -> float:
    """Mean over column bins of the total-variation distance ½ Σₑ |shareₑ − weightₑ| between
    the exemplars' shares of the pixels and their weights: 0 when the mix follows the ramp,
    0.25 for a switch from one exemplar to the other in the middle of a linear ramp."""
    share, want = ramp_shares(ex, wmap)
    return float(0.5 * np.abs(share - want).sum(1).mean())


def exemplar_windows(rgb: np.ndarray, bw: int) -> np.ndarray:
    lum = Q.luma(srgb(rgb))
    return np.concatenate([Q.window_histograms(lum[:, x:x + bw], np.ones((lum.shape[0], bw), bool), stride=1)
                           for x in range(0, lum.shape[1], bw)])


def measures(rgb, bw, S, ex_win, wmap=None) -> dict:
    out = srgb(rgb[S[..., 0], S[..., 1]])
    ex = S[..., 1] // bw
    lum = Q.luma(out)
    part = ex[:, ex.shape[1] // 3:2 * ex.shape[1] // 3] if wmap is not None else ex
    return {"region": region_share(part), "border": border_ratio(lum, ex),
            "window": Q.nearest_window_chi2(Q.window_histograms(lum, np.ones(lum.shape, bool), stride=4), ex_win),
            "ramp": ramp_error(ex, wmap) if wmap is not None else float("nan"),
            **({f"at{k}": v for k, v in enumerate(ramp_shares(ex, wmap, bins=5)[0][:, -1])}
               if wmap is not None else {})}


def configs():
    """(row name, atlas loader, output (h, w), synthesize() keywords)."""
    rows = [("renoir + creek (before)", renoir_creek, (256, 256), dict(BEFORE))]
    for s in SETS:
        rows.append((f"{s}", lambda s=s: bundled(s), (256, 256), dict(DEFAULTS)))
        rows.append((f"{s} ramp 1->3 (before)", lambda s=s: bundled(s), (128, 512),
                     dict(DEFAULTS, ramp=[0, 2], ramp_cell=0)))
        rows.append((f"{s} ramp 1->3", lambda s=s: bundled(s), (128, 512), dict(DEFAULTS, ramp=[0, 2], ramp_cell=8)))
    rows.append(("brick per level 1|3", lambda: bundled("brick"), (256, 256),
                 dict(DEFAULTS, level_weights=[[1, 0, 0], [1, 0, 0], [0, 0, 1]])))
    return rows


def run(name, load, shape, kw, seeds=SEEDS):
    atlas, bw, levels = load()
    rgb = atlas_rgb(atlas)
    t0 = time.perf_counter()
    an = H.analyse(rgb, bw, levels=levels, descriptor_levels=8, q=2, iterations=4, seed=0)
    ta = time.perf_counter() - t0
    kw = dict(kw)
    ramp, cell = kw.pop("ramp", None), kw.pop("ramp_cell", 0)
    wmap = H.ramp_map(shape, ramp, an.nb) if ramp else None  # the weights the shares are measured against
    ex_win = exemplar_windows(rgb, bw)
    ms, ts, states = [], [], []
    for s in seeds:
        t0 = time.perf_counter()
        wm = H.ramp_weights(shape, ramp, an.nb, cell=cell, seed=s) if ramp else None
        S = H.synthesize(an, shape, seed=s, weights=np.ones(an.nb), weight_map=wm, **kw)
        ts.append(time.perf_counter() - t0)
        states.append(S)
        ms.append(measures(rgb, bw, S, ex_win, wmap))
    med = {k: float(np.median([m[k] for m in ms])) for k in ms[0]}  # ramps: at0..at4, the last exemplar's share
    return dict(med, s=float(np.median(ts)), analysis=ta), rgb, states


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    argv = [a for a in argv if a != "hybrids"]
    if "--sheet" in argv:
        k = argv.index("--before") if "--before" in argv else -1
        return sheets(Path(argv[k + 1]) if k >= 0 else None)
    print(f"{'hybrid':<30} {'region':>7} {'border':>7} {'window':>8} {'ramp':>6} {'share of 3 at .1 .3 .5 .7 .9':>29} "
          f"{'s':>6} {'analysis s':>10}")
    for name, load, shape, kw in configs():
        m, _, _ = run(name, load, shape, kw)
        prof = " ".join(f"{m[f'at{k}']:.2f}" for k in range(5)) if "at0" in m else "-"
        print(f"{name:<30} {m['region']:7.3f} {m['border']:7.2f} {m['window']:8.4f} {m['ramp']:6.3f} {prof:>29} "
              f"{m['s']:6.2f} {m['analysis']:10.2f}")
    print("region: Σ area² / N² of single-exemplar regions (ramps: the middle third); border: |Δ luma| across "
          "exemplar borders / inside; window: 11x11 luma-histogram χ² to the nearest exemplar window; ramp: mean "
          "½ Σ |share − weight| over 16 column bins, and the share of the ramp's last exemplar in 5 bins")


def _tile(img, pad=2):
    return np.pad(img, ((pad, pad), (pad, pad), (0, 0)), constant_values=1.0)


def _rows(blocks):
    w = max(b.shape[1] for b in blocks)
    return np.concatenate([np.pad(b, ((0, 0), (0, w - b.shape[1]), (0, 0)), constant_values=1.0) for b in blocks], 0)


def sheets(before_jpg: Path | None):
    """hybrids_sheet.jpg: per set its exemplars, the top halves of two free hybrids (seeds 1,
    2) and the ramp; brick's two per-level hybrids. hybrids_ramp.jpg: per set the ramp 1 -> 3
    (seed 1) with the plain weights (ramp_cell 0, before) over the dithered one (after).
    With ``--before`` (renoir, creek and hybrids 1-3 of the graph main shipped before the
    sets, the top row of that main's docs/img/hybrids_sheet.jpg), hybrids_before_after.jpg:
    that row, then the foliage set's exemplars, two free hybrids and the ramp 1 -> 3."""
    from proxyshade.io.images import read_u8
    from proxyshade.io.source import srgb_to_linear

    out = {}
    for name, load, shape, kw in configs()[1:]:
        _, rgb, states = run(name, load, shape, kw, seeds=(1, 2))
        out[name] = (rgb, [rgb[S[..., 0], S[..., 1]] for S in states])
    f_rgb, f = out["foliage"]
    ramp = out["foliage ramp 1->3"][1][0]
    after = _rows([_tile(f_rgb), np.concatenate([_tile(f[0]), _tile(f[1])], 1), _tile(ramp)])
    if before_jpg is not None:
        top = srgb_to_linear(read_u8(before_jpg)[:260, :, :3])  # main's first row of 260² tiles
        write_jpeg(ROOT / "docs/img/hybrids_before_after.jpg", _rows([top[::2, ::2], after]), quality=85, view="clip")
    write_jpeg(ROOT / "docs/img/hybrids_ramp.jpg",
               _rows([_tile(out[f"{s} ramp 1->3{k}"][1][0]) for s in SETS for k in (" (before)", "")]),
               quality=85, view="clip")
    blocks = []
    for s in SETS:
        rgb, free = out[s]
        blocks.append(np.concatenate([_tile(rgb), _tile(free[0][:128]), _tile(free[1][:128])], 1))
        blocks.append(_tile(out[f"{s} ramp 1->3"][1][0]))
    blocks.append(np.concatenate([_tile(x) for x in out["brick per level 1|3"][1]], 1))
    write_jpeg(ROOT / "docs/img/hybrids_sheet.jpg", _rows(blocks), quality=85, view="clip")


if __name__ == "__main__":
    main()
