"""Patch seams moved to where the patches agree (kernels.seams) against a plain-Python
reference of the same iterated conditional modes."""
import numpy as np
import pytest

from proxyshade.kernels import seams as ks

N4 = ((-1, 0), (0, -1), (0, 1), (1, 0))


def ref_cost(img, a, b):
    Hs, Ws, _ = img.shape
    if not (0 <= a[0] < Hs and 0 <= a[1] < Ws and 0 <= b[0] < Hs and 0 <= b[1] < Ws):
        return ks.OUTSIDE
    return float(((img[a].astype(np.float64) - img[b]) ** 2).sum())


def ref_energy(S, img, target, i, j, off):
    H, W = target.shape
    e = 0.0
    for dy, dx in N4:
        y, x = i + dy, j + dx
        if not (0 <= y < H and 0 <= x < W) or target[y, x] != target[i, j]:
            continue
        q = (S[y, x, 0] - y, S[y, x, 1] - x)
        if q == off:
            continue
        e += ref_cost(img, (i + off[0], j + off[1]), (i + q[0], j + q[1]))
        e += ref_cost(img, (y + off[0], x + off[1]), (y + q[0], x + q[1]))
    return e


def ref_total(S, img, target):
    """The seam cost of the whole map, each pair once (the move's gain is its change)."""
    H, W = target.shape
    tot = 0.0
    for i in range(H):
        for j in range(W):
            for dy, dx in ((0, 1), (1, 0)):
                y, x = i + dy, j + dx
                if y >= H or x >= W or target[y, x] != target[i, j]:
                    continue
                a, b = (S[i, j, 0] - i, S[i, j, 1] - j), (S[y, x, 0] - y, S[y, x, 1] - x)
                if a != b:
                    tot += ref_cost(img, (i + a[0], j + a[1]), (i + b[0], j + b[1]))
                    tot += ref_cost(img, (y + a[0], x + a[1]), (y + b[0], x + b[1]))
    return tot


def ref_runs(S, img, target, labels):
    """Run moves: even rows, odd rows (pixels left to right, up then down), even columns,
    odd columns (top to bottom, left then right); each run (from its first pixel) tries
    every contiguous part, judged by the whole map's seam cost before and after; the part
    that lowers it most (the first such, by last then first pixel) moves."""
    H, W = target.shape
    off = lambda u, v: (S[u, v, 0] - u, S[u, v, 1] - v)  # noqa: E731
    order = [(i, j, d) for par in (0, 1) for i in range(par, H, 2) for j in range(W) for d in (N4[0], N4[3])]
    order += [(i, j, d) for par in (0, 1) for j in range(par, W, 2) for i in range(H) for d in (N4[1], N4[2])]
    moved = 0
    for i, j, (dy, dx) in order:
        y, x = i + dy, j + dx
        if not (0 <= y < H and 0 <= x < W) or target[y, x] != target[i, j]:
            continue
        a, b = off(i, j), off(y, x)
        if a == b:
            continue
        ey, ex = abs(dx), abs(dy)

        def continues(u, v):
            return (0 <= u < H and 0 <= v < W and 0 <= u + dy < H and 0 <= v + dx < W
                    and target[u, v] == target[i, j] and target[u + dy, v + dx] == target[i, j]
                    and off(u, v) == a and off(u + dy, v + dx) == b)

        if continues(i - ey, j - ex):
            continue
        run = []
        while continues(i + len(run) * ey, j + len(run) * ex):
            run.append((i + len(run) * ey, j + len(run) * ex))
        before = ref_total(S, img, target)
        best, pick = 0.0, None
        for h in range(len(run)):
            for lo in range(h + 1):
                part = run[lo:h + 1]
                if not all(0 <= u + b[0] < labels.shape[0] and 0 <= v + b[1] < labels.shape[1]
                           and labels[u + b[0], v + b[1]] == target[u, v] for u, v in part):
                    continue
                T = S.copy()
                for u, v in part:
                    T[u, v] = (u + b[0], v + b[1])
                gain = before - ref_total(T, img, target)
                if gain > best + 1e-9:
                    best, pick = gain, T
        if pick is not None:
            moved += int((pick != S).any(-1).sum())
            S[...] = pick
    return moved


