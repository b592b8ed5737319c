"""Modelling tools and the bundled scenes."""
import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from proxyshade.io.usd import camera_at, cameras, distant_light, open_stage, scene_prims, validate
from proxyshade.scene import camera as C
from proxyshade.scene.build import build_stage
from proxyshade.scene.spheres import along_path
from proxyshade.scene.terrain import Terrain

ROOT = Path(__file__).resolve().parents[2]
SCENES = ["lake", "cliffs", "farm"]


def test_gaussian_stroke_pushes_and_pulls():
    t = Terrain(cells=(40, 40), extent=((-20, -20), (20, 20)), height=1.0)
    t.stroke((0, 0), 4.0, 5.0).stroke((10, 10), 2.0, -3.0)
    H = t.heights()
    X, Z = t.grid()
    k = np.unravel_index(np.argmin(X ** 2 + Z ** 2), X.shape)
    assert H[k] == pytest.approx(1 + 5 + (-3) * np.exp(-200 / 8), abs=1e-9)
    far = (np.abs(X) > 18) & (np.abs(Z) > 18) & (X < 0)
    assert np.allclose(H[far], 1.0, atol=1e-3)
    pts, counts, idx = t.mesh()
    assert len(pts) == 41 * 41 and (counts == 4).all() and len(idx) == 4 * 1600
    # quads wound counter-clockwise from above: normals point up
    a, b, c = pts[idx[0]], pts[idx[1]], pts[idx[2]]
    assert np.cross(b - a, c - a)[1] > 0


def test_spheres_along_path_even_spacing_and_radii():
    c, r = along_path([[0, 0, 0], [10, 0, 0], [10, 0, 10]], [1.0, 2.0, 3.0], 5)
    np.testing.assert_allclose(np.linalg.norm(np.diff(c, axis=0), axis=1), 5.0)
    np.testing.assert_allclose(r, [1, 1.5, 2, 2.5, 3])


def test_camera_moves_look_at_their_target():
    for f, M in C.orbit([0, 0, 0], 10, 2, -10, 10, (1, 5), target_height=0).items():
        fwd = -M[:3, 2]
        to = -M[:3, 3] / np.linalg.norm(M[:3, 3])
        np.testing.assert_allclose(fwd, to, atol=1e-12)
        assert np.isclose(np.linalg.norm(M[[0, 2], 3]), 10)
    fly = C.fly_through([[0, 1, 0], [0, 1, -10], [10, 1, -10]], (1, 10))
    assert np.all(np.isfinite(np.array(list(fly.values()))))


def _rounded(text: str) -> str:
    return re.sub(r"-?\d+\.\d+(?:e[-+]?\d+)?", lambda m: f"{float(m.group()):.12g}", text)


@pytest.mark.parametrize("name", SCENES)
def test_bundled_usda_is_what_its_yaml_builds(name):
    spec = yaml.safe_load((ROOT / "samples/scenes" / f"{name}.yaml").read_text())
    stage = build_stage(spec)  # keep the stage alive while its in-memory layer is used
    built = stage.GetRootLayer().ExportToString()
    # the same text, numbers to 12 significant digits: the last bits of a camera matrix
    # follow the numpy / libm build, not the scene
    assert _rounded(built) == _rounded((ROOT / "samples/scenes" / f"{name}.usda").read_text())


@pytest.mark.parametrize("name", SCENES)
def test_bundled_scenes_are_valid_and_animated(name):
    st = open_stage(ROOT / "samples/scenes" / f"{name}.usda")
    assert validate(st) == []
    assert st.GetStartTimeCode() == 1 and st.GetEndTimeCode() == 48
    cam = cameras(st)[0]
    a, b = camera_at(st, cam, 1, 64, 64), camera_at(st, cam, 48, 64, 64)
    assert not np.allclose(a.camera_to_world, b.camera_to_world)
    labelled = [p for p in scene_prims(st, 1) if not p.cg]
    assert labelled and all(p.label for p in labelled)
    if name == "farm":
        assert any(p.cg for p in scene_prims(st, 1)) and distant_light(st, 1) is not None


def test_cliffs_have_an_arch_of_spheres():
    st = open_stage(ROOT / "samples/scenes/cliffs.usda")
    arch = [p for p in scene_prims(st, 1) if p.path.startswith("/World/Proxy/Arch/")]
    assert len(arch) >= 10 and all(p.kind == "sphere" and p.label == "cliff" for p in arch)


def test_bench_valley_builds_valid_with_the_eval_photos_labels(tmp_path):
    """bench_shot --eval builds bench/scenes/valley.yaml for the photos labelled sky,
    vegetation and mountain: it must stay a valid animated scene showing all three."""
    from proxyshade.scene.build import build_file

    st = open_stage(build_file(ROOT / "bench/scenes/valley.yaml", tmp_path / "valley.usda"))
    assert validate(st) == []
    cam = cameras(st)[0]
    assert not np.allclose(camera_at(st, cam, 1, 64, 64).camera_to_world, camera_at(st, cam, 48, 64, 64).camera_to_world)
    assert {p.label for p in scene_prims(st, 1)} == {"vegetation", "mountain"}
