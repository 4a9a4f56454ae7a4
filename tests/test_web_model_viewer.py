"""The <model-viewer> element as a renderer (compare.web.model_viewer): as it shows a scene (8-bit sRGB,
measured with the LDR metrics only) and with tone mapping off (float readback); framed as three.js frames
the suite's camera; the environment turned as the suite turns it; the missing part named."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest

from compare.image.tonemap import luminance
from compare.metrics.images import compare_images
from compare.renderers import RenderContext, RendererError
from compare.report.results import RunSettings
from compare.scene.loader import load_scene
from compare.web.model_viewer import ModelViewerRenderer, model_viewer_environment
from compare.web.renderer import ThreeJsRenderer

_CONTEXT: list[RenderContext] = []

#: A dark, asymmetric card off the image centre under a bright sky, seen at an angle by a camera whose
#: target is not the origin, in a 4:3 image (the element fits its field of view to the model's aspect); a
#: small area light that the element leaves out.
FRAMING = """
    name = "framing"
    [camera]
    position = [1.2, 0.8, 3.0]
    target = [0.3, 0.1, 0.0]
    fov = 40.0
    resolution = [64, 48]
    [environment]
    constant = [1.0, 1.0, 1.0]
    [materials.dark]
    base_color = [0.0, 0.0, 0.0]
    roughness = 1.0
    [[meshes]]
    name = "card"
    shape = "quad"
    material = "dark"
    corners = [[-0.2, -0.5, 0.0], [0.9, -0.4, 0.0], [0.7, 0.6, 0.0], [-0.1, 0.3, 0.0]]
    [[lights]]
    name = "small"
    center = [0.0, 2.0, 1.0]
    size = [0.1, 0.1]
    normal = [0.0, -1.0, 0.0]
    radiance = [1.0, 1.0, 1.0]
