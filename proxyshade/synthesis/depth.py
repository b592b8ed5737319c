"""Depth extension (Bonneel et al. 2010, §4.3, §7): the proxy depth carried out to the
detailed guide's new borders by jump flooding (``kernels.jfa``), over the whole frame or,
after an edit of the proxy, over a region (the rest kept from the previous result).

Reference: N. Bonneel, M. van de Panne, S. Lefebvre, G. Drettakis, "Proxy-Guided Texture
Synthesis for Rendering Natural Scenes", INRIA RR-7298, 2010."""
from __future__ import annotations

import numpy as np

from proxyshade.errors import NodeInputError
from proxyshade.plate import Plate
from proxyshade.io.camera import CameraInfo
from proxyshade.kernels import edit as kedit
from proxyshade.kernels.jfa import jump_flood
from proxyshade.kernels.pinhole import intrinsics

FOLLOW = ("N.X", "N.Y", "N.Z", "object.id")  # proxy channels taken from the pixel the depth came from


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
    # jump flooding seeded by the pixels whose label the guide kept, on the window (the whole frame without region)
    pl, gl = proxy["label.id"][win], guide["label.id"][win]
    src = jump_flood(pl == gl, gl, pl, penalty=penalty)
    sel = np.ones(pl.shape, np.bool_) if region is None else region[win]
    return guide.with_channels(_channels(proxy, previous if region is not None else None, sel, (r0, c0),
                                         np.ascontiguousarray(z[win]), src, cam), meta=meta)


def _channels(proxy: Plate, previous: Plate | None, sel: np.ndarray, origin: tuple[int, int], z: np.ndarray,
              src: np.ndarray, cam) -> dict:
    """The depth channels with the ``sel`` pixels of the window at ``origin`` taken from
    the jump flooding's result there (``z``: the window's proxy depth, ``src``: its
    window-flat seed indices, −1 for none): the extended depth (a pixel whose label the
    guide kept is its own seed; inf without a seed), 1 + the frame-flat index of its seed,
    ``P`` unprojected at that depth through the camera (``reproject.unproject``'s numbers;
    without a camera the proxy's ``P`` of the seed) and the ``FOLLOW`` channels of the
    seed. Every other pixel keeps ``previous``'s; without ``previous`` ``sel`` is the whole
    frame. One parallel pass per channel over the window (``kernels.edit``)."""
    H, W = proxy.shape
    r0, c0 = origin
    sel = np.ascontiguousarray(sel, np.bool_)
    z = np.ascontiguousarray(z, np.float32)
    src = np.ascontiguousarray(src, np.int64)

    def base(name, dtype):  # the array the window is pasted into
        return previous[name].astype(dtype) if previous is not None else np.empty((H, W), dtype)

    out = {"Z": base("Z", np.float32), "depth.src": base("depth.src", np.uint32)}
    kedit.paste_depth(sel, z, src, r0, c0, W, out["Z"], out["depth.src"])
    if cam:
        c = CameraInfo.from_meta(cam)
        P = [base(f"P.{a}", np.float32) for a in "XYZ"]
        kedit.paste_unproject(sel, z, src, r0, c0, np.ascontiguousarray(c.camera_to_world, np.float64), intrinsics(c),
                              *P)
        out.update({f"P.{a}": v for a, v in zip("XYZ", P)})
    elif all(f"P.{a}" in proxy for a in "XYZ"):  # no camera: P of the pixel the depth came from
        for a in "XYZ":
            out[f"P.{a}"] = base(f"P.{a}", np.float32)
            kedit.paste_follow(sel, src, r0, c0, np.ascontiguousarray(proxy[f"P.{a}"], np.float32), out[f"P.{a}"])
    for name in FOLLOW:  # normals and object ids: those of the pixel the depth came from
        if name in proxy:
            a = np.ascontiguousarray(proxy[name])
            out[name] = base(name, a.dtype)
            kedit.paste_follow(sel, src, r0, c0, a, out[name])
    return out
