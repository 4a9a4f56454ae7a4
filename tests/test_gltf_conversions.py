"""glTF features the reader converts into the scene model, so that every renderer gets them: spec-gloss
materials (as glTF-Transform's metalRough()), morph targets at their default weights, and skins posed by their
joints' node transforms (compare.scene.gltf_specgloss, compare.scene.gltf_pose)."""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest

from compare.scene.gltf_read import load_gltf
from compare.scene.gltf_write import GltfWriter
from compare.scene.loader import load_scene
from compare.util.errors import SceneError

SCENE = """
    include = "plane.gltf"

    [camera]
    position = [0.0, 0.0, 4.0]
    target = [0.0, 0.0, 0.0]
    fov = 40.0
    resolution = [8, 8]

    [environment]
    constant = [1.0, 1.0, 1.0]
    """
SPEC_GLOSS = "KHR_materials_pbrSpecularGlossiness"
#: The card's corners (facing +Z, counter-clockwise seen from +Z) and its texture coordinates.
CORNERS = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], dtype=np.float64)
UVS = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], dtype=np.float32)


def _load(make_scene):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = load_scene(make_scene(SCENE))
    return scene, [str(w.message) for w in caught]


def _card(w: GltfWriter, material: int | None = None) -> dict:
    """One primitive of the card (positions, normals, texture coordinates, indices) in the writer's buffer."""
    attrs = {"POSITION": w.accessor(CORNERS.astype(np.float32), bounds=True),
             "NORMAL": w.accessor(np.tile([[0.0, 0.0, 1.0]], (4, 1)).astype(np.float32)),
             "TEXCOORD_0": w.accessor(UVS)}
    prim = {"attributes": attrs, "indices": w.accessor(np.array([[0, 1, 2], [0, 2, 3]], np.uint32), indices=True)}
    if material is not None:
        prim["material"] = material
    return prim


def _ints(w: GltfWriter, values, ctype: int = 5121) -> int:
    """An unsigned-byte (5121) or -short (5123) VEC4 accessor, as JOINTS_n are stored."""
    data = np.asarray(values, dtype=np.uint8 if ctype == 5121 else np.uint16)
    return w._add("accessors", {"bufferView": w.view(data.tobytes()), "componentType": ctype,  # noqa: SLF001
                                "count": len(data), "type": "VEC4"})


def _mat4s(w: GltfWriter, matrices) -> int:
    """A MAT4 accessor of ``matrices`` (n, 4, 4), column-major as glTF stores them."""
    data = np.asarray(matrices, dtype=np.float32).transpose(0, 2, 1).copy()
    return w._add("accessors", {"bufferView": w.view(data.tobytes()), "componentType": 5126,  # noqa: SLF001
                                "count": len(data), "type": "MAT4"})


def _write(w: GltfWriter, folder, edit=None):
    """Write the document as ``plane.gltf``, after ``edit(doc)`` changes its JSON."""
    doc = w.document(embed_buffer=True)
    if edit:
        edit(doc)
    (folder / "plane.gltf").write_text(json.dumps(doc), encoding="utf-8")
    return folder / "plane.gltf"


# ----------------------------------------------------------------------------- KHR_materials_pbrSpecularGlossiness


def _spec_gloss(folder, ext: dict, *, fallback: bool = True, edit=None):
    """The card with one spec-gloss material ``ext`` (and a green metal pbrMetallicRoughness fallback)."""
    w = GltfWriter()
    m = {"name": "card", "extensions": {SPEC_GLOSS: ext}}
    if fallback:  # what a reader without the extension draws: it must not be what this one draws
        m["pbrMetallicRoughness"] = {"baseColorFactor": [0.0, 1.0, 0.0, 1.0], "metallicFactor": 1.0,
                                     "roughnessFactor": 0.0}
    w._use(SPEC_GLOSS)  # noqa: SLF001
    mat = w._add("materials", m)  # noqa: SLF001
    w._add("meshes", {"name": "card", "primitives": [_card(w, mat)]})  # noqa: SLF001
    w.node("card", mesh=0)
    return _write(w, folder, edit)


