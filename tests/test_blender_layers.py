"""glTF's anisotropy and iridescence in Blender Cycles (Principled's Anisotropic inputs and Thin Film, set by
compare.blender.export): on a sphere in the studio map, what each changes in Cycles' image correlates with
what it changes in the reference's; EEVEE, whose image does not change with them, declares them left out."""

from __future__ import annotations

import numpy as np
import pytest

from tests.helpers import sphere_scene

CASES = {
    "anisotropy": ("base_color = [0.9, 0.9, 0.9]\nmetallic = 1.0\nroughness = 0.3",
                   "anisotropy_strength = 0.9\nanisotropy_rotation = 0.0",
                   "anisotropy_strength = 0.9\nanisotropy_rotation = 1.5708", 0.9),
    "iridescence": ("base_color = [0.05, 0.05, 0.05]\nmetallic = 0.0\nroughness = 0.2",
                    "iridescence = 1.0\niridescence_thickness_max = 400.0",
                    "iridescence = 0.5\niridescence_thickness_max = 700.0", 0.5),
}


def _sphere(make_scene, material: str, name: str):
    return sphere_scene(make_scene, material, name="m", fov=22.0, size=40, depth=8, file=f"{name}.toml",
                        environment='procedural = "studio"\nwidth = 128')


def _correlation(a, b) -> float:
    a, b = a.ravel() - a.mean(), b.ravel() - b.mean()
    return float(a @ b / np.sqrt((a @ a) * (b @ b) + 1e-30))


@pytest.mark.bpy
@pytest.mark.parametrize("feature", sorted(CASES))
def test_cycles_draws_the_feature_as_the_reference_changes(make_scene, feature):
    from compare.blender.render import render_blender
    from compare.mitsuba.reference import ReferenceRenderer

    base, first, second, least = CASES[feature]
    images = {}
    for name, extra in (("plain", ""), ("first", first), ("second", second)):
        scene = _sphere(make_scene, base + "\n" + extra, name)
        assert (name == "plain") != (feature in scene.features().names())
        images[name] = (ReferenceRenderer(scene).render(spp=128, seed=1).image,
                        render_blender(scene, engine="cycles", samples=64).image)
    for name in ("first", "second"):
        change = [images[name][i] - images["plain"][i] for i in (0, 1)]
        assert np.abs(change[1]).mean() > 0.25 * np.abs(change[0]).mean()  # it is drawn, not a trace of noise
        assert _correlation(*change) > least, name
    apart = [images["first"][i] - images["second"][i] for i in (0, 1)]
    assert _correlation(*apart) > 0.8


def test_eevee_declares_what_it_leaves_out():
    from compare.renderers.registry import Registry

    registry = Registry()
    assert {"anisotropy", "iridescence", "dispersion"} <= set(registry.get("cycles").renders)
    assert not {"anisotropy", "iridescence", "dispersion"} & set(registry.get("eevee").renders)
