"""Scenarios of model-viewer's render-fidelity format (``config.json``) as scenes: defaults, the camera,
errors, exclusions, ``compare run --scenarios`` and ``compare inspect``, and where paths may lead."""

from __future__ import annotations

import base64
import json
import math
import warnings

import numpy as np
import pytest

from compare.cli.main import main
from compare.image.hdr import write_hdr
from compare.scene.loader import load_scene
from compare.scene.scenarios import RENDERER_NAMES, load_scenarios, suite_renderers
from compare.util.errors import SceneError
from tests.helpers import card_gltf

#: The published file's layout: packages/render-fidelity-tools/test/config.json names
#: ../../../shared-assets/models/… and ../../../shared-assets/environments/….
CONFIG_DIR = ("packages", "render-fidelity-tools", "test")
MODEL = "../../../shared-assets/models/card/card.gltf"
HDR = "../../../shared-assets/environments/lightroom_14b.hdr"  # model-viewer's default lighting's name


@pytest.fixture
def assets(tmp_path):
    """The shared-assets tree with the card and a small uniform HDR; returns the config file's folder."""
    card_gltf(tmp_path / "shared-assets" / "models" / "card")
    env = tmp_path / "shared-assets" / "environments"
    env.mkdir(parents=True)
    write_hdr(env / "lightroom_14b.hdr", np.full((8, 16, 3), 0.5, np.float32))
    folder = tmp_path.joinpath(*CONFIG_DIR)
    folder.mkdir(parents=True)
    return folder


def _config(folder, scenarios, name="config.json"):
    path = folder / name
    path.write_text(json.dumps({"renderers": [{"name": "model-viewer", "description": "<model-viewer>"}],
                                "scenarios": scenarios}), encoding="utf-8")
    return path