def ref_refine(S, img, target, labels, passes, runs=False):
    S = S.copy()
    H, W = target.shape
    for _ in range(passes):
        moved = 0
        for parity in (0, 1):
            new = S.copy()  # a half reads only the other parity, so order inside it is free
            for i in range(H):
                for j in range(W):
                    if (i + j) % 2 != parity:
                        continue
                    own = (S[i, j, 0] - i, S[i, j, 1] - j)
                    nbr = [(S[i + dy, j + dx, 0] - i - dy, S[i + dy, j + dx, 1] - j - dx) for dy, dx in N4
                           if 0 <= i + dy < H and 0 <= j + dx < W and target[i + dy, j + dx] == target[i, j]]
                    if all(o == own for o in nbr):
                        continue
                    best, pick = ref_energy(S, img, target, i, j, own), own
                    for o in nbr:
                        sy, sx = i + o[0], j + o[1]
                        if o in (own, pick) or not (0 <= sy < labels.shape[0] and 0 <= sx < labels.shape[1]):
                            continue
                        if labels[sy, sx] != target[i, j]:
                            continue
                        e = ref_energy(S, img, target, i, j, o)
                        if e < best:
                            best, pick = e, o
                    if pick != own:
                        new[i, j] = (i + pick[0], j + pick[1])
                        moved += 1
            S = new
        if runs:
            moved += ref_runs(S, img, target, labels)
        if moved == 0:
            break
    return S


def random_case(seed, H=14, W=17, Hs=30, Ws=32, nlab=2):
    rng = np.random.default_rng(seed)
    img = rng.random((Hs, Ws, 3)).astype(np.float32)
    labels = (rng.random((Hs, Ws)) < 0.15).astype(np.int32) if nlab == 2 else np.zeros((Hs, Ws), np.int32)
    target = np.zeros((H, W), np.int32)
    target[:, W - 3:] = nlab - 1
    # blocks of 4x4 pixels, each with one random offset (a magnified synthesis map)
    S = np.empty((H, W, 2), np.int32)
    for bi in range(0, H, 4):
        for bj in range(0, W, 4):
            oy, ox = rng.integers(-bi, Hs - bi - 4), rng.integers(-bj, Ws - bj - 4)
            ii, jj = np.mgrid[bi:min(bi + 4, H), bj:min(bj + 4, W)]
            S[ii, jj, 0], S[ii, jj, 1] = ii + oy, jj + ox
    return S, img, target, labels


@pytest.mark.parametrize("seed", range(6))
def test_matches_reference_exactly(seed):
    S, img, target, labels = random_case(seed)
    got, moves = ks.refine_seams(S, img, target, labels, 3)
    want = ref_refine(S, img, target, labels, 3)
    assert np.array_equal(got, want)
    assert moves >= int((got != S).any(-1).sum())  # a pixel may move twice


@pytest.mark.parametrize("seed", range(4))
def test_seam_cost_never_rises_and_labels_hold(seed):
    S, img, target, labels = random_case(seed, nlab=2)
    before = ks.seam_cost(S, img, target)
    out, moves = ks.refine_seams(S, img, target, labels, 6)
    assert moves > 0
    assert ks.seam_cost(out, img, target) < before
    # every pixel that moved reads a source pixel of its own label
    moved = (out != S).any(-1)
    assert (labels[out[moved, 0], out[moved, 1]] == target[moved]).all()


