"""Code hashes: a node's key covers every proxyshade module it runs, and nothing else."""
from __future__ import annotations

import modulefinder
import shutil
import sys
from pathlib import Path

import pytest

import proxyshade
import proxyshade.nodes
from proxyshade.graph import keys
from proxyshade.graph.node import REGISTRY

PKG = Path(proxyshade.__file__).parent
proxyshade.nodes.load_all()  # registers every node type


@pytest.fixture
def copy(tmp_path):
    """A copy of the package to edit; code hashes read from it."""
    shutil.copytree(PKG, tmp_path / "proxyshade", ignore=shutil.ignore_patterns("__pycache__"))
    yield tmp_path
    keys.module_hash.cache_clear()
    keys.import_closure.cache_clear()


def hashes(root) -> dict[str, str]:
    keys.module_hash.cache_clear()
    keys.import_closure.cache_clear()
    return {name: keys.code_hash(cls, root) for name, cls in REGISTRY.items()}


def edit(root: Path, module: str, text: str) -> None:
    path = root / (module.replace(".", "/") + ".py")
    path.write_text(path.read_text() + text)


@pytest.mark.parametrize("module, changed, unchanged", [
    # io behind a node (the USD reader behind ProxyRender)
    ("proxyshade.io.usd", {"ProxyRender", "CgRender", "ShadowMap"},
     {"Fog", "SourceRead", "PatchInit", "Poisson", "ConsistentDepth", "Reproject", "DepthExtend"}),
    # the camera a temporal node reads from a plate: io.camera, not the USD reader
    ("proxyshade.io.camera", {"ProxyRender", "ConsistentDepth", "Reproject", "DepthExtend"},
     {"Fog", "SourceRead", "PatchInit", "Poisson"}),
    # a kernel imported only inside a function (kernels/poisson.py -> lookup)
    ("proxyshade.kernels.lookup", {"Poisson", "Magnify", "Resynthesize", "Reproject"}, {"Fog", "ProxyRender"}),
    # the synthesis layer
    ("proxyshade.synthesis.patches", {"PatchInit", "Correct", "Magnify", "Resynthesize"},
     {"Reproject", "ConsistentDepth", "ProxyRender", "Fog", "GuideSynth"}),
    # a kernel two imports deep (patch -> features -> distance)
    ("proxyshade.kernels.distance", {"PatchInit", "GuideSynth", "Poisson"}, {"Fog", "ProxyRender", "ExrWrite"}),
])
def test_editing_a_module_changes_exactly_the_keys_of_nodes_that_run_it(copy, module, changed, unchanged):
    before = hashes(copy)
    edit(copy, module, "\n\ndef _an_edit():\n    return 1\n")
    after = hashes(copy)
    moved = {n for n in before if before[n] != after[n]}
    assert changed <= moved
    assert not (unchanged & moved)
    # and exactly the nodes whose import closure holds the module
    assert moved == {n for n, cls in REGISTRY.items() if module in keys.import_closure(cls.__module__, copy)}


def test_a_comment_does_not_change_a_key(copy):
    before = hashes(copy)
    edit(copy, "proxyshade.kernels.lookup", "\n# a comment\n")
    assert hashes(copy) == before


def test_function_level_imports_are_followed(copy):
    (copy / "proxyshade" / "kernels" / "_later.py").write_text("X = 1\n")
    edit(copy, "proxyshade.kernels.fog", "\n\ndef _f():\n    from proxyshade.kernels import _later\n    return _later.X\n")
    keys.import_closure.cache_clear()
    assert "proxyshade.kernels._later" in keys.import_closure("proxyshade.nodes.fog", copy)


class _Finder(modulefinder.ModuleFinder):
    """The standard library's module finder (it reads imports at every level from the
    byte code), limited to proxyshade modules."""

    def import_hook(self, name, caller=None, fromlist=None, level=-1):
        if level <= 0 and not name.startswith("proxyshade"):
            return None
        return super().import_hook(name, caller, fromlist, level)


