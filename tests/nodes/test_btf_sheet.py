"""BtfSheet: a row per slant, a column per tilt, the frontal view alone in the first row."""
import numpy as np

from proxyshade.graph.testing import run_node
from proxyshade.synthesis.btf import stack_plate, view_grid


def test_views_land_in_their_cells():
    views = view_grid(30, 60, [0, 45, 90])
    imgs = np.stack([np.full((6, 5, 3), n + 1, np.float32) for n in range(len(views))])
    sheet = run_node("BtfSheet", {"gap": 1, "crop": 4}, {"stack": stack_plate(imgs, views, {"pixel": 1.0})})
    assert sheet.shape == (3 * 4 + 2, 3 * 4 + 2)
    R = sheet["R"]
    for n, v in enumerate(views):
        row = int(v["slant"] // 30)
        col = [0, 45, 90].index(v["tilt"]) if v["slant"] else 0
        cell = R[row * 5:row * 5 + 4, col * 5:col * 5 + 4]
        assert (cell == n + 1).all(), (n, v)
    assert (R[0:4, 5:] == 0).all() and (R[4] == 0).all()  # empty cells beside the frontal view, gaps black
