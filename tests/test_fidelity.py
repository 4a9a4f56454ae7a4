"""A run of a render-fidelity scenario file: what results.json records of it (every scenario, those left out
with their reason), the report's scenario table (its behaviour in a browser: tests/test_browser.py), and the
scenario set the suite ships, ``scenes/fidelity/config.json``: model-viewer's scenarios of the Khronos models
of ``scenes/khronos/``, every file there, each rendering with the rasterizer."""

from __future__ import annotations

import json
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from compare.cli.main import main
from compare.report.results import Results
from compare.scene.framing import bounds_center, fit_radius
from compare.scene.loader import load_scene
from compare.scene.scenarios import DEFAULTS, load_scenarios
from tests.helpers import (CORNELL, FIDELITY_RENDERERS, FIDELITY_SCENARIOS, ROOT, fidelity_report,
                           synthetic_report)

SHIPPED = ROOT / "scenes" / "fidelity" / "config.json"
KHRONOS = ROOT / "scenes" / "khronos"
PUBLISHED = ROOT / "tests" / "data" / "model-viewer" / "config.json"
#: The environment of every shipped scenario: Blender's studio light "interior" (Poly Haven's hotel_room, CC0).
LIGHTING = ROOT / "scenes" / "fidelity" / "env" / "interior.exr"


# ----------------------------------------------------------------------------- results.json and the report


@pytest.fixture(scope="module")
def fidelity_run(tmp_path_factory):
    return fidelity_report(tmp_path_factory.mktemp("fidelity"))


def test_a_scenario_run_records_every_scenario_and_why_some_were_not_rendered(fidelity_run):
    res = Results.load(fidelity_run / "results.json")  # the schema accepts what the run wrote
    record = res.scenarios
    assert record is not None and record.file.endswith("config.json")
    assert [s.name for s in record.scenarios] == [s["name"] for s in FIDELITY_SCENARIOS]
    front, side, lost, ldr = record.scenarios
    assert front.unavailable is None and side.unavailable is None
    assert lost.unavailable == "model file 'models/gone.glb' not found" and lost.scenes == []
    assert ldr.unavailable == "lighting 'env/sky.jpg' is not an .exr or .hdr file"
    assert [s.name for s in record.left_out] == ["lost", "ldr"]
    assert side.exclude == ["blender-cycles", "stellar"] and side.excluded == ["cycles"]  # the file's names mapped
    assert (lost.model, ldr.lighting) == ("models/gone.glb", "env/sky.jpg")  # as the file writes them
    # each scenario's scenes are the run's scenes of its name
    by_id = {s.id: s for s in res.scenes}
    assert [by_id[i].name for i in front.scenes] == ["front"] and [by_id[i].name for i in side.scenes] == ["side"]
    assert [r.renderer for r in by_id[side.scenes[0]].runs] == ["progressive", "progressive:paper"]
    assert [r.renderer for r in by_id[front.scenes[0]].runs] == list(FIDELITY_RENDERERS)


def test_the_report_has_the_scenario_table(fidelity_run, tmp_path):
    html = (fidelity_run / "index.html").read_text(encoding="utf-8")
    assert '<section id="fidelity">' in html and '<a href="#fidelity">Scenarios</a>' in html
    table = html[html.index('<section id="fidelity">'):html.index('<section id="table1">')]
    assert table.count("<tr data-order=") == len(FIDELITY_SCENARIOS)
    assert "not rendered: model file &#39;models/gone.glb&#39; not found" in table
    assert "excluded by the scenario (exclude: blender-cycles)" in table
    assert "<script" not in table  # the sorting is report.js's (the page allows no inline script)
    # rebuilt from results.json elsewhere, the report keeps it
    assert main(["report", str(fidelity_run / "results.json"), "-o", str(tmp_path / "copy")]) == 0
    copy = (tmp_path / "copy" / "index.html").read_text(encoding="utf-8")
    assert copy.count("<tr data-order=") == len(FIDELITY_SCENARIOS)


def test_a_failed_unit_and_a_failed_ground_truth_say_so(fidelity_run):
    from compare.report.html import _fidelity

    res = Results.load(fidelity_run / "results.json")
    front, side = res.scenes
    front.runs = [r for r in front.runs if r.renderer != "cycles"]
    res.scenes = [front]  # a ground truth that fails leaves its scene out of the results
    res.failures = [{"scene": front.id, "renderer": "cycles", "message": "it broke"},
                    {"scene": side.id, "renderer": "mitsuba", "message": "out of memory"}]
    rows = {r["name"]: r for r in _fidelity(res)["rows"]}
    k = FIDELITY_RENDERERS.index("cycles")
    assert rows["front"]["cells"][k] == {"state": "failed", "label": rows["front"]["cells"][k]["label"],
                                         "text": "failed: it broke"}
    assert rows["side"]["status"] == "not measured: the ground truth (mitsuba) failed: out of memory"
    assert rows["lost"]["status"].startswith("not rendered: model file")


