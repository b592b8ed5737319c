"""First frames from photos the project has never seen, against EbSynth on the same guide.

Cases (each a photo, its label map and a target layout that is *not* its own):
  eval      every photo folder of ``--eval DIR`` (``photo.png``, ``src_labels.png``,
            ``labels.yaml``: name -> RGB, as in ../shared/data/eval_photos; read from the
            path given, never copied). The layout is the label map of the next photo
            (sorted by name) with the same label names; a photo whose labels no other
            photo has gets its own map mirrored left-right and shifted down by 1/16 of
            its height (the same labels in other places).
  bundled   renoir, monet, creek with the second layout of their source.yaml.
Half of the eval photos (every other, sorted by name) are marked ``held``: defaults are
tuned on the others and the bundled ones, and the held cases' median is printed apart.

Each case runs the first frame's synthesis on the layout as the detailed guide, at 1024
wide (PatchInit -> Correct -> Magnify -> Poisson with graphs/first_frame.yaml's
parameters), and with ``--ebsynth PATH``
EbSynth (texture by numbers: ``-style photo -guide src_labels tgt_labels -patchsize 3
-uniformity 1000``) on the same guide; EbSynth's outputs are kept in ``--out`` by the
hash of their inputs (re-runs read them back).

Per case and label (sRGB in [0, 1], ``kernels.quality.label_fidelity``): colour-histogram
χ², windowed-luma χ² to the nearest photo window of the label, gradient ratio, std ratio,
the share of pixels whose luma lies outside the photo label's 0.5-99.5 % luma range (by
more than half an 8-bit step), and
the share of negative pixels (the linear EXR values; EbSynth's 8-bit output has none),
proxyshade beside EbSynth with the ratio. A case's figure is the mean over its labels.
Beside them, proxyshade's share of windows holding a patch seam and the windowed χ² of
those with one and those without (``seam_windows``), and ``photo``: the photo's own
windows scored the same way (``copy_floor``), what a faithful copy of the photo scores
(a method that smooths a label's texture can score below it).
Bars (issue #32): hist χ² <= EbSynth's and windowed χ² <= 1.2x EbSynth's in every case,
median windowed χ² <= EbSynth's, outside share <= 1 % per label, no negative pixels, std
ratio 0.8-1.2 per label.

``--stages`` prints instead, per case and variant, each label's std ratio after PatchInit,
before and after each Correct level, after each of Magnify's steps (magnified, label repair,
seam moves, patch shifts, seam moves again) and Poisson (``stages``), and per Correct level
the slope of each pixel's luma z-score in its label after the level on that before it
(``z_slope``: the share of a pixel's tone deviation the level keeps).
``--width 1920`` (or 3840) makes HD (4K) frames from the same photos at the photo's texture
scale, and prints each output's repetition (``kernels.quality.repetition``, ``copies``; per
label and the framing's floor, ``label_repetition``) beside its time, to compare with the
1024-wide run's; ``--rare`` adds each label's rare look (its darkest and brightest tails) after
PatchInit, Correct and Magnify: its copies against an even draw's (``kernels.quality.rare_use``),
and how near each other the copies of each label's most-used 16² windows sit on the frame
(``kernels.quality.copy_spacing``: visible repetition, where the count is forced by the area),
and ``--frames`` writes each output (PNG, and its ``source.x/y``, ``label.id`` as .npz) to ``--out``.
``--variant NAME:node.param=value,...`` (repeatable) runs more configurations beside the
defaults (``final`` is the Poisson node, ``correct``, ``init``, ``magnify`` the others;
``final.skip=true`` measures Magnify's plate, before the Poisson step);
variants differing only in Poisson parameters share the synthesis before it.
A contact sheet per case goes to ``--out``: photo | proxyshade | EbSynth, then 100 %
crops (256 px) of sky, water and a ridge (the sky's lower border) of each.

Run: ``python bench/bench_photos.py --eval ../shared/data/eval_photos --ebsynth /path/ebsynth``
(the previous defaults beside: ``--variant before:init.factor=4,final.layout=true,final.grain=2,final.screen=0.01``)
"""
from __future__ import annotations

import argparse
import hashlib
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from proxyshade.graph.plate import Plate  # noqa: E402
from proxyshade.graph.testing import run_node  # noqa: E402
from proxyshade.io.colourlib import colour_science  # noqa: E402
from proxyshade.io.images import read_u8, write_png  # noqa: E402
from proxyshade.io.source import labels_from_map, load_source  # noqa: E402
from proxyshade.kernels import quality as Q  # noqa: E402
from proxyshade.kernels.display import id_palette  # noqa: E402

sys.path.insert(0, str(ROOT / "bench"))
from bench_fidelity import resize_ids  # noqa: E402

