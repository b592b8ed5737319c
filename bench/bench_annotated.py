"""Annotated-exemplar synthesis (docs/annotated.md): quality on the topiary ground truth
against three baselines, and the speed bars.

Quality: samples/scenes/topiary.yaml, a grass-textured sphere × N·L with a box cut out;
the box is resynthesized from the rest, following (N.X, N.Y, N·L). Metric (the paper's):
chi-square distance of 8-bin luminance histograms over 11×11 windows, against the render,
averaged over the box; and the normal-angle error (the angle between the normal at each
copied source pixel and the target's). Baselines: (a) image analogies (annotations as
weighted channels in the patch distance, one cluster, no ε-balls), (b) binary weights,
(c) a single cluster.

Speed: analysis (clusters, ε-balls, weights) ≤ 2 s, and a 512² target from a 512×384
gravel(0)/grass(1) exemplar with 2 clusters ≤ 30 s (medians, 2 cores).
"""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.harness import measure, table  # noqa: E402


def grey(path) -> np.ndarray:
    from proxyshade.io.images import read_u8
    from proxyshade.io.source import srgb_to_linear

    return srgb_to_linear(read_u8(path))[..., 1]


def render_topiary(cfg_path=ROOT / "samples/scenes/topiary.yaml") -> dict:
    """The topiary render: rgb (n, n, 3), normals, N·L, sphere mask, annotations (n, n, 3)."""
    cfg = yaml.safe_load(Path(cfg_path).read_text())
    n = cfg["size"]
    tex = grey(Path(cfg_path).parent / cfg["texture"])
    yy, xx = (np.mgrid[0:n, 0:n] + 0.5) / n * 2 - 1
    r2 = xx ** 2 + yy ** 2
    sphere = r2 < 0.96 ** 2
    nz = np.sqrt(np.clip(1 - r2 / 0.96 ** 2, 0, 1))
    N = np.stack([xx / 0.96, -yy / 0.96, nz], -1)
    N /= np.linalg.norm(N, axis=2, keepdims=True)
    L = np.asarray(cfg["sun"], float)
    L /= np.linalg.norm(L)
    nl = np.clip(N @ L, 0, 1)
    u = np.arctan2(N[..., 0], N[..., 2]) / (2 * np.pi) + 0.5
    v = np.arccos(np.clip(N[..., 1], -1, 1)) / np.pi
    tu, tv = cfg["tiles"]
    th, tw = tex.shape
    t = tex[(v * tv * th).astype(int) % th, (u * tu * tw).astype(int) % tw]
    shade = cfg["ambient"] + (1 - cfg["ambient"]) * nl
    grey_ = np.where(sphere, t * shade, 0.0)
    rgb = (grey_[..., None] * np.array([0.55, 0.85, 0.35])).astype(np.float32)
    ann = np.stack([(N[..., 0] + 1) / 2, (N[..., 1] + 1) / 2, nl], -1)
    return dict(rgb=rgb, N=N, nl=nl, sphere=sphere, ann=ann, cut=cfg["cut"])


def lum(rgb):
    return rgb @ np.array([0.2126, 0.7152, 0.0722])


def chi2_windows(a, b, mask, win=11, bins=8, lo=0.0, hi=None):
    """Mean chi-square distance of 8-bin luminance histograms over win×win windows
    (centres on a 4-pixel grid inside ``mask``)."""
    hi = hi if hi is not None else max(a[mask].max(), b[mask].max())
    qa = np.clip(((a - lo) / (hi - lo) * bins).astype(int), 0, bins - 1)
    qb = np.clip(((b - lo) / (hi - lo) * bins).astype(int), 0, bins - 1)
    r = win // 2
    out = []
    for i in range(r, a.shape[0] - r, 4):
        for j in range(r, a.shape[1] - r, 4):
            if not mask[i, j]:
                continue
            ha = np.bincount(qa[i - r:i + r + 1, j - r:j + r + 1].ravel(), minlength=bins) / win ** 2
            hb = np.bincount(qb[i - r:i + r + 1, j - r:j + r + 1].ravel(), minlength=bins) / win ** 2
            s = ha + hb
            out.append(0.5 * np.sum(np.where(s > 0, (ha - hb) ** 2 / np.where(s > 0, s, 1), 0)))
    return float(np.mean(out))