def test_a_seam_moves_to_where_the_patches_agree():
    # one row read by two patches at offsets 0 and +10 columns from an image of period 10
    # except a stripe at columns 4-5: a seam costs only where it touches the stripe, so the
    # seam put at 4|5 moves left off it (a single row: each pixel's only neighbours are along
    # it; a straight seam across many rows is a local minimum of these one-pixel moves)
    rng = np.random.default_rng(3)
    img = np.tile(rng.random((1, 10, 1)).astype(np.float32), (1, 4, 1))
    img[:, 4:6] += 1.0
    S = np.stack(np.mgrid[0:1, 0:12], -1).astype(np.int32)
    S[:, 8:, 1] += 10
    target, labels = np.zeros((1, 12), np.int32), np.zeros((1, 40), np.int32)
    assert ks.seam_cost(S, img, target) == 0.0  # 7|8 reads agree already: nothing to do
    out, moves = ks.refine_seams(S, img, target, labels, 4)
    assert moves == 0 and np.array_equal(out, S)
    S[:, 5:, 1] = np.arange(5, 12)[None] + 10  # the seam moved into the stripe: it costs
    assert ks.seam_cost(S, img, target) > 0
    out, moves = ks.refine_seams(S, img, target, labels, 8)
    assert ks.seam_cost(out, img, target) == 0.0 and moves > 0


@pytest.mark.parametrize("seed", range(6))
def test_run_moves_match_reference_exactly(seed):
    S, img, target, labels = random_case(seed, H=13, W=15, Hs=26, Ws=28)
    got, moves = ks.refine_seams(S, img, target, labels, 3, runs=True)
    want = ref_refine(S, img, target, labels, 3, runs=True)
    assert np.array_equal(got, want)
    assert moves >= int((got != S).any(-1).sum())


@pytest.mark.parametrize("seed,shape", [(0, (8, 40)), (1, (8, 40)), (0, (40, 8))])
def test_run_moves_passing_over_unchanged_stretches_match_reference(seed, shape):
    # long lines on which later passes change a few places: ``_run_pass`` tries again only
    # the stretches with a change near them (and the runs reaching them); the maps after a
    # call, and after a second call on one memory once a few pixels far along the lines were
    # moved, are the full scan's
    H, W = shape
    S, img, target, labels = random_case(seed, H=H, W=W, Hs=H + 24, Ws=W + 24)
    img = (img + np.roll(img, 1, 0) + np.roll(img, 1, 1) + np.roll(img, -1, 1)) / 4
    memory = ks.SeamMemory()
    first, _ = ks.refine_seams(S, img, target, labels, 4, runs=True, memory=memory)
    assert np.array_equal(first, ref_refine(S, img, target, labels, 4, runs=True))
    edited = first.copy()
    edited[H - 6:H - 3, W - 7:W - 4, 0] += 1  # a small patch moved near one end of the lines
    got, _ = ks.refine_seams(edited, img, target, labels, 4, runs=True, memory=memory)
    assert np.array_equal(got, ref_refine(edited, img, target, labels, 4, runs=True))


def test_a_straight_seam_shifts_where_one_pixel_moves_stick():
    # two patches side by side over 12 rows (offsets 0 and +20 columns); D[r, c], how far
    # the two offsets' colours differ at pixel (r, c), is set per column: the seam at 4|5
    # costs D4 + D5 = 0.4 a row, at 3|4 0.1 (0.5 on the end rows). One pixel of column 4
    # moved alone adds two across-row pairs (0.2 each), more than it saves, so the one-pixel
    # moves leave the seam (a local minimum); the run move shifts the whole column
    rng = np.random.default_rng(5)
    H, W = 12, 10
    D = np.tile(np.array([1, 1, 1, 0, 0.1, 0.3, 1, 1, 1, 1.0]), (H, 1))
    D[[0, -1], 3] = 0.4
    base = rng.random((H, W, 3))
    img = np.zeros((H, 40, 3), np.float32)
    img[:, :W] = base
    img[:, 20:20 + W] = base + np.sqrt(D / 3)[..., None]
    S = np.stack(np.mgrid[0:H, 0:W], -1).astype(np.int32)
    S[:, 5:, 1] += 20
    target, labels = np.zeros((H, W), np.int32), np.zeros((H, 40), np.int32)
    c0 = ks.seam_cost(S, img, target)
    assert c0 == pytest.approx(H * 0.4, rel=1e-4)
    one, moves = ks.refine_seams(S, img, target, labels, 8)
    assert moves == 0 and np.array_equal(one, S)
    run, moves = ks.refine_seams(S, img, target, labels, 8, runs=True)
    assert moves == H and (run[:, 4, 1] == 24).all() and (run[:, 3, 1] == 3).all()
    assert ks.seam_cost(run, img, target) == pytest.approx(10 * 0.1 + 2 * 0.5, rel=1e-4)


