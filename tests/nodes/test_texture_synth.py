"""TextureSynth: a PNG or EXR exemplar in, a size² texture out whose pixels are copies of
the exemplar (``source.x/y`` say where from); bad inputs are one-line errors with the fix."""
import numpy as np
import pytest

from proxyshade.errors import UserError
from proxyshade.graph.plate import Plate
from proxyshade.graph.testing import run_node
from proxyshade.io.exr import write_plate
from proxyshade.io.images import write_png
from proxyshade.io.source import srgb_to_linear


def exemplar8(n=40, seed=0):
    """Blobs of three colours on a noisy ground: a small stationary texture (uint8 sRGB)."""
    rng = np.random.default_rng(seed)
    img = np.zeros((n, n, 3)) + rng.random((n, n, 1)) * 60 + 40
    for _ in range(12):
        y, x, r = rng.integers(0, n), rng.integers(0, n), rng.integers(2, 5)
        yy, xx = np.mgrid[0:n, 0:n]
        img[(yy - y) ** 2 + (xx - x) ** 2 <= r * r] = rng.choice([[200, 60, 40], [60, 180, 70], [230, 230, 210]])
    return img.astype(np.uint8)


def test_png_exemplar_gives_a_texture_of_copied_pixels(tmp_path):
    ex8 = exemplar8()
    write_png(tmp_path / "ex.png", ex8)
    out = run_node("TextureSynth", {"exemplar": str(tmp_path / "ex.png"), "size": "48"})
    assert out.shape == (48, 48) and set(out.names()) >= {"R", "G", "B", "A", "source.x", "source.y"}
    sx, sy = out["source.x"].astype(int), out["source.y"].astype(int)
    assert sx.min() >= 2 and sy.min() >= 2 and sx.max() <= 37 and sy.max() <= 37  # whole 5×5 patches inside
    lin = srgb_to_linear(ex8)
    # each output pixel is (a vote of patches around) the exemplar pixel it points at
    err = np.abs(out.rgb() - lin[sy, sx]).mean()
    assert err < 0.25 * np.abs(lin - lin.mean((0, 1))).mean()
    assert out.meta["texture"]["method"] == "annotated"


def test_exr_exemplar_is_read_as_linear_rgb(tmp_path):
    lin = srgb_to_linear(exemplar8(seed=1))
    write_plate(tmp_path / "ex.exr", Plate({"R": lin[..., 0], "G": lin[..., 1], "B": lin[..., 2]}, {}))
    out = run_node("TextureSynth", {"exemplar": str(tmp_path / "ex.exr"), "size": "32", "seed": 2})
    sx, sy = out["source.x"].astype(int), out["source.y"].astype(int)
    assert np.abs(out.rgb() - lin[sy, sx]).mean() < 0.25 * np.abs(lin - lin.mean((0, 1))).mean()


@pytest.mark.parametrize("params, words", [
    ({"size": "big"}, ["size", "whole number", "256"]),
    ({"size": "8"}, ["size", "16..4096"]),
    ({"patch": 4}, ["even", "odd"]),
    ({"levels": 4}, ["too small", "fewer levels"]),
    ({"exemplar": "missing.png"}, ["does not exist", "PNG"]),
])
def test_bad_inputs_are_one_line_errors_with_the_fix(tmp_path, params, words):
    write_png(tmp_path / "ex.png", exemplar8())
    p = {"exemplar": str(tmp_path / "ex.png"), "size": "32", **params}
    if "missing" in p["exemplar"]:
        p["exemplar"] = str(tmp_path / "missing.png")
    with pytest.raises(UserError) as e:
        run_node("TextureSynth", p)
    msg = str(e.value)
    assert "\n" not in msg and all(w in msg for w in words), msg
