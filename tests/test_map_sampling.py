"""Each map read as the glTF says: its texture coordinate set (TEXCOORD_0 or _1), its KHR_texture_transform and
its texture's sampler (wrapS and wrapT apart, nearest filtering), per map, in the reference, the rasterizer and
the job's glTF.

The closed form: a card facing the camera fills the frame exactly (90° field of view at distance 1), so pixel
(i, j) sees the card at x = −1 + (i + ½)·2/W, y = 1 − (j + ½)·2/H, and its texture coordinates are affine in
(x, y). Its maps are 2 × 2 texels, read ``nearest``, and every texel edge falls on a pixel edge: each pixel
shows exactly one texel of each map, in every renderer. The card is Lambertian (KHR_materials_specular's
factor 0 leaves glTF's dielectric no specular lobe) under a uniform sky of radiance 1, so it reflects its
base colour, and it adds its emissive map times ½: a pixel shows albedo + ½ emission of its two texels.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from compare.scene.loader import load_scene
from tests.helpers import png_bytes

SIZE = 16
#: The base-colour map's texels (sRGB bytes; rows top first: glTF's v = 0 is the image's top row).
ALBEDO = np.array([[[200, 30, 30], [30, 180, 40]], [[40, 50, 200], [220, 210, 40]]], dtype=np.uint8)
#: The emissive map's texels (sRGB bytes), times EMISSIVE_FACTOR.
EMISSION = np.array([[[0, 0, 0], [255, 255, 255]], [[255, 0, 255], [0, 255, 0]]], dtype=np.uint8)
EMISSIVE_FACTOR = 0.5
GL_REPEAT, GL_CLAMP, GL_MIRROR, GL_NEAREST = 10497, 33071, 33648, 9728


def _srgb_to_linear(c):
    c = np.asarray(c, dtype=np.float64) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _wrap(x, mode):
    if mode == GL_REPEAT:
        return x - np.floor(x)
    if mode == GL_MIRROR:
        return 1.0 - np.abs(np.mod(x, 2.0) - 1.0)
    return np.clip(x, 0.0, 1.0 - 1e-9)


def _texel(uv, wrap_s, wrap_t):
    """(row, column) of a 2 × 2 map at ``uv`` (…, 2), read nearest with those wraps."""
    u, v = _wrap(uv[..., 0], wrap_s), _wrap(uv[..., 1], wrap_t)
    return np.minimum((v * 2).astype(int), 1), np.minimum((u * 2).astype(int), 1)


#: Per map: texture coordinate set, transform (offset, rotation, scale) or None, wrapS, wrapT.
BASE = (0, None, GL_REPEAT, GL_CLAMP)
EMISSIVE = (1, ((0.25, 0.0), 0.0, (1.0, 1.0)), GL_MIRROR, GL_REPEAT)


def _uv_sets(x, y):
    """TEXCOORD_0 and TEXCOORD_1 at card position (x, y) in [−1, 1]²: affine, beyond [0, 1] so that wraps show."""
    uv0 = np.stack([x + 1.0, (1.0 - y)], axis=-1)                   # u, v in [0, 2]
    uv1 = np.stack([0.5 * (x + 1.0), 0.5 * (1.0 - y) + 0.5], axis=-1)  # u in [0, 1], v in [0.5, 1.5]
    return uv0, uv1


def _transformed(uv, transform):
    if transform is None:
        return uv
    (ox, oy), rotation, (sx, sy) = transform
    c, s = math.cos(rotation), math.sin(rotation)
    u, v = uv[..., 0] * sx, uv[..., 1] * sy
    return np.stack([c * u + s * v + ox, -s * u + c * v + oy], axis=-1)


def expected_image() -> np.ndarray:
    """What every renderer must show (linear RGB, H × W × 3)."""
    centres = (np.arange(SIZE) + 0.5) * 2.0 / SIZE
    x, y = np.meshgrid(-1.0 + centres, 1.0 - centres)
    sets = _uv_sets(x, y)
    texcoord, transform, ws, wt = BASE
    r, c = _texel(_transformed(sets[texcoord], transform), ws, wt)
    albedo = _srgb_to_linear(ALBEDO[r, c])
    texcoord, transform, ws, wt = EMISSIVE
    r, c = _texel(_transformed(sets[texcoord], transform), ws, wt)
    return albedo + EMISSIVE_FACTOR * _srgb_to_linear(EMISSION[r, c])


def write_card(folder, *, base=BASE, emissive=EMISSIVE):
    """The card as a glTF (``card.gltf``): its two maps with these (set, transform, wrapS, wrapT)."""
    from compare.scene.gltf_write import GltfWriter

    w = GltfWriter()
    mat = w.material("card", (1.0, 1.0, 1.0), 0.0, 1.0, (EMISSIVE_FACTOR,) * 3)
    corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=np.float64)
    pos = np.column_stack([corners, np.zeros(4)]).astype(np.float32)
    uv0, uv1 = (a.astype(np.float32) for a in _uv_sets(corners[:, 0], corners[:, 1]))
    attrs = {"POSITION": w.accessor(pos, bounds=True), "NORMAL": w.accessor(np.tile([[0, 0, 1]], (4, 1)).astype(np.float32)),
             "TEXCOORD_0": w.accessor(uv0), "TEXCOORD_1": w.accessor(uv1)}
    images = [w._add("images", {"bufferView": w.view(png_bytes(ALBEDO)), "mimeType": "image/png"}),  # noqa: SLF001
              w._add("images", {"bufferView": w.view(png_bytes(EMISSION)), "mimeType": "image/png"})]  # noqa: SLF001

    def info(k, spec):
        texcoord, transform, ws, wt = spec
        smp = w._add("samplers", {"wrapS": ws, "wrapT": wt, "magFilter": GL_NEAREST,  # noqa: SLF001
                                  "minFilter": GL_NEAREST})
        out = {"index": w._add("textures", {"source": images[k], "sampler": smp}), "texCoord": texcoord}  # noqa: SLF001
        if transform is not None:
            w._use("KHR_texture_transform")  # noqa: SLF001
            (ox, oy), rotation, scale = transform
            out["extensions"] = {"KHR_texture_transform": {"offset": [ox, oy], "rotation": rotation,
                                                           "scale": list(scale)}}
        return out

    m = w.doc["materials"][mat]
    m["pbrMetallicRoughness"]["baseColorTexture"] = info(0, base)
    m["emissiveTexture"] = info(1, emissive)
    m.update(doubleSided=True, extensions={"KHR_materials_specular": {"specularFactor": 0.0}})
    w._use("KHR_materials_specular")  # noqa: SLF001
    idx = w.accessor(np.array([[0, 1, 2], [0, 2, 3]], dtype=np.uint32), indices=True)
    w._add("meshes", {"name": "card", "primitives": [{"attributes": attrs, "indices": idx,  # noqa: SLF001
                                                      "material": mat}]})
    w.node("card", mesh=len(w.doc["meshes"]) - 1)
    return w.write(folder / "card.gltf")


SCENE = f"""
include = "card.gltf"

