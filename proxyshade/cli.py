"""The ``proxyshade`` command line: run graphs, list nodes, inspect EXRs, manage the cache.

Exit codes (``proxyshade.errors``): 0 ok; 1 internal error; 2 bad input or a usage error
(a one-line message, no traceback); 74 an output or cache file could not be written (a full
disk, an I/O error); 130 interrupted (Ctrl-C: "interrupted", no partial output).
"""
from __future__ import annotations

import contextlib
import inspect
import os
import signal
import sys
import threading
import warnings
from dataclasses import MISSING, dataclass, field, fields
from pathlib import Path
from enum import Enum
from typing import Annotated, List, Optional, get_type_hints

import typer
from rich.console import Console
from rich.text import Text

from proxyshade.errors import EXIT_BAD_INPUT, EXIT_INTERNAL, EXIT_INTERRUPTED, EXIT_IO, UserError

app = typer.Typer(add_completion=False, no_args_is_help=True, help="Proxy-guided texture synthesis as a cached node graph.")
cache_app = typer.Typer(no_args_is_help=True, help="Inspect or clean the cache.")
app.add_typer(cache_app, name="cache")
try:  # scene modelling tools (USD), when present
    from proxyshade.scene.cli import scene_app

    app.add_typer(scene_app, name="scene", help="Write USD proxy scenes: terrain, spheres, cameras.")
except ImportError:  # pragma: no cover
    pass

out = Console()
err = Console(stderr=True)

# typer's exceptions (typer vendors click since 0.22; older versions re-export click's): found
# from the public BadParameter, so no import of click itself
_USAGE_ERROR = next(c for c in typer.BadParameter.__mro__ if c.__name__ == "UsageError")
_CLICK_EXCEPTION = next(c for c in typer.BadParameter.__mro__ if c.__name__ == "ClickException")


def _one_line(text: str) -> str:
    return " ".join(line.strip() for line in str(text).splitlines() if line.strip())


def _say(console: Console, text: str) -> None:
    """Print text as it is: no rich markup (``shot[v2].exr`` keeps its brackets), no highlighting."""
    console.print(text, markup=False, highlight=False, soft_wrap=True)


source_app = typer.Typer(no_args_is_help=True, help="Annotated sources: a photo, its label map, a source.yaml.")
app.add_typer(source_app, name="source")


@source_app.command("new")
def source_new(photo: Path = typer.Argument(..., help="the photo (8-bit sRGB)"),
               label_map: Path = typer.Argument(..., help="its label map: flat colours, one per label, same size"),
               output: Path = typer.Option(None, "-o", "--output", help="the source.yaml to write (default: beside the photo)"),
               min_share: float = typer.Option(0.005, "--min-share", help="colours covering less of the map are noise"),
               force: bool = typer.Option(False, "--force", help="replace an existing file")):
    """Write a source.yaml for PHOTO and LABEL_MAP with the palette found in the map."""
    from proxyshade.io.files import io_error, output_target, temp_for
    from proxyshade.io.source import load_source, new_table

    output = output or photo.parent / "source.yaml"
    if output.exists() and not force:
        raise UserError(f"{output}: exists; choose another -o path or pass --force to replace it")
    target = output_target(output)
    text, rep = new_table(photo, label_map, target, min_share=min_share)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = temp_for(target, ".yaml")
    try:
        tmp.write_text(text)
        load_source(tmp, where=str(output))  # the table must load as written
        os.replace(tmp, target)
    except OSError as e:
        raise io_error(output, e) from None
    finally:
        tmp.unlink(missing_ok=True)
    _say(out, f"{output}: {rep['labels']} labels; {rep['snapped']} pixels ({rep['snapped_share']:.2%}) of other "
              "colours will snap to the nearest label. Rename the labels after your scene's.")


