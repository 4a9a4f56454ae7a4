"""Web engines in headless Chromium (compare.web): three.js, three-gpu-pathtracer, Babylon.js and
PlayCanvas.

They render the suite's scenes from the same job file as external renderers, into float
render targets, and are measured against the same ground truth. The rasterizing engines
(the ``web`` group's renderers counted in frames) all pass the same registration and
orientation tests. One Chromium serves every render of this module. Skips with the reason
where Chromium, Playwright or the npm packages are missing (``scripts/suite.sh setup``
installs them).
"""

from __future__ import annotations

import textwrap

import numpy as np
import pytest

from compare.run import runner as run_mod
from compare.metrics.images import compare_images
from compare.renderers import RenderContext, RendererError
from compare.renderers.registry import Registry
from compare.report.results import RunSettings
from compare.scene.loader import load_scene
from tests.helpers import (AXES_ENVIRONMENT, CARD_GEOMETRY, CARD_MASKED, COATED_SCENE, COLORED_CARD_SCENE, CORNELL,
                           QUADRANTS, QUADRANT_MAPS, RED_CORNERS, card_regions, card_scene, centre_mean,
                           coated_model, colored_card, npm_availability, quadrant_regions, quadrant_scene, sided_card,
                           synthetic_report)

_REGISTRY = Registry()
#: The web engines that rasterize (counted in frames), from the registry's ``web`` group.
RASTER = [n for n in _REGISTRY.groups()["web"] if _REGISTRY.get(n).unit == "frame"]
#: The same, three.js in the default run and the others among the slow tests (each page load costs seconds).
RASTER_THREE_FIRST = [e if e == "threejs" else pytest.param(e, marks=pytest.mark.slow) for e in RASTER]

def _render(pages, engine: str, scene, steps: int, checkpoints=None):
    return pages.render(Registry().get(engine), scene, steps, checkpoints)


@pytest.mark.web
def test_threejs_beside_mitsuba_and_the_rasterizer(tmp_path, gl_ctx):
    settings = RunSettings(frames=8, spp=64, sizes=[[32, 24]], renderers=["mitsuba", "progressive", "threejs"])
    res = run_mod.run([CORNELL], tmp_path / "out", settings, progress=False, gl_ctx=gl_ctx)
    scene = res.scenes[0]
    three, prog = scene.run("threejs"), scene.run("progressive")
    assert [p.step for p in three.points] == [1, 2, 4, 8] and three.unit == "frame"
    assert three.setup_seconds > 0 and 0 < three.points[0].seconds <= three.seconds
    assert res.machine.facts.get("webgl_renderer") and "webgl_renderer" in three.metadata
    # Against the same 64-spp ground truth at 32x24 (measured: three.js 0.25, the rasterizer 0.25): both
    # lack the indirect light; three.js also the area light's shadows (RectAreaLight casts none).
    assert 0.15 < three.final.metrics["flip"] < 0.35, three.final.metrics
    assert abs(three.final.metrics["flip"] - prog.final.metrics["flip"]) < 0.1
    assert "three.js" in (tmp_path / "out" / "index.html").read_text()


