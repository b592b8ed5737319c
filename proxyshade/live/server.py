"""``proxyshade edit``: the live editing page (Starlette + uvicorn, a websocket per page).

Routes: ``/?token=T`` the page, ``/static/NAME`` its script and style (a fixed list of the
package's files: no path from a request ever reaches the file system), ``/ws?token=T`` the
websocket. Every request without the session's token is refused (403).

One worker thread runs the session (``live.session.Session``): edits are applied one at a
time, in the order received, and the updated pixels are broadcast to every open page
before anything else runs. The sinks (EXR, preview) run on a second thread once the edits
have rested ``SINK_DELAY`` seconds (or at once on a ``save`` message), off the stroke's
path.

Messages from the page (JSON): ``stroke`` {frame, points: [[x, y], ...], radius,
strength}, ``sphere`` {frame, at: [x, y], radius, label}, ``remove`` {frame, at},
``undo``, ``redo``, ``view`` {view}, ``frame`` {frame}, ``save``. To the page: JSON
``state``, ``edit``, ``error``, ``busy``, ``saved``; binary pixel messages: a 4-byte
little-endian header length, the JSON header {frame, view, x, y, w, h, width, height},
then w*h*4 bytes of 8-bit sRGB RGBA rows.
"""
from __future__ import annotations

import asyncio
import json
import secrets
import socket
import struct
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from proxyshade.errors import UserError
from proxyshade.live.session import VIEWS, EditError, Session

STATIC = Path(__file__).with_name("static")
FILES = {"app.js": "text/javascript", "style.css": "text/css"}  # every file the server ever reads for a request
SINK_DELAY = 1.5  # seconds of rest after an edit before the EXR and preview are written
MAX_MESSAGE = 64 * 1024  # bytes of one message from a page


def pixels_message(plate, view: str, frame: int, box=None, norm=None) -> bytes:
    """A binary pixel message of ``box`` (y0, y1, x0, x1; None: the whole frame) of ``view``."""
    from proxyshade.graph.plate import Plate
    from proxyshade.kernels.display import id_palette, to_display

    H, W = plate.shape
    y0, y1, x0, x1 = box or (0, H, 0, W)
    chans = VIEWS[view]
    if view == "depth":
        z = plate["Z"][y0:y1, x0:x1].astype(np.float64)
        lo, hi = norm
        fin = np.isfinite(z)
        g = np.where(fin, 1.0 - np.clip((z - lo) / max(hi - lo, 1e-12), 0, 1), 0.0)
        rgb = np.repeat((g * 255 + 0.5).astype(np.uint8)[..., None], 3, axis=2)
    elif view in ("label", "objects", "flags"):
        ids = plate[chans[0]][y0:y1, x0:x1]
        rgb = id_palette(ids.astype(np.uint32), plate.meta.get("labels") if view == "label" else None)
    else:
        rgb = to_display(Plate({c: plate[c][y0:y1, x0:x1] for c in chans}, {}), list(chans))
    rgba = np.empty((y1 - y0, x1 - x0, 4), np.uint8)
    rgba[..., :3] = rgb
    rgba[..., 3] = 255
    head = json.dumps({"type": "pixels", "frame": frame, "view": view, "x": x0, "y": y0, "w": x1 - x0,
                       "h": y1 - y0, "width": W, "height": H}).encode()
    return struct.pack("<I", len(head)) + head + rgba.tobytes()


def depth_norm(plate) -> tuple[float, float]:
    z = plate["Z"]
    fin = np.isfinite(z)
    if not fin.any():
        return 0.0, 1.0
    lo, hi = np.percentile(z[fin], [1, 99])
    return float(lo), float(hi)


def changed_box(a, b, view: str):
    """(y0, y1, x0, x1) around the pixels of ``view``'s channels that differ, None if none."""
    diff = None
    for c in VIEWS[view]:
        d = a[c] != b[c]
        if a[c].dtype.kind == "f":
            d &= ~(np.isnan(a[c]) & np.isnan(b[c]))
        diff = d if diff is None else diff | d
    rows = np.flatnonzero(diff.any(1))
    if not len(rows):
        return None
    cols = np.flatnonzero(diff[rows[0]:rows[-1] + 1].any(0))
    return int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1


