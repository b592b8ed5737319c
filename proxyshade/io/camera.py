"""A pinhole camera at one frame, in pixels (``CameraInfo``): what ``io.usd`` reads from a
stage, what a ProxyRender plate carries in ``meta["camera"]`` and what temporal synthesis
reprojects with. Kept apart from ``io.usd`` so that reading it back from a plate never loads
USD (``pxr``)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class CameraInfo:
    """A pinhole camera at one frame, in pixels."""

    path: str
    frame: int
    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    near: float
    far: float
    camera_to_world: np.ndarray  # (4, 4)

    @property
    def world_to_camera(self) -> np.ndarray:
        return np.linalg.inv(self.camera_to_world)

    @property
    def position(self) -> np.ndarray:
        return self.camera_to_world[:3, 3].copy()

    def to_camera(self, p: np.ndarray) -> np.ndarray:
        """World points (..., 3) -> camera space."""
        V = self.world_to_camera
        return p @ V[:3, :3].T + V[:3, 3]

    def project(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """World points (..., 3) -> (column, row, depth) in pixels (continuous coordinates)."""
        c = self.to_camera(np.asarray(p, np.float64))
        d = -c[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            return self.cx + self.fx * c[..., 0] / d, self.cy - self.fy * c[..., 1] / d, d

    def unproject(self, col: np.ndarray, row: np.ndarray, depth: np.ndarray) -> np.ndarray:
        """(column, row, depth) -> world points (..., 3); the inverse of ``project``."""
        x = (col - self.cx) / self.fx * depth
        y = -(row - self.cy) / self.fy * depth
        c = np.stack([x, y, -np.asarray(depth, np.float64)], axis=-1)
        M = self.camera_to_world
        return c @ M[:3, :3].T + M[:3, 3]

    def pixel_grid(self) -> tuple[np.ndarray, np.ndarray]:
        """(column, row) of every pixel centre, each (H, W)."""
        rows, cols = np.mgrid[0:self.height, 0:self.width].astype(np.float64)
        return cols + 0.5, rows + 0.5

    def projection(self) -> np.ndarray:
        """The OpenGL clip matrix (4, 4, column-vector): ``clip = projection @ world_to_camera
        @ [p, 1]``, NDC = clip[:3] / clip[3] with x right, y up in [-1, 1] over the image,
        z in [-1, 1] between near and far (the transpose of ``Gf.Frustum``'s matrix)."""
        W, H, n, f = self.width, self.height, self.near, self.far
        return np.array([[2 * self.fx / W, 0.0, 1.0 - 2 * self.cx / W, 0.0],
                         [0.0, 2 * self.fy / H, 2 * self.cy / H - 1.0, 0.0],
                         [0.0, 0.0, -(f + n) / (f - n), -2 * f * n / (f - n)],
                         [0.0, 0.0, -1.0, 0.0]])

    def to_meta(self) -> dict:
        """JSON-able: the intrinsics in pixels, both 4x4 transforms (column-vector) and the
        projection matrix; ``from_meta`` rebuilds the camera from it."""
        return {"path": self.path, "frame": self.frame, "resolution": [self.width, self.height],
                "fx": self.fx, "fy": self.fy, "cx": self.cx, "cy": self.cy, "near": self.near, "far": self.far,
                "camera_to_world": self.camera_to_world.tolist(),
                "world_to_camera": self.world_to_camera.tolist(),
                "projection": self.projection().tolist(),
                "position": self.position.tolist()}

    @classmethod
    def from_meta(cls, m: dict) -> "CameraInfo":
        return cls(path=m["path"], frame=int(m["frame"]), width=int(m["resolution"][0]),
                   height=int(m["resolution"][1]), fx=float(m["fx"]), fy=float(m["fy"]), cx=float(m["cx"]),
                   cy=float(m["cy"]), near=float(m["near"]), far=float(m["far"]),
                   camera_to_world=np.array(m["camera_to_world"], np.float64))