@pytest.mark.web
@pytest.mark.parametrize("engine", RASTER)
def test_web_engine_lands_on_the_same_pixels(tmp_path, engine, web_pages):
    """A small light facing the camera off the image centre: its pixels are where the camera's own
    ray directions (compare.scene.loader.Camera) put it, as in Mitsuba, and its emitter face shows the
    light's radiance."""
    path = tmp_path / "marker.toml"
    path.write_text(textwrap.dedent("""
        name = "marker"
        [camera]
        position = [0.0, 0.0, 0.0]
        target = [0.0, 0.0, -1.0]
        fov = 40.0
        resolution = [40, 30]
        [materials.black]
        base_color = [0.0, 0.0, 0.0]
        [[meshes]]
        name = "backdrop"
        shape = "quad"
        material = "black"
        corners = [[-9.0, -9.0, -5.0], [9.0, -9.0, -5.0], [9.0, 9.0, -5.0], [-9.0, 9.0, -5.0]]
        [[lights]]
        name = "marker"
        center = [0.55, 0.3, -4.0]
        size = [0.25, 0.25]
        normal = [0.0, 0.0, 1.0]
        radiance = [10.0, 10.0, 10.0]
    """))
    scene = load_scene(path)
    image = _render(web_pages, engine, scene, 1).checkpoints[-1].image
    cam = scene.camera
    # the marker's centre on the film (pixels, x right, y down, row 0 at the top), by the camera's basis
    r, u, f = cam.basis()
    p = np.array([0.55, 0.3, -4.0]) - np.asarray(cam.position)
    t = np.tan(np.radians(cam.fov) / 2)
    sx, sy = (p @ r) / (p @ f), (p @ u) / (p @ f)
    x, y = (sx / (t * cam.aspect) + 1) / 2 * cam.width, (1 - sy / t) / 2 * cam.height
    lit = np.argwhere(image[..., 0] > 5.0)  # at frame 1 the pixels whose centres see the marker
    assert len(lit) >= 4
    cy, cx = lit.mean(0) + 0.5
    assert abs(cx - x) < 0.5 and abs(cy - y) < 0.5, ((cx, cy), (x, y))
    np.testing.assert_allclose(np.median(image[image[..., 0] > 5.0], 0), 10.0, rtol=0.02)


#: FLIP of each engine's axes background against Mitsuba's, measured: three.js 0.016, PlayCanvas 0.022,
#: Babylon.js 0.064 (its 256-pixel cube map, a pixel softer than the 256 x 128 map); a map turned the
#: wrong way or mirrored measures 0.18 to 0.5.
@pytest.mark.web
@pytest.mark.parametrize("engine", RASTER_THREE_FIRST)
def test_web_environment_has_the_suites_orientation(tmp_path, make_scene, engine, web_pages):
    """The axes test map, turned 30 degrees: each engine's background against Mitsuba's."""
    from compare.mitsuba.reference import ReferenceRenderer

    scene = load_scene(make_scene(AXES_ENVIRONMENT))
    ours = _render(web_pages, engine, scene, 4).checkpoints[-1].image
    truth = ReferenceRenderer(scene, cache_dir=tmp_path / "cache", progress=False).render(64).image
    assert compare_images(truth, ours)["flip"] < 0.1
    np.testing.assert_allclose(ours.mean((0, 1)), truth.mean((0, 1)), rtol=0.05)


@pytest.mark.web
@pytest.mark.slow  # about 60 s of SwiftShader path tracing on two CPU cores
def test_browser_path_tracer_converges_towards_mitsuba(tmp_path, web_pages):
    scene = load_scene(CORNELL).with_resolution(32, 24)
    res = _render(web_pages, "threejs-pathtracer", scene, 8, [1, 2, 4, 8])
    assert [c.step for c in res.checkpoints] == [1, 2, 4, 8] and res.setup_seconds > res.checkpoints[-1].seconds
    from compare.mitsuba.reference import ReferenceRenderer

    truth = ReferenceRenderer(scene, cache_dir=tmp_path / "cache", progress=False).render(256).image
    errors = [compare_images(truth, c.image)["relmse"] for c in res.checkpoints]
    assert errors[-1] < errors[0], errors
    flip = compare_images(truth, res.checkpoints[-1].image)["flip"]
    assert flip < 0.3, flip


def test_missing_pieces_are_named(monkeypatch, tmp_path):
    monkeypatch.setenv("COMPARE_CHROMIUM", str(tmp_path / "no-chromium"))
    ok, why = Registry().get("threejs").available()
    assert not ok and why.startswith(f"Chromium {tmp_path / 'no-chromium'} ($COMPARE_CHROMIUM) is not an "
                                     "executable file; scripts/suite.sh setup installs all of it")
    monkeypatch.delenv("COMPARE_CHROMIUM")
    ok, why = npm_availability(monkeypatch, tmp_path, Registry().get("threejs-pathtracer"))
    assert not ok and why.startswith(f"the npm package three is not in {tmp_path / 'node_modules'}; ")
    # each engine names the first of its own packages that is missing
    for engine, package in (("babylon", "@babylonjs/core"), ("playcanvas", "playcanvas")):
        ok, why = npm_availability(monkeypatch, tmp_path, Registry().get(engine), "three")
        assert not ok and why.startswith(f"the npm package {package} is not in {tmp_path / 'node_modules'}; "
                                         "scripts/suite.sh setup installs"), why
        with RenderContext(RunSettings(frames=1)) as context, \
                pytest.raises(RendererError, match=rf"^renderer '{engine}': the npm package {package} is not in"):
            Registry().get(engine).render(load_scene(CORNELL), steps=1, checkpoints=[1], seed=0, context=context)