BUNDLED = ["renoir", "monet", "creek"]
WIDTH = 1024
CROP = 256
BARS = {"hist_ratio": 1.0, "window_ratio": 1.2, "median_window_ratio": 1.0, "outside": 0.01,
        "std": (0.8, 1.2), "negative": 0.0}
TIE = 0.5 / 255  # luma within half an 8-bit step of the photo's range counts as inside (a saturated sky's
                 # 99.5th percentile lies on a plateau of equal values; a frame reading more of it is not out)
NODES = {"init": "PatchInit", "correct": "Correct", "magnify": "Magnify", "final": "Poisson"}


# ---- cases ------------------------------------------------------------------------------

def _hex(rgb) -> str:
    return "#%02x%02x%02x" % tuple(int(v) for v in rgb)


def eval_cases(root: Path, work: Path) -> list[dict]:
    """One case per photo folder of ``root``: a source.yaml written in ``work`` (the files
    stay where they are) and a layout of another photo with the same labels."""
    folders = sorted(p for p in root.iterdir() if (p / "photo.png").exists())
    tables = {}
    for f in folders:
        names = yaml.safe_load((f / "labels.yaml").read_text())
        tables[f.name] = names
        lines = [f"image: {(f / 'photo.png').resolve()}", f"labels_map: {(f / 'src_labels.png').resolve()}",
                 "labels:"]
        lines += [f"  {n}: {{id: {i}, color: \"{_hex(c)}\"}}" for i, (n, c) in enumerate(names.items(), 1)]
        (work / f"{f.name}.yaml").write_text("\n".join(lines) + "\n")
    cases = []
    for i, f in enumerate(folders):
        same = [g for g in folders[i + 1:] + folders[:i] if set(tables[g.name]) == set(tables[f.name])]
        cases.append({"name": f.name, "table": work / f"{f.name}.yaml", "held": i % 2 == 1,
                      "layout": same[0] / "src_labels.png" if same else None, "mirror": not same,
                      "layout_name": same[0].name if same else f"{f.name} mirrored"})
    return cases


def bundled_cases() -> list[dict]:
    out = []
    for s in BUNDLED:
        table = ROOT / "samples" / s / "source.yaml"
        lay = yaml.safe_load(table.read_text())["layout"]
        out.append({"name": s, "table": table, "held": False, "layout": (table.parent / lay).resolve(),
                    "mirror": False, "layout_name": Path(lay).name})
    return out