def test_spec_gloss_factors_become_metal_rough_with_specular_colour_and_ior(tmp_path, make_scene):
    """diffuse → base colour and alpha, roughness 1 − glossiness, metallic 0, KHR_materials_specular's colour =
    the specular factor (its factor 1) and ior 1000 (F0 = 0.996 × the specular colour): glTF-Transform's
    metalRough(); the fallback is not read, and the scene's notes say the extension was converted."""
    _spec_gloss(tmp_path, {"diffuseFactor": [0.8, 0.2, 0.2, 0.75], "specularFactor": [0.04, 0.05, 0.06],
                           "glossinessFactor": 0.7})
    scene, notes = _load(make_scene)
    mat = scene.materials["plane/card"]
    assert mat.base_color == pytest.approx((0.8, 0.2, 0.2)) and mat.alpha == pytest.approx(0.75)
    assert mat.metallic == 0.0 and mat.roughness == pytest.approx(0.3)
    assert mat.specular == 1.0 and mat.specular_color == pytest.approx((0.04, 0.05, 0.06))
    assert mat.ior == 1000.0 and ((mat.ior - 1) / (mat.ior + 1)) ** 2 == pytest.approx(0.996, abs=1e-4)
    assert mat.base_color_texture is None and mat.metallic_roughness_texture is None and mat.layer_maps == ()
    assert {"specular", "ior"} <= mat.uses()  # a renderer that leaves them out says so
    assert any(SPEC_GLOSS in n and "converted" in n for n in notes)
    assert not any("ignored" in n for n in notes)
    fate = load_gltf(tmp_path / "plane.gltf").extension_fates()[SPEC_GLOSS]
    assert fate.startswith("converted")


def test_spec_gloss_defaults_and_a_required_extension(tmp_path, make_scene):
    """glTF's defaults (diffuse 1, specular 1, glossiness 1): white, roughness 0, a white specular colour;
    a file that requires the extension is read, not refused."""
    _spec_gloss(tmp_path, {}, fallback=False, edit=lambda d: d.update(extensionsRequired=[SPEC_GLOSS]))
    mat = _load(make_scene)[0].materials["plane/card"]
    assert (mat.base_color, mat.metallic, mat.roughness, mat.specular_color) == ((1, 1, 1), 0.0, 0.0, (1, 1, 1))


def test_spec_gloss_maps_are_the_base_colour_specular_colour_and_a_baked_roughness_map(tmp_path, make_scene):
    """diffuseTexture × diffuseFactor is the base-colour map (baked, as every factor beside a map is); the
    specularGlossinessTexture's RGB is the specular-colour map (sRGB) and 1 − glossinessFactor × its alpha
    the roughness map (G; metallic B = 0), with roughness factor 1."""
    from PIL import Image

    from compare.image.tonemap import srgb_decode
    from compare.scene.textures import load_alpha, load_texture

    diffuse = np.zeros((2, 2, 4), np.uint8)
    diffuse[...] = (200, 100, 50, 255)
    sg = np.zeros((2, 2, 4), np.uint8)
    sg[...] = (10, 20, 30, 204)
    sg[0, 1, 3] = 51
    Image.fromarray(diffuse, "RGBA").save(tmp_path / "diffuse.png")
    Image.fromarray(sg, "RGBA").save(tmp_path / "sg.png")

    def maps(doc):
        doc["images"] = [{"uri": "diffuse.png"}, {"uri": "sg.png"}]
        doc["textures"] = [{"source": 0}, {"source": 1}]

    _spec_gloss(tmp_path, {"diffuseFactor": [0.5, 1.0, 1.0, 1.0], "diffuseTexture": {"index": 0},
                           "specularFactor": [0.5, 0.5, 0.5], "glossinessFactor": 0.5,
                           "specularGlossinessTexture": {"index": 1}}, edit=maps)
    mat = _load(make_scene)[0].materials["plane/card"]
    assert mat.metallic == 0.0 and mat.roughness == 1.0
    np.testing.assert_allclose(load_texture(mat.base_color_texture, srgb=True)[0, 0],
                               srgb_decode(np.array([200, 100, 50]) / 255.0) * [0.5, 1.0, 1.0], rtol=1e-6)
    rough = load_texture(mat.metallic_roughness_texture, srgb=False)
    np.testing.assert_allclose(rough[..., 1], [[1 - 0.5 * 204 / 255, 1 - 0.5 * 51 / 255],
                                               [1 - 0.5 * 204 / 255, 1 - 0.5 * 204 / 255]], rtol=1e-6)
    assert np.all(rough[..., 2] == 0.0)
    assert mat.specular_color == pytest.approx((0.5, 0.5, 0.5)) and mat.specular == 1.0
    ((fld, channel, path),) = mat.layer_maps
    assert (fld, channel, path.name) == ("specular_color", "rgb", "sg.png")
    np.testing.assert_allclose(load_texture(path, srgb=True)[0, 0], srgb_decode(np.array([10, 20, 30]) / 255.0),
                               rtol=1e-6)
    assert load_alpha(path)[0, 1] == pytest.approx(51 / 255)  # the glossiness is the roughness map's, not a colour's


