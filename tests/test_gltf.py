"""glTF 2.0 import (compare.scene.gltf_read): accessors, hierarchy, materials, cameras, lights, and [[include]]."""

from __future__ import annotations

import base64
import json
import math
import struct
import textwrap
import warnings
from pathlib import Path

import numpy as np
import pytest

from compare.scene import geometry
from compare.util.errors import SceneError
from compare.scene.gltf_read import GltfError, load_gltf
from compare.scene.gltf_write import GltfWriter
from compare.scene.loader import load_scene

# A 2×2 PNG (red, green / blue, white), 8-bit RGB.
# A valid 2x2 RGB PNG (the scene loader reads every texture it names).
PNG_2X2 = base64.b64decode(
    "iVBORw0KGgoAAAANSUhEUgAAAAIAAAACCAIAAAD91JpzAAAAFklEQVR4nGM8kWLEwMDAxMDAwMDAAAARKAFipiAqoAAAAABJRU5ErkJggg=="
)


def quiet_load(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_scene(path)


def simple_writer() -> GltfWriter:
    """A red box at y = 0.5 under a 0.5 m emissive quad at y = 2 facing down, a camera and a point light."""
    w = GltfWriter()
    red = w.material("paint", (0.8, 0.1, 0.1), 0.0, 0.3)
    lamp = w.material("lamp", (1.0, 1.0, 1.0), 0.0, 1.0, emission=(5.0, 4.0, 3.0))
    box = w.mesh("box", [(geometry.box((1.0, 1.0, 1.0)), red)])
    down = geometry.quad((0.5, 0.5)).transformed(geometry.transform_matrix(rotate=(180.0, 0.0, 0.0)))
    quad = w.mesh("lamp", [(down, lamp)])
    w.node("box", mesh=box, translation=(0.0, 0.5, 0.0))
    w.node("lamp", mesh=quad, translation=(0.0, 2.0, 0.0))
    w.node("camera", camera=w.camera("cam", 40.0, 4 / 3), translation=(0.0, 1.0, 4.0))
    w.node("bulb", light=w.light("bulb", "point", 683.0), translation=(1.0, 2.0, 1.0))
    return w


# ----------------------------------------------------------------------------- reading


@pytest.mark.parametrize("suffix", [".glb", ".gltf"])
def test_round_trip_geometry_materials_camera_light(tmp_path, suffix):
    path = simple_writer().write(tmp_path / f"m{suffix}")
    doc = load_gltf(path)
    assert [p.name for p in doc.primitives] == ["box", "lamp"]
    box = geometry.box((1.0, 1.0, 1.0))
    np.testing.assert_array_equal(doc.primitives[0].mesh.positions, box.positions)
    np.testing.assert_array_equal(doc.primitives[0].mesh.indices, box.indices)
    np.testing.assert_allclose(doc.primitives[0].mesh.normals, box.normals)
    np.testing.assert_allclose(doc.primitives[0].matrix[:3, 3], [0.0, 0.5, 0.0])
    paint, lamp = doc.materials
    assert paint.name == "paint" and paint.base_color == pytest.approx((0.8, 0.1, 0.1)) and paint.roughness == 0.3
    assert paint.metallic == 0.0
    # Emission above 1 is stored as a normalised factor times KHR_materials_emissive_strength.
    assert lamp.emission == pytest.approx((5.0, 4.0, 3.0))
    (cam,) = doc.cameras
    assert cam.yfov == pytest.approx(math.radians(40.0)) and cam.aspect == pytest.approx(4 / 3)
    (light,) = doc.lights
    assert light.kind == "point" and light.intensity == 683.0
    np.testing.assert_allclose(light.matrix[:3, 3], [1.0, 2.0, 1.0])


def test_node_hierarchy_trs_and_matrix(tmp_path):
    w = GltfWriter()
    tri = geometry._mesh([[1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 0, 1]] * 3, [[0, 0]] * 3, [[0, 1, 2]])
    mesh = w.mesh("t", [(tri, None)])
    # child: rotate 90° about +Y (quaternion), scale 2; parent: translate (10, 0, 0) as a matrix.
    s = math.sqrt(0.5)
    child = w.node("child", mesh=mesh, rotation=(0.0, s, 0.0, s), scale=(2.0, 2.0, 2.0))
    parent = np.eye(4)
    parent[:3, 3] = (10.0, 0.0, 0.0)
    w.node("parent", matrix=parent, children=(child,))
    doc = load_gltf(w.write(tmp_path / "h.glb"))
    (prim,) = doc.primitives
    world = prim.mesh.transformed(prim.matrix).positions
    # Rotating +X by 90° about +Y gives −Z; then ×2, then +10 in x.
    np.testing.assert_allclose(world, [[10, 0, -2], [10, 2, 0], [12, 0, 0]], atol=1e-6)


def test_instanced_mesh_gives_one_primitive_per_node(tmp_path):
    w = GltfWriter()
    mesh = w.mesh("box", [(geometry.box((1, 1, 1)), None)])
    for x in (0.0, 3.0, 6.0):
        w.node(f"box{x:g}", mesh=mesh, translation=(x, 0.0, 0.0))
    doc = load_gltf(w.write(tmp_path / "i.glb"))
    assert [p.matrix[0, 3] for p in doc.primitives] == [0.0, 3.0, 6.0]
    assert doc.primitives[0].mesh is doc.primitives[1].mesh  # decoded once


def _raw_doc(w: GltfWriter) -> dict:
    return w.document(embed_buffer=True)


def _write_doc(path: Path, doc: dict) -> Path:
    path.write_text(json.dumps(doc))
    return path


def test_strided_normalized_and_sparse_accessors(tmp_path):
    """Interleaved positions/UVs with byteStride, normalized uint16 UVs, and a sparse override."""
    p = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=np.float32)
    uv = np.array([[0, 0], [65535, 0], [65535, 65535], [0, 32768]], dtype=np.uint16)
    rows = b"".join(p[i].tobytes() + uv[i].tobytes() for i in range(4))  # 16-byte stride
    w = GltfWriter()
    view = w.view(rows)
    w.doc["bufferViews"][view]["byteStride"] = 16
    w._add("accessors", {"bufferView": view, "componentType": 5126, "count": 4, "type": "VEC3"})
    w._add("accessors", {"bufferView": view, "byteOffset": 12, "componentType": 5123, "normalized": True,
                         "count": 4, "type": "VEC2"})
    idx = w.accessor(np.array([[0, 1, 2], [0, 2, 3]]), indices=True)
    # Sparse: move vertex 2 to z = 5 on top of the same positions.
    si = w.view(np.array([2], dtype=np.uint16).tobytes())
    sv = w.view(np.array([1, 1, 5], dtype=np.float32).tobytes())
    w._add("accessors", {"bufferView": view, "componentType": 5126, "count": 4, "type": "VEC3",
                         "sparse": {"count": 1, "indices": {"bufferView": si, "componentType": 5123},
                                    "values": {"bufferView": sv}}})
    nrm = w.accessor(np.tile([0.0, 0.0, 1.0], (4, 1)))
    w._add("meshes", {"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1, "NORMAL": nrm},
                                      "indices": idx}]})
    w._add("meshes", {"primitives": [{"attributes": {"POSITION": idx + 1, "NORMAL": nrm}, "indices": idx}]})
    w.node("plain", mesh=0)
    w.node("sparse", mesh=1)
    doc = load_gltf(_write_doc(tmp_path / "s.gltf", _raw_doc(w)))
    plain, sparse = doc.primitives
    np.testing.assert_array_equal(plain.mesh.positions, p)
    np.testing.assert_allclose(plain.mesh.uvs, [[0, 0], [1, 0], [1, 1], [0, 32768 / 65535]], atol=1e-7)
    np.testing.assert_array_equal(sparse.mesh.positions[2], [1, 1, 5])
    np.testing.assert_array_equal(sparse.mesh.positions[[0, 1, 3]], p[[0, 1, 3]])


