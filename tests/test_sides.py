"""glTF's doubleSided: a single-sided surface's back faces are culled, a double-sided one's shaded as its
front, in the ground truth, the rasterizer and the web engines; the others say they leave it out."""

from __future__ import annotations

import json

import numpy as np
import pytest

from compare.scene.loader import load_scene
from compare.util.errors import SceneError

ENV = 0.5


def _scene(make_scene, tmp_path, *, double_sided, from_behind: bool, blue_env=False):
    """A grey card (a glTF with doubleSided as given) facing +Z, seen from +Z or from behind, under a
    constant environment."""
    from compare.scene import geometry
    from compare.scene.gltf_write import GltfWriter

    w = GltfWriter()
    mat = w.material("card", (0.2, 0.2, 0.2), 0.0, 1.0)
    if double_sided is not None:
        w.doc["materials"][mat]["doubleSided"] = double_sided
    w.node("card", mesh=w.mesh("card", [(geometry.quad((1.0, 1.0)), mat)]),
           rotation=[np.sin(np.pi / 4), 0.0, 0.0, np.cos(np.pi / 4)])  # +Y normal turned to +Z
    w.write(tmp_path / "card.gltf")
    z = -2.0 if from_behind else 2.0
    return load_scene(make_scene(f"""
        include = "card.gltf"

        [camera]
        position = [0.0, 0.0, {z}]
        target = [0.0, 0.0, 0.0]
        fov = 30.0
        resolution = [16, 16]

        [environment]
        constant = [{ENV}, {ENV}, {ENV}]
        """))


def test_glTF_says_which_materials_are_single_sided(tmp_path, make_scene):
    scene = _scene(make_scene, tmp_path, double_sided=None, from_behind=False)
    assert not next(iter(scene.materials.values())).double_sided  # glTF's default
    assert scene.features().single_sided and list(scene.material_features()["single_sided"]) == ["card/card"]
    scene = _scene(make_scene, tmp_path, double_sided=True, from_behind=False)
    assert "single_sided" not in scene.material_features()
    with pytest.raises(SceneError, match=r"materials\[0\].doubleSided.*true or false"):
        _scene(make_scene, tmp_path, double_sided="yes", from_behind=False)


def _centre(image):
    return float(image[6:10, 6:10].mean())


def _reference(scene):
    from compare.mitsuba.reference import ReferenceRenderer

    return ReferenceRenderer(scene, cache_dir=False, progress=False).render(128, seed=1).image


def _rasterized(scene, gl_ctx):
    from compare.progressive.rasterizer import render_progressive

    return render_progressive(scene, frames=4, seed=1, ctx=gl_ctx).image


@pytest.mark.parametrize("renderer", ["reference", "progressive"])
def test_a_single_sided_card_seen_from_behind_is_not_there(tmp_path, make_scene, gl_ctx, renderer):
    """From behind, a single-sided card shows the environment behind it (culled); a double-sided one the
    same grey as its front (its normal turned to the viewer); from the front both are the grey card."""
    render = _reference if renderer == "reference" else (lambda s: _rasterized(s, gl_ctx))
    front = _centre(render(_scene(make_scene, tmp_path, double_sided=False, from_behind=False)))
    culled = _centre(render(_scene(make_scene, tmp_path, double_sided=False, from_behind=True)))
    back = _centre(render(_scene(make_scene, tmp_path, double_sided=True, from_behind=True)))
    double_front = _centre(render(_scene(make_scene, tmp_path, double_sided=True, from_behind=False)))
    assert culled == pytest.approx(ENV, rel=0.01)  # the background
    assert front < 0.5 * ENV and front == pytest.approx(double_front, rel=0.03)
    assert back == pytest.approx(front, rel=0.05)


def test_the_job_glTF_says_which_side_is_drawn(tmp_path, make_scene):
    from compare.renderers.job import export_gltf

    for sided in (False, True):
        scene = _scene(make_scene, tmp_path, double_sided=sided, from_behind=False)
        (tmp_path / f"job{sided}").mkdir()
        doc = json.loads(export_gltf(scene, tmp_path / f"job{sided}" / "scene.gltf").read_text())
        assert doc["materials"][0]["doubleSided"] is sided


def test_renderers_that_do_not_cull_say_so(tmp_path, make_scene):
    from compare.renderers.registry import Registry

    scene = _scene(make_scene, tmp_path, double_sided=False, from_behind=True)
    reg = Registry()
    for name in reg.builtins():
        r = reg.get(name)
        _, notes = r.prepare(scene, {"card/card": 0.3})
        said = "single sided not rendered (1 material(s), 30 % of the pixels)" in notes
        assert said == ("single_sided" not in r.renders), name