@pytest.mark.web
@pytest.mark.parametrize("engine", RASTER)
def test_no_webgl_is_one_clear_error(monkeypatch, engine, web_pages):
    """Without WebGL 2 each engine's page fails with one line naming it, before any engine code runs."""
    web_pages.close()
    monkeypatch.setenv("COMPARE_CHROMIUM_ARGS", "--disable-webgl --disable-gpu")
    scene = load_scene(CORNELL).with_resolution(8, 6)
    with RenderContext(RunSettings(frames=1)) as context, \
            pytest.raises(RendererError, match=rf"^renderer '{engine}': the page failed: .*no WebGL 2 context$"):
        Registry().get(engine).render(scene, steps=1, checkpoints=[1], seed=0, context=context)


@pytest.mark.web
@pytest.mark.parametrize("engine", RASTER)
def test_no_float_render_targets_is_one_clear_error(monkeypatch, engine, web_pages):
    """A WebGL 2 without EXT_color_buffer_float (a page that hides it): one line naming the extension."""
    from compare.web import host

    def new_page(self):
        page = self.browser.new_page()
        page.add_init_script("""const get = WebGL2RenderingContext.prototype.getExtension;
            WebGL2RenderingContext.prototype.getExtension = function (name) {
              return name === 'EXT_color_buffer_float' ? null : get.call(this, name); };""")
        return page

    web_pages.close()
    monkeypatch.setattr(host._Browser, "new_page", new_page)
    scene = load_scene(CORNELL).with_resolution(8, 6)
    with RenderContext(RunSettings(frames=1)) as context, \
            pytest.raises(RendererError, match=rf"^renderer '{engine}': the page failed: .*no EXT_color_buffer_float: "
                                               "float render targets are not available$"):
        Registry().get(engine).render(scene, steps=1, checkpoints=[1], seed=0, context=context)


@pytest.mark.web
def test_threejs_variants(tmp_path, web_pages):
    """threejs:shadows puts shadow-mapped spot lights where RectAreaLight casts none: the pixels the
    direct-light ground truth has in shadow get darker; threejs:msaa renders; bad options are named."""
    from compare.mitsuba.reference import ReferenceRenderer

    scene = load_scene(CORNELL).with_resolution(32, 24)
    plain = _render(web_pages, "threejs", scene, 4).checkpoints[-1].image
    shadows = _render(web_pages, "threejs:shadows", scene, 4).checkpoints[-1].image
    # both average the pixel's area: MSAA per frame, jittered frames over time (16 of them here)
    smooth, msaa = (_render(web_pages, s, scene, 16).checkpoints[-1].image for s in ("threejs", "threejs:msaa"))
    direct = ReferenceRenderer(scene, max_depth=2, cache_dir=tmp_path / "cache", progress=False).render(64).image
    shadowed = (direct.mean(-1) < 0.3 * plain.mean(-1)) & (plain.mean(-1) > 0.01)
    assert shadowed.sum() >= 10
    assert shadows[shadowed].mean() < 0.6 * plain[shadowed].mean(), (shadows[shadowed].mean(), plain[shadowed].mean())
    assert np.isfinite(msaa).all() and abs(msaa.mean() / smooth.mean() - 1) < 0.05, (msaa.mean(), smooth.mean())
    for bad in ("threejs:nope", "threejs-pathtracer:msaa", "threejs:msaa+msaa"):
        with pytest.raises(ValueError, match=r"unknown option 'nope'; expected one of shadows|takes no ':' "
                                             r"options|'msaa' given twice"):
            Registry().get(bad)