def test_strip_fan_nonindexed_and_points(tmp_path):
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0, 2, 0]], dtype=np.float32)
    w = GltfWriter()
    pos = w.accessor(pts)
    nrm = w.accessor(np.tile([0.0, 0.0, 1.0], (5, 1)))
    for mode in (5, 6, 4, 0):
        w._add("meshes", {"name": f"mode{mode}",
                          "primitives": [{"attributes": {"POSITION": pos, "NORMAL": nrm}, "mode": mode}]})
        w.node(f"mode{mode}", mesh=len(w.doc["meshes"]) - 1)
    doc = load_gltf(w.write(tmp_path / "m.glb"))
    strip, fan, tris = (p.mesh.indices.tolist() for p in doc.primitives)
    assert strip == [[0, 1, 2], [1, 3, 2], [2, 3, 4]]  # the spec's order: every triangle counter-clockwise
    assert fan == [[1, 2, 0], [2, 3, 0], [3, 4, 0]]
    assert tris == [[0, 1, 2]]  # 5 vertices: one whole triangle, the rest ignored
    assert any("mode 0" in n for n in doc.warnings)  # points: skipped and said so
    # Strips keep a consistent facing: every triangle's normal is +Z.
    p = doc.primitives[0].mesh.positions.astype(np.float64)
    for a, b, c in doc.primitives[0].mesh.indices:
        assert np.cross(p[b] - p[a], p[c] - p[a])[2] > 0


