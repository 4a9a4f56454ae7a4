"""Cameras for files without one (orbit about a target, auto framing), units, and ``compare inspect``."""

from __future__ import annotations

import json
import math
import shutil

import numpy as np
import pytest

from compare.cli.main import main
from compare.scene import framing
from compare.scene.loader import load_scene
from compare.util.errors import SceneError
from tests.helpers import ROOT

CAR = ROOT / "scenes" / "car"
ENV = """
[environment]
constant = [1.0, 1.0, 1.0]
"""


def _include(tmp_path, extra: str = "", name: str = "coupe-meshopt.glb") -> str:
    shutil.copyfile(CAR / name, tmp_path / name)
    return f'[[include]]\nfile = "{name}"\n{extra}\n'


@pytest.mark.parametrize("theta, phi, direction", [(0, 90, (0, 0, 1)), (90, 90, (1, 0, 0)), (180, 90, (0, 0, -1)),
                                                   (-90, 90, (-1, 0, 0)), (0, 1e-9, (0, 1, 0)),
                                                   (45, 60, (math.sqrt(3 / 8), 0.5, math.sqrt(3 / 8)))])
def test_orbit_is_the_fidelity_tools_convention(theta, phi, direction):
    """model-viewer's camera-orbit (three.js Spherical): theta about +Y from +Z towards +X, phi from +Y."""
    p = framing.orbit_position([1.0, 2.0, 3.0], theta, phi, 2.0)
    np.testing.assert_allclose(p, np.add([1.0, 2.0, 3.0], 2.0 * np.asarray(direction)), atol=1e-9)


def _projected(camera, points):
    r, u, f = camera.basis()
    d = np.asarray(points) - np.asarray(camera.position)
    t = math.tan(math.radians(camera.fov) / 2)
    return (d @ r) / (d @ f) / (t * camera.aspect), (d @ u) / (d @ f) / t


@pytest.mark.parametrize("theta, phi, resolution", [(0, 75, [320, 240]), (130, 40, [120, 240]), (-60, 100, [400, 100])])
def test_auto_target_and_radius_frame_the_model_from_any_direction(tmp_path, make_scene, theta, phi, resolution):
    path = make_scene(_include(tmp_path), ENV, camera={"target": "auto", "fov": 30.0, "resolution": resolution,
                                                       "orbit": {"theta": theta, "phi": phi, "radius": "auto"}})
    s = load_scene(path)
    lo, hi = s.bounds()
    np.testing.assert_allclose(s.camera.target, (lo + hi) / 2, atol=1e-9)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    x, y = _projected(s.camera, s.meshes[0].triangles().positions.tolist() + corners.tolist())
    assert np.abs(x).max() <= 1.0 and np.abs(y).max() <= 1.0  # all of it in view
    xs, ys = _projected(s.camera, np.concatenate([m.triangles().positions for m in s.meshes]))
    assert max(np.abs(xs).max(), np.abs(ys).max()) > 0.3  # and not a speck


def test_no_camera_at_all_frames_the_model_with_a_note(tmp_path, make_scene):
    path = make_scene(_include(tmp_path), ENV)
    with pytest.warns(UserWarning, match=r"no \[camera\] .* framed by an orbit \(theta 0°, phi 75°\)"):
        s = load_scene(path)
    lo, hi = s.bounds()
    np.testing.assert_allclose(s.camera.target, (lo + hi) / 2, atol=1e-9)


def test_auto_frames_the_model_not_the_floor_the_toml_adds(tmp_path, make_scene):
    path = make_scene(_include(tmp_path), ENV, camera={"target": "auto", "orbit": {}},
                      materials={"grey": {"base_color": [0.5, 0.5, 0.5]}},
                      meshes=[{"name": "floor", "shape": "quad", "size": [200.0, 200.0], "material": "grey"}])
    s = load_scene(path)
    assert np.linalg.norm(np.subtract(s.camera.position, s.camera.target)) < 20  # not framed on a 200 m floor


@pytest.mark.parametrize("camera, field, message", [
    ({"target": [0, 0, 0], "position": [0, 0, 5], "orbit": {}}, "camera.orbit", "either a position or an orbit"),
    ({"target": [0, 0, 0], "orbit": {"phi": 0}}, "camera.orbit.phi", r"expected degrees from \+Y in \(0, 180\)"),
    ({"target": [0, 0, 0], "orbit": {"radius": -1}}, "camera.orbit.radius", 'expected metres > 0 or "auto"'),
    ({"target": [0, 0, 0], "orbit": {"tilt": 3}}, "camera.orbit.tilt", r"unknown field \(allowed: phi, radius, theta\)"),
    ({"target": "middle", "orbit": {}}, "camera.target", "expected"),
])
def test_bad_orbits_name_the_field(tmp_path, make_scene, camera, field, message):
    path = make_scene(_include(tmp_path), ENV, camera=camera)
    with pytest.raises(SceneError, match=rf"scene.toml: {field}: .*{message}"):
        load_scene(path)


def test_units_scale_the_model_and_implausible_bounds_suggest_them(tmp_path, make_scene):
    cam = {"target": [0, 0.5, 0], "position": [8, 2, 8]}
    plain = load_scene(make_scene(_include(tmp_path), ENV, camera=cam))
    for units, factor in (("cm", 0.01), ("mm", 0.001), ("in", 0.0254)):
        s = load_scene(make_scene(_include(tmp_path, f'units = "{units}"'), ENV, camera=cam, name=f"{units}.toml"))
        np.testing.assert_allclose(np.subtract(*s.bounds()[::-1]), factor * np.subtract(*plain.bounds()[::-1]),
                                   rtol=1e-6)  # float32 positions
    # a model authored in millimetres, read as metres: 4.5 km across
    big = make_scene(_include(tmp_path, "scale = 1000.0"), ENV, camera={"target": "auto", "orbit": {}}, name="mm.toml")
    with pytest.warns(UserWarning, match=r"the model is 4515 m across when read as metres .* set units = \"cm\", "
                                         r"\"mm\" or \"in\" in its \[\[include\]\] \(it would be 45.2 m, 4.52 m"):
        load_scene(big)
    with pytest.raises(SceneError, match=r"include\[0\].units: expected one of 'm', 'cm', 'mm', 'in', 'ft', got 'km'"):
        load_scene(make_scene(_include(tmp_path, 'units = "km"'), ENV, name="km.toml"))


def test_inspect_prints_what_a_camera_needs(tmp_path, capsys):
    assert main(["inspect", str(CAR / "coupe-ktx2.glb")]) == 0
    out = capsys.readouterr().out
    assert "bounds       [-2.25, -1.311e-08, -1.025] … [2.265, 1.335, 1.025] m" in out
    assert "triangles    36,134 in 17 part(s), 9 material(s)" in out
    assert "KHR_texture_basisu: transcoded to RGBA8 with Basis Universal" in out
    assert "map          image 0: 512×1024 RGB, base_color" in out
    assert "cameras      none (frame one with [camera] orbit)" in out
    assert main(["inspect", "--json", str(CAR / "coupe-draco.glb")]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["extensions"]["KHR_draco_mesh_compression"] == "decoded with Draco (DracoPy)"
    assert info["triangles"] == 36134 and len(info["maps"]) == 3


def test_inspect_of_a_broken_file_is_one_error(tmp_path, capsys):
    bad = tmp_path / "bad.glb"
    bad.write_bytes(b"glTF\x02\0\0\0" + b"\0" * 4)
    assert main(["inspect", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("compare: error:") and "bad.glb" in err and "Traceback" not in err
