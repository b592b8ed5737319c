"""Gradient-domain transfer of synthesized colour: a multigrid Poisson solver.

The final step of fast guided synthesis (Bonneel et al. 2010, §5 step 3 and §7) solves,
for each of the three colour channels,

    Δu = Δ(f∘s)   in Ω,
    ∇u = 0        across Γ1 (boundaries between patches),
    u  = f∘s      on Γ2 (boundaries between different label ids),

where f∘s is the synthesized image (the source looked up through the coordinate map).
Discretely, on the 4-connected pixel graph: for every pixel p that is not fixed,

    Σ_{q ∈ N(p)} (u_p − u_q) = Σ_{q ∈ N(p)} g_pq,
    g_pq = (f∘s)_p − (f∘s)_q  if p and q are in the same patch, else 0,

so inside a patch the source's gradients are kept, across a patch seam the target
gradient is zero (the seam is blended away), and fixed pixels (label contours, plus an
optional caller mask, e.g. everything outside newly synthesized areas) keep their
values. Neighbours outside the image are absent (natural Neumann condition). A connected
set of free pixels that touches no fixed pixel is determined up to a constant; its mean
is set to the mean of f∘s over it.

The solver works on the correction v = u − f∘s (zero almost everywhere but along seams)
with conjugate gradients preconditioned by a multigrid V-cycle: red-black Gauss-Seidel
smoothing and Galerkin coarse operators of 2×2 aggregation (every level is again a
5-point stencil, so irregular fixed pixels need no special cases). All three channels
are swept together.

References
----------
P. Pérez, M. Gangnet, A. Blake. Poisson image editing. SIGGRAPH 2003.
A. McAdams, E. Sifakis, J. Teran. A parallel multigrid Poisson solver for fluids
simulation on large grids. SCA 2010.
D. Braess. Towards algebraic multigrid for elliptic problems of second order.
Computing 55, 1995 (over-correction of aggregation coarse grids).
"""
from __future__ import annotations

import numba
import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import JIT, PJIT
from proxyshade.kernels.distance import contour_mask

# ---------------------------------------------------------------------------
# operators: level = (diag, wE, wS); (A x)_p = diag_p x_p - sum_q w_pq x_q.
# diag == 0 marks a cell with no unknown (fixed).


@njit(inline="always", **JIT)
def _neighbour_sum(x, we, ws, i, j, h, w):
    """Sum over the 4 neighbours of (i, j) of edge weight × x, per channel (east weights
    ``we[i, j]`` join (i, j)-(i, j+1), south weights ``ws[i, j]`` join (i, j)-(i+1, j))."""
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    if j + 1 < w:
        c = we[i, j]
        s0 += c * x[i, j + 1, 0]
        s1 += c * x[i, j + 1, 1]
        s2 += c * x[i, j + 1, 2]
    if j > 0:
        c = we[i, j - 1]
        s0 += c * x[i, j - 1, 0]
        s1 += c * x[i, j - 1, 1]
        s2 += c * x[i, j - 1, 2]
    if i + 1 < h:
        c = ws[i, j]
        s0 += c * x[i + 1, j, 0]
        s1 += c * x[i + 1, j, 1]
        s2 += c * x[i + 1, j, 2]
    if i > 0:
        c = ws[i - 1, j]
        s0 += c * x[i - 1, j, 0]
        s1 += c * x[i - 1, j, 1]
        s2 += c * x[i - 1, j, 2]
    return s0, s1, s2


@njit(**PJIT)
def _fine_operator(fixed, screen):
    h, w = fixed.shape
    diag = np.zeros((h, w), np.float32)
    we = np.zeros((h, w), np.float32)
    ws = np.zeros((h, w), np.float32)
    for i in prange(h):
        for j in range(w):
            if fixed[i, j]:
                continue
            n = 0
            if i > 0:
                n += 1
            if i + 1 < h:
                n += 1
                if not fixed[i + 1, j]:
                    ws[i, j] = 1.0
            if j > 0:
                n += 1
            if j + 1 < w:
                n += 1
                if not fixed[i, j + 1]:
                    we[i, j] = 1.0
            diag[i, j] = n + screen
    return diag, we, ws


@njit(**PJIT)
def _coarsen(diag, we, ws, mass, alpha):
    """Coarse operator for 2x2 piecewise-constant aggregation: the Galerkin product
    P^T A P, its Laplacian part (edge weights, and the diagonal less the screening mass)
    divided by ``alpha``, its mass part (the screening term) kept exact."""
    h, w = diag.shape
    hc = (h + 1) // 2
    wc = (w + 1) // 2
    dc = np.zeros((hc, wc), np.float32)
    ec = np.zeros((hc, wc), np.float32)
    sc = np.zeros((hc, wc), np.float32)
    mc = np.zeros((hc, wc), np.float32)
    inv = 1.0 / alpha
    for I in prange(hc):
        for J in range(wc):
            d = 0.0
            m = 0.0
            i0 = 2 * I
            j0 = 2 * J
            for di in range(2):
                i = i0 + di
                if i >= h:
                    continue
                for dj in range(2):
                    j = j0 + dj
                    if j >= w:
                        continue
                    d += diag[i, j] - mass[i, j]
                    m += mass[i, j]
            # internal edges count twice (both off-diagonal entries)
            if i0 < h and j0 + 1 < w:
                d -= 2.0 * we[i0, j0]
            if i0 + 1 < h and j0 + 1 < w:
                d -= 2.0 * we[i0 + 1, j0]
            if i0 + 1 < h:
                d -= 2.0 * ws[i0, j0]
                if j0 + 1 < w:
                    d -= 2.0 * ws[i0, j0 + 1]
            dc[I, J] = d * inv + m
            mc[I, J] = m
            # east: fine edges from column j0+1 to j0+2
            if j0 + 2 < w:
                e = we[i0, j0 + 1]
                if i0 + 1 < h:
                    e += we[i0 + 1, j0 + 1]
                ec[I, J] = e * inv
            if i0 + 2 < h:
                s = ws[i0 + 1, j0]
                if j0 + 1 < w:
                    s += ws[i0 + 1, j0 + 1]
                sc[I, J] = s * inv
    return dc, ec, sc, mc