@pytest.mark.parametrize("ext, field", [
    ({"glossinessFactor": 2.0}, "glossinessFactor"),
    ({"diffuseFactor": [0.8, 0.2, 0.2]}, "diffuseFactor"),
    ({"specularFactor": [0.04, "x", 0.04]}, "specularFactor"),
])
def test_bad_spec_gloss_factors_are_one_error_naming_the_field(tmp_path, make_scene, ext, field):
    _spec_gloss(tmp_path, ext)
    with pytest.raises(SceneError, match=rf"materials\[0\]\.extensions\.{SPEC_GLOSS}\.{field}: expected"):
        _load(make_scene)


# ----------------------------------------------------------------------------- morph targets


def _morphed(folder, *, mesh_weights=None, node_weights=None, count: int = 4, edit=None):
    """The card with one morph target moving every vertex by (0, 0, 2) and tilting its normal to +X."""
    w = GltfWriter()
    prim = _card(w)
    prim["targets"] = [{"POSITION": w.accessor(np.tile([[0.0, 0.0, 2.0]], (count, 1)).astype(np.float32), bounds=True),
                        "NORMAL": w.accessor(np.tile([[1.0, 0.0, -1.0]], (count, 1)).astype(np.float32))}]
    mesh = {"name": "card", "primitives": [prim]}
    if mesh_weights is not None:
        mesh["weights"] = mesh_weights
    w._add("meshes", mesh)  # noqa: SLF001
    w.node("card", mesh=0)
    if node_weights is not None:
        w.doc["nodes"][0]["weights"] = node_weights
    return _write(w, folder, edit)


def test_a_morph_target_at_weight_half_moves_the_vertices_half_way(tmp_path, make_scene):
    _morphed(tmp_path, mesh_weights=[0.5])
    scene, notes = _load(make_scene)
    tri = scene.meshes[0].triangles()
    np.testing.assert_allclose(tri.positions, CORNERS + [0.0, 0.0, 1.0], atol=1e-6)
    np.testing.assert_allclose(tri.normals, [[1 / math.sqrt(2), 0.0, 1 / math.sqrt(2)]] * 4, atol=1e-6)
    assert not any("morph" in n for n in notes)


def test_a_nodes_weights_override_its_meshes_and_none_is_zero(tmp_path, make_scene):
    _morphed(tmp_path, mesh_weights=[0.5], node_weights=[1.0])
    np.testing.assert_allclose(_load(make_scene)[0].meshes[0].triangles().positions, CORNERS + [0, 0, 2], atol=1e-6)
    _morphed(tmp_path)
    np.testing.assert_allclose(_load(make_scene)[0].meshes[0].triangles().positions, CORNERS, atol=1e-6)


@pytest.mark.parametrize("kwargs, field, message", [
    (dict(mesh_weights=[0.5], count=3), r"meshes\[0\]\.primitives\[0\]\.targets\[0\]\.POSITION",
     "3 elements, but the primitive's POSITION has 4"),
    (dict(mesh_weights=[0.5, 0.5]), r"meshes\[0\]\.weights", "expected 1 finite numbers"),
    (dict(node_weights=[float("nan")]), r"nodes\[0\]\.weights", "expected 1 finite numbers"),
])
def test_bad_morph_targets_or_weights_are_one_error_naming_the_field(tmp_path, make_scene, kwargs, field, message):
    _morphed(tmp_path, **kwargs)
    with pytest.raises(SceneError, match=rf"{field}: {message}"):
        _load(make_scene)


# ----------------------------------------------------------------------------- skins

ROT_X_90 = [math.sin(math.pi / 4), 0.0, 0.0, math.cos(math.pi / 4)]  # +Y → +Z, +Z → −Y