def test_missing_normals_are_flat_and_zero_normals_repaired(tmp_path):
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 0, -1], [0, 1, -1]], dtype=np.float32)
    idx = np.array([[0, 1, 2], [0, 2, 3]])
    w = GltfWriter()
    pos = w.accessor(pts)
    ind = w.accessor(idx, indices=True)
    bad = w.accessor(np.array([[0, 0, 0], [0, 1, 0], [np.nan, 0, 0], [0, 1, 0]], dtype=np.float32))
    w._add("meshes", {"primitives": [{"attributes": {"POSITION": pos}, "indices": ind}]})
    w._add("meshes", {"primitives": [{"attributes": {"POSITION": pos, "NORMAL": bad}, "indices": ind}]})
    w.node("flat", mesh=0)
    w.node("repaired", mesh=1)
    doc = load_gltf(w.write(tmp_path / "n.glb"))
    flat, repaired = doc.primitives
    assert len(flat.mesh.positions) == 6  # unwelded: one face normal per triangle
    np.testing.assert_allclose(flat.mesh.normals[:3], [[0, 1, 0]] * 3, atol=1e-7)
    np.testing.assert_allclose(flat.mesh.normals[3:], [[1, 0, 0]] * 3, atol=1e-7)
    n = repaired.mesh.normals
    assert np.all(np.isfinite(n)) and np.allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-6)
    assert any("normals replaced" in m for m in doc.warnings)


@pytest.mark.parametrize("break_it, message", [
    (lambda d: d["accessors"][0].update(count=10_000), r"accessors\[0\]: 10000 elements need"),
    (lambda d: d["meshes"][0]["primitives"][0].update(indices=99), r"accessors index 99 out of range"),
    (lambda d: d.update(extensionsRequired=["KHR_animation_pointer"]),
     "unsupported required extension.*KHR_animation_pointer"),
    (lambda d: d["asset"].update(version="1.0"), r"asset\.version: only glTF 2\.x"),
    (lambda d: d["nodes"][0].update(children=[0]), r"nodes\[0\]: the node hierarchy has a cycle"),
    (lambda d: d["buffers"][0].update(uri="../outside.bin"), "leaves the glTF file's folder"),
    (lambda d: d["buffers"][0].update(uri="missing.bin"), "file 'missing.bin' not found"),
])
def test_malformed_files_name_file_and_json_path(tmp_path, break_it, message):
    w = GltfWriter()
    w.node("box", mesh=w.mesh("box", [(geometry.box((1, 1, 1)), None)]))
    doc = _raw_doc(w)
    break_it(doc)
    sub = tmp_path / "sub"
    sub.mkdir()
    (tmp_path / "outside.bin").write_bytes(bytes(w.bin))
    path = _write_doc(sub / "bad.gltf", doc)
    with pytest.raises(GltfError, match=message) as info:
        load_gltf(path)
    assert str(path) in str(info.value)


def test_truncated_glb(tmp_path):
    data = simple_writer().glb()
    path = tmp_path / "t.glb"
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(GltfError, match="t.glb"):
        load_gltf(path)


def test_external_buffer_and_image_files_count_for_the_hash(tmp_path, make_scene):
    w = simple_writer()
    doc = _raw_doc(w)
    (tmp_path / "m.bin").write_bytes(bytes(w.bin))
    doc["buffers"][0]["uri"] = "m.bin"
    _write_doc(tmp_path / "m.gltf", doc)
    scene = make_scene('include = "m.gltf"\n')
    s1 = quiet_load(scene)
    assert tmp_path / "m.bin" in s1.referenced_files and tmp_path / "m.gltf" in s1.referenced_files
    data = bytearray(w.bin)
    data[0:4] = struct.pack("<f", 0.25)  # move one vertex
    (tmp_path / "m.bin").write_bytes(bytes(data))
    assert quiet_load(scene).hash != s1.hash


# ----------------------------------------------------------------------------- into a scene


