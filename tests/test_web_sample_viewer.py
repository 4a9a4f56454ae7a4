"""The Khronos glTF Sample Viewer as a renderer (compare.web.sample_viewer): finite linear radiance read back
in float, framed as three.js frames the suite's camera, the environment turned as the suite turns it, a
punctual light in the suite's units, its sheen table laid out as it reads it, the missing part named."""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
import pytest

from compare.image.tonemap import luminance
from compare.metrics.images import compare_images
from compare.renderers import RenderContext
from compare.report.results import RunSettings
from compare.scene.loader import load_scene
from compare.web.renderer import ThreeJsRenderer
from compare.web.sample_viewer import SampleViewerRenderer, sheen_lut_image
from test_web_model_viewer import FRAMING

EFFECTS = Path(__file__).resolve().parents[1] / "scenes" / "effects"

_CONTEXT: list[RenderContext] = []

#: The tests' spec: the viewer's IBL prefiltering at its coarse settings (seconds on SwiftShader, not minutes).
SPEC = "gltf-sample-viewer:coarse"


@pytest.fixture(scope="module", autouse=True)
def _one_browser():
    """One Chromium for every render of this module."""
    yield
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
def test_sample_viewer_frames_the_suites_camera_as_threejs_does(tmp_path):
    """The card's silhouette lands on three.js's pixels; the sky is linear radiance 1 (no tone mapping, no
    output transfer); the area light is left out, with a note."""
    scene = _scene(tmp_path, FRAMING)
    three = _render(ThreeJsRenderer("threejs"), scene)[0].checkpoints[-1].image
    ours, changed = _render(SampleViewerRenderer(SPEC), scene)
    assert changed == ["1 area light(s) not rendered (neither their light nor their face)"]
    assert ours.metadata["gltf_sample_viewer"] == "1.1.0" and "output" not in ours.metadata
    image = ours.checkpoints[-1].image
    assert image.shape == (48, 64, 3) and np.isfinite(image).all()
    mask = luminance(three) < 0.5
    assert 300 < mask.sum() < 1500
    differ = int(((luminance(image) < 0.5) != mask).sum())
    assert differ <= 12, differ  # measured: 0
    np.testing.assert_allclose(image[~mask].mean(), 1.0, rtol=0.02)


@pytest.mark.web
def test_sample_viewer_environment_has_the_suites_orientation(tmp_path):
    """The axes test map, turned 30 degrees: the background against three.js's."""
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
    ours = _render(SampleViewerRenderer(SPEC), scene, 4)[0].checkpoints[-1].image
    assert np.isfinite(ours).all()
    # the +X marker (red) at the left edge, the +Z marker (blue) at the right: a turn of the map would move
    # both the same way, so their midpoint agrees within half a pixel; each lies within 1.5 pixels, closer
    # to the centre (measured 0.8 each at this size), as the viewer's skybox vertex shader puts w + 0.1 for
    # its cube's w, which draws the background a few per cent smaller than a pinhole camera sees it
    (r3, b3), (ro, bo) = _marker_x(three), _marker_x(ours)
    assert abs((ro + bo) - (r3 + b3)) / 2 < 0.5, (r3, b3, ro, bo)
    assert abs(ro - r3) < 1.5 and abs(bo - b3) < 1.5, (r3, b3, ro, bo)
    assert ro >= r3 and bo <= b3  # drawn smaller, not shifted
    flip = compare_images(three, ours)["flip"]
    assert flip < 0.15, flip  # measured 0.11 (the smaller background; the coarse 64² cube)


def _marker_x(image: np.ndarray) -> tuple[float, float]:
    """The column centroids of the red and of the blue marker of the axes map in ``image``."""
    out = []
    for ch in (0, 2):
        others = np.delete(image, ch, axis=2).max(axis=2)
        ys, xs = np.nonzero(image[..., ch] - others > 0.15)
        assert xs.size > 5, f"no marker of channel {ch}"
        out.append(float(xs.mean()))
    return out[0], out[1]


@pytest.mark.web
def test_sample_viewer_point_light_in_the_suites_units(tmp_path):
    """The effect scene of a point light over a white rough plane, no environment: the viewer's light,
    converted from candela, gives the plane the radiance three.js gives it (both glTF's inverse square)."""
    text = (EFFECTS / "point_light.toml").read_text().replace("resolution = [96, 72]", "resolution = [32, 24]")
    scene = _scene(tmp_path, text)
    three = _render(ThreeJsRenderer("threejs"), scene)[0].checkpoints[-1].image
    ours = _render(SampleViewerRenderer(SPEC), scene)[0].checkpoints[-1].image
    assert np.isfinite(ours).all() and ours.mean() > 0.05
    np.testing.assert_allclose(ours.mean(), three.mean(), rtol=0.05)


def test_the_sheen_table_is_laid_out_as_the_viewer_reads_it():
    """Columns n·v, rows roughness from the top: the viewer reads texture(lut, vec2(n·v, roughness)) from an
    image uploaded unflipped."""
    from compare.brdf.sheen import TABLE_SIZE, albedo_table

    img = sheen_lut_image()
    assert img.shape == (TABLE_SIZE, TABLE_SIZE) and img.dtype == np.uint8
    table = albedo_table()
    i_mu, j_r = 20, 5  # row 20 of the table is n·v = 20/31, column 5 roughness 5/31
    assert img[j_r, i_mu] == round(float(table[i_mu, j_r]) * 255)


def test_a_missing_package_is_named(monkeypatch, tmp_path):
    from compare.web import host

    monkeypatch.setattr(host, "chromium_path", lambda: "/bin/sh")
    monkeypatch.setattr(host, "web_root", lambda: tmp_path)
    ok, why = SampleViewerRenderer("gltf-sample-viewer").available()
    assert not ok and why.startswith(
        f"the npm package @khronosgroup/gltf-viewer is not in {tmp_path / 'node_modules'}; "), why
