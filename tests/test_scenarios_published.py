"""model-viewer's render-fidelity ``config.json`` as published (tests/data/model-viewer/config.json, an
unmodified copy; THIRD_PARTY.md names its commit): every scenario read with model-viewer's defaults and
camera, its renderer names mapped, its missing files one error (``compare run``) or a listing (``compare
inspect``), and, with the Khronos models the suite ships placed where its paths point, the scenarios whose
files are there rendered while the others are named as left out."""

from __future__ import annotations

import json
import math
import re
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

from compare.cli.main import main
from compare.image.exr import read_exr
from compare.image.hdr import write_hdr
from compare.renderers.registry import Registry
from compare.scene.scenarios import DEFAULTS, RENDERER_NAMES, load_scenarios
from compare.util.errors import SceneError

ROOT = Path(__file__).resolve().parent.parent
PUBLISHED = ROOT / "tests" / "data" / "model-viewer" / "config.json"
KHRONOS = ROOT / "scenes" / "khronos"
#: Where the file lives in model-viewer's tree: its paths lead three folders up, to shared-assets/.
CONFIG_DIR = ("packages", "render-fidelity-tools", "test")
#: packages/render-fidelity-tools/src/config-reader.ts, defaultScenario (what a scenario leaves out).
CONFIG_READER_DEFAULTS = {
    "lighting": "../../../shared-assets/environments/lightroom_14b.hdr",
    "dimensions": {"width": 768, "height": 768},
    "target": {"x": 0, "y": 0, "z": 0},
    "orbit": {"theta": 0, "phi": 90, "radius": 1},
    "verticalFoV": 45,
    "renderSkybox": False,
}


def _doc() -> dict:
    return json.loads(PUBLISHED.read_text(encoding="utf-8"))


def _load(path: Path = PUBLISHED):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the phi notes
        return load_scenarios(path)


def _copy_into_tree(root: Path) -> Path:
    """The published file, unmodified, at its place in a model-viewer tree under ``root``."""
    folder = root.joinpath(*CONFIG_DIR)
    folder.mkdir(parents=True)
    return Path(shutil.copyfile(PUBLISHED, folder / "config.json"))


def test_the_file_is_the_published_one():
    """The copy is byte for byte the published text (its length and its last scenario as read at that commit);
    a reformatted or edited copy fails here."""
    text = PUBLISHED.read_bytes().decode("utf-8")
    assert len(text) == 27206 and not text.endswith("\n")
    doc = _doc()
    assert [r["name"] for r in doc["renderers"]] == ["model-viewer", "filament", "babylon", "gltf-sample-viewer",
                                                    "dspbr-pt", "stellar", "rhodonite"]
    assert len(doc["scenarios"]) == 79 and doc["scenarios"][-1]["name"] == "DirectionalLightTest"


def test_the_suites_defaults_are_the_config_readers():
    assert DEFAULTS == CONFIG_READER_DEFAULTS


def test_every_scenario_is_read_as_model_viewer_defines_it():
    """Every scenario, in order, each field the file's value or config-reader.ts's default (nested objects key
    by key); paths resolved against the file's folder, even where they leave it."""
    doc = _doc()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scenarios = load_scenarios(PUBLISHED)
    assert [s.name for s in scenarios] == [raw["name"] for raw in doc["scenarios"]]
    for k, (sc, raw) in enumerate(zip(scenarios, doc["scenarios"])):
        merged = {key: {**CONFIG_READER_DEFAULTS[key], **raw.get(key, {})}
                  for key in ("dimensions", "target", "orbit")}
        assert sc.index == k and sc.source == PUBLISHED
        assert (sc.width, sc.height) == (merged["dimensions"]["width"], merged["dimensions"]["height"]), sc.name
        assert sc.target == tuple(merged["target"][c] for c in "xyz"), sc.name
        assert sc.orbit == tuple(merged["orbit"][c] for c in ("theta", "phi", "radius")), sc.name
        assert sc.vertical_fov == raw.get("verticalFoV", 45)
        assert sc.render_skybox is raw.get("renderSkybox", False)
        assert sc.exclude == tuple(raw.get("exclude", ()))
        assert sc.model == (PUBLISHED.parent / raw["model"]).resolve()
        assert sc.lighting == (PUBLISHED.parent / raw.get("lighting", CONFIG_READER_DEFAULTS["lighting"])).resolve()
        assert sc.given == (raw["model"], raw.get("lighting", CONFIG_READER_DEFAULTS["lighting"]))
    notes = [str(w.message) for w in caught]
    # renderSkybox false is reproduced (the scene's background = false): no note says otherwise
    assert not any("renderSkybox" in n for n in notes), notes
    assert any("scenarios[46] (khronos-RecursiveSkeletons): orbit.phi 5°" in n for n in notes), notes


