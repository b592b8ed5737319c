"""The terrain tool: a heightfield mesh edited by Gaussian push/pull strokes.

"The terrain tool simply pushes and pulls vertices of a heightfield with a Gaussian region
of influence" (Bonneel et al. 2010, §3). A terrain is its grid plus an ordered list of
strokes, so it is reproducible and editable as data (YAML).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Stroke:
    """Push (amount > 0) or pull (amount < 0) heights around ``centre`` (x, z) with a
    Gaussian of standard deviation ``radius``: h += amount · exp(−d² / (2 radius²))."""

    centre: tuple[float, float]
    radius: float
    amount: float


@dataclass
class Terrain:
    """A Y-up heightfield over ``extent`` = ((x0, z0), (x1, z1)) with ``cells`` = (nx, nz)."""

    cells: tuple[int, int] = (128, 128)
    extent: tuple[tuple[float, float], tuple[float, float]] = ((-50.0, -50.0), (50.0, 50.0))
    height: float = 0.0
    strokes: list[Stroke] = field(default_factory=list)

    def stroke(self, centre, radius, amount) -> "Terrain":
        self.strokes.append(Stroke(tuple(centre), float(radius), float(amount)))
        return self

    def grid(self) -> tuple[np.ndarray, np.ndarray]:
        (x0, z0), (x1, z1) = self.extent
        nx, nz = self.cells
        return np.meshgrid(np.linspace(x0, x1, nx + 1), np.linspace(z0, z1, nz + 1))

    def heights(self) -> np.ndarray:
        """(nz + 1, nx + 1) heights after every stroke, in order."""
        X, Z = self.grid()
        H = np.full(X.shape, float(self.height))
        for s in self.strokes:
            d2 = (X - s.centre[0]) ** 2 + (Z - s.centre[1]) ** 2
            H += s.amount * np.exp(-d2 / (2.0 * s.radius ** 2))
        return H

    def mesh(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(points (V, 3), faceVertexCounts, faceVertexIndices) of quads, wound so normals point up."""
        X, Z = self.grid()
        H = self.heights()
        nx, nz = self.cells
        pts = np.column_stack([X.ravel(), H.ravel(), Z.ravel()])
        i, j = np.mgrid[0:nz, 0:nx]
        a = (i * (nx + 1) + j).ravel()
        quads = np.column_stack([a, a + nx + 1, a + nx + 2, a + 1])  # counter-clockwise seen from +y
        return pts, np.full(len(quads), 4, np.int32), quads.ravel().astype(np.int32)

    @classmethod
    def from_dict(cls, d: dict) -> "Terrain":
        t = cls(cells=tuple(d.get("cells", (128, 128))), extent=tuple(tuple(e) for e in d.get("extent", ((-50, -50), (50, 50)))),
                height=float(d.get("height", 0.0)))
        from proxyshade.scene.bumps import bump_strokes

        for s in list(d.get("strokes", [])) + bump_strokes(d):
            t.stroke(s["centre"], s["radius"], s["amount"])
        return t