def test_include_maps_materials_camera_and_lights(tmp_path, make_scene):
    simple_writer().write(tmp_path / "m.glb")
    s = quiet_load(make_scene("""
        include = "m.glb"

        [[meshes]]
        name = "floor"
        shape = "quad"
        size = [10, 10]
        material = "m/paint"
    """))
    # Camera from the glTF (no [camera] table): looks down its −Z, 320 wide at the glTF aspect.
    assert s.camera.position == (0.0, 1.0, 4.0) and s.camera.target == (0.0, 1.0, 3.0)
    assert s.camera.fov == pytest.approx(40.0) and s.camera.resolution == (320, 240)
    assert [m.name for m in s.meshes] == ["floor", "m/box"]
    assert s.materials["m/paint"].base_color == pytest.approx((0.8, 0.1, 0.1))
    # The emissive quad became a rectangle light facing down with the emission as radiance.
    lamp = s.lights[0]
    assert lamp.name == "m/lamp" and lamp.size == pytest.approx((0.5, 0.5))
    np.testing.assert_allclose(lamp.center, [0, 2, 0], atol=1e-7)
    np.testing.assert_allclose(lamp.normal, [0, -1, 0], atol=1e-7)
    assert lamp.radiance == pytest.approx((5.0, 4.0, 3.0))
    # The point light (683 cd = 1 W/sr) is a point light; a renderer with area lights only gets a closed
    # cube of six lights emitting its 4π W in all.
    (bulb,) = s.punctual
    assert bulb.kind == "point" and bulb.intensity == pytest.approx((1.0, 1.0, 1.0))
    assert len(s.lights) == 1
    cube = s.with_punctual_as_area()[0].lights[1:]
    assert len(cube) == 6
    total = sum(light.power for light in cube)
    np.testing.assert_allclose(total, 4 * math.pi, rtol=1e-9)
    centre = np.mean([light.center for light in cube], axis=0)
    np.testing.assert_allclose(centre, [1, 2, 1], atol=1e-9)
    for light in cube:  # each face emits away from the cube's centre
        assert np.dot(np.subtract(light.center, centre), light.normal) > 0


def test_include_options_transform_override_and_toml_camera(tmp_path, make_scene):
    simple_writer().write(tmp_path / "m.glb")
    s = quiet_load(make_scene("""
        [camera]
        resolution = [64, 48]
        fov = 30

        [[include]]
        file = "m.glb"
        prefix = ""
        translate = [5, 0, 0]
        scale = 2
        emissive_quads = "meshes"
        punctual = "ignore"

        [materials.paint]
        base_color = [0.1, 0.8, 0.1]
        roughness = 0.9
    """))
    assert s.camera.resolution == (64, 48) and s.camera.fov == 30  # the TOML's fields win
    assert s.camera.position == pytest.approx((5.0, 2.0, 8.0))  # glTF camera moved with the include
    assert s.materials["paint"].base_color == (0.1, 0.8, 0.1)  # replaced by the TOML
    assert not s.lights and s.features().emissive_meshes  # quad kept as an emissive mesh, no punctual lights
    lo, hi = s.bounds()
    np.testing.assert_allclose(lo, [4.0, 0.0, -1.0], atol=1e-6)  # box ×2 about the glTF origin, then +5 x
    np.testing.assert_allclose(hi, [6.0, 4.0, 1.0], atol=1e-6)


def test_spot_and_directional_lights(tmp_path, make_scene):
    w = GltfWriter()
    w.node("floor", mesh=w.mesh("floor", [(geometry.quad((4, 4)), w.material("white"))]))
    w.node("spot", light=w.light("spot", "spot", 683.0 * 2), translation=(0, 3, 0),
           rotation=(-math.sqrt(0.5), 0, 0, math.sqrt(0.5)))  # −Z turned to −Y
    w.node("sun", light=w.light("sun", "directional", 5.0))
    w.write(tmp_path / "l.glb")
    s = load_scene(make_scene("""
        [camera]
        position = [0, 2, 5]
        target = [0, 0, 0]

        [[include]]
        file = "l.glb"
        punctual_size = 0.1
    """))
    spot, sun = s.punctual
    assert (spot.kind, sun.kind) == ("spot", "directional") and not s.lights
    np.testing.assert_allclose(spot.direction, [0, -1, 0], atol=1e-9)
    np.testing.assert_allclose(sun.intensity, [5 / 683] * 3)  # lux at 1/683 W/lm: W/m²
    # where only area lights are drawn: the spot as one square of on-axis intensity L·A = 2 W/sr, no sun
    (square,) = s.with_punctual_as_area()[0].lights
    np.testing.assert_allclose(square.normal, [0, -1, 0], atol=1e-9)
    assert square.radiance[0] * square.area == pytest.approx(2.0) and square.size == pytest.approx((0.1, 0.1))
    with pytest.warns(UserWarning, match="directional light 'sun' skipped"):
        area = load_scene(make_scene('[camera]\nposition = [0, 2, 5]\ntarget = [0, 0, 0]\n'
                                     '[[include]]\nfile = "l.glb"\npunctual = "area"\n', name="area.toml"))
    assert len(area.lights) == 1 and not area.punctual


