"""Every job glTF of the shipped scenes passes the Khronos glTF-Validator (npm gltf-validator) with no error.

The job's glTF is what external and web renderers read (compare.renderers.job.export_gltf); a file the
reference validator rejects would make a renderer's error the suite's. Warnings are listed, and the ones a
job may still carry are named here with why.
"""

from __future__ import annotations

import json

import pytest

from compare.renderers.job import export_gltf
from compare.scene.loader import load_scene
from tests.helpers import CORNELL, ROOT, validate_gltf

SCENES = sorted([*ROOT.glob("scenes/*.toml"), *ROOT.glob("scenes/effects/*.toml"), *ROOT.glob("scenes/stress/*.toml"),
                 *ROOT.glob("scenes/khronos/*.toml")])

#: Warnings a job glTF may carry: a material with KHR_materials_volume that is double-sided (the TOML scenes'
#: default; the volume's thickness is then the file's own statement, kept as written).
ALLOWED_WARNINGS = {"KHR_MATERIALS_VOLUME_DOUBLE_SIDED"}

@pytest.fixture(scope="module")
def shipped_reports(tmp_path_factory) -> dict[str, set[tuple[str, int]]]:
    """Scene → the validator's (code, severity) pairs for its job glTF, every shipped scene."""
    out = tmp_path_factory.mktemp("jobs")
    files = {p: export_gltf(load_scene(p), out / p.parent.name / p.stem / "scene.gltf") for p in SCENES}
    reports = validate_gltf(list(files.values()))
    return {p.stem: {(m["code"], m["severity"]) for m in reports[str(f)]["issues"]["messages"]}
            for p, f in files.items()}


@pytest.mark.npm("gltf-validator")
def test_every_shipped_scene_exports_a_gltf_without_errors(shipped_reports):
    assert len(shipped_reports) >= 20
    errors = {scene: sorted(c for c, sev in codes if sev == 0) for scene, codes in shipped_reports.items()}
    assert not {k: v for k, v in errors.items() if v}, errors


@pytest.mark.npm("gltf-validator")
def test_every_shipped_scene_exports_a_gltf_without_warnings(shipped_reports):
    """Beyond errors: nothing a reader would have to guess, e.g. tangents (MESH_PRIMITIVE_GENERATED_TANGENT_SPACE
    when a normal-mapped primitive has no TANGENT: each renderer would derive its own frame)."""
    warned = {scene: sorted(c for c, sev in codes if sev == 1 and c not in ALLOWED_WARNINGS)
              for scene, codes in shipped_reports.items()}
    assert not {k: v for k, v in warned.items() if v}, warned


@pytest.mark.npm("gltf-validator")
def test_the_validator_sees_a_broken_file(tmp_path):
    """The check can fail: an accessor past its buffer's end is an error the validator reports."""
    gltf = export_gltf(load_scene(CORNELL), tmp_path / "scene.gltf")
    doc = json.loads(gltf.read_text(encoding="utf-8"))
    doc["accessors"][0]["count"] *= 1000
    gltf.write_text(json.dumps(doc), encoding="utf-8")
    (report,) = validate_gltf([gltf]).values()
    assert report["issues"]["numErrors"] >= 1
