"""Material maps in the rasterizer and the reference: base colour (sRGB) and metallic-roughness (glTF channels)."""

from __future__ import annotations

import math
import textwrap

import numpy as np

from compare.progressive.gl.srgb_probe import srgb_decode_table
import pytest
from PIL import Image

from compare.progressive.rasterizer import render_progressive
from compare.progressive.frame.gpu_scene import GpuScene
from compare.mitsuba.reference import ReferenceRenderer
from compare.scene.loader import load_scene
from tests.helpers import (QUADRANTS, QUADRANT_LIGHT, QUADRANT_MAPS, quadrant_regions, quadrant_scene, tilt_ratio,
                           tilt_scenes)


def test_base_colour_map_matches_the_reference(tmp_path, gl_ctx):
    """Every quadrant of an sRGB base-colour map within 5 % of Mitsuba's (direct light; the control too)."""
    scene = quadrant_scene(tmp_path, 'base_color_texture = "quadrants.png"\nroughness = 1.0')
    # LTC: the unshadowed light in closed form, so that the point-sample discretisation of the default
    # area model (-9 ... +8 % per pixel, issue 18's measurements) does not hide what the map does
    raster = render_progressive(scene, frames=64, ctx=gl_ctx, area_model="ltc").image
    ref = ReferenceRenderer(scene, cache_dir=False, progress=False).render(512).image
    for name, mask in quadrant_regions(scene).items():
        assert mask.sum() > 30, name
        np.testing.assert_allclose(raster[mask].mean(0), ref[mask].mean(0), rtol=0.05, atol=0.002, err_msg=name)


def test_metallic_roughness_map_is_its_factors(tmp_path, gl_ctx):
    """glTF's channels (G = roughness, B = metallic): each half of the map renders as the factors it
    holds, in the rasterizer and in the reference."""
    textured = quadrant_scene(tmp_path, 'base_color = [0.8, 0.6, 0.4]\nmetallic_roughness_texture = "mr.png"')
    halves = {"left": ("metallic = 0.0\nroughness = 1.0", ("quadrant 00", "quadrant 10")),
              "right": (f"metallic = 1.0\nroughness = {204 / 255}", ("quadrant 01", "quadrant 11"))}
    regions = quadrant_regions(textured)

    def images(scene):
        return (render_progressive(scene, frames=32, ctx=gl_ctx, area_model="ltc").image,
                ReferenceRenderer(scene, cache_dir=False, progress=False).render(1024, seed=3).image)

    got = images(textured)
    for half, (factors, names) in halves.items():
        sub = tmp_path / half
        sub.mkdir()
        want = images(quadrant_scene(sub, f"base_color = [0.8, 0.6, 0.4]\n{factors}"))
        for renderer, a, b, tol in (("rasterizer", got[0], want[0], 0.01), ("reference", got[1], want[1], 0.03)):
            for name in names:
                m = regions[name]
                np.testing.assert_allclose(a[m].mean(0), b[m].mean(0), rtol=tol, err_msg=f"{renderer}: {half} {name}")


def test_maps_replace_their_factors_and_leave_the_control_alone(tmp_path, gl_ctx):
    textured = quadrant_scene(tmp_path, 'base_color_texture = "quadrants.png"\nroughness = 1.0')
    (tmp_path / "plain").mkdir()
    plain = quadrant_scene(tmp_path / "plain", 'base_color = [0.8, 0.8, 0.8]\nroughness = 1.0')
    a = render_progressive(textured, frames=16, ctx=gl_ctx).image
    b = render_progressive(plain, frames=16, ctx=gl_ctx).image
    regions = quadrant_regions(textured)
    np.testing.assert_array_equal(a[regions["control"]], b[regions["control"]])  # direct light: no crosstalk
    red, green = a[regions["quadrant 00"]].mean(0), a[regions["quadrant 01"]].mean(0)
    assert red[0] > 3 * red[1] and green[1] > 3 * green[0]  # the map, the right way up and round


def test_no_texture_work_without_textures(tmp_path, gl_ctx):
    plain = quadrant_scene(tmp_path, 'base_color = [0.8, 0.8, 0.8]')
    textured = quadrant_scene(tmp_path, 'base_color_texture = "quadrants.png"')
    gpu = [GpuScene(gl_ctx, plain), GpuScene(gl_ctx, textured)]
    try:
        assert not gpu[0].textured and gpu[1].textured
    finally:
        for g in gpu:
            g.release()
    assert "texture upload and sampling" in plain.features().omitted()


