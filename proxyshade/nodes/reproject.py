"""Reproject: carry the previous frame's synthesis into this frame and flag what must be
resynthesized (Bonneel et al. 2010, §6.2).

Reference: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010.

"We project the 3D coordinates of a given pixel in the current frame (N) to the camera
position of the previous frame (N − 1); we copy this color ... pixels which became
disoccluded ... are flagged for resynthesis. ... We compute the determinant of the
Jacobian J of the reprojected pixel coordinates ... D = ||det(J) − 1|| which we
accumulate across frames. If D becomes greater than a given threshold, D is reset to 0
and the pixel is flagged for resynthesis. We perturb D with random noise to avoid a
coherent wave ... pixels previously visible and now occluded by objects (category C) are
also tagged ... We remove these isolated pixels in 5×5 neighborhoods. We dilate remaining
flagged regions."

What is carried is the synthesis state, the coordinate map: ``source.x/y`` (bilinear
inside one patch, nearest across seams) and ``patch.id`` (nearest). With ``colour: map``
(default) the colour is looked up again through the carried map and the previous
frame's smooth Poisson correction (its colour minus the source through its map) is
added back, bilinearly reprojected: re-sampling the colour itself every frame would blur
the texture a little more each frame. ``colour: bilinear`` copies the previous colour
bilinearly (the paper's literal reading).

Departures from the paper, each for what a viewer saw over a whole shot (docs/temporal.md):
the source is read with Lanczos-4 at the carried fractional positions (``filter``;
bilinear lost a quarter of the detail on the first carried frame; ``flat4``, flat to
0.9 × Nyquist and clamped to the 4×4 pixels around, keeps more of a painted texture's
finest detail than Lanczos-4); disoccluded pixels
first continue a neighbouring kept patch (``fill_radius``, at most ``extend_frames``
frames running, counted in ``extension``); distortion is measured on the carried map
itself, D = ‖J − I‖ of ∂(source.x, source.y)/∂(col, row) / scale within a patch
(det J of the geometry is blind to shear), and a patch whose mean D crosses its own
threshold (hashed per patch within ``spread``: the paper's noise against a coherent
wave) is re-anchored whole to a plain copy through its middle instead of resynthesized.

Flags (uint32 ``flag``): 0 kept, 1 disoccluded (no previous pixel of this label on this
surface, and not continued), 2 newly occluded (category C of ConsistentDepth whose
previous pixel had another label: the object now in front hides what was seen there),
3 distorted (re-anchored, but the copy leaves its label; or kept, but its carried source
position has left its label by more than half a source pixel: resynthesized), 4 re-anchored
(the new map kept; only the Poisson solve is redone). Isolated flags (fewer than
``min_neighbours`` other flagged pixels in the 5×5 window) are dropped; reasons 1 and 2
are dilated by ``dilate`` pixels (dilated pixels take the reason of a flag they grew
from, 2 before 1). When more than ``cut_threshold`` of the frame is flagged the frame is
treated as a camera cut: everything is flagged for a full synthesis (noted in the run
report).

Gradient creep (``creep_gate`` > 0): each label's mean display-luma gradient in ``prev`` over
the first frame's (``temporal.gradient_ratios``) goes into ``meta["temporal"]["gradient"]``;
the labels above the gate (``rising``) alone take ``solve_continued`` here and Resynthesize's
``kept_as_one`` / ``flagged_apart`` / ``solve_margin``, so a label whose texture has not crept
is not flattened by repeated solves (docs/temporal.md).

Progressive (``progressive: true``, after an edit of the first frame, Bonneel et al. 2010,
§7): only the pixels the edit reaches in this frame (ConsistentDepth changed, or the
previous final frame's changed pixels reprojected here, grown by the carry's margins) are
carried again; every other pixel keeps the last run's result bit for bit, and a frame the
edit does not reach keeps it whole (``temporal.carry_update``).

Layer: ``proxyshade.synthesis.temporal``; kernels ``proxyshade.kernels.reproject``,
``proxyshade.kernels.temporal``.
"""
from __future__ import annotations

from proxyshade.graph.node import Input, Node, Progressive
from proxyshade.graph.plate import Plate
from proxyshade.synthesis.params import Carry, source_input
from proxyshade.synthesis.state import STATE


class Reproject(Carry, Progressive, Node):
    """The previous final frame warped into this frame's camera, with flags.

    Output at the ConsistentDepth's size: ``R,G,B``, ``source.x/y``, ``patch.id`` (the
    carried synthesis; zeros where flagged without a previous pixel), ``label.id``, ``Z``,
    ``P.X/Y/Z``, ``category`` (from ConsistentDepth), ``distortion`` (float32, the
    map's deviation ‖J − I‖ where kept), ``extension`` (frames of continuation), ``flag`` (uint32, see the module doc); metadata: the previous frame's
    (labels, source, synthesis) with this frame's camera and ``temporal`` (flag shares,
    ``cut``).

    At the first frame (``prev`` not there yet) the ``first`` plate (the full first-frame
    synthesis) passes through with no flags; without ``first`` the whole frame is flagged.
    """

    version = 1
    time_dependent = True  # the frame is recorded in meta['temporal']
    # not stored (kept in memory for its frame's Resynthesize, computed again when read): its one
    # reader is that frame's Resynthesize, whose key changes with it through the previous final
    # frame, so a later run never reads it back; its entry cost 0.28 CPU s an update frame at
    # 1024 wide (ZSTD, 22 channels, 30 MiB) and held each 88 MiB plate until written. Stored when
    # progressive (its update starts from the last run's result; a progressive Resynthesize after
    # a Reproject that is not finds no last input and computes its frame whole)
    stored = False
    depth = Input("this frame's ConsistentDepth: label.id, Z, category, camera", channels=("label.id", "Z"),
                  fix="connect this frame's ConsistentDepth")
    prev = Input("the previous final frame (Poisson at frame: -1): R,G,B, source.x/y, patch.id, label.id, Z",
                 optional=True, channels=STATE + ("Z",), finite=("R", "G", "B", "source.x", "source.y"),
                 fix="connect the previous frame's final Poisson (frame: -1)")
    first = Input("the full first-frame synthesis (Poisson at frame: first), used at the first frame",
                  optional=True, channels=STATE, fix="connect the first frame's final Poisson (frame: first)")
    source = source_input("annotated source (SourceRead): colours are looked up through the carried map")

    def compute(self, ctx) -> Plate:
        from proxyshade.synthesis.temporal import carry, carry_update

        if ctx.previous is not None:
            up = carry_update(ctx.previous.plate, ctx.previous.inputs, ctx.depth, ctx.prev, ctx.first, ctx.source,
                              Carry.of(ctx.p), frame=ctx.frame, first_frame=ctx.first_frame, note=ctx.note,
                              memo=ctx.memo)
            if up is not None:
                return up[0]
        return carry(ctx.depth, ctx.prev, ctx.first, ctx.source, Carry.of(ctx.p), frame=ctx.frame,
                     first_frame=ctx.first_frame, note=ctx.note, memo=ctx.memo)
