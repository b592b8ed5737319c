"""Red-black SOR on listed pixels for the Poisson correction A v = b of ``kernels.poisson``:
many small free regions (a frame update, an edit), each swept on its own until its own
residual has fallen by ``tol``, a thread owning whole regions.

References
----------
Bonneel, van de Panne, Lefebvre, Drettakis. Proxy-Guided Texture Synthesis for Rendering
Natural Scenes. INRIA RR-7298, 2010 (§5 step 3, §6.3: the restricted solve of a frame update).
D. M. Young. Iterative Solution of Large Linear Systems. Academic Press, 1971 (the
over-relaxation of a rectangle).
"""
from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import JIT, PJIT
from proxyshade.kernels.stencil import apply_at, fine_operator, neighbour_sum



class Seams(NamedTuple):
    """Where the seam gradients are read (``poisson.seam_gradients_at``): the ``source``
    colours (Hs, Ws, 3), the map ``sx``, ``sy`` (H, W) float32 into it, ``step`` source
    pixels per pixel, the reconstruction ``filter``."""

    source: np.ndarray
    sx: np.ndarray
    sy: np.ndarray
    step: float = 1.0
    filter: str = "bilinear"


class Regions(NamedTuple):
    """The listed pixels' regions in sweep order (``_sor_plan``): region k holds list
    entries ``starts[k]``..``starts[k + 1]``, its red pixels before ``mids[k]``; ``bins``
    the region ids of each thread from ``bin_start``."""

    starts: np.ndarray
    mids: np.ndarray
    bins: np.ndarray
    bin_start: np.ndarray


class ListedSystem(NamedTuple):
    """The correction equation at the listed pixels: each one's neighbours ``nb`` (n, 4)
    (``_list_neighbours``), diagonal ``dl`` (n,), right-hand side ``bl`` (n, 3) and
    over-relaxation ``omega`` (n,)."""

    nb: np.ndarray
    dl: np.ndarray
    bl: np.ndarray
    omega: np.ndarray


# ---------------------------------------------------------------------------
# many small free regions (a frame update): red-black SOR on the free pixels only


@njit(**PJIT)
def _sor_sweep(ii, jj, omega, diag, we, ws, b, v):
    """One over-relaxed Gauss-Seidel update of the listed pixels (all of one colour of the
    red-black ordering, so no two are neighbours: the order does not matter)."""
    h, w = diag.shape
    for k in prange(ii.shape[0]):
        i = ii[k]
        j = jj[k]
        n0, n1, n2 = neighbour_sum(diag, v, we, ws, i, j, h, w)
        inv = 1.0 / diag[i, j]
        o = omega[k]
        v[i, j, 0] += o * ((b[i, j, 0] + n0) * inv - v[i, j, 0])
        v[i, j, 1] += o * ((b[i, j, 1] + n1) * inv - v[i, j, 1])
        v[i, j, 2] += o * ((b[i, j, 2] + n2) * inv - v[i, j, 2])


RES_BLOCK = 4096  # listed pixels per partial sum of the residual norm


@njit(**PJIT)
def _residual_norm(ii, jj, diag, we, ws, b, v, out):
    """Per-channel residual norm over the listed pixels: partial sums over fixed blocks of
    the list in parallel, added in block order (the same number for any thread count, so
    the number of sweeps never depends on it)."""
    h, w = diag.shape
    n = ii.shape[0]
    nb = (n + RES_BLOCK - 1) // RES_BLOCK
    part = np.zeros((nb, 3))
    for blk in prange(nb):
        for k in range(blk * RES_BLOCK, min(n, (blk + 1) * RES_BLOCK)):
            i = ii[k]
            j = jj[k]
            a0, a1, a2 = apply_at(diag, we, ws, v, i, j)
            r0 = b[i, j, 0] - a0
            r1 = b[i, j, 1] - a1
            r2 = b[i, j, 2] - a2
            part[blk, 0] += r0 * r0
            part[blk, 1] += r1 * r1
            part[blk, 2] += r2 * r2
    out[:] = 0.0
    for blk in range(nb):
        for c in range(3):
            out[c] += part[blk, c]
    for c in range(3):
        out[c] = np.sqrt(out[c])