def _found(path: str) -> set[str]:
    f = _Finder(path=sys.path)
    f.run_script(path)
    return {m for m in f.modules if m.startswith("proxyshade")}


def test_import_closure_holds_every_module_the_standard_finder_finds():
    """Independent reference: modulefinder. What it finds only through package
    ``__init__`` modules (the engine the top-level package exposes lazily) is not code the
    node runs; everything else it finds must be in the node's closure."""
    packages = {m for m in sys.modules if m.startswith("proxyshade") and hasattr(sys.modules[m], "__path__")}
    via_packages = set().union(*(_found(sys.modules[p].__file__) for p in packages)) | packages
    for name, cls in REGISTRY.items():
        mine = set(keys.import_closure(cls.__module__))
        ref = _found(sys.modules[cls.__module__].__file__)
        assert ref - via_packages <= mine, name
        assert mine - {cls.__module__} <= ref, name


def test_no_node_imports_another_node():
    for name, cls in REGISTRY.items():
        others = [m for m in keys.import_closure(cls.__module__)
                  if m.startswith("proxyshade.nodes.") and m != cls.__module__]
        assert not others, f"{name} ({cls.__module__}) imports {others}"


def test_no_circular_import():
    """The import graph of the package's modules (every level) has no cycle."""
    import networkx as nx

    g = nx.DiGraph()
    for path in PKG.rglob("*.py"):
        rel = path.relative_to(PKG.parent).with_suffix("")
        name = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
        src = path.read_text()
        for dep in keys.imported_modules(src, name, rel.name == "__init__"):
            if dep != name:
                g.add_edge(name, dep)
    cycles = list(nx.simple_cycles(g))
    assert not cycles, cycles[:3]


def test_a_memo_is_kept_while_its_files_packages_and_environment_are_unchanged(tmp_path, monkeypatch):
    monkeypatch.setenv("PROXYSHADE_CODE_CACHE", str(tmp_path / "code"))
    monkeypatch.delenv("PROXYSHADE_TEST_VAR", raising=False)
    f = tmp_path / "scene.txt"
    f.write_text("a")
    calls = []

    def compute():
        calls.append(1)
        return f"value of {f.read_text()}", {"files": [f], "packages": ["numpy"], "env": ["PROXYSHADE_TEST_VAR"]}

    assert keys.memo(["what", 1], compute) == "value of a"
    assert keys.memo(["what", 1], compute) == "value of a" and len(calls) == 1  # kept: not computed again
    assert keys.memo(["what", 2], compute) == "value of a" and len(calls) == 2  # another question
    f.write_text("b")
    assert keys.memo(["what", 1], compute) == "value of b" and len(calls) == 3  # a file changed
    monkeypatch.setenv("PROXYSHADE_TEST_VAR", "x")
    assert keys.memo(["what", 1], compute) == "value of b" and len(calls) == 4  # the environment changed
    f.unlink()
    assert keys.memo(["what", 1], lambda: ("gone", None)) == "gone"  # an error: not kept
    assert keys.memo(["what", 1], lambda: ("again", None)) == "again"


def test_the_proxy_render_key_follows_an_edit_of_a_sublayer_and_loads_no_usd_when_unchanged(tmp_path):
    """ProxyRender's key is the USD data it renders, kept with the hashes of every layer
    the stage used: a sublayer's edit changes the key; an unchanged scene needs no pxr."""
    shutil.copy(Path(proxyshade.__file__).parents[1] / "samples" / "scenes" / "lake.usda", tmp_path / "geo.usda")
    (tmp_path / "shot.usda").write_text('#usda 1.0\n(\n    subLayers = [@./geo.usda@]\n)\n')
    code = ("import sys; from proxyshade.graph.graph import Graph; "
            f"g = Graph.load({str(PKG.parent / 'graphs' / 'first_frame.yaml')!r}, cache=sys.argv[1], "
            "variables={'scene': sys.argv[2]}); "
            "print(g.plan([1]).keys[('proxy', 1)], 'pxr' in sys.modules)")
    env = {**__import__("os").environ, "PROXYSHADE_CODE_CACHE": str(tmp_path / "code"), "PYTHONPATH": str(PKG.parent)}

    def key():
        import subprocess

        r = subprocess.run([sys.executable, "-c", code, str(tmp_path / "cache"), str(tmp_path / "shot.usda")],
                           capture_output=True, text=True, env=env, timeout=120)
        assert r.returncode == 0, r.stderr
        k, loaded = r.stdout.split()
        return k, loaded == "True"

    first = key()
    assert first[1]  # the first key reads the scene
    assert key() == (first[0], False)  # unchanged: the same key, USD not loaded
    with open(tmp_path / "geo.usda", "a") as f:
        f.write('\ndef Sphere "added"\n{\n    double radius = 3\n}\n')
    edited = key()
    assert edited[0] != first[0] and edited[1]


