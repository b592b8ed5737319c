"""The Dask executor on a LocalCluster of 2 worker processes (loopback): outputs bit-identical
to the local executor, a worker killed mid-task (the run completes, every cache entry
whole), concurrent runs on one cache, several graphs at once, and the one-line error
without Dask installed."""
from __future__ import annotations

import json
import os
import signal
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from proxyshade.cli import main
from proxyshade.graph.cache import Cache
from proxyshade.graph.graph import Graph
from proxyshade.graph.node import InputRef, Node, Param
from proxyshade.graph.plate import Plate

pytest.importorskip("distributed")
from proxyshade.graph.dask_executor import DaskExecutor
from proxyshade.graph.shots import run_graphs  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


class _TSlow(Node, register=False):
    """R = value + frame, after ``seconds``; appends 'frame pid' to ``log`` when it starts
    (the test's record of every compute, on whichever worker). With ``victim`` (a path), the
    first compute of all creates that file with its pid and sleeps until it is killed."""

    time_dependent = True
    value = Param(float, 1.0)
    seconds = Param(float, 0.5, hashed=False)
    log = Param(str, "", hashed=False)
    victim = Param(str, "", hashed=False)

    def compute(self, ctx):
        if ctx.p.log:
            with open(ctx.p.log, "a") as f:
                f.write(f"{self.name} {ctx.frame} {os.getpid()}\n")
        if ctx.p.victim:
            try:
                fd = os.open(ctx.p.victim, os.O_WRONLY | os.O_CREAT | os.O_EXCL)
            except FileExistsError:
                pass
            else:
                os.write(fd, f"{os.getpid()}\n".encode())
                os.close(fd)
                time.sleep(600)  # killed meanwhile
        time.sleep(ctx.p.seconds)
        rng = np.random.default_rng(ctx.frame)
        return Plate({"R": (ctx.p.value + ctx.frame + rng.random((16, 16))).astype(np.float32)})


@pytest.fixture(scope="module")
def dask_ex():
    """One LocalCluster of 2 worker processes for the module (closed at the end)."""
    with DaskExecutor(workers=2) as ex:
        assert len(ex.client.scheduler_info()["workers"]) in (1, 2) and ex.address.startswith("tcp://127.0.0.1:")
        yield ex


