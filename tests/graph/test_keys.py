"""Code hashes: a node's key covers every proxyshade module it runs, and nothing else."""
from __future__ import annotations

import modulefinder
import shutil
import sys
from pathlib import Path

import pytest

import proxyshade
import proxyshade.nodes  # noqa: F401  (registers the node types)
from proxyshade.graph import keys
from proxyshade.graph.node import REGISTRY

PKG = Path(proxyshade.__file__).parent


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
    ("proxyshade.io.usd", {"ProxyRender", "CgRender", "ShadowMap", "ConsistentDepth", "Reproject", "DepthExtend"},
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
