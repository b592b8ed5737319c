"""Issue 32's listed artefacts, measured and cropped: the issue's configuration against today's.

    python bench/bench_artefacts.py --eval ../shared/data/eval_photos [--ebsynth PATH] [--out DIR]

Each case is ``bench_photos``' (a photo with a layout not its own, 1024 wide, seed 1). Two
configurations of the first frame run on it: ``issue`` (the settings the issue measured: Poisson's
node defaults, the layout and grain steps on, ``screen: 0.01``; Correct without the tone term;
Magnify without the whole-patch shifts) and ``now`` (graphs/first_frame.yaml). Per case the bench
prints, on display luma ``L`` in 8-bit steps (0-255) unless said, for each configuration
and EbSynth (``--ebsynth``, on the same guide):

- ``rim bright`` / ``rim dark``: the share of a label's pixels within 2 px of another label
  brighter (darker) than the photo label's 0.5-99.5 % L range, less the photo's own share there;
  the label with the most (a white halo along a ridge: the sky's; a dark line: the mountain's;
  dark dots along a shore: the water's). A step at the rim against the label's inside is not
  used: the photos' label maps are a few pixels off their edges, so the photo's own rims carry
  the neighbour's tones.
- ``top``: the sky's top 20 rows of the frame against the photo sky's top 20 rows: the largest
  channel difference of their mean sRGB (the top band).
- ``hue``: the largest channel difference of a label's mean sRGB to the photo's, over labels
  (the reflections' hue).
- ``blob``: per label, the std of L box-filtered over 17² (what is left of large soft blobs)
  over the photo's, the label furthest from 1.
- ``grain``: per label, the std of L less its 5² box mean over the photo's, furthest from 1.
- ``neg``: the share of pixels with a negative linear channel (EbSynth: none by construction).

Crops at 100 % (``--out``/artefacts_CASE.png, all of them side by side in artefacts_sheet.png):
for each measure, the 128² window where the issue configuration is furthest from the photo, then
the same window of ``now`` and EbSynth; artefacts_worst.png holds one row per measure, from the
case where the issue configuration was furthest (the next case where another row shows much
of that window). The photos stay where they are: nothing is copied.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

import bench_photos as BP  # noqa: E402
from proxyshade.io.images import write_png  # noqa: E402
from proxyshade.io.source import load_source  # noqa: E402
from proxyshade.kernels import quality as Q  # noqa: E402
from proxyshade.kernels.distance import squared_distance
from proxyshade.synthesis.btf import box_sum  # noqa: E402

ISSUE = {"final": {"layout": True, "grain": 2.0, "layout_spread": 2.0, "screen": 0.01},
         "correct": {"tone_balance": 0.0}, "magnify": {"patch_shift": 0, "patch_adopt": 0}}
CROP = 128
MEASURES = ("rim bright", "rim dark", "top", "hue", "blob", "grain", "neg")


def box(img: np.ndarray, r: int) -> np.ndarray:
    """Mean over a (2r+1)² box, edge pixels repeated (``synthesis.btf.box_sum``)."""
    return box_sum(np.asarray(img, np.float64)[None], r)[0] / (2 * r + 1) ** 2


def distance(measure: str, value: float) -> float:
    """How far a figure is from the photo's: |log| of a ratio (blob, grain), else |value|."""
    if measure in ("blob", "grain"):
        return abs(np.log(value)) if value > 0 else np.inf
    return abs(value)


def bands(ids: np.ndarray, label: int) -> np.ndarray:
    """A label's pixels within 2 px of another label."""
    m = ids == label
    return m & (squared_distance(~m) <= 4)


