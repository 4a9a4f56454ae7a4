"""The published JSON Schemas (compare/schemas/): package data, valid schemas, and every results.json, job.json and
baseline.json the suite writes conforms to them, so that other tools can read those files without reading the code."""

from __future__ import annotations

import copy
import json
import tomllib
from importlib import resources
from pathlib import Path

import jsonschema
import pytest
from referencing import Registry, Resource

from compare.cli.main import main
from compare.report.results import RunSettings
from tests.helpers import CORNELL, ROOT, gate_run

NAMES = ("results", "job", "baseline")


def schemas() -> dict[str, dict]:
    """The schemas as the installed package ships them (importlib.resources, not the checkout's path)."""
    folder = resources.files("compare") / "schemas"
    return {n: json.loads((folder / f"{n}.schema.json").read_text(encoding="utf-8")) for n in NAMES}


def validator(name: str) -> jsonschema.Draft202012Validator:
    found = schemas()
    registry = Registry().with_resources([(s["$id"], Resource.from_contents(s)) for s in found.values()])
    return jsonschema.Draft202012Validator(found[name], registry=registry, format_checker=None)


def validate(name: str, path: Path) -> dict:
    data = json.loads(path.read_text(encoding="utf-8"))
    errors = sorted(validator(name).iter_errors(data), key=lambda e: list(e.absolute_path))
    assert not errors, f"{path} does not conform to {name}.schema.json:\n" + "\n".join(
        f"  {'/'.join(map(str, e.absolute_path))}: {e.message}" for e in errors[:10])
    return data


def test_the_schemas_are_valid_and_ship_with_the_package():
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    assert "schemas/*.json" in pyproject["tool"]["setuptools"]["package-data"]["compare"]
    for name, schema in schemas().items():
        jsonschema.Draft202012Validator.check_schema(schema)
        assert schema["$id"].endswith(f"/{name}.schema.json") and schema["description"]


def test_job_files_conform(tmp_path):
    """job.json of both schemas, for scenes with area lights, punctual lights and an environment."""
    from compare.renderers.job import write_job
    from compare.scene.loader import load_scene

    cases = [("cornell.toml", 1), ("cornell.toml", 2), ("effects/spot_light.toml", 2), ("effects/materials_furnace.toml", 2)]
    seen = set()
    for i, (name, schema) in enumerate(cases):
        scene = load_scene(ROOT / "scenes" / name).with_resolution(16, 12)
        path = write_job(scene, tmp_path / f"job{i}", renderer="mine", unit="frame", checkpoints=[1, 2, 4], seed=3,
                         output_dir=tmp_path / f"job{i}" / "output", cache_dir=tmp_path / "cache", schema=schema)
        job = validate("job", path)
        seen |= {"punctual" if job["scene"].get("punctual") else "", "environment" if job["scene"]["environment"]
                 else "", f"schema{job['schema']}"}
    assert {"punctual", "environment", "schema1", "schema2"} <= seen
    # the schema says something: a schema-1 job with punctual lights, a missing field and a bad camera fail
    bad = json.loads(path.read_text())
    v = validator("job")
    assert v.is_valid(bad)
    assert not v.is_valid({**bad, "schema": 1})
    assert not v.is_valid({k: x for k, x in bad.items() if k != "checkpoints"})
    assert not v.is_valid({**bad, "camera": {**bad["camera"], "width": 0}})


def test_results_and_baselines_conform(tmp_path, gl_ctx):
    """results.json of a run with the reference, the rasterizer and two seeds (noise floor, per-pixel variance,
    per-seed runs), of an external renderer's run, and the baseline made of it."""
    from compare.run.runner import run

    res = run([CORNELL], tmp_path / "r", RunSettings(frames=4, spp=8, sizes=[[32, 24]],
                                                                                seeds=2),
              progress=False, cache_dir=tmp_path / "cache", gl_ctx=gl_ctx, report=False)
    data = validate("results", tmp_path / "r" / "results.json")
    scene = data["scenes"][0]
    assert scene["noise_floor"] and scene["reference"]["variance"]
    assert all(len(r["seed_runs"]) == 2 for r in scene["runs"]) and res.scenes[0].run("progressive").seed_runs
    external = gate_run(tmp_path / "ext")
    validate("results", external)
    for source, folder in ((tmp_path / "r" / "results.json", tmp_path / "bl"), (external, tmp_path / "bl2")):
        assert main(["baseline", "save", str(folder), "--results", str(source)]) == 0
        validate("baseline", folder / "baseline.json")
        validate("results", folder / "results.json")
    # the schema says something: a NaN-free number where a count belongs, a missing run field, a path
    # leaving the baseline folder fail
    v = validator("results")
    bad = copy.deepcopy(data)
    bad["scenes"][0]["runs"][0]["points"][0]["step"] = 0
    assert not v.is_valid(bad)
    bad = copy.deepcopy(data)
    del bad["scenes"][0]["runs"][0]["unit"]
    assert not v.is_valid(bad)
    index = json.loads((tmp_path / "bl" / "baseline.json").read_text())
    index["runs"][0]["mean"] = "../elsewhere.exr"
    assert not validator("baseline").is_valid(index)


def test_measured_results_conform(tmp_path):
    """results.json of `compare measure` (images made elsewhere)."""
    import numpy as np

    from compare.image.exr import write_exr

    folder = tmp_path / "engine"
    for step in (1, 2, 4):
        write_exr(folder / f"step-{step}.exr", np.full((12, 16, 3), 0.3, np.float32))
    (folder / "timings.json").write_text(json.dumps({"setup_seconds": 0.2, "seconds": {"1": 0.1, "2": 0.2, "4": 0.4}}))
    out = tmp_path / "measured"
    assert main(["measure", str(folder), "--scene", str(CORNELL), "--spp", "4", "--quiet",
                 "-o", str(out)]) == 0
    assert validate("results", out / "results.json")["scenes"][0]["runs"][0]["renderer"] == "engine"


