"""Slow, obvious references for the synthesis kernels (used by the tests only)."""
import numpy as np

NB = 5


def window(lab, i, j, h=1):
    H, W = lab.shape
    return np.array([[lab[min(max(i + di * h, 0), H - 1), min(max(j + dj * h, 0), W - 1)]
                      for dj in range(-2, 3)] for di in range(-2, 3)])


def chamfer_one_way(a, b):
    s = 0
    for p in np.ndindex(NB, NB):
        same = np.argwhere(b == a[p])
        if len(same) == 0:
            s += 2 * NB
        else:
            s += int(np.abs(same - np.array(p)).max(1).min())
    return s


def chamfer(a, b):
    """The paper's symmetric Chamfer distance of two 5x5 label windows."""
    return chamfer_one_way(a, b) + chamfer_one_way(b, a)


def dist_window(d, i, j, h=1):
    return window(d, i, j, h).astype(np.float32)


def eq1(src_lab, src_dist, tgt_lab, tgt_dist, y, x, i, j, w, heights=None, hw=0.0):
    """eq. 1 as the kernels compute it: float32 differences, float64 row-major sum, after
    the height term (hw × (height difference))² (``heights`` = (source, target))."""
    a = dist_window(src_dist, y, x)
    b = dist_window(tgt_dist, i, j)
    s = 0.0 if heights is None else (hw * (float(heights[0][y, x]) - float(heights[1][i, j]))) ** 2
    for t in range(25):
        d = np.float32(a.flat[t] - b.flat[t])
        s += float(np.float32(d * d))
    return np.sqrt(s) + w * chamfer(window(src_lab, y, x), window(tgt_lab, i, j))


def flood_fill(src_lab, src_dist, tgt_lab, tgt_dist, order, w, ts, to, seed, heights=None, hw=0.0, mask=None,
               S0=None, patch0=None):
    """Patches grown from the pixels in ``order``; each search scans the same-label
    exemplar pixels (row-major) from a start drawn from (seed, pixel), ties to the first.
    With ``mask``, only masked pixels are covered, the others keep ``S0`` and ``patch0``."""
    from proxyshade.kernels.random import rand
    He, We = src_lab.shape
    Ht, Wt = tgt_lab.shape
    free = np.ones((Ht, Wt), bool) if mask is None else mask.copy()
    S = np.zeros((Ht, Wt, 2), int) if mask is None else S0.astype(int).copy()
    patch = np.zeros((Ht, Wt), int) if mask is None else patch0.astype(int).copy()
    pid = 0 if mask is None else int(patch0.max())
    for p in order:
        i, j = divmod(int(p), Wt)
        if not free[i, j]:
            continue
        pid += 1
        best, bc = np.inf, None
        cands = [(y, x) for y in range(He) for x in range(We) if src_lab[y, x] == tgt_lab[i, j]]
        start = int(rand(seed, int(p), 0x5CA7, 0)) % len(cands)
        for y, x in cands[start:] + cands[:start]:
            d = eq1(src_lab, src_dist, tgt_lab, tgt_dist, y, x, i, j, w, heights, hw)
            if d < best:
                best, bc = d, (y, x)
        oy, ox = bc[0] - i, bc[1] - j
        thr = ts * best + to
        queue = [(i, j)]
        seen = {(i, j)}
        first = True
        while queue:
            a, b = queue.pop(0)
            y, x = a + oy, b + ox
            if not first:
                if not (0 <= y < He and 0 <= x < We) or src_lab[y, x] != tgt_lab[a, b]:
                    continue
                if eq1(src_lab, src_dist, tgt_lab, tgt_dist, y, x, a, b, w, heights, hw) > thr:
                    continue
            first = False
            free[a, b] = False
            patch[a, b] = pid
            S[a, b] = (y, x)
            for da, db in ((-1, 0), (1, 0), (0, -1), (0, 1)):
                q = (a + da, b + db)
                if 0 <= q[0] < Ht and 0 <= q[1] < Wt and free[q] and q not in seen:
                    seen.add(q)
                    queue.append(q)
    return S, patch


def rejected(S, i, j, cy, cx, h, radius, half=4):
    Ht, Wt = S.shape[:2]
    for di in range(-half, half + 1):
        for dj in range(-half, half + 1):
            ii, jj = i + di, j + dj
            if (di, dj) == (0, 0) or not (0 <= ii < Ht and 0 <= jj < Wt):
                continue
            dy, dx = S[ii, jj, 0] - cy, S[ii, jj, 1] - cx
            if (dy, dx) == (h * di, h * dj):
                continue
            if abs(dy) <= radius and abs(dx) <= radius:
                return True
    return False


