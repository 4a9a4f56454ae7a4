"""Property-based fuzzing of every input the suite reads: one clear error or a correct result.

Scene files, meshes (OBJ, PLY, glTF), images (EXR, HDR, PNG), thresholds, results
files and command lines are mutated at random (hypothesis). Each must either
load, or fail with a :class:`compare.util.errors.CompareError` whose message names
the file it is about; no other exception, no traceback, no file half-written.

Textures (PNG, EXR) are fuzzed through the scene that names them. How many
cases each property tries is the hypothesis profile's (tests/conftest.py): the
default run tries a few dozen per input (seconds); ``-m slow`` (or
``HYPOTHESIS_PROFILE=slow``) runs the same properties with many more.
"""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
import tomli_w
from hypothesis import given, strategies as st

from compare.util.errors import CompareError
from tests.helpers import ROOT


# --------------------------------------------------------------------------- a scene with one of everything


OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1/1 2/2/1 3/3/1\n"
PLY = ("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
       "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")


def _gltf() -> dict:
    from compare.scene.geometry import box
    from compare.scene.gltf_write import GltfWriter

    from compare.scene.model import LAYERS

    w = GltfWriter()
    m = w.material("grey", (0.5, 0.5, 0.5), 0.0, 0.5)
    # every material extension's factors (valid), for the mutations to break
    exts: dict = {}
    for layer in LAYERS:
        value = [0.5, 0.5, 0.5] if layer.color else (2.0 if layer.field == "attenuation_distance" else 0.5
                                                     if layer.field != "ior" else 1.4)
        exts.setdefault(layer.extension, {})[layer.key] = value
        w._use(layer.extension)  # noqa: SLF001
    w.doc["materials"][m]["extensions"] = exts
    w.doc["materials"][m]["alphaMode"] = "BLEND"
    w.node("box", mesh=w.mesh("box", [(box([0.2, 0.2, 0.2]), m)]), translation=[0.0, 0.1, 0.0])
    return w.document(embed_buffer=True)


SCENE = {
    "name": "fuzz",
    "camera": {"position": [0.0, 0.5, 2.0], "target": [0.0, 0.3, 0.0], "up": [0.0, 1.0, 0.0], "fov": 45.0,
               "resolution": [8, 6]},
    "render": {"max_depth": 4},
    "materials": {"white": {"base_color": [0.8, 0.8, 0.8], "roughness": 0.5, "metallic": 0.0},
                  "tex": {"base_color": [1.0, 1.0, 1.0], "base_color_texture": "tex.exr"},
                  "lamp": {"base_color": [0.0, 0.0, 0.0], "emission": [1.0, 1.0, 1.0]},
                  "png": {"base_color_texture": "tex.png"},
                  "glass": {"transmission": 1.0, "ior": 1.5, "thickness": 0.1, "attenuation_distance": 1.0,
                            "attenuation_color": [0.9, 0.8, 0.7], "clearcoat": 0.5, "clearcoat_roughness": 0.1,
                            "sheen_color": [0.2, 0.2, 0.2], "sheen_roughness": 0.5, "specular": 0.8,
                            "specular_color": [1.0, 0.9, 0.8], "alpha_mode": "blend", "alpha": 0.6}},
    "meshes": [{"name": "floor", "shape": "quad", "material": "white", "size": [2.0, 2.0]},
               {"name": "obj", "shape": "file", "file": "m.obj", "material": "tex"},
               {"name": "ply", "shape": "file", "file": "m.ply", "material": "lamp", "translate": [0.3, 0.0, 0.0]}],
    "lights": [{"name": "key", "center": [0.0, 1.0, 0.0], "size": [0.5, 0.5], "normal": [0.0, -1.0, 0.0],
                "radiance": [5.0, 5.0, 5.0]}],
    "environment": {"file": "env.exr", "intensity": 1.0},
    "include": [{"file": "part.gltf", "translate": [0.0, 0.0, -0.5]}],
}


def to_toml(d: dict) -> str:
    """TOML text of ``d`` (tomli-w; NaN and infinities as TOML's nan and inf). Raises TypeError for what
    TOML cannot hold (None, a non-string key)."""
    return tomli_w.dumps(d)


