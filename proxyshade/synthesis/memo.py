"""Results that every frame of a run would compute again from the same data (a source's
similarity sets, the first frame's grid), kept in the memo the engine hands the node
(``ctx.memo``, ``graph.memo``) and the node passes to the layer's functions.

A step names its result and every value it depends on: ``kept(memo, "grain.graded",
(source, table), compute)``. The memo keys it like a plate (the step, the code of the
module that computes it, the parts, plates and arrays by their content), so an entry is
never found for other parameters or other data. ``memo=None`` keeps nothing: the functions
stay plain functions of their arguments.
"""
from __future__ import annotations

from typing import Any, Callable


def kept(memo, step: str, parts: Any, compute: Callable[[], Any], *, size: int = 2) -> Any:
    """``compute()``, or the result kept in ``memo`` for ``step`` and ``parts`` (the newest
    ``size`` of the step are kept; shared: not to be written to)."""
    if memo is None:
        return compute()
    return memo.get(step, parts, compute, size=size)