def figures(srgb: np.ndarray, lin: np.ndarray | None, ids: np.ndarray, photo: np.ndarray, pids: np.ndarray,
            names: dict[int, str]) -> tuple[dict, dict]:
    """({measure: (value, label)}, {measure: per-pixel map whose 128² window sum marks the worst place})."""
    L, PL = Q.luma(srgb) * 255, Q.luma(photo) * 255
    best = {k: (0.0, "") for k in MEASURES}
    maps_by = {}
    lowp, plowp = box(L, 8), box(PL, 8)
    hp, php = L - box(L, 2), PL - box(PL, 2)
    for k in np.unique(ids):
        m, pm = ids == k, pids == k
        if m.sum() < 400 or pm.sum() < 400:
            continue
        name = names.get(int(k), str(k))
        rim, prim = bands(ids, int(k)), bands(pids, int(k))
        if prim.sum() > 50 and rim.sum() > 50:
            lo, hi = Q.label_range(PL / 255, pm)
            for m_, side in (("rim bright", L / 255 > hi + BP.TIE), ("rim dark", L / 255 < lo - BP.TIE)):
                pside = PL / 255 > hi + BP.TIE if m_ == "rim bright" else PL / 255 < lo - BP.TIE
                share = side[rim].mean() - pside[prim].mean()
                if share > best[m_][0] or not best[m_][1]:
                    best[m_] = (share, name)
                    maps_by[m_] = (side & rim).astype(np.float64)
        shift = (srgb[m].mean(0) - photo[pm].mean(0)) * 255
        j = int(np.argmax(np.abs(shift)))
        if abs(shift[j]) > abs(best["hue"][0]):
            best["hue"] = (float(shift[j]), name)
            maps_by["hue"] = np.where(m, np.abs(srgb[..., j] * 255 - photo[pm][:, j].mean()), 0.0)
        for key, ratio, where in (("blob", lowp[m].std() / max(plowp[pm].std(), 1e-9), np.abs(lowp - plowp[pm].mean())),
                                  ("grain", hp[m].std() / max(php[pm].std(), 1e-9), np.abs(hp))):
            if not best[key][1] or distance(key, ratio) > distance(key, best[key][0]):
                best[key] = (ratio, name)
                maps_by[key] = np.where(m, where, 0.0)
        if name == "sky":
            top, ptop = m & (np.arange(m.shape[0])[:, None] < 20), pm & (np.arange(pm.shape[0])[:, None] < 20)
            if top.sum() > 50 and ptop.sum() > 50:
                d = (srgb[top].mean(0) - photo[ptop].mean(0)) * 255
                best["top"] = (float(d[np.argmax(np.abs(d))]), name)
                band = np.zeros(m.shape)
                band[top] = np.abs(srgb[top] * 255 - photo[ptop].mean(0) * 255).max(-1)
                maps_by["top"] = band
    neg = (lin < 0).any(-1) if lin is not None else np.zeros(ids.shape, bool)
    best["neg"] = (float(neg.mean()), "")
    maps_by["neg"] = neg.astype(np.float64)
    return best, maps_by


def worst_window(a: np.ndarray) -> tuple[int, int]:
    """Top-left of the CROP² window with the largest sum of ``a``."""
    h, w = a.shape
    ii = np.pad(a, ((1, 0), (1, 0))).cumsum(0).cumsum(1)
    c = min(CROP, h, w)
    s = ii[c:, c:] - ii[:-c, c:] - ii[c:, :-c] + ii[:-c, :-c]
    y, x = np.unravel_index(int(np.argmax(s)), s.shape)
    return int(y), int(x)


