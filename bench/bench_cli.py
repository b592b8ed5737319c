"""The command a user types, timed from outside: ``proxyshade run graphs/first_frame.yaml
--frames 1`` with a fresh plate cache (a new shot's state) and a warm numba kernel cache,
as a new process, against EbSynth on the same guide, interleaved round by round. Each
checkout's bytecode is compiled first, as ``pip install`` leaves a user's (``compile_bytecode``).

Each round runs, in turn: the command of this checkout; with ``--baseline DIR``, the same
command from another checkout (its ``proxyshade`` package first on ``PYTHONPATH``, this
virtual environment's libraries); with ``--ebsynth PATH``, EbSynth texture by numbers
(``-style photo -guide src_labels tgt_labels -patchsize 3 -uniformity 1000``, as
bench/bench_photos.py runs it) with the source's label map and the frame's detailed guide
(the ``guide`` node's label.id at the output size, in the label map's colours). Every
child's wall time, CPU seconds (user + system) and peak resident memory come from
``os.wait4``. Prints the medians over ``--rounds`` (default 5; the peak RSS's largest round too), the ratios, the load
average before and after, then this checkout's ``--profile`` of one more run: where the
time went and the resident memory before and during each node, the node holding the peak,
the plates in memory then (resident MiB, each page once: ``profile.plate_memory``; allocated
beside) and what the peak holds (mapped library files, the heap when the first node started,
plates, the rest).

Run: ``python bench/bench_cli.py --ebsynth /tmp/ebsynth --baseline /work/main``. On a machine
shared with other checkouts, give this one a kernel cache of its own (``NUMBA_CACHE_DIR``):
``proxyshade cache clean`` in another checkout removes every other version's compiled kernels.
(``--format 4k --rounds 1`` for 4K: EbSynth is left out above 1024 wide unless ``--ebsynth-4k``).
Bars (issue 41): median wall <= 3 s on 2 idle cores at 1024 wide, >= 5x faster than
EbSynth; peak RSS <= 400 MiB at 1024 wide, <= 1.5 GiB at 4K.
"""
from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
GRAPH = ROOT / "graphs" / "first_frame.yaml"
RUN = "import sys; from proxyshade.cli import main; sys.exit(main())"


