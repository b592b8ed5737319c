"""The ``proxyshade`` command line: run graphs, list nodes, inspect EXRs, manage the cache.

Exit codes: 0 ok, 2 bad input (a one-line message, no traceback), 1 internal error.
"""
from __future__ import annotations

import os
import sys
import warnings
from pathlib import Path
from typing import List, Optional

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from proxyshade.errors import UserError

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

source_app = typer.Typer(no_args_is_help=True, help="Annotated sources: a photo, its label map, a source.yaml.")
app.add_typer(source_app, name="source")


@source_app.command("new")
def source_new(photo: Path = typer.Argument(..., help="the photo (8-bit sRGB)"),
               label_map: Path = typer.Argument(..., help="its label map: flat colours, one per label, same size"),
               output: Path = typer.Option(None, "-o", "--output", help="the source.yaml to write (default: beside the photo)"),
               min_share: float = typer.Option(0.005, "--min-share", help="colours covering less of the map are noise"),
               force: bool = typer.Option(False, "--force", help="replace an existing file")):
    """Write a source.yaml for PHOTO and LABEL_MAP with the palette found in the map."""
    from proxyshade.io.source import load_source, new_table

    output = output or photo.parent / "source.yaml"
    if output.exists() and not force:
        raise UserError(f"{output}: exists; choose another -o path or pass --force to replace it")
    text, rep = new_table(photo, label_map, output, min_share=min_share)
    output.parent.mkdir(parents=True, exist_ok=True)
    tmp = output.with_name(f".{output.name}.{os.getpid()}.tmp")
    tmp.write_text(text)
    try:
        load_source(tmp, where=str(output))  # the table must load as written
    except UserError:
        tmp.unlink()
        raise
    os.replace(tmp, output)
    out.print(f"{output}: {rep['labels']} labels; {rep['snapped']} pixels ({rep['snapped_share']:.2%}) of other "
              "colours will snap to the nearest label. Rename the labels after your scene's.", markup=False)


class _BarHooks:
    """One progress bar per node, advancing once per frame."""

    def __init__(self, progress: Progress):
        self.progress = progress
        self.tasks = {}

    def plan(self, plan):
        counts = {}
        for name, _ in plan.keys:
            counts[name] = counts.get(name, 0) + 1
        for name in plan.graph.nodes:
            if name in counts:
                self.tasks[name] = self.progress.add_task(name, total=counts[name])

    def start(self, run):
        pass

    def done(self, run):
        if run.node in self.tasks:
            self.progress.advance(self.tasks[run.node])