def quality(modes=("full", "analogies", "binary", "single"), seed=0, **kw) -> dict:
    from proxyshade.synthesis.annotated import AnnotatedParams, synthesize

    sc = render_topiary()
    r0, r1, c0, c1 = sc["cut"]
    usable = sc["sphere"].copy()
    usable[r0:r1, c0:c1] = False
    tgt_ann = sc["ann"][r0:r1, c0:c1]
    truth = sc["rgb"][r0:r1, c0:c1]
    tmask = sc["sphere"][r0:r1, c0:c1]
    res = {}
    for mode in modes:
        p = AnnotatedParams(mode=mode, seed=seed, bandwidth=kw.get("bandwidth", 0.15), eps=kw.get("eps", 0.1))
        t0 = time.perf_counter()
        r = synthesize(sc["rgb"], usable.astype(np.float32), sc["ann"], usable, tgt_ann, p)
        dt = time.perf_counter() - t0
        chi = chi2_windows(lum(r["rgb"]), lum(truth), tmask)
        Ns = sc["N"][r["sy"].astype(int), r["sx"].astype(int)]
        Nt = sc["N"][r0:r1, c0:c1]
        ang = np.degrees(np.arccos(np.clip((Ns * Nt).sum(-1), -1, 1)))[tmask].mean()
        res[mode] = dict(chi2=chi, angle=float(ang), missing=float(r["missing"][tmask].mean()),
                         clusters=r["n_clusters"], seconds=dt, rgb=r["rgb"])
    res["truth"] = truth
    return res


def transition(H=384, W=512, h=512, w=512):
    """512×384 exemplar: gravel (annotation 0) left, grass (1) right; a 512² ramp target."""
    g0 = grey(ROOT / "samples/textures/gravel.png")[:H, : W // 2]
    g1 = grey(ROOT / "samples/textures/grass.png")[:H, : W - W // 2]
    rgb = np.concatenate([g0[..., None] * [0.6, 0.55, 0.5], g1[..., None] * [0.4, 0.7, 0.3]], axis=1).astype(np.float32)
    ann = np.zeros((H, W, 1))
    ann[:, W // 2:] = 1.0
    tgt = np.repeat(np.linspace(0, 1, w)[None, :, None], h, axis=0)
    return rgb, ann, tgt


def figure(path: Path) -> None:
    """docs/img/annotated_topiary.png: the whole source sphere with the box cut (scaled to
    the box), then inside the box: the render (truth), the full method, (a) analogies,
    (b) binary, (c) single cluster; 2x nearest, sRGB."""
    from proxyshade.io.images import write_png
    from proxyshade.kernels.layout import srgb_encode

    sc = render_topiary()
    r0, r1, c0, c1 = sc["cut"]
    res = quality()
    src = sc["rgb"] * sc["sphere"][..., None]
    src[r0:r1, c0:c1] = 0.0  # the source the synthesis was given: the sphere less the box
    n = src.shape[0]
    idx = np.arange(r1 - r0) * n // (r1 - r0)
    tiles = [src[idx][:, idx], res["truth"]] + [res[m]["rgb"] for m in ("full", "analogies", "binary", "single")]
    pad = lambda t: np.pad(np.repeat(np.repeat(t, 2, 0), 2, 1), ((0, 0), (0, 6), (0, 0)), constant_values=1.0)
    img = np.ascontiguousarray(np.concatenate([pad(t) for t in tiles], 1), np.float32)
    write_png(path, np.clip(srgb_encode(img) * 255 + 0.5, 0, 255).astype(np.uint8))
    print(f"wrote {path}")


def main() -> None:
    from proxyshade.synthesis import annotated as sa

    if "--figure" in sys.argv:
        figure(ROOT / "docs/img/annotated_topiary.png")
        return

    print(f"load: {os.getloadavg()}")
    res = quality()
    print("\n## topiary ground truth: box resynthesized (lower is better)")
    print(f"{'method':<12} {'chi2':>8} {'angle °':>8} {'missing':>8} {'clusters':>8} {'s':>6}")
    for m in ("full", "analogies", "binary", "single"):
        q = res[m]
        print(f"{m:<12} {q['chi2']:8.4f} {q['angle']:8.2f} {q['missing']:8.2%} {q['clusters']:8d} {q['seconds']:6.2f}")
    f = res["full"]
    print(f"chi2 full < analogies: {f['chi2'] < res['analogies']['chi2']}, < binary: {f['chi2'] < res['binary']['chi2']}, "
          f"< single: {f['chi2'] < res['single']['chi2']}; angle full < analogies: {f['angle'] < res['analogies']['angle']}")

    rgb, ann, tgt = transition()
    usable = np.ones(rgb.shape[:2], bool)
    alpha = np.ones(rgb.shape[:2], np.float32)
    p = sa.AnnotatedParams(bandwidth=0.3)

    def analysis():
        cl, C, W, missing = sa.analyse(ann, usable, tgt, p)  # clusters, ε-balls, eq. 2 weights
        assert C == 2, C
        return W

    def full():
        r = sa.synthesize(rgb, alpha, ann, usable, tgt, p)
        assert r["n_clusters"] == 2
        return r

    table("annotated synthesis speed", [
        ("analysis (clusters, ε-balls, weights)", measure(analysis, repeat=3), 2.0),
        ("512² target, 512x384 exemplar, 2 clusters", measure(full, repeat=3, warmup=1), 30.0),
    ])
    print(f"load: {os.getloadavg()}")


if __name__ == "__main__":
    main()
