"""The engine: incremental runs, keys, cache robustness, time, cycles, determinism."""
from __future__ import annotations

import re

import numpy as np
import pytest

from proxyshade.errors import CycleError
from proxyshade.graph.graph import Graph, InputRef
from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate
from proxyshade.io.exr import read_plate

from tests.conftest import _TAdd, _TConst, _TFrame, _TRead, _TSeq


def chain(tmp_path, frames=(1, 1)):
    g = Graph(graph_dir=tmp_path, frames=frames, cache=tmp_path / "cache")
    g.add("a", _TConst, {"value": 1.0})
    g.add("b", _TConst, {"value": 2.0})
    g.add("sum", _TAdd, {}, {"a": "a", "b": "b"})
    g.add("out", _TAdd, {"gain": 2.0}, {"a": "sum"})
    return g


def test_unchanged_second_run_computes_nothing(tmp_path, computes):
    g = chain(tmp_path)
    r1 = g.run()
    assert r1.computed == {"a", "b", "sum", "out"}
    computes.clear()
    r2 = chain(tmp_path).run()  # a fresh Graph object: only the disk cache is shared
    assert r2.computed == set()
    assert r2.reused == {"a", "b", "sum", "out"}
    assert sum(computes.values()) == 0


def test_param_edit_recomputes_only_downstream_closure(tmp_path, computes):
    g = chain(tmp_path)
    g.run()
    computes.clear()
    g.set("b.value", 5.0)
    r = g.run()
    assert r.computed == {"b", "sum", "out"}
    assert "a" in r.reused
    assert computes == {"b": 1, "sum": 1, "out": 1}
    assert "new params (value: 2.0 -> 5.0)" in r.rows("b")[0].reason
    assert "new input (b)" in r.rows("sum")[0].reason
    np.testing.assert_array_equal(g.value("out")["R"], np.full((8, 8), 12.0, np.float32))


def test_unhashed_param_does_not_invalidate(tmp_path, computes):
    g = chain(tmp_path)
    g.run()
    g.set("a.threads", 2)
    assert g.run().computed == set()


def test_code_version_bump_invalidates(tmp_path, monkeypatch):
    g = chain(tmp_path)
    g.run()
    monkeypatch.setattr(_TAdd, "version", 2)
    r = g.run()
    assert r.computed == {"sum", "out"}
    assert r.rows("sum")[0].reason == "new code"


def test_corrupted_cache_entry_is_recomputed(tmp_path, computes):
    g = chain(tmp_path)
    g.run()
    key = g.plan().keys[("sum", 1)]
    exr = tmp_path / "cache" / key[:2] / f"{key}.exr"
    data = bytearray(exr.read_bytes())
    data[-20:] = b"\x00" * 20  # same size, damaged content
    exr.write_bytes(bytes(data))
    computes.clear()
    g2 = chain(tmp_path)
    g2.set("out.gain", 3.0)  # out must read sum: the damaged entry is detected on read
    with pytest.warns(UserWarning, match="corrupt"):
        r = g2.run()
    assert computes["sum"] == 1 and computes["out"] == 1
    np.testing.assert_array_equal(g2.value("out")["R"], np.full((8, 8), 9.0, np.float32))
    assert r.computed == {"sum", "out"}  # the report says what ran: the damaged entry was recomputed
    assert r.rows("sum")[0].reason == "corrupt cache entry (content hash)"


def test_cache_entries_in_either_codec_are_read(tmp_path, computes):
    """Entries are written with the cache's codec (ZSTD where OpenEXR has it); an entry
    of an older cache written with ZIP is still a hit and loads the same plate."""
    from proxyshade.io.exr import cache_compression, read_header, write_plate

    g = chain(tmp_path)
    g.run()
    key = g.plan().keys[("sum", 1)]
    exr = tmp_path / "cache" / key[:2] / f"{key}.exr"
    assert read_header(exr)["attributes"]["compression"] == cache_compression()
    plate = read_plate(exr)
    # the same entry as an older cache wrote it: ZIP, record updated to match
    write_plate(exr, plate, compression="zip", extra={"proxyshade/key": key})
    import hashlib
    import json
    js = exr.with_suffix(".json")
    rec = json.loads(js.read_text())
    rec.update(size=exr.stat().st_size, sha256=hashlib.sha256(exr.read_bytes()).hexdigest())
    js.write_text(json.dumps(rec))
    computes.clear()
    g2 = chain(tmp_path)
    g2.set("out.gain", 3.0)  # out reads sum from disk
    r = g2.run()
    assert r.computed == {"out"} and computes["sum"] == 0
    np.testing.assert_array_equal(g2.value("out")["R"], np.full((8, 8), 9.0, np.float32))