def test_some_scenarios_field_by_field():
    """Values read off the file by hand: defaults filled in where a field or a key is absent."""
    by = {s.name: s for s in _load()}
    dragon = by["khronos-DragonAttenuation"]  # only orbit.radius given
    assert (dragon.width, dragon.height, dragon.target, dragon.orbit) == (768, 768, (0.0, 0.0, 0.0), (0.0, 90.0, 5.0))
    assert dragon.vertical_fov == 45.0 and dragon.render_skybox is False and dragon.exclude == ()
    assert dragon.given[1] == "../../../shared-assets/environments/lightroom_14b.hdr"
    dish = by["khronos-IridescentDishWithOlives"]
    assert (dish.width, dish.height) == (768, 570) and dish.target == (0.0, 0.11, 0.0)
    assert dish.orbit == (-70.0, 90.0, 0.47) and dish.render_skybox is True
    assert dish.lighting.name == "spruit_sunrise_1k_HDR.hdr" and dish.exclude == ("babylon",)
    car = by["khronos-ToyCar"]
    assert (car.width, car.height, car.orbit, car.target) == (1200, 500, (-35.0, 75.0, 0.037), (0.0, 0.001, 0.0))
    assert by["khronos-AttenuationTest"].orbit == (0.0, 90.0, 22.0)  # written 22.00
    assert (by["khronos-AttenuationTest"].width, by["khronos-AttenuationTest"].height) == (1024, 768)
    gearbox = by["khronos-GearboxAssy"]
    assert gearbox.target == (159.0, 17.0, 3.2) and (gearbox.width, gearbox.height) == (1024, 512)
    # an orbit off the axes: SmoothControls.moveCamera's spherical position about the target
    buggy = by["khronos-Buggy"]
    t, p, r = math.radians(-60), math.radians(60), 286
    direction = np.array([math.sin(p) * math.sin(t), math.cos(p), math.sin(p) * math.cos(t)])
    cam = buggy.camera()
    np.testing.assert_allclose(cam.position, np.array([24, 50, 16]) + r * direction, atol=1e-9)
    np.testing.assert_allclose(cam.forward, -direction, atol=1e-12)
    assert cam.fov == 45.0


@pytest.mark.parametrize("name, target, forward", [
    ("khronos-Sponza", (0, 1, 0), (-1, 0, 0)),  # theta 90: looking along -X
    ("khronos-MetalRoughSpheresNoTextures", (0.003, 0.003, 0.01), (0, 0, -1)),  # theta 0: along -Z
])
def test_radius_zero_puts_the_camera_on_the_target_looking_outward(name, target, forward):
    sc = {s.name: s for s in _load()}[name]
    assert sc.orbit[2] == 0.0
    cam = sc.camera()
    np.testing.assert_allclose(cam.position, target, atol=1e-12)
    np.testing.assert_allclose(cam.forward, forward, atol=1e-12)
    np.testing.assert_allclose(cam.up, (0, 1, 0), atol=1e-12)


def test_excluded_renderer_names_map_to_the_suites():
    """Every name of every ``exclude`` becomes the suite's renderer of that engine where it has one
    (RENDERER_NAMES), and is dropped where it has none (dspbr-pt, stellar, rhodonite)."""
    known = Registry().names()
    by = {s.name: s for s in _load()}
    assert by["khronos-Sponza"].suite_excluded(known) == ("model-viewer",)
    assert by["khronos-IridescentDishWithOlives"].suite_excluded(known) == ("babylon",)
    assert by["khronos-MetalRoughSpheres-LDR"].suite_excluded(known) == ("babylon", "gltf-sample-viewer")
    assert by["khronos-ToyCar"].suite_excluded(known) == ()  # dspbr-pt, rhodonite: none here
    names = {n for s in by.values() for n in s.exclude}
    assert names == {"model-viewer", "babylon", "gltf-sample-viewer", "dspbr-pt", "stellar", "rhodonite"}
    for s in by.values():
        assert s.suite_excluded(known) == tuple(RENDERER_NAMES[n] for n in s.exclude if n in RENDERER_NAMES)


def test_an_ldr_lighting_is_that_scenarios_problem_not_the_files():
    """khronos-MetalRoughSpheres-LDR is lit by a JPEG: the file reads, and that scenario alone says why it
    cannot be rendered here, naming the field and the path."""
    sc = {s.name: s for s in _load()}["khronos-MetalRoughSpheres-LDR"]
    assert sc.unavailable() == ("lighting '../../../shared-assets/environments/spruit_sunrise_1k_LDR.jpg' "
                                "is not an .exr or .hdr file")
    with pytest.raises(SceneError, match=r"scenarios\[24\] \(khronos-MetalRoughSpheres-LDR\): lighting: "
                                         r"'\.\./\.\./\.\./shared-assets/environments/spruit_sunrise_1k_LDR\.jpg': "
                                         r"the suite reads environments from \.exr or \.hdr files"):
        sc.scene()


