"""Compressed glTF as published (compare.scene.gltf_decode): every decode path against the plain file.

The compressed variants of the built-in car are written by real tools (scenes/generate.py
--compressed: gltfpack, glTF-Transform, Pillow, Basis Universal); each must load to the plain
car's triangles within its quantisation error and to its texels within its codec's error, and
render in every renderer that is available here.
"""

from __future__ import annotations

import json
import struct

import numpy as np
import pytest
from PIL import Image

from compare.scene.glb import pack_glb, parse_glb
from compare.scene.gltf_read import GltfError, load_gltf
from tests.helpers import ROOT

CAR = ROOT / "scenes" / "car"
#: variant → (extension it must use, smallest PSNR in dB of any of its maps against the plain PNG).
#: Measured: WebP (quality 90) 27.2 dB on the tread's normal map, 34–46 dB elsewhere; UASTC 34.7 dB.
VARIANTS = {"meshopt": ("EXT_meshopt_compression", None), "draco": ("KHR_draco_mesh_compression", None),
            "webp": ("EXT_texture_webp", 25.0), "ktx2": ("KHR_texture_basisu", 30.0)}


def _world(p) -> np.ndarray:
    return p.mesh.positions @ p.matrix[:3, :3].T + p.matrix[:3, 3]


@pytest.mark.parametrize("variant", VARIANTS)
def test_each_compressed_variant_loads_to_the_plain_car(variant):
    ext, min_psnr = VARIANTS[variant]
    path = CAR / f"coupe-{variant}.glb"
    doc, _ = parse_glb(path.read_bytes())
    assert ext in doc["extensionsRequired"], "the variant must really need its decoder"
    plain, got = load_gltf(CAR / "coupe.glb"), load_gltf(path)
    assert not got.warnings
    extent = np.ptp(np.concatenate([_world(p) for p in plain.primitives]), axis=0).max()
    parts = {p.name: p for p in got.primitives}
    assert sorted(parts) == sorted(p.name for p in plain.primitives)
    for p in plain.primitives:
        q = parts[p.name]
        assert len(q.mesh.indices) == len(p.mesh.indices), p.name
        a, b = _world(p), _world(q)
        # every vertex of the variant within quantisation error of one of the plain's (14-bit positions:
        # measured 0.84 × extent / 2^14 for gltfpack and Draco), whatever order the encoder left them in
        worst = max(np.sqrt(((b[i:i + 1024, None] - a[None]) ** 2).sum(-1)).min(1).max() for i in range(0, len(b), 1024))
        assert worst <= extent / 2 ** 13, (p.name, worst)
        # the surface area within what moving each corner by `worst` can change: a triangle's area moves by
        # at most its perimeter × the offset
        def area(m, x):
            e = [x[m.indices[:, (k + 1) % 3]] - x[m.indices[:, k]] for k in range(3)]
            return 0.5 * np.linalg.norm(np.cross(e[0], -e[2]), axis=1).sum(), sum(np.linalg.norm(v, axis=1).sum()
                                                                                for v in e)
        (got_area, _), (want_area, perimeter) = area(q.mesh, b), area(p.mesh, a)
        assert abs(got_area - want_area) <= perimeter * worst + 1e-9, p.name
    assert [m.name for m in got.materials] == [m.name for m in plain.materials]
    assert len(got.images) == len(plain.images)
    for mine, theirs in zip(plain.images, got.images):
        with Image.open(mine) as a, Image.open(theirs) as b:
            assert a.size == b.size and a.mode == b.mode
            x, y = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
        mse = float(((x - y) ** 2).mean())
        if min_psnr is None:
            assert mse == 0.0  # a geometry codec leaves the maps alone
        else:
            assert 10 * np.log10(255.0 ** 2 / max(mse, 1e-12)) >= min_psnr, theirs