def _progress(quiet: bool, *more_columns: str):
    """rich's progress bars on stderr (off with --quiet or when stderr is not a terminal):
    the step, a bar, done/total, elapsed time, then ``more_columns`` (task fields). Imported
    here: a fully cached run draws none."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    return Progress(TextColumn("{task.description:<14}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                    *(TextColumn(c) for c in more_columns), console=err, disable=quiet or not err.is_terminal,
                    transient=True)


class _LazyBars:
    """``_progress`` started when a node first computes: a fully cached run draws no bars
    and imports no rich.progress. A context manager; thread-safe."""

    def __init__(self, quiet: bool):
        self.quiet = quiet
        self.progress = None
        self.lock = threading.Lock()

    def get(self):
        with self.lock:
            if self.progress is None:
                self.progress = _progress(self.quiet)
                self.progress.start()
            return self.progress

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        if self.progress is not None:
            self.progress.stop()


class _BarHooks:
    """One progress bar per node (per graph and node when several run), advancing once per
    frame; drawn from the first node computed on (``_LazyBars``)."""

    def __init__(self, bars: _LazyBars, prefix: str = ""):
        self.bars = bars
        self.prefix = prefix
        self.counts = {}  # node -> (frames planned, frames done)
        self.tasks = None
        self.lock = threading.Lock()
        self.told_compiling = False
        self.graph = None

    def plan(self, plan):
        self.graph = plan.graph
        planned = {}
        for name, _ in plan.keys:
            planned[name] = planned.get(name, 0) + 1
        self.counts = {name: [planned[name], 0] for name in plan.graph.nodes if name in planned}
        self.tasks = None  # a later graph's plan (``compile`` runs several): its bars when it computes

    def _bars(self):  # under self.lock
        if self.tasks is None:
            progress = self.bars.get()
            self.tasks = {name: progress.add_task(self.prefix + name, total=total, completed=done)
                          for name, (total, done) in self.counts.items()}
        return self.bars.progress

    def start(self, run):
        with self.lock:
            self._bars()
        if not self.told_compiling and self.graph is not None and err.is_terminal:  # a progress note: terminals only
            from proxyshade.graph.keys import import_closure
            from proxyshade.kernels._cache import kernels_cached

            mods = [m for m in import_closure(type(self.graph.nodes[run.node]).__module__)
                    if m.startswith("proxyshade.kernels.")]
            if mods and not kernels_cached(mods):
                self.told_compiling = True
                _say(err, "compiling the numba kernels: once after an install or upgrade, about a minute on 2 cores "
                          "(later runs load them from numba's cache)")

    def done(self, run):
        if run.node not in self.counts:
            return
        with self.lock:
            if self.tasks is None and self.bars.progress is None:  # nothing drawn yet: counted for later
                self.counts[run.node][1] += 1
            else:
                self._bars().advance(self.tasks[run.node])


class Executor(str, Enum):
    local = "local"
    dask = "dask"


@dataclass
class RunOptions:
    """The parameters of ``proxyshade run``, each declared once (typer reads the ``Annotated``
    declarations through ``_options_command``); the command's body takes them as one object."""

    graphs: Annotated[List[Path], typer.Argument(metavar="GRAPH", help="YAML graph file(s): several are several shots")]
    frames: Annotated[Optional[str], typer.Option("--frames", help="frames to compute: 1-48, 30 or 1,5,9-12 (default: "
                                                  "the graph's range)")] = None
    set_: Annotated[List[str], typer.Option("--set", help="override a parameter: node.param=value (repeatable)")] = \
        field(default_factory=list)
    var: Annotated[List[str], typer.Option("--var", help="set a graph variable: name=value (repeatable), used as "
                                           "${name}")] = field(default_factory=list)
    sweep: Annotated[List[str], typer.Option("--sweep", help="run the graph once per value of a variable: name=a,b,c "
                                             "(repeatable: every combination)")] = field(default_factory=list)
    cache: Annotated[Optional[Path], typer.Option("--cache", help="plate cache folder (default $PROXYSHADE_CACHE, "
                                                  "else plates/ in the per-user cache: $XDG_CACHE_HOME/proxyshade or "
                                                  "~/.cache/proxyshade)")] = None
    explain: Annotated[bool, typer.Option("--explain", help="print per node whether it was computed or reused, and "
                                          "why")] = False
    jobs: Annotated[int, typer.Option("--jobs", min=1, help="nodes run concurrently (local executor)")] = 1
    force: Annotated[List[str], typer.Option("--force", help="recompute this node (repeatable)")] = \
        field(default_factory=list)
    threads: Annotated[int, typer.Option("--threads", min=0, help="numba threads per kernel (0: all cores; on a local "
                                         "Dask cluster, cores / workers)")] = 0
    executor: Annotated[Executor, typer.Option("--executor", help="local: this process; dask: Dask workers (a local "
                                               "cluster, or --scheduler)")] = Executor.local
    scheduler: Annotated[Optional[str], typer.Option("--scheduler", help="a running Dask scheduler, tcp://host:port "
                                                     "(implies --executor dask)")] = None
    workers: Annotated[Optional[int], typer.Option("--workers", min=1, help="worker processes of the local Dask "
                                                   "cluster (default: one per core)")] = None
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="no progress bars")] = False
    watch: Annotated[bool, typer.Option("--watch", help="after the run, run again whenever a graph file or a file its "
                                        "nodes read (scene, source table, ...) changes; Ctrl-C stops")] = False
    poll: Annotated[float, typer.Option("--poll", min=0.01, help="--watch: seconds between checks for changed "
                                        "files")] = 0.5
    watch_runs: Annotated[int, typer.Option("--watch-runs", min=0, hidden=True, help="--watch: stop after this many "
                                            "runs")] = 0
    profile: Annotated[bool, typer.Option("--profile", help="print where the run's time and memory went: imports, "
                                          "kernel loading, each node, cache and output writes (docs/engine.md)")] = False


