"""Display conversion: a plate's chosen channels as an 8-bit sRGB picture for people.

Colour channels go through a view transform (``view``) and the sRGB encoding (IEC
61966-2-1, via colour-science), id
channels get distinct colours (the label table's own where known, otherwise golden-ratio
hues), depth-like channels a grey ramp between their 1st and 99th percentiles. Shared by
the Preview and Movie nodes; living among the kernels, it is part of their cache keys.
"""
from __future__ import annotations


import lazy_loader

from proxyshade.io.colourlib import encode_srgb8

np = lazy_loader.load("numpy")  # on first use: a fully cached run never loads numpy


DEFAULT_CHANNELS = ("R", "G", "B")
VIEWS = ("shoulder", "clip")
KNEE = 0.9  # linear value where the shoulder view starts to roll off
ROWS = 128  # rows converted at a time by to_display (each pixel on its own: the same bytes in any band)


def view_transform(rgb: np.ndarray, view: str = "shoulder") -> np.ndarray:
    """Scene-referred linear values (>= 0, may exceed 1) to display-referred linear in
    [0, 1]. ``clip``: min(x, 1) (exact below 1, every value above shown as white).
    ``shoulder`` (the default): the identity up to ``KNEE`` (0.9), then
    ``KNEE + (1 - KNEE) tanh((x - KNEE) / (1 - KNEE))``: continuous with slope 1 at the
    knee, strictly increasing, approaching 1 (x = 1 shows as 0.976, 1.5 as 0.9995), so a
    sky brighter than white keeps its gradations instead of flattening into one value.
    Negative values show as 0 in both."""
    rgb = np.maximum(np.asarray(rgb, np.float64), 0.0)
    if view == "clip":
        return np.minimum(rgb, 1.0)
    if view != "shoulder":
        raise ValueError(f"view {view!r}: choose one of {', '.join(VIEWS)}")
    span = 1.0 - KNEE
    return np.where(rgb <= KNEE, rgb, KNEE + span * np.tanh((rgb - KNEE) / span))


def channels_problem(names: list[str], channels: list[str]) -> str | None:
    """Why ``channels`` cannot be shown from a plate holding ``names`` (with the fix), or None."""
    missing = [c for c in channels if c not in names]
    if missing:
        return f"channels {missing} are not in the input; it has {', '.join(names)}"
    if len(channels) not in (1, 3):
        return f"channels {channels}: give one channel or three"
    return None


def _hues(ids: np.ndarray) -> np.ndarray:
    """(N, 3) uint8 golden-ratio hues of ``ids`` (N,): ``colorsys.hsv_to_rgb`` at hue
    ``id × 0.618… mod 1``, saturation 0.65, value 0.95, each channel × 255 truncated; the same
    float64 operations in the same order, so the same bytes."""
    s, v = 0.65, 0.95
    h6 = (ids.astype(np.float64) * 0.618033988749895) % 1.0 * 6.0
    i = np.trunc(h6)
    f = h6 - i
    p, q, t = np.full_like(f, v * (1.0 - s)), v * (1.0 - s * f), v * (1.0 - s * (1.0 - f))
    vv = np.full_like(f, v)
    sector = i.astype(np.int64) % 6
    pick = [(vv, t, p), (q, vv, p), (p, vv, t), (p, q, vv), (t, p, vv), (vv, p, q)]
    rgb = np.stack([np.choose(sector, [c[k] for c in pick]) for k in range(3)], -1)
    return (rgb * 255).astype(np.uint8)  # each in [0, 255): truncated as int() does


LUT_MAX = 1 << 22  # largest id looked up through a table of every id up to it (else: np.unique)


def id_palette(ids: np.ndarray, labels: list[dict] | None = None) -> np.ndarray:
    """Distinct 8-bit colours for an id map: the label table's colours where known,
    otherwise golden-ratio hues; id 0 is black. Ids of an unsigned or non-negative integer
    map up to ``LUT_MAX`` and the frame's size are coloured through a table of every id up
    to the largest, a band of ``ROWS`` rows at a time (no frame-wide sort, no frame-wide
    index temporaries); others through ``np.unique``: the same bytes."""
    known = {}
    for t in labels or []:
        c = t["color"].lstrip("#")
        known[int(t["id"])] = [int(c[i:i + 2], 16) for i in (0, 2, 4)]
    ids = np.asarray(ids)
    top = int(ids.max()) if ids.size and ids.dtype.kind in "ui" else -1
    if 0 <= top <= min(LUT_MAX, max(ids.size, 255)) and (ids.dtype.kind == "u" or int(ids.min()) >= 0):
        lut = _hues(np.arange(top + 1))
        lut[0] = 0
        for u, c in known.items():
            if 0 <= u <= top:
                lut[u] = c
        out = np.empty(ids.shape + (3,), np.uint8)
        chans = [np.ascontiguousarray(lut[:, k]) for k in range(3)]  # a flat table per channel: np.take's fast path
        flat = out.reshape(-1, 3) if ids.ndim < 2 else out
        for r0 in range(0, max(flat.shape[0], 1), ROWS):
            band = ids.reshape(-1)[r0:r0 + ROWS] if ids.ndim < 2 else ids[r0:r0 + ROWS]
            for k in range(3):
                flat[r0:r0 + ROWS, ..., k] = np.take(chans[k], band)
        return out
    uniq, inv = np.unique(ids, return_inverse=True)
    pal = _hues(uniq)
    pal[uniq == 0] = 0
    for i, u in enumerate(uniq.tolist()):
        if u in known:
            pal[i] = known[u]
    return pal[inv.reshape(ids.shape)]


def to_display(plate, channels: list[str], exposure: float = 0.0, view: str = "shoulder") -> np.ndarray:
    """(H, W, 3) uint8 sRGB picture of ``channels`` of ``plate``: ids in distinct colours,
    depth as grey, colour through ``view_transform`` and colour-science's sRGB encoding."""
    arrs = [plate[c] for c in channels]
    if len(arrs) == 1 and arrs[0].dtype == np.uint32:
        return id_palette(arrs[0], plate.meta.get("labels") if channels[0] == "label.id" else None)
    if len(arrs) == 1 and channels[0] in ("Z", "depth.Z", "distortion") or (len(arrs) == 1 and arrs[0].dtype != np.uint32 and channels[0] not in "RGB"):
        z = arrs[0].astype(np.float64)
        fin = np.isfinite(z)
        out = np.zeros(z.shape, np.float64)
        if fin.any():
            lo, hi = np.percentile(z[fin], [1, 99])
            out[fin] = 1.0 - np.clip((z[fin] - lo) / max(hi - lo, 1e-12), 0, 1)
        g = (out * 255 + 0.5).astype(np.uint8)
        return np.repeat(g[..., None], 3, axis=2)
    h, w = arrs[0].shape[:2]
    out = np.empty((h, w, 3), np.uint8)
    for r0 in range(0, h, ROWS):  # a band of rows at a time: the float64 temporaries of a band, not a frame
        band = [a[r0:r0 + ROWS] for a in arrs]
        rgb = np.stack([a.astype(np.float64) for a in band], -1)
        if rgb.shape[-1] == 1:
            rgb = np.repeat(rgb, 3, axis=-1)
        rgb = np.nan_to_num(rgb * 2.0 ** exposure, nan=0.0, posinf=1e6, neginf=0.0)
        out[r0:r0 + ROWS] = encode_srgb8(view_transform(rgb[..., :3], view))
    return out
