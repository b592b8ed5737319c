"""ProxyRender at 1024²: a 128×128-cell terrain plus 30 spheres (target ≤ 0.1 s per frame on 2 cores)."""
import tempfile
from pathlib import Path

import numpy as np

from harness import measure, table
from proxyshade.graph.plate import Plate
from proxyshade.graph.testing import run_node
from proxyshade.scene.build import build_stage

SPEC = {
    "frames": [1, 48],
    "terrains": [{"name": "Ground", "label": "vegetation", "cells": [128, 128], "extent": [[-100, -160], [100, 40]],
                  "height": 0, "strokes": [{"centre": [0, -60], "radius": 30, "amount": 15},
                                           {"centre": [-40, -120], "radius": 25, "amount": 30}]}],
    "spheres": [{"name": "Trees", "label": "tree", "path": [[-40, 4, -10], [0, 6, -50], [40, 5, -90]],
                 "radius": [3, 5, 4], "count": 30}],
    "cameras": [{"name": "Camera", "focal_length": 24, "move": "orbit", "centre": [0, 0, -50], "radius": 70,
                 "height": 12, "start_deg": -10, "end_deg": 10}],
}
SRC = Plate({"label.id": np.zeros((1, 1), np.uint32)},
            {"labels": [{"name": "sky", "id": 2, "color": "#ffffff"}, {"name": "vegetation", "id": 1, "color": "#00ff00"},
                        {"name": "tree", "id": 4, "color": "#ff331f"}]})


def main():
    from proxyshade.kernels.raster import rasterize
    from proxyshade.io.usd import CameraInfo
    from proxyshade.nodes.proxy_render import open_cached
    from proxyshade.io import usd

    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "bench.usda"
        stage = build_stage(SPEC)
        path.write_text(stage.GetRootLayer().ExportToString())
        frame = iter(range(1, 10_000))
        params = {"scene": str(path), "resolution": [1024, 1024]}
        whole = measure(lambda: run_node("ProxyRender", params, {"source": SRC}, frame=1 + next(frame) % 48), repeat=7)
        st = open_cached(path)
        cam = usd.camera_at(st, None, 10, 1024, 1024)
        prims = [p for p in usd.scene_prims(st, 10) if not p.cg]
        P, T, N, owner = usd.world_meshes(prims, cam)
        pc = cam.to_camera(P)
        ras = measure(lambda: rasterize(pc, T, width=1024, height=1024, fx=cam.fx, fy=cam.fy, cx=cam.cx, cy=cam.cy,
                                        near=cam.near), repeat=7)
        print(f"triangles: {len(T)}")
        table("ProxyRender 1024², 128² terrain + 30 spheres", [
            ("ProxyRender node (USD read, tessellate, raster, AOVs)", whole, 0.1),
            ("rasterize kernel alone", ras, None),
        ])


if __name__ == "__main__":
    main()
