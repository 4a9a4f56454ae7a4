"""Each Khronos sample model of scenes/khronos/ shows what its own README says a correct viewer shows.

A README states what is correct: a square that must be green and never red, an arrow that must point at a
marker, a column whose tiles must look alike, a colour that equals a vertex's position. Each test measures
that claim in the reference (and in the rasterizer, which declares every feature these models use but
dispersion and anisotropy), at positions taken from the model's own geometry (its nodes' triangles as the
suite loads them), never from pixel coordinates written down by hand. Where a claim has a closed form (a
vertex colour equal to its position, an attenuation colour raised to a thickness) the test compares with it.

A lighting of the test's own replaces the scene's uniform sky where the README's claim needs one: a sky over
a dark ground (a horizon), which a normal map or a flipped normal changes, or a studio's soft boxes, whose
highlights an anisotropic lobe stretches.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from compare.scene.loader import load_scene
from compare.scene.model import Environment
from compare.scene.procedural_env import validate_procedural
from compare.scene.textures import load_texture
from tests.helpers import FAST_IBL

pytestmark = pytest.mark.filterwarnings("ignore::UserWarning")

KHRONOS = Path(__file__).resolve().parent.parent / "scenes" / "khronos"


# ----------------------------------------------------------------------------- the models' geometry

def _scene(name: str):
    return load_scene(KHRONOS / f"{name}.toml")


def _part(scene, name: str):
    """The mesh of the model's node ``name`` (a scene names an included node ``<Model>/<node>``)."""
    (mesh,) = [m for m in scene.meshes if m.name.split("/", 1)[1] == name]
    return mesh


def _bounds(*meshes) -> tuple[np.ndarray, np.ndarray]:
    p = np.concatenate([m.triangles().positions for m in meshes]).astype(np.float64)
    return p.min(0), p.max(0)