def case_guide(case: dict, src: Plate, width: int = WIDTH) -> np.ndarray:
    """The case's target label ids at ``width`` wide (the layout's aspect)."""
    table = src.meta["labels"]
    if case["mirror"]:
        ids = src["label.id"][:, ::-1]
        ids = np.roll(ids, ids.shape[0] // 16, axis=0)
        ids[: ids.shape[0] // 16] = ids[ids.shape[0] // 16]  # the rolled-in rows: the first kept row again
    else:
        ids, _ = labels_from_map(Path(case["layout"]), table, far_distance=100.0, max_far_fraction=0.05,
                                 where="bench")
    h = int(round(ids.shape[0] * width / ids.shape[1]))
    return resize_ids(ids, (h, width)).astype(np.uint32)


# ---- the two methods --------------------------------------------------------------------

def srgb(lin: np.ndarray) -> np.ndarray:
    lin = np.clip(np.asarray(lin, np.float64), 0.0, None)
    return np.clip(colour_science().cctf_encoding(lin, function="sRGB"), 0.0, 1.0)


def parse_variant(text: str) -> tuple[str, dict]:
    name, _, rest = text.partition(":")
    sets: dict[str, dict] = {}
    for item in filter(None, rest.split(",")):
        key, _, val = item.partition("=")
        node, _, param = key.strip().partition(".")
        if node not in NODES:
            raise SystemExit(f"--variant {text}: node {node!r} is not one of {', '.join(NODES)}")
        sets.setdefault(node, {})[param] = yaml.safe_load(val)
    return name, sets


def graph_params() -> dict[str, dict]:
    """The parameters graphs/first_frame.yaml gives the nodes of ``NODES``."""
    nodes = yaml.safe_load((ROOT / "graphs" / "first_frame.yaml").read_text())["nodes"]
    return {k: dict(nodes[k].get("params") or {}) for k in NODES}


def proxyshade(src: Plate, ids: np.ndarray, variants: dict[str, dict],
               kept: dict | None = None) -> dict[str, tuple[Plate, float]]:
    """{variant: (Poisson's plate, seconds)}: each node with graphs/first_frame.yaml's
    parameters, then the variant's; the synthesis before Poisson is shared by variants
    that set only Poisson parameters. ``kept``: filled with {variant: (PatchInit's,
    Correct's, Magnify's plate)}."""
    guide = Plate({"label.id": ids}, {"labels": src.meta["labels"]})
    base = graph_params()
    memo, out = {}, {}
    for name, sets in variants.items():
        sets = {k: {**base[k], **sets.get(k, {})} for k in NODES}
        pre = yaml.safe_dump({k: v for k, v in sets.items() if k != "final"}, sort_keys=True)
        t0 = time.perf_counter()
        if pre not in memo:
            init = run_node("PatchInit", sets["init"], {"guide": guide, "source": src})
            corr = run_node("Correct", sets["correct"], {"init": init, "source": src})
            memo[pre] = (init, corr, run_node("Magnify", sets["magnify"], {"synth": corr, "source": src, "guide": guide}))
        if kept is not None:
            kept[name] = memo[pre]
        fp = dict(sets["final"])
        mag = memo[pre][2]
        fin = mag if fp.pop("skip", False) else run_node("Poisson", fp, {"image": mag, "source": src})
        out[name] = (fin, time.perf_counter() - t0)
    return out


def stages(src: Plate, ids: np.ndarray, src_srgb: np.ndarray, sets: dict[str, dict]) -> list[tuple[str, dict]]:
    """Where a label's tone spread goes: [(stage, {label: std ratio})] after PatchInit, before
    and after each Correct level, after each of Magnify's steps, Magnify and Poisson. A map is read at the
    output size (each level's map upsampled to the synthesis size, then magnified, without
    the seam moves), counting only the pixels that read their own label; plates by their RGB."""
    from proxyshade.kernels import correct as kc
    from proxyshade.kernels import magnify as kmag
    from proxyshade.kernels import seams as kseams
    from proxyshade.synthesis.exemplar import grid_to_source

    names = {int(t["id"]): t["name"] for t in src.meta["labels"]}
    lab = src["label.id"]

    def ratios(img, read=None):
        out = {}
        for k in np.unique(ids):
            m, ms = (ids == k) & (True if read is None else read == k), lab == k
            if m.sum() >= 200 and ms.sum() >= 200:
                out[names.get(int(k), str(k))] = float(np.sqrt(img[m].var(0).sum() / src_srgb[ms].var(0).sum()))
        return out

    rec, orig = [], kc.correct_level

    def spy(level, S, knn, **kw):
        rec.append((level, "in", np.array(S)))
        res = orig(level, S, knn, **kw)
        rec.append((level, "out", np.array(res[0])))
        return res

    guide = Plate({"label.id": ids}, {"labels": src.meta["labels"]})
    kc.correct_level = spy
    try:
        init = run_node("PatchInit", sets["init"], {"guide": guide, "source": src})
        corr = run_node("Correct", sets["correct"], {"init": init, "source": src})
    finally:
        kc.correct_level = orig
    steps, kept = [], (kmag.magnify, kmag.repair_labels, kseams.refine_seams, kseams.shift_patches)

    def watch(name, fn):  # Magnify's steps, each map at the output size as it leaves the step
        def run(*a, **kw):
            res = fn(*a, **kw)
            steps.append((name, np.array(res if name == "raw" else res[0])))
            return res
        return run

    kmag.magnify, kmag.repair_labels = watch("raw", kept[0]), watch("repaired", kept[1])
    kseams.refine_seams, kseams.shift_patches = watch("seams", kept[2]), watch("shifts", kept[3])
    try:
        mag = run_node("Magnify", sets["magnify"], {"synth": corr, "source": src, "guide": guide})
    finally:
        kmag.magnify, kmag.repair_labels, kseams.refine_seams, kseams.shift_patches = kept
    fin = run_node("Poisson", sets["final"], {"image": mag, "source": src})
    shapes = {lv.h: lv.tgt_lab.shape for lv, _, _ in rec}
    ex_shape = rec[0][0].src_lab.shape
    factor = int(init.meta["synthesis"]["factor"])  # (not the height ratio: a height need not be a multiple)

    def read_map(S, h):
        while h > 1:
            h //= 2
            S = kc.upsample_state(S, h, shapes[h], ex_shape)
        co = kmag.magnify(np.ascontiguousarray(S, np.int32), factor, ids.shape)
        y, x = np.clip(co[..., 0], 0, lab.shape[0] - 1), np.clip(co[..., 1], 0, lab.shape[1] - 1)
        return ratios(src_srgb[y, x], lab[y, x])

    def read_plate(p):  # a map plate through its source.x/y (Magnify's, at the output size)
        y = np.clip(np.rint(p["source.y"]).astype(int), 0, lab.shape[0] - 1)
        x = np.clip(np.rint(p["source.x"]).astype(int), 0, lab.shape[1] - 1)
        return ratios(src_srgb[y, x], lab[y, x])

    F = float(init.meta["synthesis"]["exemplar_factor"])
    S0 = np.stack([np.rint((init["source.y"] + 0.5) / F - 0.5), np.rint((init["source.x"] + 0.5) / F - 0.5)], -1)
    rows = [("PatchInit", read_map(S0.astype(np.int32), 1))]
    rows += [(f"Correct h={lv.h} {tag}", read_map(S, lv.h)) for lv, tag, S in rec]
    from proxyshade.synthesis.labels import source_table
    dense = {i: names.get(int(t), str(t)) for i, t in enumerate(source_table(src))}
    rows += [(f"z slope h={lv.h}", z_slope(lv, a, b, dense)) for (lv, _, a), (_, _, b) in zip(rec[::2], rec[1::2])]
    step = float(mag.meta["synthesis"]["scale"])
    for t, (name, co) in enumerate(steps):  # own-label pixels only before the repair
        y = np.clip(np.rint(grid_to_source(co[..., 0], step)).astype(int), 0, lab.shape[0] - 1)
        x = np.clip(np.rint(grid_to_source(co[..., 1], step)).astype(int), 0, lab.shape[1] - 1)
        again = " 2" if any(n == name for n, _ in steps[:t]) else ""
        rows.append((f"Magnify {name}{again}", ratios(src_srgb[y, x], lab[y, x])))
    rows += [("Magnify map", read_plate(mag)), ("Magnify", ratios(srgb(mag.rgb()))),
             ("Poisson", ratios(srgb(fin.rgb())))]
    return rows


def z_slope(lv, S_in: np.ndarray, S_out: np.ndarray, dense: dict) -> dict:
    """Per label, how much of a pixel's tone deviation one Correct level keeps: the slope of
    the luma z-score (within the label, the level's exemplar colours) of each target pixel's
    position after the level on that before it (1: kept; 0.45: the similarity sets' first
    entries')."""
    from proxyshade.kernels import correct as kc

    z = np.empty(lv.src_lab.shape)
    kc._tone_z(lv.src_lab, lv.src_rgb, lv.src_masks.shape[2], z)
    a, b = z[S_in[..., 0], S_in[..., 1]], z[S_out[..., 0], S_out[..., 1]]
    la = lv.src_lab[S_out[..., 0], S_out[..., 1]]
    out = {}
    for k in np.unique(lv.tgt_lab):
        m = (lv.tgt_lab == k) & (la == k)
        if m.sum() >= 50 and a[m].var() > 0:
            out[dense[int(k)]] = float(np.cov(a[m], b[m])[0, 1] / a[m].var(ddof=1))
    return out


def ebsynth(exe: Path, src: Plate, ids: np.ndarray, cache: Path) -> tuple[np.ndarray, float]:
    """EbSynth's output (sRGB in [0, 1]) and seconds (0 when read back from ``cache``)."""
    photo = Path(src.meta["source"]["image"])
    table = src.meta["labels"]
    g_src, g_tgt = id_palette(src["label.id"], table), id_palette(ids, table)  # the label map's colours
    h = hashlib.sha256(photo.read_bytes() + g_src.tobytes() + g_tgt.tobytes() + repr(g_tgt.shape).encode())
    path = cache / f"ebsynth_{h.hexdigest()[:16]}.png"
    if path.exists():
        return read_u8(path).astype(np.float64) / 255.0, 0.0
    with tempfile.TemporaryDirectory() as tmp:
        a, b = Path(tmp, "src.png"), Path(tmp, "tgt.png")
        write_png(a, g_src)
        write_png(b, g_tgt)
        t0 = time.perf_counter()
        subprocess.run([str(exe), "-style", str(photo), "-guide", str(a), str(b), "-patchsize", "3",
                        "-uniformity", "1000", "-output", str(Path(tmp, "out.png"))], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        dt = time.perf_counter() - t0
        rgb = read_u8(Path(tmp, "out.png"))
    write_png(path, rgb)
    return rgb.astype(np.float64) / 255.0, dt


# ---- figures ----------------------------------------------------------------------------

def measure(out_srgb: np.ndarray, lin: np.ndarray | None, ids: np.ndarray, src: Plate,
            src_srgb: np.ndarray, *, stride: int = 16, patch: np.ndarray | None = None) -> dict:
    """Per label name: label_fidelity's figures (output windows every ``stride`` px),
    ``outside`` and ``negative``; with ``patch`` (the plate's ``patch.id``), the windowed
    χ² apart for the windows that hold a patch seam and those that do not (``seam_windows``)."""
    names = {int(t["id"]): t["name"] for t in src.meta["labels"]}
    ly, lys = Q.luma(out_srgb), Q.luma(src_srgb)
    res = {}
    for k in np.unique(ids):
        m, ms = ids == k, src["label.id"] == k
        if m.sum() < 200 or ms.sum() < 200:
            continue
        f = Q.label_fidelity(out_srgb, ids, src_srgb, src["label.id"], int(k), window_stride=(stride, 3))
        f["outside"] = Q.outside_share(ly, m, Q.label_range(lys, ms), eps=TIE)
        f["negative"] = float((lin[m] < 0).any(-1).mean()) if lin is not None else 0.0
        if patch is not None:
            f.update(seam_windows(ly, m, patch, lys, ms, stride))
        res[names.get(int(k), str(k))] = f
    return res


def seam_windows(lum: np.ndarray, mask: np.ndarray, patch: np.ndarray, src_lum: np.ndarray,
                 src_mask: np.ndarray, stride: int) -> dict:
    """label_fidelity's windows (11², every ``stride`` px) split by whether their ``mask``
    pixels hold a patch seam (two 4-adjacent ones of different ``patch``): the share that
    do (``seam_share``) and the windowed χ² of each group (``win_seam``, ``win_free``;
    nan when empty)."""
    edge = np.zeros(mask.shape, bool)
    for a, b in (((slice(None), slice(1, None)), (slice(None), slice(None, -1))),
                 ((slice(1, None), slice(None)), (slice(None, -1), slice(None)))):
        e = (patch[a] != patch[b]) & mask[a] & mask[b]
        edge[a] |= e
        edge[b] |= e
    # the same windows as the luma histograms': a 2-bin histogram of the edge flag
    seam = Q.window_histograms(edge * 0.75, mask, bins=2, stride=stride)[:, 1] > 0
    wo = Q.window_histograms(lum, mask, stride=stride)
    ws = Q.window_histograms(src_lum, src_mask, stride=3)
    return {"seam_share": float(seam.mean()) if len(seam) else float("nan"),
            "win_seam": Q.nearest_window_chi2(wo[seam], ws), "win_free": Q.nearest_window_chi2(wo[~seam], ws)}


def copy_floor(src_srgb: np.ndarray, src_labels: np.ndarray, labels, *, stride: int = 16) -> dict:
    """Per label name: the windowed χ² of the photo's own windows (every ``stride`` px,
    the grid shifted by 1, 2, 4 and 7 px, mean) to the photo's windows (every 3 px): what
    a faithful copy of the photo scores, the floor of a method that copies it."""
    lum = Q.luma(src_srgb)
    out = {}
    for t in labels:
        ms = src_labels == int(t["id"])
        if ms.sum() < 200:
            continue
        ws = Q.window_histograms(lum, ms, stride=3)
        out[t["name"]] = float(np.mean([Q.nearest_window_chi2(Q.window_histograms(lum[o:, o:], ms[o:, o:], stride=stride),
                                                              ws) for o in (1, 2, 4, 7)]))
    return out


def case_figures(per: dict) -> dict:
    ls = list(per.values())
    return {k: float(np.mean([m[k] for m in ls])) for k in ("hist_chi2", "window_chi2", "grad_ratio", "std_ratio")} | {
        "outside_max": max(m["outside"] for m in ls), "negative": max(m["negative"] for m in ls),
        "std_min": min(m["std_ratio"] for m in ls), "std_max": max(m["std_ratio"] for m in ls)}


def _ratio(a: float, b: float) -> str:
    return f"{a / b:6.2f}" if b > 0 else "     -"


def print_rare(case: str, name: str, src: Plate, rare: np.ndarray, plates) -> None:
    """One line per stage: each label's rare look (``kernels.quality.rare_use``): copies (mean
    uses of its rare source pixels), the even draw's, the most copies of one 16² window."""
    names = {int(t["id"]): t["name"] for t in src.meta["labels"]}
    for stage, p in plates:
        r = Q.rare_use(p["source.x"], p["source.y"], p["label.id"], src["label.id"], rare)
        if r:
            print(f"{case}: {name} {stage:<8} rare looks: copies (even) peak "
                  + ", ".join(f"{names.get(k, k)} {c:.2f} ({e:.2f}) {w:.1f}" for k, (c, e, w) in r.items())
                  + f"; max copies {max(v[0] for v in r.values()):.2f}, peak {max(v[2] for v in r.values()):.1f}",
                  flush=True)


def print_spacing(case: str, name: str, src: Plate, plate: Plate, looks: np.ndarray | None = None) -> None:
    """Visible repetition (``kernels.quality.copy_spacing``): per label, for its 8 most-used
    16² source windows that are not flat (luma std ≥ 0.03), each copy's distance to the
    nearest other copy on the frame against an even spread's spacing: the median ratio, the
    share under a quarter (clusters), the median distance in pixels, the copies per window.
    With ``looks`` (the rare looks) only windows a tenth of which are rare (bushes, tents,
    clouds: ``rare copy spacing``)."""
    names = {int(t["id"]): t["name"] for t in src.meta["labels"]}
    r = Q.copy_spacing(plate["source.x"], plate["source.y"], plate["label.id"], src["label.id"],
                       source_luma=Q.luma(srgb(src.rgb())), looks=looks)
    if r:
        worst = min(r.values(), key=lambda v: v[0])
        kind = "rare copy spacing" if looks is not None else "copy spacing"
        print(f"{case}: {name} {kind} (nearest copy / even spacing, share < 1/4, px, copies): "
              + ", ".join(f"{names.get(k, k)} {q:.2f} {c:.2f} {d:.0f} {n:.1f}" for k, (q, c, d, n) in r.items())
              + f"; worst {worst[0]:.2f}, clustered {max(v[1] for v in r.values()):.2f}", flush=True)


def print_case(case: dict, figs: dict[str, dict], eb: dict | None, floor: dict | None = None) -> None:
    print(f"\n## {case['name']} ({'held' if case['held'] else 'tune'}), layout {case['layout_name']}")
    print(f"{'label':<11} {'method':<14} {'share':>6} {'histχ²':>7} {'winχ²':>7} {'grad':>5} {'std':>5} "
          f"{'outside':>8} {'neg':>6} {'hist/EB':>7} {'win/EB':>6} {'seam win':>8} {'winχ² seam/free':>15} "
          f"{'photo':>6}")
    first = next(iter(figs.values()))
    for lab in first:
        rows = list(figs.items()) + ([("EbSynth", eb)] if eb else [])
        for meth, per in rows:
            m = per[lab]
            e = eb[lab] if eb else None
            flag = " <" if (m["outside"] > BARS["outside"] or not BARS["std"][0] <= m["std_ratio"] <= BARS["std"][1]
                            or m["negative"] > 0) else ""
            print(f"{lab:<11} {meth:<14} {m['share']:6.1%} {m['hist_chi2']:7.4f} {m['window_chi2']:7.4f} "
                  f"{m['grad_ratio']:5.2f} {m['std_ratio']:5.2f} {m['outside']:8.2%} {m['negative']:6.2%} "
                  f"{_ratio(m['hist_chi2'], e['hist_chi2']) if e else '     -':>7} "
                  f"{_ratio(m['window_chi2'], e['window_chi2']) if e else '     -':>6} "
                  + (f"{m['seam_share']:8.0%} {m['win_seam']:7.4f}/{m['win_free']:7.4f} " if 'seam_share' in m
                     else f"{'-':>8} {'-':>15} ")
                  + (f"{floor[lab]:6.4f}" if floor and lab in floor else f"{'-':>6}") + flag)


def summary(results: list[tuple[dict, dict, dict | None]]) -> None:
    """One line per case and method, then medians (all, tune, held) and the bars."""
    print("\n## summary (mean over each case's labels)")
    print(f"{'case':<13} {'method':<14} {'histχ²':>7} {'winχ²':>7} {'grad':>5} {'std min-max':>11} {'outside':>8} "
          f"{'neg':>6} {'hist/EB':>7} {'win/EB':>6}")
    meths = list(results[0][1])
    for case, figs, eb in results:
        e = case_figures(eb) if eb else None
        for meth in meths + (["EbSynth"] if eb else []):
            c = case_figures(figs[meth] if meth != "EbSynth" else eb)
            print(f"{case['name']:<13} {meth:<14} {c['hist_chi2']:7.4f} {c['window_chi2']:7.4f} {c['grad_ratio']:5.2f} "
                  f"{c['std_min']:5.2f}-{c['std_max']:4.2f} {c['outside_max']:8.2%} {c['negative']:6.2%} "
                  f"{_ratio(c['hist_chi2'], e['hist_chi2']) if e else '     -':>7} "
                  f"{_ratio(c['window_chi2'], e['window_chi2']) if e else '     -':>6}")
    print(f"\n{'method':<14} {'group':<6} {'median histχ²':>13} {'median winχ²':>12} {'hist/EB':>8} {'win/EB':>7} "
          f"{'max win/EB':>10} {'cases in bars':>13}")
    for meth in meths + (["EbSynth"] if results[0][2] else []):
        for group, sel in (("all", lambda c: True), ("tune", lambda c: not c["held"]), ("held", lambda c: c["held"])):
            rows = [(case_figures(f[meth] if meth != "EbSynth" else eb), case_figures(eb) if eb else None)
                    for case, f, eb in results if sel(case)]
            if not rows:
                continue
            mh = statistics.median(r[0]["hist_chi2"] for r in rows)
            mw = statistics.median(r[0]["window_chi2"] for r in rows)
            if rows[0][1]:
                hr = statistics.median(r[0]["hist_chi2"] / r[1]["hist_chi2"] for r in rows)
                wr = [r[0]["window_chi2"] / r[1]["window_chi2"] for r in rows]
                ok = sum(r[0]["hist_chi2"] <= r[1]["hist_chi2"] * BARS["hist_ratio"]
                         and r[0]["window_chi2"] <= r[1]["window_chi2"] * BARS["window_ratio"]
                         and r[0]["outside_max"] <= BARS["outside"] and r[0]["negative"] <= 0
                         and BARS["std"][0] <= r[0]["std_min"] and r[0]["std_max"] <= BARS["std"][1] for r in rows)
                print(f"{meth:<14} {group:<6} {mh:13.4f} {mw:12.4f} {hr:8.2f} {statistics.median(wr):7.2f} "
                      f"{max(wr):10.2f} {ok:>6}/{len(rows)}")
            else:
                print(f"{meth:<14} {group:<6} {mh:13.4f} {mw:12.4f}")


# ---- contact sheet ----------------------------------------------------------------------

def _crop_at(ids: np.ndarray, mask: np.ndarray) -> tuple[int, int] | None:
    """Top-left of a CROP² window centred on the median pixel of ``mask`` (None if empty)."""
    ys, xs = np.nonzero(mask)
    if len(ys) == 0:
        return None
    i = np.argsort(xs, kind="stable")[len(xs) // 2]
    h, w = ids.shape
    return (int(np.clip(ys[i] - CROP // 2, 0, max(h - CROP, 0))), int(np.clip(xs[i] - CROP // 2, 0, max(w - CROP, 0))))


def crops(ids: np.ndarray, src: Plate) -> dict[str, tuple[int, int]]:
    names = {t["name"]: int(t["id"]) for t in src.meta["labels"]}
    out = {}
    sky = ids == names.get("sky", -1)
    if sky.any():
        inner = sky & np.roll(sky, CROP // 2, 0) & np.roll(sky, -CROP // 4, 0)
        if (c := _crop_at(ids, inner if inner.any() else sky)):
            out["sky"] = c
        ridge = sky & ~np.roll(sky, -1, 0)  # the sky's lower border
        ridge[-1] = False
        if (c := _crop_at(ids, ridge)):
            out["ridge"] = c
    if "water" in names and (c := _crop_at(ids, ids == names["water"])):
        out["water"] = c
    return out


def sheet(path: Path, photo: np.ndarray, outs: dict[str, np.ndarray], ids: np.ndarray, src: Plate) -> None:
    """photo | each output side by side (at 512 wide), then each output's 100 % crops."""
    def fit(img, w=512):
        h = int(round(img.shape[0] * w / img.shape[1]))
        return img[(np.arange(h) * img.shape[0] // h)][:, (np.arange(w) * img.shape[1] // w)]

    top = [fit(photo)] + [fit(o) for o in outs.values()]
    hmax = max(t.shape[0] for t in top)
    row = np.concatenate([np.pad(t, ((0, hmax - t.shape[0]), (0, 4), (0, 0))) for t in top], 1)
    rows = [row]
    cs = crops(ids, src)
    for name, (y, x) in cs.items():
        tiles = [o[y:y + CROP, x:x + CROP] for o in outs.values()]
        tiles = [np.pad(t, ((0, CROP - t.shape[0]), (0, CROP - t.shape[1] + 4), (0, 0))) for t in tiles]
        r = np.concatenate(tiles, 1)
        rows.append(np.pad(r, ((4, 0), (0, row.shape[1] - r.shape[1]), (0, 0))) if r.shape[1] <= row.shape[1] else r)
    wmax = max(r.shape[1] for r in rows)
    img = np.concatenate([np.pad(r, ((0, 0), (0, wmax - r.shape[1]), (0, 0))) for r in rows], 0)
    write_png(path, (np.clip(img, 0, 1) * 255 + 0.5).astype(np.uint8))


# ---- main -------------------------------------------------------------------------------

def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--eval", type=Path, help="folder of annotated photos (photo.png, src_labels.png, labels.yaml)")
    ap.add_argument("--ebsynth", type=Path, help="EbSynth's binary (built from ../shared/peers/ebsynth)")
    ap.add_argument("--no-bundled", action="store_true", help="only the --eval photos")
    ap.add_argument("--cases", nargs="*", help="only these case names")
    ap.add_argument("--variant", action="append", default=[], help="NAME:node.param=value,... (repeatable)")
    ap.add_argument("--no-default", action="store_true", help="only the --variant configurations")
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "bench_photos", help="contact sheets, EbSynth outputs")
    ap.add_argument("--stages", action="store_true",
                    help="only where each label's std goes: its ratio to the photo's after each stage (``stages``)")
    ap.add_argument("--rare", type=float, nargs="?", const=0.1, default=None, metavar="TAIL",
                    help="also each label's rare look (its TAIL darkest and brightest source pixels, at least 0.15 "
                         "from its median luma; default 0.1) after PatchInit, "
                         "Correct and Magnify: its copies, an even draw's, the most copies of one 16² window "
                         "(``kernels.quality.rare_use``); and how near each other the copies of each label's "
                         "most-used 16² windows sit (``kernels.quality.copy_spacing``)")
    ap.add_argument("--frames", action="store_true",
                    help="also write each output to --out: CASE_WIDTH_VARIANT.png (sRGB) and .npz (source.x/y, label.id)")
    ap.add_argument("--width", type=int, default=WIDTH,
                    help="output width (1920: HD, 3840: 4K from the same photos; texture at the photo's scale)")
    args = ap.parse_args(sys.argv[2:] if argv is None and len(sys.argv) > 1 and sys.argv[1] == "photos" else argv)
    args.out.mkdir(parents=True, exist_ok=True)
    variants = {} if args.no_default else {"proxyshade": {}}
    variants.update(parse_variant(v) for v in args.variant)
    with tempfile.TemporaryDirectory() as work:
        cases = (eval_cases(args.eval, Path(work)) if args.eval else []) + ([] if args.no_bundled else bundled_cases())
        if args.cases:
            cases = [c for c in cases if c["name"] in args.cases]
        if not args.eval:
            print("no --eval folder: bundled photos only (their own tuning data)")
        if not args.ebsynth:
            print("no --ebsynth: proxyshade alone, no ratios")
        results = []
        for case in cases:
            src = load_source(case["table"], max_far_fraction=0.05)
            src_srgb = srgb(src.rgb())
            ids = case_guide(case, src, args.width)
            stride = max(16, 16 * args.width // WIDTH)  # as many output windows as at 1024 wide
            if args.stages:
                base = graph_params()
                for name, sets in variants.items():
                    rows = stages(src, ids, src_srgb, {k: {**base[k], **sets.get(k, {})} for k in NODES})
                    labels = list(rows[-1][1])
                    print(f"\n## {case['name']} {name}: std ratio per label after each stage")
                    print(f"{'stage':<20}" + "".join(f"{n:>12}" for n in labels))
                    for st, r in rows:
                        print(f"{st:<20}" + "".join(f"{r.get(n, float('nan')):12.3f}" for n in labels), flush=True)
                continue
            kept = {}
            runs = proxyshade(src, ids, variants, kept)
            rare = Q.rare_looks(src_srgb, src["label.id"], tail=args.rare) if args.rare is not None else None
            figs, outs = {}, {}
            for name, (plate, dt) in runs.items():
                rgb = plate.rgb()
                outs[name] = srgb(rgb)
                figs[name] = measure(outs[name], rgb, plate["label.id"], src, src_srgb, stride=stride,
                                     patch=plate["patch.id"])
                sx, sy = plate["source.x"], plate["source.y"]
                per, floor = Q.label_repetition(sx, sy, plate["label.id"], src["label.id"])
                print(f"{case['name']}: {name} {dt:.1f} s, {ids.shape[1]}x{ids.shape[0]}, repetition (share from the "
                      f"most-used 1 % of source pixels) {Q.repetition(sx, sy, src.shape):.4f}, most copies of a 16² "
                      f"patch {Q.copies(sx, sy, src.shape):.1f}, per label {per:.4f} (framing floor {floor:.4f})",
                      flush=True)
                if args.frames:
                    stem = args.out / f"{case['name']}_{args.width}_{name}"
                    write_png(stem.with_suffix(".png"), (np.clip(outs[name], 0, 1) * 255 + 0.5).astype(np.uint8))
                    np.savez_compressed(stem.with_suffix(".npz"), sx=sx, sy=sy, lab=plate["label.id"])
                if rare is not None:
                    print_rare(case["name"], name, src, rare, zip(("init", "correct", "magnify"), kept[name]))
                    print_spacing(case["name"], name, src, plate)
                    print_spacing(case["name"], name, src, plate, rare)
            eb = None
            if args.ebsynth:
                out, dt = ebsynth(args.ebsynth, src, ids, args.out)
                outs["EbSynth"] = out
                eb = measure(out, None, ids, src, src_srgb, stride=stride)
                print(f"{case['name']}: EbSynth {dt:.1f} s" + (" (cached)" if dt == 0 else ""), flush=True)
            print_case(case, figs, eb, copy_floor(src_srgb, src["label.id"], src.meta["labels"], stride=stride))
            sheet(args.out / f"{case['name']}_{args.width}_sheet.png", src_srgb, outs, ids, src)
            results.append((case, figs, eb))
    if results:
        summary(results)
        print(f"\ncontact sheets: {args.out}")


if __name__ == "__main__":
    main()
