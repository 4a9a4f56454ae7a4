"""Filament (WebAssembly) as a renderer (compare.web.filament): finite linear radiance read back in float,
framed as three.js frames the suite's camera, its IndirectLight made by the suite (orientation of the sky and
of the diffuse SH, Filament's SH convention), a punctual light in the suite's units, the missing part named."""

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
from compare.web.filament import FilamentRenderer
from compare.web.filament_ibl import level_roughness, sh_coefficients
from compare.web.renderer import ThreeJsRenderer
from test_web_model_viewer import FRAMING

EFFECTS = Path(__file__).resolve().parents[1] / "scenes" / "effects"
_CONTEXT: list[RenderContext] = []

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
def test_filament_frames_the_suites_camera_as_threejs_does(tmp_path):
    """The card's silhouette lands on three.js's pixels; the sky is linear radiance 1 (exposure 1, no post
    processing); the area light is left out, with a note."""
    scene = _scene(tmp_path, FRAMING)
    three = _render(ThreeJsRenderer("threejs"), scene)[0].checkpoints[-1].image
    ours, changed = _render(FilamentRenderer("filament"), scene)
    assert changed == ["1 area light(s) not rendered (neither their light nor their face)"]
    assert ours.metadata["filament"] == "1.53.4" and "output" not in ours.metadata
    image = ours.checkpoints[-1].image
    assert image.shape == (48, 64, 3) and np.isfinite(image).all()
    mask = luminance(three) < 0.5
    assert 300 < mask.sum() < 1500
    differ = int(((luminance(image) < 0.5) != mask).sum())
    assert differ <= 12, differ  # measured: 0
    np.testing.assert_allclose(image[~mask].mean(), 1.0, rtol=0.02)


@pytest.mark.web
def test_filament_environment_has_the_suites_orientation(tmp_path):
    """Two white cards under the axes map turned 30°: the sky behind them and the light on them (the SH
    irradiance) against three.js's (PMREM's irradiance, not SH: the cards' light agrees to a few per cent)."""
    scene = _scene(tmp_path, CARDS)
    three = _render(ThreeJsRenderer("threejs"), scene, 4)[0].checkpoints[-1].image
    ours = _render(FilamentRenderer("filament"), scene, 4)[0].checkpoints[-1].image
    assert np.isfinite(ours).all()
    flip = compare_images(three, ours)["flip"]
    assert flip < 0.08, flip
    np.testing.assert_allclose(ours.mean((0, 1)), three.mean((0, 1)), rtol=0.05)


@pytest.mark.web
def test_filament_point_light_in_the_suites_units(tmp_path):
    """The effect scene of a point light over a white rough plane, no environment: Filament's light, set
    from the job's W/sr, gives the plane the radiance three.js gives it."""
    text = (EFFECTS / "point_light.toml").read_text().replace("resolution = [96, 72]", "resolution = [32, 24]")
    scene = _scene(tmp_path, text)
    three = _render(ThreeJsRenderer("threejs"), scene)[0].checkpoints[-1].image
    ours = _render(FilamentRenderer("filament"), scene)[0].checkpoints[-1].image
    assert np.isfinite(ours).all() and ours.mean() > 0.05
    np.testing.assert_allclose(ours.mean(), three.mean(), rtol=0.05)


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
    from compare.web import host

    monkeypatch.setattr(host, "chromium_path", lambda: "/bin/sh")
    monkeypatch.setattr(host, "web_root", lambda: tmp_path)
    ok, why = FilamentRenderer("filament").available()
    assert not ok and why.startswith(f"the npm package filament is not in {tmp_path / 'node_modules'}; "), why
