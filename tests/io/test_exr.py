"""EXR round trips: uint32 IDs and float32 exact, half within half precision, metadata kept."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from proxyshade.errors import UserError
from proxyshade.graph.plate import Plate
from proxyshade.io.exr import compressions, exr_problem, header_strings, read_header, read_plate, write_plate


@settings(max_examples=20, deadline=None)
@given(h=st.integers(1, 17), w=st.integers(1, 17), seed=st.integers(0, 2**31))
def test_round_trip_exact_for_uint32_and_float32(tmp_path_factory, h, w, seed):
    rng = np.random.default_rng(seed)
    ids = rng.integers(0, 2**32, (h, w), dtype=np.uint32)
    ids.flat[0] = 2**32 - 1  # the largest id survives (no float scaling)
    f32 = rng.standard_normal((h, w)).astype(np.float32) * 1e6
    f32.flat[-1] = np.inf
    p = Plate({"label.id": ids, "Z": f32}, {"labels": [{"name": "sky", "id": 1, "color": "#ffffff"}]})
    path = tmp_path_factory.mktemp("exr") / "p.exr"
    write_plate(path, p)
    assert read_plate(path).equals(p)


def test_half_within_half_precision(tmp_path):
    a = np.random.default_rng(1).random((9, 11)).astype(np.float32) * 100
    p = Plate({"R": a.astype(np.float16)})
    write_plate(tmp_path / "h.exr", p)
    back = read_plate(tmp_path / "h.exr")["R"]
    assert back.dtype == np.float16
    np.testing.assert_allclose(back.astype(np.float32), a, rtol=2**-10)


def test_header_lists_types_and_metadata(tmp_path):
    p = Plate({"R": np.zeros((2, 3), np.float32), "label.id": np.zeros((2, 3), np.uint32)},
              {"cryptomatte/abc/name": "CryptoLabel"})
    write_plate(tmp_path / "m.exr", p, extra={"proxyshade/node": "src"})
    info = read_header(tmp_path / "m.exr")
    assert dict(info["channels"]) == {"R": "float", "label.id": "uint"}
    assert info["attributes"]["proxyshade/node"] == "src"
    assert info["attributes"]["cryptomatte/abc/name"] == "CryptoLabel"
    assert info["attributes"]["compression"] == "zip"
    oiiotool = Path(sys.executable).parent / "oiiotool"
    if oiiotool.exists():
        text = subprocess.run([str(oiiotool), "--info", "-v", str(tmp_path / "m.exr")], capture_output=True, text=True).stdout
        assert "label.id (uint)" in text and "R (float)" in text


def test_header_strings_read_in_python_match_openimageio(tmp_path):
    """The cache writer's header check reads string attributes from the bytes (no image library
    on its thread): the same values OpenImageIO reads; a cut-short or foreign file is an error."""
    p = Plate({"R": np.zeros((2, 3), np.float32)}, {"labels": [{"name": "sky", "id": 1}] * 500})
    write_plate(tmp_path / "m.exr", p, extra={"proxyshade/node": "src", "proxyshade/key": "ab" * 32})
    names = ("proxyshade/node", "proxyshade/key", "proxyshade/meta", "absent")
    got = header_strings(tmp_path / "m.exr", names)
    attrs = read_header(tmp_path / "m.exr")["attributes"]
    assert got == {k: attrs[k] for k in names[:3]} and got["proxyshade/key"] == "ab" * 32
    data = (tmp_path / "m.exr").read_bytes()
    (tmp_path / "cut.exr").write_bytes(data[:data.index(b"proxyshade/meta") + 30])
    with pytest.raises(UserError, match="cut.exr: EXR header cut short"):
        header_strings(tmp_path / "cut.exr", names)
    (tmp_path / "png.exr").write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(20))
    with pytest.raises(UserError, match="png.exr: not an EXR file"):
        header_strings(tmp_path / "png.exr", names)


@pytest.mark.parametrize("compression", ["zip", "none", "zstd"])
def test_exr_problem_finds_every_cut(tmp_path, compression):
    """A written EXR is checked whole before it is renamed into place (a full disk cuts it short
    while the library reports success): every cut of the file is found, the whole file passes."""
    if compression not in compressions():
        pytest.skip(f"no {compression} in these bindings")
    rng = np.random.default_rng(1)
    p = Plate({"R": rng.random((40, 7), dtype=np.float32), "label.id": np.arange(280, dtype=np.uint32).reshape(40, 7)})
    write_plate(tmp_path / "m.exr", p, compression=compression)
    data = (tmp_path / "m.exr").read_bytes()
    assert exr_problem(tmp_path / "m.exr") is None
    for cut in sorted({0, 3, 8, 50, len(data) // 2, len(data) - 100, len(data) - 1}):
        (tmp_path / "cut.exr").write_bytes(data[:cut])
        assert exr_problem(tmp_path / "cut.exr"), cut
    (tmp_path / "long.exr").write_bytes(data + b"\0")
    assert "1 bytes after its last chunk" in exr_problem(tmp_path / "long.exr")


def test_unreadable_file_names_the_file(tmp_path):
    bad = tmp_path / "bad.exr"
    bad.write_bytes(b"not an exr")
    with pytest.raises(UserError, match="bad.exr"):
        read_plate(bad)
    with pytest.raises(UserError, match="missing.exr"):
        read_plate(tmp_path / "missing.exr")


def test_failed_write_leaves_nothing(tmp_path):
    p = Plate({"R": np.zeros((2, 2), np.float32)})
    with pytest.raises(UserError):
        write_plate(tmp_path / "x.exr", p, compression="bogus")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif("zstd" not in compressions(), reason="OpenEXR without ZSTD")
def test_zstd_level_set_and_entries_exact(tmp_path):
    """The cache's ZSTD level reaches the library (a bindings upgrade that drops the C
    symbol would silently bring back level 5's CPU cost), and level-1 files hold the
    pixels exactly."""
    import ctypes

    import OpenEXR
    from proxyshade.io.exr import ZSTD_LEVEL

    compressions()  # io.exr sets the bindings up on first use
    got = ctypes.c_int(-99)
    ctypes.CDLL(OpenEXR.__file__).exr_get_default_zstd_compression_level(ctypes.byref(got))
    assert got.value == ZSTD_LEVEL
    rng = np.random.default_rng(3)
    p = Plate({"R": rng.standard_normal((37, 53)).astype(np.float32), "patch.id": rng.integers(0, 9, (37, 53), dtype=np.uint32)})
    write_plate(tmp_path / "z.exr", p, compression="zstd")
    assert read_header(tmp_path / "z.exr")["attributes"]["compression"] == "zstd"
    assert read_plate(tmp_path / "z.exr").equals(p)


def test_plate_equals_compares_bits_of_channels_with_any_strides():
    """``Plate.equals`` is bit-exact on views (a node's channels may be strided slices of one
    array) and tells a one-ulp difference."""
    from proxyshade.plate import Plate

    rgb = np.random.default_rng(3).random((5, 7, 3), dtype=np.float32)
    a = Plate({"R": rgb[..., 0], "G": rgb[..., 1]})
    b = Plate({"R": rgb[..., 0].copy(), "G": rgb[..., 1].copy()})
    assert a.equals(b) and b.equals(a)
    g = rgb[..., 1].copy()
    g[2, 3] = np.nextafter(g[2, 3], np.float32(2))
    assert not a.equals(Plate({"R": rgb[..., 0], "G": g}))


def test_read_holds_one_copy_of_the_pixels(tmp_path):
    """Reading a plate back (a cache hit) takes the bindings' arrays as they are: numpy
    allocates one copy of the pixels, not two (a 4K plate of 0.5 GiB read at 1 GiB), and the
    channels are the plate's own, writable, and exact."""
    import tracemalloc

    rng = np.random.default_rng(3)
    plate = Plate({"R": rng.random((256, 320), np.float32), "id": rng.integers(0, 9, (256, 320)).astype(np.uint32)})
    path = tmp_path / "p.exr"
    write_plate(path, plate)
    tracemalloc.start()
    try:
        back = read_plate(path)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 1.5 * plate.nbytes(), f"{peak} bytes allocated by numpy while reading {plate.nbytes()} bytes of pixels"
    for n, a in plate.channels.items():
        assert back[n].dtype == a.dtype and np.array_equal(back[n], a)
        assert back[n].flags.writeable and back[n].flags.owndata


