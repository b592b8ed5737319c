"""View-consistent BTF stack synthesis (Neubeck, Zalesny and Van Gool 2004) on btf_bumps.

Speed (medians after JIT, 2 threads): support view 256² (r = 3) ≤ 3 s; each other view
(r = 2) ≤ 1.5 s; a 15-view stack ≤ 30 s. Quality, one 15-view stack synthesized three ways
(independent views, whole columns, sequential), on the non-support views: consistency
E_c = mean ‖A(q_v(p)) − A′(p)‖ and seams E_s = mean colour jump across edges whose sources
are not neighbours; pass: E_c(sequential) < E_c(independent), E_s(sequential) < E_s(columns).
Alignment: the chosen plane against the sample's heights, and the RMSE of a 27.5° view
interpolated from 25° and 30° with that plane and with planes outside the heights.
Shaded move (``--move`` alone, or after the rest): graphs/btf_move.yaml's stack (57 views, tilts
around the circle) synthesized sequentially (5 levels, tiled, parallax), sequentially without
parallax (the paper's other views), as independent views and with 3 levels untiled without
parallax, each shading the 12 frames of btf_move (BtfShade,
256²) against per-frame independent shading: frame-to-frame warp error, seams E_s, tile
seams of the stack and of the move (against the same pixels with the tile moved by half),
and the shard share at 60–70° of the stacks and the frames (against the view cast through
the synthesized surface with the sample's heights; bound: the input views tiled), and the
plane-sweep heights against the sample's. ``--figures DIR``: the docs images.
"""
import os
import sys
from pathlib import Path

import numba
import numpy as np

from harness import measure, table, write_jpeg
from proxyshade.graph.testing import run_node
from proxyshade.synthesis import btf

ROOT = Path(__file__).resolve().parents[1]
SCENE = str(ROOT / "samples/scenes/btf_bumps.usda")


def alignment():
    stack = run_node("BtfRender", {"scene": SCENE, "size": 128, "slant_step": 2.5, "slant_max": 30,
                                   "tilts": [0, 90]})
    aligned = run_node("BtfAlign", {}, {"stack": stack})
    lo, hi = stack.meta["btf"]["heights"]
    plane = aligned.meta["btf"]["plane"]
    views, imgs = btf.stack_arrays(stack)
    pixel = stack.meta["btf"]["pixel"]
    idx = {(v["slant"], v["tilt"]): n for n, v in enumerate(views)}
    sel = [idx[(25.0, 0.0)], idx[(27.5, 0.0)], idx[(30.0, 0.0)]]
    m = btf.max_shift(views, 2 * (hi - lo) + abs(lo), pixel) + 2

    def rmse(h):
        r = btf.rectify(imgs[sel], [views[n] for n in sel], h, pixel)
        return float(np.sqrt(((0.5 * (r[0] + r[2]) - r[1])[m:-m, m:-m] ** 2).mean()))

    print("\n## alignment (slants 0-30 step 2.5, tilts 0 and 90, 128²)")
    print(f"heights [{lo:.4f}, {hi:.4f}], chosen plane {plane:.4f}: "
          f"{'within' if lo <= plane <= hi else 'OUTSIDE'}")
    for name, h in (("chosen plane", plane), ("above the heights", hi + 0.5 * (hi - lo)),
                    ("below the heights", lo - 0.5 * (hi - lo)), ("rendered plane (0)", 0.0)):
        print(f"27.5° from 25° and 30°, {name:<20} h = {h:+.4f}: RMSE {rmse(h):.5f}")


