"""``proxyshade scene ...``: new, stroke, spheres, camera, build, validate, info; bad input."""
import numpy as np
import yaml

from proxyshade.cli import main
from proxyshade.io.usd import camera_at, open_stage, scene_prims
from proxyshade.scene.terrain import Terrain


def test_new_then_edit_with_each_tool(tmp_path, capsys):
    spec = tmp_path / "valley.yaml"
    assert main(["scene", "new", str(spec)]) == 0
    usda = tmp_path / "valley.usda"
    assert usda.is_file()
    before = {p.path: p for p in scene_prims(open_stage(usda), 1)}["/World/Proxy/Ground"].points

    assert main(["scene", "stroke", str(spec), "--terrain", "Ground", "--centre", "10,-40", "--radius", "6",
                 "--amount", "-3"]) == 0
    after = {p.path: p for p in scene_prims(open_stage(usda), 1)}["/World/Proxy/Ground"].points
    d = after[:, 1] - before[:, 1]
    assert d.min() < -2.5 and d.max() <= 1e-6  # only pulled down, near the centre
    k = np.argmin(d)
    assert np.hypot(after[k, 0] - 10, after[k, 2] + 40) < 4

    assert main(["scene", "spheres", str(spec), "--name", "Row", "--label", "tree", "--path", "0,3,-20;30,3,-20",
                 "--radius", "2,4", "--count", "4"]) == 0
    row = [p for p in scene_prims(open_stage(usda), 1) if p.path.startswith("/World/Proxy/Row/")]
    np.testing.assert_allclose([p.radius for p in row], [2, 2 + 2 / 3, 2 + 4 / 3, 4], rtol=1e-6)
    assert all(p.label == "tree" for p in row)

    assert main(["scene", "camera", str(spec), "--move", "dolly", "-p", "start=[0,5,30]", "-p", "end=[0,5,10]",
                 "-p", "target=[0,0,-50]"]) == 0
    st = open_stage(usda)
    np.testing.assert_allclose(camera_at(st, None, 1, 8, 8).position, [0, 5, 30], atol=1e-5)
    np.testing.assert_allclose(camera_at(st, None, 48, 8, 8).position, [0, 5, 10], atol=1e-5)
    assert len(yaml.safe_load(spec.read_text())["cameras"]) == 1  # replaced, not added

    capsys.readouterr()
    assert main(["scene", "validate", str(usda)]) == 0
    assert "valid" in capsys.readouterr().out
    assert main(["scene", "info", str(usda), "--frame", "2"]) == 0
    out = capsys.readouterr().out
    assert "/World/Proxy/Row/S000" in out and "tree" in out and "cameras: /World/Camera" in out


def test_bad_edits_are_one_line_errors_and_leave_the_yaml(tmp_path, capsys):
    spec = tmp_path / "s.yaml"
    assert main(["scene", "new", str(spec)]) == 0
    text = spec.read_text()
    capsys.readouterr()
    assert main(["scene", "stroke", str(spec), "--terrain", "Nope", "--centre", "0,0", "--radius", "1",
                 "--amount", "1"]) == 2
    assert "no terrain 'Nope'; terrains are Ground" in capsys.readouterr().err
    assert main(["scene", "camera", str(spec), "--move", "zoom"]) == 2
    err = capsys.readouterr().err
    assert "cameras[0] (Camera): camera move 'zoom' is not valid" in err and len(err.strip().splitlines()) == 1
    assert main(["scene", "spheres", str(spec), "--name", "bad name", "--label", "tree", "--path", "0,0,0;1,1,1",
                 "--radius", "1", "--count", "2"]) == 2
    assert "not a valid prim name" in capsys.readouterr().err
    assert spec.read_text() == text
    assert main(["scene", "new", str(spec)]) == 2
    assert "already exists" in capsys.readouterr().err


def test_build_reports_missing_fields(tmp_path, capsys):
    spec = tmp_path / "m.yaml"
    spec.write_text("terrains:\n  - {name: G, cells: [2, 2]}\n")
    assert main(["scene", "build", str(spec)]) == 2
    assert "m.yaml: terrains[0] (G): missing field 'label'" in capsys.readouterr().err


def test_validate_reports_usd_errors(tmp_path, capsys):
    bad = tmp_path / "bare.usda"
    bad.write_text('#usda 1.0\n\ndef Xform "World"\n{\n}\n')
    assert main(["scene", "validate", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "UsdValidation error" in err and "MissingDefaultPrim" in err


def test_terrain_mesh_matches_strokes_exactly():
    t = Terrain(cells=(4, 4), extent=((0, 0), (4, 4)), height=0.5).stroke((2, 2), 1.0, 2.0)
    pts, counts, idx = t.mesh()
    d2 = (pts[:, 0] - 2) ** 2 + (pts[:, 2] - 2) ** 2
    np.testing.assert_allclose(pts[:, 1], 0.5 + 2.0 * np.exp(-d2 / 2.0))