@pytest.mark.parametrize("rows", [1, 3, 64])
def test_read_channels_gives_read_plates_arrays(tmp_path, rows):
    """``read_channels``: the channels asked for, each in its stored type, bit for bit those
    ``read_plate`` returns, whatever the band height; a wrong ``expect`` is refused."""
    from proxyshade.io.exr import ExrError, read_channels

    rng = np.random.default_rng(5)
    h, w = 13, 7
    plate = Plate({"R": rng.random((h, w), dtype=np.float32), "Z": np.where(rng.random((h, w)) < 0.2, np.inf,
                                                                            rng.random((h, w))).astype(np.float32),
                   "N.X": rng.standard_normal((h, w)).astype(np.float16),
                   "object.id": rng.integers(0, 2**32, (h, w), dtype=np.uint32)})
    path = write_plate(tmp_path / "p.exr", plate, compression="zip", extra={"proxyshade/key": "abc"})
    whole = read_plate(path)
    got = read_channels(path, ["object.id", "Z", "N.X"], expect={"proxyshade/key": "abc"}, rows=rows)
    assert sorted(got) == ["N.X", "Z", "object.id"]
    for n, a in got.items():
        assert a.dtype == whole[n].dtype and a.shape == (h, w) and a.tobytes() == whole[n].tobytes()
    with pytest.raises(ExrError, match="belongs elsewhere"):
        read_channels(path, ["Z"], expect={"proxyshade/key": "other"})


