"""The layer table of docs/engine.md, read from every import statement of the package (module
level and inside functions, absolute and relative): each layer imports only the ones below it."""
from __future__ import annotations

import ast
from pathlib import Path

import proxyshade
from proxyshade.graph import keys

ROOT = Path(proxyshade.__file__).parent
BASE = {"errors", "plate", "declare"}  # shared by every layer: exceptions, plates, Input/Param declarations
ALLOWED = {  # layer -> the layers (top-level names under proxyshade/) its modules may import
    "errors": set(),
    "plate": {"errors"},
    "declare": {"errors", "plate"},
    "io": {"io"} | BASE,
    "kernels": {"kernels", "io"} | BASE,
    "synthesis": {"synthesis", "kernels", "io"} | BASE,
    "graph": {"graph", "kernels", "io"} | BASE,
}


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(path: Path, name: str | None = None) -> list[tuple[int, str]]:
    """(line, module) of every import of a proxyshade module in ``path`` (the module ``name``):
    for ``from X import name``, X.name where that is a module, else X."""
    name = name or module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(up + ([node.module] if node.module else []))
            for a in node.names:
                sub = f"{base}.{a.name}"
                out.append((node.lineno, sub if keys.module_file(sub) is not None else base))
    return [(line, m) for line, m in out if m == "proxyshade" or m.startswith("proxyshade.")]


def layer(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def test_every_layer_imports_only_the_layers_below_it():
    wrong = []
    for path in sorted(ROOT.rglob("*.py")):
        me = layer(module_name(path))
        if me not in ALLOWED:
            continue  # nodes (checked in tests/graph/test_keys.py: no node imports another), cli, scene
        for line, m in imports(path):
            if layer(m) not in ALLOWED[me]:
                wrong.append(f"{path.relative_to(ROOT.parent)}:{line}: {me} imports {m}")
    assert not wrong, "\n".join(wrong)


def test_the_check_sees_function_level_and_relative_imports(tmp_path):
    p = tmp_path / "probe.py"
    p.write_text("def f():\n    from ..graph import graph\n    import proxyshade.nodes.magnify\n")
    found = [m for _, m in imports(p, "proxyshade.synthesis.probe")]
    assert found == ["proxyshade.graph.graph", "proxyshade.nodes.magnify"]


def test_no_kernel_inlines_code_outside_the_kernels_package():
    # the compiled kernels' cache is keyed by the kernels package alone (kernels/_cache.py):
    # io, the one layer below it, has no jitted function a kernel could inline
    for path in sorted((ROOT / "io").rglob("*.py")):
        tree = ast.parse(path.read_text())
        names = {a.name.split(".")[0] for n in ast.walk(tree) if isinstance(n, (ast.Import, ast.ImportFrom))
                 for a in (n.names if isinstance(n, ast.Import) else [ast.alias(n.module or "")])}
        assert "numba" not in names, path


def test_temporal_synthesis_reads_cameras_without_usd():
    for module in ("proxyshade.synthesis.temporal", "proxyshade.synthesis.depth"):
        keys.import_closure.cache_clear()
        assert "proxyshade.io.usd" not in keys.import_closure(module), module
