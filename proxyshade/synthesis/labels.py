"""Label tables and label maps: the source's table, dense label indices, the guide taken
down to the synthesis size and the source's labels on the output-scale grid.

The label guides of N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided
Texture Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010 (§3, §4)."""
from __future__ import annotations

import math

import numpy as np

from proxyshade.errors import NodeInputError
from proxyshade.plate import Plate
from proxyshade.kernels import features as kf
from proxyshade.synthesis.memo import kept


def joint_dense(*labs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A lookup table from label id to a dense index (0..n-1) over the ids present in any
    of ``labs`` (an output's and a photo's label maps), and those ids in order."""
    top = int(max(int(l.max()) for l in labs))
    present = np.zeros(top + 1, bool)
    for l in labs:
        present[l.ravel()] = True
    return (np.cumsum(present) - 1).astype(np.int32), np.nonzero(present)[0]


def source_table(source: Plate) -> np.ndarray:
    """The source's label ids (dense index -> id) from ``meta['labels']``."""
    labels = source.meta.get("labels")
    if not labels:
        raise NodeInputError("input 'source' has no label table in its metadata (meta['labels']); "
                             "read it with SourceRead from a source.yaml")
    return np.array([int(t["id"]) for t in labels], dtype=np.int64)


def dense_guide(guide_ids: np.ndarray, table: np.ndarray, name: str = "guide") -> np.ndarray:
    """Label ids of input ``name`` -> dense label indices; a label missing from the table is
    an error."""
    dense, missing = kf.dense_labels(guide_ids, table)
    if missing.any():
        ids, counts = np.unique(guide_ids[missing], return_counts=True)
        which = ", ".join(f"{int(i)}{' (none)' if i == 0 else ''}: {int(c)} px" for i, c in zip(ids[:5], counts[:5]))
        raise NodeInputError(
            f"input '{name}' has label ids missing from the source's label table ({which}); the table has "
            f"ids {', '.join(map(str, table.tolist()))}: add the labels to source.yaml or relabel the "
            "proxy so every guide pixel has a source label")
    return dense


def source_dense(source: Plate, table: np.ndarray) -> np.ndarray:
    """The source's own label map as dense indices."""
    dense, missing = kf.dense_labels(source["label.id"], table)
    if missing.any():
        raise NodeInputError("input 'source' has label ids that are not in its own label table; "
                             "re-read it with SourceRead")
    return dense


def guide_at_synthesis(guide_dense: np.ndarray, factor: int, n: int) -> np.ndarray:
    """The guide voted down by ``factor`` (a power of two)."""
    if factor & (factor - 1):
        raise NodeInputError(f"factor {factor} is not a power of two; use 1, 2, 4 or 8")
    if factor == 1:
        return guide_dense
    H, W = guide_dense.shape
    Hp, Wp = -(-H // factor) * factor, -(-W // factor) * factor
    if (Hp, Wp) != (H, W):  # replicate the last rows/columns up to a multiple of factor
        guide_dense = np.pad(guide_dense, ((0, Hp - H), (0, Wp - W)), mode="edge")
    nlev = int(round(math.log2(factor))) + 1
    out = kf.vote_pyramid(guide_dense, nlev, n)[0]
    assert out.shape == (Hp // factor, Wp // factor), out.shape
    return np.ascontiguousarray(out)


def working_labels(source_dense: np.ndarray, scale: float, n: int) -> np.ndarray:
    """Source labels on the output-scale grid (source / scale), dense."""
    if scale == 1.0:
        return np.ascontiguousarray(source_dense, np.int32)
    _, lab = kf.build_exemplar(np.zeros(source_dense.shape + (3,), np.float32), source_dense, scale, n)
    return lab


def source_working_labels(source: Plate, table: np.ndarray, scale: float, memo=None) -> np.ndarray:
    """``working_labels`` of the source's own label map, kept for the frames of a run that
    pass the same source, in ``memo`` (``synthesis.memo``; shared: not to be written to)."""
    return kept(memo, "labels.source_working_labels", (source["label.id"], table, float(scale)),
                lambda: working_labels(source_dense(source, table), scale, len(table)))