def _skinned(folder, *, joints=((0, 0, 0, 0),) * 4, weights=((1, 0, 0, 0),) * 4, joint_nodes=None, root=None,
             inverse_binds=None, mesh_translation=(5.0, 0.0, 0.0), edit=None):
    """The card skinned to the joints ``joint_nodes`` (node keywords: rotation, translation, scale, matrix),
    children of one node "skeleton" translated by ``root``; the mesh's own node is translated by
    ``mesh_translation`` (which a skin ignores)."""
    w = GltfWriter()
    prim = _card(w)
    prim["attributes"]["JOINTS_0"] = _ints(w, joints)
    prim["attributes"]["WEIGHTS_0"] = w.accessor(np.asarray(weights, dtype=np.float32))
    w._add("meshes", {"name": "card", "primitives": [prim]})  # noqa: SLF001
    ids = [w.node(f"joint{k}", **spec) for k, spec in enumerate(joint_nodes or [{"rotation": ROT_X_90}])]
    w.node("skeleton", translation=root, children=tuple(ids))
    w.node("card", mesh=0, translation=mesh_translation)
    skin = {"joints": ids}
    if inverse_binds is not None:
        skin["inverseBindMatrices"] = _mat4s(w, inverse_binds)
    w._add("skins", skin)  # noqa: SLF001
    w.doc["nodes"][-1]["skin"] = 0
    return _write(w, folder, edit)


def test_a_skinned_card_is_posed_by_its_joint_and_not_by_its_own_node(tmp_path, make_scene):
    """One joint rotated 90° about X under a parent at (0, 1, 0), inverse bind identity: every vertex is
    rotated and lifted, the normal turned to −Y; the mesh node's translation (5, 0, 0) does not apply."""
    _skinned(tmp_path, joint_nodes=[{"rotation": ROT_X_90}], root=(0.0, 1.0, 0.0))
    scene, notes = _load(make_scene)
    tri = scene.meshes[0].triangles()
    x, y, z = CORNERS.T
    np.testing.assert_allclose(tri.positions, np.stack([x, 1.0 - z, y], axis=1), atol=1e-6)
    np.testing.assert_allclose(tri.normals, [[0.0, -1.0, 0.0]] * 4, atol=1e-6)
    assert not any("skin" in n for n in notes)


def test_inverse_bind_matrices_that_undo_the_joint_give_the_meshs_own_vertices(tmp_path, make_scene):
    from compare.scene import geometry

    joint = geometry.transform_matrix(translate=(0.0, 1.0, 0.0), rotate=(90.0, 0.0, 0.0))
    _skinned(tmp_path, joint_nodes=[{"matrix": joint}], inverse_binds=[np.linalg.inv(joint)])
    tri = _load(make_scene)[0].meshes[0].triangles()
    np.testing.assert_allclose(tri.positions, CORNERS, atol=1e-6)
    np.testing.assert_allclose(tri.normals, [[0.0, 0.0, 1.0]] * 4, atol=1e-6)


def test_skin_weights_blend_the_joints(tmp_path, make_scene):
    """Half to a joint at rest, half to one 2 m up: the card moves 1 m up; weights summing to 2 are
    renormalised (with a note)."""
    _skinned(tmp_path, joints=[(0, 1, 0, 0)] * 4, weights=[(0.5, 0.5, 0, 0)] * 4,
             joint_nodes=[{}, {"translation": (0.0, 2.0, 0.0)}])
    np.testing.assert_allclose(_load(make_scene)[0].meshes[0].triangles().positions, CORNERS + [0, 1, 0], atol=1e-6)
    _skinned(tmp_path, joints=[(0, 1, 0, 0)] * 4, weights=[(1.0, 1.0, 0, 0)] * 4,
             joint_nodes=[{}, {"translation": (0.0, 2.0, 0.0)}])
    scene, notes = _load(make_scene)
    np.testing.assert_allclose(scene.meshes[0].triangles().positions, CORNERS + [0, 1, 0], atol=1e-6)
    assert any("WEIGHTS_0" in n and "renormalised" in n for n in notes)


def test_a_mirroring_joint_keeps_the_faces_front_facing(tmp_path, make_scene):
    """A joint scaled by −1 along X mirrors the card: its triangles' winding turns with it, so that the
    faces' normals (from the winding) agree with the vertex normals."""
    _skinned(tmp_path, joint_nodes=[{"scale": (-1.0, 1.0, 1.0)}])
    tri = _load(make_scene)[0].meshes[0].triangles()
    np.testing.assert_allclose(tri.positions, CORNERS * [-1, 1, 1], atol=1e-6)
    p = tri.positions[tri.indices]
    face = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    assert np.all(np.einsum("ij,ij->i", face, tri.normals[tri.indices[:, 0]]) > 0)