def _islands(tri) -> list[np.ndarray]:
    """The connected pieces of a triangle mesh (triangles that share a vertex position): their triangle
    indices, one array per piece."""
    _, vertex = np.unique(np.round(tri.positions.astype(np.float64), 5), axis=0, return_inverse=True)
    faces = vertex.ravel()[tri.indices]
    parent = np.arange(faces.max() + 1)

    def root(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for a, b, c in faces:
        ra = root(a)
        parent[root(b)] = ra
        parent[root(c)] = ra
    roots = np.array([root(a) for a in faces[:, 0]])
    return [np.nonzero(roots == r)[0] for r in np.unique(roots)]


def _island_bounds(tri) -> list[tuple[np.ndarray, np.ndarray]]:
    out = []
    for tris in _islands(tri):
        p = tri.positions[tri.indices[tris].ravel()].astype(np.float64)
        out.append((p.min(0), p.max(0)))
    return out


# ----------------------------------------------------------------------------- cameras and pixels

def _pixels(camera, points) -> np.ndarray:
    """Film positions (x right, y down, in pixels) of world ``points``."""
    r, u, f = camera.basis()
    q = np.atleast_2d(np.asarray(points, dtype=np.float64)) - np.asarray(camera.position)
    t = math.tan(math.radians(camera.fov) / 2)
    x = (q @ r) / (q @ f) / (t * camera.aspect)
    y = (q @ u) / (q @ f) / t
    return np.stack([(x + 1) / 2 * camera.width, (1 - y) / 2 * camera.height], axis=-1)


def _box(camera, lo, hi, inset: float = 0.08) -> tuple[slice, slice]:
    """The pixels (rows, columns) a world box covers, less ``inset`` of its size on each side."""
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    p = _pixels(camera, corners)
    (x0, y0), (x1, y1) = p.min(0), p.max(0)
    dx, dy = (x1 - x0) * inset, (y1 - y0) * inset
    return (slice(int(round(y0 + dy)), int(round(y1 - dy))), slice(int(round(x0 + dx)), int(round(x1 - dx))))


def _framed(scene, lo, hi, width: int, height: int, *, axis=(0.0, 0.0, 1.0), margin: float = 1.05):
    """``scene`` seen along −``axis`` from far away (eight times the box's radius), the box ``lo``–``hi``
    filling the ``width`` × ``height`` image up to ``margin``."""
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    centre, half = (lo + hi) / 2, (hi - lo) / 2
    d = np.asarray(axis, dtype=np.float64) / np.linalg.norm(axis)
    up = np.array([0.0, 1.0, 0.0]) if abs(d[1]) < 0.9 else np.array([0.0, 0.0, -1.0])
    right = np.cross(-d, up)
    right /= np.linalg.norm(right)
    reach = 8.0 * float(np.linalg.norm(half))
    near = reach - np.abs(d) @ half
    across = max(np.abs(np.cross(right, -d)) @ half, (np.abs(right) @ half) * height / width)
    fov = math.degrees(2 * math.atan(across * margin / near))
    camera = dataclasses.replace(scene.camera, position=tuple(centre + d * reach), target=tuple(centre),
                                 up=tuple(up), fov=fov, resolution=(width, height))
    return dataclasses.replace(scene, camera=camera)


def _sky(scene):
    """``scene`` under a sky over a dark ground (the procedural sky without its sun): light from above."""
    params = validate_procedural("sky", {"sun_radiance": 0.0, "glow": 0.0, "width": 128})
    return dataclasses.replace(scene, environment=Environment(procedural="sky", parameters=tuple(sorted(params.items()))))


# ----------------------------------------------------------------------------- renders and measures

def _reference(scene, spp: int, seed: int = 1) -> np.ndarray:
    from compare.mitsuba.reference import ReferenceRenderer

    return ReferenceRenderer(scene, cache_dir=False, progress=False).render(spp, seed=seed).image


def _raster(scene, ctx, frames: int = 8) -> np.ndarray:
    from compare.progressive.rasterizer import render_progressive

    return render_progressive(scene, frames=frames, seed=1, ctx=ctx, **FAST_IBL).image


def _renders(scene, gl_ctx, spp: int, frames: int = 8) -> dict[str, np.ndarray]:
    """The reference's and the rasterizer's images of ``scene``."""
    return {"reference": _reference(scene, spp), "progressive": _raster(scene, gl_ctx, frames)}


def _ncc(a, b, shift: int = 0) -> float:
    """Normalised cross-correlation of two equal-sized images, the best over shifts of up to ``shift``
    pixels (a box projected a pixel off)."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    best = -1.0
    h, w = a.shape[:2]
    for dy in range(-shift, shift + 1):
        for dx in range(-shift, shift + 1):
            x = a[max(dy, 0):h + min(dy, 0), max(dx, 0):w + min(dx, 0)].ravel()
            y = b[max(-dy, 0):h + min(-dy, 0), max(-dx, 0):w + min(-dx, 0)].ravel()
            x, y = x - x.mean(), y - y.mean()
            best = max(best, float(x @ y / math.sqrt((x @ x) * (y @ y) + 1e-30)))
    return best


def _alike(image, box_a, box_b) -> tuple[np.ndarray, np.ndarray]:
    """The pixels of two boxes of one image, cut to the same size."""
    a, b = image[box_a], image[box_b]
    h, w = min(a.shape[0], b.shape[0]), min(a.shape[1], b.shape[1])
    return a[:h, :w], b[:h, :w]


def _red_share(pixels, white: float) -> float:
    """The share of ``pixels`` that are a bright red (a red "X" of a failed test): red over twice green and
    blue, and over a quarter of the ``white`` of the image's paper."""
    r, g, b = pixels[..., 0], pixels[..., 1], pixels[..., 2]
    return float(((r > 2 * np.maximum(g, b)) & (r > 0.25 * white)).mean())


def _green_share(pixels):
    """Green's share of each pixel's colour (a green check on white paper, whatever the light's level)."""
    return pixels[..., 1] / np.maximum(pixels.sum(-1), 1e-6)


def _footprint(camera, rows: slice, cols: slice, z: float, sub: int = 4) -> np.ndarray:
    """World (x, y) where the rays of ``sub`` × ``sub`` points in each pixel of ``rows`` × ``cols`` meet the
    plane at height ``z``: (rows, cols, sub, sub, 2)."""
    r, c = np.mgrid[rows, cols]
    o = (np.arange(sub) + 0.5) / sub
    y, x = np.broadcast_arrays(r[..., None, None] + o[:, None], c[..., None, None] + o[None, :])
    d = camera.ray_directions(x, y)
    p = np.asarray(camera.position, dtype=np.float64)
    return (p + ((z - p[2]) / d[..., 2])[..., None] * d)[..., :2]


def _affine_uv(xy, uv) -> np.ndarray:
    """The affine map (3 × 2) from a flat face's (x, y) to its texture coordinates, fitted to its vertices."""
    coef, *_ = np.linalg.lstsq(np.c_[xy, np.ones(len(xy))], uv, rcond=None)
    return coef


def _sample(texture: np.ndarray, uv) -> np.ndarray:
    """Nearest texels of ``texture`` (row 0 at the top, glTF's v = 0) at ``uv`` (wrapped), averaged over
    the sub-pixel axes of :func:`_footprint`."""
    h, w = texture.shape[:2]
    rows = np.clip((np.mod(uv[..., 1], 1.0) * h).astype(int), 0, h - 1)
    cols = np.clip((np.mod(uv[..., 0], 1.0) * w).astype(int), 0, w - 1)
    return texture[rows, cols].mean(axis=(2, 3))


def _r2(y, *columns) -> tuple[np.ndarray, float]:
    """Least-squares fit of ``y`` by the ``columns`` and a constant: coefficients and R²."""
    x = np.column_stack([*(np.ravel(c) for c in columns), np.ones(np.size(y))])
    coef, *_ = np.linalg.lstsq(x, np.ravel(y), rcond=None)
    rest = np.ravel(y) - x @ coef
    return coef, float(1 - rest @ rest / np.sum((np.ravel(y) - np.mean(y)) ** 2))


# ----------------------------------------------------------------------------- what the files hold

def test_simple_instancing_runs_from_the_plain_cube_to_the_turned_doubled_one_at_10():
    """SimpleInstancing: "the first instance that is rendered is the unmodified unit cube, and the last
    instance is a cube at (10, 10, 10) that is rotated around the axis (1, 1, 1) ... and scaled by
    (2, 2, 2)"; "the translation ranges from 0.0 to 10.0 along each axis ... the scale ranges from 1.0 to 2.0".
    (The last turn is 120°, the file's quaternion (½, ½, ½, ½), which takes x to y, y to z and z to x; the
    README says 90°.)"""
    from compare.scene.gltf_read import load_gltf

    doc = load_gltf(KHRONOS / "SimpleInstancing" / "SimpleInstancing.glb")
    first, last = doc.primitives[0].matrix, doc.primitives[-1].matrix
    np.testing.assert_allclose(first, np.eye(4), atol=1e-6)
    np.testing.assert_allclose(last[:3, 3], [10.0, 10.0, 10.0], atol=1e-5)
    turn = last[:3, :3] / 2.0
    np.testing.assert_allclose(turn, [[0, 0, 1], [1, 0, 0], [0, 1, 0]], atol=1e-6)  # scale 2, a turn about (1, 1, 1)
    np.testing.assert_allclose(turn @ np.ones(3), np.ones(3), atol=1e-6)
    matrices = np.array([p.matrix for p in doc.primitives])
    np.testing.assert_allclose([matrices[:, :3, 3].min(), matrices[:, :3, 3].max()], [0.0, 10.0], atol=1e-5)
    scales = np.linalg.norm(matrices[:, :3, :3], axis=1)
    np.testing.assert_allclose([scales.min(), scales.max()], [1.0, 2.0], atol=1e-5)


def test_morph_primitives_test_raises_both_primitives_by_half_their_target():
    """MorphPrimitivesTest: "a larger red primitive displays a grid covering 3 of the 4 quadrants ... a smaller
    green primitive covering the last"; "the model's only mesh contains a weights: [0.5] instruction that should
    cause these morph targets to be applied at half strength, raising the center of the model". Each loaded
    primitive is its POSITION plus half its target's displacement, exactly; the red one covers three times the
    green one's area; only the middle half of the square is raised."""
    from compare.scene.glb import parse_glb
    from compare.scene.gltf_read import load_gltf

    path = KHRONOS / "MorphPrimitivesTest" / "MorphPrimitivesTest.glb"
    raw, chunk = parse_glb(path.read_bytes())

    def accessor(index):
        a = raw["accessors"][index]
        view = raw["bufferViews"][a["bufferView"]]
        start = view.get("byteOffset", 0) + a.get("byteOffset", 0)
        return np.frombuffer(chunk, np.float32, count=3 * a["count"], offset=start).reshape(-1, 3)

    (mesh,) = raw["meshes"]
    assert mesh["weights"] == [0.5]
    doc = load_gltf(path)
    areas = {}
    for prim, loaded in zip(mesh["primitives"], doc.primitives, strict=True):
        base, delta = accessor(prim["attributes"]["POSITION"]), accessor(prim["targets"][0]["POSITION"])
        np.testing.assert_allclose(loaded.mesh.positions, base + 0.5 * delta, atol=1e-6)
        colour = tuple(raw["materials"][prim["material"]]["pbrMetallicRoughness"]["baseColorFactor"][:3])
        p = loaded.mesh.positions[loaded.mesh.indices][..., [0, 2]]
        u, v = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
        areas[colour] = float(np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]).sum() / 2)
    assert areas[(1.0, 0.0, 0.0)] == pytest.approx(3 * areas[(0.0, 1.0, 0.0)], rel=1e-4), areas
    p = np.concatenate([prim.mesh.positions for prim in doc.primitives])
    raised, reach = p[p[:, 1] > 1e-6], np.abs(p[:, [0, 2]]).max()
    assert p[:, 1].max() > 0.05 and np.abs(raised[:, [0, 2]]).max() <= 0.5 * reach + 1e-6, raised  # the middle


