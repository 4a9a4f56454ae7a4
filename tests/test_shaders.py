"""The rasterizer's shader plumbing: the one table of texture units, the constants GLSL takes from
Python as defines, and the one G-buffer preamble (compare.progressive.gl)."""

from __future__ import annotations

import re
import types
from pathlib import Path

import pytest

from compare.progressive.gl import shaders, units
from compare.progressive.gl.units import GBUFFER, LAYERS, MAPS, PROGRAM_UNITS, Units, check_units
from tests.helpers import ROOT

PROGRESSIVE = ROOT / "compare" / "progressive"


def _glsl_files() -> dict[str, Path]:
    return {p.name: p for p in PROGRESSIVE.rglob("*.glsl")}


def _programs() -> set[str]:
    """The .glsl files that are programs (both stages in one file), not includes."""
    return {name for name, p in _glsl_files().items() if "defined VERTEX_SHADER" in p.read_text(encoding="utf-8")}


# -- texture units ----------------------------------------------------------------------------

def test_no_two_ranges_of_a_program_overlap():
    check_units()
    for program, row in PROGRAM_UNITS.items():
        taken: dict[int, str] = {}
        for role, r in row.items():
            for unit in r:
                assert unit not in taken, f"{program}: unit {unit} is both {taken[unit]}'s and {role}'s"
                taken[unit] = role


@pytest.mark.parametrize("row, match", [
    ({"a": Units(0, 3), "b": Units(2)}, r"p\.glsl: a \(units 0 … 2\) and b \(units 2\) overlap"),
    ({"gbuffer": Units(1, 4)}, r"gbuffer takes units 1 … 4; every program has it at 0 … 3"),
    ({"a": Units(units.MAX_UNITS - 1, 2)}, "beyond the 48"),
])
def test_check_units_names_what_collides(row, match):
    with pytest.raises(ValueError, match=match):
        check_units({"p.glsl": row})


def test_shared_groups_keep_their_place_and_units_range_checks():
    for row in PROGRAM_UNITS.values():
        for name, r in (("gbuffer", GBUFFER), ("maps", MAPS), ("layers", LAYERS)):
            assert row.get(name, r) == r
    assert list(Units(5, 3)) == [5, 6, 7] and Units(5, 3)[2] == 7 and str(Units(5, 3)) == "5 … 7"
    with pytest.raises(IndexError, match="texture unit 3 of a range of 3"):
        Units(5, 3)[3]
    with pytest.raises(KeyError, match="nosuch.glsl: no row"):
        units.units_of("nosuch.glsl")


def test_every_program_with_samplers_has_a_row_and_every_row_is_a_program():
    programs = _programs()
    assert set(PROGRAM_UNITS) <= programs, sorted(set(PROGRAM_UNITS) - programs)
    for name in programs:
        text = shaders.shader_source(name, "FRAGMENT_SHADER", {"BATCH": 1})
        if re.search(r"^\s*uniform\s+sampler", text, flags=re.M):
            assert name in PROGRAM_UNITS, f"{name} samples textures but has no row in gl/units.py"


def test_no_pass_picks_a_texture_unit_by_number():
    """Units come from the table: no literal unit in a ``use(location=…)`` or ``use(…)``."""
    literal = re.compile(r"\.use\(\s*(location\s*=\s*)?\d|first_unit")
    found = [f"{p.relative_to(ROOT)}:{i}: {line.strip()}"
             for p in PROGRESSIVE.rglob("*.py") for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
             if literal.search(line)]
    assert not found, "\n".join(found)


def test_punctual_glsl_shades_as_many_lights_as_a_batch_has_units():
    from compare.progressive.lights.punctual import MAX_BATCH

    text = _glsl_files()["punctual.glsl"].read_text(encoding="utf-8")
    shaded = {int(k) for k in re.findall(r"light\((\d+), u_pshadow\[\1\]\)", text)}
    assert shaded == set(range(MAX_BATCH))