def _options_command(options: type):
    """A typer command whose parameters are the fields of the dataclass ``options`` (typer
    reads the signature and annotations made from them), calling the decorated body with
    one ``options`` instance."""
    def wrap(body):
        hints = get_type_hints(options, include_extras=True)
        params = [inspect.Parameter(f.name, inspect.Parameter.KEYWORD_ONLY, annotation=hints[f.name],
                                    default=f.default if f.default is not MISSING
                                    else f.default_factory() if f.default_factory is not MISSING
                                    else inspect.Parameter.empty)
                  for f in fields(options)]

        def command(**values):
            return body(options(**values))

        command.__name__, command.__qualname__, command.__doc__ = body.__name__, body.__qualname__, body.__doc__
        command.__signature__ = inspect.Signature(params)
        command.__annotations__ = {p.name: p.annotation for p in params}
        return command
    return wrap


@app.command()
@_options_command(RunOptions)
def run(opts: RunOptions):
    """Run GRAPH(s): compute what the cache lacks, reuse the rest."""
    if opts.profile:
        from proxyshade.graph import profile as prof

        prof.start()
        try:
            _run_once(opts)
        finally:
            p = prof.finish()
        _say(out, p.text())
        return
    runs = 0
    while True:
        watched = _run_once(opts)
        runs += 1
        if not opts.watch or (opts.watch_runs and runs >= opts.watch_runs):
            return
        _say(err, f"watching {len(watched)} file(s) for changes (Ctrl-C stops)")
        _wait_for_change(watched, opts.poll)


@app.command()
def edit(
    graph: Path = typer.Argument(..., metavar="GRAPH", help="YAML graph with a ProxyRender (graphs/edit.yaml)"),
    var: List[str] = typer.Option([], "--var", help="set a graph variable: name=value (repeatable)"),
    set_: List[str] = typer.Option([], "--set", help="override a parameter: node.param=value (repeatable)"),
    port: int = typer.Option(8800, "--port", min=0, max=65535, help="port on 127.0.0.1 (0: any free one)"),
    open_: bool = typer.Option(False, "--open", help="open the page in the default browser"),
    cache: Optional[Path] = typer.Option(None, "--cache", help="plate cache folder (as for run)"),
    threads: int = typer.Option(0, "--threads", min=0, help="numba threads per kernel (0: all cores)"),
):
    """Edit GRAPH's scene on a live page: sculpt the terrain, add or remove spheres, undo; each
    edit updates the frame progressively (docs/editing.md). Prints the page's URL."""
    try:
        import starlette  # noqa: F401
        import uvicorn  # noqa: F401
        import websockets  # noqa: F401

        from proxyshade.live.server import serve
        from proxyshade.live.session import Session
    except ImportError as e:
        raise UserError(f"proxyshade edit needs the live extra ({e.name} is missing): "
                        "pip install 'proxyshade[live]'") from None
    session = Session(graph, _vars(var), cache=cache, overrides=set_, threads=threads,
                      log=lambda m: _say(err, m))
    serve(session, port=port, open_browser=open_)


