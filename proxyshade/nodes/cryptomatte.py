"""Cryptomatte AOVs for texture labels and CG objects, so a compositor can pick any label
or object as a matte (Cryptomatte specification 1.1.0; Friedman and Jones 2015).

Adds ``<label_layer>NN.R/G/B/A`` from ``label.id`` + ``meta["labels"]`` and
``<object_layer>NN.R/G/B/A`` from ``object.id`` + ``meta["objects"]`` (both lists of
``{"name", "id"}``), float32, and the metadata ``cryptomatte/<key>/name``, ``/hash``,
``/conversion`` and ``/manifest`` that the EXR writer puts in the header verbatim.
"""
from __future__ import annotations

import json

import lazy_loader

from proxyshade.graph.node import Input, Node, Param
from proxyshade.graph.plate import Plate

np = lazy_loader.load("numpy")  # on first use: a fully cached run never loads numpy


def crypto_channels(ids: np.ndarray, table: list[dict], type_name: str, *, levels: int,
                    factor: int = 1, where: str = "") -> tuple[dict, dict]:
    """Channels and metadata of one Cryptomatte type.

    Parameters
    ----------
    ids : (M * factor, N * factor) uint32 ndarray
        Integer id per sample; 0 is empty.
    table : list of {"name", "id"}
        Names of the integer ids (ids in ``ids`` but not in ``table`` are an error).
    type_name : str
        Layer name, e.g. ``CryptoLabel``.
    """
    from proxyshade.kernels import cryptomatte as cm

    names = {int(t["id"]): str(t["name"]) for t in table}
    top = int(ids.max()) if ids.size else 0
    # the distinct ids, sorted: counted in one pass where they are small (np.unique sorts the frame)
    present = np.flatnonzero(np.bincount(ids.ravel(), minlength=1)) if top < (1 << 24) else np.unique(ids)
    missing = [int(i) for i in present if i != 0 and int(i) not in names]
    if missing:
        known = ", ".join(f"{n}={i}" for i, n in sorted(names.items())) or "none"
        raise ValueError(f"{where}ids {missing} have no name in the table ({known})")
    size = max([int(present.max()) if present.size else 0] + list(names)) + 1
    lut = np.zeros(size, np.float32)
    for i, n in names.items():
        lut[i] = cm.name_id(n)
    hashes = {}
    for i, n in names.items():
        hx = cm.id_hex(lut[i])
        if hx in hashes and hashes[hx] != n:
            raise ValueError(f"{where}names {hashes[hx]!r} and {n!r} hash to the same Cryptomatte id {hx}; rename one")
        hashes[hx] = n
    rid, rcov = cm.rank_coverage(ids, lut, levels=levels, factor=factor)
    ch = {}
    for k in range(levels // 2):
        ch[f"{type_name}{k:02d}.R"] = np.ascontiguousarray(rid[..., 2 * k])
        ch[f"{type_name}{k:02d}.G"] = np.ascontiguousarray(rcov[..., 2 * k])
        ch[f"{type_name}{k:02d}.B"] = np.ascontiguousarray(rid[..., 2 * k + 1])
        ch[f"{type_name}{k:02d}.A"] = np.ascontiguousarray(rcov[..., 2 * k + 1])
    key = cm.layer_key(type_name)
    meta = {
        f"cryptomatte/{key}/name": type_name,
        f"cryptomatte/{key}/hash": "MurmurHash3_32",
        f"cryptomatte/{key}/conversion": "uint32_to_float32",
        f"cryptomatte/{key}/manifest": json.dumps(cm.manifest(names.values()), sort_keys=True),
    }
    return ch, meta


class Cryptomatte(Node):
    """Add Cryptomatte AOVs (spec 1.1) for texture labels and CG objects.

    Coverage: with no ``samples`` input each pixel has one sample (coverage 1). A
    ``samples`` plate at an integer multiple k of the image size (e.g. a proxy or CG
    render at k times the resolution) gives box-filtered coverage from its k x k samples
    per pixel, so antialiased edges carry two ranks.
    """

    stored = False  # 24 channels re-packed from ids in 0.03-0.05 s at 1024 wide: less than writing them to the cache
    version = 1
    image = Input("plate with label.id (+ meta labels) and/or object.id (+ meta objects)",
                  dtype={"label.id": "uint32", "object.id": "uint32"}, fix="connect the composite plate")
    samples = Input("optional plate k times the size with the same id channels, for edge coverage",
                    optional=True)
    levels = Param(int, 6, choices=(2, 4, 6, 8), doc="ranks stored (2 per RGBA layer); the spec suggests 6")
    label_layer = Param(str, "CryptoLabel", doc="Cryptomatte type name for texture labels ('' to skip)")
    object_layer = Param(str, "CryptoObject", doc="Cryptomatte type name for CG objects ('' to skip)")

    def compute(self, ctx) -> Plate:
        img: Plate = ctx.image
        smp: Plate | None = ctx.samples
        factor = 1
        if smp is not None:
            fy, ry = divmod(smp.height, img.height)
            fx, rx = divmod(smp.width, img.width)
            if ry or rx or fx != fy or fx < 1:
                raise ctx.error(
                    f"samples plate is {smp.width}x{smp.height}, not an integer multiple of the image's "
                    f"{img.width}x{img.height}; render it at k times the resolution")
            factor = fx
        src = smp if smp is not None else img
        channels, meta = {}, {}
        todo = [("label.id", "labels", ctx.p.label_layer), ("object.id", "objects", ctx.p.object_layer)]
        for chan, table_key, type_name in todo:
            if not type_name or chan not in img:
                continue
            if chan not in src:
                raise ctx.error(f"samples plate has no {chan!r} channel; it has {', '.join(src.names())}")
            table = src.meta.get(table_key) or img.meta.get(table_key) or []
            try:
                ch, md = crypto_channels(src[chan], table, type_name, levels=ctx.p.levels, factor=factor,
                                         where=f"{chan}: ")
            except ValueError as e:
                raise ctx.error(f"{e}; fix meta[{table_key!r}]") from None
            channels.update(ch)
            meta.update(md)
        if not channels:
            raise ctx.error(
                "nothing to encode: the image has neither label.id nor object.id (or both layers are ''); "
                f"it has {', '.join(img.names())}")
        return img.with_channels(channels, meta)
