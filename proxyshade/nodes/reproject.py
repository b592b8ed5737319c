"""Reproject: carry the previous frame's synthesis into this frame and flag what must be
resynthesized (Bonneel et al. 2010, §6.2).

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
bilinear lost a quarter of the detail on the first carried frame); disoccluded pixels
first continue a neighbouring kept patch (``fill_radius``, at most ``extend_frames``
frames running, counted in ``extension``); distortion is measured on the carried map
itself, D = ‖J − I‖ of ∂(source.x, source.y)/∂(col, row) / scale within a patch
(det J of the geometry is blind to shear), and a patch whose mean D crosses its own
threshold (hashed per patch within ``spread``: the paper's noise against a coherent
wave) is re-anchored whole to a plain copy through its middle instead of resynthesized.

Flags (uint32 ``flag``): 0 kept, 1 disoccluded (no previous pixel of this label on this
surface, and not continued), 2 newly occluded (category C of ConsistentDepth whose
previous pixel had another label: the object now in front hides what was seen there),
3 distorted (re-anchored, but the copy leaves its label: resynthesized), 4 re-anchored
(the new map kept; only the Poisson solve is redone). Isolated flags (fewer than
``min_neighbours`` other flagged pixels in the 5×5 window) are dropped; reasons 1 and 2
are dilated by ``dilate`` pixels (dilated pixels take the reason of a flag they grew
from, 2 before 1). When more than ``cut_threshold`` of the frame is flagged the frame is
treated as a camera cut: everything is flagged for a full synthesis (noted in the run
report).

Layer: ``proxyshade.synthesis.temporal``; kernels ``proxyshade.kernels.reproject``,
``proxyshade.kernels.temporal``.
"""
from __future__ import annotations

import numpy as np

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate
from proxyshade.kernels import reproject as kr
from proxyshade.kernels import temporal as kt
from proxyshade.kernels.lookup import lookup
from proxyshade.synthesis.params import source_input
from proxyshade.synthesis.temporal import (CORRECTION, FLAG, STATE, absorb_fragments, camera_of, clean_flags,
                                           fits_source, newly_occluded, reanchor_distorted)


