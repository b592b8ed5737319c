"""Helpers for tests: run one node's compute on plates, without a graph or a cache."""
from __future__ import annotations

from pathlib import Path

from proxyshade.errors import UserError
from proxyshade.graph.node import REGISTRY, Context, Node, PlateSequence, find_type
from proxyshade.graph.plate import Plate


def run_node(node_type: str | type[Node], params: dict | None = None, inputs: dict[str, Plate | None] | None = None,
             *, frame: int = 1, first_frame: int = 1, graph_dir: str | Path = ".", threads: int = 0,
             name: str = "node", notes: list[str] | None = None) -> Plate:
    """Validate ``params``, build the node and return ``compute``'s plate for ``frame``
    (``notes``: a list the node's notes, ``ctx.note``, are appended to).

    A sequence input takes a list of plates, the frames ``first_frame`` onwards."""
    cls = (find_type(node_type) or REGISTRY[node_type]) if isinstance(node_type, str) else node_type
    node = cls(name, params or {})
    ins = {k: None for k in cls.inputs_spec}
    ins.update(inputs or {})
    for k, spec in cls.inputs_spec.items():
        if spec.sequence and ins[k] is not None:
            plates = list(ins[k])
            ins[k] = PlateSequence(range(first_frame, first_frame + len(plates)),
                                   lambda f, plates=plates: plates[f - first_frame],
                                   lambda plate, k=k: node.check_plate(k, plate))
    notes = [] if notes is None else notes
    ctx = Context(node, frame, first_frame, ins, node.params, Path(graph_dir), threads, notes)
    node.check_inputs(ins)
    try:
        return node.compute(ctx)
    except UserError as e:  # the layer's errors name no node: prefix it, as the engine does
        msg = str(e)
        raise type(e)(msg if msg.startswith(f"{name}:") else f"{name}: {msg}") from None