@njit(**JIT)
def _smooth_serial(diag, we, ws, x, b, color):
    """``_smooth`` on one thread (for the tiny coarsest level: no parallel launch). The
    cells of one colour do not neighbour each other, so the result is the same."""
    for i in range(diag.shape[0]):
        _smooth_row(diag, we, ws, x, b, color, i)


@njit(**JIT)
def _coarse_solve(diag, we, ws, x, b, sweeps):
    """The coarsest level of a V-cycle: from x = 0, ``sweeps`` red-black then ``sweeps``
    black-red Gauss-Seidel sweeps, in one compiled call."""
    x[...] = 0.0
    for _ in range(sweeps):
        _smooth_serial(diag, we, ws, x, b, 0)
        _smooth_serial(diag, we, ws, x, b, 1)
    for _ in range(sweeps):
        _smooth_serial(diag, we, ws, x, b, 1)
        _smooth_serial(diag, we, ws, x, b, 0)


@njit(inline="always", **JIT)
def _smooth_row(diag, we, ws, x, b, color, i):
    """Row i of a Gauss-Seidel half sweep on cells with (i + j) % 2 == color."""
    h, w = diag.shape
    j0 = (color + i) % 2
    for j in range(j0, w, 2):
        d = diag[i, j]
        if d == 0.0:
            continue
        n0, n1, n2 = _neighbour_sum(x, we, ws, i, j, h, w)
        s0 = b[i, j, 0] + n0
        s1 = b[i, j, 1] + n1
        s2 = b[i, j, 2] + n2
        inv = 1.0 / d
        x[i, j, 0] = s0 * inv
        x[i, j, 1] = s1 * inv
        x[i, j, 2] = s2 * inv


@njit(**PJIT)
def _smooth(diag, we, ws, x, b, color):
    """One Gauss-Seidel half sweep on cells with (i + j) % 2 == color, 3 channels."""
    for i in prange(diag.shape[0]):
        _smooth_row(diag, we, ws, x, b, color, i)


@njit(**PJIT)
def _residual(diag, we, ws, x, b, r):
    h, w = diag.shape
    for i in prange(h):
        for j in range(w):
            d = diag[i, j]
            if d == 0.0:
                r[i, j, 0] = 0.0
                r[i, j, 1] = 0.0
                r[i, j, 2] = 0.0
                continue
            n0, n1, n2 = _neighbour_sum(x, we, ws, i, j, h, w)
            s0 = b[i, j, 0] - d * x[i, j, 0] + n0
            s1 = b[i, j, 1] - d * x[i, j, 1] + n1
            s2 = b[i, j, 2] - d * x[i, j, 2] + n2
            r[i, j, 0] = s0
            r[i, j, 1] = s1
            r[i, j, 2] = s2


@njit(inline="always", **JIT)
def _jacobi_start_row(diag, x, b, color, i):
    for j in range(diag.shape[1]):
        d = diag[i, j]
        if (i + j) % 2 == color and d != 0.0:
            inv = 1.0 / d
            x[i, j, 0] = b[i, j, 0] * inv
            x[i, j, 1] = b[i, j, 1] * inv
            x[i, j, 2] = b[i, j, 2] * inv
        else:
            x[i, j, 0] = 0.0
            x[i, j, 1] = 0.0
            x[i, j, 2] = 0.0


@njit(**PJIT)
def _jacobi_start(diag, x, b, color):
    """x = 0 except cells of ``color``: b / diag (a red half-sweep from zero)."""
    for i in prange(diag.shape[0]):
        _jacobi_start_row(diag, x, b, color, i)


@njit(inline="always", **JIT)
def _apply_at(diag, we, ws, x, i, j):
    """(A x)_(i, j) for the three channels."""
    h, w = diag.shape
    d = diag[i, j]
    s0 = d * x[i, j, 0]
    s1 = d * x[i, j, 1]
    s2 = d * x[i, j, 2]
    if j + 1 < w:
        c = we[i, j]
        s0 -= c * x[i, j + 1, 0]
        s1 -= c * x[i, j + 1, 1]
        s2 -= c * x[i, j + 1, 2]
    if j > 0:
        c = we[i, j - 1]
        s0 -= c * x[i, j - 1, 0]
        s1 -= c * x[i, j - 1, 1]
        s2 -= c * x[i, j - 1, 2]
    if i + 1 < h:
        c = ws[i, j]
        s0 -= c * x[i + 1, j, 0]
        s1 -= c * x[i + 1, j, 1]
        s2 -= c * x[i + 1, j, 2]
    if i > 0:
        c = ws[i - 1, j]
        s0 -= c * x[i - 1, j, 0]
        s1 -= c * x[i - 1, j, 1]
        s2 -= c * x[i - 1, j, 2]
    return s0, s1, s2


@njit(inline="always", **JIT)
def _residual_restrict_row(diag, we, ws, x, b, rc, I):
    h, w = diag.shape
    for J in range(rc.shape[1]):
        rc[I, J, 0] = 0.0
        rc[I, J, 1] = 0.0
        rc[I, J, 2] = 0.0
    for i in range(2 * I, min(2 * I + 2, h)):
        for j in range(w):
            if diag[i, j] == 0.0:
                continue
            a0, a1, a2 = _apply_at(diag, we, ws, x, i, j)
            J = j >> 1
            rc[I, J, 0] += b[i, j, 0] - a0
            rc[I, J, 1] += b[i, j, 1] - a1
            rc[I, J, 2] += b[i, j, 2] - a2