def test_truncated_cache_entry_is_recomputed(tmp_path, computes):
    g = chain(tmp_path)
    g.run()
    key = g.plan().keys[("out", 1)]
    exr = tmp_path / "cache" / key[:2] / f"{key}.exr"
    exr.write_bytes(exr.read_bytes()[:50])
    with pytest.warns(UserWarning, match="corrupt"):
        r = chain(tmp_path).run()
    assert r.computed == {"out"}
    assert r.rows("out")[0].reason == "corrupt cache entry (size)"


def test_killed_write_leaves_no_entry(tmp_path, monkeypatch):
    import OpenEXR

    g = chain(tmp_path)
    real = OpenEXR.File
    victim = g.plan().keys[("sum", 1)]

    class Dying:
        def __init__(self, header, *a, **k):
            self.victim = victim in str(header)
            self.f = real(header, *a, **k)

        def __enter__(self):
            return self

        def __exit__(self, *a):
            return False

        def write(self, path):
            if not self.victim:
                return self.f.write(path)
            with open(path, "wb") as fh:
                fh.write(b"partial")
            raise KeyboardInterrupt  # killed in the middle of writing sum's entry

    monkeypatch.setattr(OpenEXR, "File", Dying)
    with pytest.raises(KeyboardInterrupt):
        g.run()
    monkeypatch.setattr(OpenEXR, "File", real)
    files = [p for p in (tmp_path / "cache").rglob("*") if p.is_file() and "runs" not in p.parts]
    assert not [p for p in files if "tmp" in p.name]  # no half-written file
    assert not [p for p in files if victim in p.name]  # no entry for the killed write
    for js in [p for p in files if p.suffix == ".json"]:
        assert js.with_suffix(".exr").is_file()  # every record has its image
    r = chain(tmp_path).run()
    assert "sum" in r.computed and "a" in r.reused


def test_disabled_node_passes_through_and_shares_key(tmp_path):
    g = chain(tmp_path)
    g.enabled["out"] = False
    plan = g.plan()
    assert plan.keys[("out", 1)] == plan.keys[("sum", 1)]
    r = g.run()
    assert r.rows("out")[0].status == "passthrough"
    np.testing.assert_array_equal(g.value("out")["R"], g.value("sum")["R"])


def test_frame_offsets_and_first_frame(tmp_path, computes):
    g = Graph(graph_dir=tmp_path, frames=(1, 4), cache=tmp_path / "cache")
    g.add("f", _TFrame)
    g.add("acc", _TAdd, {}, {"a": "f", "prev": InputRef("acc", offset=-1)})
    g.add("ref", _TAdd, {"gain": 3.0}, {"a": InputRef("f", first=True)})
    r = g.run()
    assert computes["f"] == 4 and computes["acc"] == 4
    assert computes["ref"] == 1  # same key at every frame: computed once
    assert g.value("acc", 4)["R"][0, 0] == 1 + 2 + 3 + 4
    assert g.value("ref", 3)["R"][0, 0] == 3
    assert {x.status for x in r.rows("ref")} == {"computed", "reused"}


def test_single_late_frame_reuses_or_computes_history(tmp_path, computes):
    g = Graph(graph_dir=tmp_path, frames=(1, 48), cache=tmp_path / "cache")
    g.add("f", _TFrame)
    g.add("acc", _TAdd, {}, {"a": "f", "prev": InputRef("acc", offset=-1)})
    r = g.run([30])
    assert computes["acc"] == 30  # frames 1..29 computed because they were missing
    computes.clear()
    g.run([1, 2])
    r = g.run([31])
    assert computes["acc"] == 1  # 1..30 cached
    assert g.value("acc", 31)["R"][0, 0] == sum(range(1, 32))