@pytest.mark.parametrize("text, message", [
    ('include = "none.glb"\n', r"include\.file: file 'none.glb' not found"),
    ('[[include]]\nfile = "m.glb"\nemissive_quads = "yes"\n', r"include\[0\]\.emissive_quads: expected 'lights'"),
    ('[[include]]\nfile = "m.glb"\ncamera = "nope"\n', r"include\[0\]\.camera: no camera named 'nope'"),
    ('[[include]]\nfile = "m.glb"\ncolour = 1\n', r"include\[0\]\.colour: unknown field"),
    ('include = "bad.glb"\n', r"scene\.toml: include\.file: .*bad\.glb: "),
    ('include = "m.obj"\n', r"include\.file: 'm.obj': unsupported file type"),
])
def test_include_errors_name_scene_and_field(tmp_path, make_scene, text, message):
    simple_writer().write(tmp_path / "m.glb")
    (tmp_path / "bad.glb").write_bytes(b"glTF\x02\x00\x00\x00\x20\x00\x00\x00" + b"\x00" * 20)
    (tmp_path / "m.obj").write_text("v 0 0 0\n")
    with pytest.raises(SceneError, match=message):
        quiet_load(make_scene(text))


def test_embedded_and_external_textures(tmp_path, make_scene, monkeypatch):
    monkeypatch.setenv("COMPARE_CACHE", str(tmp_path / "cache"))
    w = simple_writer()
    img = w._add("images", {"bufferView": w.view(PNG_2X2), "mimeType": "image/png"})
    ext = w._add("images", {"uri": "tex/mr.png"})
    w._add("textures", {"source": img})
    w._add("textures", {"source": ext})
    pbr = w.doc["materials"][0]["pbrMetallicRoughness"]
    pbr["baseColorTexture"] = {"index": 0}
    pbr["metallicRoughnessTexture"] = {"index": 1}
    # factors of 1: the files themselves are the maps (a factor other than 1 is baked into a copy)
    pbr.update(baseColorFactor=[1.0, 1.0, 1.0, 1.0], metallicFactor=1.0, roughnessFactor=1.0)
    w.doc["materials"][0]["emissiveTexture"] = {"index": 1}
    w.doc["materials"][0]["normalTexture"] = {"index": 1, "scale": 0.5}
    w.doc["materials"][0]["emissiveFactor"] = [0.5, 0.25, 0.0]
    (tmp_path / "tex").mkdir()
    (tmp_path / "tex" / "mr.png").write_bytes(PNG_2X2)
    w.write(tmp_path / "t.glb")
    s = quiet_load(make_scene('include = "t.glb"\n'))
    mat = s.materials["t/paint"]
    assert mat.base_color_texture.read_bytes() == PNG_2X2
    assert mat.base_color_texture.is_relative_to(tmp_path / "cache")
    assert mat.metallic_roughness_texture == tmp_path / "tex" / "mr.png"
    assert mat.emissive_texture == tmp_path / "tex" / "mr.png" and mat.emission == (0.5, 0.25, 0.0)
    assert mat.normal_texture == tmp_path / "tex" / "mr.png" and mat.normal_scale == 0.5
    assert s.features().textures


# ----------------------------------------------------------------------------- rendering


def _pair(tmp_path: Path, make_scene):
    """The same lit box twice: once from a glTF include, once written as TOML primitives and lights."""
    simple_writer().write(tmp_path / "m.glb")
    cam = """
        [camera]
        position = [2.5, 2.0, 3.5]
        target = [0, 0.5, 0]
        resolution = [48, 36]
    """
    floor = """
        [materials.grey]
        base_color = [0.5, 0.5, 0.5]
        roughness = 1.0

        [[meshes]]
        name = "floor"
        shape = "quad"
        size = [6, 6]
        material = "grey"
    """
    via_gltf = quiet_load(make_scene(cam + floor + """
        [[include]]
        file = "m.glb"
        punctual = "ignore"
    """, name="a.toml"))
    via_toml = quiet_load(make_scene(cam + floor + """
        [materials.paint]
        base_color = [0.8, 0.1, 0.1]
        roughness = 0.3

        [[meshes]]
        shape = "box"
        size = [1, 1, 1]
        translate = [0, 0.5, 0]
        material = "paint"

        [[lights]]
        center = [0, 2, 0]
        size = [0.5, 0.5]
        normal = [0, -1, 0]
        tangent = [1, 0, 0]
        radiance = [5, 4, 3]
    """, name="b.toml"))
    return via_gltf, via_toml


