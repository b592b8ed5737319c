"""Cryptomatte node: decoded by an independent implementation of the spec (hash by mmh3)."""
import json
import re
import struct

import mmh3
import numpy as np
import pytest

from proxyshade.errors import NodeInputError
from proxyshade.graph.plate import Plate
from proxyshade.graph.testing import run_node

LABELS = [{"name": "sky", "id": 1, "color": "#0000ff"}, {"name": "grass", "id": 2, "color": "#00ff00"},
          {"name": "rock face", "id": 5, "color": "#777777"}]
OBJECTS = [{"name": "/World/Car", "id": 1}, {"name": "/World/Cube", "id": 2}]


def spec_id(name: str) -> float:
    """Independent id of a name: mmh3, then the spec's exponent clamp."""
    h = mmh3.hash(name, 0, signed=False)
    exp = min(max((h >> 23) & 0xFF, 1), 254)
    return struct.unpack("<f", struct.pack("<I", (h & 0x807FFFFF) | (exp << 23)))[0]


def decode(plate: Plate, type_name: str, name: str) -> np.ndarray:
    """A decoder written from the spec: find the type by metadata, the id by the manifest."""
    keys = [k.split("/")[1] for k, v in plate.meta.items()
            if re.fullmatch(r"cryptomatte/[0-9a-f]{1,7}/name", k) and v == type_name]
    assert len(keys) == 1
    key = keys[0]
    assert plate.meta[f"cryptomatte/{key}/hash"] == "MurmurHash3_32"
    assert plate.meta[f"cryptomatte/{key}/conversion"] == "uint32_to_float32"
    man = json.loads(plate.meta[f"cryptomatte/{key}/manifest"])
    target = struct.unpack(">f", bytes.fromhex(man[name]))[0]
    assert struct.pack("<f", target) == struct.pack("<f", spec_id(name))
    matte = np.zeros(plate.shape, np.float64)
    k = 0
    while f"{type_name}{k:02d}.R" in plate:
        for idc, covc in (("R", "G"), ("B", "A")):
            ids = plate[f"{type_name}{k:02d}.{idc}"]
            assert ids.dtype == np.float32
            matte += np.where(ids == np.float32(target), plate[f"{type_name}{k:02d}.{covc}"], 0.0)
        k += 1
    return matte


def scene(rng, h=12, w=16):
    lab = rng.choice(np.array([0, 1, 2, 5], np.uint32), (h, w))
    obj = rng.choice(np.array([0, 0, 1, 2], np.uint32), (h, w))
    rgb = rng.random((h, w), dtype=np.float32)
    return Plate({"R": rgb, "G": rgb, "B": rgb, "label.id": lab, "object.id": obj},
                 {"labels": LABELS, "objects": OBJECTS})


def test_decoded_label_and_object_mattes_equal_masks():
    p = scene(np.random.default_rng(1))
    out = run_node("Cryptomatte", {}, {"image": p})
    for t in LABELS:
        assert np.array_equal(decode(out, "CryptoLabel", t["name"]), (p["label.id"] == t["id"]).astype(float))
    for t in OBJECTS:
        assert np.array_equal(decode(out, "CryptoObject", t["name"]), (p["object.id"] == t["id"]).astype(float))
    assert {f"CryptoLabel0{k}.{c}" for k in range(3) for c in "RGBA"} <= set(out.names())
    assert out["R"] is p["R"]  # other channels pass through


def test_supersampled_coverage_is_box_filtered_mask():
    rng = np.random.default_rng(2)
    hi = scene(rng, 24, 32)
    lo = scene(rng, 6, 8)
    out = run_node("Cryptomatte", {"levels": 8, "object_layer": ""}, {"image": lo, "samples": hi})
    assert not any(n.startswith("CryptoObject") for n in out.names())
    for t in LABELS:
        want = (hi["label.id"] == t["id"]).reshape(6, 4, 8, 4).mean(axis=(1, 3))
        np.testing.assert_allclose(decode(out, "CryptoLabel", t["name"]), want, atol=1e-6)


def test_unnamed_id_is_one_line_error():
    p = scene(np.random.default_rng(3))
    p = p.with_channels({"label.id": np.full(p.shape, 9, np.uint32)})
    with pytest.raises(NodeInputError, match=r"ids \[9\] have no name.*sky=1") as e:
        run_node("Cryptomatte", {}, {"image": p})
    assert "\n" not in str(e.value)


def test_needs_an_id_channel():
    p = Plate({"R": np.zeros((2, 2), np.float32)})
    with pytest.raises(NodeInputError, match="neither label.id nor object.id"):
        run_node("Cryptomatte", {}, {"image": p})


def test_samples_size_must_be_a_multiple():
    rng = np.random.default_rng(4)
    with pytest.raises(NodeInputError, match="integer multiple"):
        run_node("Cryptomatte", {}, {"image": scene(rng, 6, 8), "samples": scene(rng, 13, 16)})


def test_exr_opens_in_oiiotool_with_every_aov_and_decodes_after_round_trip(tmp_path):
    import shutil
    import subprocess
    import sys
    from pathlib import Path

    from proxyshade.io.exr import read_plate, write_plate

    oiiotool = Path(sys.executable).parent / "oiiotool"
    if not oiiotool.exists():
        oiiotool = shutil.which("oiiotool")
    assert oiiotool, "oiiotool is not installed beside the interpreter"
    p = scene(np.random.default_rng(5))
    p = p.with_channels({"Z": np.ones(p.shape, np.float16)})
    out = run_node("Cryptomatte", {}, {"image": p})
    path = write_plate(tmp_path / "crypto.exr", out)
    info = subprocess.run([str(oiiotool), "--info", "-v", str(path)], capture_output=True, text=True, check=True).stdout
    listed = dict(re.findall(r"([A-Za-z0-9_.]+) \((float|half|uint)\)", info.split("channel list:")[1].splitlines()[0]))
    want = {"float32": "float", "float16": "half", "uint32": "uint"}
    assert listed == {n: want[str(a.dtype)] for n, a in out.channels.items()}
    for k, v in out.meta.items():
        if k.startswith("cryptomatte/"):
            assert f'{k}: "{v}"' in info
    back = read_plate(path)
    for t in LABELS:
        assert np.array_equal(decode(back, "CryptoLabel", t["name"]), (p["label.id"] == t["id"]).astype(float))