def far_copy(S, i, j, cy, cx, h, reach2, r):
    """Whether any target pixel q != (i, j) within sqrt(reach2) (Euclidean) uses an exemplar
    pixel within r (L-inf) of (cy, cx) without being coherent with it, every pixel looked at."""
    Ht, Wt = S.shape[:2]
    for ii in range(Ht):
        for jj in range(Wt):
            di, dj = ii - i, jj - j
            if (di, dj) == (0, 0) or di * di + dj * dj > reach2:
                continue
            dy, dx = int(S[ii, jj, 0]) - cy, int(S[ii, jj, 1]) - cx
            if abs(dy) <= r and abs(dx) <= r and (dy, dx) != (h * di, h * dj):
                return True
    return False


def correct_pixel(lv, knn, S, i, j, radius, w, kappa, hw=0.0, over=None, uniformity=0.0, zw=0.0, zs=None, zt=None,
                  far=None):
    """One pixel of a correction sub-pass, written out (height term weight ``hw``;
    distances x (1 + uniformity x over[candidate]); with ``zw`` > 0 also x (1 + zw (zs[candidate]
    - zt[i, j])^2)); ``far`` (reach2 per label, r): candidates with another copy of their
    spot within sqrt(reach2[label]) rejected too (``far_copy``)."""
    h = lv.h
    He, We = lv.src_lab.shape
    Ht, Wt = lv.tgt_lab.shape
    lab = lv.tgt_lab[i, j]
    k = knn.shape[2]
    cands = []  # [(cy, cx, coherent)] in kernel order, deduplicated
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            ii, jj = i + di, j + dj
            if not (0 <= ii < Ht and 0 <= jj < Wt):
                continue
            qy, qx = S[ii, jj]
            for t in range(k + 1):
                if t == 0:
                    cy, cx = qy - h * di, qx - h * dj
                else:
                    cy, cx = knn[qy, qx, t - 1, 0] - h * di, knn[qy, qx, t - 1, 1] - h * dj
                if not (0 <= cy < He and 0 <= cx < We) or lv.src_lab[cy, cx] != lab:
                    continue
                for u, c in enumerate(cands):
                    if c[:2] == (cy, cx):
                        cands[u] = (cy, cx, c[2] or t == 0)
                        break
                else:
                    cands.append((cy, cx, t == 0))
    target_dist = dist_window(lv.tgt_dist, i, j)
    tRGB = np.array([[lv.src_rgb[tuple(S[min(max(i + di, 0), Ht - 1), min(max(j + dj, 0), Wt - 1)])]
                      for dj in range(-2, 3)] for di in range(-2, 3)], np.float32)
    tW = window(lv.tgt_lab, i, j)

    def dist(cy, cx):
        a = dist_window(lv.src_dist, cy, cx, h)
        sd = (hw * (float(lv.src_height[cy, cx]) - float(lv.tgt_height[i, j]))) ** 2
        for t in range(25):
            d = np.float32(a.flat[t] - target_dist.flat[t])
            sd += float(np.float32(d * d))
        sr = 0.0
        for t, (di, dj) in enumerate(np.ndindex(5, 5)):
            yy = min(max(cy + (di - 2) * h, 0), He - 1)
            xx = min(max(cx + (dj - 2) * h, 0), We - 1)
            for c in range(3):
                e = np.float32(lv.src_rgb[yy, xx, c] - tRGB[di, dj, c])
                sr += float(np.float32(e * e))
        return np.sqrt(sd + sr) + w * chamfer(window(lv.src_lab, cy, cx, h), tW)

    def mult(cy, cx, coh):
        f = (1.0 if coh else 1.0 + kappa) * (1.0 + uniformity * (0.0 if over is None else over[cy, cx]))
        return f * (1.0 + zw * (zs[cy, cx] - zt[i, j]) ** 2) if zw > 0 else f

    best, by = np.inf, tuple(S[i, j])
    for cy, cx, coh in cands:
        if rejected(S, i, j, cy, cx, h, radius):
            continue
        if far is not None and far[0][lab] > 0 and far_copy(S, i, j, cy, cx, h, far[0][lab], far[1]):
            continue
        d = mult(cy, cx, coh) * dist(cy, cx)
        if d < best:
            best, by = d, (cy, cx)
    if best == np.inf and lv.src_lab[by] != lab:
        for cy, cx, coh in cands:
            d = mult(cy, cx, coh) * dist(cy, cx)
            if d < best:
                best, by = d, (cy, cx)
    return by
