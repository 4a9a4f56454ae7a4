"""A run of a render-fidelity scenario file: what results.json records of it (every scenario, those left out
with their reason), and the report's scenario table (its behaviour in a browser: tests/test_browser.py)."""

from __future__ import annotations

import json

import pytest

from compare.cli.main import main
from compare.report.results import Results
from tests.helpers import CORNELL, FIDELITY_RENDERERS, FIDELITY_SCENARIOS, fidelity_report, synthetic_report

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
