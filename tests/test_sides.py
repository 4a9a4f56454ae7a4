"""glTF's doubleSided: a single-sided surface's back faces are culled, a double-sided one's shaded as its
front, in the ground truth, the rasterizer, Cycles and the web engines; the others say they leave it out."""

from __future__ import annotations

import json

import pytest

from compare.util.errors import SceneError
from tests.helpers import SIDES_ENV, centre_mean, sided_card


def test_glTF_says_which_materials_are_single_sided(tmp_path, make_scene):
    scene = sided_card(make_scene, tmp_path, double_sided=None, from_behind=False)
    assert not next(iter(scene.materials.values())).double_sided  # glTF's default
    assert scene.features().single_sided and list(scene.material_features()["single_sided"]) == ["card/card"]
    scene = sided_card(make_scene, tmp_path, double_sided=True, from_behind=False)
    assert "single_sided" not in scene.material_features()
    with pytest.raises(SceneError, match=r"materials\[0\].doubleSided.*true or false"):
        sided_card(make_scene, tmp_path, double_sided="yes", from_behind=False)


def _reference(scene):
    from compare.mitsuba.reference import ReferenceRenderer

    return ReferenceRenderer(scene, cache_dir=False, progress=False).render(128, seed=1).image


def _rasterized(scene, gl_ctx):
    from compare.progressive.rasterizer import render_progressive

    return render_progressive(scene, frames=4, seed=1, ctx=gl_ctx).image


def _cycles(scene):
    from compare.blender import render_blender

    return render_blender(scene, samples=64, seed=1).image


@pytest.mark.parametrize("renderer", ["reference", "progressive", pytest.param("cycles", marks=pytest.mark.bpy)])
def test_a_single_sided_card_seen_from_behind_is_not_there(tmp_path, make_scene, gl_ctx, renderer):
    """From behind, a single-sided card shows the environment behind it (culled); a double-sided one the
    same grey as its front (its normal turned to the viewer); from the front both are the grey card."""
    render = {"reference": _reference, "progressive": lambda s: _rasterized(s, gl_ctx), "cycles": _cycles}[renderer]
    front = centre_mean(render(sided_card(make_scene, tmp_path, double_sided=False, from_behind=False)))
    culled = centre_mean(render(sided_card(make_scene, tmp_path, double_sided=False, from_behind=True)))
    back = centre_mean(render(sided_card(make_scene, tmp_path, double_sided=True, from_behind=True)))
    double_front = centre_mean(render(sided_card(make_scene, tmp_path, double_sided=True, from_behind=False)))
    assert culled == pytest.approx(SIDES_ENV, rel=0.01)  # the background
    assert front < 0.5 * SIDES_ENV and front == pytest.approx(double_front, rel=0.03)
    assert back == pytest.approx(front, rel=0.05)


def test_the_job_glTF_says_which_side_is_drawn(tmp_path, make_scene):
    from compare.renderers.job import export_gltf

    for sided in (False, True):
        scene = sided_card(make_scene, tmp_path, double_sided=sided, from_behind=False)
        (tmp_path / f"job{sided}").mkdir()
        doc = json.loads(export_gltf(scene, tmp_path / f"job{sided}" / "scene.gltf").read_text())
        assert doc["materials"][0]["doubleSided"] is sided


def test_renderers_that_do_not_cull_say_so(tmp_path, make_scene):
    from compare.renderers.registry import Registry

    scene = sided_card(make_scene, tmp_path, double_sided=False, from_behind=True)
    reg = Registry()
    for name in reg.builtins():
        r = reg.get(name)
        _, notes = r.prepare(scene, {"card/card": 0.3})
        said = "single sided not rendered (1 material(s), 30 % of the pixels)" in notes
        assert said == ("single_sided" not in r.renders), name
