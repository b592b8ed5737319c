"""Reading and writing ordinary (non-plate) images with OpenImageIO: photos, label maps, previews.

OpenImageIO reports errors by return value; here they become one-line ``UserError``s naming
the file (``WriteError`` when an output cannot be written: a full disk). Outputs are written
to a temporary name and renamed (``proxyshade.io.files``): a failed or interrupted write
leaves nothing at the name, a symlink is written through, a device is refused.
"""
from __future__ import annotations

import contextlib
import os

from pathlib import Path

import lazy_loader

from proxyshade.errors import UserError, WriteError
from proxyshade.io.files import commit_temp, io_error, output_target, temp_for

np = lazy_loader.load("numpy")  # on first use: a fully cached run never loads numpy

# OpenImageIO is imported by the functions that read or write pictures: a cached run needs none


def _msg(text: str) -> str:
    """OpenImageIO's error text (often several lines of library output, repeated) as one line."""
    lines = [line.strip() for line in str(text).splitlines() if line.strip()]
    return "; ".join(dict.fromkeys(lines)) or "unknown error"


def _png_problem(path: Path) -> str | None:
    """Why a PNG file is cut short (its chunks do not reach IEND), or None. Checked before libpng
    reads it: libpng prints its own complaints about a truncated file straight to stderr."""
    with open(path, "rb") as f:
        data = f.read()
    if not data.startswith(b"\x89PNG\r\n\x1a\n"):
        return None  # not a PNG by content: OpenImageIO says what it is
    pos = 8
    while pos + 8 <= len(data):
        length = int.from_bytes(data[pos:pos + 4], "big")
        kind = data[pos + 4:pos + 8]
        end = pos + 12 + length
        if end > len(data):
            return f"truncated: the file ends inside its {kind.decode('latin-1')} chunk at byte {len(data)} of {end}"
        if kind == b"IEND":
            return None
        pos = end
    return f"truncated: the file ends at byte {len(data)} before its IEND chunk"


def _written_png_problem(path: Path) -> str | None:
    """Why a PNG just written is not whole (no signature, or cut short before IEND), or None."""
    with open(path, "rb") as f:
        head = f.read(8)
    if head != b"\x89PNG\r\n\x1a\n":
        return f"{path.stat().st_size} bytes, no PNG signature"
    return _png_problem(path)


def _gif_problem(path: Path, images: int) -> str | None:
    """Why a GIF just written is not whole, or None: its blocks must be read through to the
    trailer at the very end, with ``images`` images on the way."""
    with open(path, "rb") as f:
        data = f.read()
    n = len(data)
    if data[:6] not in (b"GIF87a", b"GIF89a") or n < 13:
        return f"{n} bytes, no GIF header"

    def table(packed: int) -> int:
        return 3 * 2 ** ((packed & 7) + 1) if packed & 0x80 else 0

    def sub_blocks(pos: int) -> int:  # the position after a chain of sub-blocks, or -1
        while pos < n:
            size = data[pos]
            pos += 1 + size
            if size == 0:
                return pos if pos <= n else -1
        return -1

    pos, seen = 13 + table(data[10]), 0
    while pos < n:
        kind = data[pos]
        if kind == 0x3B:  # trailer
            if pos + 1 != n:
                return f"{n - pos - 1} bytes after its trailer"
            return None if seen == images else f"{seen} of {images} frames"
        if kind == 0x21:  # extension: label, sub-blocks
            pos = sub_blocks(pos + 2)
        elif kind == 0x2C:  # image: descriptor, local table, LZW code size, sub-blocks
            if pos + 10 > n:
                break
            pos = sub_blocks(pos + 10 + table(data[pos + 9]) + 1)
            seen += 1
        else:
            return f"an unknown block at byte {pos}"
        if pos < 0:
            break
    return f"the file ends at byte {n}, before its trailer ({seen} of {images} frames read)"


def _open(path: str | Path):
    """An image file as an OpenImageIO ImageBuf, its colours as stored: alpha unassociated (a
    PNG or TIFF with alpha is not premultiplied on read, which darkened photos and moved
    label-map colours). One-line errors naming the file."""
    import OpenImageIO as oiio

    path = Path(path)
    if not path.is_file():
        raise UserError(f"{path}: no such image file; check the path (relative paths resolve against the YAML file)")
    if path.suffix.lower() == ".png":
        problem = _png_problem(path)
        if problem:
            raise UserError(f"{path}: cannot read image ({problem}); re-export it")
    config = oiio.ImageSpec()
    config.attribute("oiio:UnassociatedAlpha", 1)
    buf = oiio.ImageBuf(str(path), 0, 0, config)
    if buf.has_error:
        raise UserError(f"{path}: cannot read image: {_msg(buf.geterror())}; re-export it")
    return buf


