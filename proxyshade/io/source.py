"""Annotated sources: a photo, its label map and a YAML label table.

The label table (``source.yaml``) names the photo, the label map and each label's id and
colour. Loading decodes an 8-bit sRGB photo to linear light with colour-science (a linear
EXR photo is read as it is, values above 1 kept) and snaps every label-map pixel to the
nearest table colour, counting how many were snapped and failing when too many are far
from every table colour. Alpha is ignored in both: colours are read as stored, never
premultiplied.
"""
from __future__ import annotations

import os
from pathlib import Path

import lazy_loader

from proxyshade.errors import UserError
from proxyshade.plate import Plate
from proxyshade.io import yamlfile
from proxyshade.io.colourlib import decode_srgb8
from proxyshade.io.images import is_linear, read_float, read_u8

np = lazy_loader.load("numpy")  # on first use: a fully cached run never loads numpy


def parse_colour(text: str, where: str) -> tuple[int, int, int]:
    s = str(text).strip().lstrip("#")
    if len(s) != 6:
        raise UserError(f"{where}: colour {text!r} is not '#rrggbb'; write it like \"#00ff00\"")
    try:
        return tuple(int(s[i:i + 2], 16) for i in (0, 2, 4))  # type: ignore[return-value]
    except ValueError:
        raise UserError(f"{where}: colour {text!r} is not '#rrggbb'; write it like \"#00ff00\"") from None


MAX_ID = 2**32 - 1  # label.id is uint32


def load_table(path: Path) -> dict:
    """Read and check a label table; returns the plain dict with absolute paths."""
    if not path.is_file():
        raise UserError(f"{path}: no such label table; point 'source' at a source.yaml")
    data = yamlfile.load(path, what="source table")
    if not isinstance(data, dict):
        raise UserError(f"{path}: expected a mapping with image, labels_map and labels")
    for field in ("image", "labels_map", "labels"):
        if field not in data:
            raise UserError(f"{path}: {field}: missing; a source table needs image, labels_map and labels")
    for field, kind in (("image", "the photo"), ("labels_map", "its label map"), ("layout", "a second label map")):
        value = data.get(field)
        if field == "layout" and value is None:
            continue
        if not isinstance(value, str) or not value.strip():
            raise UserError(f"{path}: {field}: expected the file name of {kind} (relative to the table), got "
                            f"{yamlfile.short(value, 80)}; write it like {field}: photo.png")
        if (path.parent / value).is_dir():
            raise UserError(f"{path}: {field}: {value!r} is a folder; name {kind}'s image file")
    labels = data["labels"]
    if not isinstance(labels, dict) or not labels:
        raise UserError(f"{path}: labels: expected a mapping name -> {{id, color}}")
    table = []
    for i, (name, entry) in enumerate(labels.items()):
        where = f"{path}: labels.{name}"
        if not isinstance(name, (str, int)) or isinstance(name, bool):
            raise UserError(f"{path}: labels: label names are words, got {yamlfile.short(name, 80)}; name it like sky")
        if not isinstance(entry, dict) or "color" not in entry:
            raise UserError(f"{where}: expected {{id: N, color: '#rrggbb'}}")
        lid = entry.get("id", i + 1)
        if not isinstance(lid, int) or isinstance(lid, bool) or not 1 <= lid <= MAX_ID:
            raise UserError(f"{where}.id: expected an int from 1 to {MAX_ID} (0 means unlabelled), got "
                            f"{yamlfile.short(lid, 80)}")
        table.append({"name": str(name), "id": lid, "color": "#%02x%02x%02x" % parse_colour(entry["color"], where + ".color")})
    ids = [t["id"] for t in table]
    if len(set(ids)) != len(ids):
        raise UserError(f"{path}: labels: ids must be unique, got {ids}")
    base = path.parent
    out = dict(data)
    out["labels"] = table
    for field in ("image", "labels_map", "layout"):
        if field in data and data[field]:
            out[field] = str((base / data[field]).resolve())
    out["images"] = photo_series(path, data.get("images"))
    return out


