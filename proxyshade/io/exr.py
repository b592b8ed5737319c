"""Plates as multichannel EXR files.

Plates are written with the OpenEXR bindings, which store each channel in its own pixel
type exactly (float16, float32 and uint32: ID channels round-trip bit for bit; writing
uint channels from float buffers through OpenImageIO would scale them). Foreign EXRs and
``inspect`` go through OpenImageIO, whose errors come back as return values and are
turned into exceptions naming the file here.

Metadata: ``proxyshade/meta`` holds the plate's metadata as JSON; string values whose key
contains '/' (``proxyshade/node``, ``cryptomatte/<key>/name``, ...) are also written as
header attributes of their own, so other tools see them. Plates with R,G,B carry their
colour space: ``chromaticities`` (Rec.709, D65) and ``colorInteropID`` ``lin_rec709_scene``
(OpenImageIO's ``oiio:ColorSpace``). Compression is ZIP by default; the plate cache uses
ZSTD where the bindings have it (``cache_compression()``). The bindings are imported on
first use.
Files are written to a temporary name beside the target and renamed into place
(``proxyshade.io.files``): a symlink is written through, a device or folder refused, and a
failed write (a full disk) leaves nothing at the name and raises ``WriteError``.
"""
from __future__ import annotations

import functools
import json
import os
import threading
from pathlib import Path

import lazy_loader

from proxyshade.errors import UserError, WriteError
from proxyshade.plate import Plate
from proxyshade.io.files import io_error, output_target, temp_for, verify_temp

np = lazy_loader.load("numpy")  # on first use: a fully cached run never loads numpy

# ZSTD (OpenEXR 3.4+): lossless, about 2x less CPU than ZIP and smaller files on plates (4K
# first frame: 120 vs 206 MiB); readers before OpenEXR 3.4 (most compositors today) cannot
# open it, so it is for the cache, not for delivery
COMPRESSION_NAMES = ("zip", "zips", "piz", "none", "dwaa", "zstd")
# ZSTD's level (OpenEXR's default 5): the Python bindings take no level in the header, so the
# library's default is set through its C API. At 4K, level 1 costs a third to a half of level
# 5's CPU for files 3 % larger (15-channel plate: 0.9 vs 2.4 CPU s, 124 vs 120 MiB); the
# bytes of every level decode to the same pixels
ZSTD_LEVEL = 1
_META = "proxyshade/meta"
# one EXR encoded at a time in this process: a write holds OpenEXR's line buffers (two per worker
# thread, each a chunk of every channel, raw and compressed); the plate cache's writer and an
# output writer side by side held both at the 1024 first frame's peak (final's cache entry beside
# the 39-channel output). The two share OpenEXR's worker threads either way
_ENCODING = threading.Lock()
# (an output compressed without worker threads held 6 MiB instead of 23 at the end of the run, but
# the peak is earlier and the last write then runs on one core: +7 % wall; not kept)


@functools.cache
def _openexr():
    """The OpenEXR bindings, imported on first use (they import numpy: ~0.13 s that a fully
    cached run does without) and set up once: ZSTD at ``ZSTD_LEVEL``, and chunks compressed
    and decompressed on every core (files are byte-identical)."""
    import OpenEXR

    if hasattr(OpenEXR, "ZSTD_COMPRESSION"):
        _set_zstd_level(OpenEXR, ZSTD_LEVEL)
    if OpenEXR.global_thread_count() == 0:
        OpenEXR.set_global_thread_count(os.cpu_count() or 1)
    return OpenEXR


def compressions() -> dict:
    """Compression name -> the bindings' constant, for the names these bindings have."""
    lib = _openexr()
    return {n: getattr(lib, f"{n.upper()}_COMPRESSION") for n in COMPRESSION_NAMES
            if hasattr(lib, f"{n.upper()}_COMPRESSION")}


def cache_compression() -> str:
    """The plate cache's compression: ZSTD where the bindings have it, else ZIP."""
    return "zstd" if "zstd" in compressions() else "zip"


def _set_zstd_level(lib, level: int) -> bool:
    """Set OpenEXR's default ZSTD level (the bindings' own symbol); False when unavailable."""
    import ctypes

    try:
        fn = ctypes.CDLL(lib.__file__).exr_set_default_zstd_compression_level
    except (OSError, AttributeError):
        return False
    fn.argtypes, fn.restype = [ctypes.c_int], None
    fn(level)
    return True