def test_run_without_the_files_is_one_error(tmp_path, capsys):
    """None of the published paths leads to a file here: one line, naming the first scenario, its field and the
    path as written and as looked for, and how many others lack theirs; nothing written."""
    config = _copy_into_tree(tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        status = main(["run", "--scenarios", str(config), "--renderers", "progressive", "--size", "32x24",
                       "-o", str(tmp_path / "never"), "--quiet"])
    err = capsys.readouterr().err
    model = "../../../shared-assets/models/glTF-Sample-Models/2.0/DragonAttenuation/glTF/DragonAttenuation.gltf"
    assert status == 2 and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert err.strip() == (f"compare: error: {config}: scenarios[0] (khronos-DragonAttenuation): model: file "
                           f"'{model}' not found (looked for {(config.parent / model).resolve()}); 78 other "
                           f"scenario(s) cannot be rendered here either (`compare inspect {config}` lists them)")
    assert not (tmp_path / "never").exists()
    # --skip-unavailable with nothing left: the same one error, nothing rendered
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["run", "--scenarios", str(config), "--renderers", "progressive", "--skip-unavailable",
                     "-o", str(tmp_path / "never"), "--quiet"]) == 2
    assert "78 other scenario(s) cannot be rendered here either" in capsys.readouterr().err
    assert not (tmp_path / "never").exists()