def test_cycle_is_rejected_with_its_path(tmp_path):
    g = Graph(graph_dir=tmp_path, cache=tmp_path / "cache")
    g.add("x", _TAdd, {}, {"a": "y"})
    g.add("y", _TAdd, {}, {"a": "x"})
    with pytest.raises(CycleError, match=r"cycle (x@1 -> y@1 -> x@1|y@1 -> x@1 -> y@1)"):
        g.run()


def test_same_seed_gives_identical_files_also_with_threads(tmp_path):
    outs = []
    for i, jobs in enumerate([1, 2, 2]):
        g = Graph(graph_dir=tmp_path, cache=tmp_path / f"cache{i}")
        g.add("n1", _TConst, {"seed": 7})
        g.add("n2", _TConst, {"seed": 8})
        g.add("s", _TAdd, {}, {"a": "n1", "b": "n2"})
        g.add("w", "ExrWrite", {"path": f"out{i}.exr"}, {"image": "s"})
        g.run(jobs=jobs)
        outs.append((tmp_path / f"out{i}.exr").read_bytes())
    assert outs[0] == outs[1] == outs[2]


def test_sink_rewrites_a_deleted_output(tmp_path):
    g = chain(tmp_path)
    g.add("w", "ExrWrite", {"path": "o/x.####.exr"}, {"image": "out"})
    g.run()
    f = tmp_path / "o" / "x.0001.exr"
    assert f.is_file()
    assert g.run().computed == set()
    f.unlink()
    r = g.run()
    assert r.computed == {"w"} and f.is_file()
    assert read_plate(f)["R"][0, 0] == 6.0


def test_report_has_times_and_memory(tmp_path):
    r = chain(tmp_path).run(jobs=2)
    assert r.peak_rss_mb > 0 and r.wall > 0
    assert all(x.seconds >= 0 for x in r.runs)
    assert [x.node for x in r.runs if x.node in ("sum", "out")] == ["sum", "out"]  # topological order


def test_declared_input_channels_are_checked_before_compute(tmp_path, computes):
    from proxyshade.errors import NodeInputError
    from proxyshade.graph.testing import run_node

    with pytest.raises(NodeInputError, match=r"^s: input 'a' has no channel R; _TAdd needs R there, it has Z$"):
        run_node(_TAdd, {}, {"a": Plate({"Z": np.zeros((2, 2), np.float32)})}, name="s")
    assert computes["s"] == 0


# -- sequence inputs: {node: X, frame: all} ---------------------------------------------

def sequence(tmp_path, frames=(1, 6)):
    g = Graph(graph_dir=tmp_path, frames=frames, cache=tmp_path / "cache")
    g.add("f", _TFrame)
    g.add("acc", _TAdd, {}, {"a": "f", "prev": InputRef("acc", offset=-1)})
    g.add("seq", _TSeq, {}, {"image": InputRef("acc", all=True)})
    return g


def test_sequence_node_runs_once_at_the_last_frame_over_every_frame(tmp_path, computes):
    g = sequence(tmp_path)
    r = g.run(jobs=2)
    assert computes["seq"] == 1 and computes["acc"] == 6
    assert [(x.frame, x.status) for x in r.rows("seq")] == [(6, "computed")]
    plate = g.value("seq", 6)
    assert plate.meta["frames"] == [1, 2, 3, 4, 5, 6]
    assert plate["R"][0, 0] == sum(sum(range(1, f + 1)) for f in range(1, 7))  # acc(f) = 1 + ... + f


def test_sequence_node_is_reused_when_nothing_changed(tmp_path, computes):
    sequence(tmp_path).run()
    computes.clear()
    r = sequence(tmp_path).run()
    assert r.computed == set() and "seq" in r.reused
    assert sum(computes.values()) == 0


