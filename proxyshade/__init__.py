"""proxyshade: proxy-guided texture synthesis for rendering natural scenes.

Bonneel, van de Panne, Lefebvre and Drettakis, "Proxy-Guided Texture Synthesis for
Rendering Natural Scenes", INRIA RR-7298, 2010.
"""
__version__ = "0.1.0"


def __getattr__(name):
    if name == "Graph":
        from proxyshade.graph.graph import Graph

        return Graph
    raise AttributeError(name)