def test_unlit_test_colours_are_the_readme_s():
    """UnlitTest: "one orange-ish (#FF7F00 in sRGB space) and one blue-ish (#007FFF in sRGB space)" (within
    2/255 once encoded: the file's 0.2176 is 128.5/255); tests/test_khronos_models.py checks that both renderers
    show them unchanged by light."""
    from compare.image.tonemap import srgb_encode

    scene = _scene("UnlitTest")
    got = sorted(tuple(float(c) for c in srgb_encode(np.asarray(m.emission)) * 255) for m in scene.materials.values())
    np.testing.assert_allclose(got, sorted([(0x00, 0x7F, 0xFF), (0xFF, 0x7F, 0x00)]), atol=2.0)


# ----------------------------------------------------------------------------- texture coordinates

def test_texture_coordinate_test_shows_each_corner_of_the_image_on_the_quad_named_for_it(gl_ctx):
    """TextureCoordinateTest: "the accessor named TopLeft_TEXCOORD_0 shows that the upper-left portion of the
    texture image is represented by texture coordinates ranging from roughly 0.0 to roughly 0.4". The quad
    at the top left holds those coordinates, and each quad shows its part of the image the right way round:
    the render correlates with the image sampled at the quad's coordinates (v = 0 at the image's top) better
    than with the image flipped in u, in v or both (the image is symmetric but for its labels)."""
    scene = _scene("TextureCoordinateTest").with_resolution(200, 200)
    top_left = _part(scene, "TopLeftObj").triangles()
    np.testing.assert_allclose(top_left.uvs.min(0), [0.0, 0.0], atol=1e-6)
    np.testing.assert_allclose(top_left.uvs.max(0), [0.4, 0.4], atol=1e-6)
    assert top_left.positions[:, 0].max() < 0 < top_left.positions[:, 1].min()  # at the top left
    renders = _renders(scene, gl_ctx, spp=32)
    for corner in ("TopLeft", "TopRight", "BottomLeft", "BottomRight"):
        mesh = _part(scene, f"{corner}Obj")
        tri = mesh.triangles()
        texture = load_texture(scene.materials[mesh.material].base_color_texture, srgb=False)
        rows, cols = _box(scene.camera, *_bounds(mesh), inset=0.04)
        uv = _footprint(scene.camera, rows, cols, float(tri.positions[:, 2].mean()))
        uv = uv @ (a := _affine_uv(tri.positions[:, :2], tri.uvs))[:2] + a[2]
        flips = {"as given": (1, 0), "u flipped": (-1, 0), "v flipped": (1, 1), "both flipped": (-1, 1)}
        for name, image in renders.items():
            scores = {}
            for flip, (su, fv) in flips.items():
                u = uv[..., 0] if su == 1 else 1 - uv[..., 0]
                v = 1 - uv[..., 1] if fv else uv[..., 1]
                want = _sample(texture, np.stack([u, v], -1)).mean(-1)
                scores[flip] = _ncc(image[rows, cols].mean(-1), want)
            wrong = max(v for k, v in scores.items() if k != "as given")
            assert scores["as given"] > 0.8 and scores["as given"] > wrong + 0.03, (corner, name, scores)


def test_texture_transform_offsets_show_their_quadrant_and_the_arrows_point_at_the_green_markers(gl_ctx):
    """TextureTransformTest (KHR_texture_transform on a clamped base-colour map): the top row's offsets (0.5, 0),
    (0, 0.5) and (0.5, 0.5) of coordinates 0–0.5 show the image's other quadrants ("a yellow image indicates
    that offset was not applied"); on the bottom row the arrow turned by 22.5°, the arrow scaled by 1.5 and the
    arrow under all three "should point to the green marker", not the yellow ("not applied") or red ("the
    opposite direction") one. The markers are the model's own meshes; the arrow is the dark pixels of its
    quad, its axis their principal direction, its tip their end towards the marker it points at."""
    scene = _scene("TextureTransformTest").with_resolution(160, 160)
    camera = scene.camera
    uv_map = load_texture(KHRONOS / "TextureTransformTest" / "UV.png", srgb=True)
    h, w = uv_map.shape[:2]
    quadrant = {(ou, ov): uv_map[int(ov * h):int((ov + 0.5) * h), int(ou * w):int((ou + 0.5) * w)].reshape(-1, 3).mean(0)
                for ou in (0.0, 0.5) for ov in (0.0, 0.5)}
    offsets = {"Offset U": (0.5, 0.0), "Offset V": (0.0, 0.5), "Offset UV": (0.5, 0.5)}
    arrows = {"Rotation": ("Rotation - Correct", "Rotation - Not Supported", "Rotation - Error"),
              "Scale": ("Scale - Correct", "Scale - Not Supported"), "All": ("All - Correct",)}
    for name, image in _renders(scene, gl_ctx, spp=16).items():
        for quad, offset in offsets.items():
            mesh = _part(scene, quad)
            assert scene.materials[mesh.material].sampling("base_color_texture").offset == offset
            got = image[_box(camera, *_bounds(mesh), inset=0.1)].reshape(-1, 3).mean(0)
            chroma = {k: np.abs(got / got.sum() - c / c.sum()).sum() for k, c in quadrant.items()}
            assert min(chroma, key=chroma.get) == offset, (name, quad, got, chroma)
        for quad, markers in arrows.items():
            rows, cols = _box(camera, *_bounds(_part(scene, quad)), inset=0.06)
            lum = image[rows, cols].mean(-1)
            ys, xs = np.nonzero(lum < 0.3 * np.median(lum))
            dark = np.c_[xs + cols.start + 0.5, ys + rows.start + 0.5]
            centre = dark.mean(0)
            axis = np.linalg.eigh(np.cov((dark - centre).T))[1][:, -1]
            along = (dark - centre) @ axis
            where = {}
            for marker in markers:
                d = _pixels(camera, np.mean(_bounds(_part(scene, marker)), axis=0))[0] - centre
                ahead = 1.0 if d @ axis > 0 else -1.0
                tip = centre + axis * ahead * (along.max() if ahead > 0 else -along.min())
                where[marker] = (abs(d[0] * axis[1] - d[1] * axis[0]), float(np.linalg.norm(d + centre - tip)))
            off_axis, reach = where[markers[0]]
            assert off_axis < 2.0, (name, quad, where)  # on the arrow's line, within two pixels ...
            for other in markers[1:]:  # ... and the nearest to its tip of the markers on that line
                assert where[other][0] > 8.0 or where[other][1] > reach + 8.0, (name, quad, where)


