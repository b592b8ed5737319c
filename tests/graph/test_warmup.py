"""The kernels' precompile (proxyshade/graph/warmup.py): the manifest lists what the demo's
first frame reaches, a precompiled kernel loads from numba's cache in another process
(parallel ones included), and a stale entry only costs a lazy compile."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from proxyshade.graph import warmup
from proxyshade.kernels import _cache

ROOT = Path(__file__).resolve().parents[2]


REACH = r"""
import json, sys
import proxyshade.kernels  # noqa: F401
from proxyshade.graph import warmup
from proxyshade.graph.graph import Graph

def sigs():
    return {(f"proxyshade.kernels.{k}", warmup.type_text(s)) for k, d in warmup.kernel_dispatchers().items()
            for s in d.signatures}

g = Graph.load(sys.argv[1], cache=sys.argv[2],
               overrides=["proxy.resolution=[96,64]", "guide.size=64", "guide.start=16", "preview.enabled=false",
                          "proxy_labels.enabled=false", "detail_labels.enabled=false"],
               variables={"out": sys.argv[3], "scene": "lake", "source": "renoir"})
before = sigs()
g.run([1])
print(json.dumps({"reached": sorted(sigs() - before), "modules": sorted(warmup.manifest_modules(g))}))
"""


def test_the_manifest_covers_what_a_small_first_frame_reaches(tmp_path):
    """Every kernel signature a small lake first frame compiles or loads (in a fresh process,
    so earlier tests' kernels do not hide it) is in the manifest (called from Python, or
    compiled inside one that is): a stale manifest fails here."""
    r = subprocess.run([sys.executable, "-c", REACH, str(ROOT / "graphs" / "first_frame.yaml"), str(tmp_path / "cache"),
                        str(tmp_path / "out")], capture_output=True, text=True, timeout=600,
                       env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert r.returncode == 0, r.stderr
    got = json.loads(r.stdout.strip().splitlines()[-1])
    reached = {tuple(x) for x in got["reached"]}
    assert len(reached) > 20  # the run called kernels (compiled, or loaded from numba's cache)
    listed = set()
    for kernel, text, _, inner in warmup.manifest():
        listed.add((kernel, text))
        listed.update(inner)
    for kernel, _ in listed:  # each listed kernel exists
        assert warmup._dispatcher(kernel).py_func.__module__ == kernel.rpartition(".")[0]
    missing = reached - listed
    assert not missing, f"regenerate: python -m proxyshade.graph.warmup --write-manifest; missing {sorted(missing)}"
    # the graph's precompile units (its node types) cover every kernel it reached
    units, found, covered = set(got["modules"]), warmup.callers(), set()
    for kernel, text, _, inner in warmup.manifest():
        if set(warmup._units(kernel, text, found)) & units:
            covered.add((kernel, text))
            covered.update(inner)
    assert not reached - covered, sorted(reached - covered)


CHILD = r"""
import json, sys
from numba.core import event
from proxyshade.graph import warmup
from proxyshade.kernels import random

compiled = []

class Rec(event.Listener):
    def on_start(self, ev):
        compiled.append(ev.data["dispatcher"].py_func.__name__)
    def on_end(self, ev):
        pass

event.register("numba:compile", Rec())
if sys.argv[1] == "precompile":
    r = warmup.precompile(progress=None, workers=2)
    print(json.dumps({"compiled": r["compiled"], "failed": r["failed"], "workers": r["workers"]}))
else:
    pending = warmup.pending()
    import numpy as np
    ids = np.arange(12, dtype=np.uint32).reshape(3, 4)
    out = random.uniform_field(7, ids)
    print(json.dumps({"pending": len(pending), "compiled": list(compiled), "hits": sum(random.uniform_field.stats.cache_hits.values()),
                      "ok": bool((out == np.array([[random.uniform(7, int(i), 0, 0) for i in r] for r in ids],
                                                  np.float32)).all())}))