def _snapshot(paths) -> dict:
    """Each path's (mtime, size), None where it does not exist."""
    snap = {}
    for p in paths:
        try:
            st = os.stat(p)
            snap[p] = (st.st_mtime_ns, st.st_size)
        except OSError:
            snap[p] = None
    return snap


def _wait_for_change(paths, poll: float) -> None:
    import time

    before = _snapshot(paths)
    while _snapshot(paths) == before:
        time.sleep(poll)


def _run_once(opts: RunOptions) -> set:
    """One run of every shot, reported; returns the files a watch looks at."""
    graphs, frames, cache, quiet = opts.graphs, opts.frames, opts.cache, opts.quiet
    from proxyshade.graph.executor import make_executor
    from proxyshade.graph.graph import Graph, return_freed_memory
    from proxyshade.graph.shots import run_graphs
    from proxyshade.io.graphfile import parse_frame_list

    return_freed_memory()  # this process is the command's: freed arrays leave the resident set
    shots = []  # (label, graph, frames)
    for path in graphs:
        for combo in _sweep(opts.sweep):
            g = Graph.load(path, cache=cache, overrides=list(opts.set_), variables=dict(_vars(opts.var), **combo))
            label = f"{path}" + (f" [{' '.join(f'{k}={v}' for k, v in combo.items())}]" if combo else "")
            shots.append((label, g, parse_frame_list(frames, bounds=g.frames) if frames is not None else None))
    from proxyshade.graph.warmup import manifest_modules

    try:  # the kernels' cold-cache step
        _precompile(set().union(*(manifest_modules(g) for _, g, _ in shots)), quiet)
    except Exception as e:  # never in the way of the run: its kernels then compile when first called
        _say(err, f"note: compiling the kernels ahead failed ({type(e).__name__}: {e}); they compile when first called")
    several = len(shots) > 1
    prefixes = {id(g): f"{label.rpartition('/')[2]}: " if several else "" for label, g, _ in shots}
    distributed = bool(opts.scheduler) or opts.executor is Executor.dask
    if distributed:
        from proxyshade.graph.dask_executor import DaskExecutor

        ex = DaskExecutor(opts.scheduler, opts.workers)
    else:
        ex = make_executor(opts.jobs)
    with _LazyBars(quiet) as bars:
        with ex if distributed else contextlib.nullcontext():
            reports = run_graphs([(g, fl) for _, g, fl in shots], executor=ex, force=tuple(opts.force),
                                 hooks=lambda g: _BarHooks(bars, prefixes[id(g)]), threads=opts.threads,
                                 labels=[label for label, _, _ in shots])
    for (label, g, _), report in zip(shots, reports):
        _report(label, report, opts.explain, several)
    return {Path(p).resolve() for p in graphs} | {f for _, g, fl in shots for f in g.input_files(fl)}


