"""Preview: PNGs people look at; labels in their table colours."""
import numpy as np

from proxyshade.graph.plate import Plate
from proxyshade.graph.testing import run_node
from proxyshade.io.images import read_u8


def test_label_preview_uses_table_colours(tmp_path):
    ids = np.array([[1, 2], [2, 0]], np.uint32)
    p = Plate({"label.id": ids}, {"labels": [{"name": "a", "id": 1, "color": "#ff0000"}, {"name": "b", "id": 2, "color": "#00ff00"}]})
    run_node("Preview", {"path": "p.png", "channels": ["label.id"]}, {"image": p}, graph_dir=tmp_path)
    img = read_u8(tmp_path / "p.png")
    assert img[0, 0].tolist() == [255, 0, 0] and img[0, 1].tolist() == [0, 255, 0] and img[1, 1].tolist() == [0, 0, 0]


def test_colour_preview_is_srgb_encoded(tmp_path):
    v = np.full((2, 2), 0.2158605, np.float32)  # linear value of sRGB 128
    p = Plate({"R": v, "G": v, "B": v})
    run_node("Preview", {"path": "c.png"}, {"image": p}, graph_dir=tmp_path)
    assert read_u8(tmp_path / "c.png")[0, 0].tolist() == [128, 128, 128]


def test_preview_returns_the_channels_shown_and_releases_its_input(tmp_path):
    """The plate a Preview returns holds the channels it shows (arrays shared, metadata
    kept); its input is released before the PNG is written (``ctx.image`` reads None then)."""
    from proxyshade.graph.node import Context
    from proxyshade.nodes.preview import Preview

    ids = np.array([[1, 2], [2, 0]], np.uint32)
    p = Plate({"label.id": ids, "Z": np.ones((2, 2), np.float32)}, {"labels": []})
    node = Preview("p", {"path": "p.png", "channels": ["label.id"]})
    released = []
    ctx = Context(node, 1, 1, {"image": p}, dict(node.params), tmp_path, 0, [])
    ctx.on_release = released.append
    out = node.compute(ctx)
    assert out.names() == ["label.id"] and out["label.id"] is ids and out.meta == p.meta
    assert released == ["image"] and ctx.image is None and (tmp_path / "p.png").is_file()