@njit(**PJIT)
def _residual_restrict(diag, we, ws, x, b, rc):
    """rc = P^T (b - A x): the residual summed over each 2x2 aggregate."""
    for I in prange(rc.shape[0]):
        _residual_restrict_row(diag, we, ws, x, b, rc, I)


@njit(**PJIT)
def _matvec_dot(diag, we, ws, p, q, pq):
    """q = A p and pq[c] = <p, q> per channel (fixed summation order)."""
    h, w = diag.shape
    part = np.zeros((h, 3), np.float64)
    for i in prange(h):
        t0 = 0.0
        t1 = 0.0
        t2 = 0.0
        for j in range(w):
            if diag[i, j] == 0.0:
                q[i, j, 0] = 0.0
                q[i, j, 1] = 0.0
                q[i, j, 2] = 0.0
                continue
            a0, a1, a2 = _apply_at(diag, we, ws, p, i, j)
            q[i, j, 0] = a0
            q[i, j, 1] = a1
            q[i, j, 2] = a2
            t0 += np.float64(p[i, j, 0]) * a0
            t1 += np.float64(p[i, j, 1]) * a1
            t2 += np.float64(p[i, j, 2]) * a2
        part[i, 0] = t0
        part[i, 1] = t1
        part[i, 2] = t2
    for c in range(3):
        pq[c] = 0.0
    for i in range(h):
        for c in range(3):
            pq[c] += part[i, c]


@njit(**PJIT)
def _cg_update(v, r, p, q, a, rr):
    """v += a p; r -= a q; rr = <r, r> per channel (fixed summation order)."""
    h, w = v.shape[0], v.shape[1]
    a32 = np.empty(3, np.float32)
    for c in range(3):
        a32[c] = a[c]
    part = np.zeros((h, 3), np.float64)
    for i in prange(h):
        for j in range(w):
            for c in range(3):
                v[i, j, c] += a32[c] * p[i, j, c]
                rv = r[i, j, c] - a32[c] * q[i, j, c]
                r[i, j, c] = rv
                part[i, c] += np.float64(rv) * np.float64(rv)
    for c in range(3):
        rr[c] = 0.0
    for i in range(h):
        for c in range(3):
            rr[c] += part[i, c]


@njit(inline="always", **JIT)
def _prolong_add_row(xc, x, diag, alpha, i):
    I = i // 2
    for j in range(diag.shape[1]):
        if diag[i, j] == 0.0:
            continue
        J = j // 2
        x[i, j, 0] += alpha * xc[I, J, 0]
        x[i, j, 1] += alpha * xc[I, J, 1]
        x[i, j, 2] += alpha * xc[I, J, 2]


@njit(**PJIT)
def _prolong_add(xc, x, diag, alpha):
    for i in prange(diag.shape[0]):
        _prolong_add_row(xc, x, diag, alpha, i)


# serial twins of the V-cycle kernels for small levels (one compiled call per V-cycle
# below ``SERIAL_CELLS`` instead of a parallel launch per kernel): every cell is
# computed from the same neighbours as in the parallel kernels, so the bits are the same


SERIAL_CELLS = 1 << 15  # levels with fewer cells run their whole V-cycle serially


@njit(**JIT)
def _jacobi_start_serial(diag, x, b, color):
    for i in range(diag.shape[0]):
        _jacobi_start_row(diag, x, b, color, i)


@njit(**JIT)
def _residual_restrict_serial(diag, we, ws, x, b, rc):
    for I in range(rc.shape[0]):
        _residual_restrict_row(diag, we, ws, x, b, rc, I)


@njit(**JIT)
def _prolong_add_serial(xc, x, diag, alpha):
    for i in range(diag.shape[0]):
        _prolong_add_row(xc, x, diag, alpha, i)


@njit(inline="always", **JIT)
def _level2(flat, shapes, offsets, l):
    """Level ``l``'s (h, w) array in a flat buffer of levels (``_Hierarchy``: one after another)."""
    h, w = shapes[l, 0], shapes[l, 1]
    return flat[offsets[l]:offsets[l] + h * w].reshape((h, w))


@njit(inline="always", **JIT)
def _level3(flat, shapes, offsets, l):
    """Level ``l``'s (h, w, 3) array in a flat buffer of levels."""
    h, w = shapes[l, 0], shapes[l, 1]
    return flat[3 * offsets[l]:3 * offsets[l] + 3 * h * w].reshape((h, w, 3))