def test_emission_map_multiplies_the_emission(tmp_path, gl_ctx):
    """An sRGB emission map times the emission: each quadrant shows emission x the decoded texel in the
    rasterizer and in the reference."""
    from compare.image.tonemap import srgb_decode

    scene = quadrant_scene(tmp_path, 'base_color = [0.0, 0.0, 0.0]\nemission = [2.0, 1.0, 0.5]\n'
                                     'emissive_texture = "quadrants.png"', light=False)
    assert scene.features().textures and scene.materials["floor"].is_emissive
    raster = render_progressive(scene, frames=16, ctx=gl_ctx).image
    ref = ReferenceRenderer(scene, cache_dir=False, progress=False).render(64).image
    regions = quadrant_regions(scene)
    for (r, c), colour in QUADRANTS.items():
        m = regions[f"quadrant {r}{c}"]
        want = np.array([2.0, 1.0, 0.5]) * srgb_decode(np.array(colour) / 255.0)
        # the rasterizer's map is an sRGB texture: this OpenGL's sampler decodes it (exact on GPUs, within
        # 0.0012 of the curve on llvmpipe; compare.progressive.gl.srgb_probe)
        sampled = np.array([2.0, 1.0, 0.5]) * srgb_decode_table(gl_ctx)[np.array(colour)]
        # no light but the floor's own: its pixels are its emission alone
        np.testing.assert_allclose(raster[m].mean(0), sampled, rtol=0.01, err_msg=f"rasterizer {r}{c}")
        np.testing.assert_allclose(ref[m].mean(0), want, rtol=0.01, err_msg=f"reference {r}{c}")


@pytest.mark.parametrize("settings", [
    "texture_offset = [0.5, 0.0]",
    "texture_offset = [0.1, 0.3]\ntexture_rotation = 90\ntexture_scale = [2.0, 1.0]",
    "texture_scale = [1.6, 1.6]\ntexture_wrap = \"clamp\"",
    "texture_scale = [1.6, 1.6]\ntexture_offset = [-0.3, 0.0]\ntexture_wrap = \"mirror\"",
    "texture_scale = [3.0, 3.0]\ntexture_filter = \"nearest\"",
])
def test_texture_transform_and_sampler_agree_with_the_reference(tmp_path, gl_ctx, settings):
    """KHR_texture_transform (offset · rotation · scale), wrap and filter: every region's mean in the
    rasterizer within 5 % of the reference's."""
    scene = quadrant_scene(tmp_path, f'base_color_texture = "quadrants.png"\nroughness = 1.0\n{settings}')
    raster = render_progressive(scene, frames=64, ctx=gl_ctx, area_model="ltc").image
    ref = ReferenceRenderer(scene, cache_dir=False, progress=False).render(256).image
    for name, mask in quadrant_regions(scene).items():
        np.testing.assert_allclose(raster[mask].mean(0), ref[mask].mean(0), rtol=0.05, atol=0.003, err_msg=name)
    if settings == "texture_offset = [0.5, 0.0]":  # half a turn along u: left and right quadrants swap
        regions = quadrant_regions(scene)
        red = ref[regions["quadrant 01"]].mean(0)
        assert red[0] > 3 * red[1]  # quadrant (0, 0)'s red, now on the right


@pytest.mark.parametrize("index", range(4))
def test_texture_transform_moves_whole_quadrants(tmp_path, gl_ctx, index):
    """Transforms that move whole quadrants of an emission map (tests/helpers.py QUADRANT_MAPS): each
    region shows the quadrant glTF's KHR_texture_transform says, in the rasterizer and the reference."""
    from compare.image.tonemap import srgb_decode

    settings, source = QUADRANT_MAPS[index]
    scene = quadrant_scene(tmp_path, 'base_color = [0.0, 0.0, 0.0]\nemission = [1.0, 1.0, 1.0]\n'
                                     f'emissive_texture = "quadrants.png"\n{settings}', light=False)
    raster = render_progressive(scene, frames=8, ctx=gl_ctx).image
    ref = ReferenceRenderer(scene, cache_dir=False, progress=False).render(16).image
    regions = quadrant_regions(scene)
    for (r, c) in QUADRANTS:
        want = srgb_decode(np.array(QUADRANTS[source(r, c)]) / 255.0)
        sampled = srgb_decode_table(gl_ctx)[np.array(QUADRANTS[source(r, c)])]  # the sampler's sRGB decode
        m = regions[f"quadrant {r}{c}"]
        np.testing.assert_allclose(raster[m].mean(0), sampled, rtol=0.01, err_msg=f"rasterizer {r}{c}")
        np.testing.assert_allclose(ref[m].mean(0), want, rtol=0.01, err_msg=f"reference {r}{c}")


