"""Shared by the live page's tests: a small edit graph and a `proxyshade edit` process."""
from __future__ import annotations

import contextlib
import json
import os
import signal
import struct
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
GRAPH = ROOT / "graphs/edit.yaml"
SMALL = ["proxy.resolution=[256,256]", "guide.size=64", "guide.start=16"]  # 256² frame, 64² synthesis
STROKE_AT = [128, 150]  # a pixel of the lake in the 256² first frame: ground under it


def decode(message) -> dict:
    """A server message as a dict (a pixel message: its header plus 'rgba', an (h, w, 4) array)."""
    if isinstance(message, (bytes, bytearray)):
        import numpy as np

        n = struct.unpack("<I", message[:4])[0]
        head = json.loads(message[4:4 + n])
        head["rgba"] = np.frombuffer(message[4 + n:], np.uint8).reshape(head["h"], head["w"], 4)
        return head
    return json.loads(message)


@contextlib.contextmanager
def edit_process(out: Path, cache: Path, timeout: float = 240.0):
    """``proxyshade edit`` on the small lake (its scene copied into ``out/scene``); yields
    (process, url)."""
    args = [sys.executable, "-m", "proxyshade.cli", "edit", str(GRAPH), "--port", "0", "--var", f"out={out}",
            "--cache", str(cache)] + [a for s in SMALL for a in ("--set", s)]
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT,
                            env=dict(os.environ, PYTHONUNBUFFERED="1"))
    try:
        t = time.monotonic()
        url = None
        while time.monotonic() - t < timeout:
            line = proc.stdout.readline()
            if not line:
                break
            if line.startswith("open http"):
                url = line.split()[1]
                break
        if url is None:
            proc.kill()
            raise RuntimeError(f"proxyshade edit did not start: {proc.stderr.read()[-2000:]}")
        yield proc, url
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
