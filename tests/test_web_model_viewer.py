"""The <model-viewer> element as a renderer (compare.web.model_viewer): as it shows a scene (8-bit sRGB,
measured with the LDR metrics only) and with tone mapping off (float readback); framed as three.js frames
the suite's camera; the environment turned as the suite turns it; the missing part named."""

from __future__ import annotations

import numpy as np
import pytest

from compare.metrics.images import compare_images
from compare.renderers import RendererError
from compare.report.results import RunSettings
from compare.scene.loader import load_scene
from compare.web.model_viewer import ModelViewerRenderer, model_viewer_environment
from tests.helpers import (AXES_ENVIRONMENT, FRAMING, assert_frames_as_threejs, npm_availability,
                           threejs_and)


@pytest.mark.web
def test_model_viewer_frames_the_suites_camera_as_threejs_does(make_scene, web_pages):
    """The card's silhouette in both variants lands on three.js's pixels (a pixel or two along its edges);
    the element's own view is display-encoded and says so; the area light is left out, with a note."""
    (linear, shown), mask = assert_frames_as_threejs(web_pages, load_scene(make_scene(FRAMING)),
                                                     ModelViewerRenderer("model-viewer:linear"),
                                                     ModelViewerRenderer("model-viewer"))
    assert shown.metadata["output"] == "display" and "output" not in linear.metadata
    assert shown.metadata["model_viewer"] == "4.4.0"
    # the sky: linear radiance 1 in the float readback (checked above); the element's neutral tone mapping
    # shows it below 1
    assert 0.5 < shown.checkpoints[-1].image[~mask].mean() < 1.0


@pytest.mark.web
def test_model_viewer_environment_has_the_suites_orientation(make_scene, web_pages):
    """The axes test map, turned 30 degrees: the float readback's background against three.js's."""
    three, ours = threejs_and(web_pages, ModelViewerRenderer("model-viewer:linear"),
                              load_scene(make_scene(AXES_ENVIRONMENT)), 4)
    # measured: 0.023 (the HDR's 8-bit mantissa, the element's PMREM-free skybox against three's)
    assert compare_images(three, ours)["flip"] < 0.06
    np.testing.assert_allclose(ours.mean((0, 1)), three.mean((0, 1)), rtol=0.03)


@pytest.mark.web
def test_a_rolled_camera_is_one_clear_error(make_scene, web_pages):
    scene = load_scene(make_scene(FRAMING.replace('fov = 40.0', 'fov = 40.0\n    up = [1.0, 1.0, 0.0]')))
    with pytest.raises(RendererError, match=r"^renderer 'model-viewer': the page failed: .*the camera is rolled"):
        web_pages.prepared(ModelViewerRenderer("model-viewer"), scene, 1)


@pytest.mark.web
def test_the_elements_own_view_is_measured_with_ldr_metrics_only(tmp_path, make_scene, gl_ctx, web_pages):
    from compare.run import runner as run_mod

    web_pages.close()  # the run starts its own
    path = make_scene(FRAMING, name="framing.toml")
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
    ok, why = npm_availability(monkeypatch, tmp_path, ModelViewerRenderer("model-viewer"))
    assert not ok and why.startswith(f"the npm package @google/model-viewer is not in {tmp_path / 'node_modules'}; ")
    ok, why = npm_availability(monkeypatch, tmp_path, ModelViewerRenderer("model-viewer:linear"), "@google/model-viewer")
    assert not ok and why.startswith("the npm package three-r183 is not in"), why
