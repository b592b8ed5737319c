"""The guide layer: the exemplar's similarity sets are searched once per source and
parameters, and a guide synthesized with them found again is the same."""
from types import SimpleNamespace

import numpy as np

from proxyshade.graph.memo import Memo, RunMemo
from proxyshade.io.source import load_source
from proxyshade.kernels import guide as kg
from proxyshade.synthesis import guide as G
from proxyshade.synthesis.params import Guidance

from tests.nodes.test_guide_synth import ROOT, bands


def test_similarity_sets_are_found_again_for_the_same_source_and_searched_anew_for_other_parameters(monkeypatch):
    src = load_source(ROOT / "samples/renoir/source.yaml")
    proxy = bands(src, ["sky", "vegetation", "water"], [80, 100, 76], size=256)
    calls = []
    real = kg.similarity_sets
    monkeypatch.setattr(kg, "similarity_sets", lambda *a: calls.append(a[6]) or real(*a))
    gp = SimpleNamespace(**{**vars(Guidance.defaults()), "size": 128, "start": 32, "seed": 3})
    memo = RunMemo(Memo())
    first, _ = G.synthesize_guide(proxy, src, gp, memo=memo)
    n = len(calls)
    assert n == 3  # one search per level
    again, _ = G.synthesize_guide(proxy, src, gp, memo=memo)
    assert len(calls) == n  # found again
    for c in first.names():
        assert np.array_equal(first[c], again[c])
    G.synthesize_guide(proxy, src, SimpleNamespace(**{**vars(gp), "seed": 4}), memo=memo)
    assert len(calls) == 2 * n  # another seed: other sets