def solve_sor(fixed: np.ndarray, b: np.ndarray, rows: np.ndarray, cols: np.ndarray, omega: np.ndarray, *,
              screen: float = 0.0, tol: float, max_sweeps: int = 2000, check: int = 8) -> tuple[np.ndarray, dict]:
    """Solve A v = b (``solve_system``'s operator) on the listed free pixels by red-black SOR.

    For many small free regions, each bounded by fixed pixels, in a large frame: the work
    is proportional to the free pixels, not the frame. ``omega`` (one per listed pixel)
    should suit its region's size (``sor_omega``). Stops when every channel's residual
    norm over the listed pixels is at most ``tol`` times its initial norm (checked every
    ``check`` sweeps). Returns v (zero off the list) and {"iterations", "residual"}.
    """
    diag, we, ws = fine_operator(np.ascontiguousarray(fixed, np.bool_), np.float32(screen))
    b = np.ascontiguousarray(b, np.float32)
    v = np.zeros(b.shape, np.float32)
    red = (rows + cols) % 2 == 0
    lists = [(np.ascontiguousarray(rows[m], np.int64), np.ascontiguousarray(cols[m], np.int64),
              np.ascontiguousarray(omega[m], np.float64)) for m in (red, ~red)]
    ii = np.ascontiguousarray(rows, np.int64)
    jj = np.ascontiguousarray(cols, np.int64)
    r0 = np.zeros(3)
    _residual_norm(ii, jj, diag, we, ws, b, v, r0)
    if np.all(r0 == 0.0):
        return v, {"iterations": 0, "residual": 0.0}
    res = r0.copy()
    sweeps = 0
    while sweeps < max_sweeps:
        for _ in range(check):
            for a, c, o in lists:
                _sor_sweep(a, c, o, diag, we, ws, b, v)
        sweeps += check
        _residual_norm(ii, jj, diag, we, ws, b, v, res)
        if np.all(res <= tol * r0):
            break
    rel = float(np.max(np.where(r0 > 0, res / np.where(r0 > 0, r0, 1.0), 0.0)))
    return v, {"iterations": sweeps, "residual": rel}


@njit(inline="always", **JIT)
def _sor_run_inv(nb, inv, bl, omega, base, lo, hi, vl):
    """Over-relaxed Gauss-Seidel updates of list entries lo..hi, in list order, on the
    compact list (``nb``: list index of the east, west, south, north neighbour, -1 where
    there is none or it is fixed; ``inv[k - base]`` = 1 / the diagonal, taken once a region;
    ``bl``: right-hand side). The arithmetic of ``_sor_sweep``: a fixed neighbour's term there
    is exactly zero."""
    for k in range(lo, hi):
        n0 = 0.0
        n1 = 0.0
        n2 = 0.0
        for m in range(4):
            q = nb[k, m]
            if q >= 0:
                n0 += vl[q, 0]
                n1 += vl[q, 1]
                n2 += vl[q, 2]
        iv = inv[k - base]
        o = omega[k]
        vl[k, 0] += o * ((bl[k, 0] + n0) * iv - vl[k, 0])
        vl[k, 1] += o * ((bl[k, 1] + n1) * iv - vl[k, 1])
        vl[k, 2] += o * ((bl[k, 2] + n2) * iv - vl[k, 2])


@njit(**JIT)
def _run_residual(nb, dl, bl, lo, hi, vl, out):
    """Per-channel squared residual norm over list entries lo..hi, summed in list order
    (``apply_at``'s float32 arithmetic)."""
    out[:] = 0.0
    for k in range(lo, hi):
        d = dl[k]
        a0 = d * vl[k, 0]
        a1 = d * vl[k, 1]
        a2 = d * vl[k, 2]
        for m in range(4):
            q = nb[k, m]
            if q >= 0:
                a0 -= vl[q, 0]
                a1 -= vl[q, 1]
                a2 -= vl[q, 2]
        r0 = bl[k, 0] - a0
        r1 = bl[k, 1] - a1
        r2 = bl[k, 2] - a2
        out[0] += r0 * r0
        out[1] += r1 * r1
        out[2] += r2 * r2


