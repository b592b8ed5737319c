"""ConsistentDepth on an analytic scene (wall, ball, sky) and on a sample camera move."""
import numpy as np
import pytest

from proxyshade.errors import NodeInputError
from proxyshade.graph.plate import Plate
from proxyshade.graph.testing import run_node
from proxyshade.synthesis.temporal import CATEGORY
from tests.nodes._temporal import camera, proxy, render

A, B, C, D = (CATEGORY[k] for k in "ABCD")


def cd(proxy_n, guide, depth=None, ref_proxy=None, **params):
    return run_node("ConsistentDepth", params, {"proxy": proxy_n, "guide": guide, "depth": depth,
                                                "ref_proxy": ref_proxy}, frame=2)


def test_same_camera_gives_the_first_frame_back():
    p0 = render(camera())
    out = cd(p0, p0, ref_proxy=p0)
    assert (out["category"] == A).all()  # the sky too: a grid quad at infinity
    np.testing.assert_array_equal(out["label.id"], p0["label.id"])
    fin = np.isfinite(p0["Z"])
    np.testing.assert_array_equal(np.isfinite(out["Z"]), fin)
    wall = p0["label.id"] == 1  # planar: exact; the ball's quads are planar pieces of a curved surface
    np.testing.assert_allclose(out["Z"][wall], p0["Z"][wall], rtol=1e-5)
    np.testing.assert_allclose(out["Z"][fin], p0["Z"][fin], rtol=0.01)
    for a in "XYZ":
        np.testing.assert_allclose(out[f"P.{a}"][wall], p0[f"P.{a}"][wall], atol=1e-3)
    assert out.meta["camera"] == p0.meta["camera"] and out["category"].dtype == np.uint32


def test_camera_translation_reveals_uncovered_pixels_and_the_balls_far_side():
    p0 = render(camera(), sphere=(0, 0, -10))
    p1 = render(camera(pos=(0.8, 0, 0), frame=2), sphere=(0, 0, -10))
    out = cd(p1, p0, ref_proxy=p0)
    cat = out["category"]
    # the wall moves 40 * 0.8 / 20 = 1.6 px left: the last columns were not in frame 0
    assert (cat[:, -1] == D).all()
    # wall pixels hidden behind the ball at frame 0 and visible now have no grid: D, proxy's wall
    assert ((cat == D) & (p1["label.id"] == 1)).any()
    np.testing.assert_array_equal(out["label.id"][cat >= C], p1["label.id"][cat >= C])
    # grid pixels (A) keep frame-0 labels and agree with this frame's proxy away from edges
    agree = (out["label.id"] == p1["label.id"])[cat == A].mean()
    assert agree > 0.98
    # the ball's newly visible side covers wall pixels seen at frame 0: category C, labelled ball
    c = cat == C
    assert c.any() and (p1["label.id"][c] == 2).all()


def test_guide_detail_behind_the_proxy_is_kept_category_b():
    p0 = render(camera(), sphere=(0, 0, -10))
    guide = Plate({"label.id": p0["label.id"].copy(), "Z": p0["Z"]}, dict(p0.meta))
    depth = Plate({"Z": p0["Z"].copy()}, dict(p0.meta))
    # the detailed guide shows the wall through a notch in the ball (its extended depth: the wall's)
    notch = (slice(28, 36), slice(30, 34))
    guide["label.id"][notch] = 1
    depth["Z"][notch] = 20.0
    p1 = render(camera(pos=(0.05, 0, 0), frame=2), sphere=(0, 0, -10))
    out = cd(p1, guide, depth=depth, ref_proxy=p0)
    b = out["category"] == B
    assert b.sum() >= 0.8 * 8 * 4 and (out["label.id"][b] == 1).all()
    assert np.allclose(out["Z"][b], 20.0, rtol=0.02)
    # without the first frame's proxy depth nothing counts as occluded then: C, the proxy's ball
    out = cd(p1, Plate({"label.id": guide["label.id"]}, dict(p0.meta)), depth=depth)
    assert not (out["category"] == B).any()


