"""Depth extension (Bonneel et al. 2010, §4.3, §7): the proxy depth carried out to the
detailed guide's new borders by jump flooding (``kernels.jfa``), over the whole frame or,
after an edit of the proxy, over a region (the rest kept from the previous result)."""
from __future__ import annotations

import numpy as np

from proxyshade.errors import NodeInputError
from proxyshade.graph.plate import Plate
from proxyshade.io.usd import CameraInfo
from proxyshade.kernels import edit as kedit
from proxyshade.kernels.jfa import jump_flood
from proxyshade.kernels.reproject import intrinsics, unproject

FOLLOW = ("N.X", "N.Y", "N.Z", "object.id")  # proxy channels taken from the pixel the depth came from


def extend_depth(proxy_labels: np.ndarray, guide_labels: np.ndarray, z: np.ndarray, *, penalty: float = 1024.0
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Extended depth (H, W) float32 and the flat index of the pixel each depth came from."""
    keep = proxy_labels == guide_labels
    src = jump_flood(keep, guide_labels, proxy_labels, penalty=penalty)
    flat = z.reshape(-1)
    out = np.where(src >= 0, flat[np.maximum(src, 0)], np.inf).astype(np.float32)
    out[keep] = z[keep]
    return out, src


def box(region: np.ndarray, margin: int) -> tuple[int, int, int, int]:
    """The bounding box (row0, row1, col0, col1, exclusive ends) of ``region`` grown by
    ``margin`` and clipped to it."""
    rows, cols = np.nonzero(region.any(1))[0], np.nonzero(region.any(0))[0]
    h, w = region.shape
    return (max(0, rows[0] - margin), min(h, rows[-1] + 1 + margin),
            max(0, cols[0] - margin), min(w, cols[-1] + 1 + margin))


def depth_plate(proxy: Plate, guide: Plate, *, penalty: float, region: np.ndarray | None = None,
                previous: Plate | None = None, margin: int = 64) -> Plate:
    """``guide`` with ``Z`` extended, ``P.X/Y/Z`` unprojected from it through the proxy's
    camera (or, without one, the proxy's P of the pixel the depth came from), ``N.*`` and
    ``object.id`` of that pixel, and ``depth.src`` (1 + its flat index).

    With ``region`` and ``previous``: jump flooding runs on the region's bounding box grown
    by ``margin`` (the seeds around it), only the region's pixels take the new values and
    every other pixel keeps ``previous``'s."""
    H, W = proxy.shape
    if proxy.shape != guide.shape:
        raise NodeInputError(f"guide is {guide.width}x{guide.height} but proxy is {proxy.width}x{proxy.height}; "
                             "synthesize the guide at the proxy's size")
    z = proxy["Z"].astype(np.float32, copy=False)
    cam = proxy.meta.get("camera")
    meta = {"camera": cam} if cam else None
    if region is not None and not region.any():
        if np.isnan(z).any():
            raise NodeInputError("proxy Z has NaN values; re-render the proxy")
        return guide.with_channels({c: previous[c] for c in ("Z", "depth.src", "P.X", "P.Y", "P.Z") + FOLLOW
                                    if c in previous}, meta=meta)
    r0, r1, c0, c1 = (0, H, 0, W) if region is None else box(region, margin)
    win = (slice(r0, r1), slice(c0, c1))
    # an update reads Z on its window only (outside it Z is the last run's, checked then)
    if np.isnan(z if region is None else z[win]).any():
        raise NodeInputError("proxy Z has NaN values; re-render the proxy")
    if region is not None:  # the seeds on the window; the depth of the region's pixels only
        pl, gl = proxy["label.id"][win], guide["label.id"][win]
        src = jump_flood(pl == gl, gl, pl, penalty=penalty)
        return guide.with_channels(_region_channels(proxy, previous, region, (r0, c0), np.ascontiguousarray(z[win]),
                                                    src, cam), meta=meta)
    ext, src = extend_depth(proxy["label.id"], guide["label.id"], np.ascontiguousarray(z), penalty=penalty)
    ch = {"Z": ext, "depth.src": (src + 1).astype(np.uint32)}
    flat = np.maximum(src, 0)
    if cam:
        c = CameraInfo.from_meta(cam)
        # one parallel pass (numpy's took 1.5 s at 4K)
        P = unproject(np.ascontiguousarray(ext, np.float32), np.ascontiguousarray(c.camera_to_world, np.float64),
                      intrinsics(c))
        for k, a in enumerate("XYZ"):
            ch[f"P.{a}"] = np.ascontiguousarray(P[..., k])
    elif all(f"P.{a}" in proxy for a in "XYZ"):
        # no camera to unproject with: P of the pixel the depth came from
        for a in "XYZ":
            pa = proxy[f"P.{a}"].astype(np.float32)
            ch[f"P.{a}"] = np.where(src >= 0, pa.reshape(-1)[flat], pa).astype(np.float32)
    # normals and object ids follow the depth: those of the pixel it came from
    for name in FOLLOW:
        if name in proxy:
            a = proxy[name]
            ch[name] = np.where(src >= 0, a.reshape(-1)[flat], a).astype(a.dtype, copy=False)
    return guide.with_channels(ch, meta=meta)


def _region_channels(proxy: Plate, previous: Plate, region: np.ndarray, origin: tuple[int, int], z: np.ndarray,
                     src: np.ndarray, cam) -> dict:
    """An update's channels: ``previous``'s with the ``region``'s pixels replaced by the
    jump flooding's result on the window at ``origin`` (``z``: the window's proxy depth,
    ``src``: its window-flat seed indices), the same numbers as the whole frame's path
    (``extend_depth``, ``unproject``); one parallel pass per channel over the window
    (``kernels.edit``), no window-sized temporaries."""
    H, W = proxy.shape
    r0, c0 = origin
    h, w = z.shape
    sel = np.ascontiguousarray(region[r0:r0 + h, c0:c0 + w])
    z = np.ascontiguousarray(z, np.float32)
    src = np.ascontiguousarray(src, np.int64)
    out = {"Z": previous["Z"].astype(np.float32), "depth.src": previous["depth.src"].astype(np.uint32)}
    kedit.paste_depth(sel, z, src, r0, c0, W, out["Z"], out["depth.src"])
    if cam:
        c = CameraInfo.from_meta(cam)
        P = [previous[f"P.{a}"].astype(np.float32) for a in "XYZ"]
        kedit.paste_unproject(sel, z, src, r0, c0, np.ascontiguousarray(c.camera_to_world, np.float64), intrinsics(c),
                              *P)
        out.update({f"P.{a}": v for a, v in zip("XYZ", P)})
    elif all(f"P.{a}" in proxy for a in "XYZ"):  # no camera: P of the pixel the depth came from
        for a in "XYZ":
            out[f"P.{a}"] = previous[f"P.{a}"].astype(np.float32)
            kedit.paste_follow(sel, src, r0, c0, np.ascontiguousarray(proxy[f"P.{a}"], np.float32), out[f"P.{a}"])
    for name in FOLLOW:  # normals and object ids: those of the pixel the depth came from
        if name in proxy:
            a = np.ascontiguousarray(proxy[name])
            out[name] = previous[name].astype(a.dtype)
            kedit.paste_follow(sel, src, r0, c0, a, out[name])
    return out
