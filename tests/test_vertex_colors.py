"""glTF's COLOR_0: vertex colours multiply the base colour (and alpha) in the ground truth and the renderers
that declare them; the others say they leave them out."""

from __future__ import annotations

import json

import numpy as np
import pytest

from compare.scene.loader import load_scene
from compare.util.errors import SceneError
from tests.helpers import COLORED_CARD_SCENE, RED_CORNERS, colored_card


@pytest.mark.parametrize("accessor", ["float", "ubyte", "ushort"])
def test_color_0_is_read_in_every_encoding(tmp_path, make_scene, accessor):
    colored_card(tmp_path, colors=RED_CORNERS, accessor=accessor)
    scene = load_scene(make_scene(COLORED_CARD_SCENE))
    (mesh,) = scene.meshes
    assert mesh.has_vertex_colors
    np.testing.assert_allclose(mesh.triangles().colors, [[1, 0, 0, 1]] * 4, atol=1e-6)
    assert scene.material_features()["vertex_colors"] == ["plane/card"]
    assert scene.features().vertex_colors


def test_white_vertex_colors_change_nothing_and_bad_ones_name_the_field(tmp_path, make_scene):
    colored_card(tmp_path, colors=[[1, 1, 1, 1]] * 4)
    assert not load_scene(make_scene(COLORED_CARD_SCENE)).meshes[0].has_vertex_colors
    colored_card(tmp_path, colors=[[1.5, 0, 0]] * 4)
    with pytest.raises(SceneError, match=r"COLOR_0.*\[0, 1\]"):
        load_scene(make_scene(COLORED_CARD_SCENE))


def _reference(scene, spp=16):
    from compare.mitsuba.reference import ReferenceRenderer

    return ReferenceRenderer(scene, cache_dir=False, progress=False).render(spp, seed=3).image


def test_the_reference_multiplies_the_base_colour_by_the_vertex_colour(tmp_path, make_scene):
    """A grey card whose vertices are red renders as the card whose base colour is that product, the same
    samples giving the same image; a card of red and blue vertices is red at one side, blue at the other."""
    colored_card(tmp_path, base=(0.8, 0.8, 0.8, 1.0), colors=RED_CORNERS)
    tinted = _reference(load_scene(make_scene(COLORED_CARD_SCENE)))
    colored_card(tmp_path, base=(0.8, 0.0, 0.0, 1.0))
    plain = _reference(load_scene(make_scene(COLORED_CARD_SCENE)))
    np.testing.assert_allclose(tinted, plain, rtol=1e-4, atol=1e-6)
    assert tinted[..., 0].mean() > 0.3 and tinted[..., 1:].max() < 0.1
    colored_card(tmp_path, base=(1.0, 1.0, 1.0, 1.0), colors=[[1, 0, 0], [0, 0, 1], [0, 0, 1], [1, 0, 0]])
    image = _reference(load_scene(make_scene(COLORED_CARD_SCENE)))
    left, right = image[6:10, 1:3].mean((0, 1)), image[6:10, 13:15].mean((0, 1))
    assert left[0] > 3 * left[2] and right[2] > 3 * right[0]


def test_the_job_glTF_carries_the_vertex_colours(tmp_path, make_scene):
    from compare.renderers.job import export_gltf
    from compare.scene.gltf_read import load_gltf

    colored_card(tmp_path, colors=RED_CORNERS)
    scene = load_scene(make_scene(COLORED_CARD_SCENE))
    (tmp_path / "job").mkdir()
    out = export_gltf(scene, tmp_path / "job" / "scene.gltf")
    assert "COLOR_0" in json.loads(out.read_text())["meshes"][0]["primitives"][0]["attributes"]
    (prim,) = load_gltf(out).primitives
    np.testing.assert_allclose(prim.mesh.colors, [[1, 0, 0, 1]] * 4, atol=1e-6)


def test_a_renderer_that_does_not_draw_them_says_so(tmp_path, make_scene):
    from compare.renderers.registry import Registry

    colored_card(tmp_path, colors=RED_CORNERS)
    scene = load_scene(make_scene(COLORED_CARD_SCENE))
    reg = Registry()
    _, notes = reg.get("mitsuba").prepare(scene, {"plane/card": 1.0})
    assert notes == []
    for name in reg.builtins():
        r = reg.get(name)
        _, notes = r.prepare(scene, {"plane/card": 1.0})
        said = "vertex colors not rendered (1 material(s), 100 % of the pixels)" in notes
        assert said == ("vertex_colors" not in r.renders), name