def test_included_scene_renders_like_its_toml_twin_progressive(tmp_path, make_scene, gl_ctx):
    from compare.progressive.rasterizer import render_progressive

    a, b = _pair(tmp_path, make_scene)
    ia = render_progressive(a, frames=24, ctx=gl_ctx).image
    ib = render_progressive(b, frames=24, ctx=gl_ctx).image
    assert np.isfinite(ia).all() and ia.mean() > 2e-3
    # The emissive quad's light must light the floor: same light, same pixels.
    np.testing.assert_allclose(ia, ib, rtol=1e-4, atol=1e-6)


def test_included_scene_renders_like_its_toml_twin_reference(tmp_path, make_scene):
    from compare.mitsuba.reference import ReferenceRenderer

    a, b = _pair(tmp_path, make_scene)
    ia = ReferenceRenderer(a, cache_dir=False, progress=False).render(16).image
    ib = ReferenceRenderer(b, cache_dir=False, progress=False).render(16).image
    assert np.isfinite(ia).all() and ia.mean() > 2e-3
    assert abs(ia.mean() - ib.mean()) < 0.03 * ib.mean()


def test_fields_of_the_wrong_json_type_are_one_error_naming_the_file(tmp_path):
    """Found by tests/test_fuzz.py: a string for a node's translation, a number for "asset" (before:
    ValueError and AttributeError tracebacks)."""
    from compare.scene.geometry import box

    w = GltfWriter()
    w.node("b", mesh=w.mesh("b", [(box([1, 1, 1]), w.material("g"))]), translation=[0, 0, 0])
    path = tmp_path / "bad.gltf"
    for edit, message in ((lambda d: d["nodes"][0].__setitem__("translation", "up"),
                           f"{path}: nodes[0].translation: expected 3 finite numbers, got 'up'"),
                          (lambda d: d.__setitem__("asset", 0),
                           f"{path}: malformed glTF (AttributeError: 'int' object has no attribute 'get'); check it "
                           "with the Khronos glTF validator")):
        doc = w.document(embed_buffer=True)
        edit(doc)
        path.write_text(json.dumps(doc))
        with pytest.raises(GltfError) as exc:
            load_gltf(path)
        assert str(exc.value) == message


def test_texture_transform_and_sampler_are_imported_and_exported(tmp_path, make_scene, monkeypatch):
    """KHR_texture_transform and the sampler's wrapS / magFilter become the material's texture settings;
    the glTF a renderer of the registry receives (compare.renderers.job.export_gltf) carries them back."""
    import math

    from compare.renderers.job import export_gltf

    monkeypatch.setenv("COMPARE_CACHE", str(tmp_path / "cache"))
    w = simple_writer()
    img = w._add("images", {"bufferView": w.view(PNG_2X2), "mimeType": "image/png"})
    smp = w._add("samplers", {"wrapS": 33648, "wrapT": 33648, "magFilter": 9728})
    w._add("textures", {"source": img, "sampler": smp})
    w._use("KHR_texture_transform")
    w.doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {
        "index": 0, "extensions": {"KHR_texture_transform": {"offset": [0.25, 0.5], "rotation": math.pi / 2,
                                                             "scale": [2.0, 3.0]}}}
    w.write(tmp_path / "t.glb")
    s = quiet_load(make_scene('include = "t.glb"\n'))
    t = s.materials["t/paint"].sampling("base_color_texture")
    assert t.offset == (0.25, 0.5) and t.rotation == pytest.approx(90.0)
    assert t.scale == (2.0, 3.0) and t.wrap == ("mirror", "mirror") and t.filter == "nearest"
    np.testing.assert_allclose(t.uv_transform() @ [1.0, 0.0, 1.0], [0.25, 0.5 - 2.0, 1.0], atol=1e-12)
    (tmp_path / "out").mkdir()
    out = export_gltf(s, tmp_path / "out" / "scene.gltf")
    from compare.scene.gltf_read import load_gltf

    again = dict(next(m for m in load_gltf(out).materials if m.base_color_image is not None).sampling)
    a = again["base_color_texture"]
    assert (a.offset, a.scale, a.wrap, a.filter, a.texcoord) == ((0.25, 0.5), (2.0, 3.0), ("mirror", "mirror"),
                                                                 "nearest", 0)
    assert a.rotation == pytest.approx(90.0)