class Client:
    def __init__(self, ws, frame: int):
        self.ws = ws
        self.view = "frame"
        self.frame = frame


class LiveServer:
    """The session, its worker threads and the open pages."""

    def __init__(self, session: Session, token: str | None = None, sink_delay: float = SINK_DELAY):
        self.session = session
        self.token = token or secrets.token_urlsafe(24)
        self.sink_delay = sink_delay
        self.clients: set[Client] = set()
        self.worker = ThreadPoolExecutor(1, thread_name_prefix="live-edit")
        self.sinks = ThreadPoolExecutor(1, thread_name_prefix="live-sinks")
        self.loop: asyncio.AbstractEventLoop | None = None
        self.last_edit = 0.0
        self.dirty: set[int] = set()
        self.sink_pending = False
        self.norms: dict[int, tuple[float, float]] = {}
        self.shown: dict[tuple[int, str], object] = {}  # (frame, view) -> the plate last sent for it
        self.seq = 0

    # -- the app ---------------------------------------------------------------
    def app(self):
        from starlette.applications import Starlette
        from starlette.responses import HTMLResponse, PlainTextResponse, Response
        from starlette.routing import Route, WebSocketRoute

        def authorized(request) -> bool:
            return secrets.compare_digest(str(request.query_params.get("token", "")), self.token)

        async def page(request):
            if not authorized(request):
                return PlainTextResponse("403: open the URL proxyshade edit printed (it holds the session's token)",
                                         status_code=403)
            html = (STATIC / "index.html").read_text()
            return HTMLResponse(html.replace("{{token}}", self.token), headers={"Cache-Control": "no-store"})

        async def static(request):
            name = request.path_params["name"]
            if name not in FILES:
                return PlainTextResponse("404", status_code=404)
            return Response((STATIC / name).read_bytes(), media_type=FILES[name])

        async def not_found(request):
            return PlainTextResponse("404", status_code=404)

        routes = [Route("/", page), Route("/static/{name}", static), WebSocketRoute("/ws", self.websocket),
                  Route("/{rest:path}", not_found)]
        return Starlette(routes=routes)

    # -- the websocket -------------------------------------------------------------
    async def websocket(self, ws):
        from starlette.websockets import WebSocketDisconnect

        gone = (WebSocketDisconnect, RuntimeError)  # RuntimeError: Starlette's WebSocketDisconnected (a page gone)

        if not secrets.compare_digest(str(ws.query_params.get("token", "")), self.token):
            await ws.close(code=1008)
            return
        await ws.accept()
        self.loop = asyncio.get_running_loop()
        client = Client(ws, self.session.first)
        self.clients.add(client)
        try:
            await self.send_json(client, self.state_message(client))
            data = await self.run(self._frame_pixels, client.frame, client.view)
            await self.send_bytes(client, data)
            while True:
                text = await ws.receive_text()
                await self.handle(client, text)
        except gone:
            pass
        finally:
            self.clients.discard(client)

    async def run(self, fn, *args):
        return await asyncio.get_running_loop().run_in_executor(self.worker, fn, *args)

    async def send_json(self, client: Client, msg: dict) -> None:
        try:
            await client.ws.send_text(json.dumps(msg))
        except Exception:  # noqa: BLE001 - a page gone meanwhile
            self.clients.discard(client)

    async def send_bytes(self, client: Client, data: bytes) -> None:
        try:
            await client.ws.send_bytes(data)
        except Exception:  # noqa: BLE001
            self.clients.discard(client)

    async def broadcast(self, msg: dict) -> None:
        for c in list(self.clients):
            await self.send_json(c, msg)

    def state_message(self, client: Client) -> dict:
        s = self.session
        return {"type": "state", "frames": [s.first, s.last], "frame": client.frame, "view": client.view,
                "views": s.views(client.frame), "labels": s.labels(), "scene": s.spec.name,
                "undo": len(s.undo_stack), "redo": len(s.redo_stack),
                "undo_what": s.undo_stack[-1][2] if s.undo_stack else None,
                "redo_what": s.redo_stack[-1][2] if s.redo_stack else None}

    async def handle(self, client: Client, text: str) -> None:
        t0 = time.perf_counter()
        try:
            if len(text) > MAX_MESSAGE:
                raise EditError(f"message of {len(text)} bytes: at most {MAX_MESSAGE}")
            try:
                msg = json.loads(text)
            except ValueError:
                raise EditError("not a JSON message") from None
            if not isinstance(msg, dict) or not isinstance(msg.get("type"), str):
                raise EditError("a message is a JSON object with a 'type'")
            kind = msg["type"]
            if kind == "view":
                if msg.get("view") not in self.session.views(client.frame):
                    raise EditError(f"view {msg.get('view')!r}: pick one of {', '.join(self.session.views(client.frame))}")
                client.view = msg["view"]
                data = await self.run(self._frame_pixels, client.frame, client.view)
                await self.send_json(client, self.state_message(client))
                await self.send_bytes(client, data)
                return
            if kind == "frame":
                frame = self.session.check_frame(msg.get("frame"))
                client.frame = frame
                await self.send_json(client, {"type": "busy", "message": f"frame {frame}…"})
                data = await self.run(self._frame_pixels, frame, client.view)
                if client.view not in self.session.views(frame):
                    client.view = "frame"
                    data = await self.run(self._frame_pixels, frame, client.view)
                await self.send_json(client, self.state_message(client))
                await self.send_bytes(client, data)
                return
            if kind == "save":
                files, secs = await asyncio.get_running_loop().run_in_executor(self.sinks, self._write_sinks, True)
                await self.broadcast({"type": "saved", "files": [str(f) for f in files], "seconds": secs})
                return
            edits = {"stroke": self._stroke, "sphere": self._sphere, "remove": self._remove,
                     "undo": lambda m: self.session.undo(), "redo": lambda m: self.session.redo()}
            if kind not in edits:
                raise EditError(f"message type {kind!r}: one of stroke, sphere, remove, undo, redo, view, frame, save")
            await self.send_json(client, {"type": "busy", "message": "updating…"})
            what, updates = await self.run(self._edit, edits[kind], msg, client.frame, t0)
            await self.send_updates(updates)  # the editing page's frame first
            others = sorted({(c.frame, c.view) for c in self.clients} - set(updates) - {(client.frame, "frame")})
            if others:
                await self.send_updates(await self.run(self._updates, others))
        except EditError as e:
            await self.send_json(client, {"type": "error", "message": str(e)})
            return
        except UserError as e:
            await self.send_json(client, {"type": "error", "message": f"refused: {e}"})
            return
        ms = (time.perf_counter() - t0) * 1000
        share = (self.session.plates.get((self.session.view_node, client.frame)).meta.get("edit") or {}).get("share")
        await self.broadcast({"type": "edit", "what": what, "ms": round(ms, 1), "seq": self.seq, "share": share,
                              "cpu_s": round(self.session.timings.get("update_cpu", 0.0), 3),
                              "undo": len(self.session.undo_stack), "redo": len(self.session.redo_stack),
                              "undo_what": self.session.undo_stack[-1][2] if self.session.undo_stack else None,
                              "redo_what": self.session.redo_stack[-1][2] if self.session.redo_stack else None})
        self.last_edit = time.perf_counter()
        self._schedule_sinks()

    async def send_updates(self, updates: dict) -> None:
        for c in list(self.clients):  # every page: the pixels of its own frame and view
            for data in updates.get((c.frame, c.view), []):
                await self.send_bytes(c, data)

    # -- on the worker thread ---------------------------------------------------------
    def _stroke(self, m):
        return self.session.stroke(m.get("frame"), m.get("points"), m.get("radius"), m.get("strength"))

    def _sphere(self, m):
        return self.session.add_sphere(m.get("frame"), m.get("at"), m.get("radius"), m.get("label"))

    def _remove(self, m):
        return self.session.remove_sphere(m.get("frame"), m.get("at"))

    def _frame_pixels(self, frame: int, view: str) -> bytes:
        plate = self.session.frame_plate(frame)
        if view == "depth" and frame not in self.norms:
            self.norms[frame] = depth_norm(plate)
        self.shown[(frame, view)] = plate
        return pixels_message(plate, view, frame, norm=self.norms.get(frame))

    def _edit(self, fn, msg, frame, t0):
        """Apply an edit, then update the frames the pages look at (the editing page's first):
        the changed box of each, as pixel messages. An edit whose update fails is undone."""
        s = self.session
        gen = s.gen
        cpu = time.process_time()
        what = fn(msg)  # EditError: nothing written
        self.seq += 1
        try:
            out = self._updates([(frame, "frame")] + [(frame, c.view) for c in self.clients if c.frame == frame])
        except Exception as e:
            if s.gen != gen and s.undo_stack:
                s.undo()
                s.redo_stack.clear()
            raise UserError(f"the update failed and the edit was undone: {e}") from e
        s.timings["update"] = time.perf_counter() - t0
        s.timings["update_cpu"] = time.process_time() - cpu  # the process's CPU seconds, every thread
        return what, out

    def _updates(self, wanted) -> dict[tuple[int, str], list[bytes]]:
        """Pixel messages of the changed box of each (frame, view) since it was last sent."""
        s, out = self.session, {}
        for f, view in dict.fromkeys(wanted):
            new = s.frame_plate(f)
            self.dirty.add(f)
            if view not in s.views(f):
                continue
            old = self.shown.get((f, view))
            if old is None:
                out[(f, view)] = [self._frame_pixels(f, view)]
                continue
            box = changed_box(old, new, view)
            self.shown[(f, view)] = new
            if box is not None:
                out[(f, view)] = [pixels_message(new, view, f, box, self.norms.get(f))]
        return out

    # -- the sinks ----------------------------------------------------------------------
    def _schedule_sinks(self) -> None:
        if self.sink_pending:
            return
        self.sink_pending = True
        self.loop.call_later(self.sink_delay, self._sinks_due)

    def _sinks_due(self) -> None:
        rest = time.perf_counter() - self.last_edit
        if rest < self.sink_delay:
            self.loop.call_later(self.sink_delay - rest, self._sinks_due)
            return
        self.sink_pending = False
        fut = self.loop.run_in_executor(self.sinks, self._write_sinks, False)
        fut.add_done_callback(lambda f: f.exception() is None and f.result()[0] and asyncio.ensure_future(
            self.broadcast({"type": "saved", "files": [str(p) for p in f.result()[0]], "seconds": f.result()[1]})))

    def _write_sinks(self, now: bool) -> tuple[list[Path], float]:
        """(files written, seconds) of the sinks at the frames edited since the last write
        (``now``: and the frames the pages show)."""
        t = time.perf_counter()
        dirty, self.dirty = self.dirty, set()  # one swap: an edit's frame added meanwhile goes to the next write
        frames = sorted(dirty | ({c.frame for c in self.clients} if now else set()))
        if not frames:
            return [], 0.0
        files = self.session.write_outputs(frames, self.session.snapshot())
        return files, round(time.perf_counter() - t, 3)


