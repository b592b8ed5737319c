"""The engine's DAG (proxyshade/graph/dag.py) against networkx, the obvious reference: the
same topological order (runs keep their order), cycles found where there are some, and
the run path never imports networkx."""
from __future__ import annotations

import random
import subprocess
import sys

import networkx as nx
import pytest

from proxyshade.graph.dag import DAG, CycleFound, find_cycle, topological_order


def _pair(seed: int, n: int, p: float, acyclic: bool):
    rng = random.Random(seed)
    names = [(rng.choice("abcxyz") + str(i), rng.randint(1, 3)) for i in range(n)]
    rng.shuffle(names)
    ours, ref = DAG(), nx.DiGraph()
    for v in names:
        first = rng.random() < 0.3
        ours.add_node(v, first=first)
        ref.add_node(v, first=first)
    for i, u in enumerate(names):
        for j, v in enumerate(names):
            if i != j and (i < j or not acyclic) and rng.random() < p:
                ours.add_edge(u, v, inputs=(f"in{j}",))
                ref.add_edge(u, v, inputs=(f"in{j}",))
    return ours, ref


@pytest.mark.parametrize("seed", range(40))
def test_topological_order_is_networkx_lexicographical_order(seed):
    ours, ref = _pair(seed, n=3 + seed % 17, p=0.25, acyclic=True)
    for key in (str, lambda v: (not ref.nodes[v]["first"], str(v))):
        assert list(topological_order(ours, key=key)) == list(nx.lexicographical_topological_sort(ref, key=key))
    for v in ref:
        assert list(ours.predecessors(v)) == list(ref.predecessors(v))
        assert list(ours.successors(v)) == list(ref.successors(v))
        assert ours.in_degree(v) == ref.in_degree(v) and ours.out_degree(v) == ref.out_degree(v)
        assert ours.nodes[v] == ref.nodes[v]
    assert ours.edges == list(ref.edges) and list(ours) == list(ref) and len(ours) == len(ref)
    assert find_cycle(ours) is None


@pytest.mark.parametrize("seed", range(40))
def test_a_cycle_is_found_when_there_is_one(seed):
    ours, ref = _pair(seed, n=2 + seed % 9, p=0.2, acyclic=False)
    cycle = find_cycle(ours)
    if nx.is_directed_acyclic_graph(ref):
        assert cycle is None
        return
    assert cycle and cycle[0][0] == cycle[-1][1]
    assert all(ours.has_edge(u, v) for u, v in cycle)
    assert all(cycle[i][1] == cycle[i + 1][0] for i in range(len(cycle) - 1))
    with pytest.raises(CycleFound):
        list(topological_order(ours))


def test_remove_node_drops_its_edges():
    dag = DAG([("a", "b"), ("b", "c"), ("a", "c")])
    dag.remove_node("b")
    assert list(dag) == ["a", "c"] and dag.edges == [("a", "c")] and dag.in_degree("c") == 1
    assert dag.get_edge_data("a", "b", {}) == {} and "b" not in dag


def test_the_run_path_does_not_import_networkx():
    """The command's engine modules build their DAGs without networkx (12 MiB resident)."""
    code = ("import sys; import proxyshade.cli, proxyshade.graph.graph, proxyshade.graph.executor, "
            "proxyshade.graph.warmup, proxyshade.graph.shots; print('networkx' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False", out.stderr
