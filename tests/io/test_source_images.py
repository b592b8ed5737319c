"""Photos and label maps as a studio hands them over (issue 36, item 8): PNGs with alpha, label
maps with transparency, linear EXR photos, all written for real with OpenImageIO and read
through ``load_source``: nothing darkened, clamped, decoded twice or silently black."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import OpenImageIO as oiio
import pytest

from proxyshade.errors import UserError
from proxyshade.io.images import read_u8
from proxyshade.io.source import load_source, new_table, srgb_to_linear

H, W = 24, 32
COLOURS = [(255, 255, 255), (0, 255, 0), (0, 0, 255)]  # sky, vegetation, water
TABLE = """image: {image}
labels_map: {labels}
labels:
  sky:        {{id: 1, color: "#ffffff"}}
  vegetation: {{id: 2, color: "#00ff00"}}
  water:      {{id: 3, color: "#0000ff"}}
"""


def write(path: Path, pixels: np.ndarray, fmt=oiio.UINT8, *, unassociated: bool = True) -> Path:
    """``pixels`` (H, W, C) written by OpenImageIO; with alpha, its colours stored as given
    (unassociated: the way a photo with an alpha channel is exported)."""
    spec = oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], fmt)
    if pixels.shape[2] == 4:
        spec.alpha_channel = 3
        if unassociated:
            spec.attribute("oiio:UnassociatedAlpha", 1)
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec), out.geterror()
    assert out.write_image(np.ascontiguousarray(pixels)), out.geterror()
    assert out.close()
    return path


@pytest.fixture
def shot(tmp_path):
    """A photo (mid-grey noise, mean about 122 like the probe's), its label map (three bands)
    and their opaque PNGs."""
    rng = np.random.default_rng(7)
    photo = rng.integers(40, 205, (H, W, 3), dtype=np.uint8)
    ids = np.repeat(np.array([0, 1, 2])[:, None], W, 1).repeat(H // 3, 0)
    labels = np.array(COLOURS, np.uint8)[ids]
    write(tmp_path / "photo.png", photo)
    write(tmp_path / "labels.png", labels)
    return tmp_path, photo, labels, ids + 1


def table(folder: Path, image: str, labels: str = "labels.png") -> Path:
    p = folder / f"{Path(image).stem}_{Path(labels).stem}.yaml"
    p.write_text(TABLE.format(image=image, labels=labels))
    return p


def rgb(plate) -> np.ndarray:
    return np.stack([plate["R"], plate["G"], plate["B"]], -1)


def test_a_png_photo_with_alpha_reads_as_its_colours(shot):
    folder, photo, _, _ = shot
    alpha = np.random.default_rng(1).integers(0, 256, (H, W, 1), dtype=np.uint8)
    alpha[:4] = 0  # fully transparent rows keep their colour too
    write(folder / "photo_alpha.png", np.concatenate([photo, alpha], 2))
    assert np.array_equal(read_u8(folder / "photo_alpha.png"), photo)  # premultiplied, it came out darker
    a = load_source(table(folder, "photo_alpha.png"))
    b = load_source(table(folder, "photo.png"))
    assert np.array_equal(rgb(a), rgb(b)) and np.array_equal(rgb(b), srgb_to_linear(photo))


def test_a_label_map_with_transparency_reads_its_colours(shot):
    """Alpha is ignored: a transparent pixel keeps the label its colour names."""
    folder, _, labels, ids = shot
    alpha = np.where(np.random.default_rng(2).random((H, W, 1)) < 0.3, 0, 255).astype(np.uint8)
    alpha[:, :3] = 128  # and some half-transparent edges
    write(folder / "labels_alpha.png", np.concatenate([labels, alpha], 2))
    plate = load_source(table(folder, "photo.png", "labels_alpha.png"))
    assert np.array_equal(plate["label.id"], ids) and plate.meta["snap"]["snapped"] == 0
    text, report = new_table(folder / "photo.png", folder / "labels_alpha.png", folder / "new.yaml")
    assert report["labels"] == 3 and report["snapped"] == 0


def test_transparent_pixels_of_no_label_colour_get_the_right_fix(shot):
    """Erased areas exported as transparent black: the message says they are transparent and
    how to fix the map, not to add a colour to the table."""
    folder, _, labels, _ = shot
    rgba = np.concatenate([labels, np.full((H, W, 1), 255, np.uint8)], 2)
    rgba[:, W // 2:] = 0  # the right half erased: (0, 0, 0, 0)
    write(folder / "erased.png", rgba)
    with pytest.raises(UserError) as e:
        load_source(table(folder, "photo.png", "erased.png"))
    msg = str(e.value)
    assert "erased.png: 50.0% of pixels are further than 100 from every label colour" in msg, msg
    assert "100% of them transparent; alpha is ignored" in msg and "fill the transparent areas with label colours" in msg
    assert "add the missing colours" not in msg and "\n" not in msg


@pytest.mark.parametrize("fmt", [oiio.FLOAT, oiio.HALF])
def test_a_linear_exr_photo_is_read_as_linear_light_unclamped(shot, fmt):
    folder, photo, _, _ = shot
    lin = srgb_to_linear(photo) * 4.0  # scene-referred: many values above 1
    lin[0, 0] = (0.0, 37.5, 1e-4)
    write(folder / "photo.exr", lin, fmt)
    stored = lin if fmt == oiio.FLOAT else lin.astype(np.float16).astype(np.float32)
    plate = load_source(table(folder, "photo.exr"))
    assert plate["R"].dtype == np.float32 and np.array_equal(rgb(plate), stored)
    assert rgb(plate).max() == pytest.approx(37.5) and (rgb(plate) > 1).mean() > 0.3


@pytest.mark.parametrize("case,expect", [
    ("all_nan", "photo.exr: all of the photo's 768 pixels are NaN or infinite; a photo needs finite linear values"),
    ("one_inf", "photo.exr: 1 (0.1%) of the photo's 768 pixels are NaN or infinite"),
    ("negative", "photo.exr: 2 (0.3%) of the photo's pixels have negative values (lowest -0.25); light is never "
                 "negative: clamp them to 0 in the export"),
])
def test_non_finite_or_negative_exr_photos_are_refused(shot, capsys, case, expect):
    """Through the CLI: exit 2, one line naming the file (an all-NaN photo became black before)."""
    from tests.faults.test_faults import cli, write_graph

    folder, photo, _, _ = shot
    lin = srgb_to_linear(photo)
    if case == "all_nan":
        lin[:] = np.nan
    elif case == "one_inf":
        lin[3, 4, 1] = np.inf
    else:
        lin[0, :2, 2] = -0.25
    write(folder / "photo.exr", lin, oiio.FLOAT)
    t = table(folder, "photo.exr")
    g = write_graph(folder, f"  src: {{type: SourceRead, params: {{table: {t.name}}}}}\n", frames="1", vars_="")
    code, out, err = cli(capsys, "run", g, "-q")
    assert code == 2 and len(err) == 1 and expect in err[0], err


def test_a_png_written_reads_back_as_the_same_pixels(tmp_path):
    """write_png is lossless at its compression level: every byte of the picture read back."""
    from proxyshade.io.images import write_png

    rng = np.random.default_rng(5)
    smooth = np.cumsum(rng.integers(0, 3, (37, 53, 3)), 1).astype(np.uint8)  # a preview-like ramp
    for rgb8 in (rng.integers(0, 256, (37, 53, 3), dtype=np.uint8), smooth):
        write_png(tmp_path / "p.png", rgb8)
        assert (read_u8(tmp_path / "p.png") == rgb8).all()


def test_write_png_keeps_every_pixel_with_its_row_filter(tmp_path):
    """PNGs are written with one row filter (``images.PNG_FILTER``) at a low zlib level: the
    picture read back is the array written, for noise, flat ids, ramps and odd sizes."""
    from proxyshade.io.images import read_u8, write_png

    rng = np.random.default_rng(5)
    ramp = np.broadcast_to((np.arange(37 * 3) % 256).astype(np.uint8).reshape(1, 37, 3), (23, 37, 3))
    ids = rng.integers(0, 4, (64, 48))
    pal = rng.integers(0, 256, (4, 3), dtype=np.uint8)
    for k, img in enumerate((rng.integers(0, 256, (31, 17, 3), dtype=np.uint8), ramp, pal[ids],
                             np.zeros((1, 1, 3), np.uint8), np.full((5, 300, 3), 255, np.uint8))):
        write_png(tmp_path / f"{k}.png", img)
        assert read_u8(tmp_path / f"{k}.png").tobytes() == np.ascontiguousarray(img).tobytes()