def test_a_factor_beside_a_map_is_baked_into_it(tmp_path):
    """glTF multiplies baseColorTexture by baseColorFactor and the metallic-roughness channels by their
    factors; the import bakes the product into the map (the scene model's map replaces its factor)."""
    import json

    from PIL import Image

    from compare.scene.textures import load_alpha, load_texture

    rgba = np.zeros((4, 4, 4), dtype=np.uint8)
    rgba[...] = (200, 100, 50, 128)
    Image.fromarray(rgba, "RGBA").save(tmp_path / "c.png")
    Image.fromarray(np.full((4, 4, 3), (0, 200, 100), dtype=np.uint8)).save(tmp_path / "mr.png")
    from compare.scene.gltf_write import GltfWriter
    from compare.scene.geometry import quad

    w = GltfWriter()
    m = w.material("m", (0.5, 1.0, 0.25), 0.5, 0.8)
    w.doc["materials"][m]["pbrMetallicRoughness"].update(baseColorTexture={"index": 0},
                                                         metallicRoughnessTexture={"index": 1})
    w.doc["materials"][m].update(alphaMode="MASK")
    w.doc["textures"] = [{"source": 0}, {"source": 1}]
    w.doc["images"] = [{"uri": "c.png"}, {"uri": "mr.png"}]
    w.node("q", mesh=w.mesh("q", [(quad((1.0, 1.0)), m)], uvs=True))
    w.write(tmp_path / "s.gltf")
    (tmp_path / "t.toml").write_text(textwrap.dedent('''
        [camera]
        position = [0, 2, 2]
        target = [0, 0, 0]
        [[include]]
        file = "s.gltf"
        prefix = ""
        [environment]
        constant = [1, 1, 1]
        '''))
    mat = load_scene(tmp_path / "t.toml").materials["m"]
    from compare.image.tonemap import srgb_decode

    want = srgb_decode(np.array([200, 100, 50]) / 255.0) * [0.5, 1.0, 0.25]
    np.testing.assert_allclose(load_texture(mat.base_color_texture, srgb=True)[0, 0], want, rtol=1e-6)
    np.testing.assert_allclose(load_alpha(mat.base_color_texture)[0, 0], 128 / 255, rtol=1e-6)  # alpha kept
    np.testing.assert_allclose(load_texture(mat.metallic_roughness_texture, srgb=False)[0, 0],
                               [0.0, 200 / 255 * 0.8, 100 / 255 * 0.5], rtol=1e-6)
    # and the export writes factor 1 beside a map, so that glTF's product is the map
    from compare.renderers.job import export_gltf

    (tmp_path / "out").mkdir()
    export_gltf(load_scene(tmp_path / "t.toml"), tmp_path / "out" / "s.gltf")
    pbr = json.loads((tmp_path / "out" / "s.gltf").read_text())["materials"][0]["pbrMetallicRoughness"]
    assert pbr["baseColorFactor"][:3] == [1.0, 1.0, 1.0] and pbr["metallicFactor"] == pbr["roughnessFactor"] == 1.0


def test_a_deep_node_chain_loads_and_a_cycle_without_scenes_is_an_error(tmp_path):
    """Node graphs are walked without recursion: a 5000-deep chain (valid glTF) loads, with its transforms
    composed; a file whose nodes are all each other's children, without scenes, is a cycle, not an
    empty model."""
    w = GltfWriter()
    mesh = w.mesh("tri", [(geometry.quad((1.0, 1.0)), w.material("grey"))])
    depth = 5000
    leaf = w.node("leaf", mesh=mesh)
    child = leaf
    for k in range(depth):
        child = w.node(f"n{k}", translation=(0.001, 0.0, 0.0), children=(child,))
    w.write(tmp_path / "deep.glb")
    (prim,) = load_gltf(tmp_path / "deep.glb").primitives
    assert prim.matrix[0, 3] == pytest.approx(depth * 0.001)
    doc = {"asset": {"version": "2.0"}, "nodes": [{"children": [1]}, {"children": [0]}]}
    (tmp_path / "cycle.gltf").write_text(json.dumps(doc))
    with pytest.raises(GltfError, match=r"cycle.gltf: nodes: the node hierarchy has a cycle"):
        load_gltf(tmp_path / "cycle.gltf")