@pytest.fixture(scope="module")
def template(tmp_path_factory) -> Path:
    from compare.image.exr import write_exr

    folder = tmp_path_factory.mktemp("fuzz-template")
    (folder / "m.obj").write_text(OBJ)
    (folder / "m.ply").write_text(PLY)
    (folder / "part.gltf").write_text(json.dumps(_gltf()))
    write_exr(folder / "tex.exr", np.full((4, 4, 3), 0.5, np.float32))
    (folder / "tex.png").write_bytes(PNG)
    write_exr(folder / "env.exr", np.full((8, 16, 3), 0.2, np.float32))
    (folder / "scene.toml").write_text(to_toml(SCENE))
    return folder


def _copy(template: Path, tmp: Path) -> Path:
    folder = tmp / f"case-{len(list(tmp.iterdir())) if tmp.exists() else 0}"
    shutil.copytree(template, folder)
    return folder


def _png() -> bytes:
    import io

    from PIL import Image

    b = io.BytesIO()
    Image.new("RGB", (4, 4), (200, 100, 50)).save(b, "PNG")
    return b.getvalue()


PNG = _png()


def _loads_or_names(path: Path, what: Path | None = None) -> None:
    """``load_scene(path)`` succeeds, or fails with a CompareError naming ``what`` (default: the scene)."""
    from compare.scene.loader import load_scene

    try:
        scene = load_scene(path)
    except CompareError as exc:
        names = {str(path), path.name} | ({str(what), what.name} if what else set())
        assert any(n in str(exc) for n in names), f"message names no file: {exc}"
        assert "\n" not in str(exc).strip() or "Traceback" not in str(exc)
        return
    # what loads is usable: finite camera, world-space triangles
    assert all(np.isfinite(m.triangles().positions).all() for m in scene.meshes)


# --------------------------------------------------------------------------- mutations

scalars = st.one_of(st.integers(min_value=-(2**70), max_value=2**70),
                    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=12), st.booleans(),
                    st.sampled_from([0, -1, 1e-300, 1e300, 1e39, -0.0, "../../etc/passwd", "m.obj", "nope.exr"]))
values = st.recursive(scalars, lambda inner: st.one_of(st.lists(inner, max_size=5),
                                                       st.dictionaries(st.text(max_size=6), inner, max_size=3)),
                      max_leaves=8)


def _paths(d, prefix=()):
    """Every (path, value) inside nested dicts and lists."""
    yield prefix, d
    if isinstance(d, dict):
        for k, v in d.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(d, list):
        for i, v in enumerate(d):
            yield from _paths(v, prefix + (i,))


@st.composite
def mutated(draw, base: dict):
    """``base`` with 1–3 random edits: a value replaced, a key deleted, or an unknown key added."""
    d = json.loads(json.dumps(base))
    for _ in range(draw(st.integers(1, 3))):
        paths = [p for p, _ in _paths(d) if p]
        path = draw(st.sampled_from(paths))
        parent = d
        for k in path[:-1]:
            parent = parent[k]
        op = draw(st.sampled_from(["replace", "replace", "delete", "add"]))
        if op == "replace":
            parent[path[-1]] = draw(values)
        elif op == "delete" and isinstance(parent, (dict, list)):
            del parent[path[-1]]
        elif isinstance(parent, dict):
            parent[draw(st.text(min_size=1, max_size=8))] = draw(values)
    return d


# --------------------------------------------------------------------------- the properties


def check_scene_text(template: Path, tmp: Path, data: dict) -> None:
    folder = _copy(template, tmp)
    try:
        text = to_toml(data)
    except TypeError:
        return
    (folder / "scene.toml").write_text(text)
    _loads_or_names(folder / "scene.toml")


def check_mesh_bytes(template: Path, tmp: Path, name: str, data: bytes) -> None:
    """A file the scene names (a mesh or a texture) replaced by ``data``."""
    folder = _copy(template, tmp)
    (folder / name).write_bytes(data)
    _loads_or_names(folder / "scene.toml", folder / name)


def check_gltf(template: Path, tmp: Path, doc: dict) -> None:
    folder = _copy(template, tmp)
    (folder / "part.gltf").write_text(json.dumps(doc))
    _loads_or_names(folder / "scene.toml", folder / "part.gltf")


def check_image_bytes(template: Path, tmp: Path, name: str, data: bytes) -> None:
    from compare.scene.environments import load_equirect
    from compare.image.exr import read_exr

    folder = _copy(template, tmp)
    path = folder / name
    path.write_bytes(data)
    try:
        if name.endswith(".exr"):
            image, _ = read_exr(path)
            assert image.ndim == 3 and image.shape[2] == 3
        load_equirect(path)
    except CompareError as exc:
        assert str(path) in str(exc) or path.name in str(exc), exc