@pytest.mark.parametrize("strength", [1.0, 0.5])
def test_occlusion_map_darkens_only_the_ambient_light(tmp_path, gl_ctx, strength):
    """glTF's occlusion map scales the rasterizer's environment light by 1 + strength (map - 1) and leaves
    the area light's direct light as it was; the reference, a path tracer, leaves the map out."""
    (tmp_path / "plain").mkdir()
    plain = quadrant_scene(tmp_path / "plain", 'base_color = [0.8, 0.8, 0.8]\nroughness = 1.0', environment=True)
    occluded = quadrant_scene(tmp_path, 'base_color = [0.8, 0.8, 0.8]\nroughness = 1.0\n'
                                        f'occlusion_texture = "ao.png"\nocclusion_strength = {strength}',
                              environment=True)
    a = render_progressive(occluded, frames=16, ctx=gl_ctx).layers
    b = render_progressive(plain, frames=16, ctx=gl_ctx).layers
    regions = quadrant_regions(occluded)
    np.testing.assert_array_equal(a["direct_area"], b["direct_area"])
    for name in ("quadrant 00", "quadrant 10"):  # the map's left half: 0
        m = regions[name]
        np.testing.assert_allclose(a["direct_env"][m].mean(0), (1 - strength) * b["direct_env"][m].mean(0),
                                   rtol=1e-3, atol=1e-6, err_msg=name)
    for name in ("quadrant 01", "quadrant 11", "control"):  # the right half: 1, and the control has no map
        m = regions[name]
        np.testing.assert_allclose(a["direct_env"][m].mean(0), b["direct_env"][m].mean(0), rtol=1e-3, err_msg=name)
    # the irradiance volume's indirect light too
    a = render_progressive(occluded, frames=8, ctx=gl_ctx, indirect="probes", probe_grid=(2, 2, 2)).layers
    b = render_progressive(plain, frames=8, ctx=gl_ctx, indirect="probes", probe_grid=(2, 2, 2)).layers
    for name, factor in (("quadrant 00", 1 - strength), ("quadrant 11", 1.0)):
        m = regions[name]
        np.testing.assert_allclose(a["indirect_diffuse"][m].mean(0), factor * b["indirect_diffuse"][m].mean(0),
                                   rtol=1e-3, atol=1e-6, err_msg=f"probes {name}")
    ref = [ReferenceRenderer(s, cache_dir=False, progress=False).render(4, seed=1).image for s in (occluded, plain)]
    np.testing.assert_array_equal(ref[0], ref[1])


def test_normal_map_is_the_relief_it_stands_for(tmp_path, gl_ctx):
    """A flat square with a constant normal map tilted by 25 degrees up the image (glTF: +Y up) shades as
    the square tilted that way, in the rasterizer and in the reference; tilted the other way it does not.
    Bound: 1 %, for a light 27 m away (the tilted square's points move 0.3 m, 1 % of that distance);
    measured 0.9996 (reference) and 1.0012 (rasterizer), against 1.59 for the wrong way."""
    mapped, tilted, other = tilt_scenes(tmp_path)
    ref = {k: ReferenceRenderer(s, cache_dir=False, progress=False).render(256).image
           for k, s in (("mapped", mapped), ("tilted", tilted), ("other", other))}
    ras = {k: render_progressive(s, frames=32, ctx=gl_ctx, area_model="ltc").image
           for k, s in (("mapped", mapped), ("tilted", tilted), ("other", other))}
    for name, img in (("reference", ref), ("rasterizer", ras)):
        assert tilt_ratio(img["mapped"], img["tilted"], img["other"]) == pytest.approx(1.0, abs=0.01), name
        assert tilt_ratio(img["mapped"], img["other"], img["tilted"]) > 1.3, name
    assert tilt_ratio(ras["mapped"], ref["mapped"]) == pytest.approx(1.0, abs=0.01)
    # scale 0: no perturbation at all
    flat = quadrant_scene(tmp_path, 'base_color = [0.8, 0.8, 0.8]\nroughness = 1.0')
    (tmp_path / "s0").mkdir()
    Image.open(tmp_path / "n.png").save(tmp_path / "s0" / "n.png")
    zero = quadrant_scene(tmp_path / "s0", 'base_color = [0.8, 0.8, 0.8]\nroughness = 1.0\nnormal_texture = "n.png"\n'
                                            'normal_scale = 0.0')
    np.testing.assert_allclose(render_progressive(zero, frames=8, ctx=gl_ctx).image,
                               render_progressive(flat, frames=8, ctx=gl_ctx).image, rtol=1e-5, atol=1e-6)