def bind(port: int) -> socket.socket:
    """A listening socket on 127.0.0.1 (``port`` 0: any free one)."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind(("127.0.0.1", port))
    except OSError as e:
        sock.close()
        raise UserError(f"--port {port}: cannot listen on 127.0.0.1:{port} ({e.strerror}); pick another port "
                        "or --port 0 for any free one") from None
    sock.listen(16)
    return sock


def serve(session: Session, port: int = 8800, open_browser: bool = False) -> None:
    """Serve the page until interrupted; prints its URL (with the token) on stdout first."""
    import uvicorn

    live = LiveServer(session)
    sock = bind(port)
    url = f"http://127.0.0.1:{sock.getsockname()[1]}/?token={live.token}"
    print(f"open {url}  (Ctrl-C stops)", flush=True)
    if open_browser:
        import webbrowser

        threading.Timer(0.5, webbrowser.open, args=(url,)).start()
    def warm():  # before the first edit: the update path's memo entries and kernels
        try:
            session.warm()
        except Exception as e:  # noqa: BLE001 - only the first edit's speed depends on it
            print(f"warning: warming the update path failed ({type(e).__name__}: {e})", file=sys.stderr)

    live.worker.submit(warm)
    config = uvicorn.Config(live.app(), log_level="warning", ws_max_size=MAX_MESSAGE, lifespan="off")
    uvicorn.Server(config).run(sockets=[sock])
