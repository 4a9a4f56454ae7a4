"""Filament (WebAssembly) as a renderer (compare.web.filament): finite linear radiance read back in float,
framed as three.js frames the suite's camera, its IndirectLight made by the suite (orientation of the sky and
of the diffuse SH, Filament's SH convention), a punctual light in the suite's units, the missing part named."""

from __future__ import annotations

import numpy as np
import pytest

from compare.metrics.images import compare_images
from compare.scene.loader import load_scene
from compare.web.filament import FilamentRenderer
from compare.web.filament_ibl import level_roughness, sh_coefficients
from tests.helpers import (FRAMING, assert_frames_as_threejs, assert_point_light_as_threejs,
                           npm_availability, threejs_and)

#: A white rough card facing +X and one facing −Z, seen from the side, under the axes map turned 30°: its
#: lobes make the two cards' irradiance differ in colour, so a turned or mirrored SH shows.
CARDS = """
    name = "cards"
    [camera]
    position = [2.0, 0.5, 2.0]
    target = [0.0, 0.0, 0.0]
    fov = 50.0
    resolution = [48, 36]
    [environment]
    procedural = "axes"
    rotation = 30.0
    [materials.white]
    base_color = [0.8, 0.8, 0.8]
    roughness = 1.0
    [[meshes]]
    name = "facing +X"
    shape = "quad"
    material = "white"
    corners = [[0.3, -0.5, 0.5], [0.3, -0.5, -0.5], [0.3, 0.5, -0.5], [0.3, 0.5, 0.5]]
    [[meshes]]
    name = "facing +Z"
    shape = "quad"
    material = "white"
    corners = [[-0.6, -0.5, 0.3], [0.2, -0.5, 0.3], [0.2, 0.5, 0.3], [-0.6, 0.5, 0.3]]
"""


@pytest.mark.web
def test_filament_frames_the_suites_camera_as_threejs_does(make_scene, web_pages):
    """The card's silhouette lands on three.js's pixels; the sky is linear radiance 1 (exposure 1, no post
    processing); the area light is left out, with a note."""
    (ours,), _ = assert_frames_as_threejs(web_pages, load_scene(make_scene(FRAMING)), FilamentRenderer("filament"))
    assert ours.metadata["filament"] == "1.53.4" and "output" not in ours.metadata


@pytest.mark.web
def test_filament_environment_has_the_suites_orientation(make_scene, web_pages):
    """Two white cards under the axes map turned 30°: the sky behind them and the light on them (the SH
    irradiance) against three.js's (PMREM's irradiance, not SH: the cards' light agrees to a few per cent)."""
    three, ours = threejs_and(web_pages, FilamentRenderer("filament"), load_scene(make_scene(CARDS)), 4)
    flip = compare_images(three, ours)["flip"]
    assert flip < 0.08, flip
    np.testing.assert_allclose(ours.mean((0, 1)), three.mean((0, 1)), rtol=0.05)


@pytest.mark.web
def test_filament_point_light_in_the_suites_units(make_scene, web_pages):
    """The effect scene of a point light over a white rough plane, no environment: Filament's light, set
    from the job's W/sr, gives the plane the radiance three.js gives it."""
    assert_point_light_as_threejs(web_pages, make_scene, FilamentRenderer("filament"))


def test_filament_sh_of_a_constant_sky_is_its_radiance():
    """A sky of radiance L lights a white Lambert surface with L: Filament's first coefficient is L (its SH
    carry the 1/π of Lambert), the others 0; the levels' roughness is Filament's lod fit inverted."""
    from compare.ibl.irradiance import sh9_basis

    rng = np.random.default_rng(3)
    radiance_sh = rng.normal(size=(9, 3))
    sh = sh_coefficients(radiance_sh)
    n = np.array([0.3, -0.5, 0.81])
    n /= np.linalg.norm(n)
    x, y, z = n
    poly = np.array([1, y, z, x, x * y, y * z, 3 * z * z - 1, x * z, x * x - y * y])
    from compare.ibl.irradiance import sh9_irradiance

    np.testing.assert_allclose(poly @ sh, sh9_irradiance(radiance_sh, n) / np.pi, rtol=1e-5)
    assert sh9_basis(n).shape == (9,)
    r = level_roughness(5)
    np.testing.assert_allclose(4 * r * (2 - r), np.arange(5), atol=1e-12)


def test_a_missing_package_is_named(monkeypatch, tmp_path):
    ok, why = npm_availability(monkeypatch, tmp_path, FilamentRenderer("filament"))
    assert not ok and why.startswith(f"the npm package filament is not in {tmp_path / 'node_modules'}; "), why