def _pixels(path: Path, buf, fmt) -> np.ndarray:
    """The ImageBuf's pixels as (H, W, C) of ``fmt``; a damaged file is a one-line error."""
    px = buf.get_pixels(fmt)
    if px is None or buf.has_error:
        raise UserError(f"{path}: cannot read pixels ({_msg(buf.geterror())}); the file is damaged or truncated: "
                        "re-export it")
    px = np.asarray(px)
    return px[..., None] if px.ndim == 2 else px


def _rgb_alpha(px: np.ndarray, buf, opaque) -> tuple[np.ndarray, np.ndarray]:
    """(H, W, 3) colour (grey expanded) and (H, W) alpha (``opaque`` where the file has none)."""
    spec = buf.spec()
    names = list(spec.channelnames)
    a = spec.alpha_channel if spec.alpha_channel >= 0 else (
        names.index("A") if "A" in names else 1 if px.shape[2] == 2 else 3 if px.shape[2] >= 4 else -1)
    colour = [names.index(c) for c in "RGB"] if {"R", "G", "B"} <= set(names) else \
        [c for c in range(px.shape[2]) if c != a][:3]
    rgb = px[..., colour]
    if rgb.shape[2] < 3:
        rgb = np.repeat(rgb[..., :1], 3, axis=2)
    alpha = px[..., a] if a >= 0 else np.full(px.shape[:2], opaque, px.dtype)
    return np.ascontiguousarray(rgb), np.ascontiguousarray(alpha)


def read_u8(path: str | Path, *, alpha: bool = False) -> np.ndarray:
    """An 8-bit image as an (H, W, 3) uint8 array, its colours as stored (alpha unassociated,
    then dropped; grey expanded). ``alpha``: (H, W, 4), alpha last (255 where the file has none)."""
    import OpenImageIO as oiio

    path = Path(path)
    buf = _open(path)
    rgb, a = _rgb_alpha(_pixels(path, buf, oiio.UINT8), buf, 255)
    return np.concatenate([rgb, a[..., None]], axis=2) if alpha else rgb


_LINEAR_FORMATS = ("openexr", "hdr")  # scene-referred linear light by definition


def is_linear(path: str | Path) -> bool:
    """Whether an image file holds linear light (an EXR or Radiance HDR, float pixels, or a
    linear colour space in its metadata) rather than sRGB-encoded values."""
    import OpenImageIO as oiio

    path = Path(path)
    buf = _open(path)
    spec = buf.spec()
    space = spec.get_string_attribute("oiio:ColorSpace").lower()
    return (buf.file_format_name in _LINEAR_FORMATS or spec.format.basetype in (oiio.FLOAT, oiio.HALF, oiio.DOUBLE)
            or space.startswith(("lin", "scene_linear", "acescg", "aces2065")))


def read_float(path: str | Path) -> np.ndarray:
    """An image's colour as (H, W, 3) float32 exactly as stored: no clamping, no decoding
    (a linear EXR's values above 1 kept); alpha dropped, grey expanded."""
    import OpenImageIO as oiio

    path = Path(path)
    buf = _open(path)
    rgb, _ = _rgb_alpha(_pixels(path, buf, oiio.FLOAT), buf, 1.0)
    return rgb.astype(np.float32, copy=False)


# zlib level of the PNGs written (OpenImageIO's default 6): a 1024x1024 preview 0.17 -> 0.09
# CPU s, its file 2 % larger; the pixels are the same at every level
PNG_LEVEL = 2
# libpng's row filter (``png:filter``): the average of left and up (PNG_FILTER_AVG) on every row
# instead of libpng's default, all five tried on each row: 1024x1024 previews of the shot, CPU s
# colour 0.14 -> 0.08 (its file 0.03 % larger), label.id 0.025 -> 0.010, flag 0.036 -> 0.010
# (24 -> 29, 29 -> 39 KB); the pixels are the same with any filter
PNG_FILTER = 0x40


def write_png(path: str | Path, rgb8: np.ndarray) -> Path:
    """Write an (H, W, 3) uint8 array as PNG, atomically (temporary name, then rename).

    Every OpenImageIO step is checked, and the file is fsync'd and read through to its IEND
    chunk before the rename (OpenImageIO reports success when its last buffered write fails on
    a full disk); on any failure or interrupt the temporary is removed and nothing is left at
    ``path``."""
    import OpenImageIO as oiio

    path = Path(path)
    target = output_target(path)
    h, w, c = rgb8.shape
    spec = oiio.ImageSpec(w, h, c, oiio.UINT8)
    spec.attribute("png:compressionLevel", PNG_LEVEL)
    spec.attribute("png:filter", PNG_FILTER)
    tmp, out = None, None
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        tmp = temp_for(target, ".png")
        out = oiio.ImageOutput.create(str(tmp))
        if out is None or not out.open(str(tmp), spec):
            raise WriteError(f"{path}: cannot write PNG ({_msg(oiio.geterror() if out is None else out.geterror())}); "
                             "check the folder and free space")
        ok = out.write_image(np.ascontiguousarray(rgb8, dtype=np.uint8))
        closing, out = out, None
        closed = closing.close()
        if not ok or not closed:
            raise WriteError(f"{path}: cannot write PNG ({_msg(closing.geterror())}); free space or fix the disk, "
                             "then run again")
        commit_temp(tmp, target, path, "cannot write PNG", _written_png_problem)
    except OSError as e:
        raise io_error(path, e, "cannot write PNG") from None
    finally:
        if out is not None:  # interrupted mid-write: the half-written file is deleted below, so
            with _quiet_stderr():  # libpng's complaint about it ("No IDATs written") is not shown
                out.close()
        if tmp is not None and tmp.exists():
            tmp.unlink()
    return path