def main():
    numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
    print(f"load average {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f} {os.getloadavg()[2]:.2f}, "
          f"{numba.get_num_threads()} threads")
    stack = run_node("BtfRender", {"scene": SCENE, "size": 160, "slant_step": 10, "slant_max": 70,
                                   "tilts": [0, 90]})
    aligned = run_node("BtfAlign", {}, {"stack": stack})
    views, imgs = btf.stack_arrays(aligned)
    V = len(views)
    s = btf.check_views(views)["index"][(0, 0.0)]
    out = (256, 256)
    pixel, plane = aligned.meta["btf"]["pixel"], aligned.meta["btf"]["plane"]
    geo = btf.stack_geometry(imgs, views, s, pixel, plane)
    qay, qax, _ = btf.synthesize_view(imgs[s], out, radius=3, T=4, levels=3, seed=1)
    one = [s, (s + 1) % V]
    rows = [
        (f"support view 256² (r = 3), input {imgs.shape[2]}²",
         measure(lambda: btf.synthesize_view(imgs[s], out, radius=3, T=4, levels=3, seed=1), repeat=5), 3.0),
        ("one other view 256² (r = 2)",
         measure(lambda: btf.synthesize_others(imgs[one], 0, qay, qax, radius=2, T=4, c=0.25, seed=1), repeat=5),
         1.5),
        (f"{V - 1} other views 256², parallel (per view)",
         {k: v / (V - 1) if k != "n" else v for k, v in
          measure(lambda: btf.synthesize_others(imgs, s, qay, qax, radius=2, T=4, c=0.25, seed=1),
                  repeat=3).items()}, 1.5),
        (f"heights from the {V} views (plane sweep, {imgs.shape[2]}²)",
         measure(lambda: btf.stack_geometry(imgs, views, s, pixel, plane), repeat=3), None),
        (f"{V}-view stack 256² (sequential, parallax; heights included)",
         measure(lambda: btf.synthesize_stack(imgs, s, out, seed=1,
                                              geometry=btf.stack_geometry(imgs, views, s, pixel, plane)),
                 repeat=3), 30.0),
    ]
    big = run_node("BtfRender", {"scene": SCENE, "size": 288, "window": 2.16 * 288 / 320, "slant_step": 70,
                                 "slant_max": 70, "tilts": [0]})
    _, bimgs = btf.stack_arrays(big)
    bimgs = bimgs[:, 16:-16, 16:-16]
    rows.append((f"paper size: support 512² (r = 3), input {bimgs.shape[2]}²",
                 measure(lambda: btf.synthesize_view(bimgs[0], (512, 512), radius=3, T=4, levels=3, seed=1),
                         repeat=3), None))
    table("BTF synthesis speed", rows)

    others = [n for n in range(V) if n != s]
    res = {}
    for mode in btf.MODES:
        qy, qx = btf.synthesize_stack(imgs, s, out, mode=mode, seed=1, geometry=geo)
        res[mode] = (btf.consistency_error(imgs, s, qy, qx)[others].mean(), btf.seam_error(imgs, qy, qx)[others].mean())
    print(f"\n## BTF synthesis quality, {V} views {imgs.shape[2]}² -> 256², non-support views")
    print(f"{'mode':<14} {'E_c':>8} {'E_s':>8}")
    for mode, (ec, es) in res.items():
        print(f"{mode:<14} {ec:8.4f} {es:8.4f}")
    ec_ratio = res["sequential"][0] / res["independent"][0]
    es_ratio = res["sequential"][1] / res["columns"][1]
    print(f"E_c(sequential) / E_c(independent) = {ec_ratio:.3f} ({'pass' if ec_ratio < 1 else 'FAIL'})")
    print(f"E_s(sequential) / E_s(columns)     = {es_ratio:.3f} ({'pass' if es_ratio < 1 else 'FAIL'})")
    alignment()
    shaded_move()


MOVE_TILTS = [0, 45, 90, 135, 180, 225, 270, 315]
STEEP = (60.0, 70.0)
MOVE_ORIGIN = [-0.5, -0.5]  # graphs/btf_move.yaml's: the tile's borders cross the plane at x, z = -0.5


def warp_error(frames, cams):
    """Mean over consecutive frames of the mean RGB distance between a surface pixel of frame
    t + 1 and frame t at the same surface point (P of frame t + 1 projected into camera t,
    read at the nearest pixel, where that pixel is on the surface too)."""
    errs = []
    for a, b, ca in zip(frames, frames[1:], cams):
        on_b = b["A"] == 1
        P = np.stack([b[f"P.{x}"] for x in "XYZ"], -1)[on_b].astype(np.float64)
        col, row, d = ca.project(P)
        j, i = np.floor(col).astype(np.int64), np.floor(row).astype(np.int64)
        ok = (d > 0) & (i >= 0) & (i < a.height) & (j >= 0) & (j < a.width)
        i, j = i[ok], j[ok]
        ok2 = a["A"][i, j] == 1
        ra = np.stack([a[c][i, j] for c in "RGB"], -1)[ok2]
        rb = np.stack([b[c][on_b][ok] for c in "RGB"], -1)[ok2]
        errs.append(float(np.sqrt(((ra - rb) ** 2).sum(-1)).mean()))
    return float(np.mean(errs)), errs