@pytest.mark.parametrize("name", NAMES)
def test_each_schema_is_named_in_the_docs(name):
    assert f"compare/schemas/{name}.schema.json" in (ROOT / "docs" / "ci.md").read_text(encoding="utf-8")


# --------------------------------------------------------------------------- validated when read (or written)


GOLDEN = ROOT / "tests" / "data" / "cornell-48x36-golden.json"


def _one_line(exc: BaseException, *parts: str) -> str:
    message = str(exc)
    assert "\n" not in message and all(p in message for p in parts), message
    return message


@pytest.mark.parametrize("edit, field, problem", [
    (lambda d: d["scenes"][0]["runs"][0]["points"][1]["metrics"].update(flip="x"),
     "scenes[0].runs[0].points[1].metrics.flip", 'expected number or null, got "x"'),
    (lambda d: d["scenes"][0]["runs"][0].update(steps=0), "scenes[0].runs[0].steps", "expected an integer >= 1, got 0"),
    (lambda d: d["scenes"][0]["reference"].pop("variant"), "scenes[0].reference", "missing field 'variant'"),
    (lambda d: d["machine"].update(cores=True), "machine.cores", "expected an integer >= 1, got true"),
    (lambda d: d["scenes"][0].update(noise_floor={"method": "independent-full"}), "scenes[0].noise_floor",
     "missing field 'spp'"),
])
def test_a_bad_field_of_results_json_is_one_error_naming_file_and_field(tmp_path, capsys, edit, field, problem):
    from compare.report.results import Results, ResultsError

    data = json.loads(GOLDEN.read_text(encoding="utf-8"))
    edit(data)
    path = tmp_path / "results.json"
    path.write_text(json.dumps(data))
    with pytest.raises(ResultsError) as exc:
        Results.load(path)
    assert _one_line(exc.value, str(path), field, problem) == f"{path}: {field}: {problem}"
    # and the command line says just that
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert err == f"compare: error: {path}: {field}: {problem}\n"


def _baseline_folder(tmp_path: Path, **run) -> Path:
    """A baseline folder whose index has one run (with ``run``'s fields); no images: the index is read first."""
    results = json.loads(GOLDEN.read_text(encoding="utf-8"))
    scene = results["scenes"][0]
    folder = tmp_path / "baseline"
    folder.mkdir(parents=True)
    (folder / "results.json").write_text(json.dumps(results))
    index = {"schema": 1, "kind": "compare-baseline", "created": "2026-01-31T12:00:00Z", "compare_version": "0",
             "results": "results.json", "machine": results["machine"],
             "runs": [{"scene": scene["name"], "size": f"{scene['width']}x{scene['height']}", "scene_id": scene["id"],
                       "renderer": "progressive", "step": 4, "seeds": [0], "images": ["images/seed-0.exr"],
                       "mean": "images/final.exr", "variance": None, "dof": None, "preview": None, **run}]}
    (folder / "baseline.json").write_text(json.dumps(index))
    return folder


@pytest.mark.parametrize("run, field, problem", [
    ({"step": "4"}, "runs[0].step", 'expected an integer >= 1, got "4"'),
    ({"images": ["../../elsewhere.exr"]}, "runs[0].images[0]",
     'expected a path relative to the baseline folder, never leaving it, got "../../elsewhere.exr"'),
    ({"dof": 0}, "runs[0].dof", "expected an integer >= 1 or null, got 0"),
    ({"seeds": []}, "runs[0].seeds", "expected at least 1 item(s), got 0"),
])
def test_a_bad_field_of_baseline_json_is_one_error_naming_file_and_field(tmp_path, run, field, problem):
    from compare.report.baseline import Baseline, BaselineError

    folder = _baseline_folder(tmp_path, **run)
    with pytest.raises(BaselineError) as exc:
        Baseline.load(folder)
    assert _one_line(exc.value) == f"{folder / 'baseline.json'}: {field}: {problem}"


def test_what_the_baseline_schema_cannot_say_is_still_checked(tmp_path):
    """One image per seed (two lengths) and files that are there: checked after the schema."""
    from compare.report.baseline import Baseline, BaselineError

    folder = _baseline_folder(tmp_path, seeds=[0, 1])
    with pytest.raises(BaselineError, match=r"runs\[0\]\.images: expected one image per seed \(2\), got 1"):
        Baseline.load(folder)
    folder = _baseline_folder(tmp_path / "b")
    with pytest.raises(BaselineError, match=r"baseline\.json: runs\[0\]\.mean: .*final\.exr is missing"):
        Baseline.load(folder)


def test_a_bad_field_of_a_job_is_one_error_naming_file_and_field(tmp_path):
    """The suite writes job files, never reads them: validated before the renderer gets one."""
    from compare.renderers.base import RendererError
    from compare.renderers.job import write_job
    from compare.scene.loader import load_scene

    scene = load_scene(CORNELL).with_resolution(16, 12)
    with pytest.raises(RendererError) as exc:
        write_job(scene, tmp_path / "job", renderer="mine", unit="frame", checkpoints=[1, 0], seed=3,
                  output_dir=tmp_path / "out", cache_dir=tmp_path / "cache")
    _one_line(exc.value, f"{tmp_path / 'job' / 'job.json'}: checkpoints[1]: ", "job.schema.json")
    assert not (tmp_path / "job" / "job.json").exists()
