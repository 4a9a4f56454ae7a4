"""The Khronos glTF Sample Viewer as a renderer (compare.web.sample_viewer): finite linear radiance read back
in float, framed as three.js frames the suite's camera, the environment turned as the suite turns it, a
punctual light in the suite's units, its sheen table laid out as it reads it, the missing part named."""

from __future__ import annotations

import numpy as np
import pytest

from compare.metrics.images import compare_images
from compare.scene.loader import load_scene
from compare.web.sample_viewer import SampleViewerRenderer, sheen_lut_image
from tests.helpers import (AXES_ENVIRONMENT, FRAMING, assert_frames_as_threejs,
                           assert_point_light_as_threejs, npm_availability, threejs_and)

#: The tests' spec: the viewer's IBL prefiltering at its coarse settings (seconds on SwiftShader, not minutes).
SPEC = "gltf-sample-viewer:coarse"


@pytest.mark.web
def test_sample_viewer_frames_the_suites_camera_as_threejs_does(make_scene, web_pages):
    """The card's silhouette lands on three.js's pixels; the sky is linear radiance 1 (no tone mapping, no
    output transfer); the area light is left out, with a note."""
    (ours,), _ = assert_frames_as_threejs(web_pages, load_scene(make_scene(FRAMING)), SampleViewerRenderer(SPEC))
    assert ours.metadata["gltf_sample_viewer"] == "1.1.0" and "output" not in ours.metadata


@pytest.mark.web
def test_sample_viewer_environment_has_the_suites_orientation(make_scene, web_pages):
    """The axes test map, turned 30 degrees: the background against three.js's."""
    three, ours = threejs_and(web_pages, SampleViewerRenderer(SPEC), load_scene(make_scene(AXES_ENVIRONMENT)), 4)
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
def test_sample_viewer_point_light_in_the_suites_units(make_scene, web_pages):
    """The effect scene of a point light over a white rough plane, no environment: the viewer's light,
    converted from candela, gives the plane the radiance three.js gives it (both glTF's inverse square)."""
    assert_point_light_as_threejs(web_pages, make_scene, SampleViewerRenderer(SPEC))


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
    ok, why = npm_availability(monkeypatch, tmp_path, SampleViewerRenderer("gltf-sample-viewer"))
    assert not ok and why.startswith(
        f"the npm package @khronosgroup/gltf-viewer is not in {tmp_path / 'node_modules'}; "), why
