"""Shared by the edit tests: the lake scene copied, built, run, then stroked so that an
island rises in the lake, and run again."""
from __future__ import annotations

import shutil
from pathlib import Path

from proxyshade.scene.edit import add_stroke

ROOT = Path(__file__).resolve().parents[2]


def island_edit(d: Path, run) -> dict:
    """``run(d)`` -> (report, plates, graph) before and after the island's stroke, in ``d``."""
    shutil.copy(ROOT / "samples" / "scenes" / "lake.yaml", d / "lake.yaml")
    add_stroke(d / "lake.yaml", "Ground", (150, 150), 1.0, 0.0)  # builds lake.usda (a stroke of nothing)
    r1, before, g = run(d)
    add_stroke(d / "lake.yaml", "Ground", (5, -40), 7.0, 9.0)   # an island rises in the lake
    r2, after, _ = run(d)
    return {"before": before, "after": after, "first": r1, "update": r2, "graph": g, "dir": d}
