"""AnnotationRender: light = max(N·L, 0)·(1 − shadow), depth and up maps in [0, 1], the
label mask, and bad kinds / labels as one-line errors."""
import numpy as np
import pytest

from proxyshade.errors import NodeInputError
from proxyshade.graph.plate import Plate
from proxyshade.graph.testing import run_node

LABELS = [{"name": "grass", "id": 1, "color": "#00ff00"}, {"name": "sky", "id": 2, "color": "#ffffff"}]


def proxy(rng, h=6, w=7):
    n = rng.normal(size=(h, w, 3))
    n /= np.linalg.norm(n, axis=2, keepdims=True)
    z = rng.uniform(2, 10, (h, w)).astype(np.float32)
    z[0, 0] = np.inf
    lab = np.where(np.isfinite(z), 1, 2).astype(np.uint32)
    lab[1, :3] = 2
    ch = {"N.X": n[..., 0], "N.Y": n[..., 1], "N.Z": n[..., 2], "Z": z, "label.id": lab}
    return Plate({k: v.astype(v.dtype if k == "label.id" else np.float32) for k, v in ch.items()}, {"labels": LABELS})


def test_maps_follow_their_formulas():
    rng = np.random.default_rng(0)
    p = proxy(rng)
    sh = Plate({"shadow": rng.random(p.shape).astype(np.float32)}, {"light": {"direction": [0.0, -1.0, 0.0]}})
    out = run_node("AnnotationRender", {"annotations": {"l": "light", "d": "depth", "u": "up"}, "label": "grass"},
                   {"proxy": p, "shadow": sh})
    m = p["label.id"] == 1
    assert np.array_equal(out["mask"] > 0.5, m)
    light = np.maximum(p["N.Y"], 0) * (1 - sh["shadow"])  # L = +Y (light travels down)
    np.testing.assert_allclose(out["ann.l"][m], light[m], atol=1e-6)
    z = p["Z"]
    np.testing.assert_allclose(out["ann.d"][m], ((z - z[m].min()) / (z[m].max() - z[m].min()))[m], atol=1e-6)
    np.testing.assert_allclose(out["ann.u"][m], ((p["N.Y"] + 1) / 2)[m], atol=1e-6)
    for k in ("ann.l", "ann.d", "ann.u"):  # outside the mask: the masked mean
        np.testing.assert_allclose(out[k][~m], out[k][m].mean(), rtol=1e-5)


def test_sun_parameter_without_shadow_plate():
    p = proxy(np.random.default_rng(1))
    out = run_node("AnnotationRender", {"annotations": {"l": "light"}, "sun": [1, 0, 0]}, {"proxy": p})
    m = np.isfinite(p["Z"])
    np.testing.assert_allclose(out["ann.l"][m], np.maximum(p["N.X"], 0)[m], atol=1e-6)


@pytest.mark.parametrize("params,match", [({"annotations": {"l": "shade"}}, "annotations.l: 'shade' is not one of"),
                                          ({"label": "rock"}, "label 'rock' is not in the proxy's label table")])
def test_bad_params(params, match):
    with pytest.raises(NodeInputError, match=f"^ann: {match}"):
        run_node("AnnotationRender", params, {"proxy": proxy(np.random.default_rng(2))}, name="ann")


def test_light_range_maps_shaded_and_lit_to_0_and_1():
    rng = np.random.default_rng(2)
    p = proxy(rng)
    plain = run_node("AnnotationRender", {"annotations": {"l": "light"}, "sun": [0, 1, 0]}, {"proxy": p})
    got = run_node("AnnotationRender", {"annotations": {"l": "light"}, "sun": [0, 1, 0], "light_range": [0.2, 0.6]},
                   {"proxy": p})
    m = got["mask"] > 0.5
    np.testing.assert_allclose(got["ann.l"][m], np.clip((plain["ann.l"][m] - 0.2) / 0.4, 0, 1), atol=1e-6)
    with pytest.raises(NodeInputError, match="light_range .*0 <= shaded < lit <= 1"):
        run_node("AnnotationRender", {"annotations": {"l": "light"}, "light_range": [0.6, 0.2]}, {"proxy": p})
