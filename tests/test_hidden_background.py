"""``[environment] background = false``: the environment lights the scene but camera rays that hit nothing
see black. The loader reads it, the renderers that declare ``hidden_background`` draw it (the corners of a
sphere under a bright sky go black, the lit sphere stays as it was, emitters seen directly stay seen), and
the others say they leave it out."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from compare.scene.loader import load_scene
from compare.util.errors import SceneError

SKY = 2.0
CORNERS = (np.s_[0, 0], np.s_[0, -1], np.s_[-1, 0], np.s_[-1, -1])
#: Pixels of the 16 × 16 view that the emissive card (row 1) and the area light (row 14) cover fully.
CARD, LIGHT = np.s_[1, 7:9], np.s_[14, 7:9]
CENTRE = np.s_[6:10, 6:10]


def _scene(make_scene, background: bool | None, *, emitters: bool = True, name: str = "scene.toml"):
    """A grey sphere under a constant sky of :data:`SKY`, 16 × 16; with ``emitters`` an emissive card above
    it and an area light below it, both facing the camera; ``background`` the [environment]'s field (None:
    not written)."""
    field = "" if background is None else f"background = {str(background).lower()}"
    extra = """
        [materials.glow]
        base_color = [0.0, 0.0, 0.0]
        emission = [4.0, 4.0, 4.0]

        [[meshes]]
        shape = "quad"
        corners = [[-0.15, 0.6, 0.0], [0.15, 0.6, 0.0], [0.15, 0.75, 0.0], [-0.15, 0.75, 0.0]]
        material = "glow"

        [[lights]]
        center = [0.0, -0.675, 0.0]
        size = [0.3, 0.15]
        normal = [0.0, 0.0, 1.0]
        tangent = [1.0, 0.0, 0.0]
        radiance = [3.0, 3.0, 3.0]
        """ if emitters else ""
    return load_scene(make_scene(f"""
        [camera]
        position = [0.0, 0.0, 3.0]
        target = [0.0, 0.0, 0.0]
        fov = 30
        resolution = [16, 16]

        [render]
        max_depth = 4

        [materials.grey]
        base_color = [0.5, 0.5, 0.5]
        roughness = 1.0

        [[meshes]]
        shape = "sphere"
        radius = 0.5
        material = "grey"

        [environment]
        constant = [{SKY}, {SKY}, {SKY}]
        {field}
        """, extra, name=name))


def _check_pair(shown: np.ndarray, hidden: np.ndarray, *, rtol: float, emitters: bool = True, sky: float = SKY):
    """The corners: the sky with the background (to the precision of an engine's map: RGBE, half floats), 0
    without; the sphere's centre the same in both; the emitters seen directly the same in both."""
    for c in CORNERS:
        np.testing.assert_allclose(shown[c], sky, rtol=1e-2)
        np.testing.assert_allclose(hidden[c], 0.0, atol=1e-6)
    np.testing.assert_allclose(hidden[CENTRE].mean((0, 1)), shown[CENTRE].mean((0, 1)), rtol=rtol)
    assert shown[CENTRE].mean() > 0.1
    if emitters:
        np.testing.assert_allclose(hidden[CARD], shown[CARD], rtol=rtol)
        np.testing.assert_allclose(hidden[LIGHT], shown[LIGHT], rtol=rtol)


# ------------------------------------------------------------------------------------------- the scene


def test_the_loader_reads_background(make_scene):
    shown, hidden, default = (_scene(make_scene, b, emitters=False, name=f"{b}.toml") for b in (True, False, None))
    assert default.environment.background is True and shown.environment.background is True
    assert hidden.environment.background is False
    assert hidden.features().hidden_background and hidden.hides_background
    assert not default.features().hidden_background and "hidden_background" not in default.features().names()
    # the scene's hash (every cache key's) differs, so no render of one stands in for the other
    assert hidden.hash != shown.hash and hidden.hash != default.hash
    assert hidden.with_background().hash != hidden.hash and not hidden.with_background().hides_background


@pytest.mark.parametrize("value, shown", [("0", "0"), ('"no"', "'no'"), ("[false]", "[false]")])
def test_a_bad_background_names_the_file_and_field(make_scene, value, shown):
    path = make_scene("""
        [camera]
        position = [0, 0, 3]
        target = [0, 0, 0]

        [materials.grey]

        [[meshes]]
        shape = "sphere"
        radius = 0.5
        material = "grey"

        [environment]
        constant = [1, 1, 1]
        """ + f"background = {value}\n")
    with pytest.raises(SceneError) as exc:
        load_scene(path)
    assert str(exc.value) == f"{path}: environment.background: expected true or false, got {shown}"


def test_the_studio_maps_walls_and_the_background_switch_are_apart(make_scene):
    """The studio map's wall radiance is its parameter ``walls``; ``background`` is the switch alone, and a
    number there (the studio's old name for its walls) is one error that says where the walls went."""
    base = """
        [camera]
        position = [0, 0, 3]
        target = [0, 0, 0]

        [materials.grey]

        [[meshes]]
        shape = "sphere"
        radius = 0.5
        material = "grey"

        [environment]
        procedural = "studio"
        width = 16
        """
    walls = load_scene(make_scene(base, "walls = 0.2\n", name="walls.toml"))
    assert walls.environment.background is True and dict(walls.environment.parameters)["walls"] == 0.2
    hidden = load_scene(make_scene(base, "background = false\n", name="hidden.toml"))
    assert hidden.environment.background is False and dict(hidden.environment.parameters)["walls"] == 0.05
    with pytest.raises(SceneError, match=r"old\.toml: environment\.background: expected true or false, got 0\.2 "
                                         r"\(the studio map's wall radiance is its parameter 'walls'\)"):
        load_scene(make_scene(base, "background = 0.2\n", name="old.toml"))


def test_the_job_carries_background(tmp_path, make_scene):
    from compare.renderers.job import write_job

    for background in (True, False):
        scene = _scene(make_scene, background, emitters=False, name=f"{background}.toml")
        folder = tmp_path / f"job-{background}"
        job = write_job(scene, folder, renderer="mine", unit="frame", checkpoints=[1], seed=0,
                        output_dir=folder / "out")
        assert json.loads(job.read_text())["scene"]["environment"]["background"] is background


def test_renderers_that_cannot_hide_it_say_so(make_scene):
    """Every built-in either declares hidden_background or says, in the phrases a run records, that it
    shows the environment there; it is then given the scene with the background shown."""
    from compare.renderers.registry import Registry

    scene = _scene(make_scene, False, emitters=False)
    reg = Registry()
    for name in reg.builtins():
        r = reg.get(name)
        given, notes = r.prepare(scene)
        said = any(n.startswith("hidden background not rendered") for n in notes)
        assert said == ("hidden_background" not in r.renders), name
        assert given.hides_background == ("hidden_background" in r.renders), name
    shown = _scene(make_scene, True, emitters=False, name="shown.toml")
    for name in reg.builtins():
        assert not any("hidden background" in n for n in reg.get(name).prepare(shown)[1]), name


def test_an_external_renderer_declares_it(tmp_path, make_scene):
    """A plug-in that lists hidden_background in renders gets the scene as it is (its job says background
    false); one that does not is given the background and the run's note says it left it out."""
    from compare.renderers.external import ConfigError, external_from_table

    def external(renders):
        table = {"command": ["true", "{job}"], "unit": "frames", "steps": 1, "timeout": 10, "renders": renders}
        return external_from_table("mine", table, source=tmp_path / "renderers.toml")

    scene = _scene(make_scene, False, emitters=False)
    given, notes = external(["hidden_background"]).prepare(scene)
    assert given is scene and not notes
    given, notes = external([]).prepare(scene)
    assert not given.hides_background and notes == ["hidden background not rendered (the environment is seen "
                                                    "where camera rays hit nothing)"]
    with pytest.raises(ConfigError, match="hidden_background"):
        external(["hidden-background"])


# ----------------------------------------------------------------------------------------- the reference


def _reference(scene, spp=64, *, layers=False):
    from compare.mitsuba.reference import ReferenceRenderer

    rr = ReferenceRenderer(scene, cache_dir=False, progress=False)
    return rr.render_layers(spp, seed=3) if layers else rr.render(spp, seed=3).image


def test_the_reference_hides_the_background_but_not_the_emitters(make_scene):
    """Corners black, the lit sphere unchanged (the same samples: the same pixels), the emissive card and
    the area light seen directly unchanged."""
    shown, hidden = _reference(_scene(make_scene, True, name="a.toml")), _reference(_scene(make_scene, False))
    _check_pair(shown, hidden, rtol=1e-5)
    assert hidden[CARD].min() >= 4.0 and hidden[LIGHT].min() >= 3.0  # their emission (and what they reflect)


def test_the_reference_hides_it_in_its_other_integrators(make_scene):
    """The layers integrator (per-effect ground truths; alpha masks) hides it too, its emission layer
    keeping the emitters; volpath (absorbing solids) through the wrapper."""
    _, shown = _reference(_scene(make_scene, True, name="a.toml"), layers=True)[:2]
    image, hidden = _reference(_scene(make_scene, False), layers=True)[:2]
    for c in CORNERS:
        assert np.all(image[c] == 0.0) and np.all(hidden["emission"][c] == 0.0)
        np.testing.assert_allclose(shown["emission"][c], SKY, rtol=1e-3)
    np.testing.assert_allclose(hidden["emission"][CARD], 4.0, rtol=1e-5)
    np.testing.assert_allclose(hidden["direct_env"][CENTRE].mean(), shown["direct_env"][CENTRE].mean(), rtol=1e-5)

    def masked(scene):  # a masked card with holes puts the scene on the layers integrator's image alone
        card = dataclasses.replace(scene.materials["glow"], alpha_mode="mask", alpha=1.0)
        return dataclasses.replace(scene, materials={**scene.materials, "glow": card})

    def solid(scene):  # an absorbing sphere puts it on volpath
        glass = dataclasses.replace(scene.materials["grey"], transmission=1.0, thickness=1.0,
                                    attenuation_distance=1.0, attenuation_color=(0.5, 0.5, 0.5))
        return dataclasses.replace(scene, materials={**scene.materials, "grey": glass})

    for change, features in ((masked, "holes"), (solid, "volume")):
        a, b = change(_scene(make_scene, True, name="a.toml")), change(_scene(make_scene, False))
        assert getattr(b.features(), features)
        shown, hidden = _reference(a, 16), _reference(b, 16)
        for c in CORNERS:
            np.testing.assert_allclose(shown[c], SKY, rtol=1e-3)
            assert np.all(hidden[c] == 0.0)
        np.testing.assert_allclose(hidden[CARD], shown[CARD], rtol=1e-5)
        np.testing.assert_allclose(hidden[LIGHT], shown[LIGHT], rtol=1e-5)


# --------------------------------------------------------------------------------------- the rasterizer


@pytest.mark.gl
@pytest.mark.filterwarnings("ignore:emissive meshes are shown")
@pytest.mark.parametrize("first_frame", ["forward", "gbuffer"])
def test_the_rasterizer_hides_the_background(make_scene, gl_ctx, first_frame):
    """Frame 0 (forward-shaded or from the G-buffer) and the every-frame mean after it: black corners, the
    same sphere and emitters; deterministic, so equal to float precision."""
    from compare.progressive.rasterizer import render_progressive

    def render(scene, frames):
        return render_progressive(scene, frames=frames, seed=3, ctx=gl_ctx, first_frame=first_frame).image

    for frames in (1, 4):
        shown = render(_scene(make_scene, True, name="a.toml"), frames)
        hidden = render(_scene(make_scene, False), frames)
        _check_pair(shown, hidden, rtol=1e-4)


# ------------------------------------------------------------------------------------------------ Blender


@pytest.mark.bpy
@pytest.mark.parametrize("engine", ["cycles", pytest.param("eevee", marks=pytest.mark.slow)])  # EEVEE: 40 s
def test_blender_hides_the_background(make_scene, engine):
    """A transparent film: black corners (premultiplied colour), the same lit sphere and emitters (EEVEE's
    screen-space rays read the background from the screen, now black: the emissive card's glossy reflection
    of the sky behind loses a few per cent)."""
    from compare.blender import render_blender

    def render(scene):
        return render_blender(scene, engine=engine, samples=16, seed=2).image

    shown, hidden = render(_scene(make_scene, True, name="a.toml")), render(_scene(make_scene, False))
    _check_pair(shown, hidden, rtol=0.02 if engine == "cycles" else 0.05)


# ------------------------------------------------------------------------------------------- web engines

def _web_specs() -> list:
    """Every web engine of the registry and its declared variants; the default run keeps three.js and
    <model-viewer> (the fidelity page's own element), the rest are slow here (up to 3 min a page on SwiftShader)."""
    from compare.renderers.registry import Registry

    registry = Registry()
    web = [s for s in registry.specs() if type(registry.get(s)).__module__.startswith("compare.web.")]
    return [s if s in ("threejs", "model-viewer") else pytest.param(s, marks=pytest.mark.slow) for s in web]


WEB = _web_specs()


@pytest.mark.web
@pytest.mark.parametrize("engine", WEB)
def test_web_engines_hide_the_background(make_scene, web_pages, engine):
    """Each engine's own way (three's colour scene.background, no Babylon skybox, PlayCanvas' sky layer off, the
    sample viewer's renderEnvironmentMap false, no Filament skybox, <model-viewer> without skybox-image):
    black corners, the same lit sphere and emitters (those it draws)."""
    from compare.renderers.registry import Registry

    r = Registry().get(engine)
    assert "hidden_background" in r.renders
    steps = 8 if engine == "threejs-pathtracer" else 2
    shown = web_pages.prepared(r, _scene(make_scene, True, name="a.toml"), steps)[0].checkpoints[-1].image
    rendering, notes = web_pages.prepared(r, _scene(make_scene, False), steps)
    hidden = rendering.checkpoints[-1].image
    assert not any("hidden background" in n for n in notes)
    if engine == "model-viewer":  # display-encoded: the sky through its tone mapper, black stays black
        for c in CORNERS:
            assert shown[c].min() > 0.5 and np.all(hidden[c] == 0.0)
        np.testing.assert_allclose(hidden[CENTRE].mean(), shown[CENTRE].mean(), atol=2 / 255)
        return
    if engine == "threejs-pathtracer":
        # 8 independent samples a pixel (its noise differs between renders); its camera rays see no area
        # light, and its pixel filter reaches past the pixel, so the card's pixels take in some background
        _check_pair(shown, hidden, rtol=0.25, emitters=False)
        assert hidden[CARD].min() > 3.0
        return
    _check_pair(shown, hidden, rtol=1e-3, emitters=False)
    np.testing.assert_allclose(hidden[CARD], shown[CARD], rtol=1e-3)
    if r.area_lights:
        np.testing.assert_allclose(hidden[LIGHT], shown[LIGHT], rtol=1e-3)


# ------------------------------------------------------------------------------------------- a run records it


def test_a_run_records_the_renderer_that_leaves_it_out(tmp_path, make_scene):
    """Beside the ground truth, which hides the background, an in-process renderer that does not declare
    hidden_background gets the scene with it shown and its run's metadata says so; one that declares it gets
    the scene as it is and says nothing."""
    from compare.renderers import Checkpoint, Renderer, Rendering
    from compare.report.results import RunSettings
    from compare.run import runner as run_mod

    seen: dict[str, bool] = {}

    class Sky(Renderer):
        name, label, unit, portable = "sky", "Sky (test)", "sample", False

        def steps(self, settings) -> int:
            return 1

        def render(self, scene, *, steps, checkpoints, seed, context):
            seen[self.name] = scene.hides_background
            w, h = scene.camera.resolution
            return Rendering([Checkpoint(s, 0.01, np.full((h, w, 3), 0.5, np.float32)) for s in checkpoints])

    class Hider(Sky):
        name, label = "hider", "Hider (test)"
        renders = frozenset({"hidden_background"})

    path = tmp_path / "hidden.toml"
    _scene(make_scene, False, emitters=False, name=path.name)
    settings = RunSettings(frames=1, spp=4, sizes=[[16, 16]], renderers=["mitsuba", "sky", "hider"])
    res = run_mod.run([path], tmp_path / "out", settings, progress=False, report=False, renderers=[Sky(), Hider()])
    scene = res.scenes[0]
    assert seen == {"sky": False, "hider": True}
    assert "hidden background not rendered" in scene.run("sky").metadata["scene_changed"]
    assert "scene_changed" not in scene.run("hider").metadata
    assert "hidden_background" in scene.features
    assert "scene_changed" not in scene.run("mitsuba").metadata