@njit(**PJIT)
def _sor_regions(regions, system, vl, tol, check, max_sweeps, sweeps, rel):
    """Each region of ``regions`` (list entries starts[k]..starts[k + 1], its red pixels
    before ``mids[k]``) of the listed ``system`` swept on its own until its residual falls
    to ``tol`` times its initial one (``sweeps``, ``rel``: each region's sweeps and final
    relative residual). The regions are independent (fixed pixels between them): a thread
    owns whole regions (``bins``: region ids per thread, ``bin_start``), so the result does
    not depend on which thread sweeps which region, nor on the thread count."""
    starts, mids, bins, bin_start = regions
    nb, dl, bl, omega = system
    for t in prange(bin_start.shape[0] - 1):
        r0 = np.zeros(3)
        r = np.zeros(3)
        longest = 0
        for q in range(bin_start[t], bin_start[t + 1]):
            longest = max(longest, starts[bins[q] + 1] - starts[bins[q]])
        inv = np.empty(longest)  # a region's 1 / diagonal, once for all its sweeps
        for q in range(bin_start[t], bin_start[t + 1]):
            k = bins[q]
            lo = starts[k]
            hi = starts[k + 1]
            _run_residual(nb, dl, bl, lo, hi, vl, r0)
            if r0[0] == 0.0 and r0[1] == 0.0 and r0[2] == 0.0:
                continue
            for e in range(lo, hi):
                inv[e - lo] = 1.0 / dl[e]
            s = 0
            worst = 0.0
            while s < max_sweeps:
                for _ in range(check):
                    _sor_run_inv(nb, inv, bl, omega, lo, lo, mids[k], vl)  # red
                    _sor_run_inv(nb, inv, bl, omega, lo, mids[k], hi, vl)  # black
                s += check
                _run_residual(nb, dl, bl, lo, hi, vl, r)
                done = True
                worst = 0.0
                for c in range(3):
                    if r0[c] > 0.0:
                        e = np.sqrt(r[c] / r0[c])
                        worst = max(worst, e)
                        if e > tol:
                            done = False
                if done:
                    break
            sweeps[k] = s
            rel[k] = worst


@njit(**JIT)
def _list_neighbours(ii, jj, h, w):
    """(n, 4) list index of each listed pixel's east, west, south, north neighbour (-1:
    outside the image or not listed)."""
    pos = np.full((h, w), -1, np.int64)
    for k in range(ii.shape[0]):
        pos[ii[k], jj[k]] = k
    nb = np.full((ii.shape[0], 4), -1, np.int64)
    for k in range(ii.shape[0]):
        i = ii[k]
        j = jj[k]
        if j + 1 < w:
            nb[k, 0] = pos[i, j + 1]
        if j > 0:
            nb[k, 1] = pos[i, j - 1]
        if i + 1 < h:
            nb[k, 2] = pos[i + 1, j]
        if i > 0:
            nb[k, 3] = pos[i - 1, j]
    return nb


@njit(**JIT)
def _dense_ranks(a):
    """(rank of each value among the distinct values of ``a`` (non-negative ints), their
    count): ``np.unique(a, return_inverse=True)``'s inverse, by a table instead of a sort."""
    n = a.shape[0]
    top = 0
    for k in range(n):
        top = max(top, a[k])
    rank = np.zeros(top + 2, np.int64)
    for k in range(n):
        rank[a[k] + 1] = 1
    for v in range(1, top + 2):
        rank[v] += rank[v - 1]
    out = np.empty(n, np.int64)
    for k in range(n):
        out[k] = rank[a[k]]
    return out, rank[top + 1]


@njit(**JIT)
def _group_order(key, nkeys):
    """The stable order of ``key`` (ints in [0, nkeys)): a counting sort."""
    n = key.shape[0]
    start = np.zeros(nkeys + 1, np.int64)
    for k in range(n):
        start[key[k] + 1] += 1
    for v in range(nkeys):
        start[v + 1] += start[v]
    order = np.empty(n, np.int64)
    for k in range(n):
        order[start[key[k]]] = k
        start[key[k]] += 1
    return order