def _report(label: str, report, explain: bool, several: bool) -> None:
    """A run's summary: per node seconds (or the --explain table), notes, the totals line."""
    computed = sum(r.status == "computed" for r in report.runs)
    reused = sum(r.status != "computed" for r in report.runs)
    if several:
        _say(out, label)
    if explain:
        from rich.table import Table

        t = Table(title=Text(label), show_lines=False)
        for c in ("node", "frame", "status", "why", "seconds"):
            t.add_column(c, justify="right" if c in ("frame", "seconds") else "left",
                         overflow="fold", no_wrap=False)  # reasons with paths fold, never cut
        for r in report.runs:
            t.add_row(Text(r.node), str(r.frame), r.status, Text(r.reason),
                      f"{r.seconds:.3f}" if r.status == "computed" else "")
        out.print(t)
        memo = {}  # node -> [hits, misses] of the memo (graph.memo) over its frames
        for r in report.runs:
            if r.memo_hits or r.memo_misses:
                m = memo.setdefault(r.node, [0, 0])
                m[0] += r.memo_hits
                m[1] += r.memo_misses
        for name, (h, m) in memo.items():
            _say(out, f"  memo {name:<16} {h} hit(s), {m} miss(es)")
        hits, misses = report.memo
        _say(out, f"  memo {hits} hit(s), {misses} miss(es) in all (synthesis results kept across frames)")
    else:
        per = {}
        for r in report.runs:
            if r.status == "computed":
                per[r.node] = per.get(r.node, 0.0) + r.seconds
        for name, s in per.items():
            _say(out, f"  {name:<16} {s:8.3f} s")
    if report.cleaned:
        _say(out, f"  note removed {len(report.cleaned)} temporary file(s) left by killed runs "
                  f"({sum(n for _, n in report.cleaned) / 1e6:.1f} MB)")
    for note in report.notes:
        _say(out, f"  note {note}")
    _say(out, f"{computed} computed, {reused} reused in {report.wall:.3f} s, peak memory {report.peak_rss_mb:.0f} MiB")


def _precompile(modules, quiet: bool):
    """The kernels' cold-cache step: when ``modules`` (``proxyshade.kernels`` names; None:
    every kernel module) are not all precompiled into this version's kernel cache
    (``kernels._cache``), compile their manifest signatures in one process per core, with a
    progress bar (``warmup.precompile``). Returns the precompile's report, None when there
    was nothing to compile."""
    from proxyshade.kernels._cache import kernels_cached

    if modules is not None and (not modules or kernels_cached(sorted(modules))):
        return None
    from proxyshade.graph.warmup import default_workers, mark_precompiled, pending, precompile

    todo = pending(modules)
    if not todo:
        mark_precompiled(modules)
        return None
    workers = min(default_workers(), len(todo))
    _say(err, f"compiling the numba kernels, once after an install or upgrade: {len(todo)} kernel signatures "
              f"in {workers} process(es) (later runs load them from numba's cache)")
    with _progress(quiet, "{task.fields[kernel]}") as progress:
        task = progress.add_task("compiling", total=len(todo), kernel="")

        def tick(done, total, kernel):
            progress.update(task, completed=done, total=total, kernel=(kernel or "").rpartition("kernels.")[2])

        r = precompile(modules, progress=tick, workers=workers)
    _say(err, f"kernels compiled in {r['seconds']:.1f} s ({r['compiled']} signatures, {r['workers']} processes)"
              + (f"; {len(r['failed'])} left to compile when first called" if r["failed"] else ""))
    return r


@app.command("compile")
def compile_kernels(quiet: bool = typer.Option(False, "--quiet", "-q", help="no progress bars")):
    """Compile the numba kernels into numba's cache: once after an install or upgrade (make
    demo runs it first). Compiles the kernel signatures the demo graphs reach in one process
    per core, then runs the demo graphs without their writers (their results stay in the
    graphs' caches for the demo; a kernel the list missed compiles there)."""
    import time

    from proxyshade.graph.warmup import kernel_signatures
    from proxyshade.graph.warmup_graphs import warm_up

    t0 = time.perf_counter()
    _precompile(None, quiet)
    with _LazyBars(quiet) as bars:
        hooks = _BarHooks(bars)
        hooks.told_compiling = True
        warm_up(hooks, first=False)
    _say(out, f"kernels ready in {time.perf_counter() - t0:.1f} s ({kernel_signatures()} kernel signatures "
              "in numba's cache)")


def _sweep(items: List[str]) -> list[dict]:
    """Every combination of the --sweep variables' values ([{}] without --sweep)."""
    combos = [{}]
    for item in items:
        name, eq, values = item.partition("=")
        vals = [v.strip() for v in values.split(",") if v.strip()]
        if not eq or not name.strip() or not vals:
            raise UserError(f"--sweep {item}: expected name=value1,value2,...")
        combos = [dict(c, **{name.strip(): v}) for c in combos for v in vals]
    return combos