def _no_joints(doc):
    attrs = doc["meshes"][0]["primitives"][0]["attributes"]
    del attrs["JOINTS_0"], attrs["WEIGHTS_0"]


@pytest.mark.parametrize("kwargs, field, message", [
    (dict(joints=[(0, 0, 0, 0), (0, 0, 0, 0), (3, 0, 0, 0), (0, 0, 0, 0)]), r"attributes\.JOINTS_0",
     "1 vertices name a joint that is not an index into the skin's 1 joints"),
    (dict(weights=[(0, 0, 0, 0)] * 4), r"attributes\.WEIGHTS_0", "4 vertices have weights summing to 0"),
    (dict(weights=[(-1, 2, 0, 0)] * 4), r"attributes\.WEIGHTS_0", "4 vertices have a weight that is negative"),
    (dict(edit=_no_joints), r"meshes\[0\]\.primitives\[0\]\.attributes", "its node has a skin, but"),
    (dict(inverse_binds=np.zeros((0, 4, 4))), r"skins\[0\]\.inverseBindMatrices", "0 matrices for the skin's 1"),
    (dict(edit=lambda d: d["scenes"][0]["nodes"].remove(1)), r"skins\[0\]\.joints\[0\]",  # the skeleton
     "node 0 is not in the default scene"),
])
def test_bad_skins_are_one_error_naming_the_field(tmp_path, make_scene, kwargs, field, message):
    _skinned(tmp_path, **kwargs)
    with pytest.raises(SceneError, match=rf"{field}: {message}"):
        _load(make_scene)


# ----------------------------------------------------------------------------- the job's glTF


def test_the_jobs_gltf_carries_the_conversions_and_passes_the_validator(tmp_path, make_scene):
    """What other renderers read: the converted material as metallic-roughness with KHR_materials_specular and
    _ior, and the posed mesh as plain geometry; the Khronos glTF-Validator finds no error in either."""
    from compare.renderers.job import export_gltf
    from tests.helpers import require, validate_gltf

    _spec_gloss(tmp_path, {"diffuseFactor": [0.8, 0.2, 0.2, 1.0], "specularFactor": [0.04, 0.04, 0.04],
                           "glossinessFactor": 0.7})
    gloss = export_gltf(_load(make_scene)[0], tmp_path / "gloss" / "scene.gltf")
    (m,) = json.loads(gloss.read_text(encoding="utf-8"))["materials"]
    assert m["pbrMetallicRoughness"]["metallicFactor"] == 0.0
    assert m["pbrMetallicRoughness"]["roughnessFactor"] == pytest.approx(0.3)
    assert m["extensions"]["KHR_materials_ior"]["ior"] == 1000.0
    assert m["extensions"]["KHR_materials_specular"]["specularColorFactor"] == pytest.approx([0.04] * 3)
    assert SPEC_GLOSS not in json.dumps(m)

    _skinned(tmp_path, joint_nodes=[{"rotation": ROT_X_90}], root=(0.0, 1.0, 0.0))
    scene = _load(make_scene)[0]
    posed = export_gltf(scene, tmp_path / "posed" / "scene.gltf")
    (prim,) = load_gltf(posed).primitives
    np.testing.assert_allclose(prim.mesh.transformed(prim.matrix).positions, scene.meshes[0].triangles().positions,
                               atol=1e-6)
    require("npm", "gltf-validator")
    reports = validate_gltf([gloss, posed])
    errors = {f: [x["code"] for x in r["issues"]["messages"] if x["severity"] == 0] for f, r in reports.items()}
    assert errors == {str(gloss): [], str(posed): []}


def test_animations_are_not_played_and_say_so(tmp_path, make_scene):
    _morphed(tmp_path, mesh_weights=[0.5], edit=lambda d: d.update(animations=[{"channels": [], "samplers": []}]))
    scene, notes = _load(make_scene)
    np.testing.assert_allclose(scene.meshes[0].triangles().positions, CORNERS + [0, 0, 1], atol=1e-6)
    assert any("1 animation(s) not played" in n for n in notes)
