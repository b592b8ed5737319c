"""Parameter groups: each parameter of a shared synthesis step declared once.

A node inherits the groups of the steps it runs (``class PatchInit(FloodFill, Node)``);
the engine collects their ``Param`` declarations like the node's own. ``Group.of(p)``
reads a group's values from a node's ``ctx.p``; the layer function of that step takes
them as one argument.
"""
from __future__ import annotations

from types import SimpleNamespace
from typing import Any

from proxyshade.declare import Input, Param
from proxyshade.io.source import FAR_DISTANCE, MAX_FAR_FRACTION
from proxyshade.kernels.display import DEFAULT_CHANNELS, VIEWS, to_display


class ParamGroup:
    """Base of the parameter groups."""

    @classmethod
    def names(cls) -> list[str]:
        out: list[str] = []
        for base in reversed(cls.__mro__):
            out += [k for k, v in vars(base).items() if isinstance(v, Param) and k not in out]
        return out

    @classmethod
    def defaults(cls) -> SimpleNamespace:
        """This group's default values, as attributes (for calling the layer outside a node)."""
        return SimpleNamespace(**{k: getattr(cls, k).default for k in cls.names()})

    @classmethod
    def of(cls, p: Any, *also: str) -> SimpleNamespace:
        """This group's parameter values read from ``p`` (a node's ``ctx.p``), as attributes,
        with the node's own parameters named in ``also`` (e.g. its ``seed``)."""
        return SimpleNamespace(**{k: getattr(p, k) for k in [*cls.names(), *also]})


class PatchMetric(ParamGroup):
    """Eq. 1: contour-distance neighbourhoods plus w · Chamfer distance."""

    w = Param(float, 90.0, min=0.0, doc="weight of the Chamfer distance in eq. 1")
    max_distance = Param(float, 8.0, min=0.0, optional=True,
                         doc="clamp contour distances (level pixels); null = unclamped")
    interior = Param(float, 0.5, min=0.0, max=1.0,
                     doc="per label, contour distances are also clamped where this share of the label's source "
                         "pixels counts as interior: a guide region wider than its source region draws on that "
                         "share, not only on the source region's deepest middle; 0 = max_distance only")
    height_weight = Param(float, 16.0, min=0.0,
                          doc="weight of the difference of relative heights in the label's vertical run (0 at its "
                              "top, 1 at its bottom), in contour-distance units: keeps a sky's top-to-horizon "
                              "gradient; 0 = the paper's eq. 1")


class FloodFill(PatchMetric):
    """Patches grown by flood fill from random seeds (§5 step 1)."""

    threshold_scale = Param(float, 1.25, min=1.0,
                            doc="flood fill stops above threshold_scale * best + threshold_offset")
    threshold_offset = Param(float, 5.0, min=0.0, doc="see threshold_scale")


class TextureScale(ParamGroup):
    """The texture scale, read by the guide (§4) and the synthesis grid (§5)."""

    scale = Param(float, 1.0, min=0.01, max=100.0, doc="source pixels per output pixel (texture scale)")


class SynthesisGrid(TextureScale):
    """The synthesis grid (§5): output pixels per synthesis pixel and the texture scale."""

    factor = Param(int, 4, min=1, max=64, doc="output pixels per synthesis pixel (power of two; 1024 -> 256 is 4)")


class CoarseLevel(ParamGroup):
    """Where the correction starts: PatchInit checks the source holds it, Correct starts there."""

    coarse_size = Param(int, 32, min=4, doc="long edge of the coarsest level where correction starts")