def test_sequence_key_changes_when_one_frame_changes(tmp_path, computes):
    for f in range(1, 5):
        (tmp_path / f"in.{f:04d}.txt").write_text(str(f))
    g = Graph(graph_dir=tmp_path, frames=(1, 4), cache=tmp_path / "cache")
    g.add("read", _TRead, {"path": "in.####.txt"})
    g.add("seq", _TSeq, {}, {"image": InputRef("read", all=True)})
    g.run()
    before = g.plan().keys[("seq", 4)]
    assert g.value("seq", 4)["R"][0, 0] == 10
    computes.clear()
    (tmp_path / "in.0003.txt").write_text("30")
    assert g.plan().keys[("seq", 4)] != before
    r = g.run()
    assert computes == {"read": 1, "seq": 1}  # only frame 3 upstream, and the sequence node
    assert r.rows("seq")[0].reason == "new input (image: 1 of 4 frames)"
    assert g.value("seq", 4)["R"][0, 0] == 37


def test_sequence_over_a_partial_range_covers_first_to_last_requested(tmp_path, computes):
    g = sequence(tmp_path, frames=(1, 48))
    r = g.run([5])
    assert computes["acc"] == 5 and computes["seq"] == 1
    assert [x.frame for x in r.rows("seq")] == [5]
    assert g.value("seq", 5).meta["frames"] == [1, 2, 3, 4, 5]
    computes.clear()
    r = g.run([2, 7])
    assert computes == {"f": 2, "acc": 2, "seq": 1}  # frames 6 and 7 were missing; one movie, at 7
    assert [x.frame for x in r.rows("seq")] == [7]
    assert g.value("seq", 7).meta["frames"] == list(range(1, 8))


def test_sequence_input_reads_its_plates_one_at_a_time(tmp_path, monkeypatch):
    sequence(tmp_path, frames=(1, 8)).run(list(range(1, 8)))  # acc 1..7 on disk, in no graph's memory
    g = sequence(tmp_path, frames=(1, 8))
    acc_keys = [g.plan([8]).keys[("acc", f)] for f in range(1, 8)]
    held = []
    real = _TSeq.compute

    def compute(self, ctx):
        for _ in ctx.image:
            held.append(sum(k in g.cache.memory for k in acc_keys))
        return real(self, ctx)

    monkeypatch.setattr(_TSeq, "compute", compute)
    g.run([8])
    assert len(held) == 8 and max(held) <= 1  # never more than the plate being read


def test_disabled_sequence_node_has_no_instance(tmp_path, computes):
    g = sequence(tmp_path)
    g.enabled["seq"] = False
    r = g.run()
    assert r.rows("seq") == [] and computes["seq"] == 0


class _TNoR(Node, register=False):
    def compute(self, ctx):
        return Plate({"Z": np.zeros((2, 2), np.float32)})


def test_sequence_plates_are_checked_for_declared_channels(tmp_path, computes):
    from proxyshade.errors import NodeInputError

    g = Graph(graph_dir=tmp_path, frames=(1, 2), cache=tmp_path / "cache")
    g.add("z", _TNoR)
    g.add("seq", _TSeq, {}, {"image": InputRef("z", all=True)})
    with pytest.raises(NodeInputError, match=r"^seq@2: input 'image' has no channel R; _TSeq needs R there, it has Z$"):
        g.run()


@pytest.mark.parametrize("inputs, message", [
    ({"a": InputRef("f", all=True)}, "nodes.bad.inputs.a: _TAdd input 'a' takes one plate, not the whole sequence; "
                                      "drop 'frame: all'"),
    ({"a": "seq"}, "nodes.bad.inputs.a: seq (_TSeq) reads the whole sequence and runs once per run, so no node can "
                   "read it; connect bad.a to what seq reads instead"),
])
def test_bad_sequence_connections_are_rejected(tmp_path, inputs, message):
    from proxyshade.errors import GraphFileError

    g = sequence(tmp_path)
    g.add("bad", _TAdd, {}, inputs)
    with pytest.raises(GraphFileError, match=re.escape(message)):
        g.plan()


