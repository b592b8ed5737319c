"""Parameter groups: each shared parameter declared once, the nodes inherit it."""
import inspect

import proxyshade.nodes
from proxyshade.graph.node import REGISTRY, Param
from proxyshade.synthesis import params as P

proxyshade.nodes.load_all()  # registers every node type
GROUPS = [g for g in vars(P).values() if inspect.isclass(g) and issubclass(g, P.ParamGroup) and g is not P.ParamGroup]


def test_nodes_share_the_group_declarations_and_never_redeclare_them():
    used = set()
    for node, cls in REGISTRY.items():
        for g in (b for b in cls.__mro__ if b in GROUPS):
            for name in g.names():
                assert cls.params_spec[name] is getattr(g, name), (node, name)  # the group's own declaration
                used.add(g)
        # a node's own parameter with a group parameter's name, default and doc is a copy of it
        own = {k: v for k, v in vars(cls).items() if isinstance(v, Param)}
        for g in GROUPS:
            for name in set(own) & set(g.names()):
                theirs = getattr(g, name)
                assert (own[name].default, own[name].doc) != (theirs.default, theirs.doc), (node, name, g.__name__)
    assert used == set(GROUPS)  # every group serves a node


def test_of_and_defaults_read_a_groups_values():
    class NS:
        pass

    ns = NS()
    for name in P.Correction.names():
        setattr(ns, name, f"v-{name}")
    got = P.Correction.of(ns)
    assert vars(got) == {n: f"v-{n}" for n in P.Correction.names()}
    assert {"w", "max_distance", "k", "passes"} <= set(vars(got))  # PatchMetric's too
    assert P.FloodFill.defaults().w == P.PatchMetric.w.default == 90.0
