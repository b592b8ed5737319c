"""The command line: exit codes, explain, inspect, nodes, cache."""
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from proxyshade.cli import main

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def graph(tmp_path):
    """The source-import graph copied beside a copy of the renoir sample."""
    (tmp_path / "graphs").mkdir()
    shutil.copytree(ROOT / "samples" / "renoir", tmp_path / "samples" / "renoir")
    shutil.copy(ROOT / "graphs" / "import_source.yaml", tmp_path / "graphs" / "import_source.yaml")
    return tmp_path / "graphs" / "import_source.yaml"


def test_run_then_rerun_reuses_everything(graph, capsys):
    assert main(["run", str(graph), "-q"]) == 0
    assert "4 computed, 0 reused" in capsys.readouterr().out
    assert (graph.parent.parent / "out" / "import_source" / "renoir.exr").is_file()
    assert main(["run", str(graph), "--explain", "-q"]) == 0
    text = capsys.readouterr().out
    assert "0 computed, 4 reused" in text and "cache hit" in text


def test_bad_input_exits_2_with_one_line(graph, capsys):
    assert main(["run", str(graph), "--set", "src.far_distance=-1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "src.far_distance: expected float >= 0.0, got -1" in err
    assert main(["run", str(graph.parent / "missing.yaml")]) == 2
    assert main(["run", str(graph), "--frames", "7"]) == 2  # outside the graph's frames
    assert "outside the graph's frames 1-1" in capsys.readouterr().err


def test_missing_source_file_is_bad_input(graph, capsys):
    (graph.parent.parent / "samples" / "renoir" / "style.png").unlink()
    assert main(["run", str(graph), "-q"]) == 2
    assert "style.png: no such image file" in capsys.readouterr().err


def test_inspect_nodes_graph_and_cache(graph, capsys):
    main(["run", str(graph), "-q"])
    capsys.readouterr()
    assert main(["inspect", str(graph.parent.parent / "out" / "import_source" / "renoir.exr")]) == 0
    text = capsys.readouterr().out
    assert "label.id" in text and "uint" in text and "proxyshade/node: write" in text
    assert main(["nodes"]) == 0
    assert "SourceRead" in capsys.readouterr().out
    assert main(["graph", str(graph)]) == 0
    assert "write [ExrWrite] image<-src" in capsys.readouterr().out
    assert main(["cache", "info", str(graph)]) == 0
    assert "4 entries" in capsys.readouterr().out  # one per node; the run record is not an entry
    assert main(["cache", "clean", str(graph)]) == 0
    assert main(["run", str(graph), "-q"]) == 0
    assert "4 computed" in capsys.readouterr().out


def test_console_script_exit_code(graph):
    exe = Path(sys.executable).parent / "proxyshade"
    r = subprocess.run([str(exe), "run", str(graph), "--set", "nope.x=1"], capture_output=True, text=True)
    assert r.returncode == 2 and "no node 'nope'" in r.stderr and "Traceback" not in r.stderr


def test_console_script_ends_with_everything_written_and_flushed(graph, tmp_path):
    """The console script skips the interpreter's teardown (cli._exit_now): the report still
    reaches a pipe whole, the atexit work is done (the code facts saved), every output and
    cache entry is in place, and a re-run reuses everything."""
    exe = Path(sys.executable).parent / "proxyshade"
    env = dict(__import__("os").environ, XDG_CACHE_HOME=str(tmp_path / "xdg"))
    cache = tmp_path / "plates"
    r = subprocess.run([str(exe), "run", str(graph), "-q", "--cache", str(cache)], capture_output=True, text=True,
                       env=env)
    assert r.returncode == 0, r.stderr
    assert r.stdout.rstrip().splitlines()[-1].startswith("4 computed, 0 reused")
    assert list((tmp_path / "xdg" / "proxyshade").glob("code-facts-*.json"))
    assert (graph.parent.parent / "out" / "import_source" / "renoir.exr").is_file()
    assert not [p for p in cache.rglob("*") if ".tmp" in p.name]
    r = subprocess.run([str(exe), "run", str(graph), "-q", "--cache", str(cache)], capture_output=True, text=True,
                       env=env)
    assert r.returncode == 0 and "0 computed, 4 reused" in r.stdout


def test_vars_from_the_command_line(graph, capsys, monkeypatch):
    shutil.copytree(ROOT / "samples" / "monet", graph.parent.parent / "samples" / "monet")
    # a bundled name (samples/monet beside the graph's folder) and an output folder of the user's
    assert main(["run", str(graph), "-q", "--var", "source=monet", "--var", f"out={graph.parent.parent / 'out' / 'm'}"]) == 0
    assert (graph.parent.parent / "out" / "m" / "monet.exr").is_file()
    # a path to a source.yaml, relative to the current folder
    monkeypatch.chdir(graph.parent.parent)
    assert main(["run", str(graph), "-q", "--var", "source=samples/monet/source.yaml", "--var", "out=out/p"]) == 0
    assert (graph.parent.parent / "out" / "p" / "monet.exr").is_file()
    assert main(["run", str(graph), "--var", "oops"]) == 2
    assert "--var oops: expected name=value" in capsys.readouterr().err


def test_movie_of_a_partial_range_and_graph_listing(tmp_path, registry, capsys):
    g = tmp_path / "m.yaml"
    g.write_text("format: proxyshade/1\nframes: 1-10\nnodes:\n"
                 "  f:     {type: TFrame}\n"
                 "  movie: {type: Movie, inputs: {image: {node: f, frame: all}}, params: {path: out/m.gif, channels: [R]}}\n")
    assert main(["graph", str(g)]) == 0
    assert "movie [Movie] image<-f@all" in capsys.readouterr().out
    assert main(["run", str(g), "--frames", "3", "--explain", "-q"]) == 0
    text = capsys.readouterr().out
    assert "4 computed, 0 reused" in text  # f at 1, 2, 3 and one movie
    assert main(["run", str(g), "--frames", "3", "-q"]) == 0
    assert "0 computed, 4 reused" in capsys.readouterr().out
    assert (tmp_path / "out" / "m.gif").is_file()


def test_first_run_says_it_compiles_the_kernels(graph, capsys, monkeypatch):
    import proxyshade.cli as cli
    import proxyshade.kernels._cache as config

    monkeypatch.setattr(cli.err, "_force_terminal", True)  # said on a terminal, like the progress bars
    monkeypatch.setattr(config, "kernels_cached", lambda modules=(): False)  # as right after an install
    assert main(["run", str(graph), "-q"]) == 0
    assert "compiling the numba kernels" in capsys.readouterr().err
    monkeypatch.setattr(config, "kernels_cached", lambda modules=(): True)
    assert main(["run", str(graph), "-q", "--force", "src"]) == 0
    assert "compiling" not in capsys.readouterr().err


def test_progress_bars_are_drawn_on_a_terminal_from_the_first_computed_node_only(graph, capsys, monkeypatch):
    """A run that computes shows a bar per node on a terminal (each full at the end: the
    reused nodes counted too); a fully cached run starts no bars at all."""
    import proxyshade.cli as cli

    monkeypatch.setattr(cli.err, "_force_terminal", True)
    started = []
    real = cli._progress

    def spy(*a):
        p = real(*a)
        started.append(p)
        return p

    monkeypatch.setattr(cli, "_progress", spy)
    assert main(["run", str(graph)]) == 0
    assert len(started) == 1
    tasks = started[0].tasks
    assert {t.description for t in tasks} >= {"src"} and all(t.completed == t.total > 0 for t in tasks)
    capsys.readouterr()
    assert main(["run", str(graph), "--force", "src"]) == 0  # one node computes, the others reused
    assert len(started) == 2 and all(t.completed == t.total for t in started[1].tasks)
    assert main(["run", str(graph)]) == 0
    assert "0 computed" in capsys.readouterr().out and len(started) == 2  # cached: no bars


def test_one_set_of_bars_follows_several_graphs_as_compile_runs_them(graph, tmp_path, registry, monkeypatch):
    """``proxyshade compile`` runs the demo graphs one after another with one ``_BarHooks``:
    each graph's nodes get their bars when it computes."""
    import proxyshade.cli as cli
    from proxyshade.graph.graph import Graph

    monkeypatch.setattr(cli.err, "_force_terminal", True)
    g2 = tmp_path / "m.yaml"
    g2.write_text("format: proxyshade/1\nframes: 1-2\nnodes:\n  f: {type: TFrame}\n")
    with cli._LazyBars(False) as bars:
        hooks = cli._BarHooks(bars)
        Graph.load(graph, cache=tmp_path / "c1").run(hooks=hooks)
        Graph.load(g2, cache=tmp_path / "c2").run([1, 2], hooks=hooks)
    done = {t.description: (t.completed, t.total) for t in bars.progress.tasks}
    assert done["f"] == (2, 2) and done["src"][0] == done["src"][1] > 0


def test_a_cold_kernel_cache_compiles_the_manifest_first_with_a_note(graph, capsys, monkeypatch):
    """On a cold numba cache ``run`` compiles the manifest's kernels of the graph's kernel
    modules before the run (``warmup.precompile``), saying so; on a warm one it says nothing."""
    import proxyshade.kernels._cache as config
    from proxyshade.graph import warmup

    sig = "(int64, Array(uint32, 2, 'C', False, aligned=True))"
    monkeypatch.setattr(warmup, "manifest", lambda: [("proxyshade.kernels.random.uniform_field", sig, 1.0, ()),
                                                     ("proxyshade.kernels.poisson.nothing_here", "(int64,)", 1.0, ())])
    monkeypatch.setattr(warmup, "manifest_modules", lambda g: {"proxyshade.kernels.random"})
    monkeypatch.setattr(config, "kernels_cached", lambda modules=(): False)  # as right after an install
    monkeypatch.setattr(config, "mark_precompiled", lambda modules: None)
    assert main(["run", str(graph), "-q"]) == 0
    err = capsys.readouterr().err
    assert "compiling the numba kernels, once" in err and "1 kernel signatures" in err
    assert "kernels compiled in" in err
    monkeypatch.setattr(config, "kernels_cached", lambda modules=(): True)
    assert main(["run", str(graph), "-q", "--force", "src"]) == 0
    assert "compil" not in capsys.readouterr().err


def test_compile_precompiles_every_manifest_kernel_then_runs_the_demo_graphs(capsys, monkeypatch):
    from proxyshade.graph import warmup
    from proxyshade.kernels import _cache

    sig = "(int64, Array(uint32, 2, 'C', False, aligned=True))"
    monkeypatch.setattr(warmup, "manifest", lambda: [("proxyshade.kernels.random.uniform_field", sig, 1.0, ()),
                                                     ("proxyshade.kernels.random._keys", "(int64, int64)", 0.5, ())])
    monkeypatch.setattr(_cache, "kernels_cached", lambda modules=(): False)  # as right after an install
    ran = []
    from proxyshade.graph import warmup_graphs

    monkeypatch.setattr(warmup_graphs, "WARMUP", [])  # the demo graphs: too slow for a test
    monkeypatch.setattr(warmup, "precompile", lambda modules=None, progress=None, workers=None: ran.append(
        sorted(modules or ())) or {"compiled": 2, "failed": [], "seconds": 0.1, "workers": 1})
    assert main(["compile", "-q"]) == 0
    captured = capsys.readouterr()
    assert ran == [[]]  # every module's kernels, once
    assert "2 kernel signatures" in captured.err and "kernels ready in" in captured.out


def test_watch_runs_again_when_a_file_the_graph_reads_changes(tmp_path, capsys):
    """``run --watch``: after the run it waits; an edit of the source table (a file a node
    reads) starts the next run, which recomputes what the edit reaches."""
    import threading
    import time

    src = tmp_path / "src"
    src.mkdir()
    for f in ("source.yaml", "style.png", "style_mask.png", "target_mask.png"):
        shutil.copy(ROOT / "samples" / "renoir" / f, src / f)
    out = tmp_path / "out"
    args = ["run", str(ROOT / "graphs" / "import_source.yaml"), "--var", f"source={src / 'source.yaml'}",
            "--var", f"out={out}", "--cache", str(tmp_path / "cache"), "-q", "--watch", "--poll", "0.05",
            "--watch-runs", "2"]
    result = {}
    t = threading.Thread(target=lambda: result.setdefault("rc", main(args)), daemon=True)
    t.start()
    deadline = time.time() + 120
    while not list(out.glob("*.exr")) and time.time() < deadline:
        time.sleep(0.05)
    assert list(out.glob("*.exr"))
    time.sleep(0.3)  # the watch has taken its snapshot
    table = src / "source.yaml"
    table.write_text(table.read_text().replace("sky:        {id: 2,", "sky:        {id: 7,"))
    t.join(120)
    assert not t.is_alive() and result["rc"] == 0
    totals = [line for line in capsys.readouterr().out.splitlines() if " computed, " in line]
    assert len(totals) == 2 and totals[1].startswith("4 computed")  # the source read and its three writers
    assert int(totals[0].split()[0]) == 4


def test_the_default_cache_is_per_user_outside_the_source_tree(graph, capsys, monkeypatch, tmp_path):
    """Without --cache or $PROXYSHADE_CACHE plates go to $XDG_CACHE_HOME/proxyshade/plates
    (else ~/.cache/proxyshade/plates), never beside the graph; ``cache info`` shows where
    and how much, ``cache clean`` says what it removes and keeps."""
    monkeypatch.delenv("PROXYSHADE_CACHE")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert main(["run", str(graph), "-q"]) == 0
    plates = tmp_path / "xdg" / "proxyshade" / "plates"
    assert plates.is_dir() and not (graph.parent / ".proxyshade").exists()
    capsys.readouterr()
    assert main(["cache", "info"]) == 0
    info = capsys.readouterr().out
    assert f"plates  {plates}: 4 entries" in info and "a run warns past 20.0 GiB" in info
    assert "kernels " in info and "this version of the kernels" in info
    assert main(["cache", "clean"]) == 0
    text = capsys.readouterr().out
    assert f"removed 4 entries" in text and str(plates) in text and "kept this version's" in text
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    from proxyshade.graph.graph import default_cache_dir

    assert default_cache_dir() == tmp_path / "home" / ".cache" / "proxyshade" / "plates"


def test_an_old_cache_beside_the_graph_is_shown_and_removed(graph, capsys):
    """The cache older versions kept beside the graph (graphs/.proxyshade/cache) is no longer
    used: ``cache info GRAPH`` shows it, ``cache clean GRAPH`` removes it."""
    old = graph.parent / ".proxyshade" / "cache"
    assert main(["run", str(graph), "-q", "--cache", str(old)]) == 0
    capsys.readouterr()
    assert main(["cache", "info", str(graph)]) == 0
    assert f"old     {old}: 4 entries" in capsys.readouterr().out
    assert main(["cache", "clean", str(graph)]) == 0
    assert f"removed 4 entries" in capsys.readouterr().out and not old.exists()


def test_a_run_warns_once_when_the_cache_passes_its_limit(graph, capsys, monkeypatch):
    """$PROXYSHADE_CACHE_LIMIT: a computing run past it prints one warning line; a cached
    re-run (the cache cannot have grown) is quiet; a bad value is a one-line error."""
    monkeypatch.setenv("PROXYSHADE_CACHE_LIMIT", "1k")
    assert main(["run", str(graph), "-q"]) == 0
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(err) == 1 and err[0].startswith("warning: cache ") and "over its limit of 1.0 KiB" in err[0]
    assert "proxyshade cache clean" in err[0] and "PROXYSHADE_CACHE_LIMIT" in err[0]
    assert main(["run", str(graph), "-q"]) == 0
    assert "warning" not in capsys.readouterr().err
    monkeypatch.setenv("PROXYSHADE_CACHE_LIMIT", "0")
    assert main(["run", str(graph), "-q", "--force", "src"]) == 0
    assert "warning" not in capsys.readouterr().err
    monkeypatch.setenv("PROXYSHADE_CACHE_LIMIT", "lots")
    assert main(["run", str(graph), "-q"]) == 2
    assert capsys.readouterr().err.strip() == ("error: PROXYSHADE_CACHE_LIMIT=lots: not a size; set it like 20G, "
                                               "500M or 0 (no warning)")


def test_a_ctrl_c_wrapped_by_an_import_is_an_interruption():
    """Python 3.11 wraps a Ctrl-C that lands while an import creates a class in a RuntimeError
    (``__set_name__``): the command reports it as interrupted (130), not an internal error."""
    from proxyshade import cli

    try:
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as k:
            raise RuntimeError("Error calling __set_name__") from k
    except RuntimeError as e:
        wrapped = e
    assert cli._from_ctrl_c(wrapped)
    assert not cli._from_ctrl_c(RuntimeError("a real bug"))