def test_passes_bind_every_sampler_inside_its_programs_row(gl_ctx, monkeypatch):
    """Render scenes that use every kind of pass and record each binding: each sampler's unit lies in
    its program's row, it keeps that unit, and no two samplers of one program share one."""
    from compare.progressive.rasterizer import render_progressive
    from compare.scene.loader import load_scene

    seen: dict[str, dict[str, set[int]]] = {}
    real = units.set_uniform

    def record(program, name, value):
        where = seen.setdefault(program.extra, {})
        values = [value] if isinstance(value, int) else list(memoryview(value).cast("i"))
        where.setdefault(name, set()).update(values)
        real(program, name, value)

    monkeypatch.setattr(units, "set_uniform", record)
    scenes = ROOT / "scenes"
    for path, options in ((scenes / "stress" / "textures.toml", {"area_model": "ltc", "indirect": "probes"}),
                          (scenes / "stress" / "textures.toml", {"shadow_filter": "vsm", "samples_per_light": 6}),
                          (scenes / "effects" / "materials_blend.toml", {"env_occlusion": "shadows"}),
                          (scenes / "effects" / "cornell_point.toml", {"first_frame_scale": 0.5, "indirect": "probes"})):
        scene = load_scene(path).with_resolution(12, 9)
        render_progressive(scene, frames=3, ctx=gl_ctx, **options)
    for program, samplers in seen.items():
        row = PROGRAM_UNITS[program]
        allowed = {u for r in row.values() for u in r}
        for name, got in samplers.items():
            assert got <= allowed, f"{program}: {name} at {sorted(got)}, outside its row"
            assert len(got) == 1 or name == "u_pshadow", f"{program}: {name} moves between units {sorted(got)}"
        flat = [(u, name) for name, got in samplers.items() for u in got]
        assert len({u for u, _ in flat}) == len(flat), f"{program}: two samplers on one unit: {sorted(flat)}"
    must = {"accumulate.glsl", "compose.glsl", "direct.glsl", "ltc_light.glsl", "ltc_compose.glsl",
            "env_occlusion.glsl", "env_shadows.glsl", "indirect.glsl", "probes_direct.glsl", "probes_punctual.glsl",
            "probes_shade.glsl",
            "probes_gbuffer.glsl", "gbuffer.glsl", "first_frame.glsl", "blend_fold.glsl", "punctual.glsl",
            "vsm_blur.glsl", "shadow.glsl", "depth_only.glsl"}
    assert must <= set(seen), sorted(must - set(seen))


# -- constants shared with Python: defines, not copies --------------------------------------------

#: Constants the GLSL takes from Python, and where each is defined.
SHARED = {"MAX_ENV_SAMPLES": "env_occlusion.glsl", "ENV_SPECULAR_SAMPLES": "compose.glsl",
          "LTC_SIZE": "ltc.glsl", "LTC_SHAPE_MAX": "direct.glsl"}


def test_shared_constants_are_not_written_in_the_glsl():
    for name, p in _glsl_files().items():
        for constant in SHARED:
            assert not re.search(rf"^\s*#define\s+{constant}\b", p.read_text(encoding="utf-8"), flags=re.M), (
                f"{name} writes {constant}: it comes from Python as a define")
    for constant, name in SHARED.items():
        assert re.search(rf"#ifndef {constant}\n#error {constant} ", _glsl_files()[name].read_text(encoding="utf-8"))


def test_defines_follow_the_version_line_as_glsl_literals():
    src = shaders.shader_source("compose.glsl", "FRAGMENT_SHADER", {"A": 16.0, "B": 16, "C": True, "D": "true",
                                                                      "E": False, "F": 1e-5})
    head = src.split("\n#line 1\n")[0].splitlines()
    assert head == ["#version 330 core", "#define FRAGMENT_SHADER", "#define A 16.0", "#define B 16", "#define C",
                    "#define D true", "#define E 0", "#define F 1e-05"]
    with pytest.raises(ValueError, match="#define A: inf has no GLSL literal"):
        shaders.shader_source("compose.glsl", "FRAGMENT_SHADER", {"A": float("inf")})


def test_the_passes_pass_their_constants(gl_ctx):
    """Each pass compiles with its constants from Python; without them the GLSL stops, naming the constant."""
    from compare.brdf.ltc import TABLE_SIZE
    from compare.progressive.environment.environment import MAX_SAMPLES_PER_FRAME, EnvOcclusionPass
    from compare.progressive.frame.accumulate import ENV_SPECULAR_SAMPLES, ComposePass
    from compare.progressive.lights.direct import LTC_SHAPE_MAX, DirectPass, area_model_defines

    env = types.SimpleNamespace(defines=lambda materials: {"ENV_OCTAHEDRAL": 0, "ENV_RGBM": 0, "ENV_DIFFUSE_SH9": 0,
                                                           "MATERIALS_DIFFUSE": 0})
    occlusion = EnvOcclusionPass(gl_ctx, env)
    try:
        assert occlusion.program["u_sample_kind"].array_length == MAX_SAMPLES_PER_FRAME
    finally:
        occlusion.release()
    ComposePass(gl_ctx, (2, 2)).release()
    DirectPass(gl_ctx, area_model="ltc", materials="diffuse").release()
    assert area_model_defines("ltc") == {"AREA_MODEL_PAPER": 0, "AREA_MODEL_LTC": 1, "LTC_SIZE": float(TABLE_SIZE),
                                         "LTC_SHAPE_MAX": LTC_SHAPE_MAX}
    assert ENV_SPECULAR_SAMPLES == 16.0
    with pytest.raises(RuntimeError, match="ENV_SPECULAR_SAMPLES comes from accumulate.py"):
        shaders.load_program(gl_ctx, "compose.glsl")
    defines = {**area_model_defines("ltc"), "MATERIALS_DIFFUSE": 1, "LAYERS": 0, "SHADOWS": 0}
    del defines["LTC_SIZE"]
    with pytest.raises(RuntimeError, match="LTC_SIZE comes from direct.py"):
        shaders.load_program(gl_ctx, "direct.glsl", defines)