def fmt(measure: str, v: tuple[float, str]) -> str:
    val, lab = v
    if measure in ("rim bright", "rim dark", "neg"):
        s = f"{val:.2%}" if measure == "neg" else f"{val:+.2%}"
    elif measure in ("blob", "grain"):
        s = f"{val:.2f}"
    else:
        s = f"{val:+.1f}"
    return f"{s} {lab[:13]}".strip()


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--eval", type=Path, required=True, help="folder of annotated photos (bench_photos' --eval)")
    ap.add_argument("--ebsynth", type=Path, help="EbSynth's binary: its output on the same guide beside")
    ap.add_argument("--cases", nargs="*", help="only these case names")
    ap.add_argument("--no-bundled", action="store_true", help="only the --eval photos")
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "bench_artefacts")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    rows, tiles, worst = [], [], {}
    with tempfile.TemporaryDirectory() as work:
        cases = BP.eval_cases(args.eval, Path(work)) + ([] if args.no_bundled else BP.bundled_cases())
        cases = [c for c in cases if not args.cases or c["name"] in args.cases]
        print(f"{'case':<13} {'config':<9}" + "".join(f"{m:>18}" for m in MEASURES))
        for case in cases:
            src = load_source(case["table"], max_far_fraction=0.05)
            photo, pids = BP.srgb(src.rgb()), src["label.id"]
            names = {int(t["id"]): t["name"] for t in src.meta["labels"]}
            ids = BP.case_guide(case, src)
            runs = BP.proxyshade(src, ids, {"issue": ISSUE, "now": {}})
            outs = {k: (BP.srgb(p.rgb()), p.rgb()) for k, (p, _) in runs.items()}
            if args.ebsynth:
                outs["EbSynth"] = (BP.ebsynth(args.ebsynth, src, ids, args.out)[0], None)
            figs = {k: figures(s, lin, ids, photo, pids, names) for k, (s, lin) in outs.items()}
            for k, (f, _) in figs.items():
                print(f"{case['name']:<13} {k:<9}" + "".join(f"{fmt(m, f[m]):>18}" for m in MEASURES), flush=True)
            rows.append((case["name"], {k: f for k, (f, _) in figs.items()}))
            crops = []
            for m in MEASURES:
                a = figs["issue"][1].get(m)
                if a is None or not a.any():
                    continue
                y, x = worst_window(a)
                crops.append(np.concatenate([np.pad(s[y:y + CROP, x:x + CROP], ((0, 2), (0, 2), (0, 0)), constant_values=1)
                                             for s, _ in outs.values()], 1))
                worst.setdefault(m, []).append((distance(m, figs["issue"][0][m][0]), crops[-1], case["name"], (y, x)))
            if crops:
                img = np.concatenate(crops, 0)
                write_png(args.out / f"artefacts_{case['name']}.png", (np.clip(img, 0, 1) * 255 + 0.5).astype(np.uint8))
                tiles.append(img)
    if tiles:
        h = max(t.shape[0] for t in tiles)
        sheet = np.concatenate([np.pad(t, ((0, h - t.shape[0]), (0, 6), (0, 0)), constant_values=1) for t in tiles], 1)
        write_png(args.out / "artefacts_sheet.png", (np.clip(sheet, 0, 1) * 255 + 0.5).astype(np.uint8))
        picked, shown = {}, set()  # per measure the furthest case whose window no other row shows
        for m, cands in worst.items():
            for v, t, c, at in sorted(cands, key=lambda e: -e[0]):
                if not any(c == c2 and abs(at[0] - a2[0]) < CROP // 2 and abs(at[1] - a2[1]) < CROP // 2
                           for c2, a2 in shown):
                    picked[m] = (t, c)
                    shown.add((c, at))
                    break
        w = max(t.shape[1] for t, _ in picked.values())
        img = np.concatenate([np.pad(t, ((0, 0), (0, w - t.shape[1]), (0, 0)), constant_values=1)
                              for t, _ in picked.values()], 0)
        write_png(args.out / "artefacts_worst.png", (np.clip(img, 0, 1) * 255 + 0.5).astype(np.uint8))
        print("artefacts_worst.png, one row per measure where the issue configuration is furthest from the photo: "
              + ", ".join(f"{m} ({c})" for m, (_, c) in picked.items()))
    print("\nmedian of |value| (rims, neg as shares; top, hue in 8-bit steps; blob, grain as |log| distance from 1):")
    for k in ("issue", "now", "EbSynth"):
        got = [r[k] for _, r in rows if k in r]
        if not got:
            continue
        med = []
        for m in MEASURES:
            med.append(f"{np.median([distance(m, f[m][0]) for f in got]):.4f}")
        print(f"{k:<9}" + "".join(f"{s:>18}" for s in med))
    print(f"crops: {args.out}/artefacts_*.png (rows: {', '.join(MEASURES)} where present; columns: "
          f"issue, now{', EbSynth' if args.ebsynth else ''})")


if __name__ == "__main__":
    main()
