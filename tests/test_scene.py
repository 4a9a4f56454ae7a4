"""Scene model: validation messages, geometry, features and hashing."""

from __future__ import annotations


import numpy as np
import pytest

from compare.util.errors import SceneError
from compare.scene.loader import load_scene
from tests.helpers import CORNELL


GOOD = """
[camera]
position = [0, 1, 3]
target = [0, 0, 0]
fov = 40
resolution = [32, 24]

[materials.white]
base_color = [0.8, 0.8, 0.8]

[[meshes]]
shape = "quad"
size = [2, 2]
material = "white"

[[lights]]
center = [0, 1, 0]
size = [0.5, 0.5]
normal = [0, -1, 0]
radiance = [10, 10, 10]
"""


def test_good_scene_loads(make_scene):
    s = load_scene(make_scene(GOOD))
    assert s.camera.resolution == (32, 24)
    assert len(s.meshes) == 1 and len(s.lights) == 1
    assert s.lights[0].area == pytest.approx(0.25)


# (replacement applied to GOOD, expected message after "scene.toml: ")
MALFORMED = [
    (("size = [0.5, 0.5]", "size = [0.5, -1]"), "lights[0].size: expected two positive numbers, got [0.5, -1]"),
    (("resolution = [32, 24]", "resolution = [32]"), "camera.resolution: expected two positive integers, got [32]"),
    (("fov = 40", "fov = 200"), "camera.fov: expected a vertical field of view in degrees in (0, 180), got 200"),
    (('material = "white"', 'material = "chrome"'), "meshes[0].material: unknown material 'chrome' (known: white)"),
    (('shape = "quad"', 'shape = "torus"'),
     "meshes[0].shape: expected one of quad, box, sphere, cylinder, file, got 'torus'"),
    (("base_color = [0.8, 0.8, 0.8]", "base_color = [0.8, 1.5, 0.8]"),
     "materials.white.base_color: expected three non-negative numbers at most 1, got [0.8, 1.5, 0.8]"),
    (("base_color = [0.8, 0.8, 0.8]", "base_color = [0.8, 0.8, 0.8]\nroughness = -0.1"),
     "materials.white.roughness: expected a number in [0, 1], got -0.1"),
    (("base_color = [0.8, 0.8, 0.8]", 'base_color = [0.8, 0.8, 0.8]\ndistribution = "beckmann"'),
     "materials.white.distribution: expected one of 'multi_ggx', 'ggx' (Blender's Principled BSDF distribution), "
     "got 'beckmann'"),
    (("normal = [0, -1, 0]", "normal = [0, 0, 0]"), "lights[0].normal: expected a non-zero direction, got [0, 0, 0]"),
    (("radiance = [10, 10, 10]", "radiance = [10, 10, 10]\npower = 5"),
     "lights[0]: give exactly one of 'radiance' (W/sr/m²) or 'power' (W)"),
    (("radiance = [10, 10, 10]", "radiance = [0, 0, 0]"), "lights[0].radiance: a light must emit something (all zero)"),
    (("target = [0, 0, 0]", "target = [0, 1, 3]"), "camera.target: must differ from camera.position"),
    (("fov = 40", "fov = 40\nfocal = 35"),
     "camera.focal: unknown field (allowed: fov, orbit, position, resolution, target, up)"),
    (("size = [2, 2]", 'size = "big"'), "meshes[0].size: expected two positive numbers, got 'big'"),
    (("position = [0, 1, 3]", "position = [0, 1, nan]"), "camera.position: expected three numbers, got [0, 1, nan]"),
]


@pytest.mark.parametrize("replace, message", MALFORMED, ids=[m[1].split(":")[0] for m in MALFORMED])
def test_malformed_scene_messages(make_scene, replace, message):
    old, new = replace
    assert old in GOOD
    path = make_scene(GOOD.replace(old, new, 1))
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert str(info.value) == f"{path}: {message}"


def test_invalid_toml_names_file_and_line(make_scene):
    path = make_scene("[camera\nposition = 1")
    with pytest.raises(SceneError, match=r"scene\.toml: invalid TOML: .*line 1"):
        load_scene(path)


def test_missing_scene_file(tmp_path):
    with pytest.raises(SceneError, match="nope.toml: scene file not found"):
        load_scene(tmp_path / "nope.toml")


