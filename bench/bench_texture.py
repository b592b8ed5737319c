"""Plain texture synthesis against EbSynth (issue #34): a 256² texture from a small exemplar.

Exemplars (sRGB 8-bit, the same bytes for every method): scikit-image's brick, grass and
gravel (samples/textures, CC0: the central 256² box-filtered to 128²) and two 160² crops
of the bundled photos at 100 % (creek's grassy bank, rows 440-599, columns 620-779;
Renoir's trees, rows 60-219, columns 350-509). Methods: each core of ``TextureSynth``
(``method``: annotated, hybrid; ``--methods``), and with ``--ebsynth PATH`` EbSynth with constant guides on both sides
(plain synthesis: ``-style ex.png -guide grey_ex.png grey_out.png``, its defaults).

Measures (sRGB in [0, 1], ``kernels.quality``), output against the exemplar:
  hist     χ² of 8×8×8 colour histograms
  window   mean χ² of each 11×11 window's 16-bin luma histogram to the nearest exemplar
           window (output windows every 4 pixels, exemplar windows every pixel)
  orient   χ² of the 18-bin magnitude-weighted gradient-orientation histograms of the
           luma (streaks pile the weight into one bin)
  grad     mean absolute 4-neighbour difference, output over exemplar (blur < 1)
and the median wall and CPU time of each method (interleaved, ``--repeat`` runs after a
warm-up; CPU: all threads, EbSynth's process included, steadier than wall time on shared
cores).
Bars (issue #34): hist and window within 1.5× EbSynth's, orient within 2×, grad >= 0.7,
time (wall and CPU) <= 1/5 of EbSynth's.

Run: ``python bench/bench_texture.py --ebsynth /tmp/ebsynth`` (``--out DIR`` keeps the
outputs and a contact sheet per exemplar: exemplar | each method).
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from proxyshade.io.images import read_u8, write_png  # noqa: E402
from proxyshade.kernels import quality as Q  # noqa: E402

SIZE = 256
TEXTURES = ("brick", "grass", "gravel")
PHOTO_CROPS = {"creek_bank": ("samples/creek/creek.jpg", 440, 620, 160),
               "renoir_trees": ("samples/renoir/style.png", 60, 350, 160)}
BARS = {"hist": 1.5, "window": 1.5, "orient": 2.0, "grad": 0.7, "time": 0.2, "cpu": 0.2}


def exemplars() -> dict[str, np.ndarray]:
    """Name -> (H, W, 3) uint8 sRGB exemplar."""
    out = {}
    for name in TEXTURES:
        a = read_u8(ROOT / "samples/textures" / f"{name}.png").astype(np.float64)
        if a.ndim == 2:
            a = a[..., None]
        a = np.repeat(a[..., :1], 3, axis=2) if a.shape[2] < 3 else a[..., :3]
        h, w = a.shape[:2]
        a = a[h // 2 - 128:h // 2 + 128, w // 2 - 128:w // 2 + 128]
        out[name] = np.round(a.reshape(128, 2, 128, 2, 3).mean(axis=(1, 3))).astype(np.uint8)
    for name, (path, r, c, n) in PHOTO_CROPS.items():
        out[name] = np.ascontiguousarray(read_u8(ROOT / path)[r:r + n, c:c + n, :3])
    return out


def ours(ex8: np.ndarray, method: str = "annotated", seed: int = 0) -> np.ndarray:
    """``TextureSynth``'s core on the exemplar: sRGB in [0, 1], (SIZE, SIZE, 3)."""
    from proxyshade.io.source import srgb_to_linear
    from proxyshade.synthesis.annotated import AnnotatedParams, plain_texture

    if method == "hybrid":
        from proxyshade.synthesis.hybrid import plain_texture as hybrid_texture

        return encode(hybrid_texture(srgb_to_linear(ex8), (SIZE, SIZE), seed=seed)["rgb"])
    assert method == "annotated", method
    r = plain_texture(srgb_to_linear(ex8), (SIZE, SIZE), AnnotatedParams(seed=seed))
    return encode(r["rgb"])


def encode(lin: np.ndarray) -> np.ndarray:
    """Linear -> sRGB in [0, 1] (clipped), rounded to 8 bits like EbSynth's PNG."""
    from proxyshade.io.colourlib import colour_science

    s = colour_science().cctf_encoding(np.clip(np.asarray(lin, np.float64), 0, 1), function="sRGB")
    return np.round(s * 255) / 255


def ebsynth(exe: Path, ex8: np.ndarray) -> np.ndarray:
    """EbSynth's plain synthesis (constant guides): sRGB in [0, 1], (SIZE, SIZE, 3)."""
    with tempfile.TemporaryDirectory() as tmp:
        t = Path(tmp)
        write_png(t / "ex.png", ex8)
        write_png(t / "a.png", np.full(ex8.shape, 128, np.uint8))
        write_png(t / "b.png", np.full((SIZE, SIZE, 3), 128, np.uint8))
        subprocess.run([str(exe), "-style", str(t / "ex.png"), "-guide", str(t / "a.png"), str(t / "b.png"),
                        "-output", str(t / "out.png")], check=True, stdout=subprocess.DEVNULL,
                       stderr=subprocess.DEVNULL)
        return read_u8(t / "out.png")[..., :3].astype(np.float64) / 255.0