#: An alpha-masked card (alpha factor 0.9 x the map's, cutoff 0.6) over a grey patch beside the floor,
#: where neither it nor its shadow reaches the floor's regions (the patch is what its holes show).
CARD = """[materials.leaf]
        base_color_texture = "card.png"
        roughness = 1.0
        alpha_mode = "mask"
        alpha = 0.9
        alpha_cutoff = 0.6
        [[meshes]]
        name = "card"
        shape = "quad"
        size = [0.8, 0.8]
        material = "leaf"
        translate = [-1.6, 0.3, 0.0]
        [[meshes]]
        name = "patch"
        shape = "quad"
        size = [1.2, 1.6]
        material = "grey"
        translate = [-1.7, 0.0, 0.0]"""


def _card_png(path):
    """The card's map: solid (alpha 255) in the image's top-right and bottom-left quadrants, alpha 100
    elsewhere (0.9 x 100 / 255 is below the cutoff: holes)."""
    img = np.zeros((64, 64, 4), dtype=np.uint8)
    img[...] = (220, 40, 220, 100)
    img[:32, 32:] = img[32:, :32] = (60, 200, 70, 255)
    Image.fromarray(img, "RGBA").save(path)


def _card_regions(scene) -> dict[str, np.ndarray]:
    """Pixels whose ray crosses the card's plane well inside one of its solid quadrants or its holes."""
    cam = scene.camera
    jj, ii = np.mgrid[0:cam.height, 0:cam.width]
    d = cam.ray_directions(ii + 0.5, jj + 0.5)
    o = np.asarray(cam.position)
    t = (0.3 - o[1]) / np.where(d[..., 1] < 0, d[..., 1], -1e-30)
    p = o + d * t[..., None]
    x, z = p[..., 0] + 1.6, p[..., 2]
    inner = (t > 0) & (np.abs(x) > 0.06) & (np.abs(x) < 0.34) & (np.abs(z) > 0.06) & (np.abs(z) < 0.34)
    solid = ((x > 0) & (z > 0)) | ((x < 0) & (z < 0))
    return {"card solid": inner & solid, "card hole": inner & ~solid}


def test_a_gltf_with_every_map_round_trips_and_renders_as_the_reference(tmp_path, gl_ctx):
    """One glTF material with every map (base colour, metallic-roughness, normal, occlusion, emission) and a
    texture transform, and one alpha-masked material (factor and map alpha, cutoff), written by the exporter
    and read back through [[include]]: the imported scene is the original (the reference renders it bit for
    bit), and the rasterizer's textured regions (the card's solid parts and what its holes show too) are
    within 5 % of the reference's direct light; the untextured control region too."""
    from compare.renderers.job import export_gltf

    Image.fromarray(np.tile(np.array([[[128, 150, 230]]], dtype=np.uint8), (8, 8, 1))).save(tmp_path / "n.png")
    material = ('base_color_texture = "quadrants.png"\nmetallic_roughness_texture = "mr.png"\n'
                'normal_texture = "n.png"\nnormal_scale = 0.5\nocclusion_texture = "ao.png"\n'
                'emission = [0.05, 0.05, 0.05]\nemissive_texture = "quadrants.png"\ntexture_offset = [0.5, 0.0]')
    _card_png(tmp_path / "card.png")
    original = quadrant_scene(tmp_path, material, extra=CARD)
    (tmp_path / "gltf").mkdir()
    export_gltf(original, tmp_path / "gltf" / "scene.gltf")
    (tmp_path / "gltf" / "t.toml").write_text(textwrap.dedent(f'''
        [camera]
        position = {list(original.camera.position)}
        target = {list(original.camera.target)}
        fov = {original.camera.fov}
        resolution = [80, 60]
        [[include]]
        file = "scene.gltf"
        prefix = ""
        {QUADRANT_LIGHT}
        [render]
        max_depth = 2
        '''))
    imported = load_scene(tmp_path / "gltf" / "t.toml")
    floor = imported.materials["floor"]
    assert floor.normal_scale == 0.5
    assert {floor.sampling(n) for n in floor.map_names()} == {original.materials["floor"].default_sampling}
    assert all(getattr(floor, k) is not None for k in ("base_color_texture", "metallic_roughness_texture",
                                                       "normal_texture", "occlusion_texture", "emissive_texture"))
    ref = ReferenceRenderer(original, cache_dir=False, progress=False).render(256, seed=2).image
    again = ReferenceRenderer(imported, cache_dir=False, progress=False).render(256, seed=2).image
    np.testing.assert_allclose(again, ref, rtol=1e-5, atol=1e-6)
    leaf = imported.materials["leaf"]
    assert (leaf.alpha_mode, leaf.alpha, leaf.alpha_cutoff) == ("mask", 0.9, 0.6)
    raster = render_progressive(imported, frames=64, ctx=gl_ctx, area_model="ltc").image
    regions = {**quadrant_regions(imported), **_card_regions(imported)}
    for name, mask in regions.items():
        assert mask.sum() > 10, name
        np.testing.assert_allclose(raster[mask].mean(0), ref[mask].mean(0), rtol=0.05, atol=0.003, err_msg=name)
    # the holes are holes in both: the patch under the card is seen through them, lit through them
    hole = ref[regions["card hole"]].mean(0)
    assert abs(hole[0] - hole[1]) < 0.05 * hole.mean() and hole.mean() > 0.01