@pytest.mark.parametrize("how", [["inspect", "--scenarios"], ["inspect"]], ids=["--scenarios", "positional"])
def test_inspect_lists_every_scenario_and_what_is_missing(tmp_path, capsys, how):
    config = _copy_into_tree(tmp_path)
    assert main([*how, str(config)]) == 0
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    assert out.startswith(f"{config}: 79 scenario(s)\n")
    assert out.count("  (not found)") == 79 + 79  # every model and every lighting
    assert re.search(r"spruit_sunrise_1k_LDR\.jpg  \(not found\) \(not \.exr or \.hdr: the suite cannot light", out)
    assert "  unavailable  none of the 79 scenario(s) can be rendered here" in out
    assert "theta 90°, phi 90°, radius 0 m about [0, 1, 0]: at [0, 1, 0] looking along [-1, 0, 0]" in out
    assert main([*how, str(config), "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["scenarios"]
    assert len(rows) == 79 and all(r["unavailable"] and not r["model_found"] for r in rows)
    assert [r["name"] for r in rows if not r["lighting_readable"]] == ["khronos-MetalRoughSpheres-LDR"]


def test_inspect_wants_one_file(capsys):
    assert main(["inspect"]) == 2
    assert capsys.readouterr().err.strip() == ("compare: error: give one scene file (SCENE) or one scenario file "
                                               "(--scenarios CONFIG)")
    assert main(["inspect", "scenes/cornell.toml", "--scenarios", str(PUBLISHED)]) == 2


def test_skip_unavailable_needs_scenarios(capsys):
    assert main(["run", "--scenes", "scenes/cornell.toml", "--skip-unavailable"]) == 2
    assert "--skip-unavailable: applies to the scenarios of --scenarios only" in capsys.readouterr().err


# ----------------------------------------------------------------------------- with the files placed

#: A model path of the published file: glTF-Sample-Models/2.0/<Name>/glTF[-Binary]/<Name>.gltf|glb.
_KHRONOS_PATH = re.compile(r".*/glTF-Sample-Models/2\.0/([^/]+)/glTF(?:-Binary)?/\1\.(gltf|glb)")


def _place_assets(config: Path, names: set[str] | None = None) -> list[str]:
    """Put the Khronos models the suite ships (scenes/khronos/) where the scenarios' paths point, in the same
    form (.glb, or .gltf with its folder); ``names``: only these scenarios. The default lighting,
    lightroom_14b.hdr, becomes the suite's own sky (scenes/stress/env/sun_sky.exr) written as Radiance HDR.
    Returns the names of the scenarios whose files are now all there."""
    placed = []
    for raw in json.loads(config.read_text(encoding="utf-8"))["scenarios"]:
        match = _KHRONOS_PATH.fullmatch(raw["model"])
        if match is None or "lighting" in raw or (names is not None and raw["name"] not in names):
            continue
        name, ext = match.groups()
        source = KHRONOS / name / f"{name}.{ext}"
        if not source.is_file():
            continue
        target = (config.parent / raw["model"]).resolve()
        if ext == "glb":
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(source, target)
        else:  # the .gltf with its buffers and images
            shutil.copytree(source.parent, target.parent)
        placed.append(raw["name"])
    sky, _ = read_exr(ROOT / "scenes" / "stress" / "env" / "sun_sky.exr")
    lighting = (config.parent / CONFIG_READER_DEFAULTS["lighting"]).resolve()
    lighting.parent.mkdir(parents=True, exist_ok=True)
    write_hdr(lighting, sky)
    return placed


def _run_present(tmp_path: Path, names: set[str] | None, renderers: str) -> tuple[dict, list[str], list[str]]:
    """``compare run --skip-unavailable`` on the published file with the files of ``names`` placed; returns
    results.json, the scenarios placed and the note that names those left out."""
    config = _copy_into_tree(tmp_path)
    placed = _place_assets(config, names)
    out = tmp_path / "out"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        status = main(["run", "--scenarios", str(config), "--skip-unavailable", "--renderers", renderers,
                       "--size", "32x24", "--frames", "2", "--spp", "2", "--no-likeness", "--no-report",
                       "--executor", "serial", "-o", str(out), "--quiet"])
    assert status == 0
    notes = [str(w.message) for w in caught if "left out (--skip-unavailable" in str(w.message)]
    return json.loads((out / "results.json").read_text(encoding="utf-8")), placed, notes


def _check_rendered(res: dict, placed: list[str], notes: list[str], out: Path) -> None:
    assert [s["name"] for s in res["scenes"]] == placed  # in the file's order, each at the size asked for
    assert not res.get("failures")
    for scene in res["scenes"]:
        assert (scene["width"], scene["height"]) == (32, 24)
        assert [r["renderer"] for r in scene["runs"]] == ["mitsuba", "progressive"]
        for run in scene["runs"]:
            image, _ = read_exr(out / run["image"])
            assert image.shape == (24, 32, 3) and np.isfinite(image).all() and image.mean() > 0, scene["name"]
    (note,) = notes
    left = [line.removeprefix("  - ").partition(":")[0] for line in note.splitlines()[1:]]
    assert note.splitlines()[0].endswith(f"{79 - len(placed)} of 79 scenario(s) left out (--skip-unavailable; "
                                         f"paths relative to {(out.parent.joinpath(*CONFIG_DIR)).resolve()}):")
    assert len(left) == 79 - len(placed) and not set(left) & set(placed)
    assert "  - khronos-DragonAttenuation: model file '../../../shared-assets/models/glTF-Sample-Models/2.0/" \
           "DragonAttenuation/glTF/DragonAttenuation.gltf' not found" in note.splitlines()
    assert ("  - khronos-MetalRoughSpheres-LDR: lighting '../../../shared-assets/environments/"
            "spruit_sunrise_1k_LDR.jpg' is not an .exr or .hdr file") in note.splitlines()
    # results.json records them too, each with its reason (the report's scenario table shows them)
    record = {s["name"]: s for s in res["scenarios"]["scenarios"]}
    assert len(record) == 79 and [n for n, s in record.items() if s["unavailable"] is None] == placed
    assert record["khronos-DragonAttenuation"]["unavailable"] == (
        "model file '../../../shared-assets/models/glTF-Sample-Models/2.0/DragonAttenuation/glTF/"
        "DragonAttenuation.gltf' not found")
    assert record["khronos-MetalRoughSpheres-LDR"]["unavailable"].endswith("is not an .exr or .hdr file")
    assert sorted(i for n in placed for i in record[n]["scenes"]) == sorted(s["id"] for s in res["scenes"])


#: Three of the scenarios whose models the suite ships, in the three forms of a path: a .glb, a .gltf with its
#: buffer and maps beside it, a .glb with morph targets.
FEW = {"khronos-TextureCoordinateTest", "khronos-TwoSidedPlane", "khronos-MorphPrimitivesTest"}


@pytest.mark.gl
def test_the_scenarios_whose_files_are_there_render(tmp_path):
    res, placed, notes = _run_present(tmp_path, FEW, "mitsuba,progressive")
    assert set(placed) == FEW
    _check_rendered(res, placed, notes, tmp_path / "out")


@pytest.mark.slow
@pytest.mark.gl
@pytest.mark.npm("mikktspace")  # TextureTransformMultiTest's normal map has no TANGENT
def test_every_scenario_whose_files_the_suite_ships_renders(tmp_path):
    res, placed, notes = _run_present(tmp_path, None, "mitsuba,progressive")
    assert len(placed) >= 8 and FEW <= set(placed)
    _check_rendered(res, placed, notes, tmp_path / "out")
