"""BtfRender: a synthetic BTF capture of a heightfield (views, drift, shadows, meta)."""
import math
from pathlib import Path

import numpy as np
import pytest

from proxyshade.errors import UserError
from proxyshade.graph.testing import run_node
from proxyshade.scene.build import build_stage, write_usda


def _scene(tmp_path, strokes, light=None, name="one"):
    spec = {"name": name, "frames": [1, 1],
            "terrains": [{"name": "Sample", "label": "bumps", "cells": [80, 80], "extent": [[-1, -1], [1, 1]],
                          "height": 0.0, "strokes": strokes}]}
    if light:
        spec["light"] = light
    return str(write_usda(build_stage(spec), tmp_path / f"{name}.usda"))


def _view(plate, n):
    return np.stack([plate[f"v{n}.{c}"] for c in "RGB"], -1)


def test_views_follow_the_grid_and_a_point_drifts_by_its_height(tmp_path):
    # one tall narrow bump, lit from high up, albedo rising with height: brightest at the peak
    h, c = 0.3, (0.1, -0.05)
    scene = _scene(tmp_path, [{"centre": list(c), "radius": 0.08, "amount": h}],
                   {"name": "Sun", "elevation": 60, "azimuth": 0, "intensity": 0.0})
    out = run_node("BtfRender", {"scene": scene, "slant_step": 30, "slant_max": 60, "tilts": [0, 45, 90],
                                 "size": 64, "window": 1.6, "ambient": 1.0, "plane": 0.0})
    views = out.meta["views"]
    assert [(v["slant"], v["tilt"]) for v in views] == [(0, 0), (30, 0), (30, 45), (30, 90), (60, 0), (60, 45),
                                                         (60, 90)]
    pix = out.meta["btf"]["pixel"]
    assert pix == pytest.approx(1.6 / 64)
    assert out.meta["btf"]["heights"][1] == pytest.approx(h, rel=0.02)
    x0, z0 = out.meta["btf"]["origin"]
    for n, v in enumerate(views):
        img = _view(out, n)[..., 0]
        i, j = np.unravel_index(np.argmax(img), img.shape)
        t = math.tan(math.radians(v["slant"]))
        ex = (c[0] - h * t * math.cos(math.radians(v["tilt"])) - x0) / pix - 0.5
        ez = (c[1] - h * t * math.sin(math.radians(v["tilt"])) - z0) / pix - 0.5
        # the drift is up to 21 pixels; the brightest pixel of the sheared peak is within 1.5 of its prediction
        assert abs(j - ex) <= 1.5 and abs(i - ez) <= 1.5, (n, v, (i, j), (ez, ex))


def test_a_bump_shadows_the_ground_away_from_the_sun(tmp_path):
    # sun low from +x (azimuth 90 turns the light's -z toward -x: rays travel toward -x)
    scene = _scene(tmp_path, [{"centre": [0, 0], "radius": 0.06, "amount": 0.25}],
                   {"name": "Sun", "elevation": 25, "azimuth": 90, "intensity": 3.0, "color": [1, 1, 1]}, "lit")
    out = run_node("BtfRender", {"scene": scene, "slant_step": 30, "slant_max": 30, "tilts": [0],
                                 "size": 64, "window": 1.6, "ambient": 0.1, "shadow_size": 512})
    img = _view(out, 0)[..., 1]
    from proxyshade.io import usd
    L = np.array(usd.distant_light(usd.open_stage(scene), 1)["direction"])
    # flat ground 0.3 to 0.4 m from the bump, on the side the rays travel to and on the other side
    x0 = out.meta["btf"]["origin"][0]
    pix = out.meta["btf"]["pixel"]
    row = img[32]
    d = np.sign(L[0])
    behind = row[int((0.35 * d - x0) / pix)]
    before = row[int((-0.35 * d - x0) / pix)]
    assert before > 3 * behind  # lit ground against ground in the bump's shadow
    assert behind > 0  # the ambient term still lights it


def test_scene_without_a_sun_is_a_one_line_error(tmp_path):
    scene = _scene(tmp_path, [], None, "dark")
    with pytest.raises(UserError, match=r"node: .*DistantLight.*add a light"):
        run_node("BtfRender", {"scene": scene, "size": 16, "slant_max": 10, "slant_step": 10, "tilts": [0]})


def test_same_stack_with_one_and_two_threads(tmp_path):
    import numba

    scene = _scene(tmp_path, [{"centre": [0, 0], "radius": 0.1, "amount": 0.2}],
                   {"name": "Sun", "elevation": 30, "azimuth": 20}, "det")
    args = ("BtfRender", {"scene": scene, "size": 32, "slant_max": 40, "slant_step": 20, "tilts": [0, 90]})
    numba.set_num_threads(1)
    a = run_node(*args)
    numba.set_num_threads(2)
    b = run_node(*args)
    assert a.equals(b)