def test_missing_camera(make_scene):
    text = GOOD[GOOD.index("[materials"):]
    with pytest.raises(SceneError, match=r"scene\.toml: camera: missing required field$"):
        load_scene(make_scene(text))


def test_no_light_at_all(make_scene):
    text = GOOD[: GOOD.index("[[lights]]")]
    with pytest.raises(SceneError, match="lights: the scene has no light"):
        load_scene(make_scene(text))


@pytest.mark.parametrize("extra", [
    "[environment]\nconstant = [0, 0, 0]\n",                    # a black environment
    "[environment]\nconstant = [1, 1, 1]\nintensity = 0\n",     # switched off
])
def test_an_environment_that_emits_nothing_is_no_light(make_scene, extra):
    """A scene lit only by a zero environment would render black everywhere, and a black image
    against a black ground truth scores as perfect: it is refused at load, with the field (a light
    of zero radiance is refused on its own field)."""
    path = make_scene(GOOD[: GOOD.index("[[lights]]")] + extra)
    with pytest.raises(SceneError) as exc:
        load_scene(path)
    assert str(exc.value) == (f"{path}: lights: the scene has no light: add [[lights]] with radiance > 0, an "
                              "[environment] above zero or an emissive material")
    load_scene(make_scene(GOOD + extra, name="lit.toml"))  # with a light beside it the scene is fine


def test_mesh_file_missing(make_scene):
    text = GOOD.replace('shape = "quad"\nsize = [2, 2]', 'shape = "file"\nfile = "bunny.ply"')
    with pytest.raises(SceneError, match=r"meshes\[0\]\.file: file 'bunny.ply' not found"):
        load_scene(make_scene(text))


