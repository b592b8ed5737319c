"""``proxyshade scene ...``: write USD proxy scenes from their YAML descriptions.

The YAML description is the source of truth (reproducible, editable, diffable); every
editing command (``stroke``, ``spheres``, ``camera``) changes it and rebuilds the ``.usda``
beside it. See docs/scenes.md.
"""
from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer

scene_app = typer.Typer(no_args_is_help=True)

STARTER = """\
# A proxy scene description: `proxyshade scene build {name}` writes {stem}.usda beside it.
name: {stem}
frames: [1, 48]
fps: 24
background: sky
terrains:
  - {{name: Ground, label: vegetation, cells: [64, 64], extent: [[-100, -160], [100, 40]], height: 0.0,
     strokes: [{{centre: [0, -80], radius: 25, amount: 12}}]}}
spheres: []
cameras:
  - {{name: Camera, focal_length: 24, horizontal_aperture: 36, vertical_aperture: 36, clipping: [0.5, 2000],
     move: orbit, centre: [0, 0, -60], radius: 70, height: 10, target_height: 4, start_deg: -8, end_deg: 8}}
"""


def _load(spec: Path) -> dict:
    from proxyshade.scene.edit import load_spec

    return load_spec(spec)


def _save_and_build(spec: Path, data: dict) -> None:
    from proxyshade.scene.edit import save_and_build

    typer.echo(str(save_and_build(spec, data)))


def _floats(text: str, n: int | None, what: str) -> list[float]:
    from proxyshade.errors import UserError

    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError:
        raise UserError(f"{what}: {text!r} is not a comma-separated list of numbers") from None
    if n is not None and len(vals) != n:
        raise UserError(f"{what}: expected {n} numbers, got {text!r}")
    return vals


@scene_app.command("new")
def new(spec: Path = typer.Argument(..., help="scene description YAML to create"),
        force: bool = typer.Option(False, "--force", help="overwrite an existing file")):
    """Write a starter scene description (a terrain, a camera orbit) and build it."""
    from proxyshade.errors import UserError

    if spec.exists() and not force:
        raise UserError(f"{spec}: already exists; pass --force to overwrite it")
    spec.parent.mkdir(parents=True, exist_ok=True)
    spec.write_text(STARTER.format(name=spec.name, stem=spec.stem))
    from proxyshade.scene.build import build_file

    typer.echo(str(build_file(spec)))


@scene_app.command("build")
def build(spec: List[Path] = typer.Argument(..., help="scene description YAML file(s)"),
          out: Optional[Path] = typer.Option(None, "-o", "--out", help="output .usda (one spec only)")):
    """Build scene description YAML into .usda (beside it unless -o)."""
    from proxyshade.scene.build import build_file

    for s in spec:
        typer.echo(str(build_file(s, out if len(spec) == 1 else None)))


@scene_app.command("stroke")
def stroke(spec: Path = typer.Argument(..., help="scene description YAML"),
           terrain: str = typer.Option(..., help="terrain name"),
           centre: str = typer.Option(..., help="x,z"), radius: float = typer.Option(..., help="Gaussian sigma"),
           amount: float = typer.Option(..., help="> 0 pushes up, < 0 pulls down")):
    """Append a Gaussian push/pull stroke to a terrain of a scene description, then rebuild."""
    from proxyshade.scene.edit import add_stroke

    typer.echo(str(add_stroke(spec, terrain, _floats(centre, 2, "--centre"), radius, amount)))


@scene_app.command("spheres")
def spheres(spec: Path = typer.Argument(..., help="scene description YAML"),
            name: str = typer.Option(..., help="group name (replaced if it exists)"),
            label: str = typer.Option(..., help="texture label of the spheres"),
            path: str = typer.Option(..., help="polyline 'x,y,z;x,y,z;...'"),
            radius: str = typer.Option(..., help="one radius, or one per path point 'r0,r1,...'"),
            count: int = typer.Option(..., min=1, help="number of spheres, evenly spaced by arc length")):
    """Add (or replace) a group of spheres along a polyline, then rebuild."""
    pts = [_floats(p, 3, "--path") for p in path.split(";") if p.strip()]
    r = _floats(radius, None, "--radius")
    entry = {"name": name, "label": label, "path": pts, "radius": r[0] if len(r) == 1 else r, "count": count}
    data = _load(spec)
    groups = [g for g in data.get("spheres") or [] if g.get("name") != name]
    data["spheres"] = groups + [entry]
    _save_and_build(spec, data)


@scene_app.command("camera")
def camera(spec: Path = typer.Argument(..., help="scene description YAML"),
           move: str = typer.Option(..., help="orbit, pan, dolly or fly_through"),
           name: str = typer.Option("Camera", help="camera name (replaced if it exists)"),
           param: List[str] = typer.Option([], "-p", "--param",
                                          help="move parameter key=value (YAML value), e.g. -p centre=[0,0,-50]"),
           focal_length: float = typer.Option(24.0, help="mm"),
           aperture: str = typer.Option("36,36", help="horizontal,vertical aperture in mm")):
    """Set a camera's keyframed move (written as one time sample per frame), then rebuild.

    orbit: centre, radius, height, start_deg, end_deg[, target_height];
    pan: eye, yaw_start, yaw_end[, pitch]; dolly: start, end, target;
    fly_through: points[, look_ahead].
    """
    from proxyshade.io import yamlfile

    from proxyshade.errors import UserError

    ha, va = _floats(aperture, 2, "--aperture")
    entry = {"name": name, "focal_length": focal_length, "horizontal_aperture": ha, "vertical_aperture": va,
             "move": move}
    for p in param:
        if "=" not in p:
            raise UserError(f"--param {p!r}: expected key=value, e.g. radius=40")
        k, v = p.split("=", 1)
        entry[k.strip()] = yamlfile.parse(v, f"--param {yamlfile.cut(p, 200)}")
    data = _load(spec)
    old = {c.get("name"): c for c in data.get("cameras") or []}
    if name in old and "clipping" in old[name]:
        entry["clipping"] = old[name]["clipping"]
    data["cameras"] = [entry if c.get("name") == name else c for c in data.get("cameras") or []]
    if name not in old:
        data["cameras"].append(entry)
    _save_and_build(spec, data)


@scene_app.command("validate")
def validate_cmd(scene: Path = typer.Argument(..., help=".usda scene")):
    """Run every registered UsdValidation validator; errors are bad input (exit code 2)."""
    from proxyshade.errors import UserError
    from proxyshade.io.usd import open_stage, validate

    errors = validate(open_stage(scene))
    if errors:
        raise UserError(f"{scene}: {len(errors)} UsdValidation error(s): {'; '.join(errors)}")
    typer.echo(f"{scene}: valid")


@scene_app.command("info")
def info(scene: Path = typer.Argument(..., help=".usda scene"), frame: int = 1):
    """Prims, labels, cameras and light of a scene at a frame."""
    from proxyshade.io.usd import cameras, distant_light, open_stage, scene_prims

    st = open_stage(scene)
    for p in scene_prims(st, frame):
        typer.echo(f"{p.path:<40} {p.kind:<7} {'CG' if p.cg else (p.label or '-')}")
    typer.echo(f"cameras: {', '.join(cameras(st))}")
    typer.echo(f"light: {distant_light(st, frame)}")