class Correction(CoarseLevel, PatchMetric):
    """k-coherent correction, coarse to fine (§5 step 2)."""

    passes = Param(int, 5, min=0, doc="correction passes per level (each four parity sub-passes)")
    passes_finest = Param(int, 3, min=0, doc="correction passes at the synthesis size")
    k = Param(int, 2, min=0, max=16, doc="similarity set size (k-coherence); 0 = coherent candidates only")
    kappa = Param(float, 0.0, min=0.0, doc="penalty (x 1 + kappa) on similarity-set candidates; favours coherence")
    knn_iterations = Param(int, 2, min=0, doc="PatchMatch iterations for the similarity sets")
    uniformity = Param(float, 0.25, min=0.0,
                       doc="candidates' distances x (1 + uniformity x over-use of their source neighbourhood "
                           "relative to an even use of the label's source region): keeps the correction from "
                           "converging on the source's blandest patch; 0 = the paper")
    tone_balance = Param(float, 0.0, min=0.0, max=1.0,
                         doc="adds tone_balance x (r - 1) to that factor (at least 0.05), r = how often the "
                             "target uses the candidate's luma bin (16) within its label over how often the photo's "
                             "label holds it (off in the finest level's last 2 passes): favours the tones the "
                             "correction drops (a label's std falls 0.1-0.3 in Correct without it). At every level "
                             "(tone_spacing 1) the restored tones come back as islands with seams (bench_photos' "
                             "window chi2 up); graphs/first_frame.yaml takes 0.25 at tone_spacing 2; 0 = off")
    tone_spacing = Param(int, 1, min=1,
                         doc="tone_balance acts only at levels whose spacing (exemplar pixels per level pixel) is at "
                             "least this: 1 = every level, 2 = not at the synthesis size (the finest levels then "
                             "build coherent patches around the tones it restored)")
    tone_over_only = Param(bool, False,
                           doc="tone_balance charges only the tones the target over-uses (r - 1 clipped at 0, "
                               "Kopf et al. 2007's histogram reweighting) and gives rarer tones no bonus")
    tone_spread = Param(float, 0.0, min=0.0, max=4.0,
                        doc="adds tone_spread x d x (1 - (t - mean)^2 / V, clipped to +-1) to that factor, at the "
                            "levels of spread_spacing or more: in a label whose target luma varies less about its mean "
                            "than the photo label's (variance V, deficit d = 1 - variance ratio), candidates near "
                            "the mean pay and those farther than one photo std gain (off in the finest level's "
                            "last 2 passes); 0 = off")
    spread_spacing = Param(int, 1, min=1, doc="tone_spread acts only at levels whose spacing is at least this")
    tone_match = Param(float, 0.0, min=0.0, max=16.0,
                       doc="multiplies each candidate's distance by 1 + tone_match x (z_c - z_p)^2, z the luma's "
                           "z-score within its label (the level's colours), z_p that of the position the pixel "
                           "entered the level with, at the levels of match_spacing or more: a pixel keeps its "
                           "tone's deviation from the label's mean instead of taking a candidate's regressed "
                           "toward it (the similarity sets' nearest entries carry 0.45x a pixel's deviation at "
                           "spacing 8); 0 = off")
    match_spacing = Param(int, 2, min=1, doc="tone_match acts only at levels whose spacing is at least this")
    match_from = Param(str, "init", choices=("init", "level"),
                       doc="the tone a pixel keeps under tone_match: its position's in PatchInit's map (init) or in "
                           "the map entering the level (level)")
    use_rgb = Param(bool, True, doc="add the colour neighbourhood to the metric (the paper does)")
    radius = Param(str, "spacing", choices=("spacing", "level"),
                   doc="near-copy radius: one level pixel (spacing h) or 2^l exemplar pixels at level l")


class ColourFidelity(ParamGroup):
    """The colour-fidelity step before the Poisson solve (``synthesis.blend.layout_move``,
    ``synthesis.grain``): each label's layout and detail moved toward the photo's. Off in the
    graphs (docs/synthesis.md says why); a graph with a flat synthesized sky may turn it on."""

    layout = Param(bool, True, doc="first move each label's mean colour, by relative height in the label, onto the "
                                   "source photo's (low frequencies from the photo: a region's hue, a sky's "
                                   "top-to-horizon gradient); false = the synthesized colours' own")
    layout_keep = Param(float, 1.0, min=0.0, max=1.0,
                        doc="share of the synthesized colours' own top-to-bottom profile (about its mean) kept "
                            "under the photo's: 1 = kept (a pond's dark band under its bank), 0 = replaced by "
                            "the photo's (flattens such a region; exact where the synthesis already follows "
                            "the photo's profile, which 1 doubles)")
    layout_spread = Param(float, 2.0, min=1.0,
                          doc="with layout: most gain of a label's large-scale layers (65-513 px windows) when "
                              "their variation is raised to the photo's (a region of another shape holds less of "
                              "it: a pond against a river's bank reflections); never lowered; 1 = off")
    grain = Param(float, 2.0, min=1.0,
                  doc="most gain of a detail layer when the first frame's detail is matched to the photo's, "
                      "label by label and scale by scale (the source is graded and read again; later frames "
                      "read the same graded source): 1 = off")


