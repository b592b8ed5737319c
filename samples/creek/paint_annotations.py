"""Paint creek's annotation maps for annotated-exemplar synthesis (docs/annotated.md):

- ``scale.png``: a near (0) -> far (1) ramp from the lowest to the highest row of the
  vegetation label: the grass blades shrink towards the top of the photo;
- ``light.png``: the photo's luminance blurred over ~25 px (lit vs shaded patches, not the
  grain), stretched so the 2nd..98th percentile of the vegetation spans 0..1;
- ``vegetation.png``: the usable pixels (the vegetation label of creek_mask.jpg).

Run from the repository root: python samples/creek/paint_annotations.py
"""
from pathlib import Path

import numpy as np

from proxyshade.io.images import read_u8, write_png
from proxyshade.io.source import load_source

HERE = Path(__file__).parent


def box_blur(a: np.ndarray, r: int) -> np.ndarray:
    for axis in (0, 1):
        c = np.cumsum(np.pad(a, [(r + 1, r) if k == axis else (0, 0) for k in range(2)], mode="edge"), axis=axis)
        a = (np.take(c, range(2 * r + 1, c.shape[axis]), axis) - np.take(c, range(0, c.shape[axis] - 2 * r - 1), axis)) / (2 * r + 1)
    return a


def main() -> None:
    src = load_source(HERE / "source.yaml")
    h, w = src.shape
    veg = src["label.id"] == 1
    lum = src.rgb() @ np.array([0.2126, 0.7152, 0.0722], np.float32)
    light = box_blur(box_blur(lum.astype(np.float64), 12), 12)
    lo, hi = np.percentile(light[veg], [2, 98])
    light = np.clip((light - lo) / (hi - lo), 0, 1)
    rows = np.flatnonzero(veg.any(axis=1))
    ramp = np.clip((rows[-1] - np.arange(h)) / (rows[-1] - rows[0]), 0, 1)
    scale = np.repeat(ramp[:, None], w, axis=1)
    for name, v in (("light", light), ("scale", scale), ("vegetation", veg.astype(float))):
        g = np.round(v * 255).astype(np.uint8)
        write_png(HERE / f"{name}.png", np.repeat(g[..., None], 3, axis=2))
    assert read_u8(HERE / "light.png").shape[:2] == (h, w)


if __name__ == "__main__":
    main()