[camera]
position = [0.0, 0.0, 1.0]
target = [0.0, 0.0, 0.0]
fov = 90.0
resolution = [{SIZE}, {SIZE}]

[environment]
constant = [1.0, 1.0, 1.0]

[render]
max_depth = 2
"""


@pytest.fixture
def card_scene(tmp_path):
    write_card(tmp_path)
    (tmp_path / "card.toml").write_text(SCENE)
    return load_scene(tmp_path / "card.toml")


def test_each_map_keeps_its_set_transform_and_sampler(card_scene):
    mat = next(iter(card_scene.materials.values()))
    base, emissive = mat.sampling("base_color_texture"), mat.sampling("emissive_texture")
    assert (base.texcoord, base.wrap, base.filter, base.mipmaps) == (0, ("repeat", "clamp"), "nearest", False)
    assert (emissive.texcoord, emissive.wrap, emissive.offset) == (1, ("mirror", "repeat"), (0.25, 0.0))
    assert {"uv_sets", "map_samplers"} <= mat.uses()
    assert card_scene.features().uv_sets and card_scene.features().map_samplers


def test_the_expected_image_tells_the_old_reading_apart():
    """The closed form is able to fail: reading both maps on TEXCOORD_0, or wrapping t as s, changes pixels."""
    global BASE, EMISSIVE
    right = expected_image()
    saved = BASE, EMISSIVE
    try:
        EMISSIVE = (0, *saved[1][1:])
        assert np.abs(expected_image() - right).max() > 0.1
        EMISSIVE, BASE = saved[1], (0, None, GL_REPEAT, GL_REPEAT)
        assert np.abs(expected_image() - right).max() > 0.1
    finally:
        BASE, EMISSIVE = saved


def test_the_reference_reads_each_map_as_the_file_says(card_scene, mi_llvm):
    from compare.mitsuba.reference import ReferenceRenderer

    image = ReferenceRenderer(card_scene, cache_dir=False, progress=False).render(512, seed=1).image
    # each 4 × 4 block sees one texel of each map; its mean is within the path tracer's noise of the closed
    # form (measured: 0.0037–0.0044 over seeds 1–3 at 512 spp), and no pixel is another combination of texels
    # (those differ by 0.5 or more; a pixel deviates by 0.03 at most)
    np.testing.assert_allclose(_blocks(image), _blocks(expected_image()), atol=0.01)
    np.testing.assert_allclose(image, expected_image(), atol=0.1)


def test_the_rasterizer_reads_each_map_as_the_file_says(card_scene, gl_ctx):
    from compare.progressive.rasterizer import render_progressive

    image = render_progressive(card_scene, frames=4, seed=1, ctx=gl_ctx).image
    np.testing.assert_allclose(image, expected_image(), atol=0.02)


def test_the_jobs_gltf_carries_each_maps_reading(card_scene, tmp_path):
    """The glTF handed to other renderers names TEXCOORD_1, each map's texCoord, sampler and transform: read
    back, every map is read as in the scene."""
    from compare.renderers.job import export_gltf
    from compare.scene.gltf_read import load_gltf

    (tmp_path / "job").mkdir()
    out = export_gltf(card_scene, tmp_path / "job" / "scene.gltf")
    mat = next(iter(card_scene.materials.values()))
    again = load_gltf(out)
    assert dict(again.materials[0].sampling) == {n: mat.sampling(n) for n in mat.map_names()}
    assert again.primitives[0].mesh.uvs1 is not None


def test_the_jobs_gltf_with_every_new_reading_passes_the_validator(card_scene, tmp_path):
    """The card's job glTF (TEXCOORD_1, a sampler per map with minFilter, transforms) with the extensions of
    anisotropy, iridescence and dispersion written beside: the Khronos glTF-Validator finds no error."""
    import dataclasses

    from compare.renderers.job import export_gltf
    from tests.helpers import require, validate_gltf

    require("npm", "gltf-validator")
    name, mat = next(iter(card_scene.materials.items()))
    rich = dataclasses.replace(mat, anisotropy_strength=0.5, anisotropy_rotation=0.3, iridescence=1.0,
                               iridescence_thickness_max=500.0, transmission=0.5, thickness=0.1, dispersion=0.5)
    scene = dataclasses.replace(card_scene, materials={name: rich})
    (tmp_path / "job").mkdir()
    out = export_gltf(scene, tmp_path / "job" / "scene.gltf")
    text = out.read_text(encoding="utf-8")
    for ext in ("KHR_materials_anisotropy", "KHR_materials_iridescence", "KHR_materials_dispersion", "TEXCOORD_1"):
        assert ext in text, ext
    (report,) = validate_gltf([out]).values()
    assert [x["code"] for x in report["issues"]["messages"] if x["severity"] == 0] == []


def _blocks(image: np.ndarray) -> np.ndarray:
    """The means of the card image's 4 × 4 blocks of 4 × 4 pixels."""
    return image.reshape(4, 4, 4, 4, 3).mean(axis=(1, 3))


