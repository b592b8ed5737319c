"""The directed graphs the engine builds: instances (node, frame) and what they wait for.

``DAG`` is the part of networkx's ``DiGraph`` the engine uses (vertices with attributes,
edges with attributes, predecessors and successors in insertion order), and
``topological_order`` and ``find_cycle`` the two algorithms it runs on them, written out
here: importing networkx held 12 MiB of the command's resident memory for those few lines.
``topological_order`` is networkx's ``lexicographical_topological_sort`` step for step
(ready vertices by ``key``, ties by insertion order), so runs keep their order.
"""
from __future__ import annotations

import heapq
from typing import Callable, Hashable, Iterable, Iterator


class CycleFound(ValueError):
    """The graph has a cycle (``topological_order``)."""


class DAG:
    """Vertices (any hashable) with attribute dicts (``dag.nodes[v]``) and directed edges
    with attribute dicts; iteration, ``len`` and ``in`` are over vertices, in the order
    they were added."""

    def __init__(self, edges: Iterable[tuple[Hashable, Hashable]] = ()):
        self.nodes: dict[Hashable, dict] = {}
        self._succ: dict[Hashable, dict[Hashable, dict]] = {}
        self._pred: dict[Hashable, dict[Hashable, dict]] = {}
        self.add_edges_from(edges)

    def add_node(self, v: Hashable, **attrs) -> None:
        if v not in self.nodes:
            self.nodes[v] = {}
            self._succ[v] = {}
            self._pred[v] = {}
        self.nodes[v].update(attrs)

    def add_edge(self, u: Hashable, v: Hashable, **attrs) -> None:
        self.add_node(u)
        self.add_node(v)
        data = self._succ[u].get(v)
        if data is None:
            data = self._succ[u][v] = self._pred[v][u] = {}
        data.update(attrs)

    def add_edges_from(self, edges: Iterable[tuple[Hashable, Hashable]]) -> None:
        for u, v in edges:
            self.add_edge(u, v)

    def remove_node(self, v: Hashable) -> None:
        for s in self._succ.pop(v):
            del self._pred[s][v]
        for p in self._pred.pop(v):
            del self._succ[p][v]
        del self.nodes[v]

    def get_edge_data(self, u: Hashable, v: Hashable, default=None):
        return self._succ.get(u, {}).get(v, default)

    def has_edge(self, u: Hashable, v: Hashable) -> bool:
        return v in self._succ.get(u, {})

    def predecessors(self, v: Hashable) -> Iterator[Hashable]:
        return iter(self._pred[v])

    def successors(self, v: Hashable) -> Iterator[Hashable]:
        return iter(self._succ[v])

    def in_degree(self, v: Hashable) -> int:
        return len(self._pred[v])

    def out_degree(self, v: Hashable) -> int:
        return len(self._succ[v])

    @property
    def edges(self) -> list[tuple[Hashable, Hashable]]:
        return [(u, v) for u, succ in self._succ.items() for v in succ]

    def __iter__(self) -> Iterator[Hashable]:
        return iter(self.nodes)

    def __len__(self) -> int:
        return len(self.nodes)

    def __contains__(self, v) -> bool:
        return v in self.nodes


def topological_order(dag: DAG, key: Callable[[Hashable], object] = str) -> Iterator[Hashable]:
    """Every vertex after its predecessors; among those ready, the smallest ``key`` first,
    ties in insertion order (networkx's ``lexicographical_topological_sort``). Raises
    ``CycleFound`` once no vertex is ready and some are left."""
    index = {v: i for i, v in enumerate(dag)}
    waiting = {v: dag.in_degree(v) for v in dag if dag.in_degree(v)}
    ready = [(key(v), index[v], v) for v in dag if not dag.in_degree(v)]
    heapq.heapify(ready)
    while ready:
        _, _, v = heapq.heappop(ready)
        for s in dag.successors(v):
            waiting[s] -= 1
            if not waiting[s]:
                del waiting[s]
                heapq.heappush(ready, (key(s), index[s], s))
        yield v
    if waiting:
        raise CycleFound("the graph has a cycle")


def find_cycle(dag: DAG) -> list[tuple[Hashable, Hashable]] | None:
    """The edges of one cycle, in order (the last edge returns to the first vertex), or None:
    a depth-first search from each vertex in insertion order."""
    state: dict[Hashable, int] = {}  # 1: on the current path, 2: done
    for root in dag:
        if root in state:
            continue
        path = [root]
        state[root] = 1
        stack = [iter(dag.successors(root))]
        while stack:
            for s in stack[-1]:
                if state.get(s) == 1:
                    loop = path[path.index(s):] + [s]
                    return list(zip(loop, loop[1:]))
                if s not in state:
                    state[s] = 1
                    path.append(s)
                    stack.append(iter(dag.successors(s)))
                    break
            else:
                state[path.pop()] = 2
                stack.pop()
    return None