"""


@pytest.fixture(scope="module", autouse=True)
def _one_browser():
    """One Chromium for every render of this module."""
    yield
    _close_shared()


def _close_shared() -> None:
    """End the shared Chromium (Playwright's sync API runs one driver per thread at a time)."""
    while _CONTEXT:
        _CONTEXT.pop().close()


def _render(renderer, scene, steps: int = 2):
    if not _CONTEXT:
        _CONTEXT.append(RenderContext(RunSettings(frames=steps)))
    given, changed = renderer.prepare(scene)
    return renderer.render(given, steps=steps, checkpoints=[steps], seed=0, context=_CONTEXT[0]), changed


def _scene(tmp_path, text: str, name: str = "s.toml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return load_scene(path)


@pytest.mark.web
def test_model_viewer_frames_the_suites_camera_as_threejs_does(tmp_path):
    """The card's silhouette in both variants lands on three.js's pixels (a pixel or two along its edges);
    the element's own view is display-encoded and says so; the area light is left out, with a note."""
    scene = _scene(tmp_path, FRAMING)
    three = _render(ThreeJsRenderer("threejs"), scene)[0].checkpoints[-1].image
    linear, changed = _render(ModelViewerRenderer("model-viewer:linear"), scene)
    shown, _ = _render(ModelViewerRenderer("model-viewer"), scene)
    assert changed == ["1 area light(s) not rendered (neither their light nor their face)"]
    assert shown.metadata["output"] == "display" and "output" not in linear.metadata
    assert shown.metadata["model_viewer"] == "4.4.0"
    mask = luminance(three) < 0.5
    assert 300 < mask.sum() < 1500  # the card covers a good part of the image, off its centre
    for rendering in (linear, shown):
        image = rendering.checkpoints[-1].image
        assert image.shape == (48, 64, 3) and np.isfinite(image).all()
        differ = int(((luminance(image) < 0.5) != mask).sum())
        assert differ <= 12, (rendering.metadata["options"], differ)
    # the sky: linear radiance 1 in the float readback; the element's neutral tone mapping shows it below 1
    sky = ~mask
    np.testing.assert_allclose(linear.checkpoints[-1].image[sky].mean(), 1.0, rtol=0.02)
    assert 0.5 < shown.checkpoints[-1].image[sky].mean() < 1.0


@pytest.mark.web
def test_model_viewer_environment_has_the_suites_orientation(tmp_path):
    """The axes test map, turned 30 degrees: the float readback's background against three.js's."""
    scene = _scene(tmp_path, """
        name = "axes environment"
        [camera]
        position = [0.0, 0.0, 0.0]
        target = [1.0, 0.3, 0.2]
        fov = 70.0
        resolution = [48, 36]
        [environment]
        procedural = "axes"
        rotation = 30.0
        [materials.m]
        base_color = [0.5, 0.5, 0.5]
        [[meshes]]
        name = "speck behind the camera"
        shape = "quad"
        material = "m"
        corners = [[-50.0, -50.0, -50.0], [-50.0, -50.01, -50.0], [-50.01, -50.01, -50.0], [-50.01, -50.0, -50.0]]
    """)
    three = _render(ThreeJsRenderer("threejs"), scene, 4)[0].checkpoints[-1].image
    ours = _render(ModelViewerRenderer("model-viewer:linear"), scene, 4)[0].checkpoints[-1].image
    # measured: 0.023 (the HDR's 8-bit mantissa, the element's PMREM-free skybox against three's)
    assert compare_images(three, ours)["flip"] < 0.06
    np.testing.assert_allclose(ours.mean((0, 1)), three.mean((0, 1)), rtol=0.03)


@pytest.mark.web
def test_a_rolled_camera_is_one_clear_error(tmp_path):
    scene = _scene(tmp_path, FRAMING.replace('fov = 40.0', 'fov = 40.0\n    up = [1.0, 1.0, 0.0]'))
    with pytest.raises(RendererError, match=r"^renderer 'model-viewer': the page failed: .*the camera is rolled"):
        _render(ModelViewerRenderer("model-viewer"), scene, 1)


@pytest.mark.web
def test_the_elements_own_view_is_measured_with_ldr_metrics_only(tmp_path, gl_ctx):
    from compare.run import runner as run_mod

    _close_shared()  # the run starts its own
    path = tmp_path / "framing.toml"
    path.write_text(textwrap.dedent(FRAMING))
    settings = RunSettings(frames=2, spp=16, renderers=["mitsuba", "model-viewer"])
    res = run_mod.run([path], tmp_path / "out", settings, progress=False, gl_ctx=gl_ctx,
                      renderers=[ModelViewerRenderer("model-viewer")], cache_dir=tmp_path / "cache")
    run = res.scenes[0].run("model-viewer")
    m = run.final.metrics
    assert m["mse"] is None and m["relmse"] is None and m["flip_hdr"] is None
    assert 0 < m["flip"] < 0.5 and m["ssim"] is not None and m["mv_rms_db"] is not None
    assert run.metadata["output"] == "display" and "area light" in run.metadata["scene_changed"]
    assert "relmse" not in run.maps and "flip" in run.maps


def test_the_environment_is_turned_for_threejs_lookup():
    """Column i of the element's map is the suite's map at u + rotation/360 − 1/4 (three.js's u is the
    suite's + 1/4): a whole roll where the shift is whole, linear between two rolls otherwise."""
    img = np.arange(128 * 256 * 3, dtype=np.float32).reshape(128, 256, 3)
    np.testing.assert_array_equal(model_viewer_environment(img, 90.0, 1.0), img)
    np.testing.assert_array_equal(model_viewer_environment(img, 0.0, 2.0), 2 * np.roll(img, 64, axis=1))
    half = model_viewer_environment(img, 90.0 + 360.0 / 512, 1.0)
    np.testing.assert_allclose(half, 0.5 * (img + np.roll(img, -1, axis=1)))
    # a constant environment's tiny map is repeated up to a width three.js prefilters
    small = model_viewer_environment(np.ones((8, 16, 3), np.float32), 90.0, 0.5)
    assert small.shape == (128, 256, 3) and np.all(small == 0.5)


def test_display_output_enters_the_ldr_metrics_as_it_is():
    from compare.image.tonemap import to_ldr

    rng = np.random.default_rng(1)
    ref = rng.uniform(0, 2, (16, 16, 3)).astype(np.float32)
    m = compare_images(ref, to_ldr(ref), display=True)
    assert m["flip"] == 0.0 and m["ssim"] == pytest.approx(1.0)
    assert m["mse"] is None and m["relmse"] is None and m["flip_hdr"] is None


def test_a_missing_package_is_named(monkeypatch, tmp_path):
    from compare.web import host

    monkeypatch.setattr(host, "chromium_path", lambda: "/bin/sh")
    monkeypatch.setattr(host, "web_root", lambda: tmp_path)
    ok, why = ModelViewerRenderer("model-viewer").available()
    assert not ok and why.startswith(f"the npm package @google/model-viewer is not in {tmp_path / 'node_modules'}; ")
    (tmp_path / "node_modules" / "@google" / "model-viewer").mkdir(parents=True)
    (tmp_path / "node_modules" / "@google" / "model-viewer" / "package.json").write_text("{}")
    ok, why = ModelViewerRenderer("model-viewer:linear").available()
    assert not ok and why.startswith("the npm package three-r183 is not in"), why
