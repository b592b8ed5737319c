"""Exponential height fog: transmittance along camera rays through a density that falls off
exponentially with height.

Density at height y: ``sigma(y) = density * exp(-falloff * (y - base))``. Along a ray of
length ``d`` from the camera (height ``y0``) to a point (height ``y1``), the optical depth
is the integral of sigma, which is closed-form (Quilez, "Better fog", 2010; the model of
Unreal's exponential height fog)::

    tau = density * d * exp(-k*h0) * (1 - exp(-k*(h1 - h0))) / (k*(h1 - h0)),  h = y - base

with the last factor -> 1 as ``k*(h1 - h0)`` -> 0 (uniform fog when ``falloff == 0``:
``tau = density * d``). The fogged colour is ``c*T + fog*(1 - T)`` with ``T = exp(-tau)``.
Pure numpy functions on arrays.
"""
from __future__ import annotations

import numpy as np


def optical_depth(d, h0, h1, density: float, falloff: float) -> np.ndarray:
    """Optical depth along rays of length ``d`` from height ``h0`` to ``h1`` (relative to base).

    Parameters
    ----------
    d : (M, N) ndarray
        Ray lengths (negative values count as 0).
    h0 : float or (M, N) ndarray
        Camera height above the fog base.
    h1 : float or (M, N) ndarray
        Point height above the fog base (ignored when ``falloff == 0``).
    density : float
        Extinction per world unit at the base height.
    falloff : float
        Exponential height falloff per world unit (0 = uniform fog).
    """
    d = np.maximum(np.asarray(d, np.float64), 0.0)
    if falloff == 0.0:
        return density * d
    h0 = np.asarray(h0, np.float64)
    x = falloff * (np.asarray(h1, np.float64) - h0)
    small = np.abs(x) < 1e-6
    safe = np.where(small, 1.0, x)
    # (1 - exp(-x)) / x, exact near 0 by its series 1 - x/2
    ratio = np.where(small, 1.0 - 0.5 * x, -np.expm1(-safe) / safe)
    return density * d * np.exp(-falloff * h0) * ratio


def apply_fog(rgb: np.ndarray, tau: np.ndarray, colour, *, alpha: np.ndarray | None = None,
              sky: np.ndarray | None = None, sky_amount: float = 1.0) -> np.ndarray:
    """Fogged colour ``rgb*T + colour*(1 - T)*alpha`` with ``T = exp(-tau)``.

    Parameters
    ----------
    rgb : (M, N, 3) ndarray
        Linear colour (premultiplied by ``alpha`` when given).
    tau : (M, N) ndarray
        Optical depth.
    colour : (3,) sequence
        Linear fog colour.
    alpha : (M, N) ndarray, optional
        Coverage; fog is added in proportion (premultiplied).
    sky, sky_amount : (M, N) bool ndarray, float
        Where ``sky`` is set (no surface, depth inf), ``1 - T`` is ``sky_amount`` instead.
    """
    fog_amt = -np.expm1(-np.asarray(tau, np.float64))  # 1 - T, accurate for small tau
    if sky is not None:
        fog_amt = np.where(sky, sky_amount, fog_amt)
    cov = fog_amt if alpha is None else fog_amt * alpha
    col = np.asarray(colour, np.float64).reshape(1, 1, 3)
    out = rgb * (1.0 - fog_amt)[..., None] + col * cov[..., None]
    return out.astype(np.float32)