def test_writes_from_several_threads_encode_one_at_a_time_same_bytes(tmp_path, monkeypatch):
    """Writes from several threads at once (the cache's writer beside output writers) encode one
    at a time (OpenEXR's line buffers held once) and give each the file it gives alone."""
    import threading

    from proxyshade.io import exr

    lib = exr._openexr()
    real, active, most = lib.File, [0], [0]

    class Spy:
        def __init__(self, *a):
            self.f = real(*a)

        def __enter__(self):
            active[0] += 1
            most[0] = max(most[0], active[0])
            return self.f.__enter__()

        def __exit__(self, *exc):
            active[0] -= 1
            return self.f.__exit__(*exc)

    monkeypatch.setattr(lib, "File", Spy)
    rng = np.random.default_rng(7)
    plate = Plate({f"C{i}": rng.random((384, 256), dtype=np.float32) for i in range(6)}
                  | {"id": rng.integers(0, 9, (384, 256)).astype(np.uint32)}, {"k": "v"})
    entry_compression = "zstd" if "zstd" in compressions() else "zip"
    alone = {"out": write_plate(tmp_path / "out.exr", plate).read_bytes(),
             "entry": exr.write_plate_temp(tmp_path / "e.exr", plate, compression=entry_compression,
                                           durable=False).read_bytes()}
    failures = []

    def many(kind: str, n: int):
        try:
            for i in range(n):
                if kind == "out":
                    p = write_plate(tmp_path / f"out{i}.exr", plate)
                else:
                    p = exr.write_plate_temp(tmp_path / f"e{i}.exr", plate, durable=False,
                                             compression=entry_compression)
                assert p.read_bytes() == alone[kind]
        except BaseException as e:  # noqa: BLE001 - reported below
            failures.append(e)

    threads = [threading.Thread(target=many, args=(k, 4)) for k in ("out", "entry", "out")]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not failures, failures
    assert most[0] == 1
