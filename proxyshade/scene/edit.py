"""Edits of a scene description (the YAML the ``.usda`` is built from), as functions: each
changes the description and rebuilds the ``.usda`` beside it, or refuses a bad edit
before anything is written. ``proxyshade scene stroke`` and ``spheres`` call them;
``graphs/edit.yaml`` (under ``proxyshade run --watch``) then updates only the region the
edit changed (docs/editing.md).
"""
from __future__ import annotations

from pathlib import Path

from proxyshade.errors import UserError


def load_spec(spec: Path) -> dict:
    """A scene description as a dict; one-line errors for a missing or malformed file."""
    if not spec.is_file():
        raise UserError(f"{spec}: no such scene description; create one with `proxyshade scene new {spec}`")
    from proxyshade.io import yamlfile

    data = yamlfile.load(spec, what="scene description")
    if not isinstance(data, dict):
        raise UserError(f"{spec}: expected a mapping with terrains, spheres, cg, cameras, light")
    return data


def save_and_build(spec: Path, data: dict) -> Path:
    """Build first (so a bad edit leaves the YAML untouched), then write the YAML and the
    ``.usda`` (each to a temporary name, then renamed). Returns the ``.usda``."""
    import os

    import yaml

    from proxyshade.io.files import temp_for
    from proxyshade.scene.build import build_stage, write_usda

    stage = build_stage(data, where=str(spec))
    tmp = temp_for(spec, ".yaml")
    tmp.write_text(yaml.safe_dump(data, sort_keys=False, default_flow_style=None))
    os.replace(tmp, spec)
    return write_usda(stage, spec.with_suffix(".usda"))


def _named(data: dict, spec: Path, field: str, name: str) -> dict:
    items = {t.get("name"): t for t in data.get(field) or []}
    if name not in items:
        kind = {"terrains": "terrain", "spheres": "sphere group"}[field]
        raise UserError(f"{spec}: {field}: no {kind} {name!r}; {field} are {', '.join(map(str, items)) or 'none'}")
    return items[name]


def add_stroke(spec: Path, terrain: str, centre: tuple[float, float], radius: float, amount: float) -> Path:
    """Append a Gaussian push (amount > 0) or pull stroke to a terrain, then rebuild."""
    data = load_spec(spec)
    t = _named(data, spec, "terrains", terrain)
    t.setdefault("strokes", []).append({"centre": [float(centre[0]), float(centre[1])], "radius": float(radius),
                                        "amount": float(amount)})
    return save_and_build(spec, data)


def move_spheres(spec: Path, name: str, offset: tuple[float, float, float]) -> Path:
    """Move a sphere group (its path or arch feet) by ``offset`` (x, y, z), then rebuild."""
    data = load_spec(spec)
    g = _named(data, spec, "spheres", name)
    dx = [float(v) for v in offset]
    if "path" in g:
        g["path"] = [[p[k] + dx[k] for k in range(3)] for p in g["path"]]
    elif "arch" in g:
        for foot in ("left", "right"):
            g["arch"][foot] = [g["arch"][foot][k] + dx[k] for k in range(3)]
    else:
        raise UserError(f"{spec}: spheres.{name}: neither 'path' nor 'arch' to move")
    return save_and_build(spec, data)


def relabel(spec: Path, field: str, name: str, label: str) -> Path:
    """Change the texture label of a terrain or sphere group (``field``: terrains or
    spheres), then rebuild."""
    if field not in ("terrains", "spheres"):
        raise UserError(f"{spec}: {field}: only terrains and spheres carry texture labels")
    data = load_spec(spec)
    _named(data, spec, field, name)["label"] = str(label)
    return save_and_build(spec, data)