# R,G,B are linear Rec.709 / sRGB primaries, D65 (sources are decoded from sRGB with
# colour-science): the chromaticities attribute and the ASWF colour-interop id, which
# OpenImageIO reports as oiio:ColorSpace and Nuke and OCIO configs understand
REC709_CHROMATICITIES = (0.64, 0.33, 0.30, 0.60, 0.15, 0.06, 0.3127, 0.3290)
COLOUR_SPACE = "lin_rec709_scene"


class ExrError(UserError):
    """An EXR could not be read or written; the message names the file."""


def _header(plate: Plate, compression: str, extra: dict | None) -> dict:
    table = compressions()
    if compression not in table:
        raise ExrError(f"compression {compression!r} is not valid; valid ones are {', '.join(table)}")
    header = {"compression": table[compression], "type": _openexr().scanlineimage}
    if all(c in plate.channels for c in ("R", "G", "B")):
        header["chromaticities"] = REC709_CHROMATICITIES
        header["colorInteropID"] = COLOUR_SPACE
    meta = plate.meta
    header[_META] = json.dumps(meta, sort_keys=True, default=str)
    for k, v in list(meta.items()) + list((extra or {}).items()):
        if "/" in k and isinstance(v, str):
            header[k] = v
    return header


def write_plate(path: str | Path, plate: Plate, *, compression: str = "zip", extra: dict | None = None) -> Path:
    """Write ``plate`` to ``path`` atomically. ``extra`` adds metadata (node, key, frame).

    A symlink at ``path`` is written through to its target; anything else that is not a
    regular file is refused (``UserError``); a failed write raises ``WriteError`` and leaves
    the old file. The file is fsync'd and checked whole (``exr_problem``) before it is renamed
    into place: a full disk never leaves a cut-short file under the name."""
    path = Path(path)
    target = output_target(path)
    tmp = write_plate_temp(target, plate, compression=compression, extra=extra, name=path)
    try:
        os.replace(tmp, target)
    except OSError as e:
        raise io_error(path, e, "cannot write EXR") from None
    finally:
        if os.path.lexists(tmp):
            tmp.unlink()
    return path


def write_plate_temp(target: Path, plate: Plate, *, compression: str = "zip", extra: dict | None = None,
                     name: Path | None = None, what: str = "cannot write EXR", durable: bool = True) -> Path:
    """Write ``plate`` to a temporary beside ``target`` and check it (fsync'd when ``durable``,
    whole by ``exr_problem``); returns the temporary, for the caller to rename into place (the
    cache renames under its lock). On any failure the temporary is removed and ``WriteError``
    names ``name`` (default ``target``) with ``what``."""
    name = Path(name or target)
    if not plate.channels:
        raise ExrError(f"{name}: the plate has no channels to write")
    header = _header(plate, compression, extra)
    channels = {n: np.ascontiguousarray(a) for n, a in plate.channels.items()}
    tmp = None
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        tmp = temp_for(target, ".exr")
        # created here first: a folder that cannot be written (a read-only cache) is then an OSError
        # with its errno, where the bindings raise a plain exception naming no reason
        os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
        try:
            with _ENCODING, _openexr().File(header, channels) as f:
                f.write(str(tmp))
        except OSError:
            raise
        except Exception as e:  # the bindings raise plain exceptions (a full disk among them)
            raise WriteError(f"{name}: {what} ({_one_line(e).replace(str(tmp), str(name))}); free space or fix the "
                             "disk, then run again") from None
        verify_temp(tmp, name, what, exr_problem, durable=durable)
        return tmp
    except OSError as e:
        _remove(tmp)
        raise io_error(name, e, what) from None
    except BaseException:
        _remove(tmp)
        raise


def _remove(tmp: Path | None) -> None:
    if tmp is not None and os.path.lexists(tmp):
        tmp.unlink()


def _one_line(e: BaseException) -> str:
    return " ".join(line.strip() for line in str(e).splitlines() if line.strip()) or type(e).__name__