def outputs(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def entries_intact(cache: Path) -> dict[str, bool]:
    """Every entry of the cache (by its record) -> whether its EXR, record and header agree."""
    c = Cache(cache, background=False)
    return {js.stem: c.intact(js.stem) for js in cache.glob("??/*.json") if not json.loads(js.read_text()).get("sink")}


def small_move(cache: Path, out: Path) -> Graph:
    return Graph.load(ROOT / "graphs" / "camera_move.yaml", cache=cache,
                      overrides=["proxy.resolution=[64,64]", "guide.size=32", "guide.start=16"],
                      variables={"out": str(out)})


def test_camera_move_on_dask_is_bit_identical_to_local(tmp_path, dask_ex):
    """Frames 1-4 of the camera move (64x64): the same 16 EXRs and PNGs, GIF and cache entries as
    the local executor; a re-run computes nothing."""
    local = small_move(tmp_path / "c_local", tmp_path / "local").run([1, 2, 3, 4])  # compiles the kernels if needed
    r = small_move(tmp_path / "c_dask", tmp_path / "dask").run([1, 2, 3, 4], executor=dask_ex)
    assert outputs(tmp_path / "dask") == outputs(tmp_path / "local") and len(outputs(tmp_path / "local")) == 17
    assert [(x.node, x.frame, x.status) for x in r.runs] == [(x.node, x.frame, x.status) for x in local.runs]
    assert {(x.node, x.frame) for x in r.runs if x.status == "computed"} >= {("final", 4), ("first", 1), ("movie", 4)}
    assert sum(x.seconds for x in r.runs) > 0 and any(n.startswith("computed on Dask (tcp://127.0.0.1:") for n in r.notes)
    assert any("flagged" in n for n in r.notes)  # the nodes' notes come back from the workers
    intact = entries_intact(tmp_path / "c_dask")
    # and the plates the local run keeps in memory only (Node.stored: Cryptomatte, Reproject), which a worker stores
    # for the others
    unstored = {x.key for x in local.runs if x.node in ("crypto", "reproject")}
    assert unstored and not unstored & set(entries_intact(tmp_path / "c_local"))
    assert intact and all(intact.values()) and set(intact) == set(entries_intact(tmp_path / "c_local")) | unstored
    again = small_move(tmp_path / "c_dask", tmp_path / "dask").run([1, 2, 3, 4], executor=dask_ex)
    assert not again.computed


def slow_graph(tmp_path: Path, name: str = "slow", seconds: float = 0.5, frames: int = 4, victim: str = "") -> Graph:
    g = Graph(frames=(1, frames), cache=tmp_path / "cache", name=name)
    g.add("slow", _TSlow, {"value": 0.5, "seconds": seconds, "log": str(tmp_path / f"{name}.log"), "victim": victim})
    g.add("sum", "TAdd", {"gain": 0.5}, {"a": "slow", "prev": InputRef("sum", -1)})
    g.add("write", "ExrWrite", {"path": str(tmp_path / "out" / f"{name}.####.exr")}, {"image": "sum"})
    return g


def computes(log: Path) -> list[tuple[str, int, int]]:
    """(node, frame, pid) of every compute logged (none when the log was never written)."""
    if not log.exists():
        return []
    return [(n, int(f), int(p)) for n, f, p in (line.split() for line in log.read_text().splitlines())]


def test_the_correction_in_row_bands_on_two_workers_is_bit_identical(tmp_path, monkeypatch):
    """Every level's sub-passes split in row bands over the 2 workers (the size threshold
    lowered for the test): the first frame's EXR is the local executor's, bit for bit."""
    from distributed import get_task_stream

    monkeypatch.setenv("PROXYSHADE_TILE_MIN_PIXELS", "0")  # read by the workers' kernels module

    def graph(name):
        return Graph.load(ROOT / "graphs" / "first_frame.yaml", cache=tmp_path / f"c_{name}",
                          overrides=["proxy.resolution=[96,64]", "guide.size=32", "guide.start=16",
                                     "preview.enabled=false", "proxy_labels.enabled=false",
                                     "detail_labels.enabled=false"],
                          variables={"out": str(tmp_path / name)})

    graph("local").run([1])
    with DaskExecutor(workers=2) as ex, get_task_stream(ex.client) as ts:
        graph("dask").run([1], executor=ex)
    assert outputs(tmp_path / "dask") == outputs(tmp_path / "local") and len(outputs(tmp_path / "local")) == 1
    assert sum(t["key"].startswith("_band") for t in ts.data) >= 8  # the sub-passes ran as bands


def test_a_killed_worker_is_replaced_and_the_run_completes(tmp_path, registry):
    """kill -9 of a worker in the middle of a task (the first compute of all, which waits to
    be killed however slow the machine): the scheduler runs that task again in another
    process (the other worker, or the nanny's replacement if it is up first); outputs equal a
    local run's and every cache entry is whole. A cluster of its own: however long the
    replacement takes to start on a busy machine, no other test waits for it, and this one
    does not need it (the surviving worker finishes the run)."""
    ref = tmp_path / "ref"
    ref.mkdir()
    slow_graph(ref, seconds=0.0).run()
    victim = tmp_path / "victim"
    killed = []

    def kill_the_victim():
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline:
            text = victim.read_text() if victim.exists() else ""
            if text.endswith("\n"):  # its pid, whole
                os.kill(int(text), signal.SIGKILL)
                killed.append(int(text))
                return
            time.sleep(0.02)

    with DaskExecutor(workers=2) as ex:
        killer = threading.Thread(target=kill_the_victim, daemon=True)
        killer.start()
        r = slow_graph(tmp_path, seconds=0.2, victim=str(victim)).run(executor=ex)
        killer.join(5)
    assert killed and all(x.status == "computed" for x in r.runs)
    done = computes(tmp_path / "slow.log")
    first = next(c for c in done if c[2] == killed[0])  # the task the victim was computing
    assert [c[:2] for c in done].count(first[:2]) == 2  # ran again,
    assert [c[2] for c in done].count(killed[0]) == 1  # elsewhere
    assert sorted({c[:2] for c in done}) == [("slow", f) for f in (1, 2, 3, 4)] and len(done) == 5
    assert outputs(tmp_path / "out") == outputs(ref / "out")
    intact = entries_intact(tmp_path / "cache")
    assert len(intact) == 8 and all(intact.values())
    assert not [p for p in (tmp_path / "cache").rglob(".*") if ".tmp" in p.name]


def test_workers_start_with_the_libraries_loaded_and_allocate_like_a_local_run(dask_ex):
    """A LocalCluster's workers are forked from a process that loaded Dask, the node modules
    and the serial kernels once (a worker starts in a few hundredths of a
    CPU second instead of importing all that), and without Dask's MALLOC_TRIM_THRESHOLD_
    (which made glibc map and zero every array afresh: 9x a local run's page faults). The
    image loads only kernels already precompiled (it never compiles): Correct's are in every
    worker when their unit was marked precompiled as the image loaded (a fresh install's
    first cluster has none marked; each worker then loads them on first use)."""
    def state():
        from proxyshade.graph import dask_executor as de

        return {"nodes": "proxyshade.nodes.resynthesize" in sys.modules, "kernels": "proxyshade.kernels.correct" in sys.modules,
                "marked": "node.Correct" in de.IMAGE_MARKED,
                "trim": os.environ.get("MALLOC_TRIM_THRESHOLD_"), "parent": os.getppid()}

    got = list(dask_ex.client.run(state).values())
    assert len(got) == 2 and all(g["nodes"] and g["trim"] is None for g in got)
    assert all(g["kernels"] for g in got if g["marked"])
    assert got[0]["parent"] == got[1]["parent"] != os.getpid()  # one forkserver, not this process


def test_two_concurrent_runs_on_one_scheduler_compute_each_key_once(tmp_path, dask_ex, registry):
    """Two clients run the same graph on one cache at once: both complete with correct
    outputs, each key computed once (the scheduler runs a key once; the other run waits)."""
    ref = tmp_path / "ref"
    ref.mkdir()
    slow_graph(ref, seconds=0.0).run()
    reports = {}

    def second():
        with DaskExecutor(dask_ex.address) as other:
            reports["b"] = slow_graph(tmp_path, seconds=0.4).run(executor=other)

    t = threading.Thread(target=second)
    t.start()
    reports["a"] = slow_graph(tmp_path, seconds=0.4).run(executor=dask_ex)
    t.join()
    done = [c[:2] for c in computes(tmp_path / "slow.log")]
    assert sorted(done) == [("slow", f) for f in (1, 2, 3, 4)]  # once each over both runs
    for r in reports.values():
        assert {(x.node, x.frame) for x in r.runs} == {(n, f) for n in ("slow", "sum", "write") for f in (1, 2, 3, 4)}
    assert outputs(tmp_path / "out") == outputs(ref / "out")
    assert all(entries_intact(tmp_path / "cache").values())


def test_a_local_and_a_dask_run_at_once_on_one_cache_both_correct(tmp_path, dask_ex, registry):
    """Without a shared scheduler (a local run beside a Dask one) keys may be computed twice,
    but the first stored entry stays and no entry is ever mixed from two writers."""
    ref = tmp_path / "ref"
    ref.mkdir()
    slow_graph(ref, seconds=0.0).run()
    reports = {}
    t = threading.Thread(target=lambda: reports.setdefault("local", slow_graph(tmp_path, seconds=0.2).run()))
    t.start()
    reports["dask"] = slow_graph(tmp_path, seconds=0.2).run(executor=dask_ex)
    t.join()
    assert outputs(tmp_path / "out") == outputs(ref / "out")
    intact = entries_intact(tmp_path / "cache")
    assert len(intact) == 8 and all(intact.values())
    for name in ("local", "dask"):
        assert {(x.node, x.frame) for x in reports[name].runs} == {(n, f) for n in ("slow", "sum", "write")
                                                                  for f in (1, 2, 3, 4)}


def test_several_graphs_share_their_common_keys(tmp_path, dask_ex, registry):
    """Two shots submitted together: a key both have is computed once, the second's row
    says whose it is; a third writing the first's files is refused before anything runs."""
    a, b = slow_graph(tmp_path, "a", 0.0), slow_graph(tmp_path, "b", 0.0)
    ra, rb = run_graphs([(a, None), (b, None)], executor=dask_ex, labels=["shot a", "shot b"])
    assert len(computes(tmp_path / "a.log")) + len(computes(tmp_path / "b.log")) == 4  # same keys: 'slow' once per frame
    shared = [x for x in ra.runs + rb.runs if x.node == "slow" and x.status == "reused"]
    assert len(shared) == 4 and all("same key as" in x.reason for x in shared)
    assert (tmp_path / "out" / "a.0004.exr").read_bytes() == (tmp_path / "out" / "b.0004.exr").read_bytes()
    c = slow_graph(tmp_path, "c", 0.0)
    c.set("write.path", str(tmp_path / "out" / "a.####.exr"))
    from proxyshade.errors import UserError

    with pytest.raises(UserError, match=r"shot a and shot c both write .*a\.0001\.exr"):
        run_graphs([(a, None), (c, None)], executor=dask_ex, labels=["shot a", "shot c"])


def test_independent_shots_each_stay_on_one_worker(tmp_path, dask_ex, registry):
    """As many shots as workers: each shot's chain runs on one worker (its plates and
    memoised analyses stay in that worker's memory), the shots on different workers."""
    a, b = slow_graph(tmp_path, "a", 0.05), slow_graph(tmp_path, "b", 0.05)
    b.set("slow.value", 1.5)
    run_graphs([(a, None), (b, None)], executor=dask_ex, labels=["shot a", "shot b"])
    pa = {pid for _, _, pid in computes(tmp_path / "a.log")}
    pb = {pid for _, _, pid in computes(tmp_path / "b.log")}
    assert len(computes(tmp_path / "a.log")) == len(computes(tmp_path / "b.log")) == 4
    assert len(pa) == len(pb) == 1 and pa != pb


def test_shots_on_workers_of_their_own_run_a_frame_per_task_as_a_local_run(tmp_path, dask_ex):
    """Two shots of the camera move on the 2 workers (no key in common): each frame of a shot
    is one task (6 tasks for 2 x 3 frames, not one per instance), the outputs, the rows and
    the cache entries are the local executor's: Cryptomatte's plates, read only by the
    frame's writer in the same task, stay in memory as in a local run."""
    from distributed import get_task_stream

    def shots(name):
        return [(Graph.load(ROOT / "graphs" / "camera_move.yaml", cache=tmp_path / f"c_{name}",
                            overrides=["proxy.resolution=[64,64]", "guide.size=32", "guide.start=16"],
                            variables={"out": str(tmp_path / name / src), "source": src, "scene": scene}), [1, 2, 3])
                for src, scene in (("renoir", "lake"), ("creek", "farm"))]

    local = run_graphs(shots("local"))
    dask_ex.client.wait_for_workers(2, timeout=300)  # one shot per worker: both up
    with get_task_stream(dask_ex.client) as ts:
        dask = run_graphs(shots("dask"), executor=dask_ex)
    assert outputs(tmp_path / "dask") == outputs(tmp_path / "local") and len(outputs(tmp_path / "local")) == 2 * 13
    for r, ref in zip(dask, local):
        assert [(x.node, x.frame, x.status) for x in r.runs] == [(x.node, x.frame, x.status) for x in ref.runs]
        assert len([n for n in r.notes if n.startswith("computed on Dask")]) == 1
    assert len({t["key"] for t in ts.data if t["key"].startswith("proxyshade-")}) == 6  # a task per shot and frame
    assert sum(x.status == "computed" for r in dask for x in r.runs) > 40
    crypto = {x.key for r in local for x in r.runs if x.node == "crypto"}
    assert crypto and set(entries_intact(tmp_path / "c_dask")) == set(entries_intact(tmp_path / "c_local"))
    assert not crypto & set(entries_intact(tmp_path / "c_dask")) and all(entries_intact(tmp_path / "c_dask").values())


def test_frame_tasks_never_wait_in_a_circle():
    """``_groups`` on a DAG where joining the frame's task would make two tasks wait for
    each other (c@1 reads a@1 and b@2, b@2 reads a@1): c@1 is a task of its own; every
    instance of a task has the task's frame and the tasks wait for each other without a cycle."""
    import networkx as nx

    from proxyshade.graph.dask_executor import _groups

    class Job:
        todo = nx.DiGraph([(("a", 1), ("b", 2)), (("a", 1), ("c", 1)), (("b", 2), ("c", 1)), (("a", 1), ("d", 1)),
                           (("d", 1), ("e", 1)), (("b", 2), ("f", 2)), (("s", 1), ("a", 1)), (("s", 1), ("b", 2))])
        plan = type("Plan", (), {"keys": {inst: f"{inst[0]}{inst[1]}" for inst in todo}})

    order = list(nx.lexicographical_topological_sort(Job.todo, key=str))
    head = _groups(Job, order, shared=set())
    assert head[("c", 1)] == ("c", 1) and head[("d", 1)] == head[("e", 1)] == head[("a", 1)]
    assert head[("f", 2)] == ("b", 2) and all(h[1] == i[1] for i, h in head.items())
    tasks = nx.DiGraph((head[u], head[v]) for u, v in Job.todo.edges if head[u] != head[v])
    assert nx.is_directed_acyclic_graph(tasks)
    shared = _groups(Job, order, shared={"a1"})  # a key another shot computes too: a task of its own
    assert shared[("a", 1)] == ("a", 1) and shared[("d", 1)] == ("d", 1) != shared[("s", 1)]


GRAPH = """\
format: proxyshade/1
frames: 1-3
vars:
  v: {default: "1"}
nodes:
  a: {type: TRead, params: {path: "in/${v}.txt"}}
  f: {type: TFrame}
  s: {type: TAdd, inputs: {a: f, b: a, prev: {node: s, frame: -1}}}
  w: {type: ExrWrite, inputs: {image: a}, params: {path: "out/${v}/a.####.exr"}}
  x: {type: ExrWrite, inputs: {image: s}, params: {path: "out/${v}/s.####.exr"}}
"""


def write_sweep_graph(folder: Path) -> None:
    (folder / "g.yaml").write_text(GRAPH)
    (folder / "in").mkdir()
    (folder / "in" / "1.txt").write_text("1.0")
    (folder / "in" / "2.txt").write_text("2.5")


def test_cli_runs_a_sweep_on_a_scheduler(tmp_path, dask_ex, registry, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write_sweep_graph(tmp_path)
    rc = main(["run", "g.yaml", "--sweep", "v=1,2", "-q", "--scheduler", dask_ex.address])
    out, err = capsys.readouterr()
    assert rc == 0, err
    assert "g.yaml [v=1]" in out and "g.yaml [v=2]" in out and out.count("computed on Dask") == 2
    # a once, f, s, w and x at 3 frames; the second shot's f is the first's (no variable in it)
    assert "13 computed, 2 reused" in out and "10 computed, 5 reused" in out
    from proxyshade.io.exr import read_plate

    assert read_plate(tmp_path / "out" / "2" / "a.0002.exr")["R"][0, 0] == 2.5
    assert read_plate(tmp_path / "out" / "1" / "s.0003.exr")["R"][0, 0] == 9.0  # (1 + 1) + (2 + 1) + (3 + 1)
    rc = main(["run", "g.yaml", "--sweep", "v=1,2", "-q", "--executor", "local"])
    out, _ = capsys.readouterr()
    assert rc == 0 and out.count("0 computed, ") == 2  # the same keys: all in the cache


def test_without_dask_the_executor_is_a_one_line_error(tmp_path, registry, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write_sweep_graph(tmp_path)
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed -> ImportError
    rc = main(["run", "g.yaml", "-q", "--executor", "dask"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "pip install 'proxyshade[dask]'" in err[0], err
    assert not (tmp_path / "out").exists()


def test_an_unreachable_scheduler_is_a_one_line_error(tmp_path, registry, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write_sweep_graph(tmp_path)
    import socket

    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    import dask

    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}):
        rc = main(["run", "g.yaml", "-q", "--scheduler", f"tcp://127.0.0.1:{port}"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and f"--scheduler tcp://127.0.0.1:{port}: cannot connect" in err[0], err


class _Banner(threading.Thread):
    """A real TCP service on 127.0.0.1 that is not a Dask scheduler: it greets every
    connection with ``banner`` (an SSH server does) or, with None, waits for the client to
    speak (an HTTP server does), holding the connection open until the test ends."""

    def __init__(self, banner: bytes | None):
        import socket

        super().__init__(daemon=True)
        self.banner = banner
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen()
        self.address = "tcp://127.0.0.1:%d" % self.sock.getsockname()[1]
        self.conns = []

    def run(self):
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            self.conns.append(conn)
            if self.banner is not None:
                conn.sendall(self.banner)

    def __enter__(self):
        self.start()
        return self

    def __exit__(self, *exc):
        self.sock.close()
        for c in self.conns:
            c.close()


@pytest.mark.parametrize("kind", ["ssh", "http"])
def test_a_scheduler_address_of_another_service_is_a_one_line_error(tmp_path, registry, capsys, monkeypatch, kind):
    """--scheduler naming a service that speaks first (an SSH banner: Dask's client read its
    first 8 bytes as a length and asked for exabytes) or one that waits for a request (a
    silent HTTP server: the client waited for ever): exit 2 within the connect timeout, one
    line naming the address and what to give instead; nothing written."""
    import dask
    from http.server import BaseHTTPRequestHandler, HTTPServer

    monkeypatch.chdir(tmp_path)
    write_sweep_graph(tmp_path)
    if kind == "ssh":
        service = _Banner(b"SSH-2.0-OpenSSH_9.6p1 Ubuntu-3ubuntu13.5\r\n")
    else:
        http = HTTPServer(("127.0.0.1", 0), BaseHTTPRequestHandler)
        service = threading.Thread(target=http.serve_forever, daemon=True)
        service.address = "tcp://127.0.0.1:%d" % http.server_address[1]
    service.start()
    try:
        done = {}

        def run():
            with dask.config.set({"distributed.comm.timeouts.connect": "2s"}):
                done["rc"] = main(["run", "g.yaml", "-q", "--scheduler", service.address])

        t = time.monotonic()
        runner = threading.Thread(target=run, daemon=True)  # a hang fails the test instead of stalling it
        runner.start()
        runner.join(60)
        seconds = time.monotonic() - t
        assert not runner.is_alive(), "the run still waits on the service after 60 s"
        rc = done["rc"]
    finally:
        if kind == "ssh":
            service.__exit__()
        else:
            http.shutdown()
            http.server_close()
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1, err
    assert f"not a Dask scheduler at {service.address}" in err[0] and "tcp://host:8786" in err[0], err
    assert ("SSH-2.0" in err[0]) if kind == "ssh" else ("no Dask handshake within 2 s" in err[0]), err
    assert seconds < 2 + 8  # the connect timeout, plus the CLI's start on a busy machine
    assert not (tmp_path / "out").exists()


def test_a_worker_on_other_code_is_a_one_line_error():
    """A worker whose proxyshade differs from the client's (another version on a farm node)
    refuses to store results under keys that name the client's code."""
    from proxyshade.errors import UserError
    from proxyshade.graph.dask_executor import _check_code
    from proxyshade.graph.keys import code_hash

    _check_code(_TSlow, code_hash(_TSlow))
    with pytest.raises(UserError, match=r"runs other proxyshade code for _TSlow .*install the same proxyshade"):
        _check_code(_TSlow, "0" * 64)


def test_adaptive_malloc_undoes_dasks_trim_threshold():
    """Under Dask's MALLOC_TRIM_THRESHOLD_=65536 (a farm's nanny sets it), 40 temporaries of 8
    MiB each map and zero fresh pages (page faults), unless the worker plugin's
    ``adaptive_malloc`` raised glibc's thresholds: then they reuse the heap's."""
    import subprocess

    code = ("import resource, sys, numpy as np\n"
            "from proxyshade.graph.dask_executor import adaptive_malloc\n"
            "print(adaptive_malloc() if sys.argv[1] == 'fix' else False)\n"
            "a = np.ones(1 << 20)\n"
            "before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt\n"
            "for _ in range(40):\n"
            "    a = a + 1.0\n"
            "print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)\n")
    env = dict(os.environ, MALLOC_TRIM_THRESHOLD_="65536")
    faults = {}
    for mode in ("plain", "fix"):
        out = subprocess.run([sys.executable, "-c", code, mode], env=env, capture_output=True, text=True, check=True)
        changed, n = out.stdout.split()
        assert changed == str(mode == "fix")
        faults[mode] = int(n)
    assert faults["plain"] > 40 * 100  # each array's pages faulted in afresh (20641 here)
    assert faults["fix"] < faults["plain"] / 10  # the heap's, reused (516 here; 1535 with no variable)
    env.pop("MALLOC_TRIM_THRESHOLD_")  # a LocalCluster's worker: raised all the same (Preload(local=True))
    out = subprocess.run([sys.executable, "-c", "from proxyshade.graph.dask_executor import adaptive_malloc as a\n"
                          "print(a(), a(always=True))"], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "True"]