@pytest.mark.web
@pytest.mark.parametrize("engine", RASTER)
def test_web_engine_reads_the_maps_of_the_exported_gltf(tmp_path, engine, web_pages):
    """An emission map under a texture transform reaches each engine through the exported glTF (textures,
    KHR_texture_transform, sampler): each region shows the quadrant the transform says (an emission map
    shows as emission x texel, in linear light)."""
    from compare.image.tonemap import srgb_decode

    settings, source = QUADRANT_MAPS[1]  # a 90 degree turn
    scene = quadrant_scene(tmp_path, 'base_color = [0.0, 0.0, 0.0]\nemission = [1.0, 1.0, 1.0]\n'
                                     f'emissive_texture = "quadrants.png"\n{settings}', light=False)
    image = _render(web_pages, engine, scene, 2).checkpoints[-1].image
    regions = quadrant_regions(scene)
    for (r, c) in QUADRANTS:
        want = srgb_decode(np.array(QUADRANTS[source(r, c)]) / 255.0)
        np.testing.assert_allclose(image[regions[f"quadrant {r}{c}"]].mean(0), want, rtol=0.03, atol=0.003,
                                   err_msg=f"{r}{c}")


@pytest.mark.web
@pytest.mark.parametrize("engine", [pytest.param(e, marks=[pytest.mark.slow, pytest.mark.xfail(
    strict=True, reason="Babylon.js 9.28 lights an untextured material with its specular term only in a scene where "
    "another material has a base-colour map: the floor measures 0.0596 with and without specular in the scene "
    "without maps, 0.0687 in the one with (three.js 0.0635, PlayCanvas 0.0611 in both); the holes are cut")])
    if e == "babylon" else e for e in RASTER])
def test_web_engine_cuts_the_holes_of_an_alpha_mask(tmp_path, engine, web_pages):
    """alphaMode MASK reaches each engine through the exported glTF: the masked card renders as its solid
    quadrants as real quads (the card, and the floor seen through its holes) within 3 %."""
    masked = card_scene(tmp_path, CARD_MASKED)
    (tmp_path / "geometry").mkdir()
    geometry = card_scene(tmp_path / "geometry", CARD_GEOMETRY)
    a = _render(web_pages, engine, masked, 4).checkpoints[-1].image
    b = _render(web_pages, engine, geometry, 4).checkpoints[-1].image
    for name, m in card_regions(masked).items():
        np.testing.assert_allclose(a[m].mean(0), b[m].mean(0), rtol=0.03, atol=0.003, err_msg=name)
    card = a[card_regions(masked)["card"]].mean(0)
    assert card[1] > 3 * card[0]  # green, the map's solid colour (the holes' magenta is never drawn)


@pytest.mark.web
def test_the_feature_table_is_measured(web_pages):
    """The engine x feature table comes from renders: three.js' RectAreaLight casts no shadow, its shadows
    variant does, and the table says so with the measured ratios."""
    from compare.bench.features import feature_table, measure_features

    web_pages.close()
    measured = measure_features(["threejs", "threejs:shadows"], frames=2, features=["area_light_shadows"])
    plain, shadows = measured["threejs"]["area_light_shadows"], measured["threejs:shadows"]["area_light_shadows"]
    assert not plain["drawn"] and plain["value"] > 0.9, plain
    assert shadows["drawn"] and shadows["value"] < 0.5, shadows
    table = feature_table(measured)
    assert "| area-light shadows (shadowed / unshadowed) | ✗ " in table and "| ✓ " in table


def test_run_features_land_in_the_reports_machine_section(tmp_path, monkeypatch):
    """`compare run --features`: the measured table of each rasterizer of the run (not the ground truth)
    becomes a fact of the run's machine, in results.json and the report's machine section."""
    import json

    import compare.bench.features as features
    from compare.cli import run as cli_run

    res = synthetic_report(tmp_path / "r", [CORNELL])
    asked = []

    def fake(specs, **kwargs):
        asked.extend(specs)
        return {s: {"clearcoat": {"value": 0.5, "drawn": True, "unit": "x"},
                    "area_light_shadows": {"value": 1.0, "drawn": False, "unit": "x"}} for s in specs}

    monkeypatch.setattr(features, "measure_features", fake)
    cli_run._measure_features(res, ["mitsuba", "progressive"], tmp_path / "r", report=True, progress=False)
    assert asked == ["progressive"]
    saved = json.loads((tmp_path / "r" / "results.json").read_text())
    assert saved["machine"]["facts"]["features of progressive"] == "clearcoat yes (0.50); area-light shadows no (1.00)"
    html = (tmp_path / "r" / "index.html").read_text()
    assert "features of progressive" in html and "clearcoat yes (0.50)" in html


