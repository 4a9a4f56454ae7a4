"""The job writer: the glTF and files it hands to external and web renderers, and what it never touches."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from compare.scene.loader import load_scene
from tests.helpers import COATED_SCENE, coated_model, png_bytes


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture
def coated_scene(tmp_path, make_scene):
    (tmp_path / "model").mkdir()
    coated_model(tmp_path / "model")
    return load_scene(make_scene(COATED_SCENE))


def test_the_job_glTF_is_written_where_asked_and_no_map_of_the_model_changes(tmp_path, coated_scene):
    """A material with extension maps: the job's glTF lands at the path asked for, carries both maps,
    and the model's own files are byte for byte what they were."""
    from compare.renderers.job import export_gltf
    from compare.scene.gltf_read import load_gltf

    (m,) = coated_scene.materials.values()
    assert {f for f, _, _ in m.layer_maps} == {"clearcoat", "clearcoat_roughness"}
    model = tmp_path / "model"
    before = {p.name: _digest(p) for p in model.iterdir()}
    (tmp_path / "job").mkdir()
    out = tmp_path / "job" / "scene.gltf"
    assert export_gltf(coated_scene, out) == out
    assert {p.name: _digest(p) for p in model.iterdir()} == before
    doc = json.loads(out.read_text())
    coat = doc["materials"][0]["extensions"]["KHR_materials_clearcoat"]
    assert {"clearcoatTexture", "clearcoatRoughnessTexture"} <= set(coat)
    back = load_gltf(out).materials[0]
    assert {f for f, _, _ in back.layer_images} == {"clearcoat", "clearcoat_roughness"}
    assert sorted(p.name for p in (tmp_path / "job").iterdir()) == ["scene.gltf", "texture-0.png", "texture-1.png"]


def test_the_job_writer_refuses_a_folder_where_it_would_replace_a_map(tmp_path, coated_scene):
    """A job folder that is the model's own folder: the writer stops with one message before it copies a
    map over another of the model's maps or its glTF over the model."""
    from compare.renderers.base import RendererError
    from compare.renderers.job import export_gltf

    model = tmp_path / "model"
    (model / "texture-0.png").write_bytes((model / "CoatStrength.png").read_bytes())  # a user's file
    (m,) = coated_scene.materials.values()
    before = {p.name: _digest(p) for p in model.iterdir()}
    # the copy made for the map named texture-0.png itself would be harmless; pretend the material names it
    import dataclasses

    scene = dataclasses.replace(coated_scene, materials={
        "card": dataclasses.replace(m, base_color_texture=model / "texture-0.png")})
    with pytest.raises(RendererError, match="would replace a map of the scene"):
        export_gltf(scene, model / "scene.gltf")
    with pytest.raises(RendererError, match="would replace a file of the scene"):
        export_gltf(scene, model / "texture-0.png")
    assert {p.name: _digest(p) for p in model.iterdir()} == before


def test_a_factor_baked_into_a_map_reaches_the_job_as_an_8_bit_png(tmp_path, make_scene):
    """glTF multiplies a map by its factor; the scene model bakes the product into a float EXR, which glTF
    readers cannot load (PlayCanvas: "the source image could not be decoded"). The job's glTF names PNG
    only, sRGB-encoded for a colour, equal to the baked linear values within 8-bit steps."""
    from compare.image.tonemap import srgb_decode
    from compare.renderers.job import export_gltf
    from compare.scene import geometry
    from compare.scene.gltf_write import GltfWriter
    from compare.scene.textures import load_texture

    texels = np.zeros((4, 8, 3), dtype=np.uint8)
    texels[:, :4] = [200, 120, 40]
    texels[:, 4:] = [255, 255, 255]
    w = GltfWriter()
    mat = w.material("tinted", (0.5, 0.25, 1.0), 0.0, 0.5)
    w.doc["materials"][mat]["pbrMetallicRoughness"]["baseColorTexture"] = w.texture(png_bytes(texels))
    w.node("card", mesh=w.mesh("card", [(geometry.quad((2.0, 2.0)), mat)], uvs=True))
    (tmp_path / "model").mkdir()
    w.write(tmp_path / "model" / "card.gltf")
    scene = load_scene(make_scene(COATED_SCENE))
    (m,) = scene.materials.values()
    assert m.base_color_texture.suffix == ".exr"  # the factor is baked in
    (tmp_path / "job").mkdir()
    doc = json.loads(export_gltf(scene, tmp_path / "job" / "scene.gltf").read_text())
    uris = [im["uri"] for im in doc["images"]]
    assert uris and all(u.endswith(".png") for u in uris)
    from PIL import Image

    with Image.open(tmp_path / "job" / uris[0]) as im:
        assert im.mode == "RGB" and im.size == (8, 4)
        written = srgb_decode(np.asarray(im, dtype=np.float64) / 255.0)
    baked = load_texture(m.base_color_texture, srgb=False)
    np.testing.assert_allclose(written, baked, atol=0.01)
    assert doc["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"][:3] == [1.0, 1.0, 1.0]