@njit(**JIT)
def _vcycle_serial(diags, wes, wss, xs, bs, shapes, offsets, sweeps, coarse_sweeps):
    """``_Hierarchy.vcycle`` from the first serial level down, on one thread: the same kernels
    in the same order. The serial levels lie one after another in flat buffers (level l at
    ``offsets[l]`` cells, of shape ``shapes[l]``; ``xs``, ``bs`` three values a cell): the
    right-hand side of the first in ``bs``, the result in ``xs``."""
    last = shapes.shape[0] - 1
    for l in range(0, last):
        d, e, sw = _level2(diags, shapes, offsets, l), _level2(wes, shapes, offsets, l), _level2(wss, shapes, offsets, l)
        x, b = _level3(xs, shapes, offsets, l), _level3(bs, shapes, offsets, l)
        _jacobi_start_serial(d, x, b, 0)
        _smooth_serial(d, e, sw, x, b, 1)
        for _ in range(sweeps - 1):
            _smooth_serial(d, e, sw, x, b, 0)
            _smooth_serial(d, e, sw, x, b, 1)
        _residual_restrict_serial(d, e, sw, x, b, _level3(bs, shapes, offsets, l + 1))
    _coarse_solve(_level2(diags, shapes, offsets, last), _level2(wes, shapes, offsets, last),
                  _level2(wss, shapes, offsets, last), _level3(xs, shapes, offsets, last),
                  _level3(bs, shapes, offsets, last), coarse_sweeps)
    for l in range(last - 1, -1, -1):
        d, e, sw = _level2(diags, shapes, offsets, l), _level2(wes, shapes, offsets, l), _level2(wss, shapes, offsets, l)
        x, b = _level3(xs, shapes, offsets, l), _level3(bs, shapes, offsets, l)
        _prolong_add_serial(_level3(xs, shapes, offsets, l + 1), x, d, 1.0)
        for _ in range(sweeps):
            _smooth_serial(d, e, sw, x, b, 1)
            _smooth_serial(d, e, sw, x, b, 0)


# ---------------------------------------------------------------------------
# problem set-up


@njit(**PJIT)
def _rhs(f, patch, fixed, vfix, gx, gy, b):
    """Right-hand side of the correction equation A v = b at free pixels:

    b_p = sum over neighbours q of (g_pq - (f_p - f_q)) + sum over fixed q of v_q,

    where g_pq (the wanted u_p - u_q) is f_p - f_q inside a patch (the term vanishes)
    and, across a seam, -gx[p] / gx[q] (east / west) and -gy[p] / gy[q] (south / north).
    """
    h, w = patch.shape
    for i in prange(h):
        for j in range(w):
            for c in range(3):
                b[i, j, c] = 0.0
            if fixed[i, j]:
                continue
            pid = patch[i, j]
            for k in range(4):
                ii = i + (k == 1) - (k == 0)
                jj = j + (k == 3) - (k == 2)
                if ii < 0 or ii >= h or jj < 0 or jj >= w:
                    continue
                if fixed[ii, jj]:
                    for c in range(3):
                        b[i, j, c] += vfix[ii, jj, c]
                if patch[ii, jj] != pid:
                    for c in range(3):
                        if k == 0:
                            g = gy[ii, jj, c]   # u_p - u_north
                        elif k == 1:
                            g = -gy[i, j, c]    # u_p - u_south
                        elif k == 2:
                            g = gx[ii, jj, c]   # u_p - u_west
                        else:
                            g = -gx[i, j, c]    # u_p - u_east
                        b[i, j, c] += g - (f[i, j, c] - f[ii, jj, c])


