"""The live page's server (proxyshade/live/server.py) through its websocket, in-process
(Starlette's test client), on the lake at 256²: an edit reaches the scene's files and every
open page, the pixels sent are the changed ones, bad messages change nothing, undo/redo
restore the scene, and no request reaches a file by its path."""
from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("starlette", reason="the live extra (pip install 'proxyshade[live]') is not installed")
pytest.importorskip("httpx", reason="Starlette's test client needs httpx (the test extra)")

import warnings  # noqa: E402

with warnings.catch_warnings():
    warnings.simplefilter("ignore")  # Starlette's notice about httpx versions
    from starlette.testclient import TestClient  # noqa: E402

from proxyshade.live.server import LiveServer  # noqa: E402
from proxyshade.live.session import Session  # noqa: E402
from proxyshade.scene.build import build_stage  # noqa: E402
from proxyshade.scene.edit import load_spec  # noqa: E402

from ._live import GRAPH, SMALL, STROKE_AT, decode  # noqa: E402


@pytest.fixture(scope="module")
def live(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("live")
    session = Session(GRAPH, {"out": str(tmp / "out")}, cache=tmp / "cache", overrides=SMALL, log=lambda m: None)
    server = LiveServer(session, token="t0k3n", sink_delay=0.2)
    with TestClient(server.app()) as client:
        yield server, client


def usda_text(data, spec) -> str:
    stage = build_stage(data, str(spec))  # held: the layer lives as long as its stage
    return stage.GetRootLayer().ExportToString()


def receive(ws, until=("edit", "error")) -> list[dict]:
    """Messages up to the first of type ``until``."""
    out = []
    while True:
        m = ws.receive()
        out.append(decode(m["bytes"]) if m.get("bytes") is not None else json.loads(m["text"]))
        if out[-1]["type"] in until:
            return out


def connect(client, token="t0k3n"):
    ws = client.websocket_connect(f"/ws?token={token}")
    return ws


def test_stroke_reaches_the_scene_files_and_every_page(live):
    server, client = live
    s = server.session
    spec_before = load_spec(s.spec)
    with connect(client) as a, connect(client) as b:
        first = [receive(w, until=("pixels",)) for w in (a, b)]
        frame0 = first[0][-1]["rgba"].copy()
        assert first[0][-1]["w"] == first[0][-1]["width"] == 256  # the whole frame on connecting
        a.send_text(json.dumps({"type": "stroke", "frame": 1, "points": [STROKE_AT], "radius": 7, "strength": 9}))
        got = [receive(w) for w in (a, b)]
    for msgs in got:  # both pages: the changed box's pixels, then the edit
        pix = [m for m in msgs if m["type"] == "pixels"]
        assert len(pix) == 1 and msgs[-1]["type"] == "edit" and msgs[-1]["undo"] == 1
    px = [m for m in got[0] if m["type"] == "pixels"][0]
    x, y, w, h = px["x"], px["y"], px["w"], px["h"]
    assert w * h < 256 * 256 and y <= STROKE_AT[1] < y + h and x <= STROKE_AT[0] < x + w
    # the box is exactly what changed: the page's picture patched with it is the frame as now computed
    from proxyshade.live.server import pixels_message

    now = decode(pixels_message(s.frame_plate(1), "frame", 1))["rgba"]
    patched = frame0.copy()
    patched[y:y + h, x:x + w] = px["rgba"]
    assert np.array_equal(patched, now)
    assert not np.array_equal(frame0[y:y + h, x:x + w], px["rgba"])
    # the scene's files hold the stroke: the description one more stroke, the .usda its build
    spec = load_spec(s.spec)
    ground = lambda d: next(t for t in d["terrains"] if t["name"] == "Ground")  # noqa: E731
    assert len(ground(spec)["strokes"]) == len(ground(spec_before)["strokes"]) + 1
    assert ground(spec)["strokes"][-1]["radius"] == 7.0 and ground(spec)["strokes"][-1]["amount"] == 9.0
    assert s.usda.read_text() == usda_text(spec, s.spec)


BAD = [
    "not json", "[1, 2]", json.dumps({"no": "type"}), json.dumps({"type": "explode"}),
    json.dumps({"type": "stroke", "frame": 1, "points": [[9999, 5]], "radius": 7, "strength": 9}),
    json.dumps({"type": "stroke", "frame": 1, "points": [[5, -1]], "radius": 7, "strength": 9}),
    json.dumps({"type": "stroke", "frame": 1, "points": [STROKE_AT], "radius": -3, "strength": 9}),
    json.dumps({"type": "stroke", "frame": 1, "points": [STROKE_AT], "radius": 7, "strength": 0}),
    json.dumps({"type": "stroke", "frame": 1, "points": [STROKE_AT], "radius": "7", "strength": 9}),
    json.dumps({"type": "stroke", "frame": 1, "points": [STROKE_AT], "radius": 1e400, "strength": 9}),
    json.dumps({"type": "stroke", "frame": 1, "points": [], "radius": 7, "strength": 9}),
    json.dumps({"type": "stroke", "frame": 1, "points": [[1, 2, 3]], "radius": 7, "strength": 9}),
    json.dumps({"type": "stroke", "frame": 99, "points": [STROKE_AT], "radius": 7, "strength": 9}),
    json.dumps({"type": "stroke", "frame": 1, "points": [[128, 2]], "radius": 7, "strength": 9}),  # sky
    json.dumps({"type": "sphere", "frame": 1, "at": STROKE_AT, "radius": 3, "label": "../../etc/passwd"}),
    json.dumps({"type": "remove", "frame": 1, "at": STROKE_AT}),  # water, not a sphere
    json.dumps({"type": "view", "view": "../../pyproject.toml"}),
    json.dumps({"type": "frame", "frame": "1; rm -rf /"}),
    json.dumps({"type": "stroke", "frame": 1, "points": [STROKE_AT] * 300, "radius": 7, "strength": 9}),
]


def test_bad_messages_get_an_error_and_change_nothing(live):
    server, client = live
    s = server.session
    files = {p: p.read_bytes() for p in (s.spec, s.usda)}
    undo = len(s.undo_stack)
    with connect(client) as ws:
        receive(ws, until=("pixels",))
        for text in BAD:
            ws.send_text(text)
            msgs = receive(ws)
            assert msgs[-1]["type"] == "error", (text, msgs[-1])
            assert not [m for m in msgs if m["type"] == "pixels"]
        ws.send_text("x" * 70000)
        assert receive(ws)[-1]["type"] == "error"
    assert {p: p.read_bytes() for p in files} == files
    assert len(s.undo_stack) == undo


def test_undo_redo_restore_the_scene(live):
    server, client = live
    s = server.session
    with connect(client) as ws:
        receive(ws, until=("pixels",))
        before = load_spec(s.spec)
        ws.send_text(json.dumps({"type": "sphere", "frame": 1, "at": STROKE_AT, "radius": 3, "label": "tree"}))
        assert receive(ws)[-1]["type"] == "edit"
        after = load_spec(s.spec)
        added = [g for g in after["spheres"] if g not in before["spheres"]]
        assert len(added) == 1 and added[0]["label"] == "tree"
        ws.send_text(json.dumps({"type": "undo"}))
        assert receive(ws)[-1]["type"] == "edit"
        assert load_spec(s.spec) == before
        assert s.usda.read_text() == usda_text(before, s.spec)
        ws.send_text(json.dumps({"type": "redo"}))
        assert receive(ws)[-1]["type"] == "edit"
        assert load_spec(s.spec) == after
        # the sphere under the cursor goes again: find it in the proxy's objects
        p = s.proxy_plate(1)
        names = {o["id"]: o["name"] for o in p.meta["objects"]}
        ys, xs = np.nonzero(np.isin(p["object.id"], [i for i, n in names.items() if f"/{added[0]['name']}/" in n]))
        ws.send_text(json.dumps({"type": "remove", "frame": 1, "at": [int(xs[len(xs) // 2]), int(ys[len(ys) // 2])]}))
        assert receive(ws)[-1]["type"] == "edit"
        assert load_spec(s.spec) == before


def test_one_sphere_of_a_group_goes_the_others_stay(live):
    from proxyshade.scene.spheres import along_path

    server, client = live
    s = server.session
    p = s.proxy_plate(1)
    names = {o["id"]: o["name"] for o in p.meta["objects"]}
    sid = next(i for i, n in names.items() if n.endswith("/TreesRight/S001"))
    ys, xs = np.nonzero(p["object.id"] == sid)
    group = next(g for g in load_spec(s.spec)["spheres"] if g["name"] == "TreesRight")
    centres, radii = along_path(group["path"], group["radius"], group["count"])
    with connect(client) as ws:
        receive(ws, until=("pixels",))
        ws.send_text(json.dumps({"type": "remove", "frame": 1, "at": [int(xs[len(xs) // 2]), int(ys[len(ys) // 2])]}))
        assert receive(ws)[-1]["type"] == "edit"
        ws.send_text(json.dumps({"type": "undo"}))
        receive(ws)
        ws.send_text(json.dumps({"type": "redo"}))
        receive(ws)
    rest = [g for g in load_spec(s.spec)["spheres"] if g["name"].startswith("TreesRight")]
    kept = np.array([g["path"][0] for g in rest])
    assert len(rest) == len(centres) - 1
    assert np.allclose(kept, np.delete(centres, 1, axis=0), atol=1e-3)
    assert np.allclose([g["radius"] for g in rest], np.delete(radii, 1), atol=1e-3)


def test_no_request_reaches_a_file_by_its_path(live):
    server, client = live
    secret = (GRAPH.parents[1] / "pyproject.toml").read_text()
    page = client.get("/?token=t0k3n").text
    for path in ["/static/../pyproject.toml", "/static/..%2f..%2fpyproject.toml", "/static/%2e%2e/%2e%2e/pyproject.toml",
                 "/../../pyproject.toml", "/static/index.html/../../../pyproject.toml", "/static/server.py",
                 "/static/..", "/etc/passwd", "/static/%2fetc%2fpasswd", "/out/lake_renoir.0001.exr",
                 "/static//etc/passwd"]:
        r = client.get(path + "?token=t0k3n")
        if r.text == page:  # a path the client itself normalizes to '/' (``/static/..``)
            continue
        assert r.status_code in (403, 404), path
        assert "[project]" not in r.text and "root:" not in r.text and "import" not in r.text, path
    assert client.get("/static/app.js").status_code == 200
    assert client.get("/?token=t0k3n").status_code == 200
    assert "t0k3n" not in secret
    # the page and the websocket only with the token
    assert client.get("/").status_code == 403 and client.get("/?token=wrong").status_code == 403
    from starlette.websockets import WebSocketDisconnect

    with pytest.raises(WebSocketDisconnect):
        with client.websocket_connect("/ws?token=wrong") as ws:
            ws.receive_text()


def test_sinks_written_after_the_update(live):
    server, client = live
    s = server.session
    exr = s.out_dir / "lake_renoir.0001.exr"
    with connect(client) as ws:
        receive(ws, until=("pixels",))
        time.sleep(4 * server.sink_delay)  # the earlier tests' writes done
        server.sinks.submit(lambda: None).result()
        t = exr.stat().st_mtime_ns if exr.exists() else 0
        ws.send_text(json.dumps({"type": "stroke", "frame": 1, "points": [[60, 160]], "radius": 5, "strength": -4}))
        msgs = receive(ws)
        assert msgs[-1]["type"] == "edit"
        assert (exr.stat().st_mtime_ns if exr.exists() else 0) == t  # not on the update's path
        saved = receive(ws, until=("saved",))[-1]
    assert str(exr) in saved["files"] and exr.stat().st_mtime_ns > t
    from proxyshade.io.exr import read_plate

    plate = read_plate(exr)
    assert np.array_equal(plate["R"], s.frame_plate(1)["R"])


_WRITES: list | None = None


def _audit(event, args):
    if _WRITES is None:
        return
    if event == "open":
        path, mode, flags = args
        writing = (mode is not None and any(c in str(mode) for c in "wax+")) or \
                  (mode is None and isinstance(flags, int) and flags & (os.O_WRONLY | os.O_RDWR | os.O_CREAT))
        if writing and isinstance(path, (str, bytes, os.PathLike)):
            _WRITES.append(Path(os.fsdecode(path)).resolve())
    elif event in ("os.rename", "os.replace", "os.remove", "os.unlink"):
        _WRITES.append(Path(os.fsdecode(args[-1] if event in ("os.rename", "os.replace") and len(args) == 2
                                        else args[1] if event in ("os.rename", "os.replace") else args[0])).resolve())


sys.addaudithook(_audit)


def test_edits_write_only_the_scene_and_the_outputs(live):
    """Every file an edit, an undo or a save writes, renames or removes (Python's audit
    events, every thread of the server) lies in the scene's folder or the output folder."""
    global _WRITES
    server, client = live
    s = server.session
    allowed = [s.spec.parent.resolve(), s.out_dir.resolve()]
    from proxyshade.kernels import _cache

    kernels = Path(_cache.folder()).resolve().parent  # numba's compiled kernels (a first call compiles)
    with connect(client) as ws:
        receive(ws, until=("pixels",))
        time.sleep(4 * server.sink_delay)
        server.sinks.submit(lambda: None).result()
        _WRITES = []
        try:
            for msg in ({"type": "stroke", "frame": 1, "points": [[100, 170]], "radius": 4, "strength": 3},
                        {"type": "sphere", "frame": 1, "at": [150, 160], "radius": 3, "label": "tree"},
                        {"type": "undo"}, {"type": "redo"}):
                ws.send_text(json.dumps(msg))
                assert receive(ws)[-1]["type"] == "edit"
            ws.send_text(json.dumps({"type": "save"}))
            receive(ws, until=("saved",))
            written = list(_WRITES)
        finally:
            _WRITES = None
    assert any(s.spec.parent.resolve() in p.parents for p in written)  # the hook saw the scene's writes
    assert any(s.out_dir.resolve() in p.parents or p.parent == s.out_dir.resolve() for p in written)
    stray = [p for p in written if not any(a == p.parent or a in p.parents for a in allowed)
             and kernels not in p.parents and "kernels" not in p.parts and not str(p).startswith("/dev/")]
    assert stray == []
