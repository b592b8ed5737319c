"""The pinhole camera's intrinsics and unprojection, shared by ``kernels.reproject`` and
``kernels.edit``: a small module of its own, so that the edit kernels and the depth step
(``synthesis.depth``, on every first frame) need not import the reprojection kernels (0.1 s
of numba decorators and their imports)."""
from __future__ import annotations

import numpy as np
from numba import njit

from proxyshade.kernels._config import JIT


@njit(inline="always", **JIT)
def _world(z, i, j, C, k, m):
    """World coordinate m of pixel (i, j)'s centre at camera depth z (``reproject.unproject``);
    C : camera-to-world 4×4, k : intrinsics (fx, fy, cx, cy)."""
    x = (j + 0.5 - k[2]) / k[0] * z
    y = -(i + 0.5 - k[3]) / k[1] * z
    return C[m, 0] * x + C[m, 1] * y - C[m, 2] * z + C[m, 3]


def intrinsics(cam) -> np.ndarray:
    """(fx, fy, cx, cy) of a ``proxyshade.io.usd.CameraInfo`` as float64."""
    return np.array([cam.fx, cam.fy, cam.cx, cam.cy], np.float64)
