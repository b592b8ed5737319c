"""Production formats: the first frame (graphs/first_frame.yaml, lake from renoir) at
growing sizes, each in its own process (so peak RSS is that size's): wall time of a
forced run after a warm-up, peak RSS, and the repetition measure of the result (share of
the output drawn from the most-used 1% of source pixels, ``kernels.quality.repetition``),
relative to 1024²; ``floor``: the part of it the framing alone gives (the measure when every
label's source pixels are used evenly: a wide frame shows more of a small source label),
``per label``: the measure label by label, area-weighted (``kernels.quality.label_repetition``:
how unevenly each label's own source pixels are used). ``CPU s``: the run's CPU time (user + system, every thread of the
process), steadier than the wall time on a shared machine; ``--nodes``: each node's wall. Bars (issue: production formats): HD <= 6 s, 4K <= 20 s, RSS at 4K
<= 6 GB, repetition at HD and 4K within 1.5x of 1024²'s.

``photo rep``: with hybrid variants (``--set src.variants=N``: the source widened by N hybrids of
itself, by default of even label shares, ``--set src.variant_labels=photo`` for whole-photo ones;
docs/hybrids.md) the repetition counted on the photo's own pixels (each variant pixel mapped
back to the photo pixel it copies); without, the repetition. ``rep / floor``: the repetition over
its framing floor (how much more unevenly than the framing forces the source is used; it does not
move with the framing, so compares sizes fairly).

Run: ``python bench/run.py formats`` (``--sizes 512x512 1024x1024 hd uhd 4k``, ``--set src.variants=2``).
``--crops``: docs/img/hybrids_variants_4k.jpg, the 4K frame's 512² crop holding the most water,
from the photo alone (left) and with ``src.variants=2`` (right).
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BARS = {"hd": 6.0, "4k": 20.0}

_CHILD = r"""
import json, resource, sys, tempfile, time
sys.path.insert(0, {root!r})
from proxyshade import Graph
from proxyshade.io.source import load_source
from proxyshade.kernels.quality import label_repetition, repetition
size = {size!r}
over = ["preview.enabled=false", "proxy_labels.enabled=false", "detail_labels.enabled=false", *{sets!r}]
var = {{"out": tempfile.mkdtemp()}}
if "x" in size:
    w, h = size.split("x")
    over.append(f"proxy.resolution=[{{w}},{{h}}]")
else:
    var["format"] = size
with tempfile.TemporaryDirectory() as cache:
    g = Graph.load({graph!r}, cache=cache, overrides=over, variables=var)
    g.run([1])  # warm-up: JIT and cache
    walls, cpus = [], []
    nodes = {{}}
    for _ in range({repeat}):
        t, c = time.perf_counter(), resource.getrusage(resource.RUSAGE_SELF)
        rep_ = g.run([1], force=tuple(g.nodes))
        walls.append(time.perf_counter() - t)
        c2 = resource.getrusage(resource.RUSAGE_SELF)
        cpus.append(c2.ru_utime + c2.ru_stime - c.ru_utime - c.ru_stime)
        for r in rep_.runs:
            if r.status == "computed":
                nodes.setdefault(r.node, []).append(r.seconds)
        # after the last node: the cache's background writes (flush) and the engine's own work
        nodes.setdefault("(rest)", []).append(walls[-1] - sum(r.seconds for r in rep_.runs if r.status == "computed"))
    plate = g.value("final", 1)
    src = g.value("src", 1)  # the source as the graph read it (with src.variants: widened)
    rep = repetition(plate["source.x"], plate["source.y"], src.shape)
    lrep, floor = label_repetition(plate["source.x"], plate["source.y"], plate["label.id"], src["label.id"])
    photo_rep = rep
    if "origin.x" in src:  # hybrid variants: the photo pixel each source pixel copies
        import numpy as np
        r = np.clip(np.rint(plate["source.y"]), 0, src.shape[0] - 1).astype(int)
        c = np.clip(np.rint(plate["source.x"]), 0, src.shape[1] - 1).astype(int)
        photo = load_source({source!r})
        photo_rep = repetition(src["origin.x"][r, c], src["origin.y"][r, c], photo.shape)