def _load(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the notes of a file (phi outside the element's range)
        return load_scenarios(path)


def test_defaults_are_the_config_readers(assets):
    """config-reader.ts defaultScenario, merged field by field and inside dimensions/target/orbit key by key."""
    path = _config(assets, [{"name": "bare", "model": MODEL},
                            {"name": "some", "model": MODEL, "dimensions": {"height": 512}, "target": {"y": 1.1},
                             "orbit": {"radius": 6}, "exclude": ["dspbr-pt"]}])
    bare, some = _load(path)
    assert (bare.width, bare.height) == (768, 768)
    assert bare.target == (0.0, 0.0, 0.0)  # the model's origin, not the centre of its bounds
    assert bare.orbit == (0.0, 90.0, 1.0) and bare.vertical_fov == 45.0
    assert bare.render_skybox is False and bare.exclude == ()
    assert bare.lighting == (assets / HDR).resolve() and bare.lighting.is_file()
    assert bare.model == (assets / MODEL).resolve()
    assert (some.width, some.height) == (768, 512) and some.target == (0.0, 1.1, 0.0)
    assert some.orbit == (0.0, 90.0, 6.0) and some.exclude == ("dspbr-pt",)


def test_the_camera_of_an_orbit(assets):
    """SmoothControls.moveCamera: target + r (sin φ sin θ, cos φ, sin φ cos θ), looking back at the target,
    up from Euler(φ − π/2, θ, 0, 'YXZ'); theta/phi in degrees, radius and target in metres."""
    path = _config(assets, [{"name": "o", "model": MODEL, "target": {"x": 1, "y": 2, "z": 3},
                             "orbit": {"theta": 30, "phi": 60, "radius": 2}, "verticalFoV": 35,
                             "dimensions": {"width": 32, "height": 16}}])
    (sc,) = _load(path)
    t, p = math.radians(30), math.radians(60)
    offset = np.array([math.sin(p) * math.sin(t), math.cos(p), math.sin(p) * math.cos(t)])
    cam = sc.camera()
    np.testing.assert_allclose(cam.position, np.array([1, 2, 3]) + 2 * offset, atol=1e-12)
    np.testing.assert_allclose(cam.forward, -offset, atol=1e-12)
    np.testing.assert_allclose(cam.up, [-math.cos(p) * math.sin(t), math.sin(p), -math.cos(p) * math.cos(t)],
                               atol=1e-12)
    assert abs(np.dot(cam.up, cam.forward)) < 1e-12 and cam.fov == 35
    scene = sc.scene()
    assert scene.name == "o" and scene.camera.resolution == (32, 16) and scene.camera.fov == 35
    np.testing.assert_allclose(scene.camera.position, cam.position, atol=1e-12)
    np.testing.assert_allclose(scene.camera.target, [1, 2, 3], atol=1e-12)
    right, up, forward = scene.camera.basis()
    np.testing.assert_allclose(forward, -offset, atol=1e-12)
    np.testing.assert_allclose(up, cam.up, atol=1e-12)
    # the default view: theta 0, phi 90 (from the side), radius 1: at +Z looking along -Z
    np.testing.assert_allclose(_load(_config(assets, [{"name": "d", "model": MODEL}], "d.json"))[0].camera().position,
                               [0, 0, 1], atol=1e-6)
    assert scene.environment.rotation == 90.0  # three.js's equirect u is the suite's + 1/4


def test_render_skybox_false_hides_the_background(assets):
    """renderSkybox false (the default) gives a scene whose environment lights but is not seen behind the
    model (background = false, the feature hidden_background); true keeps it seen; neither is a note, and
    the two scenes never share a hash (nor a cached render)."""
    path = _config(assets, [{"name": "hidden", "model": MODEL}, {"name": "sky", "model": MODEL, "renderSkybox": True},
                            {"name": "off", "model": MODEL, "renderSkybox": False}])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        hidden, sky, off = load_scenarios(path)
    assert not [w for w in caught if "renderSkybox" in str(w.message)]
    scenes = {sc.name: sc.scene() for sc in (hidden, sky, off)}
    assert scenes["hidden"].environment.background is False and scenes["off"].environment.background is False
    assert scenes["sky"].environment.background is True
    assert scenes["hidden"].features().hidden_background and not scenes["sky"].features().hidden_background
    # the same scenario but for renderSkybox: another scene hash
    flip = _config(assets, [{"name": "hidden", "model": MODEL, "renderSkybox": True}], "flip.json")
    assert _load(flip)[0].scene().hash != scenes["hidden"].hash
    assert scenes["hidden"].with_background().hash != scenes["hidden"].hash


def test_radius_zero_looks_outward_and_near_far(assets):
    """khronos-Sponza's orbit (theta 90, radius 0): the camera on the target, looking along -X; near and far
    as controls.ts derives them: far = 2 max(bounding radius about the target, radius), near = far / 1000."""
    path = _config(assets, [{"name": "in", "model": MODEL, "target": {"y": 0.5}, "orbit": {"theta": 90, "radius": 0}},
                            {"name": "out", "model": MODEL, "orbit": {"radius": 5}}])
    inside, outside = _load(path)
    scene = inside.scene()
    np.testing.assert_allclose(scene.camera.position, [0, 0.5, 0], atol=1e-12)
    np.testing.assert_allclose(scene.camera.basis()[2], [-1, 0, 0], atol=1e-9)
    cam = inside.framed_camera(scene)
    reach = math.sqrt(1 + 1.5 ** 2)  # card corner (±1, -1, 0) from (0, 0.5, 0)
    assert cam.far == pytest.approx(2 * reach) and cam.near == pytest.approx(cam.far / 1000)
    cam = outside.framed_camera(outside.scene())
    assert cam.far == pytest.approx(10.0) and cam.near == pytest.approx(0.01)


def test_a_missing_model_is_one_error_naming_scenario_and_path(assets, capsys):
    path = _config(assets, [{"name": "fine", "model": MODEL},
                            {"name": "gone", "model": "../../../shared-assets/models/nope.glb"}])
    fine, gone = _load(path)
    fine.scene()
    expected = (f"{path}: scenarios[1] (gone): model: file '../../../shared-assets/models/nope.glb' not found "
                f"(looked for {(assets / '../../../shared-assets/models/nope.glb').resolve()})")
    with pytest.raises(SceneError) as info:
        gone.scene()
    assert str(info.value) == expected
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["run", "--scenarios", str(path), "--size", "16x12", "--renderers", "mitsuba", "--spp", "2",
                     "-o", str(assets / "never"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.strip() == f"compare: error: {expected}; --skip-unavailable renders the 1 that can"
    assert "Traceback" not in err
    assert not (assets / "never").exists()


def test_an_ldr_lighting_is_one_scenarios_error_not_the_files(assets):
    """A scenario lit by an image the suite does not read (model-viewer's pages take LDR JPEGs): the file
    reads, that scenario says why it cannot be rendered, and the others are unaffected."""
    path = _config(assets, [{"name": "ldr", "model": MODEL, "lighting": "../../../shared-assets/environments/sky.jpg"},
                            {"name": "fine", "model": MODEL}])
    ldr, fine = _load(path)
    assert ldr.unavailable() == "lighting '../../../shared-assets/environments/sky.jpg' is not an .exr or .hdr file"
    with pytest.raises(SceneError, match=r"scenarios\[0\] \(ldr\): lighting: .*sky\.jpg.*\.exr or \.hdr files"):
        ldr.scene()
    assert fine.unavailable() is None and fine.scene().name == "fine"


@pytest.mark.parametrize("change, message", [
    ({"orbit": {"radius": "auto"}}, r"scenarios\[0\] \(s\): orbit\.radius: expected a number .*no 'auto'"),
    ({"orbit": {"radius": -1}}, r"orbit\.radius: expected metres >= 0"),
    ({"verticalFoV": 180}, r"verticalFoV: expected degrees in \(0, 180\)"),
    ({"dimensions": {"width": 0}}, r"dimensions\.width: expected a positive integer"),
    ({"exclude": "babylon"}, r"exclude: expected an array of renderer names"),
    ({"orbit": {"rho": 1}}, r"orbit\.rho: unknown field"),
])
def test_bad_fields_are_one_error_naming_the_field(assets, change, message):
    with pytest.raises(SceneError, match=message):
        _load(_config(assets, [{"name": "s", "model": MODEL, **change}]))


def test_bad_files_are_one_error(assets):
    with pytest.raises(SceneError, match=r"scenarios\[1\]\.name: 'a' is also scenarios\[0\]'s"):
        _load(_config(assets, [{"name": "a", "model": MODEL}, {"name": "a", "model": MODEL}]))
    (assets / "x.json").write_text("{", encoding="utf-8")
    with pytest.raises(SceneError, match="x.json: not a JSON document"):
        load_scenarios(assets / "x.json")
    (assets / "y.json").write_text('{"scenes": []}', encoding="utf-8")
    with pytest.raises(SceneError, match="y.json: scenarios: expected a render-fidelity config"):
        load_scenarios(assets / "y.json")


def test_excluded_renderers_map_to_the_suites():
    known = ["mitsuba", "progressive", "threejs", "threejs-pathtracer", "babylon", "cycles", "model-viewer",
             "gltf-sample-viewer", "filament"]
    assert suite_renderers(["model-viewer", "filament", "babylon", "three-gpu-pathtracer", "stellar",
                            "blender-cycles", "dspbr-pt", "gltf-sample-viewer"], known) == (
        "model-viewer", "filament", "babylon", "threejs-pathtracer", "cycles", "gltf-sample-viewer")
    assert suite_renderers(["progressive", "nonesuch"], known) == ("progressive",)  # the suite's own names too
    assert set(RENDERER_NAMES.values()) <= set(known)


@pytest.mark.gl
def test_run_scenarios_is_one_run_with_one_report(assets, capsys, monkeypatch):
    """Two scenarios at a tiny size: one results.json with both scenes; the second's exclude drops the
    rasterizer there (and names the suite does not have are ignored)."""
    monkeypatch.setenv("COMPARE_CACHE", str(assets / "cache"))
    path = _config(assets, [{"name": "front", "model": MODEL, "orbit": {"radius": 4}},
                            {"name": "side", "model": MODEL, "orbit": {"theta": 40, "phi": 70, "radius": 4},
                             "exclude": ["progressive", "stellar", "dspbr-pt"]}])
    out = assets / "out"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["run", "--scenarios", str(path), "--size", "16x12", "--spp", "2", "--frames", "2",
                     "--renderers", "mitsuba,progressive", "-o", str(out), "--quiet"]) == 0
    res = json.loads((out / "results.json").read_text(encoding="utf-8"))
    scenes = {s["name"]: s for s in res["scenes"]}
    assert set(scenes) == {"front", "side"} and (out / "index.html").is_file()
    assert [r["renderer"] for r in scenes["front"]["runs"]] == ["mitsuba", "progressive"]
    assert [r["renderer"] for r in scenes["side"]["runs"]] == ["mitsuba"]
    assert not res.get("failures") and (scenes["front"]["width"], scenes["front"]["height"]) == (16, 12)
    record = res["scenarios"]  # the file's scenarios, for the report's scenario table
    assert record["file"] == str(path) and [s["name"] for s in record["scenarios"]] == ["front", "side"]
    assert record["scenarios"][1]["excluded"] == ["progressive"] and record["scenarios"][1]["unavailable"] is None
    assert record["scenarios"][1]["scenes"] == [scenes["side"]["id"]]


def test_scenes_and_scenarios_are_exclusive(assets, capsys):
    path = _config(assets, [{"name": "s", "model": MODEL}])
    with pytest.raises(SystemExit) as exc:
        main(["run", "--scenes", "scenes/cornell.toml", "--scenarios", str(path)])
    assert exc.value.code == 2 and "not allowed with argument" in capsys.readouterr().err


def test_inspect_lists_the_scenarios(assets, capsys):
    path = _config(assets, [{"name": "khronos-Sponza", "model": MODEL, "target": {"y": 1},
                             "orbit": {"theta": 90, "radius": 0}, "exclude": ["model-viewer", "dspbr-pt"]},
                            {"name": "lost", "model": "../gone.glb", "renderSkybox": True,
                             "dimensions": {"width": 1024, "height": 512}}])
    assert main(["inspect", str(path)]) == 0
    text = capsys.readouterr().out
    for part in ("2 scenario(s)", "khronos-Sponza", MODEL, HDR, "768×768", "1024×512",
                 "theta 90°, phi 90°, radius 0 m", "looking along [-1, 0,", "fov 45°",
                 "model-viewer, dspbr-pt (the suite's: model-viewer)", "../gone.glb  (not found)",
                 "renderSkybox false"):
        assert part in text, part
    assert main(["inspect", str(path), "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["scenarios"]
    assert rows[0]["excluded_renderers"] == ["model-viewer"] and rows[1]["model_found"] is False
    np.testing.assert_allclose(rows[0]["camera"]["position"], [0, 1, 0], atol=1e-12)


def test_scene_files_may_name_files_outside_their_folder_but_gltf_uris_may_not(tmp_path):
    """The paths a user writes (a scenario file's, a scene file's) may leave its folder; the URIs inside a
    downloaded glTF stay confined to the glTF's own folder."""
    card_gltf(tmp_path / "models")
    (tmp_path / "env").mkdir()
    write_hdr(tmp_path / "env" / "sky.hdr", np.full((8, 16, 3), 0.5, np.float32))
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    toml = scenes / "s.toml"
    toml.write_text('include = "../models/card.gltf"\n[environment]\nfile = "../env/sky.hdr"\n'
                    '[camera]\nposition = [0, 0, 3]\ntarget = [0, 0, 0]\n', encoding="utf-8")
    scene = load_scene(toml)
    assert len(scene.meshes) == 1 and scene.environment.file == (tmp_path / "env" / "sky.hdr").resolve()
    # the glTF's buffer one folder up from the glTF: refused, naming the glTF's folder
    doc = json.loads((tmp_path / "models" / "card.gltf").read_text(encoding="utf-8"))
    (buffer,) = doc["buffers"]
    (tmp_path / "card.bin").write_bytes(base64.b64decode(buffer["uri"].partition(",")[2]))  # was a data URI
    buffer["uri"] = "../card.bin"
    (tmp_path / "models" / "card.gltf").write_text(json.dumps(doc), encoding="utf-8")
    with pytest.raises(SceneError, match=r"s\.toml: include\.file: ../models/card\.gltf: buffers\[0\]\.uri: "
                                         r"uri '\.\./card\.bin' leaves the glTF file's folder"):
        load_scene(toml)