def test_a_16_bit_grey_map_reads_alike_in_both_renderers(tmp_path, make_scene, gl_ctx):
    """A 16-bit grey PNG (Pillow's I;16) is its full range in every renderer: code 32768 of 65535 is
    sRGB 0.5 (0.214 linear) in Mitsuba (which reads the file) and in the rasterizer (load_texture), where
    converting to 8-bit RGB made it white."""
    from PIL import Image

    from compare.image.tonemap import srgb_decode
    from compare.progressive.rasterizer import render_progressive
    from compare.scene.loader import load_scene
    from compare.scene.textures import load_texture

    Image.fromarray(np.full((8, 8), 32768, dtype=np.uint16)).save(tmp_path / "g16.png")
    assert Image.open(tmp_path / "g16.png").mode == "I;16"
    want = float(srgb_decode(np.array(32768 / 65535)))
    np.testing.assert_allclose(load_texture(tmp_path / "g16.png", srgb=True), want, rtol=1e-6)
    scene = load_scene(make_scene(camera={"position": [0, 2, 0.001], "target": [0, 0, 0], "fov": 30.0,
                                          "resolution": [16, 16]},
                                  materials={"m": {"base_color_texture": "g16.png", "roughness": 1.0}},
                                  meshes=[{"name": "q", "shape": "quad", "size": [4.0, 4.0], "material": "m"}],
                                  environment={"constant": [1.0, 1.0, 1.0]}))
    ref = ReferenceRenderer(scene, materials="diffuse", cache_dir=False, progress=False).render(16).image
    raster = render_progressive(scene, frames=4, materials="diffuse", ctx=gl_ctx).image
    assert float(ref.mean()) == pytest.approx(want, rel=0.02)  # a white Lambert floor under a white sky
    assert float(raster.mean()) == pytest.approx(float(ref.mean()), rel=0.02)


def _ramp_images():
    """One grey ramp (8 columns, codes 0 … 255) in each PNG layout a download may use."""
    g = np.tile(np.linspace(0, 255, 8).astype(np.uint8), (8, 1))
    rgb = Image.fromarray(np.dstack([g, g, g]), "RGB")
    palette_alpha = rgb.convert("P")
    palette_alpha.info["transparency"] = bytes([255] * 256)  # a tRNS chunk that keeps every entry opaque
    return {"grey": Image.fromarray(g, "L"), "grey_alpha": Image.fromarray(np.dstack([g, np.full_like(g, 255)]), "LA"),
            "rgb": rgb, "rgba": Image.fromarray(np.dstack([g, g, g, np.full_like(g, 255)]), "RGBA"),
            "palette": rgb.convert("P"), "palette_alpha": palette_alpha,
            "grey16": Image.fromarray(g.astype(np.uint16) * 257)}