def _sor_plan(rows: np.ndarray, cols: np.ndarray, omega: np.ndarray, region: np.ndarray, threads: int | None,
              scan: bool = False):
    """How ``solve_sor_regions`` lays out its listed pixels: the list order (by region,
    red before black, then scan order), the regions' list ranges and red counts, and the
    regions shared between threads (decreasing expected work, each to the least loaded
    thread). ``scan``: rows, cols are in scan order and the region ids non-negative (a
    counting sort then gives the same order). Returns (order, om, starts, mids, size, bins, bin_start, nreg)."""
    black = (rows + cols) % 2
    if scan:  # region ids >= 0, rows, cols in scan order: a stable counting sort by (region, colour) keeps it
        reg, nreg = _dense_ranks(np.ascontiguousarray(np.asarray(region).ravel(), np.int64))
        order = _group_order(reg * 2 + black, 2 * nreg)
    else:
        _, reg = np.unique(np.asarray(region), return_inverse=True)
        reg = reg.ravel()
        nreg = int(reg.max()) + 1
        order = np.lexsort((cols, rows, black, reg))  # by region, red before black, then scan order
    om = np.ascontiguousarray(np.asarray(omega, np.float64)[order])
    reg = reg[order]
    nreg = int(nreg)
    starts = np.searchsorted(reg, np.arange(nreg + 1)).astype(np.int64)
    nred = np.bincount(reg, weights=black[order] == 0, minlength=nreg).astype(np.int64)
    mids = starts[:-1] + nred
    # balance: regions by decreasing expected work (pixels / (2 - omega) ~ pixels x width),
    # each to the least loaded thread
    nt = max(1, int(threads if threads is not None else numba.get_num_threads()))
    size = np.diff(starts).astype(np.float64)
    work = size / np.maximum(2.0 - np.maximum.reduceat(om, starts[:-1]), 1e-3)
    load = [0.0] * nt  # Python floats, the first least load's thread (np.argmin's): no array call per region
    owner = [0] * nreg
    first = np.argsort(-work, kind="stable")
    for k, wk in zip(first.tolist(), work[first].tolist()):
        t = min(range(nt), key=load.__getitem__)
        owner[k] = t
        load[t] += wk
    owner = np.asarray(owner, np.int64)
    bins = np.argsort(owner, kind="stable").astype(np.int64)
    bin_start = np.searchsorted(owner[bins], np.arange(nt + 1)).astype(np.int64)
    return order, om, starts, mids, size, bins, bin_start, nreg


def solve_sor_regions(fixed: np.ndarray, b: np.ndarray, rows: np.ndarray, cols: np.ndarray, omega: np.ndarray,
                      region: np.ndarray, *, screen: float = 0.0, tol: float, max_sweeps: int = 2000,
                      check: int = 8, threads: int | None = None) -> tuple[np.ndarray, dict]:
    """``solve_sor`` with each region converged on its own.

    ``region`` (one id per listed pixel) groups the listed pixels into independent
    problems: no listed pixel of one region is a 4-neighbour of another's (fixed pixels
    lie between them). Each region is swept (red-black, ``check`` sweeps between residual
    checks) until every channel's residual norm over its own pixels is at most ``tol``
    times its initial one: thin regions stop after a few sweeps instead of sweeping
    until the widest one has converged, and a thread sweeps whole regions with no
    synchronisation between sweeps. ``threads`` only balances the work (default numba's
    thread count); the result is the same for any value. Returns v (zero off the list)
    and {"iterations" (most sweeps of a region), "sweeps" (pixel sweeps / listed pixels),
    "residual" (largest relative residual of a region)}. ``solve_sor_at`` is the same
    solve built from the listed pixels alone.
    """
    diag, we, ws = fine_operator(np.ascontiguousarray(fixed, np.bool_), np.float32(screen))
    b = np.ascontiguousarray(b, np.float32)
    v = np.zeros(b.shape, np.float32)
    n = len(rows)
    if n == 0:
        return v, {"iterations": 0, "sweeps": 0.0, "residual": 0.0}
    rows = np.asarray(rows, np.int64)
    cols = np.asarray(cols, np.int64)
    order, om, starts, mids, size, bins, bin_start, nreg = _sor_plan(rows, cols, omega, region, threads)
    ii = np.ascontiguousarray(rows[order])
    jj = np.ascontiguousarray(cols[order])
    sweeps = np.zeros(nreg, np.int64)
    rel = np.zeros(nreg)
    # the listed pixels' unknowns, right-hand side, diagonal and neighbours, contiguous per region
    h, w = diag.shape
    nb = _list_neighbours(ii, jj, h, w)
    vl = np.zeros((n, 3), np.float32)
    system = ListedSystem(nb, np.ascontiguousarray(diag[ii, jj]), np.ascontiguousarray(b[ii, jj]), om)
    _sor_regions(Regions(starts, mids, bins, bin_start), system, vl, float(tol), int(check), int(max_sweeps), sweeps,
                 rel)
    v[ii, jj] = vl
    return v, {"iterations": int(sweeps.max()), "sweeps": float((sweeps * size).sum() / n),
               "residual": float(rel.max())}