def test_texture_settings_test_boxes_look_like_the_sample_column(gl_ctx):
    """TextureSettingsTest: "all of the boxes in the "Test" column should look very similar to the corresponding
    box in the "Sample pass" column ... green checkmarks, except the two "clamp" tests, which should be solid
    green boxes"; every failure is red. Each row's mesh holds its test box (with, for the sided rows, the
    polygon facing away in front of it) and its sample box. In each test box: no bright red, the check's
    green share correlating with the sample's (checks), or the sample's colour (solid boxes). In the
    reference the single-sided row's check is darkened by the culled polygon in front of it, which light
    meets from its front side (the correlation of green's share is kept by that)."""
    scene = _scene("TextureSettingsTest")
    rows = [m for m in scene.meshes if "Mesh" in m.name and not m.name.endswith(("LabelMesh", "BackgroundMesh"))]
    assert len(rows) == 8
    scene = _framed(scene, *_bounds(*rows), 72, 180)
    for name, image in _renders(scene, gl_ctx, spp=32).items():
        for mesh in rows:
            pieces = _island_bounds(mesh.triangles())
            test = [b for b in pieces if b[1][0] < 1.5]
            (sample,) = [b for b in pieces if b[0][0] > 1.5]
            test_box = _box(scene.camera, np.min([b[0] for b in test], 0), np.max([b[1] for b in test], 0))
            got, want = _alike(image, test_box, _box(scene.camera, *sample))
            white = float(np.percentile(want.max(-1), 90))
            assert _red_share(got, white) < 0.02, (name, mesh.name, _red_share(got, white))
            if "Clamp" in mesh.name:  # solid green
                np.testing.assert_allclose(got.reshape(-1, 3).mean(0), want.reshape(-1, 3).mean(0), rtol=0.05,
                                           atol=0.01, err_msg=f"{name} {mesh.name}")
            else:
                score = _ncc(_green_share(got), _green_share(want), shift=1)
                assert score > 0.7, (name, mesh.name, score)


def test_multi_uv_test_reads_its_emission_on_the_second_texture_coordinates(gl_ctx):
    """MultiUVTest: "tests a second set of texture coordinates": the cube's emissive map (the glTF logo) is read
    on TEXCOORD_1, its base colour on TEXCOORD_0. On the face seen face on, the render is the base colour
    sampled at the face's first coordinates plus the emission sampled at its second (a least-squares fit with
    an emission weight near 1 explains it), far better than with the emission sampled at the first."""
    scene = _scene("MultiUVTest").with_resolution(64, 64)
    mesh = _part(scene, "Cube")
    material = scene.materials[mesh.material]
    assert material.sampling("emissive_texture").texcoord == 1 and material.sampling("base_color_texture").texcoord == 0
    tri = mesh.triangles()
    z = float(tri.positions[:, 2].max())
    face = np.unique(tri.indices[np.all(np.abs(tri.positions[tri.indices][..., 2] - z) < 1e-4, axis=1)])
    rows, cols = _box(scene.camera, tri.positions[face].min(0), tri.positions[face].max(0), inset=0.03)
    xy = _footprint(scene.camera, rows, cols, z)
    uv0 = xy @ (a := _affine_uv(tri.positions[face, :2], tri.uvs[face]))[:2] + a[2]
    uv1 = xy @ (a := _affine_uv(tri.positions[face, :2], tri.uvs1[face]))[:2] + a[2]
    base = _sample(load_texture(material.base_color_texture, srgb=True), uv0)
    emissive = load_texture(material.emissive_texture, srgb=True)
    for name, image in _renders(scene, gl_ctx, spp=32).items():
        (_, weight, _), right = _r2(image[rows, cols], base, _sample(emissive, uv1))
        _, wrong = _r2(image[rows, cols], base, _sample(emissive, uv0))
        assert right > 0.75 and right > wrong + 0.15 and 0.7 < weight < 1.3, (name, right, wrong, weight)


# ----------------------------------------------------------------------------- vertex colours

def test_vertex_color_test_colours_zero_the_other_channels_of_the_test_row(gl_ctx):
    """VertexColorTest: the "Test" row's red, green and blue vertex colours multiply a map whose other two
    channels hold an "X" ("the red check has a cyan X ..."): with the colours applied those channels are dark
    and each check looks like its "sample pass" below it (white vertex colours). The tiles are the model's
    pieces, found by their vertex colours."""
    scene = _scene("VertexColorTest").with_resolution(128, 128)
    tri = _part(scene, "VertexColorTest").triangles()
    tiles: dict[tuple, list] = {}
    for tris in _islands(tri):
        v = tri.indices[tris].ravel()
        colour = tuple(float(c) for c in np.round(tri.colors[v, :3].mean(0), 2))
        tiles.setdefault(colour, []).append((tri.positions[v].min(0), tri.positions[v].max(0)))
    assert len(tiles[(1.0, 1.0, 1.0)]) == 3
    for name, image in _renders(scene, gl_ctx, spp=16).items():
        for channel in range(3):
            colour = tuple(float(k == channel) for k in range(3))
            (test,) = tiles[colour]
            (sample,) = [b for b in tiles[(1.0, 1.0, 1.0)] if abs(b[0][0] - test[0][0]) < 0.05]
            got, want = _alike(image, _box(scene.camera, *test, inset=0.05), _box(scene.camera, *sample, inset=0.05))
            others = [k for k in range(3) if k != channel]
            assert got[..., others].max() < 0.1 * got[..., channel].max(), (name, colour, got[..., others].max())
            score = _ncc(got[..., channel], want[..., channel], shift=1)
            assert score > 0.7, (name, colour, score)