walls.sort()
cpus.sort()
nodes = {{k: sorted(v)[len(v) // 2] for k, v in nodes.items()}}
print(json.dumps({{"size": size, "shape": list(plate.shape), "wall": walls[len(walls) // 2], "cpu": cpus[len(cpus) // 2], "nodes": nodes,
                  "rss_gb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2 ** 20, "repetition": rep,
                  "label_repetition": lrep, "floor": floor, "photo_repetition": photo_rep}}))
"""


def measure(size: str, repeat: int, sets=()) -> dict:
    code = _CHILD.format(root=str(ROOT), size=size, repeat=repeat, sets=list(sets),
                         graph=str(ROOT / "graphs" / "first_frame.yaml"),
                         source=str(ROOT / "samples" / "renoir" / "source.yaml"))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def crops(path: Path, sets=("src.variants=2",)) -> None:
    """The 4K first frame's 512² crop (on a 64 px grid) holding the most water, without and
    with ``sets``, side by side (a docs figure)."""
    import tempfile

    import numpy as np

    sys.path.insert(0, str(ROOT))
    from harness import write_jpeg
    from proxyshade import Graph

    tiles, at = [], None
    for extra in ((), tuple(sets)):
        over = ["preview.enabled=false", "proxy_labels.enabled=false", "detail_labels.enabled=false", *extra]
        with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as out:
            g = Graph.load(ROOT / "graphs" / "first_frame.yaml", cache=cache, overrides=over,
                           variables={"out": out, "format": "4k"})
            g.run([1])
            plate = g.value("final", 1)
        if at is None:
            water = next(int(t["id"]) for t in plate.meta["labels"] if t["name"] == "water")
            sat = np.pad(np.cumsum(np.cumsum(plate["label.id"] == water, 0), 1), ((1, 0), (1, 0)))
            c = sat[512::64, 512::64] - sat[:-512:64, 512::64] - sat[512::64, :-512:64] + sat[:-512:64, :-512:64]
            k = int(np.argmax(c))
            at = (k // c.shape[1] * 64, k % c.shape[1] * 64)
        y, x = at
        tiles.append(np.pad(plate.rgb()[y:y + 512, x:x + 512], ((0, 0), (0, 4), (0, 0)), constant_values=1.0))
    write_jpeg(path, np.concatenate(tiles, 1)[:, :-4], quality=85)
    print(f"wrote {path} (crop at row {at[0]}, column {at[1]})")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", nargs="*", default=["512x512", "1024x1024", "hd", "uhd", "4k"])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--nodes", action="store_true",
                    help="also print each node's median wall time (and '(rest)': the run's wall less its nodes', "
                         "mostly waiting for the cache's background writes)")
    ap.add_argument("--set", action="append", default=[], metavar="NODE.PARAM=VALUE",
                    help="a graph override, e.g. src.variants=2 (hybrid variants widen the source, docs/hybrids.md)")
    ap.add_argument("--crops", action="store_true", help="write docs/img/hybrids_variants_4k.jpg (4K, without and "
                                                        "with --set, default src.variants=2) and stop")
    args = ap.parse_args(sys.argv[2:] if argv is None and len(sys.argv) > 1 and sys.argv[1] == "formats" else argv)
    if args.crops:
        return crops(ROOT / "docs" / "img" / "hybrids_variants_4k.jpg", args.set or ("src.variants=2",))
    rows = [measure(s, args.repeat, args.set) for s in args.sizes]
    ref = next((r for r in rows if r["size"] == "1024x1024"), rows[0])
    print(f"{'size':>10} {'pixels':>10} {'first frame s':>14} {'CPU s':>7} {'s/Mpx':>7} {'peak RSS GB':>12} "
          f"{'repetition':>11} {'vs 1024²':>9} {'floor':>7} {'vs':>5} {'per label':>10} {'vs':>5} {'bar s':>6}"
          f" {'photo rep':>10} {'vs':>5} {'rep / floor':>11} {'vs':>5}")
    for r in rows:
        h, w = r["shape"]
        mp = w * h / 1e6
        print(f"{w}x{h:<5} {w * h:>10} {r['wall']:>14.2f} {r['cpu']:>7.2f} {r['wall'] / mp:>7.2f} {r['rss_gb']:>12.2f} "
              f"{r['repetition']:>11.4f} {r['repetition'] / ref['repetition']:>9.2f} {r['floor']:>7.4f} "
              f"{r['floor'] / ref['floor']:>5.2f} {r['label_repetition']:>10.4f} "
              f"{r['label_repetition'] / ref['label_repetition']:>5.2f} {BARS.get(r['size'], float('nan')):>6.1f}"
              f" {r['photo_repetition']:>10.4f} {r['photo_repetition'] / ref['photo_repetition']:>5.2f}"
              f" {r['repetition'] / r['floor']:>11.2f} {r['repetition'] / r['floor'] / (ref['repetition'] / ref['floor']):>5.2f}")
    if args.nodes:
        names = list(dict.fromkeys(n for r in rows for n in r["nodes"]))
        print(f"{'node s':>10} " + " ".join(f"{r['size']:>10}" for r in rows))
        for n in names:
            print(f"{n:>10} " + " ".join(f"{r['nodes'].get(n, float('nan')):>10.2f}" for r in rows))


if __name__ == "__main__":
    main()
