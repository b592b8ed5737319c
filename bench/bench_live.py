"""The live page's stroke latency, end to end through the server: ``proxyshade edit
graphs/edit.yaml`` (the lake from renoir, 1024² frame, 256² synthesis) started as a user
starts it, and a websocket client (the ``websockets`` package) in place of the page.

Each stroke is a page's message (image pixels, radius and strength in scene units; the
pixels of bench_edit's two edits, found from the P AOV of the EXR the server wrote at
start); the time is from sending it to receiving the updated pixels (the changed box of
the frame, 8-bit sRGB, ready to paint), and the server's own count from receiving it to
sending them. The edits alternate: hill raised, undone, island raised, undone (each undo
an edit of the same size), ``--pause`` seconds after each update as an artist's pace
(under the server's 1.5 s rest before it writes the EXR and preview: those are timed apart,
once the edits rest). Target: median <= 0.3 s for the ~5% edit (the hill) on 2 cores.

    python bench/bench_live.py [--rounds 5] [--pause 0.4] [--cache DIR] [--size 1024]
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import statistics
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from harness import table

ROOT = Path(__file__).resolve().parents[1]
EDITS = [("hill in the lake", (0, -38), 10.0, 9.0), ("island", (5, -40), 7.0, 9.0)]  # bench_edit's


def decode(m):
    if isinstance(m, bytes):
        n = struct.unpack("<I", m[:4])[0]
        return json.loads(m[4:4 + n])
    return json.loads(m)


def pixel_of(exr: Path, x: float, z: float) -> list[float]:
    """The image pixel whose world position (P AOV) is nearest (x, z) on the ground."""
    import numpy as np

    from proxyshade.io.exr import read_plate

    p = read_plate(exr)
    d = (p["P.X"] - x) ** 2 + (p["P.Z"] - z) ** 2
    d[~np.isfinite(d)] = np.inf
    y, xx = np.unravel_index(np.argmin(d), d.shape)
    return [float(xx) + 0.5, float(y) + 0.5]


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--pause", type=float, default=0.4)
    ap.add_argument("--cache", type=Path, default=None, help="plate cache (default: a new one: the first frame cold)")
    ap.add_argument("--size", type=int, default=1024)
    if argv is None:  # its own command line; under bench/run.py (``run.py live``) the defaults
        argv = sys.argv[1:] if Path(sys.argv[0]).name == "bench_live.py" else []
    a = ap.parse_args(argv)
    from websockets.sync.client import connect

    tmp = Path(tempfile.mkdtemp())
    out = tmp / "out"
    cmd = [sys.executable, "-m", "proxyshade.cli", "edit", str(ROOT / "graphs/edit.yaml"), "--port", "0",
           "--var", f"out={out}", "--cache", str(a.cache or tmp / "cache")]
    if a.size != 1024:
        cmd += ["--set", f"proxy.resolution=[{a.size},{a.size}]", "--set", f"guide.size={a.size // 4}",
                "--set", f"guide.start={a.size // 16}"]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True, cwd=ROOT, env=dict(os.environ, PYTHONUNBUFFERED="1"))
    try:
        url = next(line.split()[1] for line in proc.stdout if line.startswith("open http"))
        print(f"server up in {time.perf_counter() - t0:.1f} s: {url.split('?')[0]}")
        exr = next(out.glob("*.exr"))
        points = {name: pixel_of(exr, *c) for name, c, _, _ in EDITS}
        ws_url = url.replace("http://", "ws://").replace("/?token", "/ws?token")
        with connect(ws_url, max_size=None) as ws:
            def until(kinds):
                while True:
                    m = decode(ws.recv(timeout=300))
                    if m["type"] == "error":
                        raise RuntimeError(m["message"])
                    if m["type"] in kinds:
                        return m

            until({"pixels"})
            client: dict[str, list[float]] = {}
            server: dict[str, list[float]] = {}
            cpu: dict[str, list[float]] = {}
            shares: dict[str, float] = {}

            def timed(name, msg):
                t = time.perf_counter()
                ws.send(json.dumps(msg))
                first = until({"pixels", "edit"})
                dt = time.perf_counter() - t
                edit = first if first["type"] == "edit" else until({"edit"})
                client.setdefault(name, []).append(dt)
                cpu.setdefault(name, []).append(edit["cpu_s"])
                server.setdefault(name, []).append(edit["ms"] / 1000)
                if edit.get("share") is not None:
                    shares[name] = edit["share"]
                time.sleep(a.pause)

            for r in range(a.rounds + 1):  # the first round warms up (kernel signatures first seen)
                for name, _, radius, amount in EDITS:
                    timed(name, {"type": "stroke", "frame": 1, "points": [points[name]], "radius": radius,
                                 "strength": amount})
                    timed(f"undo {name}", {"type": "undo"})
                if r == 0:
                    client.clear()
                    server.clear()
                    cpu.clear()
            ws.send(json.dumps({"type": "save"}))
            saved = until({"saved"})
        rows = []
        for name in client:
            c, s = client[name], server[name]
            target = 0.3 if name == "hill in the lake" else None
            share = f" ({100 * shares[name]:.1f}% resynthesized)" if name in shares else ""
            rows.append((f"{name}{share}: page", {"median": statistics.median(c), "min": min(c)}, target))
            rows.append((f"  server only", {"median": statistics.median(s), "min": min(s)}, None))
        table(f"stroke -> updated pixels through proxyshade edit, lake {a.size}² ({a.rounds} rounds, bench_live)", rows)
        print("server CPU seconds per edit (every thread, median): "
              + ", ".join(f"{k} {statistics.median(v):.3f}" for k, v in cpu.items()))
        print(f"EXR + preview written after the edits rest: {saved['seconds']:.2f} s "
              f"({', '.join(Path(f).name for f in saved['files'])})")
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(20)
        except subprocess.TimeoutExpired:
            proc.kill()
        import shutil

        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
