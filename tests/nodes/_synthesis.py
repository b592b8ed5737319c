"""Shared inputs for the synthesis node tests: the samples' sources and their second
label layouts as guides, and the PatchInit -> Correct -> Magnify -> Poisson chain run
once per (sample, size) and reused."""
from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from proxyshade.graph.node import Node, Param
from proxyshade.graph.plate import Plate
from proxyshade.graph.testing import run_node
from proxyshade.io.source import labels_from_map, load_source
from proxyshade.kernels.lookup import lookup

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = ("renoir", "monet", "creek")


@functools.lru_cache(maxsize=None)
def source(sample: str) -> Plate:
    return load_source(ROOT / "samples" / sample / "source.yaml")


def resize_nearest(a: np.ndarray, shape) -> np.ndarray:
    H, W = shape
    return a[(np.arange(H) * a.shape[0] // H)][:, (np.arange(W) * a.shape[1] // W)]


@functools.lru_cache(maxsize=None)
def guide(sample: str, shape=(512, 512), own: bool = False) -> Plate:
    """The sample's layout (or with ``own`` its own label map, mirrored left-right so the
    synthesis cannot just copy the photo) as a guide of ``shape``."""
    src = source(sample)
    if own:
        ids = src["label.id"][:, ::-1]
    else:
        ids, _ = labels_from_map(Path(src.meta["source"]["layout"]), src.meta["labels"], far_distance=100.0,
                                 max_far_fraction=0.05, where="test")
    return Plate({"label.id": resize_nearest(ids, shape).astype(np.uint32)}, {"labels": src.meta["labels"]})


@functools.lru_cache(maxsize=None)
def chain(sample: str, shape=(512, 512), own: bool = False, seed: int = 0) -> dict[str, Plate]:
    src, g = source(sample), guide(sample, shape, own)
    init = run_node("PatchInit", {"seed": seed}, {"guide": g, "source": src}, name="init")
    cor = run_node("Correct", {"seed": seed}, {"init": init, "source": src}, name="correct")
    mag = run_node("Magnify", {}, {"synth": cor, "source": src, "guide": g}, name="magnify")
    poi = run_node("Poisson", {}, {"image": mag, "source": src}, name="poisson")
    return {"source": src, "guide": g, "init": init, "correct": cor, "magnify": mag, "poisson": poi}


def source_labels_through_map(src: Plate, plate: Plate) -> np.ndarray:
    """The source's label id at each pixel's source.x/y (the one lookup function)."""
    return lookup(src["label.id"], plate["source.x"], plate["source.y"])


def label_fidelity(src: Plate, plate: Plate) -> float:
    return float((source_labels_through_map(src, plate) == plate["label.id"]).mean())


class Given(Node, register=False):
    """The plate in ``plates`` under its ``name_`` parameter: an upstream node of a test graph."""

    name_ = Param(str, "")
    plates: dict = {}

    def compute(self, ctx):
        return Given.plates[ctx.p.name_]


def spy_read_back(monkeypatch) -> list:
    """``Cache.read_back`` wrapped for a test: the list it returns gets the sorted channel
    names of every read back, in order."""
    from proxyshade.graph.cache import Cache

    asked, read_back = [], Cache.read_back

    def spy(self, key, names):
        asked.append(sorted(names))
        return read_back(self, key, names)

    monkeypatch.setattr(Cache, "read_back", spy)
    return asked