def ref_shift(S, img, target, labels, patch, radius, passes, adopt=0):
    """Whole-patch shifts: patches in id order, each takes the offset within ``radius`` of
    its own (rows then columns, ascending) whose seams to the pixels outside it cost
    least, strictly less than its own, where every pixel of it reads its label (its own
    offset need not) and its label's spread (Σ (tone − the label's mean tone on the source
    grid)², tone the channel sum, over its patches) stays at least 1 − SPREAD_LOSS of what
    it was before the first pass; a patch of at most ``adopt`` pixels then the offsets of
    the patches beside it farther than ``radius`` (the first 8 met: its pixels in raster
    order, neighbours up, left, right, down). A patch across a label border is one patch
    per label (ids in order of (patch, label))."""
    S = S.copy()
    H, W = target.shape
    Hs, Ws = labels.shape
    nl = int(max(labels.max(), target.max())) + 1
    pieces = {}
    for i, j in sorted(zip(*np.nonzero(np.ones_like(target))), key=lambda p: (patch[p], target[p], p)):
        pieces.setdefault((int(patch[i, j]), int(target[i, j])), []).append((i, j))
    patch = np.zeros_like(target, dtype=np.int64)
    for n, key in enumerate(sorted(pieces), 1):
        for p in pieces[key]:
            patch[p] = n
    tone = img.astype(np.float64).sum(-1)
    mu = [sum(tone[labels == lab].tolist(), 0.0) / max(int((labels == lab).sum()), 1) for lab in range(nl)]

    def spread(pix, off):
        s = 0.0
        for i, j in pix:
            if 0 <= i + off[0] < Hs and 0 <= j + off[1] < Ws:
                v = -mu[int(target[i, j])]
                for c in img[i + off[0], j + off[1]]:
                    v += float(c)
                s += v * v
        return s

    tot = [0.0] * nl
    for pid in range(1, int(patch.max()) + 1):
        pix = list(zip(*np.nonzero(patch == pid)))
        tot[int(target[pix[0]])] += spread(pix, (S[pix[0]][0] - pix[0][0], S[pix[0]][1] - pix[0][1]))
    floor = [t * (1.0 - ks.SPREAD_LOSS) for t in tot]
    moves = 0
    for _ in range(passes):
        moved = 0
        for pid in range(1, int(patch.max()) + 1):
            pix = list(zip(*np.nonzero(patch == pid)))
            if not pix:
                continue
            i0, j0 = pix[0]
            own = (S[i0, j0, 0] - i0, S[i0, j0, 1] - j0)

            def across():  # (pixel, its same-label neighbour outside the patch, that one's offset)
                for i, j in pix:
                    for dy, dx in N4:
                        y, x = i + dy, j + dx
                        if 0 <= y < H and 0 <= x < W and target[y, x] == target[i, j] and patch[y, x] != pid:
                            yield i, j, y, x, (S[y, x, 0] - y, S[y, x, 1] - x)

            lab = int(target[i0, j0])
            least = spread(pix, own) - (tot[lab] - floor[lab])

            def cost(off, check=True):
                if check and not all(0 <= i + off[0] < Hs and 0 <= j + off[1] < Ws and labels[i + off[0], j + off[1]] == target[i, j]
                           for i, j in pix):
                    return np.inf
                if check and spread(pix, off) < least:
                    return np.inf
                e = 0.0
                for i, j, y, x, q in across():
                    if q != off:
                        e += ref_cost(img, (i + off[0], j + off[1]), (i + q[0], j + q[1]))
                        e += ref_cost(img, (y + off[0], x + off[1]), (y + q[0], x + q[1]))
                return e

            best, pick = cost(own, check=False), own
            for dy in range(-radius, radius + 1):
                for dx in range(-radius, radius + 1):
                    if (dy, dx) != (0, 0) and (e := cost((own[0] + dy, own[1] + dx))) < best:
                        best, pick = e, (own[0] + dy, own[1] + dx)
            if len(pix) <= adopt:
                cands = []
                for *_, q in across():
                    if max(abs(q[0] - own[0]), abs(q[1] - own[1])) > radius and q not in cands and len(cands) < 8:
                        cands.append(q)
                for q in cands:
                    if (e := cost(q)) < best:
                        best, pick = e, q
            if pick != own:
                tot[lab] += spread(pix, pick) - spread(pix, own)
                for i, j in pix:
                    S[i, j] = (i + pick[0], j + pick[1])
                moved += 1
        moves += moved
        if moved == 0:
            break
    return S, moves


