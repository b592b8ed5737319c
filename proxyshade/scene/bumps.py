"""Gaussian bumps on a jittered grid: the BTF test surface.

Neubeck, Zalesny and Van Gool, "Viewpoint consistent texture synthesis" (3DPVT 2004),
Fig. 6: a synthetic sample of Gaussian bumps of random widths. A terrain's ``bumps``
entry expands into ordinary terrain strokes (``proxyshade.scene.terrain.Stroke``), one
per grid cell, so the sample stays plain, editable data:

    bumps: {grid: [10, 10], jitter: 0.35, radius: [0.035, 0.08], amount: [0.05, 0.12], seed: 3}

``grid`` cells over the terrain's extent, each bump centred in its cell moved by up to
``jitter`` cell sizes, with a radius and an amount drawn uniformly between the two
values (``proxyshade.kernels.random``: the same entry gives the same bumps).
"""
from __future__ import annotations



def jittered_bumps(extent, grid, *, jitter: float, radius, amount, seed: int = 0) -> list[dict]:
    """Strokes ``{centre, radius, amount}`` of Gaussian bumps on a jittered ``grid`` (nx, nz)
    over ``extent`` ((x0, z0), (x1, z1))."""
    from proxyshade.kernels.random import uniform

    (x0, z0), (x1, z1) = extent
    nx, nz = (int(v) for v in grid)
    if nx < 1 or nz < 1:
        raise ValueError(f"bumps.grid {list(grid)} must be two positive integers")
    if not 0.0 <= float(jitter) <= 0.5:
        raise ValueError(f"bumps.jitter {jitter} must lie in [0, 0.5] (cell sizes)")
    rlo, rhi = (float(v) for v in radius)
    alo, ahi = (float(v) for v in amount)
    if not 0.0 < rlo <= rhi:
        raise ValueError(f"bumps.radius {list(radius)} must be [low, high] with 0 < low <= high")
    cw, ch = (x1 - x0) / nx, (z1 - z0) / nz
    out = []
    for k in range(nx * nz):
        i, j = divmod(k, nx)
        u = [uniform(int(seed), k, d, 0) for d in range(4)]
        cx = x0 + (j + 0.5 + float(jitter) * (2 * u[0] - 1)) * cw
        cz = z0 + (i + 0.5 + float(jitter) * (2 * u[1] - 1)) * ch
        out.append({"centre": [float(cx), float(cz)], "radius": rlo + (rhi - rlo) * u[2],
                    "amount": alo + (ahi - alo) * u[3]})
    return out


def bump_strokes(d: dict) -> list[dict]:
    """The strokes a terrain description's ``bumps`` entry stands for ([] without one)."""
    b = d.get("bumps")
    if not b:
        return []
    ext = d.get("extent", ((-50, -50), (50, 50)))
    return jittered_bumps(ext, b["grid"], jitter=b.get("jitter", 0.35), radius=b["radius"], amount=b["amount"],
                          seed=b.get("seed", 0))
