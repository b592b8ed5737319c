"""Movie: an animated GIF of the sequence, written once per run, atomically."""
import numpy as np
import OpenImageIO as oiio
import pytest

from proxyshade.errors import NodeInputError, WriteError
from proxyshade.graph.graph import Graph, InputRef
from proxyshade.graph.node import Node
from proxyshade.graph.plate import Plate
from proxyshade.graph.testing import run_node
from proxyshade.kernels.display import to_display

W, H = 40, 24


class _Ramp(Node, register=False):
    """A cheap colour plate that changes with the frame: R and G ramps, B = frame / 4."""

    time_dependent = True

    def compute(self, ctx):
        y, x = np.mgrid[0:H, 0:W].astype(np.float32)
        rgb = {"R": x / W * (0.5 + 0.1 * ctx.frame), "G": y / H, "B": np.full((H, W), ctx.frame / 4, np.float32)}
        return Plate({k: v.astype(np.float32) for k, v in rgb.items()})


def ramp(frame):
    return _Ramp("r").compute(type("Ctx", (), {"frame": frame})())


def read_gif(path):
    """(subimages as (H, W, 3) uint8 arrays, the first subimage's spec)."""
    inp = oiio.ImageInput.open(str(path))
    assert inp is not None, oiio.geterror()
    frames, spec = [], inp.spec()
    while inp.seek_subimage(len(frames), 0):
        frames.append(np.asarray(inp.read_image(oiio.UINT8))[..., :3])
    inp.close()
    return frames, spec


def movie_graph(tmp_path, frames=(1, 4), **params):
    g = Graph(graph_dir=tmp_path, frames=frames, cache=tmp_path / "cache")
    g.add("ramp", _Ramp)
    g.add("movie", "Movie", {"path": "out/move.gif", **params}, {"image": InputRef("ramp", all=True)})
    return g


def test_movie_holds_every_frame_in_order(tmp_path):
    r = movie_graph(tmp_path).run()
    assert [(x.frame, x.status) for x in r.rows("movie")] == [(4, "computed")]
    frames, spec = read_gif(tmp_path / "out" / "move.gif")
    assert len(frames) == 4 and (spec.width, spec.height) == (W, H)
    assert spec.getattribute("FramesPerSecond") == (100, 4)  # 24 fps: GIF delays are in 1/100 s
    assert spec.getattribute("gif:LoopCount") == 0  # loops forever
    want = [to_display(ramp(f), ["R", "G", "B"]).astype(int) for f in range(1, 5)]
    for i, got in enumerate(frames):
        err = [np.abs(got.astype(int) - w).mean() for w in want]
        assert err[i] < 4  # a 256-colour palette per frame, dithered
        assert np.abs(got.astype(int) - want[i]).max() <= 48  # dither steps are largest near black
        assert min(e for j, e in enumerate(err) if j != i) > 10  # and no other frame is close


def test_partial_range_covers_first_to_last_requested_and_rerun_reuses(tmp_path):
    g = movie_graph(tmp_path, frames=(1, 48))
    g.run([3])
    assert len(read_gif(tmp_path / "out" / "move.gif")[0]) == 3
    r = movie_graph(tmp_path, frames=(1, 48)).run([3])
    assert r.computed == set() and r.rows("movie")[0].status == "reused"
    g.run([5])
    assert len(read_gif(tmp_path / "out" / "move.gif")[0]) == 5


def test_deleted_movie_is_written_again(tmp_path):
    g = movie_graph(tmp_path, frames=(1, 2))
    g.run()
    (tmp_path / "out" / "move.gif").unlink()
    assert g.run().computed == {"movie"}
    assert (tmp_path / "out" / "move.gif").is_file()


def test_large_frames_are_downscaled_to_max_size(tmp_path):
    run_node("Movie", {"path": "m.gif", "max_size": 20, "fps": 10}, {"image": [ramp(1), ramp(2)]}, graph_dir=tmp_path)
    frames, spec = read_gif(tmp_path / "m.gif")
    assert len(frames) == 2 and (spec.width, spec.height) == (20, 12)
    assert spec.getattribute("FramesPerSecond") == (100, 10)
    want = to_display(ramp(2), ["R", "G", "B"]).reshape(12, 2, 20, 2, 3).mean(axis=(1, 3))
    assert np.abs(frames[1].astype(float) - want).mean() < 5


def test_only_the_movie_is_left_in_its_folder(tmp_path):
    run_node("Movie", {"path": "out/m.gif"}, {"image": [ramp(1), ramp(2)]}, graph_dir=tmp_path)
    assert [p.name for p in (tmp_path / "out").iterdir()] == ["m.gif"]


def test_failed_write_leaves_no_file_and_names_it(tmp_path, monkeypatch):
    real = oiio.ImageOutput.create
    created = []

    class Failing:
        def __init__(self, name):
            self.out = real(name)
            created.append(name)

        def open(self, *a):
            return self.out.open(*a)

        def write_image(self, px):
            self.out.write_image(px)  # something reaches the temporary file, then the write fails
            return len(created) > 5

        def close(self):
            return self.out.close()

        def geterror(self):
            return "disk full"

    run_node("Movie", {"path": "out/m.gif"}, {"image": [ramp(1)]}, graph_dir=tmp_path)
    old = (tmp_path / "out" / "m.gif").read_bytes()
    monkeypatch.setattr(oiio.ImageOutput, "create", Failing)
    with pytest.raises(WriteError, match=r"m.gif: cannot write GIF frame 0 \(disk full\); free space or fix the disk"):
        run_node("Movie", {"path": "out/m.gif"}, {"image": [ramp(1), ramp(2)]}, graph_dir=tmp_path)
    assert created and [p.name for p in (tmp_path / "out").iterdir()] == ["m.gif"]  # no temporary file left
    assert (tmp_path / "out" / "m.gif").read_bytes() == old  # the previous movie is untouched


def test_missing_channel_names_the_node_and_frame(tmp_path):
    plates = [ramp(1), Plate({"R": np.zeros((H, W), np.float32)})]
    with pytest.raises(NodeInputError, match=r"^movie: frame 2: channels \['G', 'B'\] are not in the input; it has R$"):
        run_node("Movie", {"path": "m.gif"}, {"image": plates}, graph_dir=tmp_path, name="movie")
    assert not (tmp_path / "m.gif").exists()


def test_frames_of_different_sizes_are_rejected(tmp_path):
    small = Plate({c: np.zeros((4, 4), np.float32) for c in "RGB"})
    with pytest.raises(NodeInputError, match=r"^movie: frame 2 is 4x4, frame 1 is 40x24; a movie needs one size"):
        run_node("Movie", {"path": "m.gif"}, {"image": [ramp(1), small]}, graph_dir=tmp_path, name="movie")