class PoissonSolve(ColourFidelity):
    """Gradient-domain blending of patch seams (§5 step 3, §7), after the colour-fidelity step."""

    seams = Param(str, "source", choices=("source", "zero"),
                  doc="target gradient across patch seams: the source's through the map, or zero")
    screen = Param(float, 0.01, min=0.0,
                   doc="λ of a data term λ(u - f)²: 0 = pure Poisson (the paper; drifts far from label borders "
                       "and moves a frame's tones off the photo's: graphs/first_frame.yaml takes 1)")
    label_dirichlet = Param(bool, True, doc="keep pixels on boundaries between label ids (Γ2) unchanged")
    tol = Param(float, 1e-5, min=1e-12, max=1.0, doc="relative residual at which the solver stops")
    max_iter = Param(int, 100, min=1, doc="most conjugate-gradient iterations")


class EditSynthesis(FloodFill, Correction, PoissonSolve, SynthesisGrid):
    """The first frame's steps run as a restricted resynthesis (``synthesis.edit_colour``):
    what EditSynth hands the layer, with its ``seed``."""


class RestrictedSolve(ParamGroup):
    """How a resynthesis' restricted Poisson solve (``synthesis.resynthesis``) treats the
    pixels around the redone ones (Resynthesize; the editing step takes the defaults)."""

    extend_correction = Param(bool, False,
                              doc="continue the kept pixels' carried correction (the first frame's layout and "
                                  "seam corrections) onto the flagged pixels before the solve, as the harmonic "
                                  "function with their values, so a redone region keeps the tone around it instead "
                                  "of the plain source's (farm's water); off by default: the continuation crosses "
                                  "label borders and raises lake's water (docs/temporal.md)")
    kept_as_one = Param(bool, False,
                        doc="the restricted solve sees every kept pixel as one patch: between two kept pixels their "
                            "own difference, an edge touching a flagged pixel the source's gradient (inside a patch "
                            "too: a re-anchored region keeps no step of the carried correction at its border); "
                            "false: the patch ids as they are (kept pixels' seams in the solve blended again)")
    flagged_apart = Param(bool, False,
                          doc="(without kept_as_one) an edge between a flagged and a kept pixel takes the source's "
                              "gradient through both maps even inside one patch (a re-anchored region keeps no step "
                              "of the carried correction at its border), while the kept pixels keep their patch ids "
                              "(seams in solve_margin's ring blended again)")
    solve_margin = Param(int, 0, min=0, max=64,
                         doc="kept pixels within this many pixels of a flagged one are solved too, their own "
                             "differences kept (only a smooth change): a thin flagged band between two kept regions "
                             "spreads their mismatch over the ring instead of into its few seams, which the next "
                             "frames carry (the gradient creep, docs/temporal.md); 0: the flagged pixels only")
    gate_result = Param(bool, False,
                        doc="with Reproject's creep_gate: after the solve, the labels whose gradient over the first "
                            "frame's now passes the gate (and that the previous frame did not) are solved again "
                            "with the remedies above: the gate on this frame's result, not only on the previous "
                            "frame's (farm's water at frame 2, docs/temporal.md)")
    sor_thickness = Param(float, 32.0, min=0.0,
                          doc="restricted-Poisson regions at most this thick (2 x area / perimeter, pixels) are "
                              "solved by SOR on their own pixels, not by multigrid in a window around them (the "
                              "same system, to the solver's tol); 0: only regions in small boxes")


class Resynthesis(FloodFill, Correction, PoissonSolve, RestrictedSolve):
    """The steps a resynthesis runs (``synthesis.resynthesis``): what Resynthesize hands the
    layer, with its own ``factor``, ``scale``, ``seed`` and ``solve``."""