def test_sequence_input_needs_frame_all(tmp_path):
    from proxyshade.errors import GraphFileError

    g = Graph(graph_dir=tmp_path, frames=(1, 3), cache=tmp_path / "cache")
    g.add("f", _TFrame)
    g.add("seq", _TSeq, {}, {"image": "f"})
    with pytest.raises(GraphFileError, match=r"nodes.seq.inputs.image: _TSeq reads the whole sequence here; "
                                             r"connect it as \{node: f, frame: all\}$"):
        g.instances([1])


class _TThreads(Node, register=False):
    """Records how many threads numba kernels would use in its compute."""

    time_dependent = True

    seen: list = []

    def compute(self, ctx):
        import numba

        _TThreads.seen.append(numba.get_num_threads())
        return Plate({"R": np.zeros((2, 2), np.float32)})


@pytest.mark.parametrize("jobs", [1, 2])
def test_threads_sets_numba_threads_in_every_node(tmp_path, jobs):
    import numba

    g = Graph(graph_dir=tmp_path, frames=(1, 2), cache=tmp_path / "cache")
    g.add("t", _TThreads, {})
    _TThreads.seen.clear()
    g.run([1, 2], jobs=jobs, threads=1, force=("t",))
    assert _TThreads.seen == [1, 1]
    _TThreads.seen.clear()
    g.run([1, 2], jobs=jobs, threads=0, force=("t",))
    assert _TThreads.seen == [numba.config.NUMBA_NUM_THREADS] * 2


class _TCheap(_TAdd, register=False):
    stored = False  # Node.stored: kept in memory for the run only


def cheap_chain(tmp_path, gain=2.0):
    g = Graph(graph_dir=tmp_path, frames=(1, 1), cache=tmp_path / "cache")
    g.add("a", _TConst, {"value": 1.0})
    g.add("cheap", _TCheap, {"gain": 3.0}, {"a": "a"})
    g.add("out", _TAdd, {"gain": gain}, {"a": "cheap"})
    return g


def test_a_node_type_not_stored_is_computed_only_when_a_computing_node_reads_it(tmp_path, computes):
    """``Node.stored = False``: no cache entry; a re-run whose readers are cached computes
    nothing; a reader computed again computes it again from its stored input; an unpickled
    graph (a Dask worker's, read by other processes) stores it all the same."""
    import pickle

    g = cheap_chain(tmp_path)
    assert g.run().computed == {"a", "cheap", "out"}
    entries = {p.stem for p in (tmp_path / "cache").rglob("*.exr")}
    plan = g.plan([1])
    assert plan.keys[("cheap", 1)] not in entries and plan.keys[("out", 1)] in entries
    computes.clear()
    r = cheap_chain(tmp_path).run()
    assert r.computed == set() and sum(computes.values()) == 0
    assert "not needed: nothing to compute reads it" in r.rows("cheap")[0].reason
    r = cheap_chain(tmp_path, gain=5.0).run()
    assert r.computed == {"cheap", "out"} and computes == {"cheap": 1, "out": 1}
    np.testing.assert_array_equal(cheap_chain(tmp_path, gain=5.0).value("out")["R"], np.full((8, 8), 15.0, np.float32))
    np.testing.assert_array_equal(cheap_chain(tmp_path).value("cheap")["R"], np.full((8, 8), 3.0, np.float32))
    w = pickle.loads(pickle.dumps(cheap_chain(tmp_path, gain=7.0)))
    assert w.store_all and not cheap_chain(tmp_path).store_all
    w.run()
    assert w.plan([1]).keys[("cheap", 1)] in {p.stem for p in (tmp_path / "cache").rglob("*.exr")}



class _TRelease(Node, register=False):
    """Reads R of ``a``, releases it (``ctx.release``), then records what ``ctx.a`` reads
    and which plates the run still holds in memory."""

    a = Input(channels=("R",))
    gain = Param(float, 1.0)
    seen: list = []
    graph = None

    def compute(self, ctx):
        r = ctx.a["R"] * ctx.p.gain
        ctx.release("a")
        _TRelease.seen.append((self.name, ctx.a, set(_TRelease.graph.cache.memory)))
        return Plate({"R": r.astype(np.float32)})