def test_a_run_of_scene_files_has_no_scenario_table(tmp_path):
    res = synthetic_report(tmp_path / "out", [CORNELL], renderers=("progressive",))
    assert res.scenarios is None
    assert "scenarios" not in json.loads((tmp_path / "out" / "results.json").read_text(encoding="utf-8"))
    assert 'id="fidelity"' not in (tmp_path / "out" / "index.html").read_text(encoding="utf-8")


# ----------------------------------------------------------------------------- the shipped scenario set


def _load(path: Path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the renderSkybox note
        return load_scenarios(path)


def _published() -> dict[str, dict]:
    """model-viewer's published scenarios by model name (glTF-Sample-Models/2.0/<Name>/...)."""
    out = {}
    for raw in json.loads(PUBLISHED.read_text(encoding="utf-8"))["scenarios"]:
        match = re.search(r"/glTF-Sample-Models/2\.0/([^/]+)/", raw["model"])
        if match:
            out[match.group(1)] = raw
    return out


def test_the_shipped_set_is_every_khronos_model_framed_as_model_viewer_frames_it():
    """One scenario per model of scenes/khronos/, its files there, lit by the shipped environment; where
    model-viewer's published file has a scenario of the model, its camera, target and exclude; elsewhere
    model-viewer's default angles and field of view about the suite's "auto" framing (the bounding sphere fills
    the view), as scenes/khronos/<Model>.toml frames it. Images 64 pixels high at the scenario's aspect ratio."""
    scenarios = _load(SHIPPED)
    models = sorted(p.name for p in KHRONOS.iterdir() if p.is_dir())
    assert sorted(s.name.removeprefix("khronos-") for s in scenarios) == models
    published = _published()
    for sc in scenarios:
        name = sc.name.removeprefix("khronos-")
        assert sc.unavailable() is None, sc.name
        assert sc.model.parent == (KHRONOS / name).resolve() and sc.model.is_file()
        assert sc.lighting == LIGHTING.resolve() and sc.lighting_readable
        assert sc.height == 64 and not sc.render_skybox
        raw = published.get(name)
        if raw is not None:
            dims = {**DEFAULTS["dimensions"], **raw.get("dimensions", {})}
            assert sc.width == round(64 * dims["width"] / dims["height"]), sc.name
            assert sc.orbit == tuple(float({**DEFAULTS["orbit"], **raw.get("orbit", {})}[k])
                                     for k in ("theta", "phi", "radius")), sc.name
            assert sc.target == tuple(float({**DEFAULTS["target"], **raw.get("target", {})}[k]) for k in "xyz")
            assert sc.vertical_fov == raw.get("verticalFoV", DEFAULTS["verticalFoV"])
            assert list(sc.exclude) == raw.get("exclude", []), sc.name
            continue
        # no published scenario: model-viewer's defaults, framed as the suite's scene of the model
        assert sc.width == 64 and sc.orbit[:2] == (0.0, 90.0) and sc.vertical_fov == 45.0 and sc.exclude == ()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            scene = load_scene(KHRONOS / f"{name}.toml")
        lo, hi = scene.bounds()
        np.testing.assert_allclose(sc.target, bounds_center(lo, hi), atol=1e-3 * np.linalg.norm(hi - lo))
        assert sc.orbit[2] == pytest.approx(fit_radius(lo, hi, bounds_center(lo, hi), 45.0, 1.0), rel=1e-3)


@pytest.mark.gl
@pytest.mark.npm("mikktspace")  # NormalTangentTest's and TextureTransformMultiTest's normal maps have no TANGENT
def test_the_shipped_set_renders_with_the_rasterizer(gl_ctx):
    """Every scenario of the shipped set, as ``compare run --scenarios`` makes its scene, rendered by the
    progressive rasterizer at 16 pixels high, 2 frames: finite, lit by the environment."""
    from compare.renderers import RenderContext
    from compare.renderers.registry import Registry
    from compare.report.results import RunSettings

    renderer = Registry().get("progressive")
    with RenderContext(RunSettings(frames=2)) as context, warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the notes of reading the models
        context.provide("gl", gl_ctx)
        for sc in _load(SHIPPED):
            scene = sc.scene()
            scene = scene.with_resolution(max(1, round(16 * sc.width / sc.height)), 16)
            given, _ = renderer.prepare(scene)
            image = renderer.render(given, steps=2, checkpoints=[2], seed=0, context=context).checkpoints[-1].image
            assert image.shape == (16, scene.camera.resolution[0], 3), sc.name
            assert np.isfinite(image).all() and image.mean() > 0.01, sc.name