@njit(**JIT)
def _floating_components(fixed, comp_first):
    """Label 4-connected components of free pixels; return for each component the
    flat index of its first pixel and whether it touches a fixed pixel.

    ``comp_first`` (H*W int64) receives the component index of each free pixel (-1 for
    fixed). Returns (first_pixel[ncomp], anchored[ncomp]).
    """
    h, w = fixed.shape
    n = h * w
    for p in range(n):
        comp_first[p] = -1
    _DI = np.array((-1, 1, 0, 0))
    _DJ = np.array((0, 0, -1, 1))
    stack = np.empty(n, np.int64)
    firsts = np.empty(n, np.int64)
    anchored = np.zeros(n, np.bool_)
    nc = 0
    for p0 in range(n):
        if fixed[p0 // w, p0 % w] or comp_first[p0] >= 0:
            continue
        comp_first[p0] = nc
        firsts[nc] = p0
        top = 0
        stack[0] = p0
        top = 1
        while top > 0:
            top -= 1
            p = stack[top]
            i = p // w
            j = p % w
            for k in range(4):
                ii = i + _DI[k]
                jj = j + _DJ[k]
                if ii < 0 or ii >= h or jj < 0 or jj >= w:
                    continue
                if fixed[ii, jj]:
                    anchored[nc] = True
                    continue
                q = ii * w + jj
                if comp_first[q] < 0:
                    comp_first[q] = nc
                    stack[top] = q
                    top += 1
        nc += 1
    return firsts[:nc].copy(), anchored[:nc].copy()


@njit(**JIT)
def _recentre(v, comp, ncomp, which):
    """Shift each component listed in ``which`` so its mean correction is zero."""
    h, w = v.shape[0], v.shape[1]
    sums = np.zeros((ncomp, 3), np.float64)
    cnt = np.zeros(ncomp, np.int64)
    for p in range(h * w):
        c = comp[p]
        if c >= 0 and which[c]:
            cnt[c] += 1
            for k in range(3):
                sums[c, k] += v[p // w, p % w, k]
    for p in range(h * w):
        c = comp[p]
        if c >= 0 and which[c]:
            for k in range(3):
                v[p // w, p % w, k] -= sums[c, k] / cnt[c]


@njit(**PJIT)
def _dot3(a, b, out):
    h, w = a.shape[0], a.shape[1]
    part = np.zeros((h, 3), np.float64)
    for i in prange(h):
        for j in range(w):
            for c in range(3):
                part[i, c] += np.float64(a[i, j, c]) * np.float64(b[i, j, c])
    for c in range(3):
        out[c] = 0.0
    for i in range(h):  # fixed summation order: same result for any thread count
        for c in range(3):
            out[c] += part[i, c]


@njit(**PJIT)
def _xpby3(z, beta, p):
    """p = z + beta[c] * p."""
    h, w = z.shape[0], z.shape[1]
    b0 = np.float32(beta[0])
    b1 = np.float32(beta[1])
    b2 = np.float32(beta[2])
    for i in prange(h):
        for j in range(w):
            p[i, j, 0] = z[i, j, 0] + b0 * p[i, j, 0]
            p[i, j, 1] = z[i, j, 1] + b1 * p[i, j, 1]
            p[i, j, 2] = z[i, j, 2] + b2 * p[i, j, 2]


# ---------------------------------------------------------------------------
# multigrid-preconditioned conjugate gradients


class _Hierarchy:
    """Operators and work arrays of every level, finest first.

    With piecewise-constant aggregation the Galerkin coarse Laplacian is about twice the
    rediscretized one in free regions; dividing it by ``alpha`` near 2 restores the scale
    (the over-correction of Braess 1995), while a screening term's mass is exact.
    """

    def __init__(self, fixed: np.ndarray, *, screen: float = 0.0, coarsest: int = 4, alpha: float = 1.9):
        diag, we, ws = _fine_operator(fixed, np.float32(screen))
        mass = np.where(diag > 0, np.float32(screen), np.float32(0.0)).astype(np.float32)
        ops = [(diag, we, ws)]
        while min(ops[-1][0].shape) > coarsest:
            diag, we, ws, mass = _coarsen(diag, we, ws, mass, np.float32(alpha))
            ops.append((diag, we, ws))
        self.ops = ops
        # from the first level below SERIAL_CELLS down, one serial call: those levels lie one
        # after another in flat buffers (one signature whatever their count; x and b of a
        # serial level are views of its buffers)
        self.serial_from = k0 = next((k for k, op in enumerate(ops) if op[0].size < SERIAL_CELLS), len(ops))
        self.x = [np.zeros(op[0].shape + (3,), np.float32) for op in ops[:k0]]
        self.b = [np.zeros(op[0].shape + (3,), np.float32) for op in ops[:k0]]
        if k0 < len(ops):
            shapes = np.array([op[0].shape for op in ops[k0:]], np.int64)
            offsets = np.concatenate([[0], np.cumsum(shapes[:, 0] * shapes[:, 1])]).astype(np.int64)
            flat = [np.concatenate([op[i].ravel() for op in ops[k0:]]) for i in range(3)]
            xs, bs = np.zeros(3 * offsets[-1], np.float32), np.zeros(3 * offsets[-1], np.float32)
            for (h, w), o in zip(shapes, offsets):
                self.x.append(xs[3 * o:3 * (o + h * w)].reshape(h, w, 3))
                self.b.append(bs[3 * o:3 * (o + h * w)].reshape(h, w, 3))
            self.serial = (*flat, xs, bs, shapes, offsets[:-1].copy())

    def vcycle(self, b: np.ndarray, x: np.ndarray, *, sweeps: int = 1, coarse_sweeps: int = 30,
               level: int = 0) -> None:
        """Approximately solve A x = b from x = 0; symmetric (red-black before, black-red
        after), so it can precondition conjugate gradients."""
        diag, we, ws = self.ops[level]
        if level >= self.serial_from:
            if b is not self.b[level]:  # self.b / self.x of a serial level are views of its buffers
                self.b[level][...] = b
            _vcycle_serial(*self.serial, sweeps, coarse_sweeps)
            if x is not self.x[level]:
                x[...] = self.x[level]
            return
        if level == len(self.ops) - 1:
            _coarse_solve(diag, we, ws, x, b, coarse_sweeps)
            return
        _jacobi_start(diag, x, b, 0)  # the first red half-sweep, from x = 0
        _smooth(diag, we, ws, x, b, 1)
        for _ in range(sweeps - 1):
            _smooth(diag, we, ws, x, b, 0)
            _smooth(diag, we, ws, x, b, 1)
        bc = self.b[level + 1]
        xc = self.x[level + 1]
        _residual_restrict(diag, we, ws, x, b, bc)
        self.vcycle(bc, xc, sweeps=sweeps, coarse_sweeps=coarse_sweeps, level=level + 1)
        _prolong_add(xc, x, diag, 1.0)
        for _ in range(sweeps):
            _smooth(diag, we, ws, x, b, 1)
            _smooth(diag, we, ws, x, b, 0)


def solve_system(fixed: np.ndarray, b: np.ndarray, *, screen: float = 0.0, tol: float = 1e-5, max_iter: int = 100,
                 sweeps: int = 1, alpha: float = 1.9) -> tuple[np.ndarray, dict]:
    """Solve A v = b for three channels with multigrid-preconditioned conjugate gradients.

    A is the graph Laplacian of the 4-connected grid restricted to the free (not
    ``fixed``) pixels: diagonal = number of in-image neighbours, -1 per free neighbour.
    ``screen`` is added to the diagonal (screened Poisson). Unless it is positive, every
    connected set of free pixels must touch a fixed pixel (A is then SPD).

    Stops when every channel's residual norm is at most ``tol`` times its initial norm.
    Returns v (M, N, 3) float32 (zero on fixed pixels) and {"iterations", "residual"}.
    """
    hier = _Hierarchy(np.ascontiguousarray(fixed, dtype=np.bool_), screen=screen, alpha=alpha)
    diag, we, ws = hier.ops[0]
    b = np.ascontiguousarray(b, dtype=np.float32)
    shape = b.shape
    v = np.zeros(shape, np.float32)
    r = np.empty(shape, np.float32)
    _residual(diag, we, ws, v, b, r)  # r = b with the fixed entries zeroed
    rr = np.zeros(3)
    _dot3(r, r, rr)
    r0 = np.sqrt(rr)
    if np.all(r0 == 0.0):
        return v, {"iterations": 0, "residual": 0.0}
    target = tol * r0
    z = np.empty(shape, np.float32)
    q = np.empty(shape, np.float32)
    hier.vcycle(r, z, sweeps=sweeps)
    p = z.copy()
    rz = np.zeros(3)
    _dot3(r, z, rz)
    pq = np.zeros(3)
    it = 0
    res = r0
    while it < max_iter:
        it += 1
        _matvec_dot(diag, we, ws, p, q, pq)
        a = np.where(pq > 0, rz / np.where(pq > 0, pq, 1.0), 0.0)
        _cg_update(v, r, p, q, a, rr)
        res = np.sqrt(rr)
        if np.all(res <= target):
            break
        hier.vcycle(r, z, sweeps=sweeps)
        rz_new = np.zeros(3)
        _dot3(r, z, rz_new)
        beta = np.where(rz > 0, rz_new / np.where(rz > 0, rz, 1.0), 0.0)
        rz = rz_new
        _xpby3(z, beta, p)
    rel = float(np.max(np.where(r0 > 0, res / np.where(r0 > 0, r0, 1.0), 0.0)))
    return v, {"iterations": it, "residual": rel}


def poisson_transfer(colors: np.ndarray, patch: np.ndarray, labels: np.ndarray | None = None, *,
                     fixed: np.ndarray | None = None, values: np.ndarray | None = None,
                     label_dirichlet: bool = True, seam_gx: np.ndarray | None = None,
                     seam_gy: np.ndarray | None = None, screen: float = 0.0, tol: float = 1e-5,
                     max_iter: int = 100) -> tuple[np.ndarray, dict]:
    """Gradient transfer of a synthesized image (Bonneel et al. 2010, §5 step 3).

    Parameters
    ----------
    colors : (M, N, 3) float ndarray
        f∘s: the source looked up through the coordinate map.
    patch : (M, N) uint32 ndarray
        Patch ids; the source gradient is kept between pixels of one patch, the target
        gradient across patch seams is zero.
    labels : (M, N) uint32 ndarray, optional
        Label ids; with ``label_dirichlet`` pixels on a boundary between two labels keep
        their colour (Dirichlet condition on Γ2).
    fixed : (M, N) bool ndarray, optional
        More pixels whose value is prescribed (e.g. everything outside newly synthesized
        areas when updating a frame).
    values : (M, N, 3) float ndarray, optional
        Values at ``fixed`` pixels (default: ``colors``). Label-boundary pixels always
        take ``colors``.
    seam_gx, seam_gy : (M, N, 3) float ndarray, optional
        Wanted differences u[i, j + 1] - u[i, j] and u[i + 1, j] - u[i, j] used on
        edges that cross a patch seam (read only there). Default zero: ∇u = 0 across
        seams (the paper's Γ1 condition). ``seam_gradients`` computes the source's own
        gradients there instead.
    screen : float
        Weight λ of a data term λ (u − f∘s)² (screened Poisson). 0 is the paper's pure
        Poisson problem; a small λ keeps each region's low frequencies (far from any
        fixed pixel the removed seam jumps otherwise add up to a colour drift) while
        seams are still blended over about 1/sqrt(λ) pixels.
    tol : float
        Relative residual at which conjugate gradients stops.

    Returns
    -------
    u : (M, N, 3) float32 ndarray
    info : dict
        iterations, relative residual, number of fixed pixels and floating components.
    """
    colors = np.ascontiguousarray(colors, dtype=np.float32)
    if colors.ndim != 3 or colors.shape[2] != 3:
        raise ValueError(f"colors must be (M, N, 3), got shape {colors.shape}")
    h, w = colors.shape[:2]
    patch = np.ascontiguousarray(patch, dtype=np.uint32)
    if patch.shape != (h, w):
        raise ValueError(f"patch is {patch.shape}, colors {colors.shape[:2]}")
    fx = np.zeros((h, w), np.bool_)
    vfix = np.zeros((h, w, 3), np.float32)  # fixed value of the correction v = u - f
    if fixed is not None:
        fixed = np.asarray(fixed, dtype=np.bool_)
        if fixed.shape != (h, w):
            raise ValueError(f"fixed is {fixed.shape}, colors {colors.shape[:2]}")
        fx |= fixed
        if values is not None:
            values = np.asarray(values, dtype=np.float32)
            if values.shape != (h, w, 3):
                raise ValueError(f"values must be {(h, w, 3)}, got {values.shape}")
            vfix[fixed] = values[fixed] - colors[fixed]
    if labels is not None and label_dirichlet:
        labels = np.ascontiguousarray(labels)
        if labels.shape != (h, w):
            raise ValueError(f"labels is {labels.shape}, colors {colors.shape[:2]}")
        edge = contour_mask(labels)
        fx |= edge
        vfix[edge] = 0.0
    # components of free pixels with no fixed neighbour: pin their first pixel, recentre
    # (screened: every component is determined, no labelling needed: a serial pass over the frame)
    comp = np.empty(h * w, np.int64) if screen <= 0 else None
    if screen <= 0:
        firsts, anchored = _floating_components(fx, comp)
        floating = ~anchored
    else:
        firsts, floating = np.zeros(0, np.int64), np.zeros(0, bool)
    if floating.any():
        pins = firsts[floating]
        fx = fx.copy()
        fx.reshape(-1)[pins] = True
        vfix.reshape(-1, 3)[pins] = 0.0
    grads = []
    for g, name in ((seam_gx, "seam_gx"), (seam_gy, "seam_gy")):
        if g is None:
            g = np.zeros((h, w, 3), np.float32)
        elif g.shape != (h, w, 3):
            raise ValueError(f"{name} must be {(h, w, 3)}, got {g.shape}")
        grads.append(np.ascontiguousarray(g, dtype=np.float32))
    gx, gy = grads
    b = np.empty((h, w, 3), np.float32)
    _rhs(colors, patch, fx, vfix, gx, gy, b)
    v, info = solve_system(fx, b, screen=screen, tol=tol, max_iter=max_iter)
    v[fx] = vfix[fx]
    if floating.any():
        _recentre(v, comp, len(firsts), floating)
    info.update(fixed=int(fx.sum()), floating=int(floating.sum()))
    u = colors + v
    if fixed is not None and values is not None:  # exact values, not f + (values - f)
        keep = fixed if labels is None or not label_dirichlet else fixed & ~edge
        u[keep] = values[keep]
    return u, info



def seam_gradients(source: np.ndarray, sx: np.ndarray, sy: np.ndarray, step: float = 1.0, *,
                   filter: str = "bilinear") -> tuple[np.ndarray, np.ndarray]:
    """Source gradients through a coordinate map, for the edges across patch seams.

    For output pixel p and its east neighbour q, the wanted u_q - u_p is the mean of the
    source's gradient read from either side: (f(s_p + e) - f(s_p) + f(s_q) - f(s_q - e)) / 2
    with e one output pixel (``step`` source pixels) along x; the same along y. Inside a
    patch this equals f∘s(q) - f∘s(p); across a seam it keeps the texture's contrast
    instead of the jump. ``filter`` is ``kernels.lookup``'s (read the source as the
    colours were read).

    Returns gx, gy (M, N, 3) float32 (the last column / row of gx / gy is unused).
    """
    from proxyshade.kernels.lookup import lookup

    sx = np.asarray(sx, np.float32)
    sy = np.asarray(sy, np.float32)
    e = np.float32(step)
    f0 = lookup(source, sx, sy, filter=filter)
    gx = np.zeros(f0.shape, np.float32)
    gy = np.zeros(f0.shape, np.float32)
    fe = lookup(source, sx + e, sy, filter=filter)[:, :-1]
    fw = lookup(source, sx[:, 1:] - e, sy[:, 1:], filter=filter)
    gx[:, :-1] = 0.5 * ((fe - f0[:, :-1]) + (f0[:, 1:] - fw))
    fs = lookup(source, sx, sy + e, filter=filter)[:-1]
    fn = lookup(source, sx[1:], sy[1:] - e, filter=filter)
    gy[:-1] = 0.5 * ((fs - f0[:-1]) + (f0[1:] - fn))
    return gx, gy


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
        n0, n1, n2 = _neighbour_sum(v, we, ws, i, j, h, w)
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
            a0, a1, a2 = _apply_at(diag, we, ws, v, i, j)
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
              screen: float = 0.0, tol: float = 1e-5, max_sweeps: int = 2000, check: int = 8) -> tuple[np.ndarray, dict]:
    """Solve A v = b (``solve_system``'s operator) on the listed free pixels by red-black SOR.

    For many small free regions, each bounded by fixed pixels, in a large frame: the work
    is proportional to the free pixels, not the frame. ``omega`` (one per listed pixel)
    should suit its region's size (``sor_omega``). Stops when every channel's residual
    norm over the listed pixels is at most ``tol`` times its initial norm (checked every
    ``check`` sweeps). Returns v (zero off the list) and {"iterations", "residual"}.
    """
    diag, we, ws = _fine_operator(np.ascontiguousarray(fixed, np.bool_), np.float32(screen))
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


@njit(**JIT)
def _sor_run(nb, dl, bl, omega, lo, hi, vl):
    """Over-relaxed Gauss-Seidel updates of list entries lo..hi, in list order, on the
    compact list (``nb``: list index of the east, west, south, north neighbour, -1 where
    there is none or it is fixed; ``dl``, ``bl``: diagonal and right-hand side). The
    arithmetic of ``_sor_sweep``: a fixed neighbour's term there is exactly zero."""
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
        inv = 1.0 / dl[k]
        o = omega[k]
        vl[k, 0] += o * ((bl[k, 0] + n0) * inv - vl[k, 0])
        vl[k, 1] += o * ((bl[k, 1] + n1) * inv - vl[k, 1])
        vl[k, 2] += o * ((bl[k, 2] + n2) * inv - vl[k, 2])


@njit(**JIT)
def _run_residual(nb, dl, bl, lo, hi, vl, out):
    """Per-channel squared residual norm over list entries lo..hi, summed in list order
    (``_apply_at``'s float32 arithmetic)."""
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
def _sor_regions(bins, bin_start, starts, mids, nb, dl, bl, omega, vl, tol, check, max_sweeps, sweeps, rel):
    """Each region (list entries starts[k]..starts[k + 1], its red pixels before ``mids[k]``)
    swept on its own until its residual falls to ``tol`` times its initial one. The
    regions are independent (fixed pixels between them): a thread owns whole regions
    (``bins``: region ids per thread, ``bin_start``), so the result does not depend on
    which thread sweeps which region, nor on the thread count."""
    for t in prange(bin_start.shape[0] - 1):
        r0 = np.zeros(3)
        r = np.zeros(3)
        for q in range(bin_start[t], bin_start[t + 1]):
            k = bins[q]
            lo = starts[k]
            hi = starts[k + 1]
            _run_residual(nb, dl, bl, lo, hi, vl, r0)
            if r0[0] == 0.0 and r0[1] == 0.0 and r0[2] == 0.0:
                continue
            s = 0
            worst = 0.0
            while s < max_sweeps:
                for _ in range(check):
                    _sor_run(nb, dl, bl, omega, lo, mids[k], vl)  # red
                    _sor_run(nb, dl, bl, omega, mids[k], hi, vl)  # black
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
    load = np.zeros(nt)
    owner = np.empty(nreg, np.int64)
    for k in np.argsort(-work, kind="stable"):
        t = int(np.argmin(load))
        owner[k] = t
        load[t] += work[k]
    bins = np.argsort(owner, kind="stable").astype(np.int64)
    bin_start = np.searchsorted(owner[bins], np.arange(nt + 1)).astype(np.int64)
    return order, om, starts, mids, size, bins, bin_start, nreg


def solve_sor_regions(fixed: np.ndarray, b: np.ndarray, rows: np.ndarray, cols: np.ndarray, omega: np.ndarray,
                      region: np.ndarray, *, screen: float = 0.0, tol: float = 1e-5, max_sweeps: int = 2000,
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
    diag, we, ws = _fine_operator(np.ascontiguousarray(fixed, np.bool_), np.float32(screen))
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
    _sor_regions(bins, bin_start, starts, mids, nb, np.ascontiguousarray(diag[ii, jj]),
                 np.ascontiguousarray(b[ii, jj]), om, vl, float(tol), int(check), int(max_sweeps), sweeps, rel)
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
    """``_rhs`` and ``_fine_operator``'s diagonal at the listed pixels only, in their
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
                 region: np.ndarray, *, source: np.ndarray | None = None, sx: np.ndarray | None = None,
                 sy: np.ndarray | None = None, step: float = 1.0, filter: str = "bilinear", screen: float = 0.0,
                 tol: float = 1e-5, max_sweeps: int = 2000, check: int = 8,
                 threads: int | None = None) -> tuple[np.ndarray, dict]:
    """``solve_sor_regions`` of the correction equation with every pixel but the listed
    ones (``rows``, ``cols`` in scan order, as ``np.nonzero`` gives them) fixed, its
    right-hand side (``rhs``) and seam gradients (``seam_gradients_at`` with ``source``,
    ``sx``, ``sy``, ``step``, ``filter``; zero without ``source``) computed at the listed
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
    if source is not None:
        eid, xs, ys = _seam_edges(ii, jj, patch, np.ascontiguousarray(sx, np.float32),
                                  np.ascontiguousarray(sy, np.float32), np.float32(step))
        from proxyshade.kernels.lookup import lookup_many

        fs = lookup_many(source, xs, ys, filter)
    else:
        eid, fs = np.full((n, 4), -1, np.int64), np.zeros((0, 3), np.float32)
    bl = np.empty((n, 3), np.float32)
    dl = np.empty(n, np.float32)
    _rhs_at(colors, patch, ii, jj, nb, eid, fs, np.float32(screen), bl, dl)
    sweeps = np.zeros(nreg, np.int64)
    rel = np.zeros(nreg)
    vl = np.zeros((n, 3), np.float32)
    _sor_regions(bins, bin_start, starts, mids, nb, dl, bl, om, vl, float(tol), int(check), int(max_sweeps), sweeps,
                 rel)
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


def rhs(colors: np.ndarray, patch: np.ndarray, fixed: np.ndarray, seam_gx: np.ndarray, seam_gy: np.ndarray) -> np.ndarray:
    """``_rhs`` with fixed pixels keeping their colour (correction 0)."""
    b = np.empty(colors.shape, np.float32)
    _rhs(np.ascontiguousarray(colors, np.float32), np.ascontiguousarray(patch, np.uint32),
         np.ascontiguousarray(fixed, np.bool_), np.zeros(colors.shape, np.float32),
         np.ascontiguousarray(seam_gx, np.float32), np.ascontiguousarray(seam_gy, np.float32), b)
    return b


def seam_gradients_at(source: np.ndarray, sx: np.ndarray, sy: np.ndarray, patch: np.ndarray, near: np.ndarray,
                      step: float = 1.0, *, filter: str = "bilinear") -> tuple[np.ndarray, np.ndarray]:
    """``seam_gradients`` on only the edges that cross a patch seam and touch a pixel of
    ``near`` (the rest stay zero, as ``_rhs`` reads gx, gy only across seams): the same
    numbers at a cost proportional to those edges (all the source reads in one lookup)."""
    from proxyshade.kernels.lookup import lookup_many

    h, w = patch.shape
    gx = np.zeros((h, w, 3), np.float32)
    gy = np.zeros((h, w, 3), np.float32)
    e = np.float32(step)
    sx = np.asarray(sx, np.float32)
    sy = np.asarray(sy, np.float32)
    edges = []
    xs, ys = [], []
    for axis, g in ((1, gx), (0, gy)):
        a = (slice(None), slice(0, -1)) if axis == 1 else (slice(0, -1), slice(None))
        bq = (slice(None), slice(1, None)) if axis == 1 else (slice(1, None), slice(None))
        edge = (patch[a] != patch[bq]) & (near[a] | near[bq])
        pi, pj = np.nonzero(edge)
        if not len(pi):
            continue
        qi, qj = pi + (axis == 0), pj + (axis == 1)
        dx, dy = (e, 0) if axis == 1 else (0, e)
        edges.append((g, pi, pj))
        # f(s_p + e), f(s_p), f(s_q), f(s_q - e)
        for i, j, ox, oy in ((pi, pj, dx, dy), (pi, pj, 0, 0), (qi, qj, 0, 0), (qi, qj, -dx, -dy)):
            xs.append(sx[i, j] + ox)
            ys.append(sy[i, j] + oy)
    if not edges:
        return gx, gy
    f = lookup_many(source, np.concatenate(xs), np.concatenate(ys), filter)
    k = 0
    for g, pi, pj in edges:
        n = len(pi)
        fe, f0, fq, fw = (f[k + m * n:k + (m + 1) * n] for m in range(4))
        g[pi, pj] = 0.5 * ((fe - f0) + (fq - fw))
        k += 4 * n
    return gx, gy