@njit(**JIT)
def _seam_edges(rows, cols, patch, sx, sy, e):
    """The seam edges the right-hand side of the listed pixels reads: per listed pixel and
    neighbour (north, south, west, east, ``_rhs``'s order) across a patch seam, the edge's
    index (-1: no seam), and per edge the four source positions of ``seam_gradients``
    (f(s_a + e), f(s_a), f(s_c), f(s_c - e) with a the west / north end, c the other),
    float32 as there. An edge between two listed pixels is listed twice (the same
    numbers)."""
    h, w = patch.shape
    n = rows.shape[0]
    eid = np.full((n, 4), -1, np.int64)
    m = 0
    for k in range(n):
        i = rows[k]
        j = cols[k]
        for d in range(4):
            a = i + (d == 1) - (d == 0)
            b = j + (d == 3) - (d == 2)
            if a < 0 or a >= h or b < 0 or b >= w or patch[a, b] == patch[i, j]:
                continue
            eid[k, d] = m
            m += 1
    xs = np.empty(4 * m, np.float32)
    ys = np.empty(4 * m, np.float32)
    zero = np.float32(0.0)
    for k in range(n):
        i = rows[k]
        j = cols[k]
        for d in range(4):
            q = eid[k, d]
            if q < 0:
                continue
            # the edge's west / north end (ai, aj) and its other end (ci, cj)
            if d == 0:
                ai, aj, ci, cj = i - 1, j, i, j
            elif d == 1:
                ai, aj, ci, cj = i, j, i + 1, j
            elif d == 2:
                ai, aj, ci, cj = i, j - 1, i, j
            else:
                ai, aj, ci, cj = i, j, i, j + 1
            dx = e if d >= 2 else zero
            dy = e if d < 2 else zero
            xs[4 * q] = sx[ai, aj] + dx
            ys[4 * q] = sy[ai, aj] + dy
            xs[4 * q + 1] = sx[ai, aj]
            ys[4 * q + 1] = sy[ai, aj]
            xs[4 * q + 2] = sx[ci, cj]
            ys[4 * q + 2] = sy[ci, cj]
            xs[4 * q + 3] = sx[ci, cj] - dx
            ys[4 * q + 3] = sy[ci, cj] - dy
    return eid, xs, ys


@njit(**PJIT)
def _rhs_at(f, patch, rows, cols, nb, eid, fs, screen, bl, dl):
    """``_rhs`` and ``fine_operator``'s diagonal at the listed pixels only, in their
    arithmetic and order (a neighbour that is not listed is fixed, its correction 0);
    the seam gradient of edge q is 0.5 ((fs[4q] - fs[4q+1]) + (fs[4q+2] - fs[4q+3]))
    (``seam_gradients``; zero without ``fs``)."""
    h, w = patch.shape
    have = fs.shape[0] > 0
    half = np.float32(0.5)
    zero = np.float32(0.0)
    # the listed neighbour of direction d (north, south, west, east) is nb[k, (3, 2, 1, 0)[d]]
    for k in prange(rows.shape[0]):
        i = rows[k]
        j = cols[k]
        n = 0
        if i > 0:
            n += 1
        if i + 1 < h:
            n += 1
        if j > 0:
            n += 1
        if j + 1 < w:
            n += 1
        dl[k] = n + screen
        for c in range(3):
            bl[k, c] = 0.0
        pid = patch[i, j]
        for d in range(4):
            a = i + (d == 1) - (d == 0)
            b = j + (d == 3) - (d == 2)
            if a < 0 or a >= h or b < 0 or b >= w:
                continue
            if nb[k, 3 - d] < 0:  # fixed: its correction, 0
                for c in range(3):
                    bl[k, c] += zero
            if patch[a, b] != pid:
                q = eid[k, d]
                for c in range(3):
                    g = zero
                    if have:
                        g = half * ((fs[4 * q, c] - fs[4 * q + 1, c]) + (fs[4 * q + 2, c] - fs[4 * q + 3, c]))
                    if d == 1 or d == 3:  # u_p - u_south, u_p - u_east: the edge's gradient negated
                        g = -g
                    bl[k, c] += g - (f[i, j, c] - f[a, b, c])


