"""Shared driver for the temporal tests: a sample camera move run frame by frame with
run_node (first frame: PatchInit -> Correct -> Magnify -> Poisson on the proxy guide;
later frames: ConsistentDepth -> Reproject -> Resynthesize -> Poisson with keep)."""
from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from proxyshade.graph.plate import Plate
from proxyshade.graph.testing import run_node
from proxyshade.io.source import load_source

ROOT = Path(__file__).resolve().parents[2]
SCENES = {"lake": "renoir", "cliffs": "monet", "farm": "creek"}


@functools.lru_cache(maxsize=None)
def source(sample: str) -> Plate:
    return load_source(ROOT / "samples" / sample / "source.yaml")


@functools.lru_cache(maxsize=None)
def proxy(scene: str, frame: int, size: int = 128) -> Plate:
    return run_node("ProxyRender", {"scene": str(ROOT / "samples" / "scenes" / f"{scene}.usda"),
                                    "resolution": [size, size]}, {"source": source(SCENES[scene])}, frame=frame,
                    name="proxy")


@functools.lru_cache(maxsize=None)
def detailed(scene: str, frame: int = 1, size: int = 128) -> tuple[Plate, Plate]:
    """GuideSynth's detailed guide (synthesis at size / 4) and DepthExtend's depth of a frame."""
    return detail_of(proxy(scene, frame, size), source(SCENES[scene]), frame, size)