class Guidance(TextureScale):
    """Guidance synthesis (§4): the detailed label guide."""

    size = Param(int, 256, min=8, doc="synthesis size of the longer side, a power of two")
    start = Param(int, 64, min=8, doc="coarsest synthesis level, a power of two")
    k = Param(int, 5, min=1, max=16, doc="coherent candidates per neighbour (chosen among 4k)")
    passes = Param(int, 2, min=0, max=16, doc="correction passes per level (4 parity sub-passes each)")
    proxy_weight = Param(float, 1.0, min=0.0, doc="weight of agreement with the proxy guide")
    sample = Param(int, 48, min=4, max=1024, doc="random exemplar windows examined per similarity set")
    metric = Param(str, "chamfer", choices=("chamfer", "l2"), doc="'l2' = label colours, Gaussian stack, L2 (Fig. 3 baseline)")
    locked = Param(list, [], doc="label name pairs whose borders stay as in the proxy, e.g. [[sky, water]]")
    keep_adjacency = Param(bool, True, doc="reject candidates that put side by side labels that neither the source "
                                           "nor the proxy has side by side (chamfer metric only)")
    seed = Param(int, 0)


class SameSurface(ParamGroup):
    """When two depths are one surface (the frame-0 grid against the proxy, a pixel against
    the previous frame's)."""

    depth_tolerance = Param(float, 0.02, min=0.0, max=1.0,
                            doc="relative inverse-depth difference under which two depths are one surface")


class Carry(SameSurface):
    """Reprojection of the synthesis state into the next frame and its flags (§6.2)."""

    colour = Param(str, "map", choices=("map", "bilinear"),
                   doc="look colours up through the carried map (+ reprojected Poisson correction), or copy them")
    threshold = Param(float, 0.35, min=0.0,
                      doc="map deviation ||J - I|| (J: the carried map's Jacobian over the synthesis scale) above "
                          "which a pixel is resynthesized")
    magnify_threshold = Param(float, 0.0, min=0.0, max=1.0,
                              doc="> 0: a patch whose carried map magnifies the source (the mean smaller singular "
                                  "value of J over the synthesis scale below 1 - this, per patch as threshold's "
                                  "spread) is re-anchored too: a magnified texture blurs before ||J - I|| reaches "
                                  "threshold (kernels.temporal.map_stretch_patches)")
    magnify_gate = Param(float, 0.0, min=0.0,
                         doc="> 0, with magnify_threshold: the magnification re-anchoring only on labels whose mean "
                             "gradient (display luma) in the previous frame has fallen below this ratio to the first "
                             "frame's (as creep_gate's measure); 0: every label")
    spread = Param(float, 0.5, min=0.0, max=1.0,
                   doc="each patch's threshold is uniform in [(1 - spread) x threshold, threshold] (hashed from its "
                       "id and the seed): patches that distort together are redone at different frames, not as "
                       "one wave")
    filter = Param(str, "lanczos4", choices=("lanczos4", "flat4", "lanczos3", "bilinear"),
                   doc="reconstruction of the source at the carried (fractional) positions; bilinear blurs the "
                       "finest detail, flat4 (8x8 taps flat to 0.9 x Nyquist) keeps more of it than Lanczos-4")
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
    correction_filter = Param(str, "bilinear", choices=("bilinear", "flat4", "flat2"),
                              doc="how the previous frame's Poisson correction is read where a pixel lands (colour: "
                                  "map): bilinear within the nearest pixel's patch, or flat4 (lookup's 8x8 taps) / "
                                  "flat2 (4x4 taps flat to 0.5 x Nyquist, a quarter of the cost), clamped to the 4x4 "
                                  "pixels' range, where all taps lie in that patch (bilinear near seams): the "
                                  "correction's finest detail is not blurred away frame after frame")
    continue_tail = Param(float, 0.0, min=0.0, max=0.25,
                          doc="> 0: a disoccluded pixel does not continue a neighbour's patch onto a source pixel in "
                              "its label's lowest or highest this share of luminance (the label's rare looks: "
                              "clumps, ghosts), nor does a re-anchored copy or an absorbed fragment keep one: they "
                              "are resynthesized instead (synthesis.temporal.typical_labels)")
    continue_other = Param(bool, False,
                           doc="with continue_tail: a disoccluded pixel whose nearest kept neighbour's patch would "
                               "continue onto a rare look continues the next neighbour's (fill_radius) whose lands "
                               "on a typical pixel of its label, and is resynthesized only when none does (no new "
                               "patch where a neighbour's fits)")
    snap_to_label = Param(bool, False,
                          doc="a kept pixel whose carried source position lies off its label by at most half a "
                              "source pixel (on it half a pixel across: not resynthesized as stray) is moved onto "
                              "its label's pixel there, so its nearest source pixel is its own label's "
                              "(kernels.temporal.snap_to_label)")
    stranded_fringe = Param(int, 0, min=0, max=32,
                            doc="> 0: a kept pixel whose source pixel lies on its label's fringe in the source (next to "
                                "another label) but with no other label within this many pixels of it on screen is "
                                "resynthesized (the silhouette it was copied beside has moved on: a fleck)")
    stranded_tail = Param(float, 0.0, min=0.0, max=0.25,
                          doc="> 0, with stranded_fringe: only a fringe source pixel that is a rare look of its "
                              "label (luminance in its lowest or highest this share, as continue_tail's) makes a "
                              "kept pixel stranded: a fringe that looks like the rest of its label (a thin label's) "
                              "is left alone (synthesis.temporal.rare_fringe)")
    stranded_ratio = Param(float, 0.0, min=0.0,
                           doc="> 0, with stranded_tail: stranded_fringe only on the labels whose fringe pixels in "
                               "the source are rare looks at least this many times as often as their other pixels "
                               "(a fringe with a look of its own, as a sky's beside a mountain; 0: every label)")
    min_patch_area = Param(int, 16, min=0,
                           doc="patches smaller than this (pixels) continue the neighbouring patch they touch most "
                               "(flagged re-anchored); 0 keeps every fragment")
    min_patch_width = Param(float, 2.0, min=0.0,
                            doc="patches thinner than this (2 x area / perimeter, pixels) are fragments too")
    cut_threshold = Param(float, 0.5, min=0.0, max=1.0,
                          doc="share of flagged pixels above which the frame is a camera cut (full synthesis)")
    solve_continued = Param(bool, False,
                            doc="pixels continuing a neighbour's patch into a disocclusion are flagged 4 (map kept, "
                                "Poisson redone): the seams they make where they meet another patch are blended "
                                "(Resynthesize) instead of carried as they fell (docs/temporal.md)")
    creep_gate = Param(float, 0.0, min=0.0,
                       doc="> 0: the creep remedies (solve_continued, Resynthesize's kept_as_one, flagged_apart and "
                           "solve_margin) act only on labels whose mean gradient (display luma) in the previous "
                           "frame exceeds the first frame's by this ratio (meta temporal.gradient / rising), so a "
                           "label whose texture has not crept is not flattened by repeated solves; 0: everywhere")
    anchor = Param(bool, True,
                   doc="a pixel on a seam between first-frame patches takes the patch the first frame has at its "
                       "position (the seam rounded once, from the first frame), not the nearest previous pixel's "
                       "(rounded again every frame, the seam walks off the texture)")


