"""The live editing session behind ``proxyshade edit`` (docs/editing.md): a graph kept in
memory, the scene's edits (terrain strokes, spheres added or removed, undo, redo) written
to its description and ``.usda`` and the frame updated progressively through the graph's
own nodes.

The first frame is run through the engine (its cache: a restart is a cache hit; the sinks
write their files). From then on the session holds each node's plate per frame and
computes in memory: after an edit it computes again the nodes that read the scene and
everything below them, a progressive node (``graph.node.Progressive``) getting its last
result and the inputs it was made from as ``ctx.previous``, as the engine hands them over
from its cache, and every node the engine's memo (``ctx.memo``). The pipeline the page
looks at is the view node (what the graph's Preview shows) and its ancestors; the sinks
(EXR, preview) run later, on their own thread, once the edits rest (``write_outputs``).

No web code here: ``proxyshade.live.server`` puts it behind a page.
"""
from __future__ import annotations

import copy
import shutil
import threading
import time
import uuid
from pathlib import Path

import numpy as np

from proxyshade.errors import UserError

SAMPLES = Path(__file__).resolve().parents[2] / "samples"
VIEWS = {"frame": ("R", "G", "B"), "label": ("label.id",), "depth": ("Z",), "flags": ("flag",),
         "objects": ("object.id",)}
MAX_POINTS = 256  # stamps in one stroke
MAX_HISTORY = 200  # undo steps kept


class EditError(UserError):
    """A request the session refuses (bad or out-of-range values): nothing was changed."""


def _scene_node(graph):
    """The ProxyRender node (the scene reader) of ``graph``."""
    for name, node in graph.nodes.items():
        if type(node).__name__ == "ProxyRender" and graph.enabled[name]:
            return name
    raise UserError(f"{graph.source}: no ProxyRender node; `proxyshade edit` edits the scene a ProxyRender reads "
                    "(try graphs/edit.yaml)")


def _view_node(graph) -> str:
    """What the graph's first Preview shows (else a node named 'final')."""
    for name, node in graph.nodes.items():
        if type(node).__name__ == "Preview" and graph.enabled[name]:
            ref = graph.connections[name].get("image")
            if ref is not None:
                return ref.node
    if "final" in graph.nodes:
        return "final"
    raise UserError(f"{graph.source}: no Preview node and no node 'final' to show; add a Preview of the frame")


def scene_files(graph, out_dir: Path) -> tuple[Path, Path, bool]:
    """The scene description (YAML) and ``.usda`` the session edits, and whether they are a
    copy: a bundled scene (under ``samples/``) is copied into ``out_dir/scene`` once (later
    sessions go on from the copy) so the package's samples are never changed."""
    node = graph.nodes[_scene_node(graph)]
    usda = node._scene_path(graph.graph_dir).resolve()
    spec = usda.with_suffix(".yaml")
    if not spec.is_file():
        raise UserError(f"{usda}: no scene description beside it ({spec.name}); the page edits the description and "
                        f"rebuilds the .usda: write one (docs/scenes.md) and `proxyshade scene build {spec.name}`")
    if SAMPLES in usda.parents:
        copy_dir = out_dir / "scene"
        dst = copy_dir / spec.name
        if not dst.is_file():
            copy_dir.mkdir(parents=True, exist_ok=True)
            tmp = dst.with_name(f".{dst.name}.copy.tmp")
            shutil.copyfile(spec, tmp)
            tmp.replace(dst)
        return dst, dst.with_suffix(".usda"), True
    return spec, usda, False


def ensure_built(spec: Path, usda: Path) -> None:
    """Rebuild the ``.usda`` when it is missing or older than its description (a session
    killed between the two renames of an edit: the description has the edit, the
    ``.usda`` not yet)."""
    if not usda.is_file() or usda.stat().st_mtime < spec.stat().st_mtime:
        from proxyshade.scene.edit import load_spec, save_and_build

        save_and_build(spec, load_spec(spec))


