"""BtfShade: per pixel, the view of the pixel's view direction in the surface frame, read at
its planar texture coordinates; the label selects the pixels; bad inputs are one line."""
import math

import numpy as np
import pytest

from proxyshade.errors import UserError
from proxyshade.graph.testing import run_node
from proxyshade.synthesis import btf
from tests.nodes._btf import ROOT

SHOT = str(ROOT / "samples/scenes/btf_move.usda")
TILTS = [0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0]


@pytest.fixture(scope="module")
def proxies():
    src = run_node("SourceRead", {"table": str(ROOT / "samples/renoir/source.yaml")})
    return {f: run_node("ProxyRender", {"scene": SHOT, "resolution": [40, 40], "labels": {"bumps": "vegetation"}},
                        {"source": src}, frame=f) for f in (1, 12)}


def _stack(colour, size=8, step=10.0, smax=70.0):
    views = btf.view_grid(step, smax, TILTS)
    imgs = np.stack([np.broadcast_to(np.asarray(colour(v), np.float32), (size, size, 3)) for v in views])
    return btf.stack_plate(imgs, views, {"pixel": 0.01, "plane": 0.0, "origin": [0.0, 0.0]})


@pytest.mark.parametrize("frame", [1, 12])
def test_each_pixel_gets_the_view_of_its_direction(proxies, frame):
    """Views coloured by their own direction (R = slant / 90, G = slant · tilt, both exact
    under bilinear interpolation): the shaded colour is the direction from the pixel's
    surface point toward the camera, computed here from P and the camera's matrix."""
    proxy = proxies[frame]
    stack = _stack(lambda v: (v["slant"] / 90.0, v["slant"] * v["tilt"] / (90.0 * 360.0), 0.5))
    out = run_node("BtfShade", {"label": "bumps", "background": [0.1, 0.2, 0.3]}, {"stack": stack, "proxy": proxy})
    on = out["A"] == 1
    assert on.sum() > 300 and (on == (proxy["object.id"] > 0)).all()
    eye = np.array(proxy.meta["camera"]["camera_to_world"])[:3, 3]
    d = eye - np.stack([proxy[f"P.{a}"] for a in "XYZ"], -1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    slant = np.degrees(np.arccos(d[..., 1]))
    tilt = np.degrees(np.arctan2(d[..., 2], d[..., 0])) % 360.0
    inside = on & (slant <= 70.0) & (tilt <= 315.0)
    assert inside.sum() > 300
    np.testing.assert_allclose(out["R"][inside], slant[inside] / 90.0, atol=2e-4)
    np.testing.assert_allclose(out["G"][inside], (slant * tilt)[inside] / (90.0 * 360.0), atol=2e-4)
    assert (out["B"][on] == 0.5).all()
    for c, val in zip("RGB", (0.1, 0.2, 0.3)):
        assert np.allclose(out[c][~on], val)
    if frame == 1:  # the grazing frame: the far plane is beyond 70° and takes the 70° views
        far = on & (slant > 70.5)
        assert far.any() and np.allclose(out["R"][far], 70.0 / 90.0, atol=1e-6)


def test_texture_coordinates_are_planar_at_the_stack_scale(proxies):
    """Every view the same picture: the shaded colour is that picture read bilinearly at
    (x − origin x) / scale − ½, (z − origin z) / scale − ½, wrapped."""
    proxy = proxies[12]
    rng = np.random.default_rng(3)
    pic = rng.random((8, 8, 3)).astype(np.float32)
    views = btf.view_grid(10.0, 80.0, TILTS)
    stack = btf.stack_plate(np.repeat(pic[None], len(views), 0), views, {"pixel": 0.05, "plane": 0.0})
    out = run_node("BtfShade", {"label": "vegetation", "origin": [-0.3, 0.1]}, {"stack": stack, "proxy": proxy})
    on = out["A"] == 1
    assert on.sum() > 300  # the source label names the same pixels as the scene label
    for i, j in zip(*np.nonzero(on)):
        x = (proxy["P.X"][i, j] + 0.3) / 0.05 - 0.5
        y = (proxy["P.Z"][i, j] - 0.1) / 0.05 - 0.5
        x0, y0 = math.floor(x), math.floor(y)
        fx, fy = x - x0, y - y0
        ref = sum(wy * wx * pic[(y0 + dy) % 8, (x0 + dx) % 8].astype(np.float64)
                  for dy, wy in ((0, 1 - fy), (1, fy)) for dx, wx in ((0, 1 - fx), (1, fx)))
        np.testing.assert_allclose([out[c][i, j] for c in "RGB"], ref, atol=1e-5)


def test_bad_inputs_are_one_line(proxies):
    stack = _stack(lambda v: (0.5, 0.5, 0.5))
    with pytest.raises(UserError, match=r"label 'rocks' is neither .* give one of: bumps, .*vegetation"):
        run_node("BtfShade", {"label": "rocks"}, {"stack": stack, "proxy": proxies[1]})
    with pytest.raises(UserError, match="no meta\\['views'\\]"):
        run_node("BtfShade", {"label": "bumps"}, {"stack": proxies[1], "proxy": proxies[1]})
    with pytest.raises(UserError, match="proxy.*P.X"):
        run_node("BtfShade", {"label": "bumps"}, {"stack": stack, "proxy": stack})


def test_terrain_coordinates_are_the_planes_own_grid(proxies):
    """uv: terrain reads the labelled mesh's own grid from the scene (btf_move's plane: a 2×2
    grid, flat): on a flat terrain it is the planar parametrization, pixel for pixel."""
    proxy = proxies[12]
    rng = np.random.default_rng(8)
    pic = rng.random((8, 8, 3)).astype(np.float32)
    views = btf.view_grid(10.0, 80.0, TILTS)
    stack = btf.stack_plate(np.repeat(pic[None], len(views), 0), views, {"pixel": 0.05, "plane": 0.0})
    params = {"label": "bumps", "origin": [-0.3, 0.1]}
    planar = run_node("BtfShade", params, {"stack": stack, "proxy": proxy})
    terrain = run_node("BtfShade", dict(params, uv="terrain"), {"stack": stack, "proxy": proxy})
    on = planar["A"] == 1
    for c in ("btf.u", "btf.v", "R", "G", "B"):
        np.testing.assert_allclose(terrain[c][on], planar[c][on], atol=2e-5)
    with pytest.raises(UserError, match="uv: terrain needs a scene label.*use uv: planar"):
        run_node("BtfShade", {"label": "vegetation", "uv": "terrain"}, {"stack": stack, "proxy": proxy})