def photo_series(path: Path, images) -> dict[str, str]:
    """The optional ``images`` field of a source table: other photos of the same view (a
    time-lapse series, ``images: {noon: a.jpg, dusk: b.jpg}``), name -> absolute path.
    They share the label map and its pixel grid: a map made on one photo reads any of them."""
    if images is None:
        return {}
    if not isinstance(images, dict) or not images:
        raise UserError(f"{path}: images: expected a mapping name -> photo (e.g. {{noon: a.jpg, dusk: b.jpg}})")
    out = {}
    for name, rel in images.items():
        if not isinstance(rel, str) or not rel:
            raise UserError(f"{path}: images.{name}: expected a photo file name, got {yamlfile.short(rel, 80)}")
        out[str(name)] = str((path.parent / rel).resolve())
    return out


def series_photo(t: dict, table_path: Path, photo: str | None) -> str:
    """The photo a source reads: the table's ``image``, or the ``images`` entry ``photo``."""
    if photo is None:
        return t["image"]
    if photo not in t["images"]:
        known = ", ".join(t["images"]) or "none"
        raise UserError(f"{table_path}: images.{photo}: no such photo in the table (its images: {known}); add it "
                        f"under 'images' or pick one of those")
    return t["images"][photo]


def srgb_to_linear(rgb8: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8 sRGB -> float32 linear, with colour-science's sRGB decoding (tabulated:
    ``colourlib.decode_srgb8``)."""
    return decode_srgb8(rgb8)


def _share(k: int, n: int) -> str:
    """k of n as a percentage for a message ('<0.1%' rather than '0.0%' for a few)."""
    return f"{k / n:.1%}" if k == 0 or k / n >= 0.001 else "<0.1%"


def read_photo(path: str | Path) -> np.ndarray:
    """A photo as (H, W, 3) float32 linear light. An sRGB-encoded file (8-bit PNG, JPEG, TIFF)
    is decoded with colour-science; a linear one (EXR, HDR, float TIFF: ``images.is_linear``)
    is scene-referred and read as it is, values above 1 kept. Alpha is ignored. A linear file
    with NaN, infinite or negative values is a one-line error naming it."""
    path = Path(path)
    if not is_linear(path):
        return srgb_to_linear(read_u8(path))
    rgb = read_float(path)
    n = rgb.shape[0] * rgb.shape[1]
    bad = int((~np.isfinite(rgb)).any(axis=2).sum())
    if bad:
        which = "all" if bad == n else f"{bad} ({_share(bad, n)})"
        raise UserError(f"{path}: {which} of the photo's {n} pixels are NaN or infinite; a photo needs finite "
                        "linear values: re-render or re-export it with those pixels filled")
    low = float(rgb.min()) if n else 0.0
    if low < 0:
        neg = int((rgb < 0).any(axis=2).sum())
        raise UserError(f"{path}: {neg} ({_share(neg, n)}) of the photo's pixels have negative values (lowest "
                        f"{low:.3g}); light is never negative: clamp them to 0 in the export")
    return np.ascontiguousarray(rgb, dtype=np.float32)


def snap_labels(rgb8: np.ndarray, table: list[dict], *, far_distance: float):
    """Snap each pixel of a label map to the nearest table colour.

    Returns ``(ids (H, W) uint32, snapped count, far count)``: snapped pixels were not
    exactly a table colour; far ones were more than ``far_distance`` (8-bit RGB units)
    from every table colour.
    """
    pal = np.array([parse_colour(t["color"], "table") for t in table], dtype=np.int32)
    ids = np.array([t["id"] for t in table], dtype=np.uint32)
    # Few distinct colours in a label map: work on the unique colours only, found as one
    # integer per pixel (0xRRGGBB: the same order as unique rows, without sorting rows)
    flat = rgb8.reshape(-1, 3)
    codes = (flat[:, 0].astype(np.int32) << 16) | (flat[:, 1].astype(np.int32) << 8) | flat[:, 2]
    ucodes, inverse = np.unique(codes, return_inverse=True)
    uniq = np.column_stack([ucodes >> 16, (ucodes >> 8) & 255, ucodes & 255]).astype(np.int32)
    d2 = ((uniq[:, None, :] - pal[None, :, :]) ** 2).sum(-1)
    nearest = d2.argmin(1)
    best = d2[np.arange(len(uniq)), nearest]
    inverse = inverse.reshape(-1)
    out = ids[nearest][inverse].reshape(rgb8.shape[:2])
    snapped = int((best[inverse] > 0).sum())
    far = int((best[inverse] > far_distance ** 2).sum())
    return out, snapped, far


def labels_from_map(path: Path, table: list[dict], *, far_distance: float, max_far_fraction: float,
                    where: str) -> tuple[np.ndarray, dict]:
    """Read a label-map image and snap it to ``table``; returns ids and snap statistics.
    Alpha is ignored: a pixel's label is its colour as stored, transparent or not."""
    rgba = read_u8(path, alpha=True)
    rgb8 = np.ascontiguousarray(rgba[..., :3])
    ids, snapped, far = snap_labels(rgb8, table, far_distance=far_distance)
    n = ids.size
    if far > max_far_fraction * n:
        clear = rgba[..., 3] < 255
        far_clear = snap_labels(rgb8[clear][None], table, far_distance=far_distance)[2] if clear.any() else 0
        if far_clear > far / 2:  # mostly transparent pixels whose stored colour is no label's
            raise UserError(
                f"{where}: {path.name}: {far / n:.1%} of pixels are further than {far_distance:g} from every label "
                f"colour (limit {max_far_fraction:.1%}), {far_clear / far:.0%} of them transparent; alpha is ignored "
                "(a pixel's label is its colour): fill the transparent areas with label colours, or flatten the map "
                "onto a label's colour")
        raise UserError(
            f"{where}: {path.name}: {far / n:.1%} of pixels are further than {far_distance:g} from every "
            f"label colour (limit {max_far_fraction:.1%}); add the missing colours to the label table "
            "or raise max_far_fraction"
        )
    return ids, {"snapped": snapped, "far": far, "pixels": n}