def read_plate(path: str | Path, *, expect: dict[str, str] | None = None) -> Plate:
    """Read a single-part EXR as a plate, each channel in its stored pixel type.

    ``expect``: header attributes that must hold these values (the cache checks
    ``proxyshade/key``), else ``ExrError``."""
    path = Path(path)
    if not path.is_file():
        raise ExrError(f"{path}: no such EXR file; check the path")
    try:
        with _openexr().File(str(path), separate_channels=True) as f:
            # the bindings' arrays own their pixels (not views of the file object's buffers):
            # taken as they are, not copied (a copy held two plates at once while reading: 0.5 GiB
            # more at 4K)
            chans = {name: _owned(ch.pixels) for name, ch in f.channels().items()}
            header = dict(f.header())  # after channels(): reading them resets the header view
    except Exception as e:
        raise ExrError(f"{path}: not a readable EXR ({_one_line(e)}); re-render it or delete it") from None
    for k, v in (expect or {}).items():
        if header.get(k) != v:
            raise ExrError(f"{path}: header {k} is {header.get(k)!r}, expected {v!r}; the file belongs elsewhere")
    meta = {}
    if _META in header:
        try:
            meta = json.loads(header[_META])
        except (TypeError, ValueError):
            raise ExrError(f"{path}: header {_META} is not JSON; the file is damaged") from None
    fixed = {}
    for n, a in chans.items():
        if a.dtype not in (np.float16, np.float32, np.uint32):
            a = a.astype(np.float32)
        fixed[n] = a
    return Plate(fixed, meta)


def read_channels(path: str | Path, names: list[str], *, expect: dict[str, str] | None = None,
                  rows: int = 128) -> dict[str, np.ndarray]:
    """Only the channels ``names`` of a single-part EXR, each in its stored pixel type, the
    same arrays ``read_plate`` returns for them: read ``rows`` scanlines at a time into the
    arrays returned (the rest of the file is decompressed band by band, never held whole;
    one decompression pass per pixel type among ``names``). ``expect``: as ``read_plate``."""
    path = Path(path)
    for k, v in (expect or {}).items():
        if header_strings(path, (k,)).get(k) != v:
            raise ExrError(f"{path}: header {k} is not {v!r}; the file belongs elsewhere")
    lib = _openexr()
    import Imath

    kinds = {Imath.PixelType.FLOAT: np.float32, Imath.PixelType.HALF: np.float16, Imath.PixelType.UINT: np.uint32}
    try:
        f = lib.InputFile(str(path))
        try:
            header = f.header()
            box = header["dataWindow"]
            h, w = box.max.y - box.min.y + 1, box.max.x - box.min.x + 1
            groups: dict[int, list[str]] = {}
            for n in names:
                groups.setdefault(header["channels"][n].type.v, []).append(n)
            out = {n: np.empty((h, w), kinds[t]) for t, ns in groups.items() for n in ns}
            for y in range(0, h, rows):
                y1 = min(h, y + rows)
                for t, ns in groups.items():
                    for n, b in zip(ns, f.channels(ns, Imath.PixelType(t), box.min.y + y, box.min.y + y1 - 1)):
                        out[n][y:y1] = np.frombuffer(b, kinds[t]).reshape(y1 - y, w)
        finally:
            f.close()
    except Exception as e:
        raise ExrError(f"{path}: not a readable EXR ({_one_line(e)}); re-render it or delete it") from None
    return out


def _owned(a) -> np.ndarray:
    """A channel the bindings read: the array itself when it owns its memory, else a copy."""
    return a if isinstance(a, np.ndarray) and a.flags.owndata and a.flags.writeable else np.array(a)


_EXR_MAGIC = b"\x76\x2f\x31\x01"


