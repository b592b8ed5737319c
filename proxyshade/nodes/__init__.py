"""Node types, one module per pipeline stage, named after its type in snake case
(``ProxyRender`` in ``proxy_render.py``). A type is imported (and so registered) when a
graph names it (``node_type``, the engine's ``graph.node.find_type`` on this package), so a
run imports only the nodes it uses; ``load_all`` registers every one (``proxyshade nodes``,
tests)."""
from proxyshade.graph.node import find_type as node_type  # noqa: F401
from proxyshade.graph.node import load_all  # noqa: F401