def check_thresholds(tmp: Path, data: dict) -> None:
    from compare.report.check import load_thresholds

    path = tmp / "t.toml"
    try:
        path.write_text(to_toml(data))
    except TypeError:
        return
    try:
        load_thresholds(path)
    except CompareError as exc:
        assert str(path) in str(exc) or "rule" in str(exc), exc


def check_results(tmp: Path, data) -> None:
    from compare.report.results import Results

    path = tmp / "results.json"
    path.write_text(json.dumps(data, allow_nan=True) if not isinstance(data, bytes) else "")
    try:
        Results.load(path)
    except CompareError as exc:
        assert str(path) in str(exc), exc


def check_cli(tmp: Path, argv: list[str], capsys) -> None:
    from compare.cli.main import main

    before = {p: p.stat().st_mtime_ns for p in tmp.rglob("*") if p.is_file()}
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse: usage errors exit 2 with one message
        assert exc.code in (0, 2), argv
        code = exc.code
    out = capsys.readouterr()
    assert "Traceback" not in out.err, (argv, out.err)
    if code == 2 and out.err.startswith("compare: error:"):
        assert out.err.count("\n") == 1, (argv, out.err)
    for p, t in before.items():  # no input touched
        assert not p.exists() or p.stat().st_mtime_ns == t or p.suffix in (".exr", ".png", ".json"), p
    assert not [p for p in tmp.rglob(".*") if p.is_file() and ".part-" in p.name], "half-written file left"


def _results_template() -> dict:
    return json.loads((ROOT / "tests" / "data" / "cornell-48x36-golden.json").read_text())


def _cli_argv():
    words = st.sampled_from(["diff", "check", "renderers", "report", "measure", "render", "--json", "--maps",
                             "--exposure", "0", "-1", "nan", "1e39", "--thresholds", "--size", "0x0", "9x9x9",
                             "--renderer", "progressive:nope", "--scene", "-o", "a.exr", "b.exr", "t.toml",
                             "results.json", "nowhere/", "--quiet", "--fresh", "x.png", "--steps", "--spp"])
    return st.lists(words, min_size=1, max_size=7)


@pytest.fixture
def case_dir(tmp_path) -> Path:
    d = tmp_path / "cases"
    d.mkdir()
    return d


@given(data=mutated(SCENE))
def test_fuzz_scene_files(template, case_dir, data):
    check_scene_text(template, case_dir, data)


mesh_bytes = st.one_of(st.binary(max_size=300),
                       st.builds(lambda s, i, b: (s[:i] + b + s[i:]).encode(), st.sampled_from([OBJ, PLY]),
                                 st.integers(0, 200), st.text(max_size=20)),
                       st.builds(lambda s, i: s[:i].encode(), st.sampled_from([OBJ, PLY]), st.integers(0, 200)))


@given(name=st.sampled_from(["m.obj", "m.ply"]), data=mesh_bytes)
def test_fuzz_mesh_files(template, case_dir, name, data):
    check_mesh_bytes(template, case_dir, name, data)


@given(doc=mutated(_gltf()))
def test_fuzz_gltf_files(template, case_dir, doc):
    check_gltf(template, case_dir, doc)


def _image_bytes():
    from compare.image.exr import write_exr

    tmp = Path(__import__("tempfile").mkdtemp())
    write_exr(tmp / "a.exr", np.full((8, 16, 3), 0.2, np.float32))
    exr = (tmp / "a.exr").read_bytes()
    hdr = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 2\n" + bytes([128, 128, 128, 129]) * 4
    shutil.rmtree(tmp)
    cut = st.builds(lambda s, i: s[:i], st.sampled_from([exr, hdr]), st.integers(0, 400))
    flip = st.builds(lambda s, i, b: s[:i] + bytes([b]) + s[i + 1:], st.sampled_from([exr, hdr]),
                     st.integers(0, 400), st.integers(0, 255))
    return st.one_of(st.binary(max_size=200), cut, flip)


IMAGES = _image_bytes()


@given(name=st.sampled_from(["env.exr", "env.hdr"]), data=IMAGES)
def test_fuzz_image_files(template, case_dir, name, data):
    check_image_bytes(template, case_dir, name, data)


texture_bytes = st.one_of(
    st.binary(max_size=120),
    st.builds(lambda i: PNG[:i], st.integers(0, len(PNG))),
    st.builds(lambda i, b: PNG[:i] + bytes([b]) + PNG[i + 1:], st.integers(0, len(PNG) - 1), st.integers(0, 255)))