def frame_tile_jumps(frames, shifted, size):
    """(border, control): the mean RGB jump between 4-neighbour surface pixels of the shaded
    frames whose texture coordinates lie in different repeats of the tile (the tile's
    border runs between them), and over the same pixel pairs of ``shifted``: the frames
    shaded with the tile moved by half its size, where those pairs lie inside the tile.
    Same pixels, same footprint: border / control ≈ 1 when the border shows no seam."""
    border, control = [], []
    H, W = size
    for f, g in zip(frames, shifted):
        on = f["A"] == 1
        rgb = np.stack([f[c] for c in "RGB"], -1).astype(np.float64)
        ref = np.stack([g[c] for c in "RGB"], -1).astype(np.float64)
        tile = np.floor((f["btf.u"] + 0.5) / W) * 1000 + np.floor((f["btf.v"] + 0.5) / H)
        for a, b in (((slice(None), slice(None, -1)), (slice(None), slice(1, None))),
                     ((slice(None, -1), slice(None)), (slice(1, None), slice(None)))):
            cross = on[a] & on[b] & (tile[a] != tile[b])
            border.append(np.linalg.norm(rgb[a] - rgb[b], axis=-1)[cross])
            control.append(np.linalg.norm(ref[a] - ref[b], axis=-1)[cross])
    return float(np.concatenate(border).mean()), float(np.concatenate(control).mean())


def sample_heights(capture, aligned):
    """The sample's heights at each pixel of the aligned support view (the frontal one):
    ``height_views`` of the bundled sample, cropped as BtfAlign cropped the views."""
    from proxyshade.io import usd

    prims = [q for q in usd.scene_prims(usd.open_stage(SCENE), 1) if not q.cg and q.kind == "mesh"]
    pts, tris, nrm, _ = usd.world_meshes(prims)
    size = capture.width
    pixel = capture.meta["btf"]["pixel"]
    hv = btf.height_views(pts, tris, nrm, [{"slant": 0.0, "tilt": 0.0}], size=size, window=size * pixel)[0]
    m = int(round((aligned.meta["btf"]["origin"][0] - capture.meta["btf"]["origin"][0]) / pixel))
    return hv[m:size - m, m:size - m]


def stack_shards(imgs, views, qy, qx, s, heights, meta, margin, wrap):
    """Per steep view n: the input's 3×3 range (lo, hi) at the pixel it should show for the
    synthesized surface (``surface_hits``), on the output grid; and the share of the
    view's pixels outside it by more than ``margin`` (all, and the bright ones only)."""
    ranges, shares, bright = {}, [], []
    for n, v in enumerate(views):
        if v["slant"] not in STEEP:
            continue
        iy, ix = btf.surface_hits(heights, qy[s], qx[s], v["slant"], v["tilt"], meta["plane"], meta["pixel"],
                                  wrap=wrap)
        lum, lo, hi = btf.luma_range3(imgs[n])
        ranges[n] = (lo[iy, ix], hi[iy, ix])
        out = lum[qy[n], qx[n]]
        shares.append(btf.shard_mask(out, *ranges[n], margin).mean())
        bright.append((out > ranges[n][1] + margin).mean())
    return ranges, float(np.mean(shares)), float(np.mean(bright))


def move_shards(frames, g, ranges, size, margin):
    """The share of the shaded frames' surface pixels at 60–70° outside the union of the
    ranges of the four views they blend (``stack_shards``) by more than ``margin``."""
    H, W = size
    step = 360.0 / len(MOVE_TILTS)
    bad = tot = 0
    for f in frames:
        on = (f["A"] == 1) & (f["btf.slant"] >= STEEP[0]) & (f["btf.slant"] <= STEEP[1])
        if not on.any():
            continue
        ty = np.rint(f["btf.v"][on]).astype(np.int64) % H
        tx = np.rint(f["btf.u"][on]).astype(np.int64) % W
        j0 = np.floor(np.mod(f["btf.tilt"][on], 360.0) / step).astype(np.int64) % len(MOVE_TILTS)
        lo = np.full(on.sum(), np.inf)
        hi = np.full(on.sum(), -np.inf)
        for sl in STEEP:
            k = int(round(sl / g["step"]))
            for jj in (j0, (j0 + 1) % len(MOVE_TILTS)):
                for t in range(len(MOVE_TILTS)):
                    sel = jj == t
                    n = g["index"][(k, float(MOVE_TILTS[t]))]
                    lo[sel] = np.minimum(lo[sel], ranges[n][0][ty[sel], tx[sel]])
                    hi[sel] = np.maximum(hi[sel], ranges[n][1][ty[sel], tx[sel]])
        lum = np.stack([f[c][on] for c in "RGB"], -1).astype(np.float64) @ btf.LUMA
        bad += int(btf.shard_mask(lum, lo, hi, margin).sum())
        tot += int(on.sum())
    return bad / max(tot, 1), tot


