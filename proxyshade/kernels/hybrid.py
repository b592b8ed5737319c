"""Kernels of structured image hybrids (Risser, Han, Dahyot, Grinspun, SIGGRAPH 2010).

The exemplars sit side by side in an *atlas*: equal boxes of ``bw`` columns in a row, box
``b`` owning columns ``b bw .. (b + 1) bw - 1``. Nothing here reads across a box border:

* ``gaussian_stack``: the per-exemplar Gaussian stack (Lefebvre and Hoppe 2005), the
  binomial 1 4 6 4 1 / 16 applied "à trous" level after level, clamped at the borders of
  the pixel's own box; ``stack_level``, the box-filtered stack kept for comparison (level
  ``h``: the mean over the h × h block centred at each pixel, clamped likewise,
  ``features._box_blur_centred`` on each box);
* ``gather``: the 75-D (5 × 5 × 3) neighbourhood of each atlas pixel at spacing ``h``,
  clamped into its box;
* ``pca_basis`` / ``project``: the 6-D PCA subspace of those neighbourhoods (covariance in
  fixed pixel chunks, so the sums do not depend on the thread count) and the projection;
* ``multiscale``: the descriptor of the candidate analysis, the projections of ``L``
  successive finer (or coarser) levels concatenated (the paper: L = 8), each scaled when
  given (``level_scales``: each level weighs alike);
* ``candidates``: per atlas pixel and per exemplar, the ``q`` most similar pixels under the
  multiscale descriptor, pairwise at least ``sep`` apart (L∞) and ``sep`` from the pixel
  itself, by PatchMatch (Barnes et al. 2009): random init, propagation, random search;
  also a nearest-patch search from another image (the bench's C measure);
* ``subpass``: one parity sub-set of a jitter (``jitter_threshold``, the paper's J, > 0) or
  correction (0) pass.
  For pixel p, the synthesized neighbourhood Ñ_S(p) is the PCA projection of the stack
  colours at the 5 × 5 neighbours' pointers (past the grid's border: the nearest pointer
  continued by h per pixel, clamped into its box); the candidates are, for each 3 × 3
  neighbour q, S[q] − h (q − p) (S: the pointer map, ``coords`` in the code) and its
  candidate set shifted the same way (staying in the pointer's box);
  d_i = ‖Ñ_S(p) − Ñ_E(c_i)‖² / weight(p, exemplar of c_i) (a weight
  per output pixel and exemplar, ``inv_w`` holding 1 / weight; weight 0: never a candidate). Correction
  takes the first smallest d_i; jitter drops candidates with
  (d_i − d_min) / (d_max − d_min) > J and picks uniformly among the rest (duplicates
  count once per occurrence) with ``random.rand``;
* ``spatial_jitter``: the baseline (Lefebvre and Hoppe 2005): S[p] += ⌊h r ξ + ½⌋, ξ
  uniform in [−1, 1]², clamped into the box.

References
----------
E. Risser, C. Han, R. Dahyot, E. Grinspun. Synthesizing structured image hybrids.
SIGGRAPH 2010 (ACM Transactions on Graphics 29(4)).
S. Lefebvre, H. Hoppe. Parallel controllable texture synthesis. SIGGRAPH 2005.
C. Barnes, E. Shechtman, A. Finkelstein, D. Goldman. PatchMatch. SIGGRAPH 2009.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from proxyshade.kernels._config import JIT, PJIT
from proxyshade.kernels.chamfer import chamfer_masks
from proxyshade.kernels.features import _box_blur_centred
from proxyshade.kernels.random import rand

NB = 5
NB2 = NB * NB
DIMS = 6  # PCA dimensions per level
CHUNK = 4096  # pixels per partial covariance sum


# ---------------------------------------------------------------------------
# stack, neighbourhoods, PCA


def stack_level(img: np.ndarray, bw: int, h: int) -> np.ndarray:
    """(H, Wa, C) float32 atlas -> its stack level of spacing ``h``: each box blurred on
    its own (an h × h mean, clamped at the box's borders)."""
    img = np.ascontiguousarray(img, np.float32)
    if h == 1:
        return img.copy()
    out = np.empty_like(img)
    for x0 in range(0, img.shape[1], bw):
        box = np.ascontiguousarray(img[:, x0:x0 + bw])
        tmp = np.empty_like(box)
        _box_blur_centred(box, h, tmp)
        out[:, x0:x0 + bw] = tmp
    return out


BINOMIAL = (1.0 / 16, 4.0 / 16, 6.0 / 16, 4.0 / 16, 1.0 / 16)  # the 5-tap Gaussian of a pyramid


@njit(**PJIT)
def _atrous(img, bw, step, out):
    """``img`` convolved with the binomial 1 4 6 4 1 / 16 at taps −2 step .. 2 step, rows
    then columns, each tap clamped into the pixel's own box (columns) and the atlas
    (rows); float64 sums, one pixel per write."""
    H, Wa, C = img.shape
    w = np.array(BINOMIAL)
    tmp = np.empty((H, Wa, C), np.float64)
    for i in prange(H):
        for j in range(Wa):
            x0 = (j // bw) * bw
            for c in range(C):
                s = 0.0
                for t in range(5):
                    jj = min(max(j + (t - 2) * step, x0), x0 + bw - 1)
                    s += w[t] * img[i, jj, c]
                tmp[i, j, c] = s
    for i in prange(H):
        for j in range(Wa):
            for c in range(C):
                s = 0.0
                for t in range(5):
                    ii = min(max(i + (t - 2) * step, 0), H - 1)
                    s += w[t] * tmp[ii, j, c]
                out[i, j, c] = s


def gaussian_stack(img: np.ndarray, bw: int, levels: int) -> list:
    """(H, Wa, C) float32 atlas -> its Gaussian stack, ``levels`` levels finest first
    (Lefebvre and Hoppe 2005): level 0 is the atlas, level s is level s − 1 convolved with
    the binomial 1 4 6 4 1 / 16 dilated to taps 2^(s−1) apart ("à trous"), which is a
    Gaussian pyramid's filtering kept at full resolution (level s: σ ≈ 2^s / √3); each box
    on its own, clamped at its borders, so no exemplar bleeds into another."""
    cur = np.ascontiguousarray(img, np.float32)
    out = [cur.copy()]
    for s in range(1, levels):
        nxt = np.empty_like(cur)
        _atrous(cur, int(bw), 2 ** (s - 1), nxt)
        out.append(nxt)
        cur = nxt
    return out


@njit(**PJIT)
def _gather(img, bw, h, out):
    H, Wa, C = img.shape
    for i in prange(H):
        for j in range(Wa):
            x0 = (j // bw) * bw
            t = 0
            for di in range(-2, 3):
                ii = min(max(i + di * h, 0), H - 1)
                for dj in range(-2, 3):
                    jj = min(max(j + dj * h, x0), x0 + bw - 1)
                    for c in range(C):
                        out[i, j, t] = img[ii, jj, c]
                        t += 1


def gather(img: np.ndarray, bw: int, h: int) -> np.ndarray:
    """(H, Wa, 3) -> (H, Wa, 75) float32: the 5 × 5 neighbourhood at spacing ``h`` (row
    major, then channel), clamped into the pixel's box."""
    img = np.ascontiguousarray(img, np.float32)
    out = np.empty(img.shape[:2] + (NB2 * img.shape[2],), np.float32)
    _gather(img, int(bw), int(h), out)
    return out


@njit(**PJIT)
def _partial_cov(X, nchunks, sums, cross):
    n, d = X.shape
    for c in prange(nchunks):
        for r in range(c * CHUNK, min((c + 1) * CHUNK, n)):
            for a in range(d):
                xa = np.float64(X[r, a])
                sums[c, a] += xa
                for b in range(a, d):
                    cross[c, a, b] += xa * X[r, b]


def pca_basis(X: np.ndarray, dims: int = DIMS) -> tuple[np.ndarray, np.ndarray]:
    """(N, D) samples -> (mean (D,), basis (D, dims)): the leading principal directions,
    largest first, each signed so its largest-magnitude entry is positive (float64).

    The covariance is summed in fixed chunks of ``CHUNK`` samples (thread-count
    independent), then diagonalised with ``numpy.linalg.eigh``."""
    X = np.ascontiguousarray(X, np.float32)
    n, d = X.shape
    nch = (n + CHUNK - 1) // CHUNK
    sums = np.zeros((nch, d))
    cross = np.zeros((nch, d, d))
    _partial_cov(X, nch, sums, cross)
    s = np.zeros(d)
    m = np.zeros((d, d))
    for c in range(nch):  # in order: deterministic
        s += sums[c]
        m += cross[c]
    mean = s / n
    m = np.triu(m) + np.triu(m, 1).T
    cov = m / n - np.outer(mean, mean)
    w, v = np.linalg.eigh(cov)
    basis = v[:, ::-1][:, :dims].copy()
    for k in range(basis.shape[1]):
        if basis[np.argmax(np.abs(basis[:, k])), k] < 0:
            basis[:, k] = -basis[:, k]
    return mean, basis


@njit(**PJIT)
def _project(X, mean, basis, out):
    H, W, D = X.shape
    k = basis.shape[1]
    for i in prange(H):
        for j in range(W):
            for a in range(k):
                s = 0.0
                for t in range(D):
                    s += (X[i, j, t] - mean[t]) * basis[t, a]
                out[i, j, a] = s


def project(X: np.ndarray, mean: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """(H, W, D) -> (H, W, dims) float32: (x − mean) · basis."""
    out = np.empty(X.shape[:2] + (basis.shape[1],), np.float32)
    _project(np.ascontiguousarray(X, np.float32), np.ascontiguousarray(mean, np.float64),
             np.ascontiguousarray(basis, np.float64), out)
    return out


def multiscale(projections: list, s: int, descriptor_levels: int, *, coarser: bool = False, scales=None) -> np.ndarray:
    """The candidate-analysis descriptor of level ``s``: the projections of levels s,
    s − 1, ..., s − L + 1 (L = ``descriptor_levels``; finer; ``coarser``: s, s + 1, ...,
    s + L − 1), those that exist, each times ``scales[t]`` when given, concatenated
    (float32, contiguous)."""
    n = descriptor_levels
    order = range(s, min(s + n, len(projections))) if coarser else range(s, max(s - n, -1), -1)
    parts = [projections[t] if scales is None else projections[t] * np.float32(scales[t]) for t in order]
    return np.ascontiguousarray(np.concatenate(parts, axis=-1), np.float32)


def level_scales(projections: list) -> list:
    """1 / RMS norm of each level's projections (float64 sums, so thread-count
    independent): scaled by these, every level weighs alike in a multiscale descriptor
    (unscaled, the finest level's larger variance drowns the coarser ones)."""
    return [1.0 / np.sqrt(max(float(np.mean(np.square(P.astype(np.float64)).sum(-1))), 1e-24)) for P in projections]


# ---------------------------------------------------------------------------
# candidate sets: PatchMatch with a quota per exemplar and a separation


@njit(**JIT)
def _d2(A, ai, aj, B, bi, bj, bound):
    s = 0.0
    for t in range(A.shape[2]):
        e = np.float64(A[ai, aj, t]) - B[bi, bj, t]
        s += e * e
        if s > bound:
            return s
    return s


@njit(**JIT)
def _far(ay, ax, by, bx, sep):
    return max(abs(ay - by), abs(ax - bx)) >= sep


@njit(**JIT)
def _insert_sep(ly, lx, ld, q, cy, cx, d, sep):
    """Insert (cy, cx, d) into the sorted list of q entries (empty: d = inf) keeping every
    pair at least ``sep`` apart: refused when an entry within sep is as good; otherwise the
    worse entries within sep leave. Returns whether it went in."""
    for t in range(q):
        if ld[t] < np.inf and not _far(ly[t], lx[t], cy, cx, sep) and ld[t] <= d:
            return False
    if d >= ld[q - 1]:
        # a full list whose worst is better: only enter if it displaces a near worse one
        near = False
        for t in range(q):
            if ld[t] < np.inf and not _far(ly[t], lx[t], cy, cx, sep):
                near = True
        if not near:
            return False
    n = 0
    for t in range(q):  # drop entries within sep (all worse than d)
        if ld[t] < np.inf and _far(ly[t], lx[t], cy, cx, sep):
            ly[n] = ly[t]
            lx[n] = lx[t]
            ld[n] = ld[t]
            n += 1
    for t in range(n, q):
        ld[t] = np.inf
        ly[t] = -1
        lx[t] = -1
    t = min(n, q - 1)
    while t > 0 and ld[t - 1] > d:
        ly[t] = ly[t - 1]
        lx[t] = lx[t - 1]
        ld[t] = ld[t - 1]
        t -= 1
    ly[t] = cy
    lx[t] = cx
    ld[t] = d
    return True


@njit(**JIT)
def _try(Q, A, i, j, own, bw, b, q, sep, cy, cx, ly, lx, ld):
    """Offer atlas pixel (cy, cx) (any position) as a box-b candidate for query (i, j)."""
    Ha = A.shape[0]
    if cy < 0 or cy >= Ha or cx < b * bw or cx >= (b + 1) * bw:
        return
    if own and not _far(cy, cx, i, j, sep):
        return
    for t in range(q):
        if ly[t] == cy and lx[t] == cx:
            return
    d = _d2(Q, i, j, A, cy, cx, ld[q - 1] if ld[q - 1] < np.inf else np.inf)
    _insert_sep(ly, lx, ld, q, cy, cx, d, sep)


@njit(**JIT)
def _fill(Q, A, i, j, same, bw, b, q, sep, ly, lx, ld):
    """A full quota, whatever the draws: offer a coarse scan of the box while one is missing."""
    Ha = A.shape[0]
    step = max(sep, 1)
    for y in range(0, Ha, step):
        for x in range(0, bw, step):
            if ld[q - 1] == np.inf:
                _try(Q, A, i, j, same, bw, b, q, sep, cy=y, cx=b * bw + x, ly=ly, lx=lx, ld=ld)


@njit(**PJIT)
def _cand_init(Q, A, bw, nb, q, sep, own_box, seed, init, cy_, cx_, cd_):
    """Start lists: the entries of ``init`` (another level's lists, when it has any),
    else random draws; then a scan fills what is missing."""
    Hq, Wq = Q.shape[0], Q.shape[1]
    Ha = A.shape[0]
    for i in prange(Hq):
        for j in range(Wq):
            for b in range(nb):
                ly = cy_[i, j, b]
                lx = cx_[i, j, b]
                ld = cd_[i, j, b]
                ly[:] = -1
                lx[:] = -1
                ld[:] = np.inf
                same = own_box and j // bw == b
                if init.shape[0] > 0:
                    for t in range(q):
                        _try(Q, A, i, j, same, bw, b, q, sep, cy=init[i, j, b, t, 0], cx=init[i, j, b, t, 1],
                             ly=ly, lx=lx, ld=ld)
                else:
                    for t in range(4 * q + 4):  # random draws in the box
                        r = rand(seed, i * Wq + j, b, t)
                        _try(Q, A, i, j, same, bw, b, q, sep, cy=(r >> 20) % Ha, cx=b * bw + r % bw,
                             ly=ly, lx=lx, ld=ld)
                _fill(Q, A, i, j, same, bw, b, q, sep, ly=ly, lx=lx, ld=ld)


@njit(**PJIT)
def _cand_iter(Q, A, bw, nb, q, sep, own_box, seed, it, step, old, new):
    """One PatchMatch iteration (reads the lists ``old``, writes ``new``, each a tuple of
    rows, columns and distances): the entries of the 4 neighbours at distance 1 and at
    ``step`` (jump flooding), shifted back; when Q is A, the entries of each entry's own
    list (neighbours of neighbours); then a random search around each entry with halving
    radius."""
    oy, ox, od = old
    ny, nx, nd = new
    Hq, Wq = Q.shape[0], Q.shape[1]
    Ha = A.shape[0]
    for i in prange(Hq):
        for j in range(Wq):
            for b in range(nb):
                ly = ny[i, j, b]
                lx = nx[i, j, b]
                ld = nd[i, j, b]
                ly[:] = oy[i, j, b]
                lx[:] = ox[i, j, b]
                ld[:] = od[i, j, b]
                same = own_box and j // bw == b
                for m in range(8):
                    k = m % 4
                    st = 1 if m < 4 else step
                    if m >= 4 and step <= 1:
                        break
                    dy = st * ((k == 1) - (k == 0))
                    dx = st * ((k == 3) - (k == 2))
                    ii = i + dy
                    jj = j + dx
                    if ii < 0 or ii >= Hq or jj < 0 or jj >= Wq:
                        continue
                    for t in range(q):
                        if oy[ii, jj, b, t] >= 0:
                            _try(Q, A, i, j, same, bw, b, q, sep, cy=oy[ii, jj, b, t] - dy, cx=ox[ii, jj, b, t] - dx,
                                 ly=ly, lx=lx, ld=ld)
                if own_box:
                    for t in range(q):
                        cy = oy[i, j, b, t]
                        cx = ox[i, j, b, t]
                        if cy < 0:
                            continue
                        for u in range(q):
                            if oy[cy, cx, b, u] >= 0:
                                _try(Q, A, i, j, same, bw, b, q, sep, cy=oy[cy, cx, b, u], cx=ox[cy, cx, b, u],
                                     ly=ly, lx=lx, ld=ld)
                draw = 0
                for t in range(q):
                    by = ly[t]
                    bx = lx[t]
                    if by < 0:
                        continue
                    R = max(Ha, bw) // 2
                    while R >= 1:
                        r = rand(seed, i * Wq + j, b * 65536 + it * 256 + draw, 7)
                        draw += 1
                        cy = by + (r >> 20) % (2 * R + 1) - R
                        cx = bx + r % (2 * R + 1) - R
                        _try(Q, A, i, j, same, bw, b, q, sep, cy=cy, cx=cx, ly=ly, lx=lx, ld=ld)
                        R //= 2
                _fill(Q, A, i, j, same, bw, b, q, sep, ly=ly, lx=lx, ld=ld)  # a displacement may have emptied a slot


def candidates(Q: np.ndarray, A: np.ndarray, bw: int, q: int, sep: int, *, own_box: bool, iterations: int,
               seed: int, init: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """For each query pixel of Q (Hq, Wq, D) and each box of the atlas descriptors A
    (Ha, nb bw, D), the ``q`` nearest atlas pixels of that box (squared L2), pairwise at
    least ``sep`` apart (L∞); with ``own_box`` (Q is A) also ``sep`` from the query pixel
    in its own box. Returns positions (Hq, Wq, nb, q, 2) int32 (row, atlas column) and
    squared distances (Hq, Wq, nb, q) float64, sorted per box. ``init`` (such positions,
    e.g. another level's) starts the search instead of random draws."""
    Q = np.ascontiguousarray(Q, np.float32)
    A = np.ascontiguousarray(A, np.float32)
    Hq, Wq = Q.shape[:2]
    nb = A.shape[1] // bw
    cy = np.empty((Hq, Wq, nb, q), np.int32)
    cx = np.empty_like(cy)
    cd = np.empty((Hq, Wq, nb, q), np.float64)
    init = np.zeros((0, 0, nb, q, 2), np.int32) if init is None else np.ascontiguousarray(init, np.int32)
    _cand_init(Q, A, bw=int(bw), nb=nb, q=int(q), sep=int(sep), own_box=bool(own_box), seed=int(seed), init=init,
               cy_=cy, cx_=cx, cd_=cd)
    ny, nx, nd = np.empty_like(cy), np.empty_like(cx), np.empty_like(cd)
    for it in range(iterations):
        step = min(2 ** max(iterations - 2 - it, 0), max(bw // 4, 1))  # jump flooding: ..., 4, 2, 1, 1
        _cand_iter(Q, A, bw=int(bw), nb=nb, q=int(q), sep=int(sep), own_box=bool(own_box), seed=int(seed), it=it + 1,
                   step=step, old=(cy, cx, cd), new=(ny, nx, nd))
        cy, ny = ny, cy
        cx, nx = nx, cx
        cd, nd = nd, cd
    return np.stack([cy, cx], -1), cd


# ---------------------------------------------------------------------------
# synthesis: jitter and correction sub-passes


@njit(**JIT)
def _neigh_desc(stack, mean, basis, coords, i, j, h, bw, x, out):
    """Ñ_S(i, j): the stack colours at the 5 × 5 neighbours' pointers, projected. A
    neighbour outside the grid continues the nearest inside one's pointer by h per pixel,
    clamped into its box (as ``gather`` clamps): an exemplar's own map matches exactly."""
    Ht, Wt = coords.shape[0], coords.shape[1]
    Ha = stack.shape[0]
    C = stack.shape[2]
    t = 0
    for di in range(-2, 3):
        ii = min(max(i + di, 0), Ht - 1)
        for dj in range(-2, 3):
            jj = min(max(j + dj, 0), Wt - 1)
            sy = min(max(coords[ii, jj, 0] + h * (i + di - ii), 0), Ha - 1)
            x0 = (coords[ii, jj, 1] // bw) * bw
            sx = min(max(coords[ii, jj, 1] + h * (j + dj - jj), x0), x0 + bw - 1)
            for c in range(C):
                x[t] = np.float64(stack[sy, sx, c]) - mean[t]
                t += 1
    for a in range(basis.shape[1]):
        s = 0.0
        for u in range(x.shape[0]):
            s += x[u] * basis[u, a]
        out[a] = s


@njit(**PJIT)
def _subpass(level, inv_w, coords_old, coords_new, pi, pj, h, bw, jitter_threshold, seed, salt, coherence):
    """One parity sub-set (rows pi, pi + 2, ..; columns pj, pj + 2, ..) of a pass, reading
    ``coords_old`` and writing ``coords_new``. ``level``: the level's (stack, mean, basis, P, cand)."""
    stack, mean, basis, P, cand = level
    Ht, Wt = coords_old.shape[0], coords_old.shape[1]
    Ha = P.shape[0]
    nb = cand.shape[2]
    q = cand.shape[3]
    dims = basis.shape[1]
    ncand = 9 * (1 + nb * q)
    for r in prange((Ht - pi + 1) // 2):
        i = pi + 2 * r
        x = np.empty(basis.shape[0])
        nd = np.empty(dims)
        cyl = np.empty(ncand, np.int64)
        cxl = np.empty(ncand, np.int64)
        dl = np.empty(ncand)
        for j in range(pj, Wt, 2):
            _neigh_desc(stack, mean, basis, coords_old, i, j, h, bw, x, nd)
            nc = 0
            dmin = np.inf
            dmax = -np.inf
            for di in range(-1, 2):
                ii = i + di
                if ii < 0 or ii >= Ht:
                    continue
                for dj in range(-1, 2):
                    jj = j + dj
                    if jj < 0 or jj >= Wt:
                        continue
                    qy = coords_old[ii, jj, 0]
                    qx = coords_old[ii, jj, 1]
                    for t in range(1 + nb * q):
                        if t == 0:
                            py = qy
                            px = qx
                        else:
                            py = cand[qy, qx, (t - 1) // q, (t - 1) % q, 0]
                            px = cand[qy, qx, (t - 1) // q, (t - 1) % q, 1]
                            if py < 0:
                                continue
                        cy = py - h * di
                        cx = px - h * dj
                        x0 = (px // bw) * bw
                        if cy < 0 or cy >= Ha or cx < x0 or cx >= x0 + bw or inv_w[i, j, px // bw] == np.inf:
                            continue
                        s = 0.0
                        for a in range(dims):
                            e = nd[a] - P[cy, cx, a]
                            s += e * e
                        s *= inv_w[i, j, px // bw]
                        if t == 0:
                            s *= coherence
                        cyl[nc] = cy
                        cxl[nc] = cx
                        dl[nc] = s
                        nc += 1
                        dmin = min(dmin, s)
                        dmax = max(dmax, s)
            if nc == 0:
                coords_new[i, j, 0] = coords_old[i, j, 0]
                coords_new[i, j, 1] = coords_old[i, j, 1]
                continue
            pick = -1
            if jitter_threshold <= 0.0:
                for u in range(nc):
                    if dl[u] == dmin:
                        pick = u
                        break
            else:
                span = dmax - dmin
                nq = 0
                for u in range(nc):
                    if span <= 0.0 or (dl[u] - dmin) <= jitter_threshold * span:
                        nq += 1
                k = rand(seed, i * Wt + j, salt, 0) % nq
                for u in range(nc):
                    if span <= 0.0 or (dl[u] - dmin) <= jitter_threshold * span:
                        if k == 0:
                            pick = u
                            break
                        k -= 1
            coords_new[i, j, 0] = cyl[pick]
            coords_new[i, j, 1] = cxl[pick]


PARITIES = ((0, 0), (1, 1), (0, 1), (1, 0))


def run_pass(level: tuple, inv_w, coords, *, h: int, bw: int, jitter_threshold: float, seed: int, salt: int,
             coherence: float = 1.0) -> np.ndarray:
    """One pass of 4 parity sub-passes (each reads the state the previous left);
    ``jitter_threshold`` (the paper's J) 0: correction, > 0: structure-preserving jitter. ``level``: the analysis of the level,
    (stack, mean, basis, P, cand) (``synthesis.hybrid.Analysis.level``). ``inv_w``: 1 / weight per exemplar (nb,)
    or per state pixel and exemplar (Ht, Wt, nb); inf: never a candidate. Returns the new
    state. ``coherence`` (<= 1) multiplies the cost of the coherent candidates (a
    neighbour's pointer continued, coords[q] − h (q − p)): below 1 it favours copying whole
    regions (Ashikhmin 2001's coherence, as a factor)."""
    coords_old = np.ascontiguousarray(coords, np.int32).copy()
    inv_w = np.asarray(inv_w, np.float64)
    if inv_w.ndim == 1:
        inv_w = np.broadcast_to(inv_w, coords_old.shape[:2] + inv_w.shape)
    inv_w = np.ascontiguousarray(inv_w)
    coords_new = coords_old.copy()
    for k, (pi, pj) in enumerate(PARITIES):
        _subpass(level, inv_w, coords_old, coords_new, pi=pi, pj=pj, h=int(h), bw=int(bw),
                 jitter_threshold=float(jitter_threshold), seed=int(seed), salt=int(salt) * 4 + k,
                 coherence=float(coherence))
        coords_old[...] = coords_new
    return coords_old


@njit(**PJIT)
def _spatial(coords, h, r, bw, Ha, seed, out):
    Ht, Wt = coords.shape[0], coords.shape[1]
    for i in prange(Ht):
        for j in range(Wt):
            x0 = (coords[i, j, 1] // bw) * bw
            for c in range(2):
                xi = 2.0 * (rand(seed, i * Wt + j, c, 0) * (1.0 / 9007199254740992.0)) - 1.0
                v = coords[i, j, c] + int(np.floor(h * r * xi + 0.5))
                if c == 0:
                    out[i, j, 0] = min(max(v, 0), Ha - 1)
                else:
                    out[i, j, 1] = min(max(v, x0), x0 + bw - 1)


def spatial_jitter(coords: np.ndarray, *, h: int, r: float, bw: int, atlas_height: int, seed: int) -> np.ndarray:
    """The baseline's jitter: coords[p] + ⌊h r ξ + ½⌋ per coordinate, ξ uniform in [−1, 1),
    clamped into the pointer's box."""
    out = np.empty_like(coords, dtype=np.int32)
    _spatial(np.ascontiguousarray(coords, np.int32), int(h), float(r), int(bw), int(atlas_height), int(seed), out)
    return out


# ---------------------------------------------------------------------------
# measures (bench): label error


@njit(**PJIT)
def _nearest_chamfer(out_masks, ex_masks, best):
    for a in prange(out_masks.shape[0]):
        b = np.inf
        for e in range(ex_masks.shape[0]):
            d = chamfer_masks(out_masks[a], ex_masks[e])
            if d < b:
                b = d
        best[a] = b


def nearest_chamfer(out_masks: np.ndarray, ex_masks: np.ndarray) -> np.ndarray:
    """(M, n) and (E, n) uint32 label-window masks (``features.window_masks`` rows) ->
    (M,) float64: each output window's symmetric Chamfer distance
    (``chamfer.chamfer_masks``) to its nearest exemplar window, by exhaustive search (the
    bench passes the distinct windows only)."""
    best = np.empty(out_masks.shape[0])
    _nearest_chamfer(np.ascontiguousarray(out_masks, np.uint32), np.ascontiguousarray(ex_masks, np.uint32), best)
    return best