def source_input(doc: str = "annotated source (SourceRead): R,G,B, label.id and its label table", *,
                 optional: bool = False) -> Input:
    """The annotated-source input every synthesis node declares: colours (finite) and
    uint32 label ids."""
    return Input(doc, optional=optional, channels=("R", "G", "B", "label.id"), finite=("R", "G", "B"),
                 dtype={"label.id": "uint32"}, fix="connect a SourceRead node")


class LabelMapSnap(ParamGroup):
    """How a source reader snaps its label map to the table's colours (§3's annotated exemplar)."""

    far_distance = Param(float, FAR_DISTANCE, min=0.0,
                         doc="8-bit RGB distance beyond which a label-map pixel is 'far' from every label colour")
    max_far_fraction = Param(float, MAX_FAR_FRACTION, min=0.0, max=1.0,
                             doc="fail when more label-map pixels than this are far from every label colour")


class DisplayView(ParamGroup):
    """How a plate is shown to people (Preview's PNG, Movie's GIF): ``kernels.display.to_display``'s
    options."""

    channels = Param(list, list(DEFAULT_CHANNELS), doc="one id/depth channel, or three colour channels")
    exposure = Param(float, 0.0, doc="stops of exposure for colour channels")
    view = Param(str, "shoulder", choices=VIEWS,
                 doc="colour view transform (kernels.display.view_transform): 'shoulder' rolls values above 0.9 "
                     "off smoothly toward white (a plate may exceed 1), 'clip' shows them all as white")

    @staticmethod
    def show(plate, p):
        """``plate`` as display-referred 8-bit RGB with the group's values in ``p``."""
        return to_display(plate, p.channels, p.exposure, p.view)