# how a label map snaps to the table's colours: the one default of the readers' LabelMapSnap group
FAR_DISTANCE = 100.0  # 8-bit RGB distance beyond which a pixel is far from every label colour
MAX_FAR_FRACTION = 0.02  # most share of far pixels before the read fails


def load_source(table_path: str | Path, *, far_distance: float = FAR_DISTANCE, max_far_fraction: float = MAX_FAR_FRACTION,
                where: str = "source", photo: str | None = None) -> Plate:
    """An annotated source as a plate: linear ``R,G,B`` (float32) and ``label.id`` (uint32).
    ``photo`` names one of the table's ``images`` (another photo of the same view) to read
    instead of ``image``; the label map is the same.

    Metadata: ``labels`` (list of {name, id, color}), ``source`` (paths; ``photo`` the name
    read, or null), ``snap`` (counts).
    """
    table_path = Path(table_path)
    t = load_table(table_path)
    image = series_photo(t, table_path, photo)
    lin = read_photo(image)
    ids, stats = labels_from_map(Path(t["labels_map"]), t["labels"], far_distance=far_distance,
                                 max_far_fraction=max_far_fraction, where=where)
    if ids.shape != lin.shape[:2]:
        field = f"images.{photo}" if photo is not None else "image"
        raise UserError(
            f"{table_path}: labels_map is {ids.shape[1]}x{ids.shape[0]} but {field} is "
            f"{lin.shape[1]}x{lin.shape[0]}; they must be the same size (photos of one view, one label map)"
        )
    ch = {"R": lin[..., 0].copy(), "G": lin[..., 1].copy(), "B": lin[..., 2].copy(), "label.id": ids}
    meta = {
        "labels": t["labels"],
        "source": {"table": str(table_path.resolve()), "image": image, "labels_map": t["labels_map"],
                   "credit": t.get("credit", ""), "photo": photo, "size": [int(lin.shape[1]), int(lin.shape[0])]},
        "snap": stats,
    }
    if t.get("layout"):
        meta["source"]["layout"] = t["layout"]
    return Plate(ch, meta)