@contextlib.contextmanager
def _quiet_stderr():
    """File descriptor 2 sent to the null device for the duration (C libraries print there)."""
    try:
        saved = os.dup(2)
    except OSError:
        yield
        return
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def resize_u8(rgb8: np.ndarray, max_size: int) -> np.ndarray:
    """Downscale an (H, W, 3) uint8 picture so its long edge is at most ``max_size`` (OpenImageIO's
    ImageBufAlgo.resize, its default filter); a picture already small enough is returned as is."""
    import OpenImageIO as oiio

    h, w = rgb8.shape[:2]
    if max(h, w) <= max_size:
        return rgb8
    s = max_size / max(h, w)
    nw, nh = max(1, round(w * s)), max(1, round(h * s))
    src = oiio.ImageBuf(oiio.ImageSpec(w, h, rgb8.shape[2], oiio.UINT8))
    src.set_pixels(oiio.ROI(), np.ascontiguousarray(rgb8, dtype=np.uint8))
    dst = oiio.ImageBufAlgo.resize(src, roi=oiio.ROI(0, nw, 0, nh, 0, 1, 0, rgb8.shape[2]))
    if dst.has_error:
        raise UserError(f"cannot resize a {w}x{h} picture to {nw}x{nh}: {_msg(dst.geterror())}")
    return np.asarray(dst.get_pixels(oiio.UINT8)).reshape(nh, nw, rgb8.shape[2])


def write_gif(path: str | Path, frames: list[np.ndarray], fps: int) -> Path:
    """Write (H, W, 3) uint8 pictures of one size as an animated GIF that loops forever,
    atomically (a temporary name in the same folder, then rename; a failure leaves nothing).

    The file is fsync'd and read through to its trailer before the rename (a full disk).
    GIF stores a frame's delay in hundredths of a second, so the rate plays as 100 / int(100 / fps)
    (24 fps plays at 25); colours are reduced to a 256-colour palette per frame, with dithering."""
    import OpenImageIO as oiio

    path = Path(path)
    if not frames:
        raise UserError(f"{path}: no frames to write; give the movie at least one frame")
    h, w, c = frames[0].shape
    bad = next((i for i, f in enumerate(frames) if f.shape != (h, w, c)), None)
    if bad is not None:
        raise UserError(f"{path}: frame {bad} is {frames[bad].shape[1]}x{frames[bad].shape[0]}, the first is {w}x{h}; "
                        "give every frame one size")
    target = output_target(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = temp_for(target, ".gif")
    spec = oiio.ImageSpec(w, h, c, oiio.UINT8)
    spec.attribute("FramesPerSecond", oiio.TypeRational, (int(fps), 1))
    spec.attribute("oiio:LoopCount", 0)  # 0: loop forever
    out = oiio.ImageOutput.create(str(tmp))
    try:
        if out is None:
            raise WriteError(f"{path}: cannot write GIF ({_msg(oiio.geterror())}); check the folder and free space")
        for i, frame in enumerate(frames):
            ok = out.open(str(tmp), [spec] * len(frames)) if i == 0 else out.open(str(tmp), spec, "AppendSubimage")
            if not ok or not out.write_image(np.ascontiguousarray(frame, dtype=np.uint8)):
                raise WriteError(f"{path}: cannot write GIF frame {i} ({_msg(out.geterror())}); free space or fix "
                                 "the disk, then run again")
        closing, out = out, None
        if not closing.close():
            raise WriteError(f"{path}: cannot write GIF ({_msg(closing.geterror())}); free space or fix the disk, "
                             "then run again")
        commit_temp(tmp, target, path, "cannot write GIF", lambda p: _gif_problem(p, len(frames)))
    except OSError as e:
        if out is not None:
            out.close()
        tmp.unlink(missing_ok=True)
        raise io_error(path, e, "cannot write GIF") from None
    except BaseException:
        if out is not None:
            out.close()
        tmp.unlink(missing_ok=True)
        raise
    return path
