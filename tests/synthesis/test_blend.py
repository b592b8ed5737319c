"""The blend layer: the restricted Poisson solve against the whole-frame solve, the
windows around regions, region thickness."""
import numpy as np
import pytest

from proxyshade.kernels import sor as ksor
from proxyshade.kernels import temporal as T
from proxyshade.synthesis import blend as B


def test_group_boxes_cover_every_component_with_a_margin():
    mask = np.zeros((60, 80), bool)
    mask[5:8, 5:9] = True
    mask[10:12, 6:10] = True  # near the first: merged (cheap)
    mask[40:55, 60:75] = True
    mask[0:60, 79] = True  # a border strip: clipped at the image
    _, boxes = T.components4(mask)
    groups = B.group_boxes(boxes, mask.shape, slack=64)
    seen = sorted(k for g in groups for k in g[4])
    assert seen == [1, 2, 3, 4]
    for r0, r1, c0, c1, ids in groups:
        for k in ids:
            b = boxes[k - 1]
            assert r0 <= max(0, b[0] - 1) and r1 >= min(60, b[1] + 2) and c0 <= max(0, b[2] - 1) and c1 >= min(80, b[3] + 2)
    assert len(groups) < 4


# windows with multigrid CG, or SOR on the free pixels (by box, or, an edit's update, by thickness)
@pytest.mark.parametrize("small,thin", [(0, None), (64, None), (0, 16)])
@pytest.mark.parametrize("screen", [0.0, 0.01])
def test_poisson_regions_equal_the_whole_frame_solve(screen, small, thin):
    from proxyshade.kernels import poisson as P

    rng = np.random.default_rng(12)
    h, w = 48, 56
    colors = rng.random((h, w, 3)).astype(np.float32)
    patch = (np.arange(h)[:, None] // 7 * 10 + np.arange(w)[None, :] // 9).astype(np.uint32)
    labels = np.ones((h, w), np.uint32)
    labels[:, 30:] = 2
    free = np.zeros((h, w), bool)
    free[4:15, 3:20] = True
    free[30:45, 25:50] = True  # crosses the label border
    free[20:22, 50:56] = True  # touches the image border
    src = rng.random((32, 32, 3)).astype(np.float32)
    sx = np.clip(np.arange(w)[None, :] * 0.5 + 0 * np.arange(h)[:, None], 0, 31).astype(np.float32)
    sy = np.clip(np.arange(h)[:, None] * 0.5 + 0 * np.arange(w)[None, :], 0, 31).astype(np.float32)
    gx, gy = P.seam_gradients(src, sx, sy, 0.5)
    ref, _ = P.poisson_transfer(colors, patch, labels, fixed=~free, values=colors, seam_gx=gx, seam_gy=gy,
                                screen=screen, tol=1e-7, max_iter=500)
    got, info = B.poisson_regions(colors, patch, labels, free, seams=ksor.Seams(src, sx, sy, 0.5), screen=screen,
                                  tol=1e-7, max_iter=500, slack=0, small=small, thin=thin)
    if small or thin:
        assert info["windows"] == 0 and info["sor_pixels"] == free.sum() - (free & P.contour_mask(labels)).sum()
    else:
        assert info["windows"] == 3 and info["window_pixels"] < h * w
    np.testing.assert_array_equal(got[~free], colors[~free])
    np.testing.assert_allclose(got, ref, atol=2e-4)


def test_region_thickness_is_twice_area_over_perimeter():
    mask = np.zeros((30, 40), bool)
    mask[2:5, 3:33] = True  # a band 3 px wide, 30 long
    mask[10:20, 10:20] = True  # a 10 x 10 square
    mask[25:30, 0:1] = True  # 5 x 1 at the image border (the border counts as outside)
    comp, boxes = T.components4(mask)
    got = B.region_thickness(mask, comp, len(boxes))
    np.testing.assert_allclose(got, [2 * 90 / 66, 2 * 100 / 40, 1.0])  # the last: 10 / 12, clamped to 1


@pytest.mark.parametrize("keep", [0.0, 1.0])
def test_layout_moves_a_region_mean_onto_the_photo_and_keeps_its_own_profile_as_asked(keep):
    """A pond synthesized darker than the photo's water, with a dark band at its top of its
    own (a bank's reflection); the photo's water is brighter and darkens downward."""
    from proxyshade.kernels import layout as KL

    h, w = 128, 64
    rows = ((np.arange(h) + 0.5) / h).astype(np.float32)[:, None, None]
    rng = np.random.default_rng(3)
    labels = np.ones((h, w), np.uint32)
    photo_enc = 0.65 - 0.2 * rows + 0.02 * rng.standard_normal((h, w, 3)).astype(np.float32)
    own_enc = 0.15 + 0.25 * (rows > 0.25) + 0.02 * rng.standard_normal((h, w, 3)).astype(np.float32)
    dec = lambda e: np.where(e <= 0.04045, e / 12.92, ((np.clip(e, 0, None) + 0.055) / 1.055) ** 2.4).astype(np.float32)
    out = KL.srgb_encode(B.layout_move(dec(own_enc), labels, dec(photo_enc), labels, keep=keep))
    # the mean goes onto the photo's whatever ``keep``
    np.testing.assert_allclose(out.mean((0, 1)), photo_enc.mean((0, 1)), atol=0.01)
    prof = lambda e: e.mean((1, 2))
    x = prof(own_enc) - prof(own_enc).mean()
    want = prof(photo_enc) + keep * x  # the photo's profile, plus the own one if kept
    got = prof(out)
    away = np.abs(rows[:, 0, 0] - 0.25) > 0.2  # the offset is smooth: not near the own step
    assert np.abs(got - want)[away][4:-4].max() < 0.03  # row profile: the photo's, plus the own one if kept
    step = lambda p: p[int(0.4 * h):].mean() - p[:int(0.15 * h)].mean()
    assert abs(step(got) - step(want)) < 0.04
    band = step(got) - step(prof(photo_enc))  # what the output's own band adds to the photo's profile
    assert band > 0.15 if keep else abs(band) < 0.04



def test_layout_gives_a_region_the_photo_hue_in_its_shadows_and_highlights_alike():
    """Vegetation synthesized too yellow, from deep shadow to sunlit, against a photo whose
    vegetation is greener: after the layout step every pixel has the photo's R/G and B/G
    (no blue or magenta cast in the shadows, as a per-channel offset gives), and the
    texture's light and shade stay."""
    from proxyshade.kernels import layout as KL

    h, w = 96, 96
    rng = np.random.default_rng(5)
    labels = np.ones((h, w), np.uint32)
    lum = (0.005 + 0.6 * rng.random((h, w)) ** 2).astype(np.float32)[..., None]
    own = lum * np.array([1.0, 0.9, 0.35], np.float32)  # yellow
    photo = (0.004 + 0.5 * rng.random((h, w)) ** 2).astype(np.float32)[..., None] * np.array([0.7, 0.9, 0.45],
                                                                                             np.float32)
    out = B.layout_move(own, labels, photo, labels, keep=1.0)
    ratio = out / out[..., 1:2]
    want = photo.mean((0, 1)) / photo.mean((0, 1))[1]
    dark, bright = lum[..., 0] < 0.02, lum[..., 0] > 0.3
    for m in (dark, bright):
        np.testing.assert_allclose(ratio[m].mean(0), want, rtol=0.02)
    assert ratio.std((0, 1)).max() < 1e-3  # one hue everywhere
    y = lambda x: KL.luma_encoded(x)[..., 0].ravel()
    assert np.corrcoef(y(out), y(own))[0, 1] > 0.99  # the texture's light and shade stay


def test_a_blended_frame_never_holds_negative_values():
    """Two patches each darkening to 0 across a seam with zero gradient: the solve carries
    the first's end on and overshoots below 0 (checked on the raw transfer); the frame and
    the restricted solve floor it at 0 and count it."""
    from types import SimpleNamespace

    from proxyshade.kernels import poisson as P

    h, w = 40, 48
    ramp = np.tile(np.linspace(0.3, 0.0, w // 2, dtype=np.float32), 2)  # two patches, each darkening to 0
    colors = np.repeat(np.broadcast_to(ramp, (h, w))[..., None], 3, axis=2).copy()
    patch = (np.arange(w)[None, :] // (w // 2) + 0 * np.arange(h)[:, None]).astype(np.uint32)
    labels = np.ones((h, w), np.uint32)
    raw, _ = P.poisson_transfer(colors, patch, labels, screen=0.01, tol=1e-7, max_iter=300, seam_gx=None, seam_gy=None)
    assert raw.min() < 0  # the test's premise
    solve = SimpleNamespace(layout=False, seams="zero", label_dirichlet=True, screen=0.01, tol=1e-7, max_iter=300,
                            grain=1.0, layout_keep=1.0, layout_spread=1.0)
    u, info = B.blend_frame(colors, patch, labels, solve)
    assert u.min() >= 0 and info["negative"] == int((raw < 0).sum())
    np.testing.assert_array_equal(u[raw >= 0], raw[raw >= 0])
    free = np.ones((h, w), bool)
    free[:, :4] = False  # kept pixels stay as they came, negative or not
    colors[:, :4] = -0.01
    r, rinfo = B.blend_regions(colors, patch, labels, free, solve, source_rgb=None, sx=None, sy=None, scale=1.0,
                               filter="bilinear")
    assert r[free].min() >= 0 and rinfo["negative"] > 0
    np.testing.assert_array_equal(r[~free], colors[~free])
