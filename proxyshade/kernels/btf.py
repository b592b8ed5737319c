"""Kernels of view-consistent BTF stack synthesis.

Neubeck, Zalesny and Van Gool, "Viewpoint consistent texture synthesis" (3DPVT 2004).

* ``disk_distance`` (eq. 3): Σ_N w·‖out − in‖² over the disk 0 < u² + v² ≤ r² (a ``Disk``:
  offsets stepped by a level's factor in the input); ``pair_distance`` the other-view form
  Σ w‖B′ − B‖² + c(1 − w)‖A′ − A‖² (A the ``Support`` view). An input neighbour outside the input costs the
  maximal difference (``MAXV`` per channel, the paper's "maximal value of 255"); an
  output neighbour outside the output is no neighbour (weight 0).
* ``synth_level``: one level of the confidence-weighted sequential synthesis. A pixel is
  drawn with probability P = (1 − w) / Σ(1 − w) (integer weights T − k in a Fenwick
  tree, k = visits so far, w = k / T); its candidates are the current source and, for
  every disk neighbour, the input pixel that puts the neighbour's source "in the same
  relative neighbourhood position" (Ashikhmin 2001); it is updated only by a strictly
  better one; w += 1/T. Every pixel is visited until w = 1: T times from w = 0, T − k0
  from k0. Draws come from ``kernels.random.rand(seed, step, level, 0)``.
* ``synth_others``: every non-support view given the support, in parallel over views
  (each view sequential, its own seed): the same loop with ``pair_distance`` and the
  support's sources as extra candidates.
* ``sweep_costs``: plane-sweep photo-consistency of the support view against the others,
  per pixel and height: the heights of the sample the other views are cast through.
* ``edge_distance``: the alignment measure, the mean Euclidean distance between the
  intensities of two views over a crop, for each neighbouring pair of the view grid.
* ``plane_shift``: where a view rectified to one plane reads to be rectified to another.
* ``shade_views``: a surface shaded from a stack, per pixel: bilinear between the four
  views around its (slant, tilt) on the grid, each read bilinearly at its texture
  coordinates (wrapping: the stack tiles the plane).

Pure functions on arrays; the serial loops are deterministic, the parallel ones write
only their own view or pair, so 1 and 2 threads give identical results.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import JIT, PJIT
from proxyshade.kernels.random import rand

MAXV = 1.0  # the maximal channel difference (linear images in [0, 1])


def disk_offsets(r: int) -> np.ndarray:
    """(K, 2) int64 offsets (dy, dx) with 0 < dy² + dx² ≤ r², in row-major order."""
    r = int(r)
    return np.array([(dy, dx) for dy in range(-r, r + 1) for dx in range(-r, r + 1)
                     if 0 < dy * dy + dx * dx <= r * r], np.int64).reshape(-1, 2)


class Disk(NamedTuple):
    """The neighbourhood of eq. 3: ``offsets`` (K, 2) int64 (dy, dx) (``disk_offsets``),
    stepped ``out_step`` pixels in the output and ``in_step`` in the input (a level's
    scale: the neighbour n = p + o·out_step proposes q(n) − o·in_step); ``wrap``: the
    output is a torus (its neighbours wrap around its borders)."""
    offsets: np.ndarray
    out_step: int
    in_step: int
    wrap: bool


class Support(NamedTuple):
    """The support view's part of the other-view distance: its synthesis A′ (``out``
    (H, W, 3)), its input A (``inp``), its sources (``qy``, ``qx``: extra candidates) and
    the weight ``c`` of c(1 − w)‖A′ − A‖². ``on`` False: the single-view distance (eq. 3)."""
    out: np.ndarray
    inp: np.ndarray
    qy: np.ndarray
    qx: np.ndarray
    c: float
    on: bool


def disk(r: int, out_step: int = 1, in_step: int = 1, wrap: bool = False) -> Disk:
    """The ``Disk`` of radius ``r`` with numba-stable types (int64 steps, bool wrap)."""
    return Disk(disk_offsets(r), np.int64(out_step), np.int64(in_step), bool(wrap))


def no_support() -> Support:
    """A ``Support`` that is off: the single-view distance (eq. 3) and candidates."""
    img, q = np.zeros((1, 1, 3), np.float32), np.zeros((1, 1), np.int64)
    return Support(img, img, q, q, 0.0, False)


@njit(**JIT)
def _disk_sum(out, k, T, inp, sup, py, px, cy, cx, dk, bound):
    """Σ over the disk ``dk`` of w‖out − in‖² at output (py, px) against input (cy, cx),
    plus c (1 − w)‖A′ − A‖² when the support ``sup`` is on; w = k / T. Stops once the sum
    exceeds ``bound``."""
    H, W = out.shape[0], out.shape[1]
    h, w = inp.shape[0], inp.shape[1]
    offs, so, si = dk.offsets, dk.out_step, dk.in_step
    pair = sup.on
    acc = 0.0
    for o in range(offs.shape[0]):
        qy = py + offs[o, 0] * so
        qx = px + offs[o, 1] * so
        if dk.wrap:
            qy %= H
            qx %= W
        elif qy < 0 or qy >= H or qx < 0 or qx >= W:
            continue
        wt = k[qy, qx] / T
        wa = sup.c * (1.0 - wt) if pair else 0.0
        if wt == 0.0 and wa == 0.0:
            continue
        iy = cy + offs[o, 0] * si
        ix = cx + offs[o, 1] * si
        if iy < 0 or iy >= h or ix < 0 or ix >= w:
            acc += (wt + wa) * 3.0 * MAXV * MAXV
        else:
            db = 0.0
            da = 0.0
            for c in range(3):
                e = np.float64(out[qy, qx, c]) - np.float64(inp[iy, ix, c])
                db += e * e
                if pair:
                    f = np.float64(sup.out[qy, qx, c]) - np.float64(sup.inp[iy, ix, c])
                    da += f * f
            acc += wt * db + wa * da
        if acc > bound:
            return acc
    return acc


@njit(**JIT)
def disk_distance(out, k, T, inp, py, px, cy, cx, dk, bound):
    """eq. 3 at output pixel (py, px) against input pixel (cy, cx): Σ w‖out − in‖² over the
    ``Disk`` ``dk`` (its steps a level's scale), w = k / T; stops once the sum exceeds
    ``bound``."""
    return _disk_sum(out, k, T, inp, Support(out, inp, k, k, 0.0, False), py=py, px=px, cy=cy, cx=cx, dk=dk,
                     bound=bound)


@njit(**JIT)
def pair_distance(out_b, k, T, inp_b, sup, py, px, cy, cx, dk, bound):
    """Other-view distance at (py, px) against input (cy, cx): Σ w‖B′ − B‖² +
    c (1 − w)‖A′ − A‖² over the ``Disk`` ``dk`` (A the ``Support``, B this view)."""
    return _disk_sum(out_b, k, T, inp_b, sup, py=py, px=px, cy=cy, cx=cx, dk=dk, bound=bound)


@njit(**JIT)
def _fenwick_add(tree, i, v):
    i += 1
    n = tree.shape[0]
    while i < n:
        tree[i] += v
        i += i & (-i)


@njit(**JIT)
def _fenwick_find(tree, r):
    """The index whose cumulative weight range holds ``r`` (0 <= r < total)."""
    n = tree.shape[0] - 1
    pos = 0
    step = 1
    while step * 2 <= n:
        step *= 2
    while step > 0:
        nxt = pos + step
        if nxt <= n and tree[nxt] <= r:
            pos = nxt
            r -= tree[nxt]
        step //= 2
    return pos


@njit(**JIT)
def synth_level(inp, out, qy, qx, k, T, dk, seed, level, sup, visits):
    """One level of sequential synthesis, in place: ``out`` (H, W, 3) = ``inp`` at the
    sources (``qy``, ``qx``), confidences ``k`` (visits, w = k / T) raised to T, over the
    ``Disk`` ``dk`` (its steps a level's scale; wrapping: the result tiles without a
    seam). With the ``Support`` ``sup`` on, the other-view distance against it and its
    sources as extra candidates. ``visits`` counts the visits.
    Returns the number of updates."""
    H, W = out.shape[0], out.shape[1]
    h, w = inp.shape[0], inp.shape[1]
    offs, so, si, wrap = dk.offsets, dk.out_step, dk.in_step, dk.wrap
    pair = sup.on
    qay, qax = sup.qy, sup.qx
    n = H * W
    tree = np.zeros(n + 1, np.int64)
    total = 0
    for p in range(n):
        wt = T - k[p // W, p % W]
        if wt > 0:
            _fenwick_add(tree, p, wt)
            total += wt
    nc = offs.shape[0]
    step = 0
    changed = 0
    while total > 0:
        r = rand(seed, step, level, 0) % total
        step += 1
        p = _fenwick_find(tree, r)
        py = p // W
        px = p % W
        by = qy[py, px]
        bx = qx[py, px]
        best = _disk_sum(out, k, T, inp, sup, py=py, px=px, cy=by, cx=bx, dk=dk, bound=np.inf)
        ncand = 2 * nc + 1 if pair else nc
        for m in range(ncand):
            if m < 2 * nc:  # a neighbour's source shifted back: this view's map, then the support's
                mm = m % nc
                ny = py + offs[mm, 0] * so
                nx = px + offs[mm, 1] * so
                if wrap:
                    ny %= H
                    nx %= W
                elif ny < 0 or ny >= H or nx < 0 or nx >= W:
                    continue
                own = m < nc
                cy = (qy[ny, nx] if own else qay[ny, nx]) - offs[mm, 0] * si
                cx = (qx[ny, nx] if own else qax[ny, nx]) - offs[mm, 1] * si
            else:
                cy = qay[py, px]
                cx = qax[py, px]
            if cy < 0 or cy >= h or cx < 0 or cx >= w:
                continue
            if cy == by and cx == bx:
                continue
            d = _disk_sum(out, k, T, inp, sup, py=py, px=px, cy=cy, cx=cx, dk=dk, bound=best)
            if d < best:
                best = d
                by = cy
                bx = cx
        if by != qy[py, px] or bx != qx[py, px]:
            qy[py, px] = by
            qx[py, px] = bx
            for c in range(3):
                out[py, px, c] = inp[by, bx, c]
            changed += 1
        k[py, px] += 1
        visits[py, px] += 1
        _fenwick_add(tree, p, -1)
        total -= 1
    return changed


@njit(**JIT)
def gather(inp, qy, qx):
    """(H, W, 3) float32: ``inp`` at integer sources (qy, qx)."""
    H, W = qy.shape
    out = np.empty((H, W, 3), np.float32)
    for i in range(H):
        for j in range(W):
            for c in range(3):
                out[i, j, c] = inp[qy[i, j], qx[i, j], c]
    return out


@njit(**PJIT)
def synth_others(inp_b, sup, T, k0, dk, seeds, qy, qx, visits):
    """Every other view given the support, in parallel over views: view v starts from its
    own support sources ``sup.qy[v]``, ``sup.qx[v]`` (the support's sources as view v sees
    them) with w = k0 / T and runs ``synth_level`` with the pair distance against
    ``sup.out[v]`` (A′ as view v sees it: A at those sources) over the ``Disk`` ``dk``
    (seed ``seeds[v]``). Writes ``qy[v]``, ``qx[v]``, ``visits[v]``; returns updates per view."""
    V = inp_b.shape[0]
    H, W = sup.qy.shape[1], sup.qy.shape[2]
    changed = np.zeros(V, np.int64)
    for v in prange(V):
        for i in range(H):
            for j in range(W):
                qy[v, i, j] = sup.qy[v, i, j]
                qx[v, i, j] = sup.qx[v, i, j]
        k = np.full((H, W), k0, np.int64)
        out = gather(inp_b[v], qy[v], qx[v])
        view_sup = Support(sup.out[v], sup.inp, sup.qy[v], sup.qx[v], sup.c, True)
        changed[v] = synth_level(inp=inp_b[v], out=out, qy=qy[v], qx=qx[v], k=k, T=T, dk=dk, seed=seeds[v], level=0,
                                 sup=view_sup, visits=visits[v])
    return changed


@njit(**PJIT)
def sweep_costs(images, ref, shifts, offsets, tau, out):
    """Plane-sweep photo-consistency of view ``ref`` against the others, in place in ``out``
    (M, h, w) float32: for each height offset ``offsets[m]`` (world units above the views'
    plane) and pixel (i, j) of ``ref``, the mean over the other views n of
    min(‖I_n(j + shifts[n, 0]·o, i + shifts[n, 1]·o) − I_ref(i, j)‖², ``tau``) (I_n read
    bilinearly; a view whose read falls outside it does not count; no view: ``tau``).
    ``shifts`` (V, 2): the pixels (column, row) a point moves in view n per world unit of
    height (``plane_shift`` of a unit height)."""
    V, h, w = images.shape[0], images.shape[1], images.shape[2]
    M = offsets.shape[0]
    for i in prange(h):
        for m in range(M):
            for j in range(w):
                acc = 0.0
                cnt = 0
                for n in range(V):
                    if n == ref:
                        continue
                    x = j + shifts[n, 0] * offsets[m]
                    y = i + shifts[n, 1] * offsets[m]
                    if x < 0.0 or x > w - 1.0 or y < 0.0 or y > h - 1.0:
                        continue
                    x0 = int(math.floor(x))
                    y0 = int(math.floor(y))
                    fx = x - x0
                    fy = y - y0
                    x1 = min(x0 + 1, w - 1)
                    y1 = min(y0 + 1, h - 1)
                    d = 0.0
                    for c in range(3):
                        val = ((1.0 - fy) * ((1.0 - fx) * images[n, y0, x0, c] + fx * images[n, y0, x1, c])
                               + fy * ((1.0 - fx) * images[n, y1, x0, c] + fx * images[n, y1, x1, c]))
                        e = val - images[ref, i, j, c]
                        d += e * e
                    acc += min(d, tau)
                    cnt += 1
                out[m, i, j] = acc / cnt if cnt > 0 else tau
    return out


@njit(**PJIT)
def edge_distance(stack, edges, y0, y1, x0, x1):
    """(E,) mean over the crop rows y0:y1, columns x0:x1 of ‖stack[a] − stack[b]‖ (the
    Euclidean distance of the RGB intensities) for each pair (a, b) of ``edges``."""
    E = edges.shape[0]
    out = np.zeros(E, np.float64)
    for e in prange(E):
        a = edges[e, 0]
        b = edges[e, 1]
        acc = 0.0
        for i in range(y0, y1):
            row = 0.0
            for j in range(x0, x1):
                d = 0.0
                for c in range(3):
                    t = np.float64(stack[a, i, j, c]) - np.float64(stack[b, i, j, c])
                    d += t * t
                row += math.sqrt(d)
            acc += row
        out[e] = acc / max((y1 - y0) * (x1 - x0), 1)
    return out


def plane_shift(slant_deg: float, tilt_deg: float, dh: float, pixel: float) -> tuple[float, float]:
    """(dx, dy) in pixels: a view rectified to a plane reads at (col + dx, row + dy) to be
    rectified to the parallel plane ``dh`` world units higher (columns along x, rows along
    z, the camera toward (sin θ cos φ, cos θ, sin θ sin φ)): −dh tan θ (cos φ, sin φ) / pixel."""
    t = math.tan(math.radians(slant_deg)) * dh / pixel
    return -t * math.cos(math.radians(tilt_deg)), -t * math.sin(math.radians(tilt_deg))


@njit(**JIT)
def _tilt_bracket(tilts, spans, phi):
    """(j0, j1, b): the tilts around ``phi`` (degrees) and the weight of ``j1``. ``tilts``
    sorted in [0, 360); ``spans[j]``: the arc from tilts[j] to the next (cyclically) is
    sampled (interpolated across); in an unsampled arc, the nearer end (b = 0)."""
    nt = tilts.shape[0]
    if nt <= 1:
        return 0, 0, 0.0
    phi = phi - 360.0 * math.floor(phi / 360.0)
    j = nt - 1
    for m in range(nt):
        if tilts[m] <= phi:
            j = m
    lo = tilts[j]
    if phi < lo:
        lo -= 360.0
    jn = (j + 1) % nt
    hi = tilts[jn] + (360.0 if jn == 0 else 0.0)
    if hi - lo <= 0.0:
        return j, j, 0.0
    b = (phi - lo) / (hi - lo)
    if spans[j]:
        return j, jn, b
    if b < 0.5:
        return j, j, 0.0
    return jn, jn, 0.0


class ShadeGrid(NamedTuple):
    """A stack's views on their grid, for ``shade_views``: ``table`` (K + 1, nt) int64, the
    view at slant k·``step`` and tilt ``tilts[j]`` (row 0 the frontal view for every
    tilt); ``tilts`` (nt,) sorted in [0, 360); ``spans[j]``: the arc from tilt j to the
    next is sampled (``synthesis.btf.shade_grid``)."""
    table: np.ndarray
    step: float
    tilts: np.ndarray
    spans: np.ndarray


@njit(**PJIT)
def shade_views(views, grid, u, v, slant, tilt, mask, out):
    """Shade the pixels of ``mask`` from a stack, in place in ``out`` (H, W, 3) float32.

    ``views`` (V, h, w, 3) on the ``ShadeGrid`` ``grid``; ``u``, ``v`` the texture
    coordinates (column, row; pixel centres at integers; wrapped); ``slant``, ``tilt`` the
    view direction in the surface frame (degrees). Bilinear in (slant, tilt) between the
    four views around it (slant clamped to [0, K·step]; tilt by ``_tilt_bracket``), each
    view bilinear in (u, v)."""
    table, step, tilts, spans = grid.table, grid.step, grid.tilts, grid.spans
    h, w = views.shape[1], views.shape[2]
    K = table.shape[0] - 1
    H, W = mask.shape
    for i in prange(H):
        for j in range(W):
            if not mask[i, j]:
                continue
            s = slant[i, j] / step if step > 0.0 else 0.0
            s = min(max(s, 0.0), float(K))
            k0 = min(int(math.floor(s)), max(K - 1, 0))
            a = s - k0
            k1 = min(k0 + 1, K)
            j0, j1, b = _tilt_bracket(tilts, spans, tilt[i, j])
            x = u[i, j]
            y = v[i, j]
            fx0 = math.floor(x)
            fy0 = math.floor(y)
            fx = x - fx0
            fy = y - fy0
            x0 = int(fx0) % w
            y0 = int(fy0) % h
            x1 = (x0 + 1) % w
            y1 = (y0 + 1) % h
            r = 0.0
            g = 0.0
            bl = 0.0
            for m in range(4):
                kk = k0 if m < 2 else k1
                jj = j0 if m % 2 == 0 else j1
                wv = (1.0 - a if m < 2 else a) * (1.0 - b if m % 2 == 0 else b)
                if wv == 0.0:
                    continue
                n = table[kk, jj]
                w00 = wv * (1.0 - fy) * (1.0 - fx)
                w01 = wv * (1.0 - fy) * fx
                w10 = wv * fy * (1.0 - fx)
                w11 = wv * fy * fx
                r += (w00 * views[n, y0, x0, 0] + w01 * views[n, y0, x1, 0] + w10 * views[n, y1, x0, 0]
                      + w11 * views[n, y1, x1, 0])
                g += (w00 * views[n, y0, x0, 1] + w01 * views[n, y0, x1, 1] + w10 * views[n, y1, x0, 1]
                      + w11 * views[n, y1, x1, 1])
                bl += (w00 * views[n, y0, x0, 2] + w01 * views[n, y0, x1, 2] + w10 * views[n, y1, x0, 2]
                       + w11 * views[n, y1, x1, 2])
            out[i, j, 0] = r
            out[i, j, 1] = g
            out[i, j, 2] = bl
