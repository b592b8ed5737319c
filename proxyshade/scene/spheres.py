"""The sphere tool: spheres instanced along a path, with a radius that varies along it.

"The sphere tool instances spheres along a given path, thereby enabling ... topologies
that are not possible with the heightfield model, such as arches" (Bonneel et al. 2010, §3).
"""
from __future__ import annotations

import numpy as np


def along_path(path, radius, count: int) -> tuple[np.ndarray, np.ndarray]:
    """``count`` sphere centres evenly spaced by arc length along the polyline ``path``
    (K, 3), with radii interpolated from ``radius`` (a number, or one value per path point).
    """
    path = np.asarray(path, np.float64).reshape(-1, 3)
    if len(path) < 2 or count < 1:
        raise ValueError("a sphere path needs at least two points and count >= 1")
    seg = np.linalg.norm(np.diff(path, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    t = np.linspace(0.0, s[-1], count) if count > 1 else np.array([s[-1] / 2])
    centres = np.column_stack([np.interp(t, s, path[:, k]) for k in range(3)])
    r = np.broadcast_to(np.asarray(radius, np.float64), (len(path),)) if np.ndim(radius) == 0 else np.asarray(radius, np.float64)
    if len(r) != len(path):
        raise ValueError(f"radius has {len(r)} values for {len(path)} path points")
    return centres, np.interp(t, s, r)


def arch(left, right, height: float, radius: float, count: int, bulge: float = 0.0):
    """Points of an arch path from ``left`` to ``right`` (3-vectors) rising ``height``."""
    left, right = np.asarray(left, float), np.asarray(right, float)
    u = np.linspace(0, 1, 9)
    pts = left[None] * (1 - u)[:, None] + right[None] * u[:, None]
    pts[:, 1] += height * np.sin(np.pi * u)
    return along_path(pts, radius, count)