class Reproject(Node):
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
    depth = Input("this frame's ConsistentDepth: label.id, Z, category, camera", channels=("label.id", "Z"),
                  fix="connect this frame's ConsistentDepth")
    prev = Input("the previous final frame (Poisson at frame: -1): R,G,B, source.x/y, patch.id, label.id, Z",
                 optional=True, channels=STATE + ("Z",), finite=("R", "G", "B", "source.x", "source.y"),
                 fix="connect the previous frame's final Poisson (frame: -1)")
    first = Input("the full first-frame synthesis (Poisson at frame: first), used at the first frame",
                  optional=True, channels=STATE, fix="connect the first frame's final Poisson (frame: first)")
    source = source_input("annotated source (SourceRead): colours are looked up through the carried map")
    colour = Param(str, "map", choices=("map", "bilinear"),
                   doc="look colours up through the carried map (+ reprojected Poisson correction), or copy them")
    depth_tolerance = Param(float, 0.02, min=0.0, max=1.0,
                            doc="relative inverse-depth difference under which a previous pixel is the same surface")
    threshold = Param(float, 0.35, min=0.0,
                      doc="map deviation ||J - I|| (J: the carried map's Jacobian over the synthesis scale) above "
                          "which a pixel is resynthesized")
    spread = Param(float, 0.5, min=0.0, max=1.0,
                   doc="each patch's threshold is uniform in [(1 - spread) x threshold, threshold] (hashed from its "
                       "id and the seed): patches that distort together are redone at different frames, not as "
                       "one wave")
    filter = Param(str, "lanczos4", choices=("lanczos4", "lanczos3", "bilinear"),
                   doc="reconstruction of the source at the carried (fractional) positions; bilinear blurs the "
                       "finest detail")
    seed = Param(int, 0, doc="seed of the per-patch thresholds")
    isolated_radius = Param(int, 2, min=0, max=8, doc="window radius of the isolated-flag test (2: 5x5)")
    min_neighbours = Param(int, 3, min=0, doc="flags with fewer other flags in the window are dropped")
    dilate = Param(int, 2, min=0, max=64, doc="dilation radius of the remaining flagged regions (pixels)")
    fill_radius = Param(int, 6, min=0, max=32,
                        doc="pixels without a previous value (disoccluded) continue the patch of a kept pixel of "
                            "their label this close, where the continued source position has their label; the "
                            "rest are flagged")
    extend_frames = Param(int, 6, min=0,
                          doc="frames a disoccluded band may continue its neighbour's patch before it is flood-filled "
                              "(the 'extension' channel counts them)")
    min_patch_area = Param(int, 16, min=0,
                           doc="patches smaller than this (pixels) continue the neighbouring patch they touch most "
                               "(flagged re-anchored); 0 keeps every fragment")
    min_patch_width = Param(float, 2.0, min=0.0,
                            doc="patches thinner than this (2 x area / perimeter, pixels) are fragments too")
    cut_threshold = Param(float, 0.5, min=0.0, max=1.0,
                          doc="share of flagged pixels above which the frame is a camera cut (full synthesis)")

    def compute(self, ctx) -> Plate:
        p = ctx.p
        cd, source = ctx.depth, ctx.source
        H, W = cd.shape
        cat = cd["category"] if "category" in cd else np.zeros((H, W), np.uint32)
        geo = {c: cd[c] for c in ("label.id", "Z", "P.X", "P.Y", "P.Z") if c in cd}
        geo["category"] = cat.astype(np.uint32, copy=False)
        prev = ctx.prev
        if prev is None:
            return self._first(ctx, cd, geo)
        cam1 = camera_of("depth", cd)
        cam0 = camera_of("prev", prev)
        if (cam0.width, cam0.height) != (prev.width, prev.height):
            raise ctx.error(f"prev's camera is {cam0.width}x{cam0.height}, the plate {prev.width}x{prev.height}")
        scale = float(prev.meta.get("synthesis", {}).get("scale", 1.0))
        tol = p.depth_tolerance
        w1 = kr.inverse_depth(cd["Z"])
        lab = np.ascontiguousarray(cd["label.id"], np.uint32)
        u, v, q, ok = kr.transfer(w1, kr.relative_matrix(cam1, cam0), kr.intrinsics(cam1), kr.intrinsics(cam0),
                                  cam0.near)
        src_rgb = source.rgb()
        prev_rgb = prev.rgb()
        if p.colour == "map" and all(c in prev for c in CORRECTION):
            prev_res = prev.layer(CORRECTION)  # carried by Resynthesize: no second read of the source
        elif p.colour == "map":
            prev_res = prev_rgb - lookup(src_rgb, prev["source.x"], prev["source.y"], filter=p.filter)
        else:
            prev_res = prev_rgb
        prev_ext = prev["extension"].astype(np.float32, copy=False) if "extension" in prev else np.zeros(prev.shape, np.float32)
        valid, sx, sy, patch, res, ext = kr.gather_prev(
            u, v, q, ok, lab, kr.inverse_depth(prev["Z"]), np.ascontiguousarray(prev["label.id"], np.uint32),
            np.ascontiguousarray(prev["patch.id"], np.uint32), prev["source.x"].astype(np.float32, copy=False),
            prev["source.y"].astype(np.float32, copy=False), np.ascontiguousarray(prev_res, np.float32), prev_ext, tol, scale)
        # disoccluded pixels continue the patch of a kept neighbour of their label when the
        # continued source position still has that label: no new seam, nothing to redo
        have = valid
        src_lab = np.ascontiguousarray(source["label.id"], np.uint32)
        if p.fill_radius > 0 and not valid.all():
            sx, sy, patch, res, ext, filled = kr.fill_from_neighbours(~valid, valid, lab, sx, sy, patch, res, ext,
                                                                       p.fill_radius, scale)
            ext = np.where(filled, ext + 1.0, ext).astype(np.float32, copy=False)
            # a patch continued frame after frame would extrude its borders into streaks:
            # past extend_frames the continued band is flood-filled afresh instead
            filled &= fits_source(src_lab, sx, sy, lab, filled) & (ext <= p.extend_frames)
            have = valid | filled
        D = kt.map_deviation(sx, sy, have, kr.patch_links(have, patch, lab), scale)
        distorted, sx, sy = reanchor_distorted(have, patch, D, sx, sy, scale, p.threshold, p.spread, p.seed)
        absorbed, sx, sy, patch = absorb_fragments(have, patch, lab, sx, sy, scale, p.min_patch_area, src_lab,
                                                   p.min_patch_width)
        raw = np.zeros((H, W), np.uint32)
        raw[absorbed] = FLAG["reanchored"]
        if distorted.any():
            fits = fits_source(src_lab, sx, sy, lab, distorted)
            raw[distorted] = np.where(fits[distorted], FLAG["reanchored"], FLAG["distorted"])
        raw[~have] = FLAG["disoccluded"]
        raw[newly_occluded(cat, u, v, ok, lab, prev["label.id"])] = FLAG["newly_occluded"]
        flag = clean_flags(raw, radius=p.isolated_radius, min_neighbours=p.min_neighbours, dilate=p.dilate)
        flag[~have & (flag == 0)] = FLAG["disoccluded"]  # dropped as isolated, but nothing to carry
        share = float((flag > 0).mean())
        cut = share > p.cut_threshold
        if cut:
            ctx.note(f"camera cut: {100 * share:.1f}% of the frame flagged (> {100 * p.cut_threshold:.0f}%); "
                     "full synthesis of this frame")
            flag[:] = FLAG["disoccluded"]
        # re-anchored patches keep their (new) map; their old Poisson correction no longer fits
        keep = (flag == 0) | (flag == FLAG["reanchored"])
        D = np.where(flag == 0, D, 0.0).astype(np.float32, copy=False)
        ext = np.where(keep, ext, 0.0).astype(np.float32, copy=False)
        if p.colour == "map":
            res = np.where((flag == 0)[..., None], res, 0.0).astype(np.float32, copy=False)
            rgb = lookup(src_rgb, sx, sy, filter=p.filter) + res
        else:
            rgb = res
        rgb = np.where(keep[..., None], rgb, 0.0).astype(np.float32, copy=False)
        sx = np.where(keep, sx, 0.0).astype(np.float32, copy=False)
        sy = np.where(keep, sy, 0.0).astype(np.float32, copy=False)
        patch = np.where(keep, patch, 0).astype(np.uint32, copy=False)
        counts = {k: float((flag == v).mean()) for k, v in FLAG.items() if v}
        ctx.note(f"flagged {100 * share:.2f}%: " + ", ".join(f"{k} {100 * s:.2f}%" for k, s in counts.items()))
        ch = {"R": rgb[..., 0].copy(), "G": rgb[..., 1].copy(), "B": rgb[..., 2].copy(), "source.x": sx,
              "source.y": sy, "patch.id": patch, "distortion": D, "extension": ext, "flag": flag}
        if p.colour == "map":
            ch.update({c: res[..., k].copy() for k, c in enumerate(CORRECTION)})
        ch.update(geo)
        meta = self._meta(prev, cd)
        meta["temporal"] = dict(counts, flagged=float((flag > 0).mean()), cut=bool(cut), frame=int(ctx.frame),
                                filter=p.filter)
        return Plate(ch, meta)

    @staticmethod
    def _meta(state: Plate, cd: Plate) -> dict:
        meta = dict(state.meta)
        for k in ("camera", "up_axis", "objects", "scene", "background"):
            if k in cd.meta:
                meta[k] = cd.meta[k]
        return meta

    def _first(self, ctx, cd: Plate, geo: dict) -> Plate:
        H, W = cd.shape
        first = ctx.first
        if first is None:
            if ctx.frame != ctx.first_frame:
                ctx.note("no previous frame and no 'first' plate: full synthesis of this frame")
            z = np.zeros((H, W), np.float32)
            ch = {"R": z, "G": z, "B": z, "source.x": z, "source.y": z, "patch.id": np.zeros((H, W), np.uint32),
                  "distortion": z, "extension": z, "flag": np.full((H, W), FLAG["disoccluded"], np.uint32)}
            ch.update(geo)
            meta = dict(cd.meta)
            meta["temporal"] = dict(flagged=1.0, cut=True, frame=int(ctx.frame))
            return Plate(ch, meta)
        if first.shape != (H, W):
            raise ctx.error(f"first is {first.width}x{first.height}, depth {W}x{H}; connect plates of one resolution")
        ch = {c: first[c] for c in STATE}
        ch["distortion"] = np.zeros((H, W), np.float32)
        ch["extension"] = np.zeros((H, W), np.float32)
        ch["flag"] = np.zeros((H, W), np.uint32)
        ch.update({k: v for k, v in geo.items() if k != "label.id"})
        ch.update({c: first[c] for c in ("label.id", "Z", "P.X", "P.Y", "P.Z") if c in first})
        meta = self._meta(first, cd)
        meta["temporal"] = dict(flagged=0.0, cut=False, frame=int(ctx.frame))
        return Plate(ch, meta)
