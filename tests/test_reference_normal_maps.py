"""The reference's normal maps are read in glTF's tangent frame (compare.mitsuba.normalmap): the mesh's TANGENT
(MikkTSpace's when it has none), the bitangent cross(n, t) · w, the map's +Y along it.

The closed forms: a flat Lambert square (normal +y, u along +x, v along −z) seen from straight above,
under one directional light and nothing else, direct light only: every pixel is exactly
``ρ/π · E · max(n'·l, 0) · G``, ``n'`` the normal the map stands for in that frame and ``G`` Mitsuba's
terminator smoothing (Estevez et al.), which the plugin keeps from Mitsuba's ``normalmap``
(:func:`shadowing`; 1 for a light along the unperturbed normal)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from PIL import Image

from compare.mitsuba.reference import ReferenceRenderer
from compare.scene import geometry
from compare.scene.loader import parse_scene
from compare.scene.model import Mesh

TILT = math.radians(30.0)
ALBEDO, IRRADIANCE = 0.8, 2.0
#: The square's TANGENT as MikkTSpace gives it: xyz along +u (+x), w = −1 so that cross(n, t) · w, the map's
#: +Y, points up the image (−v, +z).
MIKKTSPACE = (1.0, 0.0, 0.0, -1.0)


def _map(path, normal) -> None:
    """A constant glTF normal map of the tangent-space ``normal``, encoded (n + 1) / 2 in 8 bits."""
    code = np.round((np.asarray(normal, dtype=np.float64) + 1.0) / 2.0 * 255.0).astype(np.uint8)
    Image.fromarray(np.tile(code, (4, 4, 1)), "RGB").save(path)


def _decoded(normal) -> np.ndarray:
    """The normal an 8-bit texel of ``normal`` decodes to (normalised)."""
    c = np.round((np.asarray(normal, dtype=np.float64) + 1.0) / 2.0 * 255.0) / 255.0 * 2.0 - 1.0
    return c / np.linalg.norm(c)


def shadowing(n, l) -> float:  # noqa: E741
    """Mitsuba's eval_shadow_terminator for the perturbed normal ``n`` and light direction ``l`` (world,
    unperturbed normal +y)."""
    def tan2(v):
        return (1.0 - v[1] ** 2) / v[1] ** 2

    alpha2 = min(0.125 * tan2(n), 1.0)
    return 2.0 / (1.0 + math.sqrt(1.0 + alpha2 * tan2(l)))


def _square(tmp_path, normal, light, tangent=None):
    """The square with a constant map of the tangent-space ``normal``, lit from the world direction ``light``;
    with ``tangent`` (x, y, z, w) its TANGENT, else none (MikkTSpace's)."""
    _map(tmp_path / "n.png", normal)
    data = {
        "camera": {"position": [0.0, 10.0, 0.0], "target": [0.0, 0.0, 0.0], "up": [0.0, 0.0, -1.0], "fov": 2.0,
                   "resolution": [8, 8]},
        "materials": {"m": {"base_color": [ALBEDO] * 3, "roughness": 1.0, "normal_texture": "n.png"}},
        "meshes": [{"shape": "quad", "size": [4.0, 4.0], "material": "m"}],
        "lights": [{"type": "directional", "direction": [-x for x in light], "intensity": IRRADIANCE,
                    "light_scale": 1.0}],
        "render": {"max_depth": 2},
    }
    scene = parse_scene(data, tmp_path / "square.toml")
    if tangent is None:
        return scene
    tri = geometry.quad((4.0, 4.0))
    tri = dataclasses.replace(tri, tangents=np.tile(np.asarray(tangent, dtype=np.float32), (len(tri.positions), 1)))
    mesh = Mesh(name="square", shape="gltf", material="m", params={"triangles": tri})  # as an [[include]] makes it
    return dataclasses.replace(scene, meshes=(mesh,))


def _radiance(scene) -> float:
    """The reference's radiance of the square (diffuse materials: Lambert of the base colour)."""
    img = ReferenceRenderer(scene, materials="diffuse", cache_dir=False, progress=False).render(4).image
    assert np.ptp(img) < 1e-5 * img.max() + 1e-7  # a flat square under a distant light: every pixel alike
    return float(img.mean())


def _closed_form(n_world, light) -> float:
    """ρ/π · E · max(n'·l, 0) · G for the perturbed normal ``n_world`` and the light's direction ``light``."""
    n_world, light = np.asarray(n_world, dtype=np.float64), np.asarray(light, dtype=np.float64)
    light = light / np.linalg.norm(light)
    return ALBEDO / math.pi * IRRADIANCE * max(float(n_world @ light), 0.0) * shadowing(n_world, light)


def _world(tangent, c) -> np.ndarray:
    """glTF's frame on the square: t = the tangent, b = cross(+y, t) · w, n' = x t + y b + z n."""
    n = np.array([0.0, 1.0, 0.0])
    t = np.asarray(tangent[:3], dtype=np.float64)
    b = np.cross(n, t) * (-1.0 if tangent[3] < 0 else 1.0)
    return c[0] * t + c[1] * b + c[2] * n


#: The tangent-space normal tilted 30 degrees along +u (glTF: +X) and along +Y (up the image).
ALONG_U = (math.sin(TILT), 0.0, math.cos(TILT))
ALONG_Y = (0.0, math.sin(TILT), math.cos(TILT))
#: MikkTSpace's tangent turned 45 and 90 degrees about the normal (+y: +x goes towards −z, +v).
TURNED_45 = (math.cos(math.pi / 4), 0.0, -math.sin(math.pi / 4), -1.0)
TURNED_90 = (0.0, 0.0, -1.0, -1.0)


@pytest.mark.parametrize("tangent", [None, TURNED_45], ids=["mikktspace", "tangent-45"])
def test_a_constant_tilt_is_a_tilted_lambert_plane(tmp_path, tangent):
    """A map tilted 30 degrees along +u shades as the plane tilted so: cos 30° for a light along the
    unperturbed normal, cos 0° (times G = 0.99655) for one along the tilted normal, within 1e-3 of the closed
    form of the 8-bit texel. With a TANGENT turned 45 degrees the tilted normal turns with it (Mitsuba's own
    frame, the triangles' dp/du, used before, kept it along +x: 0.927 of the closed form, measured)."""
    frame = MIKKTSPACE if tangent is None else tangent
    c = _decoded(ALONG_U)
    tilted = _world(frame, c)
    for light in ((0.0, 1.0, 0.0), tuple(tilted)):
        got = _radiance(_square(tmp_path, ALONG_U, light, tangent))
        want = _closed_form(tilted, light)
        assert got == pytest.approx(want, rel=1e-3), light
    # the 8-bit texel's own tilt is 30.05 degrees
    assert _closed_form(tilted, (0.0, 1.0, 0.0)) == pytest.approx(ALBEDO / math.pi * IRRADIANCE * math.cos(TILT),
                                                                  rel=5e-3)


@pytest.mark.parametrize("tangent,along", [(MIKKTSPACE, "u"), (TURNED_90, "v")])
def test_the_files_tangent_decides_the_frame(tmp_path, tangent, along):
    """The same map tilted along +u (+X) under a light tilted 30 degrees towards +v (−z): with MikkTSpace's
    tangent (+x) the normal leans away from it, n'·l = cos² 30° = 0.75; with the TANGENT turned 90 degrees
    about the normal (−z, +v) the tilt turns to +v and n'·l = 1 (Mitsuba's own frame, used before: 0.75 for
    both, measured 0.749 of the second's closed form)."""
    light = (0.0, math.cos(TILT), -math.sin(TILT))
    got = _radiance(_square(tmp_path, ALONG_U, light, tangent))
    c = _decoded(ALONG_U)
    want = _closed_form(_world(tangent, c), light)
    assert got == pytest.approx(want, rel=1e-3)
    cosine = 1.0 if along == "v" else math.cos(TILT) ** 2
    assert want == pytest.approx(ALBEDO / math.pi * IRRADIANCE * cosine * shadowing(_world(tangent, c), light),
                                 rel=5e-3)


@pytest.mark.parametrize("w", [-1.0, 1.0])
def test_the_sign_mirrors_the_bitangent(tmp_path, w):
    """A map tilted 30 degrees along +Y, a light tilted 30 degrees towards +z (up the image): with w = −1
    (MikkTSpace's on this square) the bitangent cross(n, t) · w is +z and n'·l = 1; with w = +1 it is −z, the
    tilt flips and n'·l = cos 60° = 0.5 (Mitsuba's own frame, used before, ignores w: 1 for both, measured)."""
    light = (0.0, math.cos(TILT), math.sin(TILT))
    tangent = (1.0, 0.0, 0.0, w)
    got = _radiance(_square(tmp_path, ALONG_Y, light, tangent))
    c = _decoded(ALONG_Y)
    want = _closed_form(_world(tangent, c), light)
    assert got == pytest.approx(want, rel=1e-3)
    cosine = 1.0 if w < 0 else math.cos(2.0 * TILT)
    assert want == pytest.approx(ALBEDO / math.pi * IRRADIANCE * cosine * shadowing(_world(tangent, c), light),
                                 rel=5e-3)



def test_the_coats_own_map_is_read_in_the_same_frame(tmp_path):
    """The clear coat's own map (clearcoatNormalTexture, read by the coat outside the base's normal map) takes
    the same frame: tilted 30 degrees along +X under a TANGENT turned 90 degrees (t = −z) it is the map tilted
    along −Y under MikkTSpace's tangent (b = +z), the same world normal: the same pixels, within 1e-4 (a coat
    over black, lit from its mirror direction of the camera). Mitsuba's frame, blind to the TANGENT, tilted the
    first along +x, away from that light: 0.005 of it (measured)."""
    light = (0.0, math.cos(2.0 * TILT), -math.sin(2.0 * TILT))

    def render(normal, tangent):
        folder = tmp_path / f"{normal}"
        folder.mkdir()
        scene = _square(folder, (0.0, 0.0, 1.0), light, tangent)
        _map(folder / "coat.png", normal)
        mat = dataclasses.replace(scene.materials["m"], base_color=(0.0, 0.0, 0.0), normal_texture=None,
                                  clearcoat=1.0, clearcoat_roughness=0.3, clearcoat_normal_texture=folder / "coat.png",
                                  clearcoat_normal_scale=1.0)
        scene = dataclasses.replace(scene, materials={"m": mat})
        return ReferenceRenderer(scene, cache_dir=False, progress=False).render(4).image.mean()

    turned = render(ALONG_U, TURNED_90)
    mikk = render((0.0, -math.sin(TILT), math.cos(TILT)), MIKKTSPACE)
    assert mikk > 0.05
    assert turned == pytest.approx(mikk, rel=1e-4)

def bumps(path, size: int = 64, slope: float = 0.5) -> None:
    """A glTF normal map of a height field of 4 × 3 bumps over the texture, h = a sin(8πu) sin(6πv) with
    dh/du at most ``slope``: x is the fall along +u, y the rise up the image (−v)."""
    j, i = np.mgrid[0:size, 0:size]
    u, v = (i + 0.5) / size, (j + 0.5) / size
    dh_du = slope * np.cos(8.0 * math.pi * u) * np.sin(6.0 * math.pi * v)
    dh_dv = 0.75 * slope * np.sin(8.0 * math.pi * u) * np.cos(6.0 * math.pi * v)
    n = np.stack([-dh_du, dh_dv, np.ones_like(u)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    Image.fromarray(np.round((n + 1.0) / 2.0 * 255.0).astype(np.uint8), "RGB").save(path)


def bumpy_sphere(tmp_path, *, mirrored: bool, size: int = 32, segments: int = 16, rings: int = 8):
    """A sphere of :func:`compare.scene.geometry.sphere` (no TANGENT: MikkTSpace's) with :func:`bumps`, lit
    by a directional light from beside the camera, direct light only; ``mirrored``: its u runs the other way
    (a mirrored UV chart: MikkTSpace's w changes sign, and n × dp/du points up the image)."""
    bumps(tmp_path / "bumps.png")
    data = {
        "camera": {"position": [0.0, 0.5, 3.2], "target": [0.0, 0.0, 0.0], "fov": 42.0, "resolution": [size, size]},
        "materials": {"m": {"base_color": [0.8, 0.8, 0.8], "roughness": 0.5, "normal_texture": "bumps.png"}},
        "meshes": [{"shape": "sphere", "radius": 1.0, "material": "m", "segments": segments, "rings": rings}],
        "lights": [{"type": "directional", "direction": [-0.4, -0.5, -1.0], "intensity": 3.0, "light_scale": 1.0}],
        "render": {"max_depth": 2},
    }
    scene = parse_scene(data, tmp_path / "sphere.toml")
    if not mirrored:
        return scene
    tri = geometry.sphere(1.0, segments, rings)
    uv = tri.uvs.copy()
    uv[:, 0] = 1.0 - uv[:, 0]
    mesh = Mesh(name="sphere", shape="gltf", material="m", params={"triangles": dataclasses.replace(tri, uvs=uv)})
    return dataclasses.replace(scene, meshes=(mesh,))


def mitsuba_normalmap(mat, bsdf: dict) -> dict:
    """What the reference did before it read glTF's frame: Mitsuba's ``normalmap``, whose frame is the
    triangle's dp/du and n × dp/du (down the image where the chart is not mirrored), the map's y negated."""
    from compare.mitsuba.scene_dict import bitmap_dict
    from compare.scene.textures import normal_map

    if mat.normal_texture is None:
        return bsdf
    return {"type": "normalmap", "bsdf": bsdf,
            "normalmap": bitmap_dict(mat, "normal_texture", normal_map(mat.normal_texture, mat.normal_scale, flip_y=True), raw=True)}


@pytest.mark.parametrize("mirrored", [False, True], ids=["as-generated", "mirrored-u"])
def test_the_reference_agrees_with_the_rasterizer_no_worse(tmp_path, gl_ctx, monkeypatch, mirrored):
    """:func:`bumpy_sphere` (32 × 32, 16 × 8 facets), 64 spp against 32 frames: mean FLIP and relMSE of the
    rasterizer against the reference in glTF's frame, no worse than against the reference in Mitsuba's own
    frame (rendered here too, :func:`mitsuba_normalmap`). Measured (llvm_ad_rgb, llvmpipe):
    as generated 0.04794 / 0.00788 (before: 0.04823 / 0.00791; with 32 × 16 facets, where the triangles'
    dp/du is nearer the interpolated tangent, 0.04843 / 0.00750 against 0.04832 / 0.00747);
    mirrored u 0.04557 / 0.00883 (before: 0.13672 / 0.05854, the map's y the wrong way round)."""
    from compare.metrics.images import flip, relmse
    from compare.mitsuba import scene_dict
    from compare.progressive.rasterizer import render_progressive

    scene = bumpy_sphere(tmp_path, mirrored=mirrored)
    ras = render_progressive(scene, frames=32, ctx=gl_ctx).image

    def agreement():
        ref = ReferenceRenderer(scene, cache_dir=False, progress=False).render(64, seed=0).image
        return float(flip(ref, ras)[0]), relmse(ref, ras)

    new = agreement()
    monkeypatch.setattr(scene_dict, "_normal_mapped", mitsuba_normalmap)
    before = agreement()
    print(f"FLIP, relMSE: {new[0]:.5f}, {new[1]:.5f} (before: {before[0]:.5f}, {before[1]:.5f})")
    assert new[0] <= before[0] and new[1] <= before[1]
    if mirrored:  # where the frames differ, by far
        assert new[0] < 0.5 * before[0] and new[1] < 0.25 * before[1]
