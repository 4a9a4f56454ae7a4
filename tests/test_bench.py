"""``compare bench``: the figures are computed and reported, not timed against goals here."""

from __future__ import annotations

import json
import math

import numpy as np

import pytest

from compare.bench.suite import format_table, run_bench, time_to_error
from tests.helpers import CORNELL, ROOT


def test_time_to_error_interpolates_log_log():
    seconds, errors = [1.0, 2.0, 4.0, 8.0], [0.4, 0.2, 0.1, 0.05]
    assert time_to_error(seconds, errors, 0.1) == pytest.approx(4.0)
    assert time_to_error(seconds, errors, math.sqrt(0.2 * 0.1)) == pytest.approx(math.sqrt(8.0))
    assert time_to_error(seconds, errors, 0.5) == 1.0  # already there at the first checkpoint
    assert math.isinf(time_to_error(seconds, errors, 0.01))


def test_bench_reports_ratios(tmp_path, gl_ctx):
    result = run_bench(CORNELL, size=(48, 36), frames=8, spp=4, repeats=2,
                       items=("first-frame", "depth-floor", "area-models", "wrapper-overhead"), progress=False)
    names = [f["name"] for f in result["figures"]]
    assert names == ["first-frame", "first-frame-total", "first-frame-full-size", "depth-floor", "area-model-ltc",
                     "area-model-paper", "wrapper-overhead"]
    for f in result["figures"]:
        assert f["a_median"] > 0 and f["b_median"] > 0 and f["ratio"] > 0
        assert len(f["a_samples"]) == 2
    total = next(f for f in result["figures"] if f["name"] == "first-frame-total")
    assert total["ratio"] < 1  # frame 1 is part of the total
    json.dumps(result, allow_nan=False)  # no NaN/Inf can reach the JSON
    table = format_table(result)
    assert "first-frame" in table and "A/B" in table
    assert result["machine"]["cores"] >= 1


def test_bench_times_texturing_and_skips_a_scene_without_maps(tmp_path, gl_ctx):
    """The textures item: the textured car against its factors only; the Cornell box has nothing to time."""
    result = run_bench(ROOT / "scenes" / "car.toml", size=(32, 24), frames=4, spp=4, repeats=2,
                       items=("textures",), progress=False)
    (f,) = result["figures"]
    assert f["name"] == "textures" and f["a_median"] > 0 and f["b_median"] > 0 and len(f["b_samples"]) == 2
    assert "materials textured" in f["note"]
    plain = run_bench(CORNELL, size=(32, 24), frames=4, spp=4, repeats=1,
                      items=("textures",), progress=False)
    assert plain["figures"] == [] and "no material of the scene has a map" in plain["skipped"]["textures"]


def test_bench_equal_error_times_fresh_renders(tmp_path, gl_ctx, monkeypatch):
    """Both sides are medians of --repeats runs, and the Mitsuba ladder is rendered, not read from the
    reference cache (whose seconds would be those of the run that filled it)."""
    import compare.bench.suite as bench

    monkeypatch.setenv("COMPARE_CACHE", str(tmp_path / "cache"))
    calls = []
    real = bench._render

    def recording(registry, spec, scene, *, steps, checkpoints=None, seed=0, context):
        calls.append((spec, checkpoints, context.cache_dir))
        return real(registry, spec, scene, steps=steps, checkpoints=checkpoints, seed=seed, context=context)

    monkeypatch.setattr(bench, "_render", recording)
    result = run_bench(CORNELL, size=(32, 24), frames=4, spp=4, repeats=2,
                       items=("equal-error",), progress=False)
    names = [f["name"] for f in result["figures"]]
    assert names == ["equal-error-full", "equal-error-full-ltc-probes", "equal-error-direct", "equal-error-direct-ltc"]
    for f in result["figures"]:
        assert len(f["a_samples"]) == len(f["b_samples"]) == 2 and f["ratio"] > 0
    ladders = [c for c in calls if c[0] == "mitsuba" and c[1] is not None]  # the truths have no ladder
    assert len(ladders) == 4 and all(cache is False for *_, cache in ladders)
    assert any(c[0] == "mitsuba" and c[2] is not False for c in calls)  # the ground truths may come from the cache


@pytest.mark.slow  # five fresh processes that import Mitsuba: 25 s on a machine with cold caches
def test_setup_items_measure_every_renderer_on_the_car_and_the_scaled_scenes(tmp_path):
    """setup-seconds and setup-rss: per renderer, the car and the generated scene's growth over 1x (tiny
    sizes here: the real item uses 62,500 triangles and a 4096² map per x)."""
    from compare.bench.setup_cost import SCALES, bench_setup, scaled_scene
    from compare.scene.gltf_read import load_gltf

    scene = scaled_scene(4, tmp_path, triangles=200, map_size=32)
    doc = load_gltf(scene.with_suffix(".glb"))
    assert len(doc.primitives) == 4 and len(doc.images) == 4
    assert 4 * 150 <= sum(p.mesh.triangle_count for p in doc.primitives) <= 4 * 250
    figures = bench_setup(ROOT / "scenes" / "car.toml", tmp_path, size=(32, 24), repeats=1,
                          renderers=["mitsuba"], triangles=200, map_size=32, interior_triangles=1000)
    assert [(f.name, f.a) for f in figures] == [
        ("setup-seconds", "mitsuba car"), ("setup-rss", "mitsuba car"),
        ("setup-seconds", "mitsuba interior"), ("setup-rss", "mitsuba interior"),
        *[(name, f"mitsuba {s}x") for s in SCALES[1:] for name in ("setup-seconds", "setup-rss")]]
    for f in figures:
        assert f.b == ("mitsuba car" if "interior" in f.a else "mitsuba 1x")
        assert math.isfinite(f.ratio) and f.a_median > 0 and f.b_median > 0
    rss = [f for f in figures if f.name == "setup-rss"]
    assert all(50 < f.a_median < 4000 for f in rss)  # MiB of a process that imported Mitsuba
    assert "growth (linear: 16)" in figures[-1].note