@pytest.mark.parametrize("seed,adopt", [(s, a) for s in range(6) for a in (0, 6, 10**6)])
def test_patch_shifts_match_reference_exactly(seed, adopt):
    from proxyshade.kernels.patch import offset_components
    S, img, target, labels = random_case(seed, H=13, W=15, Hs=26, Ws=28)
    img = (img + np.roll(img, 1, 0) + np.roll(img, 1, 1)) / 3  # neighbours alike: a shift can pay off
    patch, _ = offset_components(S)
    got, moves = ks.shift_patches(S, img, target, labels, patch, 1 + seed % 2, 3, adopt)
    want, want_moves = ref_shift(S, img, target, labels, patch, 1 + seed % 2, 3, adopt)
    assert np.array_equal(got, want) and moves == want_moves


@pytest.mark.parametrize("seed,loss", [(s, q) for s in range(6) for q in (0.0, 0.05)])
def test_patch_shifts_under_a_tight_spread_budget_match_reference(seed, loss, monkeypatch):
    # three labels, the target's borders ragged (patches across them move per label), and a
    # budget that refuses moves: a piece refused for its label's spread must be tried again
    # once another piece's move has given that label spread back (seeds 3 and 4 need that)
    from proxyshade.kernels.patch import offset_components
    rng = np.random.default_rng(seed)
    S, img, target, labels = random_case(seed, H=14, W=16, Hs=26, Ws=28)
    img = (img + np.roll(img, 1, 0) + np.roll(img, 1, 1)) / 3
    labels = np.digitize(np.arange(28), [10, 19])[None].repeat(26, 0).astype(np.int32)
    target = np.digitize(np.arange(16) + rng.integers(-2, 3, (14, 1)), [6, 11]).astype(np.int32)
    patch, _ = offset_components(S)
    monkeypatch.setattr(ks, "SPREAD_LOSS", loss)
    got, moves = ks.shift_patches(S, img, target, labels, patch, 2, 3, 6)
    want, want_moves = ref_shift(S, img, target, labels, patch, 2, 3, 6)
    assert np.array_equal(got, want) and moves == want_moves
    monkeypatch.setattr(ks, "SPREAD_LOSS", 1.0)  # the budget decides some moves
    assert not np.array_equal(ks.shift_patches(S, img, target, labels, patch, 2, 3, 6)[0], got)
    assert np.array_equal(ks.shift_patches(S, img, target, labels, patch, 2, 3, 6, spread_loss=loss)[0], got)


