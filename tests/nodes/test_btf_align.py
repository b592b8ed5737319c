"""BtfAlign on btf_bumps: the chosen plane lies within the sample's heights, and it makes
an interpolated in-between view closer to the real one than a plane outside them (Fig. 10)."""
import numpy as np
import pytest

from proxyshade.graph.testing import run_node
from proxyshade.synthesis import btf
from tests.nodes._btf import capture


@pytest.fixture(scope="module")
def stack():
    return capture(96, 2.5, 30, [0, 90], 512)  # slants 0..30 step 2.5 (25°, 27.5°, 30° among them)


@pytest.fixture(scope="module")
def aligned(stack):
    return run_node("BtfAlign", {"search": 0.1, "steps": 21}, {"stack": stack})


def test_chosen_plane_lies_within_the_heights(stack, aligned):
    lo, hi = stack.meta["btf"]["heights"]
    plane = aligned.meta["btf"]["plane"]
    assert lo <= plane <= hi, (lo, plane, hi)
    costs = np.array(aligned.meta["align"]["costs"])
    heights = np.array(aligned.meta["align"]["heights"])
    assert heights[np.argmin(costs)] == plane
    assert costs.min() < 0.7 * costs[(heights < lo) | (heights > hi)].min()  # a clear minimum, not noise
    m = int(aligned.meta["btf"]["origin"][0] / stack.meta["btf"]["pixel"] - stack.meta["btf"]["origin"][0]
            / stack.meta["btf"]["pixel"] + 0.5)
    assert aligned.shape == (96 - 2 * m, 96 - 2 * m) and m >= 1  # cropped by the largest shift


def test_interpolated_view_is_closer_with_the_chosen_plane(stack, aligned):
    views, imgs = btf.stack_arrays(stack)
    pixel = stack.meta["btf"]["pixel"]
    lo, hi = stack.meta["btf"]["heights"]
    idx = {(v["slant"], v["tilt"]): n for n, v in enumerate(views)}
    a, mid, b = idx[(25.0, 0.0)], idx[(27.5, 0.0)], idx[(30.0, 0.0)]

    m = btf.max_shift(views, 2 * (hi - lo) + abs(lo), pixel) + 2  # one crop for every plane compared

    def rmse(h):
        r = btf.rectify(imgs[[a, mid, b]], [views[a], views[mid], views[b]], h, pixel)
        guess = 0.5 * (r[0] + r[2])
        return float(np.sqrt(((guess - r[1])[m:-m, m:-m] ** 2).mean()))

    chosen = aligned.meta["btf"]["plane"]
    for outside in (hi + 0.5 * (hi - lo), lo - 0.5 * (hi - lo)):
        assert rmse(chosen) < rmse(outside), (chosen, outside, rmse(chosen), rmse(outside))


def test_only_neighbours_sharing_a_light_are_compared():
    views = btf.view_grid(30, 60, [0, 90])  # 0; (30, 0) (30, 90); (60, 0) (60, 90)
    sun = [0.0, -1.0, 0.0]
    for v in views:
        v["light"] = sun
    assert sorted(map(tuple, btf.grid_edges(views).tolist())) == [(0, 1), (0, 2), (1, 2), (1, 3), (2, 4), (3, 4)]
    views[3]["light"] = [0.0, -0.8, 0.6]  # (60, 0) lit otherwise: its three pairs drop out
    assert sorted(map(tuple, btf.grid_edges(views).tolist())) == [(0, 1), (0, 2), (1, 2), (2, 4)]