@given(name=st.sampled_from(["tex.png", "tex.exr"]), data=texture_bytes)
def test_fuzz_texture_files(template, case_dir, name, data):
    check_mesh_bytes(template, case_dir, name, data)  # the scene names the texture: it loads or names it


THRESHOLDS = {"schema": 1, "rule": [{"scene": "Cornell box", "renderer": "progressive", "step": "final",
                                      "max": {"flip": 0.3}, "min": {"ssim": 0.5}, "note": "x"}]}


@given(data=mutated(THRESHOLDS))
def test_fuzz_thresholds(tmp_path, data):
    check_thresholds(tmp_path, data)


@given(data=mutated(_results_template()))
def test_fuzz_results_files(tmp_path, data):
    check_results(tmp_path, data)


@given(argv=_cli_argv())
def test_fuzz_command_lines(tmp_path, capsys, monkeypatch, argv):
    monkeypatch.chdir(tmp_path)  # whatever the arguments write lands here
    check_cli(tmp_path, argv, capsys)


# --------------------------------------------------------------------------- node graphs, claimed sizes, headers, names


@given(edges=st.lists(st.tuples(st.integers(0, 7), st.integers(0, 7)), max_size=16),
       scenes=st.booleans(), roots=st.lists(st.integers(0, 7), max_size=3))
def test_fuzz_gltf_node_graphs(template, case_dir, edges, scenes, roots):
    """Any graph of parent → child links (cycles, shared children, self links), with or without scenes:
    it loads, or it is one error naming the file (a cycle is never an empty model)."""
    doc = _gltf()
    mesh_node = doc["nodes"][0]
    nodes = [dict(mesh_node) if k == 0 else {"name": f"n{k}"} for k in range(8)]
    for parent, child in edges:
        nodes[parent].setdefault("children", [])
        if child not in nodes[parent]["children"]:
            nodes[parent]["children"].append(child)
    doc["nodes"] = nodes
    if scenes:
        doc["scenes"] = [{"nodes": sorted(set(roots)) or [0]}]
    else:
        doc.pop("scenes", None)
        doc.pop("scene", None)
    check_gltf(template, case_dir, doc)


@given(count=st.one_of(st.integers(-5, 10), st.integers(10, 2**62)), offset=st.integers(-16, 2**40),
       stride=st.one_of(st.none(), st.integers(-4, 2**20)), drop_view=st.booleans())
def test_fuzz_gltf_claimed_sizes(template, case_dir, count, offset, stride, drop_view):
    """Counts, offsets and strides that no bytes back are refused before anything is allocated."""
    doc = _gltf()
    acc = doc["accessors"][doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"]]
    acc["count"], acc["byteOffset"] = count, offset
    if drop_view:
        acc.pop("bufferView", None)
    elif stride is not None:
        doc["bufferViews"][acc["bufferView"]]["byteStride"] = stride
    check_gltf(template, case_dir, doc)


def _png_claiming(width: int, height: int, depth: int, colour: int) -> bytes:
    import struct
    import zlib

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, depth, colour, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(b"\0" * 16)) + chunk(b"IEND", b""))


@given(width=st.integers(0, 2**31 - 1), height=st.integers(0, 2**31 - 1), depth=st.sampled_from([1, 2, 4, 8, 16, 3]),
       colour=st.sampled_from([0, 2, 3, 4, 6, 5]))
def test_fuzz_image_headers(template, case_dir, width, height, depth, colour):
    """A PNG header claiming any size and format is read or refused on its header, one error naming it."""
    check_mesh_bytes(template, case_dir, "tex.png", _png_claiming(width, height, depth, colour))


@given(name=st.text(min_size=0, max_size=80))
def test_fuzz_renderer_names(tmp_path_factory, name):
    """Any name of a renderer file's table: refused with one error naming the file, or a name that is a
    folder of its own (lowercase, no separator) and no reserved word."""
    from compare.renderers.registry import Registry
    from compare.renderers.registry import NAME

    folder = tmp_path_factory.mktemp("names")
    path = folder / "r.toml"
    path.write_text(f'[renderer.{json.dumps(name)}]\ncommand = ["x", "{{job}}"]\n', encoding="utf-8")
    try:
        registry = Registry(path)
    except CompareError as exc:
        assert str(path) in str(exc)
        return
    assert NAME.fullmatch(name) and name not in {"reference", "all", "web"}
    assert name in registry.names()


