"""KHR_materials_unlit: the base colour is what is seen, whatever lights the scene. The reader converts it
to the emission of a black, non-specular surface, which every renderer draws."""

from __future__ import annotations

import numpy as np
import pytest

from compare.scene.loader import load_scene
from tests.helpers import facing_scene

#: Under a bright area light and a grey sky: an unlit card must show its base colour all the same.
SCENE = facing_scene("card.gltf", sky=0.5, extra="""
    [[lights]]
    name = "lamp"
    center = [0.0, 2.0, 1.0]
    size = [0.5, 0.5]
    normal = [0.0, -0.894, -0.447]
    radiance = [50.0, 50.0, 50.0]
    """)
BASE = (0.6, 0.2, 0.05, 1.0)


def unlit_card(folder, base=BASE, *, unlit=True, metallic=0.0, roughness=0.3):
    """A glTF card facing +Z filling the view, its material unlit (or not)."""
    from compare.scene.gltf_write import GltfWriter

    w = GltfWriter()
    mat = w.material("card", base[:3], metallic, roughness)
    w.doc["materials"][mat]["pbrMetallicRoughness"]["baseColorFactor"] = list(base)
    if unlit:
        w.doc["materials"][mat]["extensions"] = {"KHR_materials_unlit": {}}
        w._use("KHR_materials_unlit")  # noqa: SLF001
    pos = np.array([[-2, -2, 0], [2, -2, 0], [2, 2, 0], [-2, 2, 0]], dtype=np.float32)
    attrs = {"POSITION": w.accessor(pos, bounds=True),
             "NORMAL": w.accessor(np.tile([[0, 0, 1]], (4, 1)).astype(np.float32))}
    idx = w.accessor(np.array([[0, 1, 2], [0, 2, 3]], dtype=np.uint32), indices=True)
    w._add("meshes", {"name": "card", "primitives": [{"attributes": attrs, "indices": idx,  # noqa: SLF001
                                                       "material": mat}]})
    w.node("card", mesh=0)
    return w.write(folder / "card.gltf")


def _reference(scene, spp=16):
    from compare.mitsuba.reference import ReferenceRenderer

    return ReferenceRenderer(scene, cache_dir=False, progress=False).render(spp, seed=3).image


def test_the_reader_converts_and_says_so(tmp_path, make_scene):
    unlit_card(tmp_path)
    with pytest.warns(UserWarning, match="KHR_materials_unlit: converted"):
        scene = load_scene(make_scene(SCENE))
    (m,) = scene.materials.values()
    assert m.base_color == (0.0, 0.0, 0.0) and m.emission == pytest.approx(BASE[:3])
    assert m.metallic == 0.0 and m.specular == 0.0


def test_the_reference_shows_the_base_colour_whatever_the_light(tmp_path, make_scene):
    unlit_card(tmp_path)
    image = _reference(load_scene(make_scene(SCENE)))
    np.testing.assert_allclose(image[2:14, 2:14].reshape(-1, 3), np.tile(BASE[:3], (144, 1)), rtol=1e-5)
    unlit_card(tmp_path, unlit=False)  # lit, the same card is far from it
    lit = _reference(load_scene(make_scene(SCENE)))
    assert np.abs(lit[2:14, 2:14].mean((0, 1)) - BASE[:3]).max() > 0.1 * max(BASE[:3])


def test_the_rasterizer_shows_the_base_colour_whatever_the_light(tmp_path, make_scene, gl_ctx):
    from compare.progressive.rasterizer import render_progressive

    unlit_card(tmp_path)
    image = render_progressive(load_scene(make_scene(SCENE)), frames=4, seed=3, ctx=gl_ctx).image
    np.testing.assert_allclose(image[2:14, 2:14].reshape(-1, 3), np.tile(BASE[:3], (144, 1)), rtol=2e-3, atol=1e-4)


def test_the_jobs_gltf_draws_it_unshaded(tmp_path, make_scene):
    """What external and web renderers receive: black, non-specular, emitting the base colour."""
    import json

    from compare.renderers.job import export_gltf

    unlit_card(tmp_path)
    doc = json.loads(export_gltf(load_scene(make_scene(SCENE)), tmp_path / "job" / "scene.gltf").read_text())
    (m,) = doc["materials"]
    assert m["pbrMetallicRoughness"]["baseColorFactor"][:3] == [0.0, 0.0, 0.0]
    assert m["emissiveFactor"] == pytest.approx(list(BASE[:3]))
    assert m["extensions"]["KHR_materials_specular"]["specularFactor"] == 0.0