def child(argv: list[str], env: dict | None = None) -> dict:
    """Run ``argv``; its wall seconds, CPU seconds (user + system) and peak RSS (MiB). With
    ``env``'s PYTHONPATH (a baseline checkout) it runs in that folder, whose package
    ``python -c`` then imports ('' first on sys.path)."""
    t0 = time.perf_counter()
    cwd = (env or {}).get("PYTHONPATH") or ROOT
    p = subprocess.Popen(argv, env=env, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    out = p.stdout.read()
    _, status, ru = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t0
    p.returncode = os.waitstatus_to_exitcode(status)
    if p.returncode:
        raise SystemExit(f"{' '.join(argv[:6])} ... failed ({p.returncode}):\n{out.decode(errors='replace')[-3000:]}")
    return {"wall": wall, "cpu": ru.ru_utime + ru.ru_stime, "rss": ru.ru_maxrss / 1024.0, "out": out.decode()}


def proxyshade_argv(fmt: str | None, cache: Path, out: Path, extra=(), graph: Path = GRAPH) -> list[str]:
    """The command; ``graph``: the graph file (a baseline checkout runs its own: its defaults
    and parameters are its own)."""
    argv = [sys.executable, "-c", RUN, "run", str(graph), "--frames", "1", "--cache", str(cache),
            "--var", f"out={out}", "-q", *extra]
    if fmt:
        argv += ["--var", f"format={fmt}"]
    return argv


def guide_pngs(fmt: str | None, work: Path) -> tuple[Path, Path, Path]:
    """The source photo, its label map and the frame's detailed guide as PNGs in the label
    map's colours (bench_photos' guide images), from a run of the graph into ``work``."""
    from proxyshade.graph.graph import Graph
    from proxyshade.io.images import write_png
    from proxyshade.kernels.display import id_palette

    g = Graph.load(GRAPH, cache=work / "cache", variables={"out": str(work / "out"), **({"format": fmt} if fmt else {})})
    src, guide = g.value("src", 1), g.value("guide", 1)
    table = src.meta["labels"]
    a, b = work / "src_labels.png", work / "tgt_labels.png"
    write_png(a, id_palette(src["label.id"], table))
    write_png(b, id_palette(guide["label.id"], table))
    return Path(src.meta["source"]["image"]), a, b


def compile_bytecode(checkout: Path) -> None:
    """The package's bytecode written beside its sources (``__pycache__``), as ``pip install``
    does for a user: where ``PYTHONDONTWRITEBYTECODE`` is set (as on the project's shared
    machine) a checkout's runs would otherwise compile its ~80 modules from source, every
    run (0.15-0.25 CPU s on the command's serial path)."""
    import compileall

    compileall.compile_dir(str(checkout / "proxyshade"), quiet=1)


def med(rows: list[dict], k: str) -> float:
    return statistics.median(r[k] for r in rows)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--format", default=None, help="a delivery format (hd, 4k, ...); default 1024 wide")
    ap.add_argument("--ebsynth", type=Path, help="EbSynth's binary (built from ../shared/peers/ebsynth)")
    ap.add_argument("--ebsynth-4k", action="store_true", help="run EbSynth above 1024 wide too")
    ap.add_argument("--baseline", type=Path, help="another checkout (e.g. main) run beside this one")
    ap.add_argument("--baseline-kernels", type=Path, help="the baseline's NUMBA_CACHE_DIR (default: a folder of "
                    "its own in the temporary directory)")
    ap.add_argument("--no-profile", action="store_true")
    ap.add_argument("--guide-pngs", type=Path, help=argparse.SUPPRESS)  # the child that makes them
    args = ap.parse_args(argv)
    if args.guide_pngs:
        print(guide_pngs(args.format, args.guide_pngs)[0])
        return

    work = Path(tempfile.mkdtemp(prefix="bench_cli_"))
    try:
        print(f"# bench_cli: proxyshade run {GRAPH.name} --frames 1 ({args.format or '1024 wide'}), fresh plate "
              f"cache, warm kernel cache; {args.rounds} interleaved rounds; load {os.getloadavg()[0]:.1f} "
              f"({os.cpu_count()} cores)")
        # the kernels compiled and the guide made, untimed, in a child: a child forked from a
        # process holding the graph's plates and kernels would report that process's resident
        # set as its own peak (Linux carries the high-water mark over fork and exec)
        compile_bytecode(ROOT)
        if args.baseline:
            compile_bytecode(args.baseline.resolve())
        made = subprocess.run([sys.executable, __file__, "--guide-pngs", str(work),
                               *(["--format", args.format] if args.format else [])],
                              check=True, capture_output=True, text=True)
        photo, g_src, g_tgt = Path(made.stdout.strip().splitlines()[-1]), work / "src_labels.png", work / "tgt_labels.png"
        cmds = {"proxyshade": lambda c, o: child(proxyshade_argv(args.format, c, o))}
        child(proxyshade_argv(args.format, work / "warm", work / "o"))  # every kernel it calls compiled, untimed
        base_env = None
        if args.baseline:
            # its own kernel cache: numba's index is stamped with the source file's mtime, so
            # checkouts of one kernels version sharing a folder would compile it again in turn
            env = base_env = dict(os.environ, PYTHONPATH=str(args.baseline.resolve()),
                       NUMBA_CACHE_DIR=str(args.baseline_kernels
                                           or Path(tempfile.gettempdir(), f"bench_cli_numba_{os.getuid()}")))
            base_graph = args.baseline.resolve() / "graphs" / GRAPH.name
            child(proxyshade_argv(args.format, work / "warm_base", work / "o", graph=base_graph), env)  # compiled, untimed
            cmds["baseline"] = lambda c, o: child(proxyshade_argv(args.format, c, o, graph=base_graph), env)
        if args.ebsynth and (args.ebsynth_4k or not args.format):
            cmds["ebsynth"] = lambda c, o: child([str(args.ebsynth), "-style", str(photo), "-guide", str(g_src),
                                                  str(g_tgt), "-patchsize", "3", "-uniformity", "1000",
                                                  "-output", str(o) + ".png"])
        rows: dict[str, list[dict]] = {k: [] for k in cmds}
        for r in range(args.rounds):
            for name, fn in cmds.items():
                cache, out = work / f"c_{name}_{r}", work / f"o_{name}_{r}"
                rows[name].append(fn(cache, out))
                shutil.rmtree(cache, ignore_errors=True)
        # the peak's median and its largest round: a bar on memory holds in every round (a cache
        # write that lags behind the nodes in some rounds only holds its plate longer)
        print(f"{'command':<12} {'wall med':>9} {'min':>7} {'max':>7} {'CPU s':>7} {'peak RSS':>9} {'max':>9}")
        for name, rs in rows.items():
            print(f"{name:<12} {med(rs, 'wall'):9.2f} {min(r['wall'] for r in rs):7.2f} "
                  f"{max(r['wall'] for r in rs):7.2f} {med(rs, 'cpu'):7.2f} {med(rs, 'rss'):5.0f} MiB "
                  f"{max(r['rss'] for r in rs):5.0f} MiB")
        p = rows["proxyshade"]
        for name in rows:
            if name != "proxyshade":
                print(f"{name} / proxyshade: wall {med(rows[name], 'wall') / med(p, 'wall'):.2f}x, CPU "
                      f"{med(rows[name], 'cpu') / med(p, 'cpu'):.2f}x, peak RSS "
                      f"{med(rows[name], 'rss') / med(p, 'rss'):.2f}x")
        print(f"load after: {os.getloadavg()[0]:.1f}")
        if not args.no_profile:
            for name, env in [("proxyshade", None)] + ([("baseline", base_env)] if args.baseline else []):
                try:
                    res = child(proxyshade_argv(args.format, work / f"c_profile_{name}", work / f"o_profile_{name}",
                                                ["--profile"]), env)
                except SystemExit:  # a baseline without --profile
                    continue
                print(f"# {name} --profile")
                print(res["out"][res["out"].index("profile ("):].rstrip())
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