def test_path_leaving_scene_folder_is_allowed_but_not_absolute(tmp_path, make_scene):
    """The user wrote the path: it may lead out of the scene's folder (tests/test_scenarios.py has the glTF's
    own URIs, which may not); an absolute path is refused, so a scene folder can move."""
    (tmp_path / "outside.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    sub = tmp_path / "scenes"
    sub.mkdir()
    text = GOOD.replace('shape = "quad"\nsize = [2, 2]', 'shape = "file"\nfile = "../outside.obj"')
    assert load_scene(make_scene(text, folder=sub)).meshes[0].file == (tmp_path / "outside.obj").resolve()
    text = GOOD.replace('shape = "quad"\nsize = [2, 2]', f'shape = "file"\nfile = "{tmp_path}/outside.obj"')
    with pytest.raises(SceneError, match="is absolute"):
        load_scene(make_scene(text, folder=sub))


def test_missing_texture_names_field(make_scene):
    text = GOOD.replace("base_color = [0.8, 0.8, 0.8]", 'base_color_texture = "wood.png"')
    with pytest.raises(SceneError, match=r"materials\.white\.base_color_texture: file 'wood.png' not found"):
        load_scene(make_scene(text))


def test_malformed_mesh_file_names_scene_field_and_line(tmp_path, make_scene):
    (tmp_path / "bad.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
    text = GOOD.replace('shape = "quad"\nsize = [2, 2]', 'shape = "file"\nfile = "bad.obj"')
    with pytest.raises(SceneError, match=r"scene\.toml: meshes\[0\]\.file: .*bad\.obj:4: malformed OBJ line"):
        load_scene(make_scene(text))


def test_obj_and_ply_files_load_with_normals(tmp_path, make_scene):
    (tmp_path / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 0 -1\nv 1 0 -1\nf 1 2 4 3\n")
    (tmp_path / "tri.ply").write_text(
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 0 -1\n3 0 1 2\n")
    for name in ("tri.obj", "tri.ply"):
        text = GOOD.replace('shape = "quad"\nsize = [2, 2]', f'shape = "file"\nfile = "{name}"')
        tri = load_scene(make_scene(text)).meshes[0].triangles()
        assert tri.triangle_count >= 1
        np.testing.assert_allclose(tri.normals, np.tile([0, 1, 0], (len(tri.normals), 1)), atol=1e-6)


def test_binary_ply_matches_ascii(tmp_path, make_scene):
    header = ("ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
              "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n")
    body = np.array([0, 0, 0, 1, 0, 0, 0, 0, -1], "<f4").tobytes() + bytes([3]) + np.array([0, 1, 2], "<i4").tobytes()
    (tmp_path / "b.ply").write_bytes(header.encode() + body)
    text = GOOD.replace('shape = "quad"\nsize = [2, 2]', 'shape = "file"\nfile = "b.ply"')
    tri = load_scene(make_scene(text)).meshes[0].triangles()
    np.testing.assert_allclose(tri.positions, [[0, 0, 0], [1, 0, 0], [0, 0, -1]])
    (tmp_path / "b.ply").write_bytes(header.encode() + body[:20])
    with pytest.raises(SceneError, match="truncated or malformed PLY"):
        load_scene(make_scene(text))


def test_power_converts_to_radiance(make_scene):
    text = GOOD.replace("radiance = [10, 10, 10]", "power = 10")
    light = load_scene(make_scene(text)).lights[0]
    # Φ = π·A·L for a one-sided Lambertian emitter
    assert light.radiance[0] == pytest.approx(10 / (np.pi * 0.25))
    np.testing.assert_allclose(light.power, 10.0)


def test_light_frame_is_right_handed(make_scene):
    light = load_scene(make_scene(GOOD)).lights[0]
    np.testing.assert_allclose(np.cross(light.tangent, light.bitangent), light.normal, atol=1e-12)
    c = light.corners()
    np.testing.assert_allclose(np.cross(c[1] - c[0], c[2] - c[0]) / 0.25, light.normal, atol=1e-9)


def test_features_and_omissions(make_scene):
    s = load_scene(make_scene(GOOD))
    f = s.features()
    assert f.area_lights and not f.environment and not f.textures and f.glossy  # roughness 0.5 default
    assert any("environment" in k for k in f.omitted())
    env = GOOD.replace("[[lights]]", '[environment]\nconstant = [1, 1, 1]\n\n[[lights]]')
    f2 = load_scene(make_scene(env, name="e.toml")).features()
    assert f2.environment and not any("environment" in k for k in f2.omitted())


def test_hash_tracks_content_not_formatting(tmp_path, make_scene):
    a = load_scene(make_scene(GOOD, name="a.toml")).hash
    b = load_scene(make_scene("# a comment\n" + GOOD, name="b.toml")).hash
    c = load_scene(make_scene(GOOD.replace("fov = 40", "fov = 41"), name="c.toml")).hash
    assert a == b and a != c
    (tmp_path / "m.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 0 -1\nf 1 2 3\n")
    text = GOOD.replace('shape = "quad"\nsize = [2, 2]', 'shape = "file"\nfile = "m.obj"')
    h1 = load_scene(make_scene(text, name="d.toml")).hash
    (tmp_path / "m.obj").write_text("v 0 0 0\nv 2 0 0\nv 0 0 -1\nf 1 2 3\n")
    assert load_scene(make_scene(text, name="d.toml")).hash != h1  # referenced file content counts
    s = load_scene(make_scene(GOOD, name="a.toml"))
    assert s.with_resolution(64, 48).hash != s.hash


def test_cornell_box_geometry():
    s = load_scene(CORNELL)
    assert s.features().names() == ["area_lights"]
    lo, hi = s.bounds()
    np.testing.assert_allclose(lo, [0, 0, 0], atol=1e-6)
    np.testing.assert_allclose(hi, [0.556, 0.5488, 0.5592], atol=1e-6)
    centre = (lo + hi) / 2
    for mesh in s.meshes[:5]:  # the five walls face into the box
        tri = mesh.triangles()
        to_centre = centre - tri.positions.mean(0)
        assert float(tri.normals[0] @ to_centre) > 0, mesh.name
    light = s.lights[0]
    assert light.area == pytest.approx(0.130 * 0.105)
    assert light.center[1] < 0.5488  # just below the ceiling


def test_primitives_are_closed_and_sized():
    from compare.scene import geometry

    sph = geometry.sphere(2.0, 64, 32)
    assert sph.surface_area() == pytest.approx(4 * np.pi * 4, rel=0.01)
    box = geometry.box((1, 2, 3))
    assert box.surface_area() == pytest.approx(2 * (2 + 3 + 6))
    cyl = geometry.cylinder(1.0, 2.0, 128)
    assert cyl.surface_area() == pytest.approx(2 * np.pi * 2 + 2 * np.pi, rel=0.01)
    # outward normals: the normal at each vertex points away from the centre
    for mesh in (sph, box):
        assert np.all(np.sum(mesh.normals * mesh.positions, axis=1) > 0)


@pytest.mark.parametrize("old, new, message", [
    ("radiance = [10, 10, 10]", "radiance = [1e-200, 1, 1]",
     "lights[0].radiance: 1e-200 is below float32's smallest normal number (1.2e-38): every renderer would compute 0"),
    ("size = [0.5, 0.5]\nnormal = [0, -1, 0]\nradiance = [10, 10, 10]",
     "size = [100, 100]\nnormal = [0, -1, 0]\npower = [1e-37, 1e-37, 1e-37]",
     "lights[0].power: gives a radiance of which 3.1831e-42 is below float32's smallest normal number (1.2e-38): "
     "every renderer would compute 0"),
    ('size = [2, 2]', 'size = [2, 2]\nscale = 1e39',
     "meshes[0].scale: 1e+39 is beyond float32's range (3.4e38): every renderer would compute infinity"),
    ('size = [2, 2]', 'size = [1e10, 1e10]\nscale = 1e10',
     "meshes[0]: its vertices reach 5e+19, beyond ±1e+15: the renderers compute in float32, where squared "
     "distances of such coordinates overflow"),
    ("center = [0, 1, 0]", "center = [0, 1e16, 0]",
     "lights[0].center: the light reaches 1e+16, beyond ±1e+15: the renderers compute in float32, where squared "
     "distances of such coordinates overflow"),
    ("position = [0, 1, 3]", "position = [0, 1, 3e20]",
     "camera.position: reaches 3e+20, beyond ±1e+15: the renderers compute in float32, where squared distances of "
     "such coordinates overflow"),
])
def test_numbers_float32_cannot_carry_are_refused(make_scene, old, new, message):
    """Finite in float64 but zero or infinite in float32 (which every renderer computes in): before, such
    scenes rendered black without a word."""
    assert old in GOOD
    path = make_scene(GOOD.replace(old, new))
    with pytest.raises(SceneError) as exc:
        load_scene(path)
    assert str(exc.value) == f"{path}: {message}"


def test_textures_are_checked_when_the_scene_loads(tmp_path):
    """Negative, NaN and unreadable texture files are refused at load, naming file and field (before:
    they loaded, and Mitsuba rendered negative reflectance or stopped with its own traceback)."""
    import OpenEXR
    import numpy as np
    import pytest

    from compare.util.errors import SceneError
    from compare.image.exr import write_exr

    base = CORNELL.read_text()
    white = "[materials.white]\nbase_color = [0.885809, 0.698859, 0.666422]"
    neg = np.full((4, 4, 3), 0.5, np.float32)
    neg[0, 0] = -2.0
    write_exr(tmp_path / "neg.exr", neg)
    nan = np.full((4, 4, 3), 0.5, np.float32)
    nan[1, 1, 0] = np.nan  # written around the suite's writer, which refuses NaN
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                 {c: np.ascontiguousarray(nan[..., i]) for i, c in enumerate("RGB")}).write(str(tmp_path / "nan.exr"))
    (tmp_path / "bad.png").write_bytes(b"\x89PNG\r\n\x1a\n garbage")
    cases = {
        "neg.exr": "neg.exr: 3 negative value(s) (first at row 0, col 0: -2); texture values are reflectances "
                   "and factors >= 0",
        "nan.exr": "nan.exr: 1 NaN or infinite value(s) (first at row 1, col 1)",
        "bad.png": "bad.png: unreadable image (",
    }
    for name, message in cases.items():
        scene = tmp_path / f"{name}.toml"
        scene.write_text(base.replace(white, f'{white}\nbase_color_texture = "{name}"'))
        with pytest.raises(SceneError) as exc:
            load_scene(scene)
        assert str(exc.value).startswith(f"{scene}: materials.white.base_color_texture: {message}"), exc.value


def test_a_scenes_reference_spp_is_no_longer_read(make_scene):
    """``--spp auto`` measures the spp a ground truth needs (tests/test_spp_auto.py); a scene file that still
    names its own constant loads, with a warning saying so."""
    with pytest.warns(UserWarning, match=r"render.reference_spp is no longer read: `compare run --spp auto` "
                                         r"measures"):
        scene = load_scene(make_scene(GOOD + "\n[render]\nreference_spp = 4096\n"))
    assert not hasattr(scene, "reference_spp")


@pytest.mark.parametrize("field, value, message", [
    ("texture_wrap", '"wrap"', "texture_wrap: expected one of 'repeat', 'clamp', 'mirror', got 'wrap'"),
    ("texture_filter", '"cubic"', "texture_filter: expected one of 'linear', 'nearest', got 'cubic'"),
    ("texture_scale", "[1.0, 0.0]", "texture_scale: expected two non-zero numbers"),
    ("texture_offset", "[1.0]", "texture_offset: expected two numbers"),
    ("emissive_texture", '"missing.png"', "emissive_texture"),
])
def test_bad_texture_settings_name_file_and_field(make_scene, field, value, message):
    text = GOOD.replace("base_color = [0.8, 0.8, 0.8]", f"base_color = [0.8, 0.8, 0.8]\n{field} = {value}", 1)
    with pytest.raises(SceneError, match=f"materials.white.{message}".replace("[", r"\[").replace("]", r"\]")
                       .replace("(", r"\(").replace(")", r"\)").replace(".", r"\.")):
        load_scene(make_scene(text))


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_ply_faces_of_one_size_and_of_mixed_sizes_read_alike(tmp_path, fmt):
    """Triangles and quads, all of one size (read at once) or mixed (read one by one), fan-triangulated
    the same way."""
    import struct

    from compare.scene.geometry import MeshFileError, load_ply

    p = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0], [2, 1, 0]], dtype=np.float32)
    cases = {"tris": [[0, 1, 2], [0, 2, 3], [1, 4, 5], [1, 5, 2]], "quads": [[0, 1, 2, 3], [1, 4, 5, 2]],
             "mixed": [[0, 1, 2, 3], [1, 4, 5], [1, 5, 2]]}
    loaded = {}
    for name, faces in cases.items():
        head = (f"ply\nformat {fmt} 1.0\nelement vertex {len(p)}\nproperty float x\nproperty float y\n"
                f"property float z\nelement face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
        if fmt == "ascii":
            body = "".join(" ".join(map(str, v)) + "\n" for v in p) + "".join(
                f"{len(f)} {' '.join(map(str, f))}\n" for f in faces)
            data = head.encode() + body.encode()
        else:
            e = "<" if fmt == "binary_little_endian" else ">"
            data = head.encode() + p.astype(e + "f4").tobytes() + b"".join(
                struct.pack(f"{e}B{len(f)}i", len(f), *f) for f in faces)
        (tmp_path / f"{name}.ply").write_bytes(data)
        loaded[name] = load_ply(tmp_path / f"{name}.ply")
    area = lambda m: 0.5 * np.linalg.norm(np.cross(m.positions[m.indices[:, 1]] - m.positions[m.indices[:, 0]],  # noqa: E731
                                                   m.positions[m.indices[:, 2]] - m.positions[m.indices[:, 0]]), axis=1)
    for name, mesh in loaded.items():
        assert mesh.triangle_count == 4, name
        assert area(mesh).sum() == pytest.approx(2.0), name
    np.testing.assert_array_equal(np.sort(loaded["tris"].indices.ravel()), np.sort(loaded["quads"].indices.ravel()))
    # a bad index in faces of one size is one error naming the face
    bad = tmp_path / "bad.ply"
    bad.write_bytes((tmp_path / "tris.ply").read_bytes().replace(b"3 1 5 2", b"3 1 9 2") if fmt == "ascii"
                    else (tmp_path / "tris.ply").read_bytes()[:-4] + struct.pack(
                        ("<" if fmt == "binary_little_endian" else ">") + "i", 9))
    with pytest.raises(MeshFileError, match=r"bad.ply: PLY face \[1, [59], [29]\] is invalid for 6 vertices"):
        load_ply(bad)


@pytest.mark.parametrize("form", ["{v}", "{v}/{t}", "{v}/{t}/{n}", "{v}//{n}"])
def test_obj_read_at_once_equals_the_line_reader(tmp_path, monkeypatch, form):
    """The whole-file OBJ reader (no loop per face) gives the line reader's triangles, corners and welding,
    for each corner form, with triangles, quads and a pentagon; a file it does not take falls back."""
    from compare.scene import geometry

    rng = np.random.default_rng(3)
    lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in rng.normal(size=(12, 3))]
    lines += [f"vt {u:.4f} {v:.4f}" for u, v in rng.random((12, 2))]
    lines += [f"vn {x:.4f} {y:.4f} {z:.4f}" for x, y, z in rng.normal(size=(12, 3))]
    lines += ["o part", "usemtl x", "s off"]
    for corners in ([0, 1, 2], [2, 3, 4, 5], [5, 6, 7], [7, 8, 9, 10, 11], [0, 2, 4]):
        lines.append("f " + " ".join(form.format(v=c + 1, t=(c * 5) % 12 + 1, n=(c * 7) % 12 + 1) for c in corners))
    path = tmp_path / "m.obj"
    path.write_text("\n".join(lines) + "\n")
    fast = geometry.load_obj(path)
    monkeypatch.setattr(geometry, "_obj_at_once", lambda data: None)
    slow = geometry.load_obj(path)
    assert fast.triangle_count == slow.triangle_count == 1 + 2 + 1 + 3 + 1

    def corners(m):
        return np.concatenate([m.positions[m.indices], m.normals[m.indices], m.uvs[m.indices]], axis=2)

    np.testing.assert_allclose(corners(fast), corners(slow), atol=1e-6)
    assert len(fast.positions) == len(slow.positions)  # the same welding