def test_duplicate_material_names_are_addressable_and_a_restyle_that_matches_nothing_is_an_error(tmp_path,
                                                                                                 make_scene):
    w = GltfWriter()
    a, b = w.material("red", (0.8, 0.1, 0.1)), w.material("red", (0.6, 0.1, 0.1))
    w.node("one", mesh=w.mesh("one", [(geometry.quad((1.0, 1.0)), a)]))
    w.node("two", mesh=w.mesh("two", [(geometry.box((0.2, 0.2, 0.2)), b)]), translation=(0, 0.5, 0))
    w.write(tmp_path / "m.glb")
    cam = '[camera]\nposition = [0, 2, 3]\ntarget = [0, 0, 0]\n[environment]\nconstant = [1, 1, 1]\n'
    s = load_scene(make_scene('include = "m.glb"\n', cam))
    assert sorted(k for k in s.materials if k.startswith("m/")) == ["m/red#0", "m/red#1"]
    s = load_scene(make_scene('include = "m.glb"\n', cam, '[materials."m/red#1"]\nbase_color = [0, 0, 1]\n',
                              name="ok.toml"))
    assert s.materials["m/red#1"].base_color == (0.0, 0.0, 1.0)
    with pytest.raises(SceneError, match=r"bad.toml: materials.m/red: restyles no imported material and no mesh "
                                         r"uses it \(the file has 2 materials of that name: m/red#0, m/red#1\)"):
        load_scene(make_scene('include = "m.glb"\n', cam, '[materials."m/red"]\nbase_color = [0, 0, 1]\n',
                              name="bad.toml"))


def test_claims_that_no_bytes_back_are_refused_before_allocating(tmp_path, make_scene):
    """An accessor of 10^12 elements without data, and a 100-byte PNG that claims 100000 x 100000 pixels (in
    a GLB or beside a scene), are one error each naming the file, not a MemoryError or a traceback."""
    import struct
    import zlib

    doc = {"asset": {"version": "2.0"}, "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
           "accessors": [{"componentType": 5126, "type": "VEC3", "count": 10 ** 12}]}
    (tmp_path / "huge.gltf").write_text(json.dumps(doc))
    with pytest.raises(GltfError, match=r"huge.gltf: accessors\[0\]: 1000000000000 elements without a bufferView"):
        load_gltf(tmp_path / "huge.gltf")

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    bomb = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 100000, 100000, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(b"\0" * 64)) + chunk(b"IEND", b""))
    (tmp_path / "bomb.png").write_bytes(bomb)
    scene = make_scene('[camera]\nposition = [0, 2, 3]\ntarget = [0, 0, 0]\n[environment]\nconstant = [1, 1, 1]\n'
                       '[materials.m]\nbase_color_texture = "bomb.png"\n'
                       '[[meshes]]\nname = "q"\nshape = "quad"\nsize = [1.0, 1.0]\nmaterial = "m"\n')
    with pytest.raises(SceneError, match=r"bomb.png.*refused before decoding: its header claims more pixels"):
        load_scene(scene)


def test_a_negative_or_non_finite_gltf_light_is_skipped_with_a_note(tmp_path, make_scene):
    w = GltfWriter()
    w.node("floor", mesh=w.mesh("floor", [(geometry.quad((4, 4)), w.material("white"))]))
    w.node("bad", light=w.light("bad", "point", 683.0, (1.0, -1.0, 1.0)), translation=(0, 1, 0))
    w.node("good", light=w.light("good", "point", 683.0), translation=(0, 2, 0))
    w.write(tmp_path / "l.glb")
    with pytest.warns(UserWarning, match=r"light 'bad' has colour × intensity \[1.0, -1.0, 1.0\]: skipped"):
        s = load_scene(make_scene('include = "l.glb"\n[camera]\nposition = [0, 2, 5]\ntarget = [0, 0, 0]\n'))
    assert [p.name for p in s.punctual] == ["l/good"]


def test_a_png_bomb_inside_a_glb_is_one_error(tmp_path, make_scene):
    import struct
    import zlib

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    bomb = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 100000, 100000, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(b"\0" * 64)) + chunk(b"IEND", b""))
    w = GltfWriter()
    m = w.material("tex")
    w.doc["materials"][m]["pbrMetallicRoughness"]["baseColorTexture"] = w.texture(bomb)
    w.node("floor", mesh=w.mesh("floor", [(geometry.quad((4, 4)), m)], uvs=True))
    w.write(tmp_path / "b.glb")
    with pytest.raises(SceneError, match=r"include.file: b.glb: materials\[0\]: image 0: refused before decoding"):
        load_scene(make_scene('include = "b.glb"\n[camera]\nposition = [0, 2, 5]\ntarget = [0, 0, 0]\n'
                              '[environment]\nconstant = [1, 1, 1]\n'))