def solve_sor_at(colors: np.ndarray, patch: np.ndarray, rows: np.ndarray, cols: np.ndarray, omega: np.ndarray,
                 region: np.ndarray, *, seams: Seams | None = None, screen: float = 0.0, tol: float,
                 max_sweeps: int = 2000, check: int = 8, threads: int | None = None) -> tuple[np.ndarray, dict]:
    """``solve_sor_regions`` of the correction equation with every pixel but the listed
    ones (``rows``, ``cols`` in scan order, as ``np.nonzero`` gives them) fixed, its
    right-hand side (``rhs``) and seam gradients (``seam_gradients_at`` read as ``seams``
    says; zero without) computed at the listed
    pixels only: bit for bit the frame-sized path's numbers, at a cost that follows the
    listed pixels (no frame-sized operator, right-hand side or gradient maps; region ids
    >= 0). Returns v ((n, 3) float32, the listed pixels' corrections in their order) and
    ``solve_sor_regions``'s info."""
    n = len(rows)
    if n == 0:
        return np.zeros((0, 3), np.float32), {"iterations": 0, "sweeps": 0.0, "residual": 0.0}
    h, w = patch.shape
    rows = np.ascontiguousarray(rows, np.int64)
    cols = np.ascontiguousarray(cols, np.int64)
    colors = np.ascontiguousarray(colors, np.float32)
    patch = np.ascontiguousarray(patch)
    order, om, starts, mids, size, bins, bin_start, nreg = _sor_plan(rows, cols, omega, region, threads, scan=True)
    ii = np.ascontiguousarray(rows[order])
    jj = np.ascontiguousarray(cols[order])
    nb = _list_neighbours(ii, jj, h, w)
    if seams is not None:
        eid, xs, ys = _seam_edges(ii, jj, patch, np.ascontiguousarray(seams.sx, np.float32),
                                  np.ascontiguousarray(seams.sy, np.float32), np.float32(seams.step))
        from proxyshade.kernels.lookup import lookup_many

        fs = lookup_many(seams.source, xs, ys, seams.filter)
    else:
        eid, fs = np.full((n, 4), -1, np.int64), np.zeros((0, 3), np.float32)
    bl = np.empty((n, 3), np.float32)
    dl = np.empty(n, np.float32)
    _rhs_at(colors, patch, ii, jj, nb, eid, fs, np.float32(screen), bl, dl)
    sweeps = np.zeros(nreg, np.int64)
    rel = np.zeros(nreg)
    vl = np.zeros((n, 3), np.float32)
    _sor_regions(Regions(starts, mids, bins, bin_start), ListedSystem(nb, dl, bl, om), vl, float(tol), int(check),
                 int(max_sweeps), sweeps, rel)
    v = np.empty((n, 3), np.float32)
    v[order] = vl
    return v, {"iterations": int(sweeps.max()), "sweeps": float((sweeps * size).sum() / n),
               "residual": float(rel.max())}


def sor_omega(rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """The optimal over-relaxation for a rows × cols rectangle with Dirichlet borders:
    2 / (1 + sqrt(1 − ρ²)), ρ = (cos(π / (rows + 1)) + cos(π / (cols + 1))) / 2 the Jacobi
    spectral radius (Young). A region's bounding box stands in for it."""
    rho = 0.5 * (np.cos(np.pi / (np.asarray(rows, np.float64) + 1.0)) + np.cos(np.pi / (np.asarray(cols, np.float64) + 1.0)))
    return 2.0 / (1.0 + np.sqrt(np.maximum(1.0 - rho * rho, 0.0)))
