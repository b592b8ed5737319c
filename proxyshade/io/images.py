"""Reading and writing ordinary (non-plate) images with OpenImageIO: photos, label maps, previews.

OpenImageIO reports errors by return value; here they become ``UserError`` naming the file.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import OpenImageIO as oiio

from proxyshade.errors import UserError


def read_u8(path: str | Path) -> np.ndarray:
    """An 8-bit image as an (H, W, 3) uint8 array (alpha dropped, grey expanded)."""
    path = Path(path)
    if not path.is_file():
        raise UserError(f"{path}: no such image file; check the path (relative paths resolve against the YAML file)")
    buf = oiio.ImageBuf(str(path))
    if buf.has_error:
        raise UserError(f"{path}: cannot read image: {buf.geterror().strip()}")
    px = buf.get_pixels(oiio.UINT8)
    if px is None or buf.has_error:
        raise UserError(f"{path}: cannot read pixels: {buf.geterror().strip()}")
    px = np.asarray(px)
    if px.ndim == 2:
        px = px[..., None]
    if px.shape[2] == 1:
        px = np.repeat(px, 3, axis=2)
    return np.ascontiguousarray(px[..., :3])


def write_png(path: str | Path, rgb8: np.ndarray) -> Path:
    """Write an (H, W, 3) uint8 array as PNG, atomically (temporary name, then rename)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp{id(rgb8)}.png")
    h, w, c = rgb8.shape
    spec = oiio.ImageSpec(w, h, c, oiio.UINT8)
    out = oiio.ImageOutput.create(str(tmp))
    if out is None or not out.open(str(tmp), spec):
        raise UserError(f"{path}: cannot write PNG: {oiio.geterror().strip()}")
    ok = out.write_image(np.ascontiguousarray(rgb8, dtype=np.uint8))
    out.close()
    if not ok:
        tmp.unlink(missing_ok=True)
        raise UserError(f"{path}: cannot write PNG: {out.geterror().strip()}")
    tmp.replace(path)
    return path