def _vars(items: List[str]) -> dict:
    out = {}
    for item in items:
        name, eq, value = item.partition("=")
        if not eq or not name:
            raise UserError(f"--var {item}: expected name=value")
        if value.lstrip().startswith(("{", "[")):  # a mapping or a list, in YAML flow style
            from proxyshade.io import yamlfile

            try:
                value = yamlfile.parse(value, f"--var {yamlfile.cut(item, 200)}")
            except UserError as e:
                if "not valid YAML" not in str(e):
                    raise
                raise UserError(f"{e}; write a mapping like {{sand: rock}} or a list like [1920, 1080]") from None
        out[name.strip()] = value
    return out


@app.command()
def nodes():
    """Every node type with its inputs, parameters and docs."""
    from proxyshade.nodes import load_all

    REGISTRY = load_all()
    for name in sorted(REGISTRY):
        cls = REGISTRY[name]
        out.print(f"[bold]{name}[/bold] (v{cls.version}{', time-dependent' if cls.time_dependent else ''}{', writes files' if cls.sink else ''}{', whole sequence' if cls.sequence else ''})")
        doc = cls.doc().splitlines()
        if doc:
            _say(out, f"  {doc[0]}")
        for k, i in cls.inputs_spec.items():
            _say(out, f"  input  {k:<18} {'(optional) ' if i.optional else ''}{i.doc}")
        for k, p in cls.params_spec.items():
            default = "required" if p.required else f"default {p.default!r}"
            _say(out, f"  param  {k:<18} {p.describe()}, {default}{'' if p.hashed else ', not hashed'}  {p.doc}")


@app.command("graph")
def show_graph(graph: Path = typer.Argument(..., metavar="GRAPH", help="YAML graph file"),
               frames: Optional[str] = typer.Option(None, "--frames", help="frames to unroll (default: the first)"),
               var: List[str] = typer.Option([], "--var", help="set a graph variable: name=value")):
    """Print the graph's DAG: each node, its type and where its inputs come from."""
    from proxyshade.graph.graph import Graph
    from proxyshade.io.graphfile import parse_frame_list

    g = Graph.load(graph, variables=_vars(var))
    fl = parse_frame_list(frames, bounds=g.frames) if frames is not None else [g.frames[0]]
    g.instances(fl)  # rejects cycles
    _say(out, f"{graph}: frames {g.frames[0]}-{g.frames[1]}")
    for name, node in g.nodes.items():
        ins = []
        for k, ref in g.connections[name].items():
            at = "@all" if ref.all else "@first" if ref.first else (f"@{ref.offset:+d}" if ref.offset else "")
            ins.append(f"{k}<-{ref.node}{at}")
        state = "" if g.enabled[name] else " (disabled)"
        _say(out, f"  {name} [{type(node).__name__}]{state} {'  '.join(ins)}")


@app.command()
def inspect(file: Path = typer.Argument(..., metavar="FILE", help="an EXR file")):
    """Channels, their types and the metadata of an EXR."""
    from proxyshade.io.exr import read_header

    info = read_header(file)
    _say(out, f"{file}: {info['width']}x{info['height']}")
    for name, typ in info["channels"]:
        _say(out, f"  {name:<20} {typ}")
    for k, v in sorted(info["attributes"].items()):
        s = str(v)
        _say(out, f"  {k}: {s[:200] + '...' if len(s) > 200 else s}")


def _cache_root(cache: Optional[Path]) -> Path:
    from proxyshade.graph.graph import default_cache_dir

    return cache or default_cache_dir()


def _old_cache(graph: Optional[Path]):
    """The plate cache an older proxyshade kept beside GRAPH (``.proxyshade/cache``), if there."""
    from proxyshade.graph.cache import Cache

    old = Path(graph).resolve().parent / ".proxyshade" / "cache" if graph else None
    return Cache(old, background=False) if old is not None and old.is_dir() else None


_GRAPH_ARG = typer.Argument(None, help="a graph file: also its folder's old cache (.proxyshade/cache beside it, "
                            "where versions before the per-user cache kept it)")


