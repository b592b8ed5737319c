"""PatchInit: output plate, label fidelity, seeds, bad input."""
import numpy as np
import pytest

from proxyshade.errors import NodeInputError
from proxyshade.graph.plate import Plate
from proxyshade.graph.testing import run_node

from tests.nodes import _synthesis as T


def test_output_channels_meta_and_fidelity():
    c = T.chain("renoir")
    init, src = c["init"], c["source"]
    assert init.shape == (128, 128)  # 512 / factor 4
    for name, dt in (("R", np.float32), ("source.x", np.float32), ("source.y", np.float32),
                     ("patch.id", np.uint32), ("label.id", np.uint32)):
        assert init[name].dtype == dt
    assert init.meta["labels"] == src.meta["labels"]
    assert init.meta["source"]["image"].endswith("style.png")
    assert init.meta["source"]["labels_map"].endswith("style_mask.png")
    syn = init.meta["synthesis"]
    assert syn["factor"] == 4 and syn["scale"] == 1.0 and syn["exemplar"] == [80, 128]
    assert syn["patches"] == init["patch.id"].max() > 10
    # source coordinates are exemplar centres in source pixels: 4 e + 1.5
    assert np.all(((init["source.x"] - 1.5) / 4) % 1 == 0)
    # at the synthesis size the source's label at the block centre matches the guide
    assert T.label_fidelity(src, init) >= 0.99


def test_same_seed_same_map_other_seed_other_map():
    src, g = T.source("monet"), T.guide("monet", (256, 256))
    a = run_node("PatchInit", {"seed": 4}, {"guide": g, "source": src})
    b = run_node("PatchInit", {"seed": 4}, {"guide": g, "source": src})
    c = run_node("PatchInit", {"seed": 5}, {"guide": g, "source": src})
    assert a.equals(b)
    assert not np.array_equal(a["source.x"], c["source.x"])


def test_guide_label_missing_from_source_table():
    src = T.source("renoir")
    ids = T.guide("renoir", (128, 128))["label.id"].copy()
    ids[5:9, 5:9] = 9
    with pytest.raises(NodeInputError, match=r"^init: .*label ids missing.*9: 16 px.*source\.yaml"):
        run_node("PatchInit", {}, {"guide": Plate({"label.id": ids}), "source": src}, name="init")
    ids[5:9, 5:9] = 0
    with pytest.raises(NodeInputError, match=r"0 \(none\)"):
        run_node("PatchInit", {}, {"guide": Plate({"label.id": ids}), "source": src}, name="init")


def test_small_source_starts_the_correction_at_a_finer_level():
    """A source too small for the coarsest level's neighbourhood (large output, small photo)
    shortens the pyramid instead of failing; smaller than one 5x5 neighbourhood fails."""
    src = T.source("renoir")
    lab = int(np.bincount(src["label.id"][:60, :60].ravel()).argmax())
    g = Plate({"label.id": np.full((512, 512), lab, np.uint32)})
    # 60 px / factor 4 = 15 exemplar px: 3 levels from 32 to 128 would need 4 * 4 + 1 = 17; 2 levels fit
    small = Plate({k: np.ascontiguousarray(v[:60, :60]) for k, v in src.channels.items()}, src.meta)
    out = run_node("PatchInit", {}, {"guide": g, "source": small}, name="init")
    assert out.shape == (128, 128) and (out["label.id"] == lab).all()
    tiny = Plate({k: np.ascontiguousarray(v[:16, :16]) for k, v in src.channels.items()}, src.meta)
    tiny = tiny.with_channels({"label.id": np.full((16, 16), lab, np.uint32)})
    with pytest.raises(NodeInputError, match=r"^init: .*4x4 exemplar, smaller than a 5x5 neighbourhood at the "
                                             r"coarsest level \(spacing 1: needs 5x5\); lower 'scale'"):
        run_node("PatchInit", {}, {"guide": g, "source": tiny}, name="init")


def test_nan_in_source_is_reported():
    src = T.source("renoir")
    r = src["R"].copy()
    r[10, 20] = np.nan
    bad = src.with_channels({"R": r})
    with pytest.raises(NodeInputError, match=r"^init: input 'source' channel R has 1 NaN/Inf pixel\(s\), first at x=20 y=10"):
        run_node("PatchInit", {}, {"guide": T.guide("renoir", (128, 128)), "source": bad}, name="init")


def test_guide_label_absent_from_the_source_pixels():
    """A label in the table but painted nowhere in the source map is an error too."""
    src = T.source("renoir")
    ids = src["label.id"].copy()
    ids[ids == 4] = 1  # no tree left in the source
    g = T.guide("renoir", (256, 256))
    with pytest.raises(NodeInputError, match=r"4 \(tree\) have no pixel in the source"):
        run_node("PatchInit", {}, {"guide": g, "source": src.with_channels({"label.id": ids})}, name="init")