def test_box_vertex_colors_are_the_vertex_positions(gl_ctx):
    """BoxVertexColors: "the color of each vertex is given by the RGB colors that are defined by the vertex
    coordinates" of a unit cube: COLOR_0 equals POSITION at every vertex, and, seen towards the (1, 1, 1)
    corner, each channel of the render is one affine function of the colour interpolated to the point seen
    (the point's own coordinates: x red, y green, z blue; the material is glTF's default, white metal of
    roughness 1, whose response is the same for every channel), which a permuted channel order is not."""
    scene = _scene("BoxVertexColors")
    tri = scene.meshes[0].triangles()
    np.testing.assert_allclose(tri.colors[:, :3], tri.positions, atol=1e-6)
    lo, hi = _bounds(*scene.meshes)
    scene = _framed(scene, lo, hi, 48, 48, axis=(1.0, 1.0, 1.0))
    camera = scene.camera
    r, c = np.mgrid[0:48, 0:48]
    d = camera.ray_directions(c + 0.5, r + 0.5)
    o = np.asarray(camera.position)
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (lo - o) / d, (hi - o) / d
    near, far = np.minimum(t0, t1).max(-1), np.maximum(t0, t1).min(-1)
    point = np.clip(o + near[..., None] * d, 0.0, 1.0)
    edge = np.sort(np.minimum(point - lo, hi - point), axis=-1)[..., 1]  # distance to the face's nearest edge
    inside = (near < far) & (edge > 0.04)
    assert inside.sum() > 500
    for name, image in _renders(scene, gl_ctx, spp=64).items():
        seen = image[inside]
        (slope, offset), right = _r2(seen, point[inside])
        wrong = max(_r2(seen, point[inside][:, order])[1] for order in ([2, 1, 0], [1, 2, 0], [2, 0, 1]))
        assert right > 0.9 and wrong < 0.3 and slope > 0.2 and abs(offset) < 0.05, (name, right, wrong, slope)


# ----------------------------------------------------------------------------- sides, mirrors, rotations

def test_two_sided_plane_is_drawn_from_behind_as_its_mirror_image(gl_ctx):
    """TwoSidedPlane: "a plane having the two sided material parameter enabled". Seen from below, the plane
    covers the pixels its square projects to, as from above, and looks like the view from above mirrored
    (a double-sided face shades with its normal, and its normal map, turned to the viewer)."""
    scene = _scene("TwoSidedPlane")
    (mesh,) = scene.meshes
    assert scene.materials[mesh.material].double_sided
    lo, hi = _bounds(mesh)
    above = _framed(scene, lo, hi, 32, 32, axis=(0.0, 1.0, 0.0), margin=1.25)
    below = _framed(scene, lo, hi, 32, 32, axis=(0.0, -1.0, 0.0), margin=1.25)
    rows, cols = _box(above.camera, lo, hi, inset=0.0)
    square = np.zeros((32, 32), bool)
    square[rows, cols] = True
    inner = _box(above.camera, lo, hi, inset=0.05)
    for name, render in (("reference", lambda s: _reference(s, 32)), ("progressive", lambda s: _raster(s, gl_ctx))):
        top, bottom = render(above), render(below)
        for image in (top, bottom):  # the uniform sky is 1: the plane is wherever a pixel is not
            drawn = np.abs(image - 1.0).max(-1) > 0.02
            assert (drawn == square).mean() > 0.97, (name, (drawn == square).mean())
        mirrored = bottom[:, ::-1]
        diff = float(np.abs(top[inner] - mirrored[inner]).mean() / top[inner].mean())
        unmirrored = float(np.abs(top[inner] - bottom[inner]).mean() / top[inner].mean())
        assert diff < 0.12 and diff < 0.5 * unmirrored, (name, diff, unmirrored)


def test_orientation_test_arrows_point_at_their_targets():
    """OrientationTest: the arrows are placed by node rotations (quaternions on one side of the cube, matrices
    on the other); their targets' positions are baked into their vertices. "If each colored arrow points
    directly at a target of the same color, the test passes": each target's centre lies on its arrow's long
    axis (within 2 % of the arrow's length) beyond the arrow's end. A transposed rotation turns the arrows
    by twice their angles (10°–70°) off their targets. Every renderer draws these world-space triangles."""
    scene = _scene("OrientationTest")
    for key in ("X1", "Y1", "Z1", "X2", "Y2", "Z2"):
        arrow = _part(scene, f"Arrow{key}").triangles().positions.astype(np.float64)
        target = _part(scene, f"Target{key}").triangles().positions.astype(np.float64).mean(0)
        centre = arrow.mean(0)
        axis = np.linalg.eigh(np.cov((arrow - centre).T))[1][:, -1]
        if (target - centre) @ axis < 0:
            axis = -axis
        along = (arrow - centre) @ axis
        length = along.max() - along.min()
        d = target - centre
        off = float(np.linalg.norm(d - (d @ axis) * axis))
        assert off < 0.02 * length and d @ axis > along.max(), (key, off / length, d @ axis, along.max())