@pytest.mark.parametrize("jobs", [1, 2])
def test_a_released_input_leaves_memory_after_its_last_reader_releases_it(tmp_path, jobs):
    """``Context.release``: the input reads None from then on; its plate leaves the run's
    memory at once where the releasing instance is its last reader, and stays while another
    instance still has to read it (one at a time: 'first' runs before 'z_last'); the
    results are those of the same nodes without a release."""
    from proxyshade.graph.cache import Cache

    g = Graph(graph_dir=tmp_path, frames=(1, 1), cache=Cache(tmp_path / "cache", background=False))
    g.add("a", _TConst, {"value": 2.0})
    g.add("first", _TRelease, {"gain": 3.0}, {"a": "a"})
    g.add("z_last", _TRelease, {"gain": 5.0}, {"a": "a"})
    _TRelease.graph, _TRelease.seen = g, []
    key_a = g.plan([1]).keys[("a", 1)]
    g.run(jobs=jobs)
    assert sorted(s[0] for s in _TRelease.seen) == ["first", "z_last"]
    assert all(s[1] is None for s in _TRelease.seen)
    if jobs == 1:
        assert [(s[0], key_a in s[2]) for s in _TRelease.seen] == [("first", True), ("z_last", False)]
    assert key_a not in g.cache.memory
    np.testing.assert_array_equal(g.value("z_last")["R"], np.full((8, 8), 10.0, np.float32))
    np.testing.assert_array_equal(g.value("first")["R"], np.full((8, 8), 6.0, np.float32))


class _TReleaseWait(Node, register=False):
    """Releases ``a`` with ``wait_written`` as its param says, then records whether the
    plate's cache write is still running and whether the run still holds it."""

    a = Input(channels=("R",))
    wait = Param(bool, False)
    seen: list = []
    graph = None
    key = None

    def compute(self, ctx):
        r = ctx.a["R"] + 1.0
        ctx.release("a", wait_written=ctx.p.wait)
        cache = _TReleaseWait.graph.cache
        _TReleaseWait.seen.append((cache.writing(_TReleaseWait.key) is not None, _TReleaseWait.key in cache.memory))
        return Plate({"R": r.astype(np.float32)})


@pytest.mark.parametrize("wait", [False, True])
def test_release_waits_for_the_plates_cache_write_when_asked(tmp_path, monkeypatch, wait):
    """A released plate whose cache write still runs stays in memory until the write is
    done; ``ctx.release(..., wait_written=True)`` returns only then, with the plate out of
    the run's memory (a node about to allocate much does not hold it on top)."""
    import threading

    from proxyshade.graph.cache import Cache

    gate = threading.Event()
    write = Cache._write

    def slow_write(self, key, *a, **k):
        if key == _TReleaseWait.key:
            gate.wait(10)
        return write(self, key, *a, **k)

    monkeypatch.setattr(Cache, "_write", slow_write)
    g = Graph(graph_dir=tmp_path, frames=(1, 1), cache=tmp_path / "cache")
    g.add("a", _TConst, {"value": 2.0})
    g.add("b", _TReleaseWait, {"wait": wait}, {"a": "a"})
    _TReleaseWait.graph, _TReleaseWait.seen, _TReleaseWait.key = g, [], g.plan([1]).keys[("a", 1)]
    timer = threading.Timer(0.3, gate.set)  # the write finishes a moment after the release
    timer.start()
    try:
        g.run()
    finally:
        gate.set()
        timer.cancel()
    assert _TReleaseWait.seen == ([(False, False)] if wait else [(True, True)])
    assert _TReleaseWait.key not in g.cache.memory and g.cache.intact(_TReleaseWait.key)
    np.testing.assert_array_equal(g.value("b")["R"], np.full((8, 8), 3.0, np.float32))