def measures(out: np.ndarray, ex: np.ndarray) -> dict:
    """The four measures of an output (sRGB in [0, 1]) against the exemplar."""
    ones_o, ones_e = np.ones(out.shape[:2], bool), np.ones(ex.shape[:2], bool)
    lo, le = Q.luma(out), Q.luma(ex)
    return {"hist": Q.chi2(Q.colour_histogram(out.reshape(-1, 3)), Q.colour_histogram(ex.reshape(-1, 3))),
            "window": Q.nearest_window_chi2(Q.window_histograms(lo, ones_o, stride=4),
                                            Q.window_histograms(le, ones_e, stride=1)),
            "orient": Q.chi2(Q.orientation_histogram(lo), Q.orientation_histogram(le)),
            "grad": Q.pair_gradient(out, ones_o) / Q.pair_gradient(ex, ones_e)}


def _median_time(fn, repeat: int) -> tuple[np.ndarray, float, float]:
    """The output, the median wall time and the median CPU time (this process's threads
    and its children's: EbSynth's) of ``repeat`` runs after a warm-up."""
    out = fn()  # warm-up (kernel compile, file cache)
    ts, cs = [], []
    for _ in range(repeat):
        c0, t0 = os.times(), time.perf_counter()
        fn()
        c1 = os.times()
        ts.append(time.perf_counter() - t0)
        cs.append(c1.user + c1.system + c1.children_user + c1.children_system
                  - c0.user - c0.system - c0.children_user - c0.children_system)
    return out, float(np.median(ts)), float(np.median(cs))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--ebsynth", type=Path, help="EbSynth's binary (built from ../shared/peers/ebsynth)")
    ap.add_argument("--repeat", type=int, default=3, help="timed runs per method and exemplar (median)")
    ap.add_argument("--only", help="comma-separated exemplar names")
    ap.add_argument("--out", type=Path, help="folder for the outputs and contact sheets")
    ap.add_argument("--methods", default="annotated,hybrid", help="comma-separated cores of TextureSynth")
    args = ap.parse_args(argv if argv is not None else [a for a in sys.argv[1:] if a != "texture"])
    exs = exemplars()
    if args.only:
        exs = {k: v for k, v in exs.items() if k in args.only.split(",")}
    if not args.ebsynth:
        print("no --ebsynth: proxyshade alone, no ratios")
    keys = ("hist", "window", "orient", "grad", "time", "cpu")
    met_all = True
    print(f"{'exemplar':<11} {'method':<10} " + " ".join(f"{k:>8}" for k in keys))
    for name, ex8 in exs.items():
        ex = ex8.astype(np.float64) / 255.0
        rows, outs = {}, {}
        for meth in args.methods.split(","):
            o, t, c = _median_time(lambda: ours(ex8, meth), args.repeat)
            rows[meth] = dict(measures(o, ex), time=t, cpu=c)
            outs[meth] = o
        if args.ebsynth:
            b, t, c = _median_time(lambda: ebsynth(args.ebsynth, ex8), args.repeat)
            rows["EbSynth"] = dict(measures(b, ex), time=t, cpu=c)
            outs["EbSynth"] = b
        for meth, r in rows.items():
            print(f"{name:<11} {meth:<10} " + " ".join(f"{r[k]:8.4f}" if k not in ("time", "cpu") else f"{r[k]:7.2f}s"
                                                       for k in keys))
        for meth in (args.methods.split(",") if args.ebsynth else []):
            a, e = rows[meth], rows["EbSynth"]
            ratio = {k: a[k] / e[k] if e[k] > 0 else float("inf") for k in keys}
            met = {k: ratio[k] <= BARS[k] for k in ("hist", "window", "orient", "time", "cpu")}
            met["grad"] = a["grad"] >= BARS["grad"]
            met_all &= all(v for k, v in met.items() if k not in ("time", "cpu"))
            print(f"{name:<11} {meth[:4] + '/Eb':<10} " + " ".join(f"{ratio[k]:7.2f}{'' if met[k] else '!'}"
                                                                  for k in keys))
        if args.out:
            args.out.mkdir(parents=True, exist_ok=True)
            sheet = np.zeros((SIZE, SIZE * (1 + len(outs)), 3), np.uint8)
            sheet[:ex8.shape[0], :ex8.shape[1]] = ex8
            for k, img in enumerate(outs.values()):
                sheet[:, SIZE * (k + 1):SIZE * (k + 2)] = np.round(img * 255).astype(np.uint8)
            write_png(args.out / f"texture_{name}.png", sheet)
    if args.ebsynth:
        print("bars (hist, window ≤ 1.5×, orient ≤ 2×, grad ≥ 0.7; '!' = not met; time, cpu ≤ 0.2× apart): "
              + ("all met" if met_all else "not all met"))


if __name__ == "__main__":
    main()
