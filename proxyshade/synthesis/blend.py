"""Poisson blending of patch seams (Bonneel et al. 2010, §5 step 3, §6.3, §7): the whole
frame, or only the newly synthesized regions with Dirichlet values around them.

Solve Δu = Δ(f∘s) in Ω, ∇u = 0 across patch boundaries (Γ1: with ``seams: source`` the
source's own gradient read through the map on both sides of the seam instead), u = f∘s on
boundaries between label ids (Γ2). Kernels: ``proxyshade.kernels.poisson``, the
restricted solve ``proxyshade.kernels.temporal.poisson_regions``.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from proxyshade.kernels import poisson as kpoisson
from proxyshade.kernels import temporal as kt


def blend_frame(rgb: np.ndarray, patch: np.ndarray, labels: np.ndarray | None, solve: SimpleNamespace, *,
                source_rgb: np.ndarray | None = None, sx: np.ndarray | None = None, sy: np.ndarray | None = None,
                scale: float = 1.0, fixed: np.ndarray | None = None,
                values: np.ndarray | None = None) -> tuple[np.ndarray, dict]:
    """The whole-frame solve (``fixed`` pixels keep ``values``). ``solve``: the
    ``PoissonSolve`` parameters; ``seams: source`` reads ``source_rgb`` through ``sx, sy``
    (source pixels; ``scale`` source pixels per output pixel)."""
    gx = gy = None
    if solve.seams == "source":
        gx, gy = kpoisson.seam_gradients(source_rgb, sx, sy, scale)
    return kpoisson.poisson_transfer(rgb, patch, labels, fixed=fixed, values=values,
                                     label_dirichlet=solve.label_dirichlet, seam_gx=gx, seam_gy=gy,
                                     screen=solve.screen, tol=solve.tol, max_iter=solve.max_iter)


def blend_regions(rgb: np.ndarray, patch: np.ndarray, labels: np.ndarray, free: np.ndarray, solve: SimpleNamespace,
                  *, source_rgb: np.ndarray | None, sx: np.ndarray, sy: np.ndarray, scale: float,
                  filter: str) -> tuple[np.ndarray, dict]:
    """The solve restricted to the ``free`` pixels, the rest Dirichlet (§6.3), region by
    region; seam gradients read with ``filter`` (the reconstruction the colours used)."""
    return kt.poisson_regions(rgb, patch, labels, free, source=source_rgb if solve.seams == "source" else None,
                              sx=sx, sy=sy, step=scale, label_dirichlet=solve.label_dirichlet, screen=solve.screen,
                              tol=solve.tol, max_iter=solve.max_iter, filter=filter)