class _TReadBack(Node, register=False):
    """Keeps ``a``'s R, releases ``a`` (waiting for its cache write), lets its label.id go where
    the engine can read it back (``ctx.read_back``), and returns both; records whether it could."""

    a = Input(channels=("R", "label.id"))
    gain = Param(float, 1.0)
    seen: list = []

    def compute(self, ctx):
        r, ids = ctx.a["R"] * ctx.p.gain, ctx.a["label.id"]
        held = ids.tobytes()
        ctx.release("a", wait_written=True)
        again = ctx.read_back("a")
        if again is not None:
            del ids
            ids = again(["label.id"])["label.id"]
        _TReadBack.seen.append((self.name, again is not None, ids.dtype == np.uint32 and ids.tobytes() == held))
        return Plate({"R": r.astype(np.float32), "label.id": ids})


@pytest.mark.parametrize("jobs", [1, 2])
def test_a_released_input_is_read_back_from_its_cache_entry_bit_for_bit(tmp_path, monkeypatch, jobs):
    """``Context.read_back``: after the last reader released a stored input, its channels come
    back from the cache entry as the plate held them; a reader that is not the last (the plate
    stays in memory) and a read-only cache get None (the node keeps what it holds)."""
    import errno

    import proxyshade.graph.cache as cache_mod

    g = Graph(graph_dir=tmp_path, frames=(1, 1), cache=tmp_path / "cache")
    g.add("a", _TConst, {"value": 2.0, "seed": 3})
    g.add("first", _TReadBack, {"gain": 3.0}, {"a": "a"})
    g.add("z_last", _TReadBack, {"gain": 5.0}, {"a": "a"})
    _TReadBack.seen = []
    g.run(jobs=jobs)
    assert all(s[2] for s in _TReadBack.seen)
    if jobs == 1:  # one at a time: the second reader is the last
        assert sorted(_TReadBack.seen) == [("first", False, True), ("z_last", True, True)]
    else:  # side by side: the one releasing after the other finished, if either did
        assert sorted(s[1] for s in _TReadBack.seen) in ([False, False], [False, True])
    # read-only: nothing stored, nothing read back, the same plates
    def refuse(path, *a, **k):
        raise OSError(errno.EROFS, "Read-only file system", str(path))

    monkeypatch.setattr(cache_mod, "write_text_atomic", refuse)
    monkeypatch.setattr(cache_mod, "write_plate_temp", refuse)
    g2 = Graph(graph_dir=tmp_path, frames=(1, 1), cache=tmp_path / "ro")
    g2.add("a", _TConst, {"value": 2.0, "seed": 3})
    g2.add("z_last", _TReadBack, {"gain": 5.0}, {"a": "a"})
    _TReadBack.seen = []
    g2.run(jobs=jobs)
    assert _TReadBack.seen == [("z_last", False, True)]


def test_read_back_checks_an_entry_touched_since_written(tmp_path, monkeypatch):
    """``Cache.usable``: an entry this process wrote is trusted while its stat is unchanged;
    touched, it is hashed again (intact: usable) once, then trusted while unchanged; a changed
    byte makes it unusable."""
    import os

    from proxyshade.graph import cache as cache_mod
    from proxyshade.graph.cache import Cache

    hashed = []
    real_sha = cache_mod._sha256
    monkeypatch.setattr(cache_mod, "_sha256", lambda path: hashed.append(path) or real_sha(path))

    c = Cache(tmp_path / "cache", background=False)
    ids = np.arange(64, dtype=np.uint32).reshape(8, 8)
    c.store("k" * 64, Plate({"R": np.ones((8, 8), np.float32), "label.id": ids}), {"node": "a", "frame": 1})
    exr = c._paths("k" * 64)[0]
    assert c.usable("k" * 64) and c.read_back("k" * 64, ["label.id"])["label.id"].tobytes() == ids.tobytes()
    assert len(hashed) == 1  # the store's own hash of its record, none since
    os.utime(exr, ns=(1, 1))
    assert c.usable("k" * 64) and c.read_back("k" * 64, ["label.id"])["label.id"].tobytes() == ids.tobytes()
    assert len(hashed) == 2  # checked whole once, then trusted while its stat holds
    data = bytearray(exr.read_bytes())
    data[-1] ^= 1
    exr.write_bytes(bytes(data))
    assert not c.usable("k" * 64) and c.read_back("k" * 64, ["label.id"]) is None
    assert not Cache(tmp_path / "other", background=False).usable("k" * 64)