def test_an_obj_the_fast_reader_refuses_still_names_its_bad_line(tmp_path):
    from compare.scene.geometry import MeshFileError, load_obj

    path = tmp_path / "bad.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 7\n")
    with pytest.raises(MeshFileError, match=r"bad.obj:5: malformed OBJ line 'f 1 2 7': index 7 out of range"):
        load_obj(path)


@pytest.mark.parametrize("side", [1e-7, 1e-10])
def test_a_light_below_what_renderers_resolve_is_floored_with_its_power_and_both_renderers_agree(tmp_path, side,
                                                                                                   gl_ctx):
    """A light of 0.1 µm or 1e-10 m (which made the rasterizer thousands of times too bright and the
    reference black) is drawn as a 10 µm square of the same power, with a warning, in every renderer."""
    import math

    from compare.mitsuba.reference import ReferenceRenderer
    from compare.progressive.rasterizer import render_progressive
    from compare.scene.model import LIGHT_SIDE_FLOOR

    power = 2.0
    path = tmp_path / "tiny.toml"
    path.write_text(f"""
[camera]
position = [0, 2.5, 0.001]
target = [0, 0, 0]
fov = 40.0
resolution = [24, 24]
[materials.white]
base_color = [0.8, 0.8, 0.8]
roughness = 1.0
[[meshes]]
name = "floor"
shape = "quad"
size = [2.0, 2.0]
material = "white"
[[lights]]
center = [0.0, 1.0, 0.0]
size = [{side}, {side}]
normal = [0.0, -1.0, 0.0]
power = [{power}, {power}, {power}]
""")
    with pytest.warns(UserWarning, match=r"lights\[0\]: light 'light0' is .* below the 1e-05 m every renderer can "
                                         r"resolve: drawn as 1e-05 x 1e-05 m with the same power"):
        scene = load_scene(path)
    (light,) = scene.lights
    assert light.size == (LIGHT_SIDE_FLOOR, LIGHT_SIDE_FLOOR)
    assert float(light.power[0]) == pytest.approx(power, rel=1e-6)
    ref = ReferenceRenderer(scene, materials="diffuse", cache_dir=False, progress=False).render(16).image
    raster = render_progressive(scene, frames=8, materials="diffuse", ctx=gl_ctx).image
    # straight below: E = I / d^2 with the Lambertian emitter's on-axis intensity I = P / pi
    centre = 0.8 / math.pi * power / math.pi
    assert float(ref[11:13, 11:13, 0].mean()) == pytest.approx(centre, rel=0.03)
    assert float(raster[11:13, 11:13, 0].mean()) == pytest.approx(centre, rel=0.03)
