"""LabelGrade: no pixel outside the label changes; the grade inside follows its formulas."""
import warnings

import numpy as np
import pytest

from proxyshade.errors import NodeInputError
from proxyshade.graph.plate import Plate
from proxyshade.graph.testing import run_node
from proxyshade.nodes.label_grade import grade

warnings.filterwarnings("ignore", message='.*"Matplotlib" related API features.*')
import colour  # noqa: E402

LABELS = [{"name": "sky", "id": 1, "color": "#0000ff"}, {"name": "grass", "id": 3, "color": "#00ff00"}]


def plate(rng, h=9, w=11):
    rgb = rng.random((3, h, w), dtype=np.float32) * 2
    lab = rng.choice(np.array([0, 1, 3], np.uint32), (h, w))
    return Plate({"R": rgb[0], "G": rgb[1], "B": rgb[2], "label.id": lab, "Z": rgb[0]}, {"labels": LABELS})


STRONG = {"temperature": 3200.0, "exposure": 1.5, "slope": [1.2, 0.9, 0.8], "offset": [0.01, 0.0, -0.02],
          "power": [1.1, 1.0, 0.9], "saturation": 1.7}


@pytest.mark.parametrize("label", ["sky", "grass"])
def test_changes_no_pixel_outside_label(label):
    rng = np.random.default_rng(0)
    p = plate(rng)
    out = run_node("LabelGrade", dict(STRONG, label=label), {"image": p})
    lid = dict(sky=1, grass=3)[label]
    outside = p["label.id"] != lid
    for c in "RGB":
        assert np.array_equal(out[c][outside], p[c][outside])
        assert not np.array_equal(out[c][~outside], p[c][~outside])
        assert out[c].dtype == np.float32
    assert out["Z"] is p["Z"] and out["label.id"] is p["label.id"]


def test_identity_params_change_nothing():
    p = plate(np.random.default_rng(1))
    out = run_node("LabelGrade", {"label": "sky"}, {"image": p})
    for c in "RGB":
        assert np.array_equal(out[c], p[c])


def test_cdl_exposure_saturation_formula():
    rng = np.random.default_rng(2)
    c = rng.random((50, 3))
    slope, offset, power = np.array([1.2, 0.9, 0.8]), np.array([0.01, 0.0, -0.02]), np.array([1.1, 1.0, 0.9])
    got = grade(c, exposure=-0.5, slope=slope, offset=offset, power=power, saturation=0.3)
    v = c * 2 ** -0.5 * slope + offset
    v = np.where(v > 0, np.abs(v) ** power, v)
    lum = v @ np.array([0.2126, 0.7152, 0.0722])
    np.testing.assert_allclose(got, lum[:, None] + 0.3 * (v - lum[:, None]), atol=1e-4)
    assert np.all(np.isfinite(got))


def test_white_balance_is_chromatic_adaptation():
    rng = np.random.default_rng(3)
    c = rng.random((20, 3))
    got = grade(c, temperature=4000.0)
    cs = colour.RGB_COLOURSPACES["sRGB"]
    xyz = colour.RGB_to_XYZ(c, cs, apply_cctf_decoding=False)
    w0 = colour.xy_to_XYZ(colour.temperature.CCT_to_xy_Kang2002(6504.0))
    w1 = colour.xy_to_XYZ(colour.temperature.CCT_to_xy_Kang2002(4000.0))
    want = colour.XYZ_to_RGB(colour.chromatic_adaptation(xyz, w0, w1, method="Von Kries", transform="CAT02"),
                             cs, apply_cctf_encoding=False)
    np.testing.assert_allclose(got, want, atol=1e-9)
    grey = grade(np.array([[0.5, 0.5, 0.5]]), temperature=4000.0)[0]
    assert grey[0] > grey[1] > grey[2]  # warmer
    cool = grade(np.array([[0.5, 0.5, 0.5]]), temperature=9000.0)[0]
    assert cool[0] < cool[2]


def test_unknown_label_lists_the_labels():
    p = plate(np.random.default_rng(4))
    with pytest.raises(NodeInputError, match="label 'water' is not in .*its labels are sky, grass") as e:
        run_node("LabelGrade", {"label": "water"}, {"image": p})
    assert "\n" not in str(e.value)


def test_bad_power_and_missing_label_channel():
    p = plate(np.random.default_rng(5))
    with pytest.raises(NodeInputError, match="power"):
        run_node("LabelGrade", {"label": "sky", "power": [1, 0, 1]}, {"image": p})
    with pytest.raises(NodeInputError, match="input 'image' has no channel label.id; LabelGrade needs"):
        run_node("LabelGrade", {"label": "sky"}, {"image": p.select(["R", "G", "B"])})