"""


def test_precompiled_kernels_load_from_numbas_cache_in_another_process(tmp_path, monkeypatch):
    """Two worker processes compile a manifest (a parallel kernel and the serial kernels it
    calls) into a fresh numba cache; a later process calls the kernel and compiles nothing."""
    sig = "(int64, Array(uint32, 2, 'C', False, aligned=True))"
    manifest = tmp_path / "m"
    manifest.mkdir()
    (manifest / "kernel_manifest.py").write_text(
        "ENTRIES = [('proxyshade.kernels.random.uniform_field', %r, 1.0, ()),"
        " ('proxyshade.kernels.random._keys', '(int64, int64)', 0.5, ())]\n" % sig)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "numba"),
               PYTHONPATH=os.pathsep.join([str(manifest), str(ROOT)]))
    code = CHILD.replace("from proxyshade.graph import warmup",
                         "from proxyshade.graph import warmup\nimport kernel_manifest\n"
                         "warmup.manifest = lambda: list(kernel_manifest.ENTRIES)")

    def child(mode):
        r = subprocess.run([sys.executable, "-c", code, mode], env=env, capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr
        return json.loads(r.stdout.strip().splitlines()[-1])

    pre = child("precompile")
    assert pre == {"compiled": 2, "failed": [], "workers": 2}
    run = child("run")
    assert run["pending"] == 0  # all in the cache now
    assert run["compiled"] == [] and run["hits"] == 1 and run["ok"]


def test_a_stale_manifest_entry_is_left_to_a_lazy_compile(monkeypatch):
    """An entry naming a kernel that is gone is skipped; one whose types no longer compile
    is reported as failed, never raised."""
    monkeypatch.setattr(warmup, "manifest", lambda: [
        ("proxyshade.kernels.random.gone", "(int64,)", 1.0, ()),
        ("proxyshade.kernels.random._mix", "(Array(float32, 3, 'C', False, aligned=True),)", 1.0, ()),
    ])
    monkeypatch.setattr(_cache, "kernels_cached", lambda names=(): False)
    monkeypatch.setattr(_cache, "mark_precompiled", lambda names: None)
    assert [e[0] for e in warmup.pending()] == ["proxyshade.kernels.random._mix"]
    r = warmup.precompile(workers=1)
    assert r["compiled"] == 0 and len(r["failed"]) == 1 and r["failed"][0][0] == "proxyshade.kernels.random._mix"


def test_without_worker_processes_this_process_compiles_everything(monkeypatch):
    """Where no process can be started, precompile compiles in the calling process."""
    import concurrent.futures

    def no_pool(*a, **k):
        raise OSError("no processes here")

    monkeypatch.setattr(concurrent.futures, "ProcessPoolExecutor", no_pool)
    monkeypatch.setattr(warmup, "manifest", lambda: [
        ("proxyshade.kernels.random.uniform_field", "(int64, Array(uint32, 2, 'C', False, aligned=True))", 1.0, ()),
        ("proxyshade.kernels.random._keys", "(int64, int64)", 0.5, ()),
    ])
    monkeypatch.setattr(_cache, "kernels_cached", lambda names=(): False)
    monkeypatch.setattr(_cache, "mark_precompiled", lambda names: None)
    seen = []
    r = warmup.precompile(workers=2, progress=lambda done, total, kernel: seen.append((done, total)))
    assert r["compiled"] == 2 and r["failed"] == [] and r["workers"] == 1
    assert seen == [(0, 2), (1, 2), (2, 2)]


def test_precompile_marks_its_modules_and_later_skips_them(tmp_path, monkeypatch):
    """After a precompile of a module set (even one with nothing to compile) those modules
    are marked in this version's kernel cache: ``pending`` skips them, and a re-run's
    precompile step (``kernels_cached``) reads no numba index, imports no kernel."""
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(warmup, "manifest", lambda: [("proxyshade.kernels.random._keys", "(int64, int64)", 0.5, ())])
    mods = {"proxyshade.kernels.random", "proxyshade.kernels._config"}
    assert not _cache.kernels_cached(sorted(mods))
    assert [e[0] for e in warmup.pending(mods)] == ["proxyshade.kernels.random._keys"]
    r = warmup.precompile(mods, workers=1)
    assert r["compiled"] == 1 and r["failed"] == []
    assert _cache.kernels_cached(sorted(mods)) and warmup.pending(mods) == []
    assert (_cache.folder() / "precompiled" / "proxyshade.kernels.random").is_file()


class _Node:
    def __init__(self, **params):
        self.params = params


class Poisson(_Node):
    pass


class _G:
    def __init__(self, **nodes):
        self.nodes, self.enabled, self.connections = nodes, {n: True for n in nodes}, {n: {} for n in nodes}


def test_a_node_of_a_recorded_variant_precompiles_what_that_variant_called(monkeypatch):
    """Entries are recorded with the node type and variant (parameters, connected inputs)
    that first called them: a node of a recorded variant precompiles its type's entries up
    to the last its variant called (Poisson without layout: not the layout kernels that
    Poisson with layout called later); a node of another variant, every entry of its type."""
    e1 = ("proxyshade.kernels.random._keys", "(int64, int64)", 0.5, ())
    e2 = ("proxyshade.kernels.random._mix", "(uint64,)", 0.5, ())
    plain, layout = _G(final=Poisson(layout=False)), _G(final=Poisson(layout=True))
    v_plain, v_layout = warmup.node_variant(plain, "final"), warmup.node_variant(layout, "final")
    assert v_plain != v_layout and v_plain == warmup.node_variant(_G(final=Poisson(layout=False)), "final")
    monkeypatch.setattr(warmup, "manifest", lambda: [e1, e2])
    monkeypatch.setattr(warmup, "callers", lambda: {e1[:2]: "Poisson", e2[:2]: "Poisson"})
    monkeypatch.setattr(warmup, "variants", lambda: {e1[:2]: v_plain, e2[:2]: v_layout})
    monkeypatch.setattr(_cache, "kernels_cached", lambda names=(): False)
    assert warmup.manifest_modules(plain) == {f"node.Poisson@{v_plain}"}
    assert [e[0] for e in warmup.pending(warmup.manifest_modules(plain))] == [e1[0]]
    for g in (layout, _G(final=Poisson(layout=True, grain=3.0))):  # the last variant recorded, an unknown one
        assert warmup.manifest_modules(g) == {"node.Poisson"}
        assert sorted(e[0] for e in warmup.pending(warmup.manifest_modules(g))) == sorted([e1[0], e2[0]])


def test_the_first_frame_compiles_no_layout_or_grain_kernel(tmp_path, monkeypatch):
    """The bundled first frame's Poisson (layout: false, grain: 1; the farm's as the lake's:
    Poisson's parameters do not name the scene), and the camera move's first frame solved
    the same way, are variants recorded apart from Poisson with layout and grain on: their
    precompile leaves out the layout and grain kernels that one compiles (the real manifest)."""
    from proxyshade.graph.graph import Graph

    monkeypatch.setattr(_cache, "kernels_cached", lambda names=(): False)

    def pending(name, variables, overrides=()):
        g = Graph.load(ROOT / "graphs" / name, cache=tmp_path / "cache", variables=variables, overrides=overrides)
        return {e[0].rpartition(".")[0].rpartition(".")[2] for e in warmup.pending(warmup.manifest_modules(g))}

    first = pending("first_frame.yaml", {"scene": "farm", "source": "creek", "out": str(tmp_path / "out")})
    assert {"poisson", "multigrid", "raster", "guide"} <= first and not first & {"layout", "grain"}
    assert not pending("camera_move.yaml", {}) & {"layout", "grain"}
    assert {"layout", "grain"} <= pending("camera_move.yaml", {}, ["first.layout=true", "first.grain=2.0"])