def _rendered_blocks(scene, engine: str, settings, steps: int) -> np.ndarray:
    """:func:`_blocks` of ``engine``'s image of ``scene`` after ``steps`` steps; the engine declares that it
    reads each map's UV set and sampler."""
    from compare.renderers import RenderContext
    from compare.renderers.registry import Registry

    r = Registry().get(engine)
    assert {"uv_sets", "map_samplers"} <= r.renders
    context = RenderContext(settings)
    try:
        image = r.render(scene, steps=steps, checkpoints=[steps], seed=0, context=context).checkpoints[-1].image
    finally:
        context.close()
    return _blocks(image)


WEB_ENGINES = [e if e == "threejs" else pytest.param(e, marks=pytest.mark.slow)
               for e in ("threejs", "babylon", "playcanvas", "model-viewer:linear")]


@pytest.mark.web
@pytest.mark.parametrize("engine", WEB_ENGINES)
def test_web_engines_read_each_map_from_the_jobs_gltf(card_scene, engine):
    """The web engines read the job's glTF with their own loaders, which take texCoord, the sampler and the
    transform per map: each 4 × 4 block shows its texels (they declare both features)."""
    from compare.report.results import RunSettings

    np.testing.assert_allclose(_rendered_blocks(card_scene, engine, RunSettings(frames=2), 2),
                               _blocks(expected_image()), atol=0.05)


