"""A whole shot as good as its first frame: seams, detail, coherence, resynthesis, speed.

For each bundled scene's 48-frame camera move (GuideSynth's detailed guide, DepthExtend's
depth, the first frame's full synthesis, then ConsistentDepth -> Reproject ->
Resynthesize every frame), and with ``--eval DIR`` each photo of ../shared/data/eval_photos
in a scene of its labels (``EVAL_SCENES``: the valley of bench/scenes/valley.yaml, a scene
of this bench's own, held out from tuning; the sea-and-cliffs photo in the cliffs scene, its
labels mapped onto the photo's), at each output size, per frame:

  seams     share of same-label 4-adjacent pixel pairs whose source positions are not
            neighbours (``kernels.quality.seam_share``), relative to frame 1's
  detail    mean colour difference of same-label 4-adjacent pairs (``quality.detail``),
            relative to frame 1's
  warp      mean |I_N - warp(I_N-1)| over pixels kept and validly reprojected, coherent /
            independent per-frame synthesis, both frames low-passed by a Gaussian of
            ``--warp-sigma`` (1) pixel before the Lanczos-4 warp: the band a resampling warp
            carries exactly. Unfiltered (``warp L4``, ``warp bil``) a texture exactly attached
            to the surface scores 0.09-0.10 on cliffs at 1024² in patch interiors (Monet's
            pixel-level noise is not reproduced by resampling it between pixel grids):
            that floor is printed alongside (docs/temporal.md, "Measuring a shot")
  share     share of pixels flagged (resynthesized or re-anchored) in the frame
  update s  seconds of the frame after the first (proxy render + ConsistentDepth +
            Reproject + Resynthesize), with the run's memo kept across frames as
            ``proxyshade run`` keeps it (``--no-memo``: without)

and per label at frames 1, 12, 24 and the last (``--per-frame``: every frame), on display
luma (sRGB-encoded, ``kernels.quality``):

  grad      mean gradient magnitude of the label (``quality.gradient_magnitude``) over
            frame 1's: texture that blurs falls, blocks and speckle raise it
  block     ``quality.blockiness`` (energy of the second differences' magnitudes at a 4-px
            period against periods 3 and 5: magnified 4x4 synthesis pixels seen as a
            mosaic) over frame 1's; in the summary ``block sd``, the last frame's ratio's
            bootstrap sd over the label's 20-px windows (``quality.block_ratio_sd``): its
            noise (a small label's ratio swings by more than the bar from frame to frame)
  clump     share of the label's pixels whose source pixel (``source.x/y`` rounded) has a
            photo luma outside the photo label's 0.5-99.5 % range
            (``quality.source_outside_share``): copies of another label's pixels or of the
            label's rare looks (clumps, ghosts). An even copy of the label scores ~1 %
  range     share of the label's pixels whose own luma lies outside that range
            (``quality.outside_share``, bench_photos' ``outside``)

and with ``--edges`` the label's |d luma| per pixel split into patch interiors and seams,
untouched and touching this frame's flags (``edge_classes``); with ``--steps`` the label's grad
after each step: Reproject's output (``carried``: the carry alone, before the resynthesis and
its solve) and the source through the final map without the Poisson correction (``S(map)``):
a rise in ``carried`` that ``S(map)`` does not show is the carried correction's.

The nodes take graphs/camera_move.yaml's parameters (init, correct, magnify, first,
reproject, final), then ``--set node.param=value`` (repeatable), e.g. the first-frame
graphs' settings: ``--set init.factor=2 --set first.layout=false --set first.grain=1.0
--set first.screen=1.0``. ``--frames-out DIR`` writes frames 1, 24 and the last as PNG
(the preview's view transform) for crops.

Bars (issue 33): grad within 0.9-1.1 of frame 1 at every frame and label, block at the
last frame <= 1.1x frame 1's, clump <= 0.2 % above frame 1's.
Bars (issue: a whole shot as good as its first frame): seams <= 1.5x frame 1's and detail
>= 0.9 at every frame, warp ratio <= 0.1, median share <= 10 %, update frame at 1024²
<= 0.5 s (median).

Run: ``python bench/run.py shot`` (``--sizes 512 1024 --scenes lake cliffs farm --frames 48``);
the eval photos alone: ``python bench/bench_shot.py --eval ../shared/data/eval_photos --scenes``.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import yaml

from harness import peak_rss_mb

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from proxyshade.graph.testing import run_node  # noqa: E402
from proxyshade.io.colourlib import colour_science  # noqa: E402
from proxyshade.io.usd import CameraInfo  # noqa: E402
from proxyshade.kernels import quality as Q  # noqa: E402
from proxyshade.kernels import reproject as kr  # noqa: E402
from tests.nodes import _temporal as T  # noqa: E402


def lowpass(rgb: np.ndarray, sigma: float) -> np.ndarray:
    from scipy import ndimage

    return ndimage.gaussian_filter(np.asarray(rgb, np.float32), (sigma, sigma, 0), mode="nearest")


def warp_errors(cur, prev, cd, flag, indep_cur, indep_prev, sigma: float = 1.0) -> dict:
    c1 = CameraInfo.from_meta(cd.meta["camera"])
    c0 = CameraInfo.from_meta(prev.meta["camera"])
    w1 = kr.inverse_depth(cd["Z"])
    u, v, q, ok = kr.transfer(w1, kr.relative_matrix(c1, c0), kr.intrinsics(c1), kr.intrinsics(c0), c0.near)
    z = np.zeros(prev.shape, np.float32)
    valid = kr.gather_prev(u, v, q, ok, lab=np.ascontiguousarray(cd["label.id"]), prev_w=kr.inverse_depth(prev["Z"]),
                           prev_lab=np.ascontiguousarray(prev["label.id"]),
                           prev_patch=np.ascontiguousarray(prev["patch.id"]), prev_sx=z, prev_sy=z,
                           prev_res=np.zeros(prev.shape + (3,), np.float32), prev_d=z, tol=0.02, scale=1.0)[0]
    mask = valid & (flag == 0)
    out = {}
    for f in ("lanczos4", "bilinear"):
        out[f] = (kr.warp_error(cur.rgb(), prev.rgb(), u, v, mask, f),
                  kr.warp_error(indep_cur.rgb(), indep_prev.rgb(), u, v, mask, f))
    lp = {k: lowpass(p.rgb(), sigma) for k, p in (("c", cur), ("p", prev), ("ic", indep_cur), ("ip", indep_prev))}
    out["lowpass"] = (kr.warp_error(lp["c"], lp["p"], u, v, mask, "lanczos4"),
                      kr.warp_error(lp["ic"], lp["ip"], u, v, mask, "lanczos4"))
    return out


def attached_floor(case: "Case", size: int, f0, sigma: float, shifts=((0.3, 0.05), (0.39, -0.11), (-0.43, 0.54))):
    """The warp ratio of a texture exactly attached to the image: the first frame's map read
    through the source at a sub-pixel shift ``a`` and at ``a + d`` (a pan by ``d`` of a
    plane facing the camera, rendered exactly), warped into each other, against an
    independent synthesis read at ``a``. Over patch interiors (more than 2 px from a seam
    or a label border) this is what the measure gives a perfectly coherent rendering.
    Returns {'lanczos4': ratio, 'lowpass': ratio}."""
    from scipy import ndimage
    from proxyshade.kernels.lookup import lookup

    S = case.source().rgb()
    fb = case.first_frame(size, seed=7, frame=1)
    H, W = f0.shape
    sx, sy, lab = f0["source.x"], f0["source.y"], f0["label.id"]
    edge = np.zeros((H, W), bool)
    edge[:, 1:] |= (np.abs(sx[:, 1:] - sx[:, :-1] - 1) + np.abs(sy[:, 1:] - sy[:, :-1]) > 0.01) | (lab[:, 1:] != lab[:, :-1])
    edge[1:, :] |= (np.abs(sy[1:, :] - sy[:-1, :] - 1) + np.abs(sx[1:, :] - sx[:-1, :]) > 0.01) | (lab[1:, :] != lab[:-1, :])
    edge[:, :-1] |= edge[:, 1:].copy()
    edge[:-1, :] |= edge[1:, :].copy()
    mask = ~ndimage.binary_dilation(edge, iterations=2)
    mask[:8], mask[-8:], mask[:, :8], mask[:, -8:] = False, False, False, False
    jj, ii = np.meshgrid(np.arange(W) + 0.5, np.arange(H) + 0.5)
    rng = np.random.default_rng(1)
    err = {"lanczos4": [0.0, 0.0], "lowpass": [0.0, 0.0]}
    for d in shifts:
        a = rng.uniform(0, 1, 2)
        A = lookup(S, sx - a[0], sy - a[1], filter="lanczos4")
        B = lookup(S, sx - a[0] - d[0], sy - a[1] - d[1], filter="lanczos4")
        Ai = lookup(S, fb["source.x"] - a[0], fb["source.y"] - a[1], filter="lanczos4")
        u, v = (jj - d[0]).astype(np.float32), (ii - d[1]).astype(np.float32)
        for k, g in (("lanczos4", lambda X: X), ("lowpass", lambda X: lowpass(X, sigma))):
            err[k][0] += kr.warp_error(g(B), g(A), u, v, mask, "lanczos4")
            err[k][1] += kr.warp_error(g(B), g(Ai), u, v, mask, "lanczos4")
    return {k: e[0] / max(e[1], 1e-12) for k, e in err.items()}


_clock = time.perf_counter  # the update frames' clock (--cpu: process CPU time)
NODE_TIMES: dict[str, list[float]] = {}  # --nodes: node type -> seconds of each update frame (``timed``)


def timed(node_type: str, *args):
    """``run_memo(node_type, *args)``, its seconds (``_clock``) added to ``NODE_TIMES``."""
    t = _clock()
    out = run_memo(node_type, *args)
    NODE_TIMES.setdefault(node_type, []).append(_clock() - t)
    return out


def frame_digest(plate) -> str:
    """A digest of every channel of ``plate`` (name, dtype, shape and bytes; ``--digest``):
    two runs whose frames are bit for bit the same print the same digests."""
    import hashlib

    h = hashlib.blake2b(digest_size=8)
    for name in sorted(plate.names()):
        a = np.ascontiguousarray(plate[name])
        h.update(f"{name}|{a.dtype.str}|{a.shape}".encode())
        h.update(a.view(np.uint8).reshape(-1))
    return h.hexdigest()


def run_memo(node_type: str, params: dict, inputs: dict, frame: int, memo) -> "object":
    """``run_node`` with the run's memo (``graph.memo``) as the engine hands it to a node
    (``ctx.memo``): what every frame would compute again from the same data (the source's
    similarity sets, its graded colours, the first frame's grid) is kept across the frames of
    a shot, as in ``proxyshade run``; ``memo`` None: ``run_node`` (nothing kept). As the
    engine binds each input plate to its cache key, each input plate is bound to a key of
    its own (``plate_key``), so the memo names it without hashing its pixels every frame."""
    if memo is None:
        return run_node(node_type, params, inputs, frame=frame)
    from proxyshade.graph.memo import RunMemo
    from proxyshade.graph.node import REGISTRY, Context, find_type

    cls = find_type(node_type) or REGISTRY[node_type]
    node = cls(node_type, params or {})
    ins = dict.fromkeys(cls.inputs_spec)
    ins.update(inputs)
    ctx = Context(node, frame, 1, ins, node.params, ROOT, 0, [])
    ctx.memo = RunMemo(memo)
    for plate in inputs.values():
        if plate is not None:
            ctx.memo.bind(plate, plate_key(memo, plate))
    node.check_inputs(ins)
    return node.compute(ctx)
def plate_key(memo, plate) -> str:
    """A key of ``plate``'s own for ``memo`` (the engine's cache key stands there): a serial
    number per plate object, which the bench never writes to after making it."""
    import itertools
    import weakref

    keys = memo.__dict__.setdefault("_bench_keys", {})  # id -> (weak reference, key)
    serial = memo.__dict__.setdefault("_bench_serial", itertools.count())
    got = keys.get(id(plate))
    if got is None or got[0]() is not plate:  # a new plate (or a freed one's id)
        got = keys[id(plate)] = (weakref.ref(plate), f"bench:{next(serial)}")
    return got[1]


class Case:
    """A shot to measure: a scene (.usda), a source (source.yaml) and ProxyRender's ``labels``
    mapping (scene label -> source label). Its proxies, detailed guides and independent
    first frames are made as tests/nodes/_temporal.py makes the bundled scenes' (the same
    nodes and parameters), kept per frame and size until ``clear``."""

    def __init__(self, name: str, scene: Path, table: Path, labels: dict | None = None):
        self.name, self.scene, self.table, self.labels = name, Path(scene), Path(table), dict(labels or {})
        self.file_name = name.replace("/", "_")
        self._source = None
        self._plates: dict = {}

    @classmethod
    def bundled(cls, scene: str) -> "Case":
        return cls(scene, ROOT / "samples" / "scenes" / f"{scene}.usda",
                   ROOT / "samples" / T.SCENES[scene] / "source.yaml")

    def source(self):
        if self._source is None:
            from proxyshade.io.source import load_source

            self._source = load_source(self.table)
        return self._source

    def proxy_params(self, size: int) -> dict:
        out = {"scene": str(self.scene), "resolution": [size, size]}
        return dict(out, labels=self.labels) if self.labels else out

    def _kept(self, key, make):
        if key not in self._plates:
            self._plates[key] = make()
        return self._plates[key]

    def proxy(self, frame: int, size: int):
        return self._kept(("proxy", frame, size), lambda: run_node(
            "ProxyRender", self.proxy_params(size), {"source": self.source()}, frame=frame, name="proxy"))

    def detailed(self, frame: int, size: int):
        """GuideSynth's detailed guide (synthesis at size / 4) and DepthExtend's depth of a frame."""
        return self._kept(("detailed", frame, size),
                          lambda: T.detail_of(self.proxy(frame, size), self.source(), frame, size))

    def first_frame(self, size: int, seed: int = 0, frame: int = 1):
        """An independent full synthesis of a frame (default parameters) on its detailed guide."""
        return T.synthesize(self.source(), self.detailed(frame, size)[1], seed)

    def clear(self) -> None:
        self._plates.clear()


# scenes of the eval photos' labels: each photo whose labels are sky, vegetation and mountain
# in the valley (bench/scenes/valley.yaml, a scene of this bench's own: no default was tuned on
# it), and the sea-and-cliffs photo in the bundled cliffs scene, its labels mapped onto the photo's
EVAL_SCENES = (({"sky", "vegetation", "mountain"}, "valley", {}),
               ({"sky", "water", "vegetation", "mountain", "rock"}, "cliffs",
                {"cliff": "mountain", "sea": "water", "grass": "vegetation"}))


def eval_cases(root: Path, work: Path) -> list[Case]:
    """Shots of the annotated photos in ``root`` (bench_photos' ``--eval`` folders: photo.png,
    src_labels.png, labels.yaml; their source.yaml written in ``work`` by bench_photos), each
    in the scene of ``EVAL_SCENES`` for its label names (the valley's .usda built in ``work``)."""
    from bench_photos import eval_cases as photo_cases
    from proxyshade.scene.build import build_file

    scenes = {"valley": build_file(ROOT / "bench" / "scenes" / "valley.yaml", work / "valley.usda"),
              "cliffs": ROOT / "samples" / "scenes" / "cliffs.usda"}
    out = []
    for c in photo_cases(Path(root), work):
        names = set(yaml.safe_load((Path(root) / c["name"] / "labels.yaml").read_text()))
        out += [Case(f"{scene}/{c['name']}", scenes[scene], c["table"], mapping)
                for labels, scene, mapping in EVAL_SCENES if names == labels]
    return out


NODES = {"init": "PatchInit", "correct": "Correct", "magnify": "Magnify", "first": "Poisson",
         "reproject": "Reproject", "final": "Resynthesize"}


def graph_params(sets: list[str] = ()) -> dict[str, dict]:
    """graphs/camera_move.yaml's parameters of ``NODES``, then ``sets`` ('node.param=value')."""
    nodes = yaml.safe_load((ROOT / "graphs" / "camera_move.yaml").read_text())["nodes"]
    out = {k: dict(nodes[k].get("params") or {}) for k in NODES}
    for item in sets:
        key, _, val = item.partition("=")
        node, _, param = key.strip().partition(".")
        if node not in NODES or not param:
            raise SystemExit(f"--set {item}: expected node.param=value with node one of {', '.join(NODES)}")
        out[node][param] = yaml.safe_load(val)
    return out


def first_frame(case: "Case", size: int, params: dict):
    """The first frame's full synthesis on the detailed guide, with ``params``' first-frame nodes."""
    return T.synthesize(case.source(), case.detailed(1, size)[1], params=params, final="first")


def srgb(lin: np.ndarray) -> np.ndarray:
    lin = np.clip(np.asarray(lin, np.float64), 0.0, None)
    return np.clip(colour_science().cctf_encoding(lin, function="sRGB"), 0.0, 1.0)


class LabelFigures:
    """Per-label figures of a frame (``kernels.quality``) against the photo's label ranges."""

    def __init__(self, src):
        self.names = {int(t["id"]): t["name"] for t in src.meta["labels"]}
        self.src_lum = Q.luma(srgb(src.rgb()))
        self.src_lab = src["label.id"]
        self.ranges = {k: Q.label_range(self.src_lum, self.src_lab == k) for k in self.names
                       if (self.src_lab == k).sum() >= 200}

    def __call__(self, plate, windows: bool = False) -> dict:
        """``windows``: also each label's ``block_windows`` (frames 1 and last: the block
        ratio's bootstrap sd)."""
        lum = Q.luma(srgb(plate.rgb()))
        lab = plate["label.id"]
        out = {}
        for k, rng in self.ranges.items():
            m = lab == k
            if m.sum() < 400:
                continue
            w = Q.block_windows(lum, m) if windows else None
            out[self.names[k]] = {"grad": Q.gradient_magnitude(lum, m),
                                  "block": Q.block_of(w.sum(0)) if windows else Q.blockiness(lum, m),
                                  "clump": Q.source_outside_share(plate["source.x"], plate["source.y"], m,
                                                                  self.src_lum, rng),
                                  "range": Q.outside_share(lum, m, rng), "share": float(m.mean())}
            if windows:
                out[self.names[k]]["block_w"] = w
        return out


def step_gradients(figures: "LabelFigures", rp, fin, source, filt: str) -> dict:
    """Per label name: the mean display-luma gradient of Reproject's output ``rp`` over its kept
    pixels (flag 0: the carry alone, not the holes the resynthesis fills) and of the source read
    through ``fin``'s map with ``filt`` (no Poisson correction), for ``--steps``."""
    from proxyshade.kernels.lookup import lookup
    from proxyshade.synthesis.grain import source_colours

    smap = lookup(source_colours(source, fin.meta), fin["source.x"], fin["source.y"], filter=filt)
    out = {}
    for name, plate_lum in (("carried", Q.luma(srgb(rp.rgb()))), ("smap", Q.luma(srgb(smap)))):
        lab = rp["label.id"] if name == "carried" else fin["label.id"]
        kept = (rp["flag"] == 0) if name == "carried" and "flag" in rp else np.ones(lab.shape, bool)
        for k in figures.ranges:
            m = (lab == k) & kept
            if m.sum() >= 400:
                out.setdefault(figures.names[k], {})[name] = Q.gradient_magnitude(plate_lum, m)
    return out


def edge_classes(plate, flag, lum: np.ndarray | None = None) -> dict:
    """Per label: the sum of |Δ luma| (display) over its 4-neighbour pairs per label pixel,
    split into pairs inside a patch / across a seam (``patch.id`` differs) and untouched /
    touching a pixel flagged this frame (``flag``): where a label's gradient lives, so a
    creep can be told apart into interiors and seams (docs/temporal.md, "Gradient creep")."""
    lum = Q.luma(srgb(plate.rgb())) if lum is None else lum
    lab, pa, fl = plate["label.id"], plate["patch.id"], np.asarray(flag) != 0
    out = {}
    for k in np.unique(lab):
        n = int((lab == k).sum())
        if n < 400:
            continue
        sums = dict.fromkeys(("in", "in_f", "seam", "seam_f"), 0.0)
        for sl1, sl0 in (((slice(None), slice(1, None)), (slice(None), slice(None, -1))),
                         ((slice(1, None), slice(None)), (slice(None, -1), slice(None)))):
            same = (lab[sl1] == k) & (lab[sl0] == k)
            seam = pa[sl1] != pa[sl0]
            touch = fl[sl1] | fl[sl0]
            d = np.abs(lum[sl1] - lum[sl0])
            for name, m in (("in", ~seam & ~touch), ("in_f", ~seam & touch), ("seam", seam & ~touch),
                            ("seam_f", seam & touch)):
                sums[name] += float(d[same & m].sum())
        out[int(k)] = {name: v / n for name, v in sums.items()}
    return out


def write_frame(path: Path, plate) -> None:
    from proxyshade.io.images import write_png
    from proxyshade.kernels.display import to_display

    path.parent.mkdir(parents=True, exist_ok=True)
    write_png(path, to_display(plate, ["R", "G", "B"]))


def shot(case: "Case", size: int, frames: int, every: int = 1, sigma: float = 1.0, params: dict | None = None,
         frames_out: Path | None = None, edges: bool = False, memo: bool = True, steps: bool = False,
         digest: bool = False) -> list[dict]:
    from proxyshade.graph.memo import Memo

    params = params or graph_params()
    store = Memo() if memo else None
    src = case.source()
    p0 = case.proxy(1, size)
    g0, d0 = case.detailed(1, size)
    f0 = first_frame(case, size, params)
    figures = LabelFigures(src)
    scale = float(f0.meta.get("synthesis", {}).get("scale", 1.0))
    s0 = Q.seam_share(f0["source.x"], f0["source.y"], f0["label.id"], scale=scale)
    det0 = Q.detail(f0.rgb(), f0["label.id"])
    filt = params["reproject"].get("filter", "lanczos4")
    NODE_TIMES.clear()
    rows = [{"frame": 1, "seams": 1.0, "detail": 1.0, "share": 0.0, "update": None, "warp": None,
             "digest": frame_digest(f0) if digest else None,
             "labels": figures(f0, windows=True), "edges": edge_classes(f0, np.zeros(f0.shape, np.uint32)) if edges else None,
             "steps": step_gradients(figures, f0, f0, src, filt) if steps else None}]
    keep = {1, 24, frames}
    if frames_out:
        write_frame(frames_out / f"{case.file_name}_{size}.0001.png", f0)
    prev, indep_prev, indep_frame = f0, f0, 1
    for fr in range(2, frames + 1):
        t = _clock()
        pN = timed("ProxyRender", case.proxy_params(size), {"source": src}, fr, store)
        cd = timed("ConsistentDepth", {}, {"proxy": pN, "guide": g0, "depth": d0, "ref_proxy": p0}, fr, store)
        rp = timed("Reproject", params["reproject"], {"depth": cd, "prev": prev, "first": f0, "source": src}, fr, store)
        fin = timed("Resynthesize", params["final"], {"image": rp, "source": src}, fr, store)
        upd = _clock() - t
        row = {"frame": fr, "update": upd, "share": float((rp["flag"] > 0).mean()),
               "seams": Q.seam_share(fin["source.x"], fin["source.y"], fin["label.id"], scale=scale) / s0,
               "detail": Q.detail(fin.rgb(), fin["label.id"]) / det0, "warp": None, "labels": figures(fin, windows=fr == frames),
               "edges": edge_classes(fin, rp["flag"]) if edges else None,
               "steps": step_gradients(figures, rp, fin, src, filt) if steps else None,
               "digest": frame_digest(fin) if digest else None}
        if frames_out and fr in keep:
            write_frame(frames_out / f"{case.file_name}_{size}.{fr:04d}.png", fin)
        # pairs (fr - 1, fr) ending at frames 2, 2 + every, ...: independent syntheses of both
        if every and (fr - 2) % every == 0:
            if indep_frame != fr - 1:
                indep_prev = case.first_frame(size, seed=fr - 1, frame=fr - 1)
            indep = case.first_frame(size, seed=fr, frame=fr)
            row["warp"] = warp_errors(fin, prev, cd, rp["flag"], indep, indep_prev, sigma)
            indep_prev, indep_frame = indep, fr
        rows.append(row)
        prev = fin
    return rows


def label_table(rows: list[dict], shown) -> list[dict]:
    """Print the per-label figures of the ``shown`` frames; return the bars' figures per label."""
    first = rows[0]["labels"]
    print(f"{'frame':>5} {'label':<12} {'area':>6} {'grad':>6} {'block':>6} {'clump':>7} {'range':>7}")
    for r in rows:
        if r["frame"] not in shown:
            continue
        for name, m in r["labels"].items():
            f = first.get(name)
            g = m["grad"] / f["grad"] if f and f["grad"] > 0 else float("nan")
            b = m["block"] / f["block"] if f and f["block"] > 0 else float("nan")
            print(f"{r['frame']:>5} {name:<12} {100 * m['share']:5.1f}% {g:6.3f} {b:6.3f} {100 * m['clump']:6.2f}% "
                  f"{100 * m['range']:6.2f}%")
    out = []
    last = rows[-1]["labels"]
    for name, f in first.items():
        gr = [r["labels"][name]["grad"] / f["grad"] for r in rows if name in r["labels"] and f["grad"] > 0]
        out.append({"label": name, "grad_min": min(gr), "grad_max": max(gr),
                    "block_last": last[name]["block"] / f["block"] if name in last else float("nan"),
                    "block_sd": Q.block_ratio_sd(last[name]["block_w"], f["block_w"]) if name in last else float("nan"),
                    "clump_first": f["clump"], "clump_max": max(r["labels"][name]["clump"] for r in rows
                                                                if name in r["labels"])})
    return out


def over_bars(x: dict) -> tuple[str, ...]:
    """The bars (issue 33) a label's shot figures (``label_table``'s) miss: grad, block, clump."""
    return tuple(k for k, bad in (("grad", not (0.9 <= x["grad_min"] and x["grad_max"] <= 1.1)),
                                  ("block", not x["block_last"] <= 1.1),
                                  ("clump", not x["clump_max"] - x["clump_first"] <= 0.002)) if bad)


def seed_table(labels: list[dict], variants: list[str]) -> dict:
    """Print, for runs over several seeds and variants: per variant and seed, the labels over
    each bar; per label, the figures over the seeds (grad min: the least, grad max: the most,
    block at the last frame and clump rise: median and most) and how many seeds miss a bar;
    and each variant against the first, seed by seed (the median of the paired differences,
    and beside it the first variant's spread over seeds: its noise). Returns the counts
    {variant: {seed: {bar: n}}}."""
    seeds = sorted({x["seed"] for x in labels}, key=lambda v: (v is None, v))
    counts = {v: {s: {b: 0 for b in ("grad", "block", "clump", "any")} for s in seeds} for v in variants}
    by = {}
    for x in labels:
        bad = over_bars(x)
        c = counts[x["variant"]][x["seed"]]
        for b in bad:
            c[b] += 1
        c["any"] += bool(bad)
        by.setdefault((x["case"], x["size"], x["label"]), {}).setdefault(x["variant"], {})[x["seed"]] = x
    print(f"\n## Over seeds {', '.join(str(s) for s in seeds)}: labels over a bar (grad / block / clump / any)")
    for v in variants:
        print(f"{v:<16} " + "   ".join(f"s{s}: {c['grad']}/{c['block']}/{c['clump']}/{c['any']}"
                                        for s, c in counts[v].items()))

    def fig(xs: list[dict]) -> dict:
        rise = [100 * (x["clump_max"] - x["clump_first"]) for x in xs]
        return {"gmin": min(x["grad_min"] for x in xs), "gmax": max(x["grad_max"] for x in xs),
                "bmed": statistics.median(x["block_last"] for x in xs), "bmax": max(x["block_last"] for x in xs),
                "cmed": statistics.median(rise), "cmax": max(rise), "over": sum(bool(over_bars(x)) for x in xs)}

    print(f"{'case':<24} {'size':>5} {'label':<12} {'variant':<16} {'grad min':>8} {'grad max':>8} {'block med':>9} "
          f"{'block max':>9} {'clump+ med':>10} {'clump+ max':>10} {'over':>6}")
    for (case, size, label), per in by.items():
        for v in variants:
            if v in per:
                f = fig(list(per[v].values()))
                print(f"{case:<24} {size:>5} {label:<12} {v:<16} {f['gmin']:8.3f} {f['gmax']:8.3f} {f['bmed']:9.3f} "
                      f"{f['bmax']:9.3f} {f['cmed']:9.2f}% {f['cmax']:9.2f}% {f['over']:>3}/{len(per[v])}")
    if len(variants) > 1:
        base = variants[0]
        print(f"\nPaired with {base}, seed by seed: median of (variant - {base}) [{base}'s sd over seeds]")
        print(f"{'case':<24} {'size':>5} {'label':<12} {'variant':<16} {'d grad min':>16} {'d grad max':>16} "
              f"{'d block':>16} {'d clump+ %':>16}")
        keys = (("grad_min", 1), ("grad_max", 1), ("block_last", 1), ("clump_rise", 100))
        for (case, size, label), per in by.items():
            b = per.get(base, {})
            for v in variants[1:]:
                common = [s for s in per.get(v, {}) if s in b]
                if not common:
                    continue
                cells = []
                for k, scale in keys:
                    val = (lambda x: x["clump_max"] - x["clump_first"]) if k == "clump_rise" else (lambda x, k=k: x[k])
                    d = statistics.median(scale * (val(per[v][s]) - val(b[s])) for s in common)
                    sd = statistics.stdev(scale * val(b[s]) for s in common) if len(common) > 1 else float("nan")
                    cells.append(f"{d:+8.3f} [{sd:5.3f}]")
                print(f"{case:<24} {size:>5} {label:<12} {v:<16} " + " ".join(f"{c:>16}" for c in cells))
    return counts


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[512, 1024])
    ap.add_argument("--scenes", nargs="*", default=list(T.SCENES))
    ap.add_argument("--eval", type=Path, default=None, metavar="DIR",
                    help="also shots of the annotated photos in DIR (../shared/data/eval_photos): each in the scene "
                         "of its labels (EVAL_SCENES); '--scenes' with no name runs only these")
    ap.add_argument("--photos", nargs="*", default=None, help="with --eval: only these photo folders")
    ap.add_argument("--frames", type=int, default=48)
    ap.add_argument("--warp-every", type=int, default=1,
                    help="warp ratio over the frame pairs ending at 2, 2 + N, ... (independent syntheses of "
                         "both frames of each pair; 0: none)")
    ap.add_argument("--warp-sigma", type=float, default=1.0,
                    help="Gaussian low-pass (pixels) of both frames before the warp of the 'warp' ratio")
    ap.add_argument("--per-frame", action="store_true", help="print every frame's row")
    ap.add_argument("--set", action="append", default=[], metavar="NODE.PARAM=VALUE",
                    help="override a parameter of graphs/camera_move.yaml's nodes (" + ", ".join(NODES) + ")")
    ap.add_argument("--seed", "--seeds", dest="seeds", type=int, nargs="+", default=None,
                    help="the shot's seed(s): each sets init.seed, correct.seed and final.seed "
                         "(graphs/camera_move.yaml: 1) before any --set; with several, every case runs at each "
                         "and the summary adds the figures over seeds (seed_table)")
    ap.add_argument("--variant", action="append", default=[], metavar="NAME:NODE.PARAM=VALUE,...",
                    help="also run every case with these --set items (repeatable); with several seeds the summary "
                         "pairs each variant with the graph's run seed by seed")
    ap.add_argument("--no-default", action="store_true", help="with --variant: skip the graph's own run")
    ap.add_argument("--frames-out", type=Path, default=None, help="write frames 1, 24 and the last as PNG here")
    ap.add_argument("--edges", action="store_true",
                    help="per label at the shown frames: |d luma| per label pixel inside patches / across seams, "
                         "untouched / touching this frame's flags (edge_classes)")
    ap.add_argument("--steps", action="store_true",
                    help="per label at the shown frames: grad of Reproject's output (the carry alone) and of the source "
                         "through the final map without the correction, over frame 1's (step_gradients)")
    ap.add_argument("--cpu", action="store_true",
                    help="time update frames by the process's CPU time on one numba thread (steady on shared cores; "
                         "'update s' is then CPU seconds; the total over the shot is printed)")
    ap.add_argument("--digest", action="store_true",
                    help="print a digest of each frame's final plate (every channel's bytes) and of the whole shot: "
                         "a change meant for speed alone must leave them as they were (frame_digest)")
    ap.add_argument("--nodes", action="store_true",
                    help="per node (ProxyRender, ConsistentDepth, Reproject, Resynthesize): seconds of frame 2 (it "
                         "loads the update frame's kernels from numba's cache and fills the run's memo) and the "
                         "median and total over frames 3 to the last, on the update frames' clock")
    ap.add_argument("--no-memo", action="store_true",
                    help="no run memo across frames (each frame recomputes the source's similarity sets, graded "
                         "colours and the first frame's grid; proxyshade run keeps them)")
    args = ap.parse_args(sys.argv[2:] if argv is None and len(sys.argv) > 1 and sys.argv[1] == "shot" else argv)
    if args.cpu:
        import numba

        numba.set_num_threads(1)
        global _clock
        _clock = time.process_time
    summary = []
    variants = [] if args.no_default else [("graph", [])]
    for v in args.variant:
        name, _, items = v.partition(":")
        if not name or not items:
            raise SystemExit(f"--variant {v}: expected NAME:node.param=value[,node.param=value...]")
        variants.append((name, [x for x in items.split(",") if x]))
    if not variants:
        raise SystemExit("--no-default needs at least one --variant")
    runs = []  # (seed or None, variant name, parameters)
    for seed in args.seeds or [None]:
        sets = [f"{n}.seed={seed}" for n in ("init", "correct", "final")] if seed is not None else []
        for name, items in variants:
            runs.append((seed, name, graph_params(sets + args.set + items)))
    several = len(runs) > 1
    print("parameters: " + "; ".join(f"{k} {v}" for k, v in runs[0][2].items() if v))
    for name, items in variants[0 if args.no_default else 1:]:
        print(f"variant {name}: " + ", ".join(items))
    labels_summary = []
    cases = [Case.bundled(s) for s in args.scenes]
    if args.eval:
        import tempfile

        work = Path(tempfile.mkdtemp(prefix="bench_shot_"))
        cases += [c for c in eval_cases(args.eval, work)
                  if args.photos is None or c.name.split("/")[-1] in args.photos]
    for size, case, (seed, variant, params) in ((z, c, r) for z in args.sizes for c in cases for r in runs):
        scene = case.name + (f" s{seed} {variant}" if several else "")
        out = args.frames_out / f"s{seed}_{variant}" if args.frames_out and several else args.frames_out
        if out:
            out.mkdir(parents=True, exist_ok=True)
        rows = shot(case, size, args.frames, args.warp_every, args.warp_sigma, params, out, args.edges,
                    memo=not args.no_memo, steps=args.steps, digest=args.digest)
        node_times = {k: list(v) for k, v in NODE_TIMES.items()}
        floor = attached_floor(case, size, case.first_frame(size, frame=1), args.warp_sigma) \
            if args.warp_every else {"lanczos4": float("nan"), "lowpass": float("nan")}
        case.clear()  # the per-frame proxies and guides of the independent runs
        print(f"\n## {scene} {size}² ({args.frames} frames)")
        print(f"{'frame':>5} {'seams':>6} {'detail':>7} {'share':>7} {'update s':>9} {'warp':>8} {'warp L4':>8} {'warp bil':>8}")
        for r in rows:
            if args.per_frame or r["frame"] in (1, 2, 8, 12, 16, 24, 32, 40, 48) or r["frame"] == args.frames:
                w = r["warp"]
                wp = f"{w['lowpass'][0] / max(w['lowpass'][1], 1e-12):8.4f}" if w else f"{'':>8}"
                wl = f"{w['lanczos4'][0] / max(w['lanczos4'][1], 1e-12):8.4f}" if w else f"{'':>8}"
                wb = f"{w['bilinear'][0] / max(w['bilinear'][1], 1e-12):8.4f}" if w else f"{'':>8}"
                upd = f"{r['update']:9.3f}" if r["update"] is not None else f"{'':>9}"
                print(f"{r['frame']:>5} {r['seams']:6.2f} {r['detail']:7.3f} {100 * r['share']:6.2f}% {upd} {wp} {wl} {wb}")
        shown = {r["frame"] for r in rows} if args.per_frame else {1, 12, 24, 48, args.frames}
        labels_summary += [dict(x, scene=scene, size=size, case=case.name, seed=seed, variant=variant)
                           for x in label_table(rows, shown)]
        if args.steps:
            g1 = rows[0]["steps"]
            print(f"{'frame':>5} {'label':<12} {'grad':>6} {'carried':>7} {'S(map)':>7}  (over frame 1's)")
            for r in rows[1:]:
                if r["frame"] in shown:
                    for name, st in r["steps"].items():
                        if name in g1 and name in r["labels"] and name in rows[0]["labels"]:
                            print(f"{r['frame']:>5} {name:<12} "
                                  f"{r['labels'][name]['grad'] / rows[0]['labels'][name]['grad']:6.3f} "
                                  f"{st['carried'] / g1[name]['carried']:7.3f} {st['smap'] / g1[name]['smap']:7.3f}")
        if args.edges:
            names = {int(t["id"]): t["name"] for t in case.source().meta["labels"]}
            print(f"{'frame':>5} {'label':<12} {'in':>7} {'in flag':>7} {'seam':>7} {'seam flag':>9}  (|d luma| per label pixel)")
            for r in rows:
                if r["frame"] in shown:
                    for k, e in r["edges"].items():
                        print(f"{r['frame']:>5} {names.get(k, str(k)):<12} {e['in']:7.4f} {e['in_f']:7.4f} "
                              f"{e['seam']:7.4f} {e['seam_f']:9.4f}")
        if args.digest:
            import hashlib

            shot_digest = hashlib.blake2b("".join(r["digest"] for r in rows).encode(), digest_size=8).hexdigest()
            print("digests (final plate, frames 1..): " + " ".join(r["digest"] for r in rows))
            print(f"shot digest {scene} {size}: {shot_digest}")
        if args.nodes and node_times:
            clock = "CPU s, one thread" if args.cpu else "wall s"
            print(f"{'node':<16} {'frame 2':>8} {'median 3..':>10} {'total 3..':>9}  ({clock})")
            for k, v in node_times.items():
                rest = v[1:]
                print(f"{k:<16} {v[0]:8.3f} {statistics.median(rest) if rest else float('nan'):10.3f} {sum(rest):9.2f}")
        later = rows[1:]
        ws = [r["warp"] for r in later if r["warp"]]
        ratio = {f: (float(np.mean([w[f][0] for w in ws])) / max(float(np.mean([w[f][1] for w in ws])), 1e-12)
                     if ws else float("nan")) for f in ("lowpass", "lanczos4", "bilinear")}
        s = {"scene": scene, "size": size, "seams_max": max(r["seams"] for r in rows),
             "detail_min": min(r["detail"] for r in rows), "share_median": statistics.median(r["share"] for r in later),
             "share_max": max(r["share"] for r in later),
             "update_median": statistics.median(r["update"] for r in later[1:]), "warp": ratio, "floor": floor,
             "update_total": sum(r["update"] for r in later)}
        summary.append(s)
    print("\n('attached', 'att. L4': the ratios, low-passed and not, of a texture exactly attached to the image, "
          "patch interiors: the measure's floor)")
    print("\n## Summary (bars: seams <= 1.5x, detail >= 0.9, warp (low-passed) <= 0.1, share median <= 10 %, update 1024² <= 0.5 s)")
    print(f"{'scene':<18} {'size':>5} {'seams max':>9} {'detail min':>10} {'warp':>8} {'warp L4':>8} {'warp bil':>8} "
          f"{'share med':>9} {'share max':>9} {'update med':>10} {'attached':>8} {'att. L4':>8}")
    for s in summary:
        print(f"{s['scene']:<18} {s['size']:>5} {s['seams_max']:8.2f}x {s['detail_min']:10.3f} {s['warp']['lowpass']:8.4f} {s['warp']['lanczos4']:8.4f} "
              f"{s['warp']['bilinear']:8.4f} {100 * s['share_median']:8.2f}% {100 * s['share_max']:8.2f}% "
              f"{s['update_median']:9.3f}s {s['floor']['lowpass']:8.4f} {s['floor']['lanczos4']:8.4f}")
    print("\n## Per label (bars: grad 0.9-1.1 at every frame, block at the last frame <= 1.1x, "
          "clump <= 0.2 % above frame 1's)")
    print(f"{'scene':<18} {'size':>5} {'label':<12} {'grad min':>8} {'grad max':>8} {'block last':>10} "
          f"{'block sd':>8} {'clump f1':>8} {'clump max':>9}")
    for x in labels_summary:
        flag = " <" if over_bars(x) else ""
        print(f"{x['scene']:<18} {x['size']:>5} {x['label']:<12} {x['grad_min']:8.3f} {x['grad_max']:8.3f} "
              f"{x['block_last']:10.3f} {x['block_sd']:8.3f} {100 * x['clump_first']:7.2f}% {100 * x['clump_max']:8.2f}%{flag}")
    if several:
        seed_table(labels_summary, [n for n, _ in variants])
    print("update frames, total s (" + ("CPU, one thread" if args.cpu else "wall") + "): "
          + ", ".join(f"{s['scene']} {s['size']} {s['update_total']:.1f}" for s in summary))
    print(f"peak RSS {peak_rss_mb():.0f} MiB")


if __name__ == "__main__":
    main(sys.argv[1:])
