"""Gradient-domain transfer of synthesized colour: the Poisson problem and its right-hand side.

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

The unknown is the correction v = u − f∘s (zero almost everywhere but along seams). This
module sets the problem up (right-hand side, seam gradients, floating components) and
hands it to a solver: ``kernels.multigrid.solve_system`` (multigrid-preconditioned
conjugate gradients, for whole frames and windows) or ``kernels.sor`` (red-black SOR on
listed pixels, for many thin regions). The 5-point operator both share is in
``kernels.stencil``.

References
----------
Bonneel, van de Panne, Lefebvre, Drettakis. Proxy-Guided Texture Synthesis for Rendering
Natural Scenes. INRIA RR-7298, 2010 (§5 step 3).
P. Pérez, M. Gangnet, A. Blake. Poisson image editing. SIGGRAPH 2003.
A. McAdams, E. Sifakis, J. Teran. A parallel multigrid Poisson solver for fluids
simulation on large grids. SCA 2010.
D. Braess. Towards algebraic multigrid for elliptic problems of second order.
Computing 55, 1995 (over-correction of aggregation coarse grids).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import JIT, PJIT
from proxyshade.kernels.distance import contour_mask
from proxyshade.kernels.multigrid import solve_system

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


# ---------------------------------------------------------------------------
# the transfer: right-hand side, solve, floating components


def poisson_transfer(colors: np.ndarray, patch: np.ndarray, labels: np.ndarray | None = None, *,
                     fixed: np.ndarray | None = None, values: np.ndarray | None = None,
                     label_dirichlet: bool = True, seam_gx: np.ndarray | None = None,
                     seam_gy: np.ndarray | None = None, seam_gradients=None, screen: float = 0.0, tol: float,
                     max_iter: int) -> tuple[np.ndarray, dict]:
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
    seam_gradients : callable, optional
        Instead of ``seam_gx, seam_gy``: a function returning them, called here and its
        arrays dropped once the right-hand side is made, so that they are not held through
        the solve (two frame-sized arrays of 3 channels: 212 MiB at 4K).
    screen : float
        Weight λ of a data term λ (u − f∘s)² (screened Poisson). 0 is the paper's pure
        Poisson problem; a small λ keeps each region's low frequencies (far from any
        fixed pixel the removed seam jumps otherwise add up to a colour drift) while
        seams are still blended over about 1/sqrt(λ) pixels.
    tol, max_iter : float, int
        Relative residual at which conjugate gradients stops, and its most iterations (no
        defaults here: the Poisson node's ``PoissonSolve`` group declares them).

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
    # the pixels that take ``values`` exactly at the end (not f + (values - f)): fixed ones off
    # the label contours
    keep = fixed if fixed is not None and values is not None else None
    if labels is not None and label_dirichlet:
        labels = np.ascontiguousarray(labels)
        if labels.shape != (h, w):
            raise ValueError(f"labels is {labels.shape}, colors {colors.shape[:2]}")
        edge = contour_mask(labels)
        fx |= edge
        vfix[edge] = 0.0
        if keep is not None:
            keep = keep & ~edge
        del edge  # not held through the solve
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
    if seam_gradients is not None:
        if seam_gx is not None or seam_gy is not None:
            raise ValueError("pass seam_gx, seam_gy or seam_gradients, not both")
        seam_gx, seam_gy = seam_gradients()
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
    # what the solve no longer reads leaves memory before it: the fixed values (kept at the
    # fixed pixels only), the seam gradients made here, and b (it becomes the residual)
    vfix = vfix[fx]
    del grads, gx, gy, g, seam_gx, seam_gy
    v, info = solve_system(fx, b, screen=screen, tol=tol, max_iter=max_iter, overwrite_b=True)
    del b
    v[fx] = vfix
    if floating.any():
        _recentre(v, comp, len(firsts), floating)
    info.update(fixed=int(fx.sum()), floating=int(floating.sum()))
    u = np.add(colors, v, out=v)  # u = colors + v, in v's buffer
    if keep is not None:  # exact values, not f + (values - f)
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