@pytest.mark.parametrize("seed", range(4))
def test_patch_shifts_lower_the_seam_cost_and_keep_labels(seed):
    from proxyshade.kernels.patch import offset_components
    S, img, target, labels = random_case(seed, nlab=2)
    img = (img + np.roll(img, 1, 0) + np.roll(img, 1, 1)) / 3
    patch, _ = offset_components(S)
    before = ks.seam_cost(S, img, target)
    out, moves = ks.shift_patches(S, img, target, labels, patch, 2, 2)
    assert moves > 0 and ks.seam_cost(out, img, target) < before
    moved = (out != S).any(-1)
    assert (labels[out[moved, 0], out[moved, 1]] == target[moved]).all()
    # a patch moves whole, one piece per label: every pixel of one patch and label keeps one offset
    off = out - np.stack(np.mgrid[0:S.shape[0], 0:S.shape[1]], -1)
    for pid in np.unique(patch):
        for lab in np.unique(target[patch == pid]):
            assert len(np.unique(off[(patch == pid) & (target == lab)], axis=0)) == 1


def test_a_patch_shifts_onto_its_neighbours_texture():
    # a smooth ramp image; the right half reads it 2 columns off its neighbour's continuation
    # (as a magnified patch placed to a whole synthesis pixel would): the shift joins them
    H, W = 8, 12
    img = np.broadcast_to(np.linspace(0, 1, 40, dtype=np.float32)[None, :, None] ** 2, (H, 40, 3)).copy()
    S = np.stack(np.mgrid[0:H, 0:W], -1).astype(np.int32)
    S[:, 6:, 1] += 2
    target, labels = np.zeros((H, W), np.int32), np.zeros((H, 40), np.int32)
    from proxyshade.kernels.patch import offset_components
    patch, n = offset_components(S)
    assert n == 2 and ks.seam_cost(S, img, target) > 0
    out, moves = ks.shift_patches(S, img, target, labels, patch, 2, 2)
    assert moves == 1 and ks.seam_cost(out, img, target) == 0.0


@pytest.mark.parametrize("seed,wrap", [(s, w) for s in range(4) for w in (0, 243, 247, 251, 254)])
def test_seam_memory_over_calls_matches_reference(seed, wrap):
    # Magnify's order: seam moves, whole-patch shifts, seam moves again on one memory (the
    # second call tries again only what the shifts changed); with ``wrap`` its 8-bit clock
    # jumps there and wraps during the second call (every mark cleared)
    from proxyshade.kernels.patch import offset_components
    S, img, target, labels = random_case(seed, H=13, W=15, Hs=26, Ws=28)
    img = (img + np.roll(img, 1, 0) + np.roll(img, 1, 1)) / 3
    memory = ks.SeamMemory()
    first, _ = ks.refine_seams(S, img, target, labels, 2, runs=True, memory=memory)
    assert np.array_equal(first, ref_refine(S, img, target, labels, 2, runs=True))
    shifted, moves = ks.shift_patches(first, img, target, labels, offset_components(first)[0], 2, 2, 6)
    assert moves > 0
    if wrap:
        memory.clock = wrap
    got, _ = ks.refine_seams(shifted, img, target, labels, 3, runs=True, memory=memory)
    assert np.array_equal(got, ref_refine(shifted, img, target, labels, 3, runs=True))


def test_a_shift_does_not_draw_a_patch_onto_its_labels_mean_tone():
    # one label: a flat grey field with a bright streak (its tail). A patch (one column)
    # reads the streak; moved a column either way it would read grey and its seams would
    # vanish, but the label would lose its tail (bench_photos: the sunset's near-black
    # vegetation std 0.88 -> 0.70 from such shifts), so it stays
    H, W = 6, 9
    img = np.full((H, 30, 3), 0.5, np.float32)
    img[:, 14, :] = 1.0
    S = np.stack(np.mgrid[0:H, 0:W], -1).astype(np.int32)
    S[:, 4, 1] = 14
    target, labels = np.zeros((H, W), np.int32), np.zeros((H, 30), np.int32)
    from proxyshade.kernels.patch import offset_components
    patch, n = offset_components(S)
    assert n == 3 and ks.seam_cost(S, img, target) > 0
    out, _ = ks.shift_patches(S, img, target, labels, patch, 1, 2, adopt=64)
    assert (img[out[..., 0], out[..., 1], 0] == 1.0).sum() == H  # the streak is still read, whole