def test_a_decoded_file_is_cached_by_content_and_plain(tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    monkeypatch.setenv("COMPARE_CACHE", str(cache))
    load_gltf(CAR / "coupe-meshopt.glb")
    (decoded,) = (cache / "gltf-decoded").glob("*.glb")
    doc, binary = parse_glb(decoded.read_bytes())
    assert "EXT_meshopt_compression" not in json.dumps(doc) and len(doc["buffers"]) == 1
    stamp = decoded.stat().st_mtime_ns
    load_gltf(CAR / "coupe-meshopt.glb")
    assert decoded.stat().st_mtime_ns == stamp  # read again, not decoded again
    # another file, another entry: the key is the content
    copy = tmp_path / "copy.glb"
    data = bytearray((CAR / "coupe-meshopt.glb").read_bytes())
    copy.write_bytes(data)
    load_gltf(copy)
    assert len(list((cache / "gltf-decoded").glob("*.glb"))) == 1  # same bytes, same entry


@pytest.mark.parametrize("damage", ["truncate", "swap", "checksum"])
def test_a_damaged_decoded_entry_is_rebuilt_not_trusted(tmp_path, monkeypatch, damage):
    """A truncated entry (a killed write, a full disk), another model's entry in its place, or a lost
    checksum: the next load decodes the model again instead of failing on it or using other geometry."""
    cache = tmp_path / "cache"
    monkeypatch.setenv("COMPARE_CACHE", str(cache))
    want = load_gltf(CAR / "coupe-meshopt.glb")
    (entry,) = (cache / "gltf-decoded").glob("*.glb")
    good = entry.read_bytes()
    if damage == "truncate":
        entry.write_bytes(good[: len(good) // 2])
    elif damage == "swap":
        doc, binary = parse_glb(good)
        doc["meshes"][0]["name"] = "someone else's"
        entry.write_bytes(pack_glb(doc, binary))
    else:
        entry.with_suffix(".sha256").unlink()
    got = load_gltf(CAR / "coupe-meshopt.glb")
    assert entry.read_bytes() == good
    assert [p.name for p in got.primitives] == [p.name for p in want.primitives]


def _assert_refused(path, doc: dict, binary, match: str) -> None:
    """The GLB of ``doc`` and ``binary``, written to ``path``, fails to load with one GltfError matching
    ``match``."""
    path.write_bytes(pack_glb(doc, binary))
    with pytest.raises(GltfError, match=match):
        load_gltf(path)


def _meshopt_doc():
    doc, binary = parse_glb((CAR / "coupe-meshopt.glb").read_bytes())
    return doc, bytearray(binary)


def test_a_corrupt_meshopt_stream_is_one_error_naming_the_view(tmp_path):
    doc, binary = _meshopt_doc()
    view = next(i for i, v in enumerate(doc["bufferViews"]) if "extensions" in v)
    ext = doc["bufferViews"][view]["extensions"]["EXT_meshopt_compression"]
    start = ext.get("byteOffset", 0)
    binary[start: start + ext["byteLength"]] = b"\xff" * ext["byteLength"]
    _assert_refused(tmp_path / "bad.glb", doc, binary,
                    rf"bad.glb: bufferViews\[{view}\].extensions.EXT_meshopt_compression: meshopt could not decode it")


def test_a_meshopt_count_beyond_its_bytes_is_refused_before_allocating(tmp_path):
    doc, binary = _meshopt_doc()
    view = next(i for i, v in enumerate(doc["bufferViews"]) if "extensions" in v)
    doc["bufferViews"][view]["extensions"]["EXT_meshopt_compression"]["count"] = 10 ** 12
    _assert_refused(tmp_path / "huge.glb", doc, binary,
                    r"huge.glb: bufferViews\[\d+\].extensions.EXT_meshopt_compression: "
                    r"1000000000000 × \d+ bytes cannot come from \d+ compressed bytes")


def test_a_corrupt_draco_stream_and_a_corrupt_ktx2_map_are_one_error_each(tmp_path):
    doc, binary = parse_glb((CAR / "coupe-draco.glb").read_bytes())
    binary = bytearray(binary)
    prim = doc["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]
    v = doc["bufferViews"][prim["bufferView"]]
    binary[v.get("byteOffset", 0): v.get("byteOffset", 0) + v["byteLength"]] = b"\0" * v["byteLength"]
    _assert_refused(tmp_path / "draco.glb", doc, binary,
                    r"draco.glb: meshes\[0\].primitives\[0\].extensions.KHR_draco_mesh_compression: "
                    r"Draco could not decode it")
    doc, binary = parse_glb((CAR / "coupe-ktx2.glb").read_bytes())
    binary = bytearray(binary)
    v = doc["bufferViews"][doc["images"][0]["bufferView"]]
    binary[v.get("byteOffset", 0) + 12: v.get("byteOffset", 0) + 80] = b"\xee" * 68
    # its header now claims 0xeeeeeeee² texels: refused on the header, before the transcoder allocates them
    _assert_refused(tmp_path / "ktx2.glb", doc, binary,
                    r"ktx2.glb: images\[0\]: its header declares 4008636142 × 4008636142 texels, more than")
    binary[v.get("byteOffset", 0) + 20: v.get("byteOffset", 0) + 28] = bytes(8)  # 0 × 0: past the header check
    _assert_refused(tmp_path / "ktx2.glb", doc, binary,
                    r"ktx2.glb: images\[0\]: not a valid KTX 2 file with a Basis Universal payload")


def test_a_missing_decoder_names_the_package_and_how_to_convert(tmp_path, monkeypatch):
    import builtins

    real = builtins.__import__

    def no_basisu(name, *args, **kwargs):
        if name == "opengl_basisu":
            raise ImportError("no")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_basisu)
    monkeypatch.setattr("importlib.import_module", lambda name: no_basisu(name))
    monkeypatch.setenv("COMPARE_CACHE", str(tmp_path))
    with pytest.raises(GltfError, match=r"coupe-ktx2.glb: extensionsUsed: KHR_texture_basisu needs the "
                                        r"opengl_basisu package, which is not installed: .*pip install opengl_basisu.*"
                                        r"gltf-transform/cli png"):
        load_gltf(CAR / "coupe-ktx2.glb")


def test_an_external_buffer_and_image_are_part_of_the_decoded_files_key(tmp_path, monkeypatch):
    """A .gltf with its compressed buffer beside it: changing the buffer changes the decoded file."""
    monkeypatch.setenv("COMPARE_CACHE", str(tmp_path / "cache"))
    doc, binary = parse_glb((CAR / "coupe-draco.glb").read_bytes())
    doc["buffers"][0]["uri"] = "coupe.bin"
    (tmp_path / "coupe.bin").write_bytes(binary)
    (tmp_path / "coupe.gltf").write_text(json.dumps(doc))
    first = load_gltf(tmp_path / "coupe.gltf")
    assert tmp_path / "coupe.bin" in first.files
    assert len(first.primitives) == 17


def _builtins():
    from compare.renderers.registry import Registry

    # The browser path tracer's set-up (its shaders on SwiftShader, a BVH of five cars) is about a minute.
    # EEVEE's renders are slow (about a second a sample, whatever the size), as in tests/test_blender.py.
    # The glTF Sample Viewer's own IBL prefiltering takes minutes on SwiftShader: its coarse settings.
    # The other page engines read the same job glTF as three.js, each in a page of its own (seconds to load):
    # three.js in the default run, the others among the slow tests.
    quick = {"gltf-sample-viewer": "gltf-sample-viewer:coarse"}
    groups = Registry.groups()
    pages = {n.partition(":")[0] for n in groups["web"] + groups["viewers"]} - {"threejs"}
    return [pytest.param(quick.get(name, name), marks=pytest.mark.slow)
            if name in ("threejs-pathtracer", "eevee") or name in pages
            else name for name in Registry().builtins()]


@pytest.mark.parametrize("spec", _builtins())
def test_variants_render_alike_in_every_available_renderer(spec, tmp_path, make_scene, gl_ctx):
    """The plain car and its four variants side by side in one image, per renderer: each variant's
    column has the plain car's mean within 2 % (what differs is the codecs' error)."""
    from compare.renderers import RenderContext
    from compare.renderers.registry import Registry
    from compare.report.results import RunSettings
    from compare.scene.loader import load_scene

    names = ["plain", *VARIANTS]
    for name in names:
        src = CAR / ("coupe.glb" if name == "plain" else f"coupe-{name}.glb")
        (tmp_path / src.name).write_bytes(src.read_bytes())
    includes = "".join(f"""
        [[include]]
        file = "{'coupe.glb' if name == 'plain' else f'coupe-{name}.glb'}"
        prefix = "{name}/"
                translate = [{(i - 2) * 5.6}, 0, 0]
        """ for i, name in enumerate(names))
    scene_path = make_scene(includes, """
        [camera]
        position = [0, 40, 0]
        target = [0, 0, 0]
        up = [0, 0, -1]
        fov = 10.0
        resolution = [160, 40]
        [environment]
        constant = [1.0, 1.0, 1.0]
        """)
    scene = load_scene(scene_path)
    renderer = Registry().get(spec)
    ok, why = renderer.available()
    if not ok:
        pytest.skip(why)
    settings = RunSettings(frames=4, spp=4)
    with RenderContext(settings) as context:
        context.provide("gl", gl_ctx)
        steps = min(renderer.steps(settings), 4)
        image = renderer.render(scene, steps=steps, checkpoints=[steps], seed=0, context=context).checkpoints[-1].image
    assert np.isfinite(image).all()
    columns = np.split(image[..., :3].mean(axis=(0, 2)), 5)  # 32-pixel columns, one car each
    means = [float(c.mean()) for c in columns]
    assert means[0] > 0
    for name, m in zip(names[1:], means[1:]):
        assert m == pytest.approx(means[0], rel=0.02), (name, means)


def test_a_ktx2_header_claiming_a_huge_map_is_one_error(tmp_path):
    doc, binary = parse_glb((CAR / "coupe-ktx2.glb").read_bytes())
    binary = bytearray(binary)
    v = doc["bufferViews"][doc["images"][0]["bufferView"]]
    start = v.get("byteOffset", 0)
    binary[start + 20: start + 28] = struct.pack("<II", 100_000, 100_000)  # pixelWidth, pixelHeight
    _assert_refused(tmp_path / "huge.glb", doc, binary, r"huge.glb: images\[0\]: ")


def _ktx2_header(width: int, height: int, *, levels: int = 1, scheme: int = 2, uncompressed=None) -> bytes:
    import struct

    from compare.scene.gltf_decode import KTX2_IDENTIFIER

    head = KTX2_IDENTIFIER + struct.pack("<9I", 0, 1, width, height, 0, 0, 1, levels, scheme)
    head += struct.pack("<4I2Q", 0, 0, 0, 0, 0, 0)  # DFD, key/value data, supercompression data
    for level in range(levels):
        w, h = max(width >> level, 1), max(height >> level, 1)
        need = ((w + 3) // 4) * ((h + 3) // 4) * 16
        head += struct.pack("<3Q", 0, 100, need if uncompressed is None else uncompressed)
    return head


def test_a_ktx2_header_that_declares_too_much_is_refused_before_transcoding():
    """A 35 KB KTX 2 whose Zstd level claims 1 GiB, or a tiny file of 32768² texels: refused on the header,
    with the numbers; a plausible header passes; the limit is the one every image reader applies."""
    from compare.image.pillow import MAX_TEXELS, Image
    from compare.scene.gltf_decode import ktx2_header_problem

    assert ktx2_header_problem(_ktx2_header(64, 64)) is None
    assert ktx2_header_problem(_ktx2_header(64, 64, levels=7)) is None
    assert ktx2_header_problem(_ktx2_header(64, 64, scheme=1, uncompressed=0)) is None  # BasisLZ
    assert "declares 1,073,741,824 bytes uncompressed" in ktx2_header_problem(
        _ktx2_header(64, 64, uncompressed=1 << 30))
    assert "more than the 268,435,456 (16384²)" in ktx2_header_problem(_ktx2_header(32768, 32768))
    assert ktx2_header_problem(b"\x89PNG\r\n\x1a\n" + bytes(100)) == "not a KTX 2 file (no KTX 2 identifier)"
    assert Image.MAX_IMAGE_PIXELS == MAX_TEXELS == 16384 * 16384