@cache_app.command("info")
def cache_info(graph: Optional[Path] = _GRAPH_ARG,
               cache: Optional[Path] = typer.Option(None, "--cache", help="plate cache (default: $PROXYSHADE_CACHE, "
                                                    "else the per-user one)")):
    """Where the caches are and their size: plates, compiled kernels."""
    from proxyshade.graph.cache import Cache, LIMIT_ENV, size_limit, size_text
    from proxyshade.kernels import _cache as kernels

    def plates(c):
        i = c.info()
        temps = (f", {i['temps']} temporary file(s) ({i['temp_bytes'] / 1e6:.1f} MB, {i['stale_temps']} left by "
                 "killed runs: the next run removes them)") if i["temps"] else ""
        return f"{i['root']}: {i['entries']} entries, {size_text(i['bytes'])}{temps}"

    limit = size_limit()
    _say(out, f"plates  {plates(Cache(_cache_root(cache), background=False))} (a run warns past "
              f"{size_text(limit) if limit else 'no limit'}: {LIMIT_ENV})")
    k = kernels.info()
    old = (f"; {size_text(sum(n for _, n in k['old']))} of other versions: 'cache clean' removes them"
           if k["old"] else "")
    _say(out, f"kernels {k['folder']}: {size_text(k['bytes'])} (this version of the kernels){old}")
    legacy = _old_cache(graph)
    if legacy is not None:
        _say(out, f"old     {plates(legacy)} (no longer used: 'cache clean {graph}' removes it)")


@cache_app.command("clean")
def cache_clean(graph: Optional[Path] = _GRAPH_ARG,
                cache: Optional[Path] = typer.Option(None, "--cache", help="plate cache (default: $PROXYSHADE_CACHE, "
                                                     "else the per-user one)")):
    """Empty the plate cache (the next runs recompute what they need) and remove the compiled
    kernels of other versions of the kernels package (this version's are kept). Nothing is
    removed otherwise: a run warns when the plate cache passes $PROXYSHADE_CACHE_LIMIT (20G).
    A folder that is not a plate cache (no CACHEDIR.TAG of proxyshade's, and files that are
    not cache entries) is refused, nothing removed."""
    from proxyshade.graph.cache import Cache, size_text
    from proxyshade.kernels import _cache as kernels

    where = (f"--cache {cache}" if cache else f"$PROXYSHADE_CACHE={os.environ['PROXYSHADE_CACHE']}"
             if os.environ.get("PROXYSHADE_CACHE") else None)
    for c, label in ((Cache(_cache_root(cache), background=False), where), (_old_cache(graph), None)):
        if c is None:
            continue
        n, size = c.info()["entries"], c.size()
        c.clean(label)
        _say(out, f"removed {n} entries ({size_text(size)}) from {c.root}")
    old, in_use = kernels.remove_old()
    kept = f" and {len(in_use)} other version(s) used in the last hour" if in_use else ""
    _say(out, f"removed compiled kernels of other versions ({len(old)} folder(s) or file(s), "
              f"{size_text(sum(n for _, n in old))}) from {kernels.root()}; kept this version's "
              f"({kernels.folder().name}){kept}")


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """Warnings as one line on stderr (no source line of the code that warned)."""
    _say(err, f"warning: {_one_line(str(message))}")


def main(argv: list[str] | None = None) -> int:
    """Entry point: returns the exit code (see the module docstring). ``argv`` None: the
    process's own command line (the console script), which ends here (``_exit_now``)."""
    code = EXIT_INTERNAL
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("default")
            # as Python's own defaults: a file left open by a Ctrl-C inside an import is not the user's
            warnings.simplefilter("ignore", ResourceWarning)
            warnings.showwarning = _show_warning
            code = _main(argv)
    except KeyboardInterrupt:  # outside typer's own handling (before or after the command)
        _say(err, "interrupted")
        code = EXIT_INTERRUPTED
    finally:
        if argv is None and threading.current_thread() is threading.main_thread():
            # the exit code is decided and every file is written: a Ctrl-C while the interpreter
            # shuts down (joining threads, unloading libraries) would only turn it into a bare SIGINT
            signal.signal(signal.SIGINT, signal.SIG_IGN)
    if argv is None and threading.current_thread() is threading.main_thread():
        _exit_now(code)
    return code


