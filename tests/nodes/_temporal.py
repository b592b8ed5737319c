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


def first_frame(scene: str, size: int = 128, seed: int = 0, frame: int = 1, guide: Plate | None = None) -> Plate:
    """Full synthesis of one frame on the proxy's labels (GuideSynth stands aside here)."""
    src = source(SCENES[scene])
    g = guide if guide is not None else proxy(scene, frame, size)
    init = run_node("PatchInit", {"seed": seed}, {"guide": g, "source": src}, name="init")
    cor = run_node("Correct", {"seed": seed}, {"init": init, "source": src}, name="correct")
    mag = run_node("Magnify", {}, {"synth": cor, "source": src, "guide": g, "depth": g}, name="magnify")
    return run_node("Poisson", {}, {"image": mag, "source": src}, name="final")


def run_move(scene: str, frames, size: int = 128, reproject: dict | None = None, resynth: dict | None = None,
             first: int = 1) -> list[dict]:
    """Frames first..last of a scene's move; per frame the plates of each stage."""
    src = source(SCENES[scene])
    p0 = proxy(scene, first, size)
    f0 = first_frame(scene, size, frame=first)
    out = []
    prev = None
    for fr in frames:
        pN = proxy(scene, fr, size)
        cd = run_node("ConsistentDepth", {}, {"proxy": pN, "guide": p0, "ref_proxy": p0}, frame=fr, first_frame=first,
                      name="cd")
        rp = run_node("Reproject", reproject or {}, {"depth": cd, "prev": prev, "first": f0, "source": src},
                      frame=fr, first_frame=first, name="reproject")
        rs = run_node("Resynthesize", resynth or {}, {"image": rp, "source": src}, frame=fr, first_frame=first,
                      name="resynth")
        fin = run_node("Poisson", {}, {"image": rs, "keep": rs, "source": src}, frame=fr, first_frame=first,
                       name="final")
        out.append({"frame": fr, "proxy": pN, "cd": cd, "reproject": rp, "resynth": rs, "final": fin})
        prev = fin
    return out
