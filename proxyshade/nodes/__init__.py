"""Node types, one module per pipeline stage, named after its type in snake case
(``ProxyRender`` in ``proxy_render.py``). A type is imported (and so registered) when a
graph names it (``node_type``), so a run imports only the nodes it uses; ``load_all``
registers every one (``proxyshade nodes``, tests)."""
import importlib
import importlib.util
import pkgutil
import re


def load_all() -> dict:
    """Import every node module; returns the registry (name -> class)."""
    from proxyshade.graph.node import REGISTRY

    for m in pkgutil.iter_modules(__path__):
        if not m.name.startswith("_"):
            importlib.import_module(f"{__name__}.{m.name}")
    return REGISTRY


def node_type(name: str):
    """The node class registered as ``name`` (its module imported first), or None (then
    every type is registered, for the message listing them)."""
    from proxyshade.graph.node import REGISTRY

    if not isinstance(name, str):
        load_all()
        return None
    if name not in REGISTRY and re.fullmatch(r"[A-Z][A-Za-z0-9]*", name):
        module = re.sub(r"(?<!^)(?=[A-Z])", "_", name).lower()
        if importlib.util.find_spec(f"{__name__}.{module}") is not None:
            importlib.import_module(f"{__name__}.{module}")
    if name not in REGISTRY:
        load_all()  # a type in a module of another name
    return REGISTRY.get(name)