def seam_share(qy, qx):
    """The share of a source map's 4-neighbour edges whose sources are not neighbours the
    same way (its seams)."""
    h = (qy[:, 1:] != qy[:, :-1]) | (qx[:, 1:] != qx[:, :-1] + 1)
    v = (qy[1:] != qy[:-1] + 1) | (qx[1:] != qx[:-1])
    return float((h.sum() + v.sum()) / (h.size + v.size))


MOVE_STACKS = {  # row: BtfSynth params
    "sequential": {"mode": "sequential"},
    "seq., no parallax": {"mode": "sequential", "parallax": False},
    "independent": {"mode": "independent"},
    "seq. 3 lv, no tile/par.": {"mode": "sequential", "levels": 3, "tile": False, "parallax": False},
}


def shaded_move():
    from proxyshade.io.usd import CameraInfo

    numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
    capture = run_node("BtfRender", {"scene": SCENE, "size": 160, "slant_step": 10, "slant_max": 70,
                                     "tilts": MOVE_TILTS})
    aligned = run_node("BtfAlign", {}, {"stack": capture})
    views, imgs = btf.stack_arrays(aligned)
    meta = aligned.meta["btf"]
    heights = sample_heights(capture, aligned)
    g = btf.check_views(views)
    margin = btf.local_spread([imgs[n] for n, v in enumerate(views) if v["slant"] in STEEP])
    src = run_node("SourceRead", {"table": str(ROOT / "samples/renoir/source.yaml")})
    shot = str(ROOT / "samples/scenes/btf_move.usda")
    proxies = [run_node("ProxyRender", {"scene": shot, "resolution": [256, 256], "labels": {"bumps": "vegetation"}},
                        {"source": src}, frame=f) for f in range(1, 13)]
    cams = [CameraInfo.from_meta(p.meta["camera"]) for p in proxies]
    # the bound, from the input views alone: the inputs repeated as tiles (every view the
    # same sources), whose only seams are the tile borders
    h, w = imgs.shape[1:3]
    ty, tx = np.mgrid[0:256, 0:256]
    ty, tx = ty % h, tx % w
    V = len(views)
    _, bt, bb = stack_shards(imgs, views, np.repeat(ty[None], V, 0), np.repeat(tx[None], V, 0), 0, heights, meta,
                             margin, False)
    bound_seams = seam_share(ty, tx)
    rows = {}
    for name, params in MOVE_STACKS.items():
        synth = run_node("BtfSynth", dict(params, size=[256, 256], seed=1), {"stack": aligned})
        V = len(views)
        qy = np.stack([synth[f"v{n}.sy"] for n in range(V)]).astype(np.int64)
        qx = np.stack([synth[f"v{n}.sx"] for n in range(V)]).astype(np.int64)
        s = synth.meta["btf"]["support"]
        others = [n for n in range(V) if n != s]
        es = float(btf.seam_error(imgs, qy, qx)[others].mean())
        out = btf.gather_stack(imgs, qy, qx)
        tj = np.mean([btf.tile_jumps(out[n]) for n in range(V)], 0)
        ranges, st, sb = stack_shards(imgs, views, qy, qx, s, heights, meta, margin, synth.meta["btf"]["tile"])
        frames = [run_node("BtfShade", {"label": "bumps", "origin": MOVE_ORIGIN}, {"stack": synth, "proxy": p})
                  for p in proxies]
        half = [o + qy.shape[2] // 2 * meta["pixel"] for o in MOVE_ORIGIN]
        shifted = [run_node("BtfShade", {"label": "bumps", "origin": half}, {"stack": synth, "proxy": p})
                   for p in proxies]
        we, per = warp_error(frames, cams)
        fj = frame_tile_jumps(frames, shifted, qy.shape[1:])
        sm, tot = move_shards(frames, g, ranges, qy.shape[1:], margin)
        rows[name] = (we, es, tj, fj, st, sb, sm, tot, per, synth.meta["btf"]["levels"], seam_share(qy[s], qx[s]))
    print(f"\n## shaded move: btf_move, 12 frames 256², stack {len(views)} views {imgs.shape[2]}² -> 256² "
          f"(shard margin {margin:.4f}: the median 3×3 luminance spread of the 60-70° input views)")
    print(f"{'stack':<24} {'levels':>6} {'warp err':>9} {'E_s':>7} {'tile seam stack':>16} {'tile seam move':>16} "
          f"{'shards stack':>13} {'(bright)':>9} {'seams':>6} {'per seam':>8} {'shards move':>12} {'px':>6}")
    for name, (we, es, tj, fj, st, sb, sm, tot, _, lv, ss) in rows.items():
        print(f"{name:<24} {lv:>6} {we:9.4f} {es:7.4f} {tj[0]:7.4f} / {tj[1]:.4f} {fj[0]:7.4f} / {fj[1]:.4f} "
              f"{100 * st:12.2f}% {100 * sb:8.2f}% {100 * ss:5.2f}% {st / ss:8.2f} {100 * sm:11.2f}% {tot:6d}")
    print(f"{'input tiled (the bound)':<24} {'':>6} {'':>9} {'':>7} {'':>16} {'':>16} {100 * bt:12.2f}% "
          f"{100 * bb:8.2f}% {100 * bound_seams:5.2f}% {bt / bound_seams:8.2f}")
    print("seams: the share of the support's 4-neighbour edges that are seams; per seam: shard share / seam share")
    st = rows["sequential"][4]
    print(f"shards, sequential {100 * st:.2f}% against {100 * bt:.2f}% for the input tiled "
          f"({'pass' if st <= bt else 'FAIL'}: no more than the input views repeated whole, the fewest seams)")
    est = btf.estimate_heights(imgs, views, g["index"][(0, 0.0)], meta["pixel"], meta["plane"])
    err = est - heights
    px70 = np.tan(np.radians(STEEP[1])) / meta["pixel"]
    print(f"heights from the views (plane sweep) against the sample's: RMSE {np.sqrt((err ** 2).mean()):.4f}, "
          f"median |error| {np.median(np.abs(err)):.4f} (world units; {np.sqrt((err ** 2).mean()) * px70:.2f} px "
          f"of parallax at {STEEP[1]:g}°), heights span {heights.max() - heights.min():.4f}")
    for name in rows:
        print(f"warp error per frame pair ({name}): " + " ".join(f"{e:.3f}" for e in rows[name][8]))
    r = rows["sequential"][0] / rows["independent"][0]
    print(f"warp error sequential / independent = {r:.3f} ({'pass' if r < 1 else 'FAIL'})")
    seam = rows["sequential"][3][0] / rows["sequential"][3][1]
    print(f"tile seam in the move, border / control jump = {seam:.2f} ({'pass' if seam < 1.2 else 'FAIL'}: "
          "< 1.2, the tile's border no more visible than its inside)")
    print("tile seam columns: stack = border / interior jump of the views; move = border / control (the same "
          "pixel pairs with the tile moved by half)")


def shard_figure(path: Path):
    """Before/after of the shards: the aligned input views at 60° tilt 0, 70° tilt 0 and 70°
    tilt 90 (rows), then the sequential stack without parallax (the paper: other views from
    the support's sources at the same pixel, before) and with it (after), 120² crops at
    100% (the move's grid, 57 views)."""
    capture = run_node("BtfRender", {"scene": SCENE, "size": 160, "slant_step": 10, "slant_max": 70,
                                     "tilts": MOVE_TILTS})
    aligned = run_node("BtfAlign", {}, {"stack": capture})
    views, imgs = btf.stack_arrays(aligned)
    idx = {(v["slant"], v["tilt"]): n for n, v in enumerate(views)}
    pick = [idx[(60.0, 0.0)], idx[(70.0, 0.0)], idx[(70.0, 90.0)]]
    before, after = (btf.stack_arrays(run_node("BtfSynth", {"size": [256, 256], "seed": 1, "parallax": on},
                                               {"stack": aligned}))[1] for on in (False, True))
    gap = np.ones((120, 4, 3), np.float32)
    rows = [np.concatenate([imgs[n, :120, :120], gap, before[n, 64:184, 64:184], gap, after[n, 64:184, 64:184]], 1)
            for n in pick]
    hgap = np.ones((4, rows[0].shape[1], 3), np.float32)
    write_jpeg(path, np.concatenate([rows[0], hgap, rows[1], hgap, rows[2]], 0))
    # the tile's border in the move's last (overhead) frame: BtfSynth with tile off, then on
    src = run_node("SourceRead", {"table": str(ROOT / "samples/renoir/source.yaml")})
    proxy = run_node("ProxyRender", {"scene": str(ROOT / "samples/scenes/btf_move.usda"), "resolution": [256, 256],
                                     "labels": {"bumps": "vegetation"}}, {"source": src}, frame=12)
    crops = []
    for tile in (False, True):
        synth = run_node("BtfSynth", {"size": [256, 256], "seed": 1, "tile": tile}, {"stack": aligned})
        f = run_node("BtfShade", {"label": "bumps", "origin": MOVE_ORIGIN}, {"stack": synth, "proxy": proxy})
        crops.append(np.stack([f[c] for c in "RGB"], -1)[40:200, 20:180])
    write_jpeg(path.with_name("btf_tile.jpg"), np.concatenate([crops[0], np.ones((160, 4, 3), np.float32), crops[1]], 1))


def figures(folder: Path):
    """The images of docs/btf.md: three views (input, then sequential, columns,
    independent) as 120² crops at 100%, and the contact sheet of a sequential stack
    (80² crops)."""
    from proxyshade.graph.plate import Plate
    from proxyshade.io.images import write_png
    from proxyshade.kernels.display import to_display

    def png(path, rgb):
        write_png(path, to_display(Plate({c: np.ascontiguousarray(rgb[..., i]) for i, c in enumerate("RGB")}),
                                   ["R", "G", "B"]))

    stack = run_node("BtfRender", {"scene": SCENE, "size": 160, "slant_step": 10, "slant_max": 70,
                                   "tilts": [0, 90]})
    aligned = run_node("BtfAlign", {}, {"stack": stack})
    views, imgs = btf.stack_arrays(aligned)
    idx = {(v["slant"], v["tilt"]): n for n, v in enumerate(views)}
    pick = [idx[(0.0, 0.0)], idx[(40.0, 0.0)], idx[(70.0, 90.0)]]
    s = pick[0]
    geo = btf.stack_geometry(imgs, views, s, aligned.meta["btf"]["pixel"], aligned.meta["btf"]["plane"])
    gap = np.zeros((128, 4, 3), np.float32)
    rows = [np.concatenate(sum([[imgs[n, :120, :120], gap[:120]] for n in pick], [])[:-1], 1)]
    for mode in btf.MODES:
        qy, qx = btf.synthesize_stack(imgs, s, (256, 256), mode=mode, seed=1, geometry=geo)
        out = btf.gather_stack(imgs, qy, qx)
        rows.append(np.concatenate(sum([[out[n, 64:184, 64:184], gap[:120]] for n in pick], [])[:-1], 1))
    hgap = np.zeros((4, rows[0].shape[1], 3), np.float32)
    png(folder / "btf_modes.png", np.concatenate(sum([[r, hgap] for r in rows], [])[:-1], 0))
    # the graph's grid (tilts 0, 30, 60, 90), sequential: 80² crops of every view
    stack = run_node("BtfRender", {"scene": SCENE, "size": 160, "slant_step": 10, "slant_max": 70,
                                   "tilts": [0, 30, 60, 90]})
    _, out = btf.stack_arrays(run_node("BtfSynth", {"size": [256, 256], "seed": 1},
                                       {"stack": run_node("BtfAlign", {}, {"stack": stack})}))
    png(folder / "btf_sheet.png", btf.contact_sheet(out[:, 80:160, 80:160], btf.stack_arrays(stack)[0], gap=2))
    shard_figure(folder / "btf_shards.jpg")


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--figures":
        figures(Path(sys.argv[2]))
    elif len(sys.argv) > 1 and sys.argv[1] == "--move":
        shaded_move()
    else:
        main()