def detail_of(pr: Plate, src: Plate, frame: int, size: int) -> tuple[Plate, Plate]:
    """``detailed`` of a proxy plate ``pr`` of any scene and source (bench_shot's eval shots)."""
    s = max(16, size // 4)
    g = run_node("GuideSynth", {"size": s, "start": min(s, max(16, s // 4)), "seed": 1},
                 {"proxy": pr, "source": src}, frame=frame, name="guide")
    d = run_node("DepthExtend", {}, {"proxy": pr, "guide": g}, frame=frame, name="depth")
    return g, d


def first_frame(scene: str, size: int = 128, seed: int = 0, frame: int = 1, guide: Plate | None = None,
                detail: bool = False) -> Plate:
    """Full synthesis of one frame on the proxy's labels, or with ``detail`` on GuideSynth's
    detailed guide with DepthExtend's depth."""
    g = guide if guide is not None else (detailed(scene, frame, size)[1] if detail else proxy(scene, frame, size))
    return synthesize(source(SCENES[scene]), g, seed)


def synthesize(src: Plate, g: Plate, seed: int = 0, params: dict | None = None, final: str = "final") -> Plate:
    """PatchInit -> Correct -> Magnify -> Poisson on the guide ``g``: with ``params`` each node's
    parameters (keys init, correct, magnify, first), else the defaults with ``seed``."""
    p = params or {"init": {"seed": seed}, "correct": {"seed": seed}, "magnify": {}, "first": {}}
    init = run_node("PatchInit", p["init"], {"guide": g, "source": src}, name="init")
    cor = run_node("Correct", p["correct"], {"init": init, "source": src}, name="correct")
    mag = run_node("Magnify", p["magnify"], {"synth": cor, "source": src, "guide": g, "depth": g}, name="magnify")
    return run_node("Poisson", p["first"], {"image": mag, "source": src}, name=final)


def run_move(scene: str, frames, size: int = 128, reproject: dict | None = None, resynth: dict | None = None,
             first: int = 1, detail: bool = False) -> list[dict]:
    """Frames first..last of a scene's move; per frame the plates of each stage."""
    src = source(SCENES[scene])
    p0 = proxy(scene, first, size)
    f0 = first_frame(scene, size, frame=first, detail=detail)
    g0, d0 = detailed(scene, first, size) if detail else (p0, p0)
    out = []
    prev = None
    for fr in frames:
        pN = proxy(scene, fr, size)
        cd = run_node("ConsistentDepth", {}, {"proxy": pN, "guide": g0, "depth": d0, "ref_proxy": p0}, frame=fr,
                      first_frame=first, name="cd")
        rp = run_node("Reproject", reproject or {}, {"depth": cd, "prev": prev, "first": f0, "source": src},
                      frame=fr, first_frame=first, name="reproject")
        fin = run_node("Resynthesize", resynth or {}, {"image": rp, "source": src}, frame=fr, first_frame=first,
                       name="final")
        out.append({"frame": fr, "proxy": pN, "cd": cd, "reproject": rp, "final": fin})
        prev = fin
    return out


# -- an analytic scene: a wall (label 1) at z = -wall, a sphere (label 2), sky (label 3) ---
LABELS = [{"name": "wall", "id": 1, "color": [120, 120, 120]}, {"name": "ball", "id": 2, "color": [200, 60, 60]},
          {"name": "sky", "id": 3, "color": [90, 140, 230]}]


def camera(size=64, f=40.0, pos=(0.0, 0.0, 0.0), frame=1, yaw=0.0):
    from proxyshade.io.usd import CameraInfo

    M = np.eye(4)
    c, s = np.cos(yaw), np.sin(yaw)
    M[:3, :3] = [[c, 0, s], [0, 1, 0], [-s, 0, c]]
    M[:3, 3] = pos
    return CameraInfo("/cam", frame, width=size, height=size, fx=f, fy=f, cx=size / 2, cy=size / 2, near=0.1, far=1000.0,
                      camera_to_world=M)


def render(cam, sphere=(0.0, 0.0, -10.0), radius=2.0, wall=20.0, wall_half=None) -> Plate:
    """A ProxyRender-like plate of the analytic scene through ``cam`` (CameraInfo)."""
    col, row = cam.pixel_grid()
    d_cam = np.stack([(col - cam.cx) / cam.fx, -(row - cam.cy) / cam.fy, -np.ones_like(col)], -1)
    R = cam.camera_to_world[:3, :3]
    o = cam.camera_to_world[:3, 3]
    d = d_cam @ R.T
    Z = np.full(col.shape, np.inf)
    lab = np.full(col.shape, 3, np.uint32)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (-wall - o[2]) / d[..., 2]
    P = o + t[..., None] * d
    hit = t > 0
    if wall_half is not None:
        hit &= (np.abs(P[..., 0]) <= wall_half) & (np.abs(P[..., 1]) <= wall_half)
    Z[hit] = t[hit]  # d has camera-space z = -1: t is the depth
    lab[hit] = 1
    if sphere is not None:
        oc = o - np.asarray(sphere)
        a = (d * d).sum(-1)
        b = 2 * (d * oc).sum(-1)
        c = (oc * oc).sum() - radius * radius
        disc = b * b - 4 * a * c
        ts = (-b - np.sqrt(np.maximum(disc, 0))) / (2 * a)
        on = (disc > 0) & (ts > 0) & (ts < Z)
        Z[on] = ts[on]
        lab[on] = 2
    fin = np.isfinite(Z)
    P = o + np.where(fin, Z, 0)[..., None] * d
    ch = {"label.id": lab, "Z": Z.astype(np.float32), "object.id": lab.copy()}
    for k, a in enumerate("XYZ"):
        ch[f"P.{a}"] = np.where(fin, P[..., k], 0).astype(np.float32)
    return Plate(ch, {"labels": LABELS, "camera": cam.to_meta()})


@functools.lru_cache(maxsize=None)
def toy_source(size: int = 96) -> Plate:
    """A source photo for the analytic scene: three label bands with smooth random texture."""
    rng = np.random.default_rng(5)
    lab = np.ones((size, size), np.uint32)
    lab[:, size // 3:] = 2
    lab[:, 2 * size // 3:] = 3
    noise = rng.random((size // 4 + 1, size // 4 + 1, 3)).astype(np.float32)
    tex = np.kron(noise, np.ones((4, 4, 1), np.float32))[:size, :size]
    tex = (0.2 + 0.6 * tex + 0.1 * lab[..., None]).astype(np.float32)
    return Plate({"R": tex[..., 0].copy(), "G": tex[..., 1].copy(), "B": tex[..., 2].copy(), "label.id": lab},
                 {"labels": LABELS, "source": {}})


def state_plate(proxy_plate: Plate, seed: int = 0, scale: float = 1.0) -> Plate:
    """A 'previous final frame' over a proxy plate: identity map into the toy source
    shifted per label, random colours, one patch per label."""
    from proxyshade.kernels.lookup import lookup

    H, W = proxy_plate.shape
    i, j = np.mgrid[0:H, 0:W].astype(np.float32)
    lab = proxy_plate["label.id"]
    sx = (j % 30 + 32 * (lab.astype(np.float32) - 1)).astype(np.float32)
    sy = (i % 90).astype(np.float32)
    rgb = lookup(toy_source().rgb(), sx, sy)
    ch = {"R": rgb[..., 0].copy(), "G": rgb[..., 1].copy(), "B": rgb[..., 2].copy(), "source.x": sx, "source.y": sy,
          "patch.id": (lab * 100 + (j // 30).astype(np.uint32)).astype(np.uint32), "label.id": lab,
          "Z": proxy_plate["Z"]}
    meta = dict(proxy_plate.meta)
    meta["synthesis"] = {"factor": 4, "scale": scale, "exemplar_factor": 4.0 * scale}
    meta["source"] = {}
    return Plate(ch, meta)


def coherence_metrics(scene: str, frames, size: int = 128, reproject: dict | None = None,
                      filters=("bilinear", "cubic"), detail: bool = False) -> dict:
    """Run the move coherently and frame by frame independently; per frame the share of
    pixels resynthesized and the warp error of both over the pixels the coherent run kept
    (flag 0 and a valid reprojection: same label and surface in the previous frame)."""
    from proxyshade.io.usd import CameraInfo
    from proxyshade.kernels import reproject as kr

    frames = list(frames)
    run = run_move(scene, frames, size=size, reproject=reproject, detail=detail)
    indep = {fr: first_frame(scene, size, seed=fr, frame=fr, detail=detail) for fr in frames}
    shares = []
    coherent = {f: [] for f in filters}
    independent = {f: [] for f in filters}
    for a, b in zip(run[:-1], run[1:]):
        cd, flag = b["cd"], b["reproject"]["flag"]
        c1 = CameraInfo.from_meta(cd.meta["camera"])
        c0 = CameraInfo.from_meta(a["final"].meta["camera"])
        w1 = kr.inverse_depth(cd["Z"])
        u, v, q, ok = kr.transfer(w1, kr.relative_matrix(c1, c0), kr.intrinsics(c1), kr.intrinsics(c0), c0.near)
        prev = a["final"]
        z = np.zeros(prev.shape, np.float32)
        valid = kr.gather_prev(u, v, q, ok, lab=np.ascontiguousarray(cd["label.id"]),
                               prev_w=kr.inverse_depth(prev["Z"]), prev_lab=np.ascontiguousarray(prev["label.id"]),
                               prev_patch=np.ascontiguousarray(prev["patch.id"]), prev_sx=z, prev_sy=z,
                               prev_res=np.zeros(prev.shape + (3,), np.float32), prev_d=z, tol=0.02, scale=1.0)[0]
        mask = valid & (flag == 0)
        shares.append(float((flag > 0).mean()))
        for f in filters:
            coherent[f].append(kr.warp_error(b["final"].rgb(), prev.rgb(), u, v, mask, f))
            independent[f].append(kr.warp_error(indep[b["frame"]].rgb(), indep[a["frame"]].rgb(), u, v, mask, f))
    return {"shares": shares, "coherent": coherent, "independent": independent,
            "median_share": float(np.median(shares)),
            "ratio": {f: float(np.mean(coherent[f]) / max(np.mean(independent[f]), 1e-12)) for f in filters}}
