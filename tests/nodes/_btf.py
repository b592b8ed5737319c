"""Shared by the BTF node tests: the bundled sample and a small capture of it."""
from pathlib import Path

from proxyshade.graph.testing import run_node

ROOT = Path(__file__).resolve().parents[2]
SCENE = str(ROOT / "samples/scenes/btf_bumps.usda")


def capture(size: int, slant_step: float, slant_max: float, tilts, shadow_size: int = 256):
    """BtfRender of btf_bumps: ``size``² views on the given grid."""
    return run_node("BtfRender", {"scene": SCENE, "size": size, "slant_step": slant_step, "slant_max": slant_max,
                                  "tilts": list(tilts), "shadow_size": shadow_size})