def palette(rgb8: np.ndarray, *, min_share: float = 0.005) -> tuple[list[tuple[tuple[int, int, int], int]], int]:
    """The label colours of a label map: each distinct colour covering at least
    ``min_share`` of the pixels, largest first, with its pixel count; and how many pixels
    have another colour (anti-aliasing or JPEG noise, snapped to the nearest label when
    the source is read)."""
    flat = rgb8.reshape(-1, 3)
    uniq, counts = np.unique(flat, axis=0, return_counts=True)
    order = np.argsort(-counts, kind="stable")
    keep = [(tuple(int(v) for v in uniq[i]), int(counts[i])) for i in order if counts[i] >= min_share * len(flat)]
    return keep, int(len(flat) - sum(c for _, c in keep))


def new_table(photo: Path, label_map: Path, out: Path, *, min_share: float = 0.005) -> tuple[str, dict]:
    """The text of a ``source.yaml`` (to be written at ``out``) for ``photo`` and its
    ``label_map``: one label per palette colour (named ``label_1``, ... by area, to be
    renamed after the scene's labels), ids from 1. Returns (YAML text, report: labels,
    snapped pixels and their share)."""
    rgb, lab8 = read_photo(photo), read_u8(label_map)
    if rgb.shape != lab8.shape:
        raise UserError(f"{label_map}: the label map is {lab8.shape[1]}x{lab8.shape[0]} but the photo "
                        f"{rgb.shape[1]}x{rgb.shape[0]}; paint the label map at the photo's size")
    colours, other = palette(lab8, min_share=min_share)
    if len(colours) < 2:
        raise UserError(f"{label_map}: fewer than two colours cover {min_share:.1%} of the map each; paint at "
                        "least two labelled regions (flat colours, one per label)")

    def rel(p: Path) -> str:
        return Path(os.path.relpath(p.resolve(), out.resolve().parent)).as_posix()

    lines = ["# written by 'proxyshade source new'; rename the labels after your scene's (UsdSemantics texture",
             "# labels) and keep the colours: they are the label map's",
             f"image: {rel(photo)}", f"labels_map: {rel(label_map)}", "labels:"]
    n = rgb.shape[0] * rgb.shape[1]
    for i, (c, count) in enumerate(colours, 1):
        lines.append(f"  label_{i}: {{id: {i}, color: \"#{c[0]:02x}{c[1]:02x}{c[2]:02x}\"}}   # {count / n:.1%} of the map")
    return "\n".join(lines) + "\n", {"labels": len(colours), "snapped": other, "snapped_share": other / n}


def load_annotations(table_path: str | Path, shape: tuple[int, int]) -> dict[str, np.ndarray]:
    """The optional ``annotations: {name: map.png}`` of a source table (grey maps, 0..255 ->
    0..1, not sRGB-decoded: they are data), with ``mask`` (pixels > 127 usable) and
    ``alpha`` (0..1) when given: ``{"ann.<name>": (H, W) float32, "mask": bool, "A": float32}``."""
    table_path = Path(table_path)
    t = load_table(table_path)
    ann = t.get("annotations")
    if not isinstance(ann, dict) or not ann:
        raise UserError(f"{table_path}: annotations: expected a mapping name -> grey map (e.g. "
                        f"{{light: light.png, scale: scale.png}})")
    files = {f"ann.{k}": v for k, v in ann.items()}
    files.update({k: t[k] for k in ("mask", "alpha") if t.get(k)})
    out = {}
    for name, rel in files.items():
        where = f"annotations.{name[4:]}" if name.startswith("ann.") else name
        if not isinstance(rel, str) or not rel:
            raise UserError(f"{table_path}: {where}: expected an image file name, got {rel!r}")
        px = read_u8(table_path.parent / rel)
        if px.shape[:2] != tuple(shape):
            raise UserError(f"{table_path}: {where} is {px.shape[1]}x{px.shape[0]} but the photo is "
                            f"{shape[1]}x{shape[0]}; paint it on the photo's pixel grid")
        v = px[..., 0].astype(np.float32) / 255.0
        out[name] = v > 0.5 if name == "mask" else v
    return out