@app.command()
def run(
    graph: Path = typer.Argument(..., help="YAML graph file"),
    frames: Optional[str] = typer.Option(None, "--frames", help="frames to compute: 1-48, 30 or 1,5,9-12 (default: the graph's range)"),
    set_: List[str] = typer.Option([], "--set", help="override a parameter: node.param=value (repeatable)"),
    var: List[str] = typer.Option([], "--var", help="set a graph variable: name=value (repeatable), used as ${name}"),
    cache: Optional[Path] = typer.Option(None, "--cache", help="cache folder (default .proxyshade/cache beside the graph, or $PROXYSHADE_CACHE)"),
    explain: bool = typer.Option(False, "--explain", help="print per node whether it was computed or reused, and why"),
    jobs: int = typer.Option(1, "--jobs", min=1, help="nodes run concurrently"),
    force: List[str] = typer.Option([], "--force", help="recompute this node (repeatable)"),
    threads: int = typer.Option(0, "--threads", min=0, help="numba threads per kernel (0: all cores)"),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="no progress bars"),
):
    """Run GRAPH: compute what the cache lacks, reuse the rest."""
    from proxyshade.graph.graph import Graph
    from proxyshade.io.graphfile import parse_frame_list

    g = Graph.load(graph, cache=cache, overrides=list(set_), variables=_vars(var))
    fl = parse_frame_list(frames) if frames else None
    with Progress(TextColumn("{task.description:<14}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  console=err, disable=quiet or not err.is_terminal, transient=True) as progress:
        report = g.run(fl, jobs=jobs, force=tuple(force), hooks=_BarHooks(progress), threads=threads)
    computed = sum(r.status == "computed" for r in report.runs)
    reused = sum(r.status != "computed" for r in report.runs)
    if explain:
        t = Table(title=f"{graph}", show_lines=False)
        for c in ("node", "frame", "status", "why", "seconds"):
            t.add_column(c, justify="right" if c in ("frame", "seconds") else "left")
        for r in report.runs:
            t.add_row(r.node, str(r.frame), r.status, r.reason, f"{r.seconds:.3f}" if r.status == "computed" else "")
        out.print(t)
    else:
        per = {}
        for r in report.runs:
            if r.status == "computed":
                per[r.node] = per.get(r.node, 0.0) + r.seconds
        for name, s in per.items():
            out.print(f"  {name:<16} {s:8.3f} s")
    for note in report.notes:
        out.print(f"  note {note}")
    out.print(f"{computed} computed, {reused} reused in {report.wall:.3f} s, peak memory {report.peak_rss_mb:.0f} MiB")


def _vars(items: List[str]) -> dict:
    out = {}
    for item in items:
        name, eq, value = item.partition("=")
        if not eq or not name:
            raise UserError(f"--var {item}: expected name=value")
        if value.lstrip().startswith(("{", "[")):  # a mapping or a list, in YAML flow style
            import yaml

            try:
                value = yaml.safe_load(value)
            except yaml.YAMLError as e:
                raise UserError(f"--var {item}: not valid YAML ({getattr(e, 'problem', e)}); write a mapping like "
                                "{sand: rock} or a list like [1920, 1080]") from None
        out[name.strip()] = value
    return out


@app.command()
def nodes():
    """Every node type with its inputs, parameters and docs."""
    import proxyshade.nodes  # noqa: F401
    from proxyshade.graph.node import REGISTRY

    for name in sorted(REGISTRY):
        cls = REGISTRY[name]
        out.print(f"[bold]{name}[/bold] (v{cls.version}{', time-dependent' if cls.time_dependent else ''}{', writes files' if cls.sink else ''}{', whole sequence' if cls.sequence else ''})")
        doc = cls.doc().splitlines()
        if doc:
            out.print(f"  {doc[0]}")
        for k, i in cls.inputs_spec.items():
            out.print(f"  input  {k:<18} {'(optional) ' if i.optional else ''}{i.doc}")
        for k, p in cls.params_spec.items():
            default = "required" if p.required else f"default {p.default!r}"
            out.print(f"  param  {k:<18} {p.describe()}, {default}{'' if p.hashed else ', not hashed'}  {p.doc}", highlight=False)


@app.command("graph")
def show_graph(graph: Path = typer.Argument(..., help="YAML graph file"),
               frames: Optional[str] = typer.Option(None, "--frames", help="frames to unroll (default: the first)"),
               var: List[str] = typer.Option([], "--var", help="set a graph variable: name=value")):
    """Print the graph's DAG: each node, its type and where its inputs come from."""
    from proxyshade.graph.graph import Graph
    from proxyshade.io.graphfile import parse_frame_list

    g = Graph.load(graph, variables=_vars(var))
    fl = parse_frame_list(frames) if frames else [g.frames[0]]
    g.instances(fl)  # rejects cycles
    out.print(f"{graph}: frames {g.frames[0]}-{g.frames[1]}")
    for name, node in g.nodes.items():
        ins = []
        for k, ref in g.connections[name].items():
            at = "@all" if ref.all else "@first" if ref.first else (f"@{ref.offset:+d}" if ref.offset else "")
            ins.append(f"{k}<-{ref.node}{at}")
        state = "" if g.enabled[name] else " (disabled)"
        out.print(f"  {name} [{type(node).__name__}]{state} {'  '.join(ins)}", highlight=False)


@app.command()
def inspect(file: Path = typer.Argument(..., help="an EXR file")):
    """Channels, their types and the metadata of an EXR."""
    from proxyshade.io.exr import read_header

    info = read_header(file)
    out.print(f"{file}: {info['width']}x{info['height']}")
    for name, typ in info["channels"]:
        out.print(f"  {name:<20} {typ}", highlight=False)
    for k, v in sorted(info["attributes"].items()):
        s = str(v)
        out.print(f"  {k}: {s[:200] + '...' if len(s) > 200 else s}", highlight=False)


def _cache_root(graph: Optional[Path], cache: Optional[Path]) -> Path:
    from proxyshade.graph.graph import default_cache_dir

    if cache:
        return cache
    return default_cache_dir(Path(graph).resolve().parent if graph else Path.cwd())


@cache_app.command("info")
def cache_info(graph: Optional[Path] = typer.Argument(None, help="graph file whose default cache to use"),
               cache: Optional[Path] = typer.Option(None, "--cache")):
    """Entries and size of the cache."""
    from proxyshade.graph.cache import Cache

    i = Cache(_cache_root(graph, cache)).info()
    out.print(f"{i['root']}: {i['entries']} entries, {i['bytes'] / 1e6:.1f} MB")


@cache_app.command("clean")
def cache_clean(graph: Optional[Path] = typer.Argument(None, help="graph file whose default cache to use"),
                cache: Optional[Path] = typer.Option(None, "--cache")):
    """Delete every cache entry."""
    from proxyshade.graph.cache import Cache

    c = Cache(_cache_root(graph, cache))
    n = c.clean()
    out.print(f"removed {n} entries from {c.root}")


def main(argv: list[str] | None = None) -> int:
    """Entry point: maps bad input to exit code 2 and internal errors to 1."""
    warnings.simplefilter("default")
    try:
        app(args=argv, standalone_mode=False)
    except UserError as e:
        err.print(f"error: {e}", highlight=False, soft_wrap=True)
        return (2)
    except (typer.Exit, SystemExit) as e:
        return (getattr(e, "exit_code", getattr(e, "code", 0)) or 0)
    except Exception as e:  # noqa: BLE001
        import click

        if isinstance(e, click.exceptions.UsageError):
            err.print(f"error: {e.format_message()}", highlight=False, soft_wrap=True)
            return (2)
        if isinstance(e, click.exceptions.Abort):
            return (1)
        err.print(f"internal error: {type(e).__name__}: {e}", highlight=False, soft_wrap=True)
        if os.environ.get("PROXYSHADE_DEBUG"):
            raise
        return (1)
    return (0)


if __name__ == "__main__":
    sys.exit(main())