@pytest.mark.parametrize("layout", list(_ramp_images()))
def test_every_png_layout_decodes_to_the_same_colours_in_both_renderers(tmp_path, gl_ctx, layout):
    """8- and 16-bit grey, grey + alpha, palette (with and without tRNS), RGB and RGBA files of one grey
    ramp: the reference and the rasterizer see the same base colour (a Lambert quad in a white sky: the
    image is the decoded, sRGB-linearised map), each column within 3 % of the other renderer (sampling
    aside: the bilinear filters differ at the columns' seams) and the 8-bit RGB file's values."""
    image = _ramp_images()[layout]
    image.save(tmp_path / "ramp.png")
    # the same colours as a plain 8-bit RGB file (a palette's are its entries, quantised from the ramp)
    (image.convert("RGBA").convert("RGB") if layout.startswith("palette") else _ramp_images()["rgb"]).save(tmp_path / "plain.png")
    path = tmp_path / "scene.toml"

    def scene_with(name):
        path.write_text(textwrap.dedent(f"""
            [camera]
            position = [0.0, 4.0, 0.0]
            up = [0.0, 0.0, -1.0]
            target = [0.0, 0.0, 0.0]
            fov = 40.0
            resolution = [64, 64]
            [materials.m]
            base_color_texture = "{name}"
            roughness = 1.0
            texture_filter = "nearest"
            [[meshes]]
            shape = "quad"
            size = [3.0, 3.0]
            material = "m"
            [environment]
            constant = [1.0, 1.0, 1.0]
            """))
        return load_scene(path)

    half = 4.0 * math.tan(math.radians(20.0))  # the view's half width on the quad (within its 1.5)

    def columns(img):  # each texel column's middle pixel (the map's u runs along the image's x, either way)
        x = -1.5 + 3.0 * (np.arange(8) + 0.5) / 8
        px = ((x / half + 1.0) / 2.0 * 64).astype(int)
        return np.sort(img[28:36][:, np.stack([px - 1, px, px + 1])].mean(axis=(0, 1, 3)))

    scene = scene_with("ramp.png")
    truth = columns(ReferenceRenderer(scene, cache_dir=False, progress=False, materials="diffuse").render(16).image)
    got = columns(render_progressive(scene, frames=4, ctx=gl_ctx, materials="diffuse").image)
    plain = scene_with("plain.png")
    rgb = columns(ReferenceRenderer(plain, cache_dir=False, progress=False, materials="diffuse").render(16).image)
    assert truth.max() > 5 * truth[1] > 0 and truth.max() < 0.999  # a ramp, not the sky
    np.testing.assert_allclose(got, truth, rtol=0.03, atol=2e-3)
    np.testing.assert_allclose(truth, rgb, rtol=0.03, atol=2e-3)


@pytest.mark.parametrize("mode", ["shared", "cycles"])
def test_normal_map_bends_the_sheen(tmp_path, mode):
    """glTF's normal map bends the sheen as well as the base (Blender's Principled too, without a coat):
    a white sheen over dark grey under a constant tilted map shades as the tilted square, within 1.5 %
    (with the sheen in the unbent frame: 1.69 in the shared mode, 1.08 in the cycles mode)."""
    mapped, tilted, other = tilt_scenes(tmp_path, material='base_color = [0.1, 0.1, 0.1]\nroughness = 1.0\n'
                                        'sheen_color = [1.0, 1.0, 1.0]\nsheen_roughness = 0.5')
    img = {k: ReferenceRenderer(s, materials=mode, cache_dir=False, progress=False).render(256).image
           for k, s in (("mapped", mapped), ("tilted", tilted), ("other", other))}
    assert tilt_ratio(img["mapped"], img["tilted"], img["other"]) == pytest.approx(1.0, abs=0.015)


def test_normal_map_bends_the_transmission_and_not_the_coat(tmp_path):
    """The glass lobe sits under the normal map with the base; the coat stays outside it (its own map)."""
    import dataclasses

    from compare.mitsuba.scene_dict import material_dict
    from compare.scene.model import Material

    Image.fromarray(np.full((2, 2, 3), [128, 128, 255], dtype=np.uint8)).save(tmp_path / "n.png")
    glass = Material(name="g", transmission=1.0, thickness=1.0, metallic=0.0, roughness=0.2,
                     normal_texture=tmp_path / "n.png")
    for mode in ("shared", "cycles"):
        d = material_dict(glass, mode)
        assert d["type"] == "gltf_normalmap" and d["bsdf"]["type"] == "blendbsdf", mode
    coated = dataclasses.replace(glass, transmission=0.0, clearcoat=1.0)
    for mode in ("shared", "cycles"):
        d = material_dict(coated, mode)
        assert d["type"] == "twosided", mode  # double-sided and opaque: the stack under Mitsuba's twosided
        d = d["bsdf"]
        assert d["type"] == "gltf_coat" and d["base"]["type"] == "gltf_normalmap", mode
