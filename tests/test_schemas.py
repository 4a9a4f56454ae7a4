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

ROOT = Path(__file__).resolve().parent.parent
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
    from tests.test_gate import render

    res = run([ROOT / "scenes" / "cornell.toml"], tmp_path / "r", RunSettings(frames=4, spp=8, sizes=[[32, 24]],
                                                                                seeds=2),
              progress=False, cache_dir=tmp_path / "cache", gl_ctx=gl_ctx, report=False)
    data = validate("results", tmp_path / "r" / "results.json")
    scene = data["scenes"][0]
    assert scene["noise_floor"] and scene["reference"]["variance"]
    assert all(len(r["seed_runs"]) == 2 for r in scene["runs"]) and res.scenes[0].run("progressive").seed_runs
    external = render(tmp_path / "ext")
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
    assert main(["measure", str(folder), "--scene", str(ROOT / "scenes" / "cornell.toml"), "--spp", "4", "--quiet",
                 "-o", str(out)]) == 0
    assert validate("results", out / "results.json")["scenes"][0]["runs"][0]["renderer"] == "engine"


@pytest.mark.parametrize("name", NAMES)
def test_each_schema_is_named_in_the_docs(name):
    assert f"compare/schemas/{name}.schema.json" in (ROOT / "docs" / "ci.md").read_text(encoding="utf-8")
