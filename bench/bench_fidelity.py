"""Fidelity of the first frame to its photo, label by label (issue: first-frame fidelity).

Cases:
  first frame  the three bundled first frames (graphs/first_frame.yaml: lake/renoir,
               cliffs/monet, farm/creek), the scene's proxy laid out by GuideSynth;
  self         each sample's own label map as the guide, at the photo's size (the
               output could be the photo itself);
  layout       each sample's second label layout (``layout`` in source.yaml) at 1024².
Variants, so every change is judged against plain baselines the bench runs itself:
  final        the output (Poisson);
  pre-Poisson  the same synthesis before the Poisson step (Magnify's colours);
  no grain     first frames only: the Poisson step with ``grain: 1`` (the detail as blended,
               not matched to the photo's; synthesis/grain.py);
  no spread    first frames only: the Poisson step with ``layout_spread: 1`` (each label's
               large-scale variation as synthesized, not raised toward the photo's;
               ``grain.spread``);
  l2           first frames only: the guide synthesized with ``metric: l2``.

Per label (sRGB in [0, 1], ``kernels.quality.label_fidelity``): mean colour shift per
channel (output − photo), std ratio, 8×8×8 colour-histogram χ², 11×11-window 16-bin luma
χ² to the nearest same-label photo window, gradient ratio. Per case: label fidelity,
repetition (share of the output drawn from the most-used 1% of source pixels), the most
copies of one 16² source patch, and for a sky the correlation of its top-to-horizon mean
luma profile with the photo's. Bars (issue #19): |shift| ≤ 0.04, std ratio ≥ 0.8,
gradient ratio ≥ 0.9, label fidelity ≥ 99.5%, sky profile correlation ≥ 0.9.
``std_in`` and ``grad_in``: the std and gradient ratios again on label interiors (pixels
at least ``INTERIOR`` px from another label, in the output and in the photo): a hand-painted
label map puts the neighbours' pixels (tree tips in the sky) along a label's edges, which
raise the photo's figures but are not the material a synthesis should copy inside it.

Run: ``python bench/run.py fidelity`` (``python bench/bench_fidelity.py --cases self``).
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from proxyshade.graph.plate import Plate  # noqa: E402
from proxyshade.graph.testing import run_node  # noqa: E402
from proxyshade.io.colourlib import colour_science  # noqa: E402
from proxyshade.io.source import labels_from_map, load_source  # noqa: E402
from proxyshade.kernels import quality as Q  # noqa: E402
from proxyshade.kernels.lookup import lookup  # noqa: E402

SCENES = [("lake", "renoir"), ("cliffs", "monet"), ("farm", "creek")]
SAMPLES = ["renoir", "monet", "creek"]
INTERIOR = 4  # px from a label edge: the interior figures (std_in, grad_in)
BARS = {"shift": 0.04, "std_ratio": 0.8, "grad_ratio": 0.9, "fidelity": 0.995, "sky_corr": 0.9}


def srgb(plate: Plate) -> np.ndarray:
    lin = np.clip(plate.rgb().astype(np.float64), 0.0, None)
    return np.clip(colour_science().cctf_encoding(lin, function="sRGB"), 0.0, 1.0)


def first_frame(scene: str, source: str, overrides=()) -> tuple[Plate, Plate, float]:
    """(Magnify's plate, Poisson's plate, seconds) of graphs/first_frame.yaml."""
    from proxyshade.graph.graph import Graph

    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as out:
        g = Graph.load(ROOT / "graphs" / "first_frame.yaml", cache=cache,
                       overrides=["preview.enabled=false", "proxy_labels.enabled=false",
                                  "detail_labels.enabled=false", "write.enabled=false", *overrides],
                       variables={"scene": scene, "source": source, "out": out})
        t0 = time.perf_counter()
        g.run([1])
        dt = time.perf_counter() - t0
        return g.value("magnify", 1), g.value("final", 1), dt


def nodes(src: Plate, ids: np.ndarray) -> tuple[Plate, Plate, float]:
    """(Magnify's plate, Poisson's plate, seconds) for a guide ``ids`` at output size."""
    guide = Plate({"label.id": ids.astype(np.uint32)}, {"labels": src.meta["labels"]})
    t0 = time.perf_counter()
    init = run_node("PatchInit", {"seed": 1}, {"guide": guide, "source": src})
    corr = run_node("Correct", {"seed": 1}, {"init": init, "source": src})
    mag = run_node("Magnify", {}, {"synth": corr, "source": src, "guide": guide})
    fin = run_node("Poisson", {}, {"image": mag, "source": src})
    return mag, fin, time.perf_counter() - t0


def resize_ids(ids: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    h, w = shape
    return ids[(np.arange(h) * ids.shape[0] // h)][:, (np.arange(w) * ids.shape[1] // w)]


def interior(ids: np.ndarray, r: int = INTERIOR) -> np.ndarray:
    """``ids`` with 0 wherever a pixel within ``r`` 4-steps has another id (or the border)."""
    keep = np.ones(ids.shape, bool)
    cur = ids
    for _ in range(r):
        p = np.pad(cur, 1, constant_values=0)
        same = (p[:-2, 1:-1] == cur) & (p[2:, 1:-1] == cur) & (p[1:-1, :-2] == cur) & (p[1:-1, 2:] == cur)
        keep &= same
        cur = np.where(keep, ids, 0)
    return np.where(keep, ids, 0).astype(ids.dtype)


def measure(plate: Plate, src: Plate, src_srgb: np.ndarray) -> dict:
    out = srgb(plate)
    lab = plate["label.id"]
    names = {int(t["id"]): t["name"] for t in src.meta["labels"]}
    per = {names.get(int(k), str(k)): Q.label_fidelity(out, lab, src_srgb, src["label.id"], int(k))
           for k in np.unique(lab)}
    lab_in, src_in = interior(lab), interior(src["label.id"])
    for k in np.unique(lab):  # the same figures on label interiors, both images (hand-painted maps put
        m = per[names.get(int(k), str(k))]  # the neighbours' pixels along a label's edges)
        if (lab_in == k).sum() > 100 and (src_in == k).sum() > 100:
            f = Q.label_fidelity(out, lab_in, src_srgb, src_in, int(k))
            m["std_in"], m["grad_in"] = f["std_ratio"], f["grad_ratio"]
        else:
            m["std_in"] = m["grad_in"] = float("nan")
    sx, sy = plate["source.x"], plate["source.y"]
    res = {"labels": per,
           "fidelity": float((lookup(src["label.id"], sx, sy) == lab).mean()),
           "repetition": Q.repetition(sx, sy, src.shape),
           "copies": Q.copies(sx, sy, src.shape)}
    sky = [int(t["id"]) for t in src.meta["labels"] if t["name"] == "sky"]
    if sky:
        po = Q.vertical_profile(Q.luma(out), lab == sky[0])
        ps = Q.vertical_profile(Q.luma(src_srgb), src["label.id"] == sky[0])
        res["sky_corr"] = Q.profile_correlation(po, ps)
        res["sky_profile"] = (po, ps)
    return res


def report(title: str, variants: dict[str, dict]) -> None:
    print(f"\n## {title}")
    print(f"{'label':<11} {'variant':<12} {'share':>6} {'dR':>7} {'dG':>7} {'dB':>7} {'std':>6} {'histχ²':>7} "
          f"{'winχ²':>7} {'grad':>6} {'std_in':>6} {'grad_in':>7}")
    first = next(iter(variants.values()))
    for name in first["labels"]:
        for v, res in variants.items():
            m = res["labels"][name]
            flag = " <" if (np.abs(m["shift"]).max() > BARS["shift"] or m["std_ratio"] < BARS["std_ratio"]
                            or m["grad_ratio"] < BARS["grad_ratio"]) else ""
            print(f"{name:<11} {v:<12} {m['share']:6.1%} {m['shift'][0]:+7.3f} {m['shift'][1]:+7.3f} "
                  f"{m['shift'][2]:+7.3f} {m['std_ratio']:6.2f} {m['hist_chi2']:7.4f} {m['window_chi2']:7.4f} "
                  f"{m['grad_ratio']:6.2f} {m['std_in']:6.2f} {m['grad_in']:7.2f}{flag}")
    print(f"{'variant':<12} {'fidelity':>9} {'max|shift|':>10} {'min std':>8} {'min grad':>9} {'mean histχ²':>12} "
          f"{'mean winχ²':>11} {'top1% share':>12} {'copies':>7} {'sky corr':>9}")
    for v, res in variants.items():
        ls = res["labels"].values()
        print(f"{v:<12} {res['fidelity']:9.4%} {max(np.abs(m['shift']).max() for m in ls):10.3f} "
              f"{min(m['std_ratio'] for m in ls):8.2f} {min(m['grad_ratio'] for m in ls):9.2f} "
              f"{np.mean([m['hist_chi2'] for m in ls]):12.4f} {np.mean([m['window_chi2'] for m in ls]):11.4f} "
              f"{res['repetition']:12.4f} {res['copies']:7.1f} {res.get('sky_corr', float('nan')):9.3f}")
    for v, res in variants.items():
        if "sky_profile" in res:
            po, ps = res["sky_profile"]
            print(f"sky luma, top to horizon ({v}): output {np.round(po, 3).tolist()}")
    if any("sky_profile" in r for r in variants.values()):
        print(f"sky luma, top to horizon (photo): {np.round(ps, 3).tolist()}")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="*", default=["first", "self", "layout"], choices=["first", "self", "layout"])
    ap.add_argument("--no-l2", action="store_true", help="skip the l2 guide baseline of the first frames")
    args = ap.parse_args(sys.argv[2:] if argv is None and len(sys.argv) > 1 and sys.argv[1] == "fidelity" else argv)
    srcs = {s: load_source(ROOT / "samples" / s / "source.yaml") for s in SAMPLES}
    ssrgb = {s: srgb(p) for s, p in srcs.items()}
    if "first" in args.cases:
        for scene, s in SCENES:
            mag, fin, dt = first_frame(scene, s)
            variants = {"final": measure(fin, srcs[s], ssrgb[s]), "pre-Poisson": measure(mag, srcs[s], ssrgb[s]),
                        "no grain": measure(first_frame(scene, s, ["final.grain=1.0"])[1], srcs[s], ssrgb[s]),
                        "no spread": measure(first_frame(scene, s, ["final.layout_spread=1.0"])[1], srcs[s],
                                             ssrgb[s])}
            if not args.no_l2:
                variants["l2"] = measure(first_frame(scene, s, ["guide.metric=l2"])[1], srcs[s], ssrgb[s])
            report(f"first frame {scene}/{s} ({fin.shape[1]}x{fin.shape[0]}, {dt:.1f} s incl. JIT/USD)", variants)
    for case in ("self", "layout"):
        if case not in args.cases:
            continue
        for s in SAMPLES:
            src = srcs[s]
            if case == "self":
                ids = src["label.id"]
            else:
                ids, _ = labels_from_map(Path(src.meta["source"]["layout"]), src.meta["labels"], far_distance=100.0,
                                         max_far_fraction=0.05, where="bench")
                ids = resize_ids(ids, (1024, 1024))
            mag, fin, dt = nodes(src, ids)
            report(f"{case} {s} ({fin.shape[1]}x{fin.shape[0]}, {dt:.1f} s)",
                   {"final": measure(fin, src, ssrgb[s]), "pre-Poisson": measure(mag, src, ssrgb[s])})


if __name__ == "__main__":
    main()