def test_moving_ball_newly_occluded_ring_is_category_c():
    cam0, cam1 = camera(), camera(frame=2)
    old, new = (0.0, 0.0, -10.0), (1.5, 0.0, -10.0)
    p0 = render(cam0, sphere=old)
    p1 = render(cam1, sphere=new)
    out = cd(p1, p0, ref_proxy=p0)
    was_ball = p0["label.id"] == 2
    is_ball = p1["label.id"] == 2
    c = out["category"] == C
    # wall seen at frame 0, ball now: C; so are old-ball grid pixels the new ball hides
    np.testing.assert_array_equal(c & ~was_ball, is_ball & ~was_ball)
    assert not (c & ~is_ball).any()
    # the old ball's grid pixels that would float in front of the wall now are dropped: the proxy fills in
    # (the stale test looks at the proxy's 3x3 window: one pixel around the new ball may keep old ones)
    from proxyshade.kernels.temporal import dilate

    d = out["category"] == D
    assert not (d & ~was_ball).any() and d[was_ball & ~dilate(is_ball, 1)].all()
    np.testing.assert_array_equal(out["label.id"], p1["label.id"])
    # switched off, the stale ball stays in the grid (a ghost)
    ghost = cd(p1, p0, ref_proxy=p0, stale=False)
    assert ((ghost["label.id"] == 2) & ~is_ball).sum() > 50


def stale_notes(proxy_n, p0):
    notes = []
    out = run_node("ConsistentDepth", {}, {"proxy": proxy_n, "guide": p0, "ref_proxy": p0}, frame=2, notes=notes)
    return out, [n for n in notes if "stale grid" in n]


@pytest.mark.parametrize("pos", [(0.8, 0, 0), (0.3, 0.2, 0), (2.0, 0.5, 1.0), (4, 0, 0), (0.1, 0.05, 0.3)])
def test_a_static_scene_notes_no_moving_object_whatever_the_camera_does(pos):
    """Nothing moves but the camera: no note of stale grid from a moving object (the 2-4
    pixels a frame where the ball's silhouette quads are drawn a pixel onto the wall behind
    are no such thing)."""
    p0 = render(camera(), sphere=(0, 0, -10))
    p1 = render(camera(pos=pos, frame=2), sphere=(0, 0, -10))
    assert stale_notes(p1, p0)[1] == []


@pytest.mark.parametrize("to", [(3, 0, -10), (1, 0, -12)])
def test_a_moving_object_is_noted_with_its_stale_pixels(to):
    p0 = render(camera(), sphere=(0, 0, -10))
    p1 = render(camera(frame=2), sphere=to)
    out, notes = stale_notes(p1, p0)
    assert len(notes) == 1 and "a moving object" in notes[0]
    assert int(notes[0].split()[0]) > 100


def test_the_sample_camera_moves_note_no_moving_object():
    """The bundled lake and cliffs scenes (static objects, an orbiting camera) over the shot:
    no stale-grid note on any frame (one on every frame before)."""
    for scene in ("lake", "cliffs"):
        p0 = proxy(scene, 1, 128)
        for f in (2, 12, 24, 48):
            assert stale_notes(proxy(scene, f, 128), p0)[1] == [], (scene, f)


def test_sample_move_labels_follow_the_proxy():
    p0, p6 = proxy("lake", 1, 96), proxy("lake", 6, 96)
    out = cd(p6, p0, ref_proxy=p0)
    counts = out.meta["consistent_depth"]["categories"]
    assert counts["A"] > 0.85 * 96 * 96 and counts["D"] > 0
    assert (out["label.id"] == p6["label.id"]).mean() > 0.97


def test_bad_inputs_name_the_fix():
    p0 = render(camera())
    with pytest.raises(NodeInputError, match="camera"):
        cd(p0, Plate({"label.id": p0["label.id"], "Z": p0["Z"]}), depth=Plate({"Z": p0["Z"]}))
    with pytest.raises(NodeInputError, match="guide"):
        cd(p0, None)
    small = render(camera(size=32))
    with pytest.raises(NodeInputError, match="DepthExtend"):
        cd(p0, p0, depth=small)