def _rasterized(scene, gl_ctx, frames=4):
    from compare.progressive.rasterizer import render_progressive

    return render_progressive(scene, frames=frames, seed=3, ctx=gl_ctx).image


def test_the_rasterizer_multiplies_the_base_colour_by_the_vertex_colour(tmp_path, make_scene, gl_ctx):
    colored_card(tmp_path, base=(0.8, 0.8, 0.8, 1.0), colors=RED_CORNERS)
    tinted = _rasterized(load_scene(make_scene(COLORED_CARD_SCENE)), gl_ctx)
    colored_card(tmp_path, base=(0.8, 0.0, 0.0, 1.0))
    plain = _rasterized(load_scene(make_scene(COLORED_CARD_SCENE)), gl_ctx)
    np.testing.assert_allclose(tinted, plain, rtol=1e-5, atol=1e-6)
    assert tinted[..., 0].mean() > 0.3 and tinted[..., 1:].max() < 0.1
    colored_card(tmp_path, base=(1.0, 1.0, 1.0, 1.0), colors=[[1, 0, 0], [0, 0, 1], [0, 0, 1], [1, 0, 0]])
    image = _rasterized(load_scene(make_scene(COLORED_CARD_SCENE)), gl_ctx)
    left, right = image[6:10, 1:3].mean((0, 1)), image[6:10, 13:15].mean((0, 1))
    assert left[0] > 3 * left[2] and right[2] > 3 * right[0]


@pytest.mark.bpy
def test_cycles_multiplies_the_base_colour_by_the_vertex_colour(tmp_path, make_scene):
    """Blender gets COLOR_0 as a colour attribute that multiplies the base colour: the grey card with red
    corners renders as the red card, and a red-to-blue blend parts left from right."""
    from compare.blender import render_blender

    def cycles(scene):
        return render_blender(scene, samples=64, seed=2).image

    colored_card(tmp_path, base=(0.8, 0.8, 0.8, 1.0), colors=RED_CORNERS)
    tinted = cycles(load_scene(make_scene(COLORED_CARD_SCENE)))
    colored_card(tmp_path, base=(0.8, 0.0, 0.0, 1.0))
    plain = cycles(load_scene(make_scene(COLORED_CARD_SCENE)))
    np.testing.assert_allclose(tinted[4:12, 4:12].mean((0, 1)), plain[4:12, 4:12].mean((0, 1)), rtol=0.03, atol=0.003)
    assert tinted[4:12, 4:12, 0].mean() > 5 * tinted[4:12, 4:12, 1].mean()
    colored_card(tmp_path, base=(1.0, 1.0, 1.0, 1.0), colors=[[1, 0, 0], [0, 0, 1], [0, 0, 1], [1, 0, 0]])
    image = cycles(load_scene(make_scene(COLORED_CARD_SCENE)))
    left, right = image[6:10, 1:3].mean((0, 1)), image[6:10, 13:15].mean((0, 1))
    assert left[0] > 3 * left[2] and right[2] > 3 * right[0]


def test_a_blended_cards_vertex_alpha_is_its_coverage(tmp_path, make_scene, gl_ctx):
    """alphaMode BLEND with a vertex alpha of 0.25: a quarter of the card's colour over the background in
    the reference and the rasterizer alike (glTF multiplies the alpha by the vertex colour's)."""
    colored_card(tmp_path, base=(0.0, 0.0, 0.0, 1.0), colors=[[1, 1, 1, 0.25]] * 4, alpha_mode="BLEND")
    scene = load_scene(make_scene(COLORED_CARD_SCENE))
    colored_card(tmp_path, base=(0.0, 0.0, 0.0, 0.25), alpha_mode="BLEND")
    factor = load_scene(make_scene(COLORED_CARD_SCENE))
    for render in (lambda s: _reference(s, spp=64), lambda s: _rasterized(s, gl_ctx)):
        a, b = float(render(scene)[4:12, 4:12].mean()), float(render(factor)[4:12, 4:12].mean())
        assert a == pytest.approx(b, rel=0.03) and 0.6 < a < 0.9  # 3/4 of the background comes through