@pytest.mark.bpy
@pytest.mark.parametrize("engine", ["cycles", "cycles:gltf"])
def test_cycles_reads_each_map_as_the_file_says(card_scene, engine):
    """Blender gets both UV layers and an image node per map with its own layer, transform and wraps (per axis
    by math nodes): Cycles' blocks hold the closed form within its noise (measured 7e-7), as they do when
    Blender's own glTF importer reads the file (``cycles:gltf``)."""
    from compare.report.results import RunSettings

    np.testing.assert_allclose(_rendered_blocks(card_scene, engine, RunSettings(spp=256), 256),
                               _blocks(expected_image()), atol=0.02)


def test_inspect_says_which_renderers_leave_each_feature_out(tmp_path, capsys):
    """``compare inspect`` on a glTF lists the features its materials use and, for each, the renderers of the
    registry that do not draw it (their ``renders``)."""
    from compare.cli.main import main
    from compare.renderers.registry import Registry

    write_card(tmp_path)
    assert main(["inspect", str(tmp_path / "card.gltf")]) == 0
    out = capsys.readouterr().out
    registry = Registry()
    for feature in ("uv_sets", "map_samplers"):
        line = next(x for x in out.splitlines() if x.strip().startswith(f"feature      {feature}"))
        leaving = sorted(n for n in registry.names() if feature not in registry.get(n).renders)
        assert line.endswith(f"left out by {', '.join(leaving)}" if leaving else "drawn by every renderer"), line


@pytest.mark.bpy
def test_blenders_import_is_placed_as_the_scene_places_the_file(tmp_path):
    """An include turned, moved and in centimetres: Blender's glTF importer (``cycles:gltf``, which turns +Y up
    into +Z up itself) puts the card where the suite's own export does: the two images agree."""
    from compare.renderers import RenderContext
    from compare.renderers.registry import Registry
    from compare.report.results import RunSettings

    write_card(tmp_path)
    (tmp_path / "moved.toml").write_text(SCENE.replace('include = "card.gltf"', '''
[[include]]
file = "card.gltf"
units = "cm"
scale = [60.0, 60.0, 60.0]
rotate = [0.0, 30.0, 20.0]
translate = [0.1, -0.05, -0.2]'''))
    scene = load_scene(tmp_path / "moved.toml")
    images = {}
    for engine in ("cycles", "cycles:gltf"):
        context = RenderContext(RunSettings(spp=64))
        try:
            images[engine] = Registry().get(engine).render(scene, steps=64, checkpoints=[64], seed=0,
                                                           context=context).checkpoints[-1].image
        finally:
            context.close()
    a, b = images["cycles"], images["cycles:gltf"]
    assert np.abs(a - expected_image()).max() > 0.1  # the card did move
    np.testing.assert_allclose(b, a, atol=0.02)
