"""``proxyshade scene ...``: write USD proxy scenes from their YAML descriptions."""
from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer

scene_app = typer.Typer(no_args_is_help=True)


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
           centre: str = typer.Option(..., help="x,z"), radius: float = typer.Option(...),
           amount: float = typer.Option(..., help="> 0 pushes up, < 0 pulls down")):
    """Append a Gaussian push/pull stroke to a terrain of a scene description, then rebuild."""
    import yaml

    from proxyshade.errors import UserError
    from proxyshade.scene.build import build_file

    data = yaml.safe_load(spec.read_text())
    ts = {t["name"]: t for t in data.get("terrains", [])}
    if terrain not in ts:
        raise UserError(f"{spec}: terrains: no terrain {terrain!r}; terrains are {', '.join(ts) or 'none'}")
    x, z = (float(v) for v in centre.split(","))
    ts[terrain].setdefault("strokes", []).append({"centre": [x, z], "radius": radius, "amount": amount})
    spec.write_text(yaml.safe_dump(data, sort_keys=False))
    typer.echo(str(build_file(spec)))


@scene_app.command("info")
def info(scene: Path = typer.Argument(..., help=".usda scene"), frame: int = 1):
    """Prims, labels, cameras and light of a scene at a frame."""
    from proxyshade.io.usd import cameras, distant_light, open_stage, scene_prims

    st = open_stage(scene)
    for p in scene_prims(st, frame):
        typer.echo(f"{p.path:<40} {p.kind:<7} {'CG' if p.cg else (p.label or '-')}")
    typer.echo(f"cameras: {', '.join(cameras(st))}")
    typer.echo(f"light: {distant_light(st, frame)}")