@pytest.mark.web
@pytest.mark.parametrize("engine", RASTER_THREE_FIRST)
def test_web_engines_that_declare_vertex_colours_draw_them(tmp_path, make_scene, engine, web_pages):
    """A rasterizing web engine reads COLOR_0 from the job's glTF: the tinted grey card renders as the red
    one (each engine's own shading on both sides)."""
    assert "vertex_colors" in Registry().get(engine).renders
    colored_card(tmp_path, base=(0.8, 0.8, 0.8, 1.0), colors=RED_CORNERS)
    tinted = load_scene(make_scene(COLORED_CARD_SCENE))
    (tmp_path / "plain").mkdir()
    colored_card(tmp_path / "plain", base=(0.8, 0.0, 0.0, 1.0))
    (tmp_path / "plain" / "scene.toml").write_text(COLORED_CARD_SCENE)
    plain = load_scene(tmp_path / "plain" / "scene.toml")
    a, b = (_render(web_pages, engine, s, 2).checkpoints[-1].image for s in (tinted, plain))
    np.testing.assert_allclose(a[4:12, 4:12].mean((0, 1)), b[4:12, 4:12].mean((0, 1)), rtol=0.02, atol=0.005)
    assert a[4:12, 4:12, 0].mean() > 5 * a[4:12, 4:12, 1].mean()


@pytest.mark.web
def test_threejs_renders_a_model_with_extension_maps(tmp_path, make_scene, web_pages):
    """The case that lost a user's map: a web engine renders a scene whose material has clearcoat maps
    (it read the job's glTF, not a 404)."""
    (tmp_path / "model").mkdir()
    coated_model(tmp_path / "model")
    image = _render(web_pages, "threejs", load_scene(make_scene(COATED_SCENE)), 2).checkpoints[-1].image
    assert image.shape == (16, 24, 3) and np.isfinite(image).all() and float(image.mean()) > 0.0


@pytest.mark.web
@pytest.mark.parametrize("engine", RASTER_THREE_FIRST)
def test_web_engines_cull_single_sided_back_faces(tmp_path, make_scene, engine, web_pages):
    """The job's glTF carries doubleSided: from behind, a single-sided card is the background around it, a
    double-sided one its front's grey."""
    assert "single_sided" in Registry().get(engine).renders
    images = {}
    for sided, behind in ((False, False), (False, True), (True, True)):
        scene = sided_card(make_scene, tmp_path, double_sided=sided, from_behind=behind)
        images[sided, behind] = _render(web_pages, engine, scene, 2).checkpoints[-1].image
    culled = images[False, True]
    assert centre_mean(culled) == pytest.approx(float(culled[0:2, 0:2].mean()), rel=0.02)  # the background
    assert centre_mean(images[True, True]) == pytest.approx(centre_mean(images[False, False]), rel=0.1)
    assert centre_mean(images[False, False]) < 0.7 * float(culled[0:2, 0:2].mean())


@pytest.mark.web
def test_a_page_that_does_not_answer_in_time_is_stopped_with_one_message(make_scene, web_pages):
    """A page that waits forever (an image that never decodes) used to hang the run: each call into the
    page is bounded by the render's deadline; past it the tab is closed and the error says where it was."""
    web_pages.close()  # one Playwright driver per thread: this test's own context starts its own
    scene = sided_card(make_scene, make_scene("").parent, double_sided=True, from_behind=False)
    with RenderContext(RunSettings(frames=2), timeout=0.05) as context:
        with pytest.raises(RendererError, match=r"no answer from the page within 0.05 s \(--timeout\) while"):
            Registry().get("threejs").render(scene, steps=2, checkpoints=[2], seed=0, context=context)
