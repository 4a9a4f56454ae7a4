"""Hostile and degenerate inputs that used to pass in silence or stop with a traceback: each is one error
naming the file and field, or renders as the file means it."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from compare.scene.loader import load_scene
from compare.util.errors import CompareError, SceneError
from tests.helpers import ROOT

LIT = """
    include = "model.gltf"

    [camera]
    position = [0.0, 0.0, 3.0]
    target = [0.0, 0.0, 0.0]
    fov = 40.0
    resolution = [16, 12]
    """


def _model(folder, *, light_node=None, kind="spot", positions=None, material=None, emissive=None):
    """A card (or the given positions) and, with ``light_node`` (a node's fields), a punctual light."""
    from compare.scene import geometry
    from compare.scene.gltf_write import GltfWriter

    w = GltfWriter()
    mat = w.material("card", (0.8, 0.8, 0.8), 0.0, 0.5)
    if material:
        w.doc["materials"][mat].update(material)
    if emissive is not None:
        w.doc["materials"][mat].update(emissive)
    tri = geometry.quad((1.0, 1.0))
    if positions is not None:
        tri = geometry.TriangleMesh(np.asarray(positions, np.float32), tri.normals, tri.uvs, tri.indices)
    w.node("card", mesh=w.mesh("card", [(tri, mat)]), rotation=[math.sin(math.pi / 4), 0, 0, math.cos(math.pi / 4)])
    if light_node is not None:
        li = w.light("lamp", kind, 100.0)
        node = w.node("lamp", light=li)
        w.doc["nodes"][node].update(light_node)
    return w.write(folder / "model.gltf")


@pytest.mark.parametrize("fields, where", [
    ({"scale": [0.0, 0.0, 0.0], "translation": [0, 0, 2]}, r"nodes\[1\]: the spot light's node transform has zero "
                                                           r"scale"),
    ({"rotation": [float("nan"), 0.0, 0.0, 1.0]}, r"nodes\[1\]\.rotation: expected 4 finite numbers"),
    ({"rotation": [0.0, 0.0, 0.0, 0.0]}, r"nodes\[1\]\.rotation: a rotation quaternion must have unit length"),
    ({"matrix": [float("nan")] * 16}, r"nodes\[1\]\.matrix: expected 16 finite numbers"),
    ({"translation": [1e308, 0, 0], "scale": [1e308, 1e308, 1e308]}, r"nodes\[1\]"),
])
def test_a_light_under_a_degenerate_node_is_one_error_naming_the_node(tmp_path, make_scene, fields, where):
    _model(tmp_path, light_node=fields)
    with pytest.raises(CompareError, match=where):
        load_scene(make_scene(LIT))


def test_a_point_light_under_zero_scale_keeps_its_place(tmp_path, make_scene):
    """glTF: a light's properties are unaffected by its node's scale; a point light needs no direction."""
    _model(tmp_path, light_node={"scale": [0.0, 0.0, 0.0], "translation": [0.0, 0.0, 2.0]}, kind="point")
    (light,) = load_scene(make_scene(LIT)).punctual
    assert light.position == pytest.approx((0.0, 0.0, 2.0)) and np.all(np.isfinite(light.direction))


def test_vertices_beyond_the_float32_range_are_refused_at_load(tmp_path, make_scene):
    _model(tmp_path, positions=[[-1e16, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]])
    with pytest.raises(CompareError, match=r"model.gltf: nodes\[0\] \(mesh 0, primitive 0\): its vertices reach 1e\+16"):
        load_scene(make_scene(LIT))


@pytest.mark.parametrize("material, where", [
    ({"extensions": {"KHR_materials_volume": {"attenuationColor": [5.0, 1.0, 1.0]}}},
     r"attenuationColor: expected three numbers in \[0, 1\]"),
    ({"emissiveFactor": [1.0, 1.0, 1.0], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": -2}}},
     r"emissiveStrength: expected a finite number >= 0"),
    ({"emissiveFactor": [-1.0, 0.0, 0.0]}, r"emissiveFactor: expected three numbers >= 0"),
])
def test_out_of_range_material_values_are_refused_not_clamped(tmp_path, make_scene, material, where):
    _model(tmp_path, material=material)
    with pytest.raises(CompareError, match=where):
        load_scene(make_scene(LIT))


def test_the_documented_toml_default_attenuation_distance_inf_is_accepted(make_scene):
    scene = load_scene(make_scene("""
        [camera]
        position = [0.0, 0.0, 3.0]
        target = [0.0, 0.0, 0.0]

        [materials.glass]
        transmission = 1.0
        thickness = 0.5
        attenuation_distance = inf

        [[meshes]]
        shape = "sphere"
        radius = 0.5
        material = "glass"

        [environment]
        constant = [1.0, 1.0, 1.0]
        """))
    assert math.isinf(scene.materials["glass"].attenuation_distance)
    with pytest.raises(SceneError, match="attenuation_distance"):
        load_scene(make_scene("""
            [camera]
            position = [0.0, 0.0, 3.0]
            target = [0.0, 0.0, 0.0]

            [materials.glass]
            attenuation_distance = -inf

            [[meshes]]
            shape = "sphere"
            radius = 0.5
            material = "glass"

            [environment]
            constant = [1.0, 1.0, 1.0]
            """))


def _reference(scene, spp=32):
    from compare.mitsuba.reference import ReferenceRenderer

    return ReferenceRenderer(scene, cache_dir=False, progress=False).render(spp, seed=2).image


def test_an_index_matched_rough_volume_lets_light_through_tinted(make_scene):
    """ior 1 on rough glass (the Khronos TransmissionRoughnessTest has it): no interface, so the light goes
    straight through, tinted by the base colour; it used to stop Mitsuba ("indices must differ")."""
    scene = load_scene(make_scene("""
        [camera]
        position = [0.0, 0.0, 3.0]
        target = [0.0, 0.0, 0.0]
        fov = 20.0
        resolution = [16, 16]

        [materials.matched]
        base_color = [1.0, 0.5, 0.25]
        transmission = 1.0
        ior = 1.0
        roughness = 0.6
        thickness = 0.5

        [[meshes]]
        shape = "quad"
        size = [3.0, 3.0]
        rotate = [90.0, 0.0, 0.0]
        material = "matched"

        [environment]
        constant = [1.0, 1.0, 1.0]
        """))
    image = _reference(scene)
    np.testing.assert_allclose(image[4:12, 4:12].mean((0, 1)), [1.0, 0.5, 0.25], rtol=0.03)


def _spot_scene(make_scene, outer: float):
    return load_scene(make_scene(f"""
        [camera]
        position = [0.0, 3.0, 0.01]
        target = [0.0, 0.0, 0.0]
        fov = 60.0
        resolution = [16, 16]

        [materials.floor]
        base_color = [0.8, 0.8, 0.8]
        roughness = 1.0

        [[meshes]]
        shape = "quad"
        size = [4.0, 4.0]
        material = "floor"

        [[lights]]
        type = "spot"
        position = [0.0, 1.0, 0.0]
        direction = [0.0, -1.0, 0.0]
        intensity = 683.0
        inner_cone = 0.0
        outer_cone = {outer}
        """))


def test_a_spot_of_a_90_degree_cone_lights_the_ground_truth(make_scene):
    """glTF allows an outer cone of exactly 90°: the ground truth was black there (Mitsuba maps its spot
    texture by tan(cone)); it lights the floor as a cone of 89.9° does."""
    wide = float(_reference(_spot_scene(make_scene, 90.0)).mean())
    almost = float(_reference(_spot_scene(make_scene, 89.9)).mean())
    assert wide > 0.01 and wide == pytest.approx(almost, rel=0.02)


def test_negative_timings_in_results_are_refused(tmp_path):
    from compare.report.results import Results, ResultsError

    golden = ROOT / "tests" / "data" / "cornell-48x36-golden.json"
    for path, value in ((("runs", 0, "points", 0, "seconds"), -464651.0), (("runs", 1, "setup_seconds"), -1.0),
                        (("runs", 0, "first_frame_seconds"), -0.5)):
        d = json.loads(golden.read_text())
        node = d["scenes"][0]
        for k in path[:-1]:
            node = node[k]
        node[path[-1]] = value
        bad = tmp_path / "results.json"
        bad.write_text(json.dumps(d))
        with pytest.raises(ResultsError, match=r"seconds: expected a finite number of seconds >= 0"):
            Results.load(bad)


def test_measure_against_a_black_ground_truth_says_flip_is_undefined(tmp_path, make_scene, capsys):
    """A scene whose light is all behind the camera's view is black: FLIP of anything against it is
    undefined, which the command says (it used to write the report, then stop formatting None)."""
    from compare.cli.main import main
    from compare.image.exr import write_exr

    scene = make_scene("""
        [camera]
        position = [0.0, 0.0, 3.0]
        target = [0.0, 0.0, 0.0]
        resolution = [16, 12]

        [materials.black]
        base_color = [0.0, 0.0, 0.0]
        roughness = 1.0
        metallic = 0.0

        [[meshes]]
        shape = "quad"
        size = [10.0, 10.0]
        rotate = [90.0, 0.0, 0.0]
        material = "black"

        [[lights]]
        center = [0.0, 0.0, -1.0]
        size = [0.1, 0.1]
        normal = [0.0, 0.0, -1.0]
        radiance = [1.0, 1.0, 1.0]
        """)
    images = tmp_path / "mine"
    images.mkdir()
    write_exr(images / "step-1.exr", np.zeros((12, 16, 3), np.float32))
    (images / "timings.json").write_text(json.dumps({"setup_seconds": 0.0, "seconds": {"1": 0.1}}))
    rc = main(["measure", str(images), "--scene", str(scene), "--spp", "4", "-o", str(tmp_path / "out"), "--quiet"])
    out = capsys.readouterr()
    assert rc == 0, out.err
    assert "final FLIP undefined" in out.out


def test_text_from_files_is_inert_in_a_terminal_markdown_and_xml():
    from xml.etree import ElementTree as ET

    from compare.util.text import markdown_text, terminal_text, xml_text

    title = "\x1b]0;owned\x07car\x1b]52;c;ZWNobyBoaQ==\x07"  # a window title and a clipboard write
    assert "\x1b" not in terminal_text(title) and "\x07" not in terminal_text(title)
    assert terminal_text("plain name — ok\n") == "plain name — ok\n"
    md = markdown_text("<img src=x onerror=alert(1)> [click](javascript:x) **bold** | cell")
    assert "<img" not in md and "](" not in md and "**" not in md and " | " not in md
    raw = "a\x00b\x1bc"
    ET.fromstring("<a>" + xml_text(raw) + "</a>")  # would raise on a control character


def test_inspect_prints_a_glTFs_escape_sequences_inert(tmp_path, capsys):
    from compare.cli.main import main
    from compare.scene import geometry
    from compare.scene.gltf_write import GltfWriter

    w = GltfWriter()
    mat = w.material("\x1b]0;owned\x07paint", (0.8, 0.8, 0.8), 0.0, 0.5)
    w.node("\x1b[2Jcard", mesh=w.mesh("card", [(geometry.quad((1.0, 1.0)), mat)]))
    w.doc["extensionsUsed"] = ["\x1b]0;owned\x07EXT_evil"]  # listed by inspect among the extensions
    path = w.write(tmp_path / "evil.gltf")
    assert main(["inspect", str(path)]) == 0
    out = capsys.readouterr().out
    assert "EXT_evil" in out and "\\x1b" in out
    assert "\x1b" not in out and "\x07" not in out


def test_inspect_refuses_vertices_beyond_the_float32_range(tmp_path, capsys):
    from compare.cli.main import main

    path = _model(tmp_path, positions=[[-1e16, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]])
    assert main(["inspect", str(path)]) == 2
    err = capsys.readouterr().err
    assert "model.gltf: nodes[0] (mesh 0, primitive 0): its vertices reach 1e+16" in err and "Traceback" not in err


def test_an_unreadable_map_is_one_error(tmp_path, capsys):
    """A glTF whose map file is empty (a download that lost its textures): inspect and a run each stop with one
    error naming the file, the material and the image (inspect used to end in a traceback)."""
    import json as json_

    from compare.cli.main import main
    from compare.scene import geometry
    from compare.scene.gltf_write import GltfWriter

    w = GltfWriter()
    mat = w.material("paint", (0.8, 0.8, 0.8), 0.0, 0.5)
    w.node("card", mesh=w.mesh("card", [(geometry.quad((1.0, 1.0)), mat)]))
    doc = w.document(embed_buffer=True)
    doc["images"] = [{"uri": "lost.png"}]
    doc["textures"] = [{"source": 0}]
    doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}
    (tmp_path / "lost.png").write_bytes(b"")
    path = tmp_path / "model.gltf"
    path.write_text(json_.dumps(doc))
    assert main(["inspect", str(path)]) == 2
    err = capsys.readouterr().err
    assert "model.gltf" in err and "materials[0]: image 0: unreadable image" in err and "Traceback" not in err
    assert main(["run", "--scenes", str(path), "--renderers", "progressive", "--frames", "1", "--spp", "1",
                 "--size", "8x8", "--no-report", "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "model.gltf" in err and "image 0: unreadable image" in err and "Traceback" not in err