_number = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-2**70, 2**70),
                    st.sampled_from([0.0, -0.0, 1e-320, 1e308, -1e308]))


@given(kind=st.sampled_from(["point", "spot", "directional"]),
       field=st.sampled_from(["translation", "rotation", "scale", "matrix"]),
       values=st.lists(_number, min_size=0, max_size=17))
def test_fuzz_light_node_transforms(template, case_dir, kind, field, values):
    """Any node transform of a punctual light: a scene whose lights are finite (a position in range, a unit
    direction) or one error naming the file; never NaN into a renderer, never a traceback."""
    from compare.scene.gltf_write import GltfWriter
    from compare.scene.loader import load_scene

    w = GltfWriter()
    light = w.light("lamp", kind, 10.0)
    node = w.node("lamp", light=light)
    w.doc["nodes"][node][field] = values
    doc = w.document(embed_buffer=True)
    (case_dir / "m.gltf").write_text(json.dumps(doc, allow_nan=True))
    scene_path = case_dir / "scene.toml"
    scene_path.write_text('include = "m.gltf"\n[camera]\nposition = [0, 0, 3]\ntarget = [0, 0, 0]\n'
                          "[environment]\nconstant = [0.1, 0.1, 0.1]\n")
    try:
        scene = load_scene(scene_path)
    except CompareError as exc:
        assert "m.gltf" in str(exc) or "scene.toml" in str(exc), exc
        return
    for lamp in scene.punctual:
        assert all(math.isfinite(x) for x in (*lamp.position, *lamp.direction))
        assert abs(math.hypot(*lamp.direction) - 1.0) < 1e-6


@given(width=st.integers(0, 2**32 - 1), height=st.integers(0, 2**32 - 1), levels=st.integers(0, 40),
       scheme=st.integers(0, 4), declared=st.integers(0, 2**64 - 1), cut=st.integers(0, 400))
def test_fuzz_ktx2_headers(width, height, levels, scheme, declared, cut):
    """Any KTX 2 header: either refused with a reason, or one whose texels are within the map limit and
    whose Zstd levels declare no more than their texels need (what the transcoder may then allocate)."""
    import struct

    from compare.image.pillow import MAX_TEXELS
    from compare.scene.gltf_decode import KTX2_IDENTIFIER, ktx2_header_problem

    head = KTX2_IDENTIFIER + struct.pack("<9I", 0, 1, width, height, 0, 0, 1, levels, scheme)
    head += bytes(32) + struct.pack("<3Q", 0, 0, declared) * max(levels, 1)
    head = head[:cut] if cut < len(head) else head
    problem = ktx2_header_problem(head)
    if problem is None:
        assert len(head) >= 80 and width * max(height, 1) <= MAX_TEXELS
        if scheme == 2 and len(head) >= 104:
            assert declared <= ((max(width, 1) + 3) // 4) * ((max(height, 1) + 3) // 4) * 16
    else:
        assert isinstance(problem, str) and problem


@given(where=st.sampled_from([("seconds",), ("first_frame_seconds",), ("setup_seconds",),
                              ("points", 0, "seconds"), ("seed_runs", 0, "setup_seconds"),
                              ("seed_runs", 0, "points", 0, "seconds")]),
       value=_number)
def test_fuzz_results_timings(tmp_path, where, value):
    """Any timing in a results.json: a finite number of seconds >= 0 is read as it is; anything else is one
    error naming the file and the field (a negative time used to let the gate pass)."""
    from compare.report.results import Results

    data = _results_template()
    node = data["scenes"][0]["runs"][0]
    if where[0] == "seed_runs" and not node.get("seed_runs"):
        node["seed_runs"] = [{"seed": 0, "setup_seconds": 0.0, "image": None,
                              "points": [{"step": p["step"], "seconds": p["seconds"], "metrics": p["metrics"]}
                                         for p in node["points"]]}]
    target = node
    for k in where[:-1]:
        target = target[k]
    target[where[-1]] = value
    path = tmp_path / "results.json"
    path.write_text(json.dumps(data, allow_nan=True))
    ok = isinstance(value, (int, float)) and math.isfinite(value) and value >= 0
    try:
        Results.load(path)
    except CompareError as exc:
        assert not ok or "seed" in str(exc), exc
        assert str(path) in str(exc)
        return
    assert ok, f"{where} = {value!r} was accepted"