class Session:
    """One graph, its scene and its frames, in memory. Not thread-safe: one thread calls it
    (the server's worker); ``write_outputs`` may run on another with a ``snapshot``."""

    def __init__(self, graph_path: Path, variables: dict[str, str] | None = None, *, cache: Path | None = None,
                 overrides: list[str] = (), threads: int = 0, log=print):
        from proxyshade.graph.graph import Graph

        self.log = log
        self.threads = threads
        variables = dict(variables or {})
        g = Graph.load(graph_path, cache=cache, variables=variables, overrides=list(overrides))
        self.out_dir = self._out_dir(g)
        self.spec, self.usda, copied = scene_files(g, self.out_dir)
        if copied:
            variables["scene"] = str(self.usda)
            ensure_built(self.spec, self.usda)
            g = Graph.load(graph_path, cache=cache, variables=variables, overrides=list(overrides))
            self.log(f"editing a copy of the bundled scene: {self.spec} (--var scene=PATH.usda edits your own)")
        else:
            ensure_built(self.spec, self.usda)
        self.graph = g
        self.scene_node = _scene_node(g)
        self.view_node = _view_node(g)
        self.first, self.last = g.frames
        self.dependent = self._dependent()
        self.gen = 0  # the scene's generation: bumped by every edit
        self.plates: dict[tuple[str, int], object] = {}
        self.inputs_of: dict[tuple[str, int], dict] = {}
        self.made_at: dict[tuple[str, int], int] = {}
        self.undo_stack: list[tuple[dict, dict, str]] = []
        self.redo_stack: list[tuple[dict, dict, str]] = []
        self.timings: dict[str, float] = {}
        self.lock = threading.Lock()  # guards plates against write_outputs' snapshot
        self._start()

    # -- set-up ----------------------------------------------------------------
    @staticmethod
    def _out_dir(g) -> Path:
        from proxyshade.graph.node import resolve_path

        for name, node in g.nodes.items():
            if node.sink:
                for k, spec in type(node).params_spec.items():
                    if spec.type is Path and node.params.get(k):
                        return resolve_path(node.params[k], g.graph_dir, g.frames[0]).parent
        return g.graph_dir / "out"

    def _dependent(self) -> set[str]:
        """The nodes that read the scene and every node below them (recomputed after an edit)."""
        g = self.graph
        dep = {self.scene_node}
        changed = True
        while changed:
            changed = False
            for name, conns in g.connections.items():
                if name not in dep and any(ref.node in dep for ref in conns.values()):
                    dep.add(name)
                    changed = True
        return dep

    def _start(self) -> None:
        """The first frame through the engine (cached results reused, the sinks written), then
        the view node's ancestors at that frame read into memory."""
        from proxyshade.graph.graph import load_array_libraries, set_kernel_threads

        t = time.perf_counter()
        g = self.graph
        report = g.run(frames=[self.first], threads=self.threads)
        self.log(f"first frame: {len(report.computed)} node(s) computed, {len(report.reused)} reused "
                 f"({report.wall:.1f} s)")
        load_array_libraries()
        set_kernel_threads(self.threads)
        plan = g.plan([self.first])
        for inst in self._ancestors((self.view_node, self.first)):
            key = plan.keys[inst]
            plate = g.value(*inst)
            self._hold(inst, plate, token=f"plate:{key}")
            self.inputs_of[inst] = {inp: self.plates.get(src) if src else None
                                    for inp, src in self._input_refs(inst).items()}
        self.timings["start"] = time.perf_counter() - t

    def _input_refs(self, inst) -> dict[str, tuple[str, int] | None]:
        name, frame = inst
        g = self.graph
        out = {}
        for inp, spec in type(g.nodes[name]).inputs_spec.items():
            ref = g.connections[name].get(inp)
            if ref is None:
                out[inp] = None
                continue
            if ref.all:
                raise UserError(f"{g.source}: nodes.{name}.inputs.{inp}: reads a whole sequence; the live page shows "
                                "one frame at a time: show a node upstream of it")
            f2 = ref.frame(frame, self.first)
            out[inp] = self._canonical((ref.node, f2)) if self.first <= f2 <= self.last else None
        return out

    def _canonical(self, inst) -> tuple[str, int]:
        """A node whose result does not depend on the frame has one instance, at the first
        frame (as the engine's keys make it one: the source is read once)."""
        name, frame = inst
        return inst if self.graph.nodes[name].depends_on_frame() else (name, self.first)

    def _ancestors(self, inst) -> list[tuple[str, int]]:
        """``inst`` and everything it reads, inputs first."""
        order, seen = [], set()

        def visit(i):
            if i in seen:
                return
            seen.add(i)
            for src in self._input_refs(i).values():
                if src is not None:
                    visit(src)
            order.append(i)

        visit(inst)
        return order

    def _hold(self, inst, plate, token: str | None = None) -> None:
        from proxyshade.graph.memo import STORE

        token = token or f"live:{uuid.uuid4().hex}"
        STORE.bind(plate, token)
        with self.lock:
            self.plates[inst] = plate
            self.made_at[inst] = self.gen

    # -- computing ---------------------------------------------------------------
    def current(self, inst) -> bool:
        return inst in self.plates and (inst[0] not in self.dependent or self.made_at[inst] == self.gen)

    def _compute(self, inst, inputs: dict, previous=None):
        """(plate, context) of one node instance computed from ``inputs`` on this thread, as
        the engine computes it (``ctx.previous`` for a progressive node, the memo)."""
        from proxyshade.graph.graph import load_array_libraries, set_kernel_threads
        from proxyshade.graph.memo import RunMemo
        from proxyshade.graph.node import Context

        load_array_libraries()
        set_kernel_threads(self.threads)
        name, frame = inst
        node = self.graph.nodes[name]
        ctx = Context(node, frame, self.first, inputs, dict(node.params), self.graph.graph_dir, self.threads, [])
        ctx.memo = RunMemo(self.graph.memo)
        ctx.previous = previous
        node.check_inputs(inputs)
        try:
            return node.compute(ctx), ctx
        except UserError as e:
            raise UserError(f"{name}@{frame}: {e}") from None

    def _previous(self, inst):
        from proxyshade.graph.node import Previous

        if not self.graph.nodes[inst[0]].is_progressive() or inst not in self.plates:
            return None
        return Previous(self.plates[inst], {k: v for k, v in self.inputs_of[inst].items() if v is not None})

    def value(self, inst):
        """The plate of (node, frame) for the scene as it is now: held, or computed from its
        inputs (a progressive node updating its held result)."""
        inst = self._canonical(inst)
        for i in self._ancestors(inst):
            if self.current(i):
                continue
            inputs = {inp: (self.plates[src] if src else None) for inp, src in self._input_refs(i).items()}
            t = time.perf_counter()
            plate, _ = self._compute(i, inputs, self._previous(i))
            self.timings[i[0]] = time.perf_counter() - t
            self._hold(i, plate)
            self.inputs_of[i] = inputs
        return self.plates[inst]

    def warm(self) -> float:
        """Run the first frame's update path once on a made-up edit (a 16-pixel square of the
        proxy's labels changed), the results thrown away: the memo's entries (the source's
        similarity sets, its exemplar levels) and the update's kernels are then ready, and
        the user's first edit is as fast as the next ones. Returns the seconds it took."""
        from proxyshade.graph.plate import Plate

        t = time.perf_counter()
        proxy = (self.scene_node, self.first)
        p = self.plates[proxy]
        lab = p["label.id"].copy()
        H, W = lab.shape
        lab[H // 2:H // 2 + 16, W // 2:W // 2 + 16] = lab[0, 0]
        made = {proxy: Plate(dict(p.channels, **{"label.id": lab}), dict(p.meta))}
        for i in self._ancestors((self.view_node, self.first)):
            if i[0] not in self.dependent or i == proxy:
                continue
            inputs = {inp: (made.get(src, self.plates.get(src)) if src else None)
                      for inp, src in self._input_refs(i).items()}
            made[i], _ = self._compute(i, inputs, self._previous(i))
        return time.perf_counter() - t

    def frame_plate(self, frame: int):
        self.check_frame(frame)
        return self.value((self.view_node, frame))

    def proxy_plate(self, frame: int):
        return self.value((self.scene_node, frame))

    def check_frame(self, frame) -> int:
        if not isinstance(frame, int) or isinstance(frame, bool) or not self.first <= frame <= self.last:
            raise EditError(f"frame {frame!r}: pick a frame from {self.first} to {self.last}")
        return frame

    # -- edits ---------------------------------------------------------------------
    def _load(self) -> dict:
        from proxyshade.scene.edit import load_spec

        return load_spec(self.spec)

    def _apply(self, before: dict, after: dict, what: str, *, record: bool = True) -> None:
        """Write ``after`` (description, then ``.usda``, each by a temporary and a rename) and
        mark the scene's nodes for recomputing."""
        from proxyshade.scene.edit import save_and_build

        save_and_build(self.spec, after)
        self.gen += 1
        if record:
            self.undo_stack.append((before, after, what))
            del self.undo_stack[:-MAX_HISTORY]
            self.redo_stack.clear()

    def _world_at(self, frame: int, xy) -> tuple[np.ndarray | None, int]:
        """World position and object id of image pixel ``xy`` (x, y: column, row) of ``frame``
        (from the proxy render's P and object.id: the geometry under the cursor)."""
        p = self.proxy_plate(frame)
        x, y = _pixel(xy, p.width, p.height)
        pos = np.array([p["P.X"][y, x], p["P.Y"][y, x], p["P.Z"][y, x]], np.float64)
        obj = int(p["object.id"][y, x])
        if obj == 0 or not np.isfinite(pos).all():
            return None, 0
        return pos, obj

    def stroke(self, frame: int, points, radius: float, amount: float) -> str:
        """Raise (amount > 0) or lower the terrain under image points of ``frame``: a Gaussian
        stroke (``scene stroke``) at each point, ``radius`` and ``amount`` in scene units."""
        self.check_frame(frame)
        radius = _number(radius, "radius", 0.2, 500.0)
        amount = _number(amount, "strength", -500.0, 500.0)
        if amount == 0:
            raise EditError("strength 0: a stroke needs a strength that raises (> 0) or lowers (< 0)")
        if not isinstance(points, list) or not 1 <= len(points) <= MAX_POINTS:
            raise EditError(f"points: give 1 to {MAX_POINTS} [x, y] image positions")
        data = self._load()
        before = copy.deepcopy(data)
        terrains = [t for t in data.get("terrains") or [] if isinstance(t, dict)]
        if not terrains:
            raise EditError(f"{self.spec.name}: no terrain to sculpt")
        added, last = 0, None
        for xy in points:
            pos, _ = self._world_at(frame, xy)
            if pos is None:
                continue
            x, z = float(pos[0]), float(pos[2])
            if last is not None and np.hypot(x - last[0], z - last[1]) < 0.5 * radius:
                continue  # stamps half a radius apart along the drag
            t = _terrain_at(terrains, x, z)
            if t is None:
                continue
            t.setdefault("strokes", []).append({"centre": [round(x, 3), round(z, 3)], "radius": radius,
                                                "amount": amount})
            added += 1
            last = (x, z)
        if not added:
            raise EditError("no terrain under the stroke (sky or off every terrain's extent); stroke on the ground")
        what = f"{'raise' if amount > 0 else 'lower'} terrain ({added} stamp{'s' * (added > 1)})"
        self._apply(before, data, what)
        return what

    def add_sphere(self, frame: int, xy, radius: float, label: str) -> str:
        """A sphere proxy of ``label`` standing on the ground under image point ``xy``."""
        self.check_frame(frame)
        radius = _number(radius, "radius", 0.2, 200.0)
        labels = self.labels()
        if not isinstance(label, str) or label not in labels:
            raise EditError(f"label {label!r}: pick one of the source's labels: {', '.join(labels)}")
        pos, _ = self._world_at(frame, xy)
        if pos is None:
            raise EditError("nothing under the cursor to stand a sphere on; click on the ground")
        data = self._load()
        before = copy.deepcopy(data)
        names = {g.get("name") for g in data.get("spheres") or []}
        n = 1
        while f"Live{n}" in names:
            n += 1
        c = [round(float(pos[0]), 3), round(float(pos[1]) + 0.6 * radius, 3), round(float(pos[2]), 3)]
        data.setdefault("spheres", []).append({"name": f"Live{n}", "label": label, "path": [c, c],
                                               "radius": radius, "count": 1})
        what = f"add {label} sphere Live{n}"
        self._apply(before, data, what)
        return what

    def remove_sphere(self, frame: int, xy) -> str:
        """Remove the sphere under image point ``xy``; the other spheres of its group stay
        where they are (the group becomes one group per remaining sphere)."""
        from proxyshade.scene.spheres import along_path, arch

        self.check_frame(frame)
        _, obj = self._world_at(frame, xy)
        objects = {o["id"]: o["name"] for o in self.proxy_plate(frame).meta.get("objects", [])}
        path = objects.get(obj, "")
        parts = path.strip("/").split("/")
        if len(parts) < 4 or not parts[-1].startswith("S") or not parts[-1][1:].isdigit():
            raise EditError("no sphere under the cursor; click on a sphere (a tree or bush) to remove it")
        group, k = parts[-2], int(parts[-1][1:])
        data = self._load()
        before = copy.deepcopy(data)
        groups = data.get("spheres") or []
        idx = next((i for i, g in enumerate(groups) if g.get("name") == group), None)
        if idx is None:
            raise EditError(f"{self.spec.name}: no sphere group {group!r}")
        g = groups[idx]
        if int(g.get("count", 1)) <= 1:
            del groups[idx]
        else:
            if "arch" in g:
                a = g["arch"]
                centres, radii = arch(a["left"], a["right"], a["height"], g["radius"], int(g["count"]),
                                      a.get("bulge", 0.0))
            else:
                centres, radii = along_path(g["path"], g["radius"], int(g["count"]))
            rest = [{"name": f"{group}_{j}", "label": g["label"], "path": [c, c], "radius": round(float(r), 4),
                     "count": 1} for j, (c, r) in enumerate(zip(np.round(centres, 4).tolist(), radii)) if j != k]
            groups[idx:idx + 1] = rest
        data["spheres"] = groups
        what = f"remove sphere {k} of {group}"
        self._apply(before, data, what)
        return what

    def undo(self) -> str:
        if not self.undo_stack:
            raise EditError("nothing to undo")
        before, after, what = self.undo_stack.pop()
        self._apply(after, before, what, record=False)
        self.redo_stack.append((before, after, what))
        return f"undo: {what}"

    def redo(self) -> str:
        if not self.redo_stack:
            raise EditError("nothing to redo")
        before, after, what = self.redo_stack.pop()
        self._apply(before, after, what, record=False)
        self.undo_stack.append((before, after, what))
        return f"redo: {what}"

    # -- what the page shows ----------------------------------------------------------
    def labels(self) -> list[str]:
        src = self.plates.get(next((i for i in self.plates if i[0] not in self.dependent), None))
        table = (src.meta.get("labels") if src is not None else None) or \
            self.plates[(self.view_node, self.first)].meta.get("labels", [])
        return [t["name"] for t in table]

    def views(self, frame: int) -> list[str]:
        p = self.plates.get((self.view_node, frame))
        p = self.plates[(self.view_node, self.first)] if p is None else p
        return [v for v, chans in VIEWS.items() if all(c in p.names() for c in chans)]

    def snapshot(self) -> dict:
        with self.lock:
            return dict(self.plates)

    def write_outputs(self, frames: list[int], snapshot: dict | None = None) -> list[Path]:
        """Run the graph's sinks (EXR, preview) at ``frames`` on the held plates (the nodes
        between the view and the sinks, such as Cryptomatte, computed here and not kept).
        Safe on another thread than the edits' with a ``snapshot``."""
        plates = dict(snapshot if snapshot is not None else self.snapshot())
        written: list[Path] = []
        g = self.graph
        for frame in frames:
            if (self.view_node, frame) not in plates:
                continue
            for name, node in g.nodes.items():
                if not node.sink or not g.enabled[name]:
                    continue
                try:
                    order = self._ancestors((name, frame))
                except UserError:
                    continue  # a sequence sink (a movie): not per frame
                if any(i not in plates and i[0] not in self.dependent for i in order):
                    continue
                for i in order:
                    if i in plates:
                        continue
                    n2 = g.nodes[i[0]]
                    if n2.is_progressive() or any(src not in plates for src in self._input_refs(i).values() if src):
                        break
                    inputs = {inp: (plates[src] if src else None) for inp, src in self._input_refs(i).items()}
                    plates[i], ctx = self._compute(i, inputs)
                    if n2.sink:
                        written += n2.written_files(ctx)
        return written


def _number(v, what: str, lo: float, hi: float) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v) or not lo <= v <= hi:
        raise EditError(f"{what} {v!r}: give a number from {lo:g} to {hi:g}")
    return float(v)


def _pixel(xy, w: int, h: int) -> tuple[int, int]:
    if (not isinstance(xy, (list, tuple)) or len(xy) != 2
            or any(isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v) for v in xy)):
        raise EditError(f"point {xy!r}: give [x, y], a pixel of the {w}x{h} frame")
    x, y = int(np.floor(xy[0])), int(np.floor(xy[1]))
    if not (0 <= x < w and 0 <= y < h):
        raise EditError(f"point {list(xy)}: outside the {w}x{h} frame")
    return x, y


def _terrain_at(terrains: list[dict], x: float, z: float) -> dict | None:
    """The sculptable terrain at (x, z): of those whose extent holds it, the finest grid."""
    best, cells = None, -1
    for t in terrains:
        try:
            (x0, z0), (x1, z1) = t.get("extent", ((-50, -50), (50, 50)))
            n = int(np.prod(t.get("cells", (128, 128))))
        except (TypeError, ValueError):
            continue
        if min(x0, x1) <= x <= max(x0, x1) and min(z0, z1) <= z <= max(z0, z1) and n > cells:
            best, cells = t, n
    return best