def test_the_generated_interior_is_shaped_as_a_downloaded_one(tmp_path):
    """The set-up items' interior: deterministic, about the asked triangles over hundreds of meshes, dozens
    of materials, a few maps with tangents for the normal maps, point lights, an area light and a sky."""
    from compare.bench.setup_cost import INTERIOR_TRIANGLES, interior_scene
    from compare.scene.loader import load_scene

    toml = interior_scene(tmp_path)
    first = toml.with_suffix(".glb").read_bytes()
    assert interior_scene(tmp_path) == toml  # written once
    (tmp_path / "again").mkdir()
    assert interior_scene(tmp_path / "again").with_suffix(".glb").read_bytes() == first
    scene = load_scene(toml)
    triangles = sum(m.triangles().triangle_count for m in scene.meshes)
    assert 0.99 * INTERIOR_TRIANGLES <= triangles <= 1.01 * INTERIOR_TRIANGLES
    assert len(scene.meshes) > 300 and len({m.material for m in scene.meshes}) >= 30
    textured = [m for m in scene.materials.values() if m.base_color_texture is not None]
    assert 3 <= len(textured) <= 8 and any(m.normal_texture is not None for m in textured)
    assert len(scene.punctual) == 3 and len(scene.lights) == 1 and scene.environment is not None
    lo, hi = scene.extent()
    assert np.allclose(hi - lo, [12.15, 2.9, 8.15], atol=0.05)
    for mesh in scene.meshes:  # the file's tangents: no MikkTSpace tool needed to read it
        mat = scene.materials[mesh.material]
        if mat.normal_texture is not None:
            assert mesh.triangles(tangents=True).tangents is not None


def test_setup_specs_cover_every_option_word_and_the_declared_variants():
    """The set-up items' variants come from where the variants are defined: every progressive option
    word alone (not the default's), all its switches together, and each declared variant."""
    from compare.bench.setup_cost import setup_specs
    from compare.progressive.options import WORDS, renderer_options
    from compare.renderers.registry import Registry

    registry = Registry()
    renderers, variants = setup_specs(registry)
    if "progressive" not in renderers:
        pytest.skip("moderngl is not installed")
    words = {w for spec in variants if spec.startswith("progressive:") for w in spec.split(":")[1].split("+")}
    for w in WORDS:
        assert w.word in words or w.example in words or w.word == "radiometric", w.word
    combined = max((v for v in variants if v.startswith("progressive:")), key=lambda v: v.count("+"))
    assert {"probes", "envshadows", "sun", "vsm"} <= set(combined.split(":")[1].split("+"))
    for spec in variants:
        renderer_options(spec) if spec.startswith("progressive") else registry.get(spec)
    assert set(registry.specs()) - set(renderers) <= set(variants) | {
        s for s in registry.specs() if s.partition(":")[0] not in renderers}
    assert len(variants) == len(set(variants))


def test_a_failing_item_is_recorded_and_every_figure_is_written_as_it_is_measured(tmp_path, monkeypatch):
    """A bench item that fails (a renderer's error, a page that never answers) no longer loses the whole
    bench: it is in ``failed`` with its message, the figures measured before and after it stand, and the
    command line's file holds each figure as soon as it is measured."""
    from compare.bench import progressive
    from compare.cli.main import main
    from compare.renderers import RendererError
    from compare.util.figures import Figure

    def broken(scene, **_):
        raise RendererError("renderer 'babylon': no answer from the page within 600 s")

    seen = []

    def fine(scene, **_):
        if (tmp_path / "bench.json").is_file():
            seen.append(json.loads((tmp_path / "bench.json").read_text()))
        return [Figure("depth-floor", "a", "b", 2.0, 1.0, "s", 1)]

    monkeypatch.setitem(progressive.ITEMS, "first-frame", broken)
    monkeypatch.setitem(progressive.ITEMS, "depth-floor", fine)
    rc = main(["bench", "--scene", str(CORNELL),
               "--size", "16x12", "--frames", "2", "--spp", "4", "--repeats", "1",
               "--only", "first-frame,depth-floor", "-o", str(tmp_path / "bench.json")])
    assert rc == 1
    result = json.loads((tmp_path / "bench.json").read_text())
    assert result["failed"] == {"first-frame": "renderer 'babylon': no answer from the page within 600 s"}
    assert [f["name"] for f in result["figures"]] == ["depth-floor"]
    assert seen and seen[0]["failed"] == result["failed"] and seen[0]["figures"] == []  # written after item 1


def test_bench_times_glass_and_skips_a_scene_without_it(tmp_path, gl_ctx):
    """The transmission item: the glass spheres against the same spheres opaque; the Cornell box has no glass."""
    result = run_bench(ROOT / "scenes" / "effects" / "materials_transmission.toml", size=(32, 8), frames=4, spp=4,
                       repeats=2, items=("transmission",), progress=False)
    (f,) = result["figures"]
    assert f["name"] == "transmission" and f["a_median"] > 0 and f["b_median"] > 0 and len(f["b_samples"]) == 2
    assert "5 of 5 materials transmit" in f["note"]
    plain = run_bench(CORNELL, size=(32, 24), frames=4, spp=4, repeats=1, items=("transmission",), progress=False)
    assert plain["figures"] == [] and "no material of the scene transmits" in plain["skipped"]["transmission"]