def test_the_code_facts_file_keeps_only_this_checkouts_existing_files(tmp_path):
    """The facts a cached run reads first stay small: another root's files (a test's copy
    of the package) are not written to it, and a deleted file is dropped from it."""
    import json
    import os
    import subprocess

    copy = tmp_path / "copy"
    shutil.copytree(PKG, copy / "proxyshade", ignore=shutil.ignore_patterns("__pycache__"))
    extra = PKG / "kernels" / f"_facts_probe_{os.getpid()}.py"
    code = ("import sys; from pathlib import Path; from proxyshade.graph import keys; "
            "keys.import_closure('proxyshade.nodes.poisson'); "
            "keys.import_closure('proxyshade.nodes.poisson', Path(sys.argv[1])); "
            "keys.module_hash(sys.argv[2]) if sys.argv[2] else None")
    env = {**os.environ, "PROXYSHADE_CODE_CACHE": str(tmp_path / "code"), "PYTHONPATH": str(PKG.parent)}

    def run(probe=""):
        r = subprocess.run([sys.executable, "-c", code, str(copy), probe], capture_output=True, text=True, env=env,
                           timeout=120)
        assert r.returncode == 0, r.stderr
        (facts,) = (tmp_path / "code").glob("code-facts-*.json")
        return json.loads(facts.read_text())

    extra.write_text("X = 1\n")
    try:
        kept = run("proxyshade.kernels." + extra.stem)
    finally:
        extra.unlink()
    own = str(PKG.resolve()) + os.sep
    assert str(PKG.resolve() / "nodes" / "poisson.py") in kept and str(extra.resolve()) in kept
    assert all(k.startswith(own) for k in kept)  # none of the copy's files
    assert str(extra.resolve()) not in run("proxyshade.nodes.correct")  # deleted: dropped when written again


def test_a_library_upgrade_changes_every_key_and_explain_names_it(tmp_path, monkeypatch, registry):
    """numpy, numba, OpenEXR, colour-science and usd-core change results: their installed
    versions are in every node's code version, so an upgrade recomputes (``--explain``
    names the library) and a cache hit never comes from another version."""
    from proxyshade.graph.graph import Graph

    assert set(keys.library_versions()) == {"numpy", "numba", "OpenEXR", "colour-science", "usd-core"}
    assert keys.library_versions()["numpy"] == __import__("numpy").__version__
    g = Graph(graph_dir=tmp_path, cache=tmp_path / "cache")
    g.add("src", "TConst")
    g.add("sum", "TAdd", inputs={"a": "src"})
    before = {n: keys.code_hash(type(g.nodes[n])) for n in g.nodes}
    assert g.run([1]).computed == {"src", "sum"}
    assert g.run([1]).computed == set()
    upgraded = {**keys.library_versions(), "numpy": "9.0"}
    monkeypatch.setattr(keys, "library_versions", lambda: upgraded)
    assert all(keys.code_hash(type(g.nodes[n])) != h for n, h in before.items())
    r = g.run([1])
    assert r.computed == {"src", "sum"}
    assert r.rows("src")[0].reason.startswith(f"new library version (numpy {__import__('numpy').__version__} -> 9.0)")