def _exit_now(code: int) -> None:
    """End the process with ``code`` once the command is done: the ``atexit`` functions run
    (the code facts of ``graph.keys`` are saved), stdout and stderr are flushed, then
    ``os._exit`` skips the interpreter's teardown (freeing every module and object, the
    libraries' destructors: USD's, LLVM's), 0.3-1 s of a first frame's wall time for
    nothing: every output and cache entry was renamed into place before the command
    returned (the engine waits for the cache's writer). A flush that fails (the reader of a
    pipe went away) leaves the ordinary exit to report it."""
    import atexit

    atexit._run_exitfuncs()
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except (OSError, ValueError):
        return
    os._exit(code)


def _closed_pipe() -> int:
    """Exit 0 after the reader of stdout went away: stdout pointed at the null device, so the
    interpreter's last flush finds nothing to complain about."""
    try:
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, sys.stdout.fileno())
        os.close(null)
    except (OSError, ValueError):
        pass
    return 0


def _from_ctrl_c(e: BaseException) -> bool:
    """Whether ``e`` wraps a Ctrl-C: Python 3.11 turns a KeyboardInterrupt raised while a class
    is created during an import (``__set_name__``) into a RuntimeError caused by it."""
    seen = set()
    while e is not None and id(e) not in seen:
        if isinstance(e, KeyboardInterrupt):
            return True
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return False


def _main(argv: list[str] | None) -> int:
    try:
        code = app(args=argv, prog_name="proxyshade", standalone_mode=False)
    except UserError as e:
        _say(err, f"error: {_one_line(str(e))}")
        return getattr(e, "exit_code", EXIT_BAD_INPUT)
    except KeyboardInterrupt:
        code = EXIT_INTERRUPTED
    except BrokenPipeError:  # the reader closed the pipe ('proxyshade nodes | head -1'): it read what it wanted
        return _closed_pipe()
    except (typer.Exit, SystemExit) as e:
        if isinstance(e.__context__, BrokenPipeError):  # click turns a closed pipe into exit 1
            return _closed_pipe()
        code = getattr(e, "exit_code", getattr(e, "code", 0))
    except _USAGE_ERROR as e:
        if type(e).__name__ == "NoArgsIsHelpError":  # a bare 'proxyshade' or 'proxyshade cache'
            _say(err, e.format_message())
            return EXIT_BAD_INPUT
        usage = _one_line(e.ctx.get_usage()) if getattr(e, "ctx", None) else ""
        cmd = e.ctx.command_path if getattr(e, "ctx", None) else "proxyshade"
        _say(err, f"error: {_one_line(e.format_message())} {usage} (see '{cmd} --help')".replace("  ", " "))
        return EXIT_BAD_INPUT
    except _CLICK_EXCEPTION as e:
        _say(err, f"error: {_one_line(e.format_message())}")
        return e.exit_code or EXIT_INTERNAL
    except typer.Abort as e:
        if isinstance(e.__context__, KeyboardInterrupt):  # typer versions whose Ctrl-C is an Abort
            code = EXIT_INTERRUPTED
        else:
            _say(err, "aborted")
            return EXIT_INTERNAL
    except OSError as e:  # a file outside the writers (a report, a folder) on a full or failing disk
        if os.environ.get("PROXYSHADE_DEBUG"):
            raise
        _say(err, f"error: {e.filename or ''}{': ' if e.filename else ''}{e.strerror or e}; "
                  "free space or fix the disk, then run again")
        return EXIT_IO
    except Exception as e:  # noqa: BLE001
        if not _from_ctrl_c(e):
            _say(err, f"internal error: {type(e).__name__}: {_one_line(str(e))} (PROXYSHADE_DEBUG=1 for the traceback)")
            if os.environ.get("PROXYSHADE_DEBUG"):
                raise
            return EXIT_INTERNAL
        code = EXIT_INTERRUPTED
    code = code if isinstance(code, int) else 0
    if code == EXIT_INTERRUPTED:
        _say(err, "interrupted")
    return code


if __name__ == "__main__":
    sys.exit(main())