def _header_attributes(f, path: Path, wanted: tuple[str, ...] = ()):
    """Walk the (first) header of the EXR open as ``f`` from its start: yields (name, type,
    value) with the value's bytes for the names in ``wanted`` (None for the others, skipped);
    ``f`` is left just past the header. Raises ``ExrError`` for a foreign or cut-short file."""
    if f.read(4) != _EXR_MAGIC:
        raise ExrError(f"{path}: not an EXR file (no OpenEXR magic number); re-render it or delete it")
    if len(f.read(4)) < 4:  # version and flags
        raise ExrError(f"{path}: EXR header cut short")

    def cstring() -> bytes:
        out = bytearray()
        while (c := f.read(1)) not in (b"\0", b""):
            out += c
            if len(out) > 255:
                raise ExrError(f"{path}: damaged EXR header (a name longer than 255 bytes)")
        if c == b"":
            raise ExrError(f"{path}: EXR header cut short")
        return bytes(out)

    while name := cstring():
        kind = cstring()
        size_bytes = f.read(4)
        if len(size_bytes) < 4:
            raise ExrError(f"{path}: EXR header cut short")
        size = int.from_bytes(size_bytes, "little", signed=True)
        if size < 0:
            raise ExrError(f"{path}: damaged EXR header (attribute {name[:40]!r} of negative size)")
        key = name.decode("utf-8", "replace")
        if key in wanted:
            value = f.read(size)
            if len(value) < size:
                raise ExrError(f"{path}: EXR header cut short")
            yield key, kind, value
        else:
            f.seek(size, os.SEEK_CUR)
            yield key, kind, None


def header_strings(path: str | Path, names: tuple[str, ...]) -> dict[str, str]:
    """The string attributes ``names`` of an EXR's (first) header, read in Python from the
    file's bytes: no image library, so the cache writer's thread never enters a C++ library
    that takes the dynamic loader's lock while it holds the GIL (which deadlocked against USD
    loading its plugins on a node's thread). Raises ``ExrError`` for a file that is not an
    EXR or whose header is cut short."""
    path = Path(path)
    with open(path, "rb") as f:
        return {k: v.decode("utf-8", "replace") for k, kind, v in _header_attributes(f, path, names)
                if v is not None and kind == b"string"}


def exr_problem(path: str | Path) -> str | None:
    """Why a single-part scanline EXR (what ``write_plate`` writes) is not whole, or None: its
    header must end, its offset table be filled, and every chunk lie inside the file, the
    last ending where the file ends. Read in Python, a few bytes per chunk: OpenEXR reports
    success when its last buffered write fails (a full disk)."""
    path = Path(path)
    size = path.stat().st_size
    with open(path, "rb") as f:
        head = f.read(8)
        if len(head) < 8 or head[:4] != _EXR_MAGIC:
            return f"{size} bytes, no whole EXR header"
        flags = int.from_bytes(head[4:8], "little") >> 8
        if flags & (0x2 | 0x8 | 0x10):  # tiled, deep, multi-part: not what write_plate writes
            return None
        f.seek(0)
        try:
            for _ in _header_attributes(f, path):
                pass
        except ExrError:
            return f"the header is cut short at byte {size}"
        table = f.tell()
        first = f.read(8)
        if len(first) < 8:
            return f"the file ends at byte {size}, before its offset table"
        first_offset = int.from_bytes(first, "little")
        n, rest = divmod(first_offset - table, 8)
        if first_offset <= table or rest or n > size:
            return "its offset table is not filled in"
        data = first + f.read(8 * (n - 1))
        if len(data) < 8 * n:
            return f"the file ends at byte {size}, inside its offset table"
        end = 0
        for i in range(n):
            off = int.from_bytes(data[8 * i:8 * i + 8], "little")
            if off < table + 8 * n or off + 8 > size:
                return f"chunk {i} of {n} is missing (the file ends at byte {size})"
            f.seek(off + 4)
            length = int.from_bytes(f.read(4), "little", signed=True)
            if length < 0 or off + 8 + length > size:
                return f"chunk {i} of {n} is cut short (the file ends at byte {size})"
            end = max(end, off + 8 + length)
        if end != size:
            return f"{size - end} bytes after its last chunk"
    return None


def read_header(path: str | Path) -> dict:
    """Header attributes of an EXR (OpenImageIO), plus its channels and their types."""
    import OpenImageIO as oiio

    path = Path(path)
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise ExrError(f"{path}: cannot open: {' '.join(oiio.geterror().split())}")
    try:
        spec = inp.spec()
        fmts = spec.channelformats or [spec.format] * spec.nchannels
        info = {
            "width": spec.width,
            "height": spec.height,
            "channels": [(spec.channel_name(i), str(fmts[i])) for i in range(spec.nchannels)],
            "attributes": {a.name: a.value for a in spec.extra_attribs},
        }
    finally:
        inp.close()
    return info