def test_bundled_btf_bumps_is_what_its_yaml_builds():
    import re
    from pathlib import Path

    import yaml

    root = Path(__file__).resolve().parents[2] / "samples/scenes"
    spec = yaml.safe_load((root / "btf_bumps.yaml").read_text())
    stage = build_stage(spec)
    rounded = lambda t: re.sub(r"-?\d+\.\d+(?:e[-+]?\d+)?", lambda m: f"{float(m.group()):.10g}", t)  # noqa: E731
    assert rounded(stage.GetRootLayer().ExportToString()) == rounded((root / "btf_bumps.usda").read_text())
    from proxyshade.scene.bumps import bump_strokes

    strokes = bump_strokes(spec["terrains"][0])
    b = spec["terrains"][0]["bumps"]
    assert len(strokes) == b["grid"][0] * b["grid"][1]
    cell = 2.0 / b["grid"][0]
    for k, s in enumerate(strokes):  # each bump stays within its jittered cell, radius and amount in range
        i, j = divmod(k, b["grid"][0])
        assert abs(s["centre"][0] - (-1 + (j + 0.5) * cell)) <= b["jitter"] * cell + 1e-12
        assert abs(s["centre"][1] - (-1 + (i + 0.5) * cell)) <= b["jitter"] * cell + 1e-12
        assert b["radius"][0] <= s["radius"] <= b["radius"][1] and b["amount"][0] <= s["amount"] <= b["amount"][1]
    assert len({round(s["radius"], 9) for s in strokes}) == len(strokes)  # random widths


def test_gravel_albedo_is_the_texture_over_the_sample(tmp_path):
    from proxyshade.io.images import read_u8
    from proxyshade.io.source import srgb_to_linear
    from proxyshade.kernels.lookup import lookup

    # a flat sample under a sun straight above (E = 1, white), no ambient: each pixel is albedo / π
    scene = _scene(tmp_path, [], {"name": "Sun", "elevation": 90, "azimuth": 0, "intensity": 1.0,
                                  "color": [1, 1, 1]}, "flat")
    # pixel centres on the mesh's vertices (80 cells over 2 m, 0.025 m apart): each pixel is one vertex's albedo
    out = run_node("BtfRender", {"scene": scene, "slant_step": 30, "slant_max": 30, "tilts": [0], "size": 64,
                                 "window": 1.6, "centre": [0.0125, 0.0125], "ambient": 0.0, "albedo": "gravel"})
    tex = srgb_to_linear(read_u8(Path(__file__).resolve().parents[2] / "samples/textures/gravel.png"))
    pix, (x0, z0) = out.meta["btf"]["pixel"], out.meta["btf"]["origin"]
    cols = (x0 + (np.arange(64) + 0.5) * pix + 1.0) / 2.0 * tex.shape[1] - 0.5  # the 2 m sample spans the texture
    rows = (z0 + (np.arange(64) + 0.5) * pix + 1.0) / 2.0 * tex.shape[0] - 0.5
    want = lookup(tex, *np.meshgrid(cols, rows))
    np.testing.assert_allclose(_view(out, 0) * np.pi, want, atol=1e-5)
    assert want.std() > 0.02  # a texture, not a constant


def test_the_key_follows_an_edit_of_a_sublayer(tmp_path):
    """The capture's cache key covers the meshes and sun of every layer the stage composes:
    moving a bump in a sublayer changes it; an unchanged scene keeps it."""
    from proxyshade.graph.graph import Graph

    geo = _scene(tmp_path, [{"centre": [0.0, 0.0], "radius": 0.1, "amount": 0.1}],
                 {"name": "Sun", "elevation": 40, "azimuth": 0}, name="geo")
    (tmp_path / "shot.usda").write_text('#usda 1.0\n(\n    subLayers = [@./geo.usda@]\n)\n')
    root = Path(__file__).resolve().parents[2]

    def key():
        g = Graph.load(root / "graphs" / "btf.yaml", cache=str(tmp_path / "cache"),
                       variables={"scene": str(tmp_path / "shot.usda"), "out": str(tmp_path / "out")})
        return g.plan([1]).keys[("capture", 1)]

    first = key()
    assert key() == first
    _scene(tmp_path, [{"centre": [0.2, 0.0], "radius": 0.1, "amount": 0.1}],
           {"name": "Sun", "elevation": 40, "azimuth": 0}, name="geo")
    assert Path(geo).is_file() and key() != first
