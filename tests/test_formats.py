"""Production formats: any output size and aspect through the first-frame graph, the AOVs
and header attributes a compositor reads."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import OpenImageIO as oiio
import pytest

from proxyshade import Graph
from proxyshade.io.exr import read_plate
from proxyshade.io.source import load_source
from proxyshade.kernels.lookup import lookup

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("size", [(192, 108), (200, 84), (96, 160)])  # 16:9, 2.39:1 scope, portrait
def test_first_frame_at_any_size_and_aspect(tmp_path, size):
    w, h = size
    g = Graph.load(ROOT / "graphs" / "first_frame.yaml", cache=tmp_path / "cache",
                   overrides=[f"proxy.resolution=[{w},{h}]", "guide.size=64", "guide.start=16",
                              "preview.enabled=false", "proxy_labels.enabled=false", "detail_labels.enabled=false"],
                   variables={"out": str(tmp_path)})
    g.run([1])
    exr = tmp_path / "lake_renoir.0001.exr"
    plate = read_plate(exr)
    assert plate.shape == (h, w)
    for c in ("R", "G", "B", "Z", "P.X", "N.X", "N.Y", "N.Z", "label.id", "object.id", "patch.id", "source.x"):
        assert c in plate, c
    assert any(c.startswith("CryptoLabel00.") for c in plate.names())
    assert any(c.startswith("CryptoObject00.") for c in plate.names())
    assert np.isfinite(plate.rgb()).all()
    assert plate["label.id"].dtype == np.uint32 and plate["object.id"].dtype == np.uint32
    src = load_source(ROOT / "samples" / "renoir" / "source.yaml")
    fidelity = (lookup(src["label.id"], plate["source.x"], plate["source.y"]) == plate["label.id"]).mean()
    assert fidelity >= 0.995
    spec = oiio.ImageInput.open(str(exr)).spec()
    assert spec.getattribute("oiio:ColorSpace") == "lin_rec709_scene"
    assert spec.getattribute("chromaticities") is not None
    assert any(a.name.endswith("/manifest") for a in spec.extra_attribs)  # Cryptomatte manifest
