"""DepthExtend: proxy depth kept where labels agree, carried to new borders, P consistent."""
from pathlib import Path

import numpy as np
import pytest

from proxyshade.errors import NodeInputError
from proxyshade.graph.plate import Plate
from proxyshade.graph.testing import run_node
from proxyshade.io.usd import CameraInfo

ROOT = Path(__file__).resolve().parents[2]


def test_extends_depth_on_the_lake_scene():
    src = run_node("SourceRead", {"table": "samples/renoir/source.yaml"}, graph_dir=ROOT)
    proxy = run_node("ProxyRender", {"scene": "samples/scenes/lake.usda", "resolution": [256, 256]}, {"source": src},
                     graph_dir=ROOT)
    guide = run_node("GuideSynth", {"size": 128, "start": 32}, {"proxy": proxy, "source": src})
    out = run_node("DepthExtend", {}, {"proxy": proxy, "guide": guide})
    same = proxy["label.id"] == guide["label.id"]
    assert np.array_equal(out["Z"][same], proxy["Z"][same])
    sky = out["label.id"] == 2
    assert np.isinf(out["Z"][sky & same]).all()
    changed = ~same & ~sky  # land pixels where the proxy had another label: depth of a nearby same-label pixel
    assert changed.any() and np.isfinite(out["Z"][changed]).all()
    src_idx = out["depth.src"][changed].astype(np.int64) - 1
    assert (proxy["label.id"].reshape(-1)[src_idx] == out["label.id"][changed]).mean() > 0.99
    cam = CameraInfo.from_meta(proxy.meta["camera"])
    c, r, d = cam.project(np.stack([out["P.X"], out["P.Y"], out["P.Z"]], -1)[changed])
    np.testing.assert_allclose(d, out["Z"][changed], rtol=1e-4)


def test_size_mismatch_is_an_error():
    a = Plate({"label.id": np.zeros((4, 4), np.uint32), "Z": np.ones((4, 4), np.float32)})
    b = Plate({"label.id": np.zeros((8, 8), np.uint32)})
    with pytest.raises(NodeInputError, match="^depth: guide is 8x8 but proxy is 4x4"):
        run_node("DepthExtend", {}, {"proxy": a, "guide": b}, name="depth")


def test_without_a_camera_P_comes_from_the_same_pixel_as_Z():
    rng = np.random.default_rng(0)
    lab = np.zeros((24, 32), np.uint32)
    lab[:, 16:] = 1
    z = rng.uniform(1, 2, lab.shape).astype(np.float32)
    P = {f"P.{a}": rng.random(lab.shape).astype(np.float32) for a in "XYZ"}
    proxy = Plate({"label.id": lab, "Z": z, **P})
    g = lab.copy()
    g[:, 13:16] = 1  # the detailed guide moves the border three pixels left
    out = run_node("DepthExtend", {}, {"proxy": proxy, "guide": proxy.with_channels({"label.id": g})})
    moved = g != lab
    src = out["depth.src"].astype(np.int64) - 1
    assert (lab.reshape(-1)[src[moved]] == 1).all()  # depth from a pixel that is label 1 in both
    assert (src[moved] % 32 == 16).all()  # the nearest one: the proxy's first label-1 column
    for a in "XYZ":
        np.testing.assert_array_equal(out[f"P.{a}"][moved], P[f"P.{a}"].reshape(-1)[src[moved]])
        np.testing.assert_array_equal(out[f"P.{a}"][~moved], P[f"P.{a}"][~moved])
    np.testing.assert_array_equal(out["Z"][moved], z.reshape(-1)[src[moved]])
    np.testing.assert_array_equal(out["Z"][~moved], z[~moved])
