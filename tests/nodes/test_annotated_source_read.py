"""AnnotatedSourceRead: ann.* channels are the grey maps / 255, mask and alpha follow their
maps, and a map of another size or a table without annotations is a one-line error."""
import shutil
from pathlib import Path

import numpy as np
import pytest

from proxyshade.errors import UserError
from proxyshade.graph.testing import run_node
from proxyshade.io.images import read_u8, write_png

CREEK = Path(__file__).resolve().parents[2] / "samples" / "creek"


def table(tmp_path, extra: str, h=24, w=32, light_shape=None):
    rng = np.random.default_rng(0)
    write_png(tmp_path / "photo.png", rng.integers(0, 256, (h, w, 3), dtype=np.uint8))
    lab = np.zeros((h, w, 3), np.uint8)
    lab[:, : w // 2, 1] = 255
    lab[:, w // 2:] = 255
    write_png(tmp_path / "labels.png", lab)
    lh, lw = light_shape or (h, w)
    g = rng.integers(0, 256, (lh, lw), dtype=np.uint8)
    write_png(tmp_path / "light.png", np.repeat(g[..., None], 3, 2))
    m = np.zeros((h, w), np.uint8)
    m[:, :10] = 255
    write_png(tmp_path / "mask.png", np.repeat(m[..., None], 3, 2))
    (tmp_path / "source.yaml").write_text(
        "image: photo.png\nlabels_map: labels.png\nlabels:\n  grass: {id: 1, color: '#00ff00'}\n"
        "  sky: {id: 2, color: '#ffffff'}\n" + extra)
    return tmp_path / "source.yaml", g


def test_reads_annotations_mask_and_default_alpha(tmp_path):
    path, g = table(tmp_path, "annotations: {light: light.png}\nmask: mask.png\n")
    out = run_node("AnnotatedSourceRead", {"table": str(path)})
    np.testing.assert_array_equal(out["ann.light"], g.astype(np.float32) / 255)
    assert out["mask"][:, :10].min() == 1 and out["mask"][:, 10:].max() == 0
    assert np.all(out["A"] == 1) and out["label.id"].dtype == np.uint32
    assert out.meta["annotations"] == ["light"]


def test_map_of_another_size_is_an_error(tmp_path):
    path, _ = table(tmp_path, "annotations: {light: light.png}\n", light_shape=(20, 32))
    with pytest.raises(UserError, match=r"^src: .*annotations.light is 32x20 but the photo is 32x24; paint it") as e:
        run_node("AnnotatedSourceRead", {"table": str(path)}, name="src")
    assert "\n" not in str(e.value)


def test_table_without_annotations_is_an_error(tmp_path):
    path, _ = table(tmp_path, "")
    with pytest.raises(UserError, match=r"^src: .*annotations: expected a mapping"):
        run_node("AnnotatedSourceRead", {"table": str(path)}, name="src")


def test_creek_sample_reads():
    out = run_node("AnnotatedSourceRead", {"table": str(CREEK / "annotated.yaml")})
    assert out.shape == (600, 800)
    assert sorted(out.meta["annotations"]) == ["light", "scale"]
    veg = out["label.id"] == 1
    assert np.array_equal(out["mask"] > 0.5, veg)
    rows = np.flatnonzero(veg.any(axis=1))  # the scale ramp spans the vegetation rows
    assert out["ann.scale"][rows[0]].min() == 1 and out["ann.scale"][rows[-1]].max() == 0


def test_cli_exits_2_with_one_line_naming_the_node(tmp_path, capsys):
    from proxyshade.cli import main

    table(tmp_path, "annotations: {light: light.png}\n", light_shape=(20, 32))
    g = tmp_path / "g.yaml"
    g.write_text("format: proxyshade/1\nframes: 1\nnodes:\n  src: {type: AnnotatedSourceRead, params: {table: source.yaml}}\n")
    assert main(["run", str(g), "-q"]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if "annotations.light" in line]
    assert len(err) == 1 and "src" in err[0] and "paint it on the photo's pixel grid" in err[0]


def test_annotations_param_selects_names_and_refuses_unknown_ones():
    out = run_node("AnnotatedSourceRead", {"table": str(CREEK / "annotated.yaml"), "annotations": ["light"]})
    assert out.meta["annotations"] == ["light"] and "ann.scale" not in out
    with pytest.raises(UserError, match=r"^src: .*'slope' is not in annotated.yaml's annotations \(light, scale\)") as e:
        run_node("AnnotatedSourceRead", {"table": str(CREEK / "annotated.yaml"), "annotations": ["slope"]}, name="src")
    assert "\n" not in str(e.value)