def _shared_includes() -> dict[str, tuple[str, dict]]:
    """The shared GLSL of compare/brdf and compare/ibl: each file's include guard, and the constants its
    package writes ahead of it."""
    from compare import ibl
    from compare.brdf.glsl import BRDF_DEFINES, LAYERS_DEFINES

    return {"brdf.glsl": ("COMPARE_BRDF_GLSL", BRDF_DEFINES), "layers.glsl": ("COMPARE_LAYERS_GLSL", LAYERS_DEFINES),
            "ibl.glsl": ("COMPARE_IBL_GLSL", ibl.GLSL_DEFINES)}


def test_shared_includes_take_their_constants_from_python(gl_ctx, monkeypatch):
    """brdf.glsl, layers.glsl and ibl.glsl write none of the constants they share with Python: every program
    that includes one gets them ahead of it, with the values of the Python that owns them, a compiled program
    has them, and without them the files stop, naming each one."""
    from compare import brdf, ibl
    from compare.brdf import coat, sheen
    from compare.brdf.glsl import glsl_define
    from compare.progressive.environment import environment

    shared = _shared_includes()
    assert {k: v for _, defines in shared.values() for k, v in defines.items()} == {
        "BRDF_ALPHA_MIN": brdf.ALPHA_MIN, "BRDF_COS_MIN": brdf.COS_MIN, "BRDF_DIELECTRIC_F0": brdf.DIELECTRIC_F0,
        "BRDF_H_LEN2_MIN": brdf.H_LEN2_MIN, "BRDF_DENOM_MIN": brdf.DENOM_MIN,
        "LAYERS_SHEEN_ALPHA_MIN": sheen.SHEEN_ALPHA_MIN, "LAYERS_SHEEN_TABLE": float(sheen.TABLE_SIZE),
        "LAYERS_COAT_F0": coat.COAT_F0, "ENV_MAX_LEVELS": ibl.MAX_LEVELS}
    assert environment.MAX_LEVELS is ibl.MAX_LEVELS  # the rasterizer checks ibl_levels against the GLSL's limit
    files = {**_glsl_files(), **{p.name: p for d in ("brdf", "ibl") for p in (ROOT / "compare" / d).glob("*.glsl")}}
    for name, p in files.items():
        text = p.read_text(encoding="utf-8")
        for _, defines in shared.values():
            for constant in defines:
                assert not re.search(rf"^\s*#define\s+{constant}\b", text, flags=re.M), (
                    f"{name} writes {constant}: it comes from Python as a define")
    for include, (_, defines) in shared.items():
        for constant in defines:
            assert re.search(rf"#ifndef {constant}\n#error {constant} ", files[include].read_text(encoding="utf-8"))
    # Every program that includes one of them, through the loader: the defines come just ahead of the file.
    for program in sorted(_programs()):
        text = shaders.shader_source(program, "FRAGMENT_SHADER", {"BATCH": 1})
        raw = files[program].read_text(encoding="utf-8")
        for include, (guard, defines) in shared.items():
            if f'#include "{include}"' in raw:
                assert f"#ifndef {guard}\n" in text, f"{program} includes {include}, its text has no {guard}"
            if f"#ifndef {guard}\n" in text:
                head = text[:text.index(f"#ifndef {guard}\n")].splitlines()
                for constant, value in defines.items():
                    assert glsl_define(constant, value) in head, f"{program}: {include} without {constant}"
    env = types.SimpleNamespace(defines=lambda materials: {"ENV_OCTAHEDRAL": 0, "ENV_RGBM": 0, "ENV_DIFFUSE_SH9": 0,
                                                           "MATERIALS_DIFFUSE": 0})
    occlusion = environment.EnvOcclusionPass(gl_ctx, env, layers=True)
    try:
        assert occlusion.program["u_env_levels"].array_length == ibl.MAX_LEVELS
    finally:
        occlusion.release()
    monkeypatch.setattr(shaders, "_generated", lambda name: shaders._find(name).read_text(encoding="utf-8"))
    with pytest.raises(RuntimeError) as err:
        environment.EnvOcclusionPass(gl_ctx, env, layers=True)
    for _, defines in shared.values():
        for constant in defines:
            assert f"{constant} comes from compare/" in str(err.value), constant

# -- the G-buffer preamble -------------------------------------------------------------------------

GBUFFER_SAMPLERS = ("u_position", "u_normal", "u_material", "u_emission")


def test_one_file_declares_the_gbuffer_samplers():
    declared = re.compile(rf"^\s*uniform\s+sampler2D\s+({'|'.join(GBUFFER_SAMPLERS)})\s*;", flags=re.M)
    where = {name for name, p in _glsl_files().items() if declared.search(p.read_text(encoding="utf-8"))}
    assert where == {"gbuffer_inputs.glsl"}
    readers = {name for name, p in _glsl_files().items()
               if re.search(rf"texelFetch\(({'|'.join(GBUFFER_SAMPLERS)})\b", p.read_text(encoding="utf-8"))}
    for name in readers:
        assert '#include "gbuffer_inputs.glsl"' in _glsl_files()[name].read_text(encoding="utf-8"), name
    assert len(readers) == 10, sorted(readers)
