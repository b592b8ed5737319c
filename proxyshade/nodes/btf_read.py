"""BtfRead: a BTF stack from photos and a YAML of their view and light directions.

Neubeck, Zalesny and Van Gool (3DPVT 2004) synthesize from "98 images per texture
sample" on a slant/tilt grid. Each photo must already be rectified to one plane of the
sample (a marker plane, say); BtfAlign then finds the best plane.
"""
from __future__ import annotations

from pathlib import Path

from proxyshade.graph import keys
from proxyshade.graph.node import Node, Param, resolve_path
from proxyshade.graph.plate import Plate


def _load_yaml(path: Path) -> dict:
    from proxyshade.errors import UserError

    from proxyshade.io import yamlfile

    spec = yamlfile.load(path, what="BTF description")
    if not isinstance(spec, dict) or not isinstance(spec.get("views"), list):
        raise UserError(f"{path}: expected a mapping with 'views': [{{image, slant, tilt, light}}, ...]; fix the YAML")
    return spec


class BtfRead(Node):
    """Read the photos a YAML lists into one stack plate (``v{n}.R/G/B``, linear):

        pixel: 0.009375        # world units per pixel (default 1)
        plane: 0.0             # height of the plane the photos are rectified to
        views:
          - {image: v0.png, slant: 0, tilt: 0, light: [-0.32, -0.57, -0.75]}
          - {image: v1.exr, slant: 10, tilt: 0, light: [-0.32, -0.57, -0.75]}

    8-bit pictures are sRGB, decoded with colour-science; EXRs are read as linear R,G,B.
    Paths are relative to the YAML. The views must lie on a regular slant/tilt grid with
    one frontal view, be of one size and hold no NaN/Inf.
    """

    version = 1
    path = Param(Path, doc="YAML listing the photos with their slant, tilt (degrees) and light direction")

    def key_extra(self, frame, graph_dir):
        try:
            p = resolve_path(self.params["path"], graph_dir, frame)
            spec = _load_yaml(p)
            return [keys.file_hash(p.parent / str(v.get("image"))) for v in spec["views"]]
        except Exception:  # noqa: BLE001 - reported properly by compute
            return None

    def compute(self, ctx) -> Plate:
        import numpy as np

        from proxyshade.errors import UserError
        from proxyshade.synthesis import btf

        path = ctx.path(ctx.p.path)
        try:
            spec = _load_yaml(path)
        except UserError as e:
            raise ctx.error(str(e)) from None
        views, imgs = [], []
        for n, v in enumerate(spec["views"]):
            if not isinstance(v, dict) or "image" not in v:
                raise ctx.error(f"{path}: views[{n}] needs image, slant, tilt (and light); fix the YAML")
            views.append({"slant": v.get("slant"), "tilt": v.get("tilt", 0.0),
                          "light": [float(x) for x in v["light"]] if v.get("light") is not None else None})
        btf.check_views(views, f"{path.name}: views")
        for n, v in enumerate(spec["views"]):
            try:
                img = self._image(path.parent / str(v["image"]))
            except UserError as e:
                raise ctx.error(f"views[{n}]: {e}") from None
            if imgs and img.shape != imgs[0].shape:
                raise ctx.error(f"{path.name}: views[{n}] ({v['image']}) is {img.shape[1]}x{img.shape[0]}, views[0] "
                                f"is {imgs[0].shape[1]}x{imgs[0].shape[0]}; give photos of one size (crop or resize)")
            bad = ~np.isfinite(img)
            if bad.any():
                y, x, _ = np.argwhere(bad)[0]
                raise ctx.error(f"{path.name}: views[{n}] ({v['image']}) has {int(bad.any(-1).sum())} NaN/Inf "
                                f"pixel(s), first at x={x} y={y}; clean the image (clamp or inpaint them)")
            imgs.append(img)
        meta = {"pixel": float(spec.get("pixel", 1.0)), "plane": float(spec.get("plane", 0.0))}
        ctx.note(f"{len(views)} views of {imgs[0].shape[1]}x{imgs[0].shape[0]}")
        return btf.stack_plate(np.stack(imgs), views, meta)

    @staticmethod
    def _image(p: Path):
        import numpy as np

        from proxyshade.errors import UserError

        if p.suffix.lower() == ".exr":
            from proxyshade.io.exr import read_plate

            plate = read_plate(p)
            if not all(c in plate for c in "RGB"):
                raise UserError(f"{p}: the EXR has no R,G,B channels (it has {', '.join(plate.names())}); "
                                "write the photo as RGB")
            return np.stack([plate[c].astype(np.float32) for c in "RGB"], -1)
        from proxyshade.io.images import read_u8
        from proxyshade.io.source import srgb_to_linear

        return srgb_to_linear(read_u8(p))