def test_negative_scale_test_culls_and_lights_mirrored_nodes_as_the_others(gl_ctx):
    """NegativeScaleTest: a node whose transform mirrors turns its triangles' winding ("the determinant of the
    node's global transform defines the winding order"), so culling and lighting must follow. The check
    rows (scale 1 and −1; "front" and "back" columns, a single-sided polygon facing away in front of the
    "back" ones) show green checks like the "sample" column and no red "X"; and "the two white spheres should
    be lit the same, regardless of the negative scaling" (likewise the dark and the metal pair): under a sky
    over a dark ground each sphere of a pair has the same mean and the same ratio of its top to its bottom."""
    scene = _scene("NegativeScaleTest")
    rows = [_part(scene, n) for n in ("PositiveScaleTest", "NegativeScaleBack", "NegativeScaleFront")]
    boxes = _framed(scene, *_bounds(*rows), 96, 48)
    columns = (0.0, 1.9, 3.83)  # front, back, sample: the columns' centres (x) of the model's labels
    cells: dict[tuple, tuple] = {}
    for mesh in rows:
        for lo, hi in _island_bounds(mesh.triangles()):
            key = ("+1" if lo[1] > 2.0 else "-1", int(np.argmin([abs((lo[0] + hi[0]) / 2 - x) for x in columns])))
            old = cells.get(key, (lo, hi))
            cells[key] = (np.minimum(old[0], lo), np.maximum(old[1], hi))
    assert len(cells) == 6
    spheres = [(_part(scene, f"{k}1"), _part(scene, f"{k}Minus1")) for k in ("NotShiny", "Dark", "Shiny")]
    assert all(np.linalg.det(b.transform[:3, :3]) * np.linalg.det(a.transform[:3, :3]) < 0 for a, b in spheres)
    lit = _sky(_framed(scene, *_bounds(*[m for pair in spheres for m in pair]), 48, 56))
    for name, render in (("reference", lambda s: _reference(s, 32)), ("progressive", lambda s: _raster(s, gl_ctx))):
        image = render(boxes)
        for row in ("+1", "-1"):
            for column in (0, 1):
                got, want = _alike(image, _box(boxes.camera, *cells[row, column]), _box(boxes.camera, *cells[row, 2]))
                white = float(np.percentile(want.max(-1), 90))
                score = _ncc(_green_share(got), _green_share(want), shift=1)
                assert _red_share(got, white) < 0.02 and score > 0.5, (name, row, column, _red_share(got, white), score)
        image = render(lit)
        for a, b in spheres:
            views = [image[_box(lit.camera, *_bounds(m), inset=-0.05)] for m in (a, b)]
            h = min(v.shape[0] for v in views)
            means = [float(v.mean()) for v in views]
            tops = [float(v[: h // 3].mean() / max(v[-(h // 3):].mean(), 1e-6)) for v in views]
            assert abs(means[0] / means[1] - 1) < 0.06 and abs(tops[0] / tops[1] - 1) < 0.1, (name, a.name, means, tops)
        white = image[_box(lit.camera, *_bounds(spheres[0][0]), inset=-0.05)]  # the sky lights it from above
        assert white[: white.shape[0] // 3].mean() > 1.2 * white[-(white.shape[0] // 3):].mean(), name


# ----------------------------------------------------------------------------- normal maps

def _horizon(image, camera, centre, radius) -> tuple[float, float]:
    """How a dome at ``centre`` (world, radius ``radius``) reflects a horizon, from the inner half of its
    disk: (top − bottom) and (left − right) of its halves' mean brightness, over (top + bottom)."""
    pc = _pixels(camera, centre)[0]
    pr = _pixels(camera, np.add(centre, (radius, 0.0, 0.0)))[0][0] - pc[0]
    ys, xs = np.mgrid[0:image.shape[0], 0:image.shape[1]]
    dx, dy = xs + 0.5 - pc[0], ys + 0.5 - pc[1]
    disk = dx ** 2 + dy ** 2 < (0.5 * pr) ** 2
    lum = image.mean(-1)
    top, bottom = lum[disk & (dy < -1)].mean(), lum[disk & (dy > 1)].mean()
    left, right = lum[disk & (dx < -1)].mean(), lum[disk & (dx > 1)].mean()
    return float((top - bottom) / (top + bottom)), float((left - right) / (top + bottom))


@pytest.mark.parametrize("model", [pytest.param("NormalTangentTest", marks=pytest.mark.npm("mikktspace")),
                                   "NormalTangentMirrorTest"])
def test_normal_mapped_cells_reflect_the_horizon_as_the_real_bumps_beside_them(gl_ctx, model):
    """NormalTangentTest (tangents the renderer makes: MikkTSpace) and NormalTangentMirrorTest (the file's
    TANGENT, mirrored UVs among them): each row pairs a real bump (geometry) with flat cells whose normal map
    draws the same bump, turned and mirrored; "all of the test blocks show similar reflections" of a
    horizon. Under a sky over a dark ground, the inner half of each flat cell's bump is brighter at its top
    than at its bottom by the real bump's measure (0.55 to 1.6 times it), and level (left and right within 40 % of
    that); a flipped green channel or a tangent that ignores the mirroring turns the reflection upside down
    or sideways. (Where a normal map tilts the normal beyond 45°, the reference's mirror reflection points
    into the surface and is black: the rim of a flat cell's bump, left out here, is dark in the reference
    where the real bump reflects the ground.)"""
    scene = _scene(model)
    (mesh,) = scene.meshes
    tri = mesh.triangles()
    cells = [b for b in _island_bounds(tri) if np.all(np.abs((b[1] - b[0])[:2] - 0.3) < 0.05)]
    real = [b for b in cells if b[1][2] - b[0][2] > 0.05]
    flat = [b for b in cells if b[1][2] - b[0][2] < 0.01]
    assert (len(real), len(flat)) in ((15, 15), (10, 30)), (len(real), len(flat))
    raised = tri.positions[tri.positions[:, 2] > 0.005]
    radius = float(np.median([np.ptp(raised[np.all((raised >= lo) & (raised <= hi), axis=1), 0]) / 2 for lo, hi in real]))
    scene = _sky(_framed(scene, *_bounds(mesh), 192, 160))
    for name, image in _renders(scene, gl_ctx, spp=32).items():
        for lo, hi in flat:
            (rlo, rhi) = max((b for b in real if abs(b[0][1] - lo[1]) < 0.05 and b[0][0] < lo[0]), key=lambda b: b[0][0])
            want, _ = _horizon(image, scene.camera, [(rlo[0] + rhi[0]) / 2, (rlo[1] + rhi[1]) / 2, 0.0], radius)
            tilt, side = _horizon(image, scene.camera, [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, 0.0], radius)
            assert want > 0.1 and 0.55 < tilt / want < 1.6 and abs(side) < 0.4 * want, (name, lo[:2], want, tilt, side)


# ----------------------------------------------------------------------------- transmission and volumes

@pytest.mark.slow
def test_attenuation_test_columns_are_one_shade_of_blue_that_deepens_with_thickness(gl_ctx):
    """AttenuationTest (KHR_materials_volume): "an implementation can pass the test ... if it displays a uniform
    shade of blue in each vertical column"; the top row, "Sample Color", is the answer key: thin surfaces
    whose base colour is the attenuation formula's, attenuationColor ** (thickness / attenuationDistance)
    (checked in the file). Below it the cubes' thickness comes from their size (thicknessFactor), a thickness
    map, a node's scale, or the attenuation distance. Seen face on, each cube's chroma (green over blue, its
    median over the inner face, over the backdrop's) agrees with the other test rows of its column within
    10 % and with the answer key within 15 % (a thin surface reflects the white sky once, a cube twice), and
    deepens from column to column (by at least 8 %)."""
    scene = _scene("AttenuationTest")
    blocks = [m for m in scene.meshes if "_Block_" in m.name or "_Sample_" in m.name]
    for mesh in blocks:  # the answer key's colours are the formula's
        material = scene.materials[mesh.material]
        if "_Sample_" in mesh.name:
            size = float(np.ptp(mesh.triangles().positions[:, 0]))
            key = scene.materials["AttenuationTest/R2_and_R4_ThicknessFac_1.0"]
            want = np.asarray(key.attenuation_color) ** (size / key.attenuation_distance)
            np.testing.assert_allclose(material.base_color, want, rtol=1e-5, err_msg=mesh.name)
    scene = _framed(scene, *_bounds(*blocks), 320, 280, margin=1.02)
    for name, image in _renders(scene, gl_ctx, spp=32).items():
        backdrop = np.median(image[..., 1]) / np.median(image[..., 2])
        chroma: dict[str, dict[float, float]] = {}
        for mesh in blocks:
            for lo, hi in _island_bounds(mesh.triangles()):
                pixels = image[_box(scene.camera, lo, hi, inset=0.2)].reshape(-1, 3)
                row = chroma.setdefault(mesh.name.split("/")[1][:2], {})  # R1 … R5, the model's rows
                row[round(float(lo[0] + hi[0]) / 2, 1)] = float(np.median(pixels[:, 1]) / np.median(pixels[:, 2]) / backdrop)
        columns = sorted(chroma["R1"])
        assert len(columns) == 5 and all(sorted(row) == columns for row in chroma.values()), chroma
        key = np.array([chroma["R1"][c] for c in columns])
        tests = np.array([[chroma[r][c] for c in columns] for r in ("R2", "R3", "R4", "R5")])
        assert np.all(np.abs(tests / np.median(tests, axis=0) - 1) < 0.1), (name, tests.round(3))
        assert np.all(np.abs(tests / key - 1) < 0.15), (name, key.round(3), tests.round(3))
        assert np.all(np.diff(tests, axis=1) < -0.08 * tests[:, 1:]) and np.all(np.diff(key) < 0), (name, tests.round(3))


def _without(scene, meshes):
    """``scene`` without ``meshes``."""
    return dataclasses.replace(scene, meshes=tuple(m for m in scene.meshes if m not in meshes))


@pytest.mark.slow
@pytest.mark.parametrize("renderer", ["reference", "progressive"])
def test_transmission_roughness_test_blurs_with_ior_and_not_at_ior_1(gl_ctx, renderer):
    """TransmissionRoughnessTest: tiles of transmissive material, roughness growing to the right (the
    metallic-roughness map's G), IOR growing upwards (one mesh per IOR, 1.0 at the bottom). "With IOR = 1.0,
    light vectors do not change regardless of how strong the microfacet angles become": that row is sharp
    at every roughness, as is the smooth left column at every IOR; and in the second column "each higher tile
    shows a blurrier transmission". Sharpness: the tile's correlation with the backdrop rendered without the
    tiles (a blurred backdrop correlates less). The smooth column is held to it up to IOR 1.5: above, the
    tile's own reflection (F0 17 % at IOR 2.42) and its refraction's magnification make it unlike the backdrop
    without any blur (the reference's smooth tiles: 0.97, 0.90, 0.91, 0.79, 0.72 from IOR 1.0 to 2.42)."""
    scene = _scene("TransmissionRoughnessTest")
    rows = [_part(scene, f"IOR_{n}") for n in ("1.0", "1.33", "1.50", "1.76", "2.42")]
    scene = _framed(scene, *_bounds(*rows), 320, 176, margin=1.02)
    render = (lambda s: _reference(s, 128)) if renderer == "reference" else (lambda s: _raster(s, gl_ctx, 16))
    image, bare = render(scene), render(_without(scene, rows))
    sharp = np.array([[_ncc(image[box].mean(-1), bare[box].mean(-1)) for box in
                       (_box(scene.camera, lo, hi, inset=0.12)
                        for lo, hi in sorted(_island_bounds(row.triangles()), key=lambda b: b[0][0]))]
                      for row in rows])
    assert sharp.shape == (5, 9)
    assert np.all(sharp[0] > 0.9), sharp.round(2)  # IOR 1.0: sharp at every roughness
    assert np.all(sharp[:3, 0] > 0.85), sharp.round(2)  # smooth: sharp up to IOR 1.5
    second = sharp[:, 1]
    assert np.all(np.diff(second) < 0.03) and second[-1] < second[0] - 0.2, second.round(2)


@pytest.mark.slow
@pytest.mark.parametrize("renderer", ["reference", "progressive"])
def test_transmission_test_transmits_where_the_surface_is_not_metal(gl_ctx, renderer):
    """TransmissionTest: "different combinations of uniform transmission and textured transmission and how
    they should render in conjunction with opacity (baseColor.a) and surface roughness/metalicity". What
    shows through a sphere is measured by removing the back wall behind the spheres: the change inside each
    sphere, over its brightness. The smooth and the rough transmissive spheres and the masked ones (holes)
    show the wall (change > 0.5); glTF's transmission is the dielectric part's only, so the metallic row,
    whose metallic map is 1 on half of its stripes and 0 on the others, shows it through its dielectric
    stripes only: more than 0.05 and less than 0.85 times as much as the same colour in the transmissive row
    (the change over the sphere's brightness, which its metal stripes' reflection raises: measured 0.17 and
    0.08 in the reference, 0.24 and 0.30 in the rasterizer; a reader that takes the metallic factor for the
    map's gives 0.01)."""
    scene = _scene("TransmissionTest")
    spheres = [m for m in scene.meshes if "Label" not in m.name and "Backdrop" not in m.name]
    assert len(spheres) == 12
    scene = _framed(scene, *_bounds(*spheres), 160, 120)
    wall = _part(scene, "Cloth Backdrop 01")
    tri = wall.params["triangles"]
    behind = np.all(wall.triangles().positions[wall.triangles().indices][..., 2] < -0.15, axis=1)
    front = dataclasses.replace(wall, params={**wall.params, "triangles": dataclasses.replace(tri, indices=tri.indices[~behind])})
    open_back = dataclasses.replace(scene, meshes=tuple(front if m is wall else m for m in scene.meshes))
    render = (lambda s: _reference(s, 16)) if renderer == "reference" else (lambda s: _raster(s, gl_ctx, 8))
    image, without = render(scene), render(open_back)
    shows = {}
    for mesh in spheres:
        box = _box(scene.camera, *_bounds(mesh), inset=0.25)
        shows[mesh.name.split("/")[1]] = float(np.abs(image[box] - without[box]).mean() / image[box].mean())
    for name in ("YellowTrans", "YellowTransRough", "GreenMask", "GreenMaskRough", "GreenMaskMetal"):
        assert shows[name] > 0.5, (name, shows)
    for metal, glass in (("YellowTransMetal", "YellowTrans"), ("RedTransTextureMetal", "RedTransTexture")):
        assert 0.05 < shows[metal] / shows[glass] < 0.85, (metal, shows)


@pytest.mark.slow
def test_dispersion_test_fringes_grow_with_dispersion_and_need_an_ior_above_1():
    """DispersionTest (KHR_materials_dispersion on prisms before a checkered cloth): dispersion "changes the
    effective IOR values for different frequencies of light, producing ... chromatic aberration", and "scales
    with IOR": at IOR 1 it does nothing. The colour fringes (mean |R − B| over mean G in a prism, after a 3 × 3
    box filter) of the IOR 1.5 prisms grow with the dispersion (0, 0.5, 5), and the IOR 1.0 prism of
    dispersion 5 shows only the noise of the reference's per-channel sampling (under half the IOR 1.5 one's).
    Each prism is rendered alone in its own frame at 512 samples per pixel (that noise is strong)."""
    from scipy.ndimage import uniform_filter

    scene = _scene("DispersionTest")
    fringes = {}
    for name in ("Prism_IOR1.50_D1", "Prism_IOR1.50_D2", "Prism_IOR1.50_D5", "Prism_IOR1.0_D5"):
        prism = _part(scene, name)
        material = scene.materials[prism.material]
        framed = _framed(scene, *_bounds(prism), 40, 28, margin=1.0)
        pixels = _reference(framed, 512)[_box(framed.camera, *_bounds(prism), inset=0.08)]
        smooth = np.stack([uniform_filter(pixels[..., c], 3) for c in range(3)], -1)
        fringes[(material.ior, material.dispersion)] = float(np.abs(smooth[..., 0] - smooth[..., 2]).mean() / smooth[..., 1].mean())
    ior = float(np.float32(1.5))
    none, some, most = fringes[(ior, 0.0)], fringes[(ior, 0.5)], fringes[(ior, 5.0)]
    assert none < 0.1 and none < some < most and some < 0.8 * most, fringes
    assert fringes[(1.0, 5.0)] < 0.5 * most, fringes


# ----------------------------------------------------------------------------- anisotropy

def _studio(scene):
    """``scene`` under the procedural studio (three soft boxes in a dim room): highlights to stretch."""
    params = validate_procedural("studio", {"width": 256})
    return dataclasses.replace(scene, environment=Environment(procedural="studio", parameters=tuple(sorted(params.items()))))


def _alone(scene, mesh, width: int, height: int, spp: int = 64) -> np.ndarray:
    """The reference's image of ``mesh`` alone, framed by itself (every mesh seen the same way, with the same
    samples)."""
    framed = dataclasses.replace(_framed(scene, *_bounds(mesh), width, height), meshes=(mesh,))
    return _reference(framed, spp)


def _differ(a, b) -> float:
    return float(np.abs(a - b).mean() / (0.5 * (a.mean() + b.mean())))


def test_anisotropy_strength_test_does_nothing_at_roughness_1_and_most_at_roughness_0():
    """AnisotropyStrengthTest: spheres of roughness 0 to 1 (columns) and anisotropy strength 0 to 1 (rows);
    "the effects should be most apparent in the column with zero material roughness, and anisotropy should
    not offer any effect when material roughness is 1.0" (the extension's α_t = mix(α, 1, s²) is α when
    α = 1). Each sphere alone, seen the same way under a studio's soft boxes: at roughness 1 strengths 0.5 and
    1 look as strength 0 (within 1 %: the same samples meet the same lobe), at roughness 0 strength 1 changes
    the sphere entirely, and more than at roughness 0.5 (the reference; the rasterizer leaves anisotropy out)."""
    scene = _studio(_scene("AnisotropyStrengthTest"))
    column = {}
    for mesh in scene.meshes:
        material = scene.materials[mesh.material]
        if "Label" not in mesh.name and material.anisotropy_strength in (0.0, 0.5, 1.0):
            column[(material.roughness, material.anisotropy_strength)] = mesh
    assert len(column) == 21
    image = {key: _alone(scene, column[key], 32, 32) for key in ((1.0, 0.0), (1.0, 0.5), (1.0, 1.0), (0.0, 0.0),
                                                                 (0.0, 1.0), (0.5, 0.0), (0.5, 1.0))}
    rough = [_differ(image[1.0, 0.0], image[1.0, s]) for s in (0.5, 1.0)]
    assert max(rough) < 0.01, rough
    smooth, middle = _differ(image[0.0, 0.0], image[0.0, 1.0]), _differ(image[0.5, 0.0], image[0.5, 1.0])
    assert smooth > 0.5 and smooth > middle > 0.05, (smooth, middle)


def test_anisotropy_rotation_test_rotated_tangents_look_as_their_neighbours():
    """AnisotropyRotationTest: bands whose TANGENT is tilted 30° clockwise and turned back by
    anisotropyRotation, by the anisotropyTexture's direction, or by both (10° + 20°): "when the rotation is
    applied correctly, the anisotropy here should look the same as the neighboring meshes" (plain tangents).
    Each band alone, seen the same way under a studio's soft boxes, with the same samples: each turned-back
    band differs from a plain one less than 0.4 times as much as the tilt left uncorrected does (the band
    with its anisotropyRotation set to 0). The band of grooves in a normal map ("will not look exactly the
    same") is left out."""
    scene = _studio(_scene("AnisotropyRotationTest"))
    plain = _part(scene, "Band 1L")
    assert scene.materials[plain.material].anisotropy_rotation == 0.0
    reference = _alone(scene, plain, 48, 24)
    tilted = dataclasses.replace(scene.materials[_part(scene, "Band 2L").material], anisotropy_rotation=0.0)
    uncorrected = dataclasses.replace(scene, materials={**scene.materials, tilted.name: tilted})
    wrong = _differ(reference, _alone(uncorrected, _part(uncorrected, "Band 2L"), 48, 24))
    for band in ("Band 2L", "Band 4L", "Band 2R"):  # rotation; texture; rotation and texture
        turned = _differ(reference, _alone(scene, _part(scene, band), 48, 24))
        assert turned < 0.4 * wrong, (band, turned, wrong)


# ----------------------------------------------------------------------------- texture transforms on every map

@pytest.mark.slow
@pytest.mark.npm("mikktspace")  # the normal maps have no TANGENT
def test_texture_transform_multi_test_rows_look_like_their_sample(gl_ctx):
    """TextureTransformMultiTest: "an implementation should render rows of checkmarks, where each of the three
    tiles in a row look virtually identical": the "UV 0" and "UV 1" tiles (TEXCOORD_0 and TEXCOORD_1, each
    transformed by KHR_texture_transform) against the "Sample" tile (no transform); a transform not applied
    shows a crossed-out circle. Rows base colour, emission, normal, metal/rough and unlit: each test tile
    correlates with its sample (> 0.75) in both renderers; occlusion in the rasterizer (the reference computes
    its own occlusion and leaves the map out: "may appear blank in path tracers ... a pass"). The clearcoat
    rows are left out: under the uniform sky their checks are too faint to measure (the README: "dark and
    low-contrast"; correlation 0.2-0.6)."""
    scene = _scene("TextureTransformMultiTest")
    rows = ["BaseColor", "Emission", "Normal", "MetalRough", "Occlusion", "Unlit"]
    tiles = {(r, c): _part(scene, f"{r}{c}") for r in rows for c in ("UV0", "UV1", "Sample")}
    for (r, c), mesh in tiles.items():
        sampling = [scene.materials[mesh.material].sampling(n) for n in scene.materials[mesh.material].map_names()]
        assert all(s.has_uv_transform for s in sampling) == (c != "Sample"), (r, c, sampling)
        assert any(s.texcoord == 1 for s in sampling) == (c == "UV1"), (r, c, sampling)
    scene = _framed(scene, *_bounds(*tiles.values()), 72, 160, margin=1.02)
    for name, image in _renders(scene, gl_ctx, spp=32).items():
        for r in rows:
            if r == "Occlusion" and name == "reference":
                continue
            for c in ("UV0", "UV1"):
                got, want = _alike(image, _box(scene.camera, *_bounds(tiles[r, c]), inset=0.06),
                                   _box(scene.camera, *_bounds(tiles[r, "Sample"]), inset=0.06))
                score = _ncc(got.mean(-1), want.mean(-1), shift=1)
                assert score > 0.75, (name, r, c, score)
