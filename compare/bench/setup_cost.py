"""Set-up seconds and peak memory per renderer, and how they grow with triangles and texels.

Two ``compare bench`` items:

``setup-seconds``
    the seconds from the start of a render until its first image can be drawn: loading the scene
    (glTF decoding, maps) plus the renderer's own set-up (:attr:`Rendering.setup_seconds`), median of
    ``--repeats`` warm runs (the decoded-file and image caches filled by a first run).
``setup-rss``
    the peak resident memory (MiB) of the same run: of its own process (``VmHWM``), or of the largest
    process it started and waited for (Blender's) where that is larger. The browser of the web engines is
    not waited for by this process (Playwright's driver starts it), so their figure is the Python side.

Each is measured per available renderer, each run in a process of its own, on the built-in car, on a
generated interior shaped as a downloaded one (:func:`interior_scene`: 178k triangles in a few hundred
meshes, 40-odd materials, six maps, a sky with a sun, point lights and an area light) and on a generated
scene at 1×, 4× and 16× (:func:`scaled_scene`: 62,500 triangles and one 4096² map per ×, so 16× is a
million triangles and sixteen 4096² maps). A scaled figure's ratio is the growth, 4× or 16× over 1×: 4 and
16 are linear, less is a fixed cost that the scene does not grow; the interior's is over the car. Every
variant (:func:`setup_specs`) is measured on the car (its ratio: over its renderer's defaults) and the
interior. Each run renders two steps: the note gives the second's seconds, where the rasterizer bakes its
irradiance volume (the first image, a forward-shaded frame, reads none of it).
"""

from __future__ import annotations

import io
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

from compare.util.figures import Figure, median

__all__ = ["INTERIOR_TRIANGLES", "SCALES", "bench_setup", "interior_scene", "probe", "scaled_scene", "setup_specs"]

#: The generated scene's sizes, and what one × holds.
SCALES = (1, 4, 16)
TRIANGLES_PER_SCALE = 62_500
MAP_SIZE = 4096


def _map(seed: int, size: int) -> bytes:
    """A size² JPEG base-colour map: a checker over a colour ramp, different per seed."""
    from PIL import Image

    y, x = np.mgrid[0:size, 0:size].astype(np.float32) / size
    check = ((np.floor(x * 32) + np.floor(y * 32)) % 2).astype(np.float32)
    hue = (seed * 0.618) % 1.0
    rgb = np.stack([0.3 + 0.5 * x, 0.3 + 0.4 * ((y + hue) % 1.0), 0.3 + 0.5 * (1 - x)], axis=-1)
    rgb = rgb * (0.6 + 0.4 * check[..., None])
    buf = io.BytesIO()
    Image.fromarray((rgb * 255).astype(np.uint8)).save(buf, format="JPEG", quality=90)
    return buf.getvalue()


def scaled_scene(scale: int, folder: Path, *, triangles: int = TRIANGLES_PER_SCALE, map_size: int = MAP_SIZE) -> Path:
    """The generated scene at ``scale`` × (a GLB and a TOML around it) in ``folder``, written once: ``scale``
    spheres of ``triangles`` triangles, each with its own ``map_size``² base-colour map."""
    from compare.scene import geometry
    from compare.scene.gltf_write import GltfWriter
    from compare.util.files import write_bytes_atomic, write_text_atomic

    stem = f"scaled-{scale}x-{triangles}-{map_size}"
    toml = folder / f"{stem}.toml"
    if toml.is_file():
        return toml
    w = GltfWriter(generator="compare bench setup-seconds")
    # a UV sphere of about `triangles` triangles (2 · segments · rings, segments = 2 · rings)
    rings = max(2, round(np.sqrt(triangles / 4)))
    segments = max(3, round(triangles / (2 * rings)))
    side = int(np.ceil(np.sqrt(scale)))
    for k in range(scale):
        mesh = geometry.sphere(1.0, segments, rings)
        mat = w.material(f"m{k}", (1.0, 1.0, 1.0), 0.0, 0.5)
        w.doc["materials"][mat]["pbrMetallicRoughness"]["baseColorTexture"] = w.texture(_map(k, map_size), "image/jpeg")
        translation = [2.5 * (k % side), 1.0, 2.5 * (k // side)]
        w.node(f"sphere {k}", mesh=w.mesh(f"sphere {k}", [(mesh, mat)], uvs=True), translation=translation)
    write_bytes_atomic(folder / f"{stem}.glb", w.glb())
    write_text_atomic(toml, f"""name = "generated, {scale}x"
[[include]]
file = "{stem}.glb"

[camera]
target = "auto"
orbit = {{ theta = 30, phi = 60 }}

[environment]
constant = [1.0, 1.0, 1.0]
""")
    return toml


#: The generated interior's triangles: a downloaded furnished apartment's (a Sketchfab model of 178k).
INTERIOR_TRIANGLES = 178_000


def _normal_map(seed: int, size: int) -> bytes:
    """A size² PNG tangent-space normal map: gentle bumps, different per seed."""
    from PIL import Image

    y, x = np.mgrid[0:size, 0:size].astype(np.float32) * (2 * np.pi * (4 + seed % 5) / size)
    nx, ny = 0.15 * np.cos(x) * np.sin(y), 0.15 * np.sin(x) * np.cos(y)
    n = np.stack([nx, ny, np.ones_like(nx)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    buf = io.BytesIO()
    Image.fromarray(((n * 0.5 + 0.5) * 255).astype(np.uint8)).save(buf, format="PNG")
    return buf.getvalue()


def _with_tangents(mesh):
    """``mesh`` with glTF TANGENTs from its UVs (per-triangle dp/du summed per vertex): its normal maps need
    no MikkTSpace tool to read the file, as a downloaded file that carries its tangents."""
    import dataclasses

    p, uv, idx = mesh.positions.astype(np.float64), mesh.uvs.astype(np.float64), mesh.indices
    e1, e2 = p[idx[:, 1]] - p[idx[:, 0]], p[idx[:, 2]] - p[idx[:, 0]]
    d1, d2 = uv[idx[:, 1]] - uv[idx[:, 0]], uv[idx[:, 2]] - uv[idx[:, 0]]
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    r = np.where(np.abs(det) > 1e-12, 1.0 / np.where(det == 0, 1.0, det), 0.0)[:, None]
    t_face, b_face = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) * r, (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) * r
    t, b = np.zeros_like(p), np.zeros_like(p)
    for k in range(3):
        np.add.at(t, idx[:, k], t_face)
        np.add.at(b, idx[:, k], b_face)
    n = mesh.normals.astype(np.float64)
    t -= n * np.sum(n * t, axis=1, keepdims=True)
    t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-12)
    sign = np.where(np.sum(np.cross(n, t) * b, axis=1) < 0, -1.0, 1.0)[:, None]
    return dataclasses.replace(mesh, tangents=np.concatenate([t, sign], axis=1).astype(np.float32))


def _interior_glb(triangles: int) -> bytes:
    """The GLB of :func:`interior_scene`: a furnished three-room apartment (12 × 8 × 2.7 m) of about
    ``triangles`` triangles over many meshes and materials, as a downloaded interior is made."""
    from compare.scene import geometry
    from compare.scene.gltf_write import GltfWriter

    rng = np.random.default_rng(44)
    w = GltfWriter(generator="compare bench setup-seconds (interior)")
    mats: dict[str, int] = {}

    def mat(name, color, metallic=0.0, roughness=0.6, *, base_map=None, normal_map=None, scale=None,
            emission=(0.0, 0.0, 0.0)):
        k = w.material(name, color, metallic, roughness, emission=emission)
        m = w.doc["materials"][k]
        if base_map is not None:
            m["pbrMetallicRoughness"]["baseColorTexture"] = w.texture(base_map, "image/jpeg", scale=scale)
        if normal_map is not None:
            m["normalTexture"] = w.texture(normal_map, "image/png", scale=scale)
        mats[name] = k
        return k

    # A few maps, as downloads carry them: two 2048² and two 1024² colour maps, two normal maps.
    mat("floor_wood", (1, 1, 1), 0.0, 0.45, base_map=_map(1, 2048), normal_map=_normal_map(1, 1024), scale=(6, 4))
    mat("tile", (1, 1, 1), 0.0, 0.2, base_map=_map(2, 1024), normal_map=_normal_map(2, 512), scale=(8, 8))
    mat("rug", (1, 1, 1), 0.0, 0.9, base_map=_map(3, 2048))
    mat("fabric", (1, 1, 1), 0.0, 0.85, base_map=_map(4, 1024), scale=(3, 3))
    for k, c in enumerate([(0.75, 0.72, 0.66), (0.62, 0.68, 0.70), (0.80, 0.78, 0.74)]):
        mat(f"wall_paint_{k}", c, 0.0, 0.9)
    mat("ceiling", (0.82, 0.82, 0.80), 0.0, 1.0)
    for k in range(6):
        mat(f"upholstery_{k}", tuple(rng.uniform(0.05, 0.6, 3)), 0.0, float(rng.uniform(0.6, 0.95)))
    for k in range(4):
        mat(f"wood_{k}", tuple(np.array([0.45, 0.28, 0.15]) * rng.uniform(0.4, 1.2)), 0.0, float(rng.uniform(0.3, 0.7)))
    for k, c in enumerate([(0.9, 0.9, 0.9), (0.95, 0.75, 0.4), (0.2, 0.2, 0.2)]):
        mat(f"metal_{k}", c, 1.0, 0.15 + 0.2 * k)
    for k in range(4):
        mat(f"plastic_{k}", tuple(rng.uniform(0.05, 0.9, 3)), 0.0, 0.35)
    for k in range(3):
        mat(f"ceramic_{k}", tuple(rng.uniform(0.5, 0.95, 3)), 0.0, 0.1)
    for k in range(3):
        mat(f"leaf_{k}", (0.05 + 0.05 * k, 0.25 + 0.08 * k, 0.06), 0.0, 0.7)
    for k in range(8):
        mat(f"book_{k}", tuple(rng.uniform(0.05, 0.7, 3)), 0.0, 0.6)
    mat("lamp_shade", (0.9, 0.85, 0.7), 0.0, 0.8, emission=(2.0, 1.8, 1.4))
    mat("counter_stone", (0.12, 0.12, 0.13), 0.0, 0.15)

    count = [0]

    def put(name, parts, matrix):
        """One node of one mesh: (TriangleMesh, material name) parts in the node's own frame."""
        count[0] += sum(m.triangle_count for m, _ in parts)
        w.node(name, mesh=w.mesh(name, [(m, mats[n]) for m, n in parts], uvs=True), matrix=matrix)

    def at(x, y, z, rotate_y=0.0, scale=(1.0, 1.0, 1.0)):
        return geometry.transform_matrix((x, y, z), (0.0, rotate_y, 0.0), scale)

    def moved(mesh, x, y, z, scale=(1.0, 1.0, 1.0)):
        return mesh.transformed(geometry.transform_matrix((x, y, z), (0, 0, 0), scale))

    H, T = 2.7, 0.15  # ceiling height, wall thickness
    # Shell: floor, ceiling, outer walls with window openings, inner walls with door openings.
    put("floor", [(_with_tangents(geometry.box((12.0, 0.1, 8.0))), "floor_wood")], at(6.0, -0.05, 4.0))
    put("ceiling", [(geometry.box((12.0, 0.1, 8.0)), "ceiling")], at(6.0, H + 0.05, 4.0))

    def wall(name, length, openings, paint, *, sill=0.9, top=2.1):
        """A wall along its +x from 0 to ``length``: full-height pieces between ``openings`` [(x0, x1)],
        a sill below and a lintel above each (a door: sill 0)."""
        parts, x = [], 0.0
        for x0, x1 in [*openings, (length, length)]:
            if x0 > x:
                parts.append((moved(geometry.box((x0 - x, H, T)), (x + x0) / 2, H / 2, 0), paint))
            if x1 > x0:
                if sill > 0:
                    parts.append((moved(geometry.box((x1 - x0, sill, T)), (x0 + x1) / 2, sill / 2, 0), paint))
                parts.append((moved(geometry.box((x1 - x0, H - top, T)), (x0 + x1) / 2, (H + top) / 2, 0), paint))
            x = x1
        return parts

    put("wall south", wall("south", 12.0, [(1.0, 3.0), (6.0, 7.5), (9.8, 11.2)], "wall_paint_0"), at(0, 0, 0))
    put("wall north", wall("north", 12.0, [(2.0, 3.6), (7.0, 8.2)], "wall_paint_0"), at(12.0, 0, 8.0, 180.0))
    put("wall west", wall("west", 8.0, [(3.0, 5.0)], "wall_paint_1"), at(0, 0, 8.0, 90.0))
    put("wall east", wall("east", 8.0, [(2.5, 4.0)], "wall_paint_2"), at(12.0, 0, 0, -90.0))
    put("wall living|kitchen", wall("", 8.0, [(5.0, 6.0)], "wall_paint_1", sill=0.0), at(5.0, 0, 8.0, 90.0))
    put("wall kitchen|bedroom", wall("", 8.0, [(1.5, 2.5)], "wall_paint_2", sill=0.0), at(9.0, 0, 8.0, 90.0))
    put("rug", [(geometry.box((3.0, 0.01, 2.0)), "rug")], at(2.5, 0.005, 4.5))

    def sofa(name, x, z, ry, upholstery):
        seat = moved(geometry.box((2.0, 0.45, 0.9)), 0, 0.25, 0)
        back = moved(geometry.box((2.0, 0.5, 0.2)), 0, 0.7, -0.35)
        arms = [moved(geometry.box((0.2, 0.6, 0.9)), s * 1.0, 0.3, 0) for s in (-1, 1)]
        cushions = [moved(geometry.sphere(0.22, 48, 24), cx, 0.62, -0.15, (1.0, 0.45, 0.8)) for cx in (-0.6, 0.0, 0.6)]
        legs = [moved(geometry.cylinder(0.03, 0.05, 24), sx * 0.9, 0.025, sz * 0.4) for sx in (-1, 1) for sz in (-1, 1)]
        put(name, [(seat, upholstery), (back, upholstery), *[(a, upholstery) for a in arms],
                   *[(c, "fabric") for c in cushions], *[(g, "metal_2") for g in legs]], at(x, 0, z, ry))

    def table(name, x, z, size, wood, *, height=0.75, legs_segments=32):
        top = moved(geometry.box((size[0], 0.04, size[1])), 0, height, 0)
        legs = [moved(geometry.cylinder(0.03, height, legs_segments), sx * (size[0] / 2 - 0.08), height / 2,
                      sz * (size[1] / 2 - 0.08)) for sx in (-1, 1) for sz in (-1, 1)]
        put(name, [(top, wood), *[(g, wood) for g in legs]], at(x, 0, z))

    def chair(name, x, z, ry, wood, upholstery):
        seat = moved(geometry.box((0.45, 0.05, 0.45)), 0, 0.45, 0)
        back = moved(geometry.box((0.45, 0.45, 0.04)), 0, 0.7, -0.2)
        pad = moved(geometry.sphere(0.2, 32, 16), 0, 0.48, 0, (1.0, 0.12, 1.0))
        legs = [moved(geometry.cylinder(0.02, 0.45, 16), sx * 0.19, 0.225, sz * 0.19) for sx in (-1, 1) for sz in (-1, 1)]
        put(name, [(seat, wood), (back, wood), (pad, upholstery), *[(g, wood) for g in legs]], at(x, 0, z, ry))

    def lamp(name, x, z, height=1.5):
        put(name, [(moved(geometry.cylinder(0.15, 0.03, 48), 0, 0.015, 0), "metal_1"),
                   (moved(geometry.cylinder(0.015, height, 24), 0, height / 2, 0), "metal_1"),
                   (moved(geometry.sphere(0.2, 64, 32), 0, height + 0.1, 0, (1.0, 0.7, 1.0)), "lamp_shade")],
            at(x, 0, z))

    def plant(name, x, z, leaves):
        parts = [(moved(geometry.cylinder(0.18, 0.35, 48), 0, 0.175, 0), "ceramic_0")]
        for k in range(leaves):
            a, r = rng.uniform(0, 2 * np.pi), rng.uniform(0.0, 0.25)
            parts.append((moved(geometry.sphere(float(rng.uniform(0.06, 0.12)), 24, 12), r * np.cos(a),
                                float(rng.uniform(0.45, 1.2)), r * np.sin(a), (1.0, 0.35, 1.6)), f"leaf_{k % 3}"))
        put(name, parts, at(x, 0, z))

    def shelf(name, x, z, ry, books):
        parts = [(moved(geometry.box((1.6, 0.03, 0.35)), 0, 0.4 * (k + 1), 0), "wood_2") for k in range(4)]
        parts += [(moved(geometry.box((0.03, 1.8, 0.35)), s * 0.8, 0.9, 0), "wood_2") for s in (-1, 1)]
        for k in range(books):
            row, bx = k % 4, -0.75 + (k // 4) * 1.5 / max(1, (books + 3) // 4)
            hgt = float(rng.uniform(0.2, 0.32))
            parts.append((moved(geometry.box((0.03, hgt, 0.22)), bx, 0.4 * (row + 1) + 0.015 + hgt / 2, 0),
                          f"book_{k % 8}"))
        put(name, parts, at(x, 0, z, ry))

    # Living room (x 0-5), kitchen and dining (x 5-9), bedroom (x 9-12).
    sofa("sofa", 2.5, 6.8, 180.0, "upholstery_0")
    sofa("armchair", 0.8, 4.5, 90.0, "upholstery_1")
    table("coffee table", 2.5, 4.6, (1.1, 0.6), "wood_0", height=0.4)
    table("dining table", 7.0, 5.0, (1.8, 0.9), "wood_1")
    for k, (cx, cz, ry) in enumerate([(6.4, 4.3, 0), (7.6, 4.3, 0), (6.4, 5.7, 180), (7.6, 5.7, 180)]):
        chair(f"dining chair {k}", cx, cz, ry, "wood_1", f"upholstery_{2 + k % 2}")
    put("kitchen counter", [(moved(geometry.box((3.6, 0.9, 0.6)), 0, 0.45, 0), "wood_3"),
                            (moved(geometry.box((3.7, 0.04, 0.65)), 0, 0.92, 0), "counter_stone"),
                            (_with_tangents(moved(geometry.box((3.6, 0.6, 0.02)), 0, 1.3, -0.3)), "tile")], at(7.0, 0, 0.45))
    for k in range(6):
        put(f"pot {k}", [(moved(geometry.cylinder(0.1, 0.12, 48), 0, 0.06, 0), f"metal_{k % 2}"),
                         (moved(geometry.cylinder(0.008, 0.2, 12), 0.15, 0.1, 0, (1, 1, 1)), "metal_2")],
            at(5.6 + 0.6 * k, 0.94, 0.4))
    put("bed", [(moved(geometry.box((1.6, 0.35, 2.0)), 0, 0.175, 0), "wood_2"),
                (moved(geometry.box((1.55, 0.2, 1.95)), 0, 0.45, 0), "fabric"),
                *[(moved(geometry.sphere(0.3, 48, 24), sx * 0.4, 0.6, -0.75, (1.0, 0.35, 0.6)), "upholstery_4")
                  for sx in (-1, 1)]], at(10.5, 0, 5.5))
    table("desk", 10.5, 1.2, (1.2, 0.6), "wood_0")
    chair("desk chair", 10.5, 1.8, 180, "wood_0", "upholstery_5")
    shelf("bookshelf living", 0.3, 2.0, 90.0, 60)
    shelf("bookshelf bedroom", 11.7, 3.5, -90.0, 40)
    for k, (lx, lz) in enumerate([(0.4, 0.4), (4.5, 6.8), (9.5, 7.4), (11.6, 7.4)]):
        lamp(f"floor lamp {k}", lx, lz)
    for k in range(12):  # ornaments on the shelves and tables: vases, bowls, figures
        put(f"vase {k}", [(geometry.sphere(0.06 + 0.01 * (k % 4), 64, 32), f"ceramic_{k % 3}")],
            at(float(rng.uniform(0.5, 11.5)), 0.8, float(rng.uniform(0.5, 7.5)), scale=(1.0, 1.6, 1.0)))
    # Plants fill the rest up to the triangle count (576 triangles a leaf): the bulk of a download's triangles
    # is in small detailed objects.
    spots = [(4.5, 0.5), (0.5, 7.5), (8.7, 7.5), (5.4, 7.5), (9.4, 0.5), (11.5, 0.5), (3.5, 0.5), (8.6, 2.5)]
    per_leaf = geometry.sphere(0.1, 24, 12).triangle_count
    left = max(0, triangles - count[0] - len(spots) * geometry.cylinder(0.18, 0.35, 48).triangle_count)
    leaves = left // per_leaf
    for k, (px, pz) in enumerate(spots):
        plant(f"plant {k}", px, pz, leaves // len(spots) + (1 if k < leaves % len(spots) else 0))
    # Ceiling lamps: the download's own punctual lights (KHR_lights_punctual), one per room.
    for k, (lx, lz) in enumerate([(2.5, 4.0), (7.0, 3.0), (10.5, 4.0)]):
        w.node(f"ceiling light {k}", light=w.light(f"ceiling light {k}", "point", 300.0, (1.0, 0.9, 0.75)),
               translation=(lx, H - 0.3, lz))
    return w.glb()


def interior_scene(folder: Path, *, triangles: int = INTERIOR_TRIANGLES) -> Path:
    """A generated furnished apartment shaped as a downloaded interior (a GLB and a TOML around it) in
    ``folder``, written once: three rooms behind walls with window and door openings, about ``triangles``
    triangles in a few hundred meshes, 40-odd materials, six maps and three point lights, under a sky
    with a sun that shines through the south windows, one ceiling panel in the kitchen, seen from inside
    at the living room's end."""
    from compare.util.files import write_bytes_atomic, write_text_atomic

    stem = f"interior-{triangles}"
    toml = folder / f"{stem}.toml"
    if toml.is_file():
        return toml
    write_bytes_atomic(folder / f"{stem}.glb", _interior_glb(triangles))
    write_text_atomic(toml, f"""name = "generated interior, {triangles} triangles"
[[include]]
file = "{stem}.glb"
prefix = ""

[camera]
position = [0.6, 1.6, 7.4]
target = [5.0, 1.0, 2.5]
fov = 65.0
resolution = [160, 120]

[[lights]]
name = "kitchen panel"
center = [7.0, 2.69, 2.0]
size = [0.6, 0.6]
normal = [0.0, -1.0, 0.0]
tangent = [1.0, 0.0, 0.0]
radiance = [20.0, 19.0, 17.0]

[environment]
procedural = "sky"
sun_elevation = 30.0
sun_azimuth = 20.0
""")
    return toml


_PROBE = r"""
import json, resource, sys, time, warnings
warnings.simplefilter("ignore")
start = time.perf_counter()
from compare.renderers import RenderContext
from compare.renderers.registry import Registry
from compare.report.results import RunSettings
from compare.scene.loader import load_scene
spec, path, width, height = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
imported = time.perf_counter()
scene = load_scene(path).with_resolution(width, height)
loaded = time.perf_counter()
renderer = Registry().get(spec)
with RenderContext(RunSettings(frames=2, spp=2), cache_dir=False) as context:
    # two steps: the first image, then the step after it, where work left out of the set-up lands
    rendering = renderer.render(renderer.prepare(scene)[0], steps=2, checkpoints=[1, 2], seed=0, context=context)
cps = rendering.checkpoints
second = cps[-1].seconds - cps[0].seconds if len(cps) > 1 else float("nan")
bake = rendering.metadata.get("probe_bake_seconds", 0.0)
# VmHWM, not ru_maxrss: Linux carries ru_maxrss over exec, so a child of a large parent would report the
# parent's size; the high-water mark of this process's own memory starts afresh at exec
own = next((int(line.split()[1]) for line in open("/proc/self/status") if line.startswith("VmHWM:")),
           resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
children = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
print(json.dumps({"import": imported - start, "load": loaded - imported, "setup": rendering.setup_seconds,
                  "second": second, "bake": bake,
                  "rss_mib": max(own, children) / 1024.0, "own_mib": own / 1024.0, "children_mib": children / 1024.0}))
"""


def probe(spec: str, scene: Path, size: tuple[int, int]) -> dict:
    """One render of two steps of ``scene`` by ``spec`` in a fresh process: its import, scene-load and
    set-up seconds, the seconds of its second step (``second``; with ``bake``, the irradiance volume's bake
    seconds, which the rasterizer spends there) and its peak RSS (MiB)."""
    out = subprocess.run([sys.executable, "-c", _PROBE, spec, str(scene), str(size[0]), str(size[1])],
                         capture_output=True, text=True, timeout=3600)
    if out.returncode != 0:
        tail = (out.stderr or out.stdout).strip().splitlines()[-1:] or ["no output"]
        raise RuntimeError(f"{spec} on {scene.name}: {tail[0][-300:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def setup_specs(registry) -> tuple[list[str], list[str]]:
    """(renderers, variants) of the set-up items: every available built-in renderer, and the variants of
    those whose set-up differs: each declared variant (:meth:`Registry.specs`) and, for the progressive
    rasterizer, every option word alone and its switches together
    (:func:`compare.progressive.options.setup_variants`)."""
    from compare.progressive.options import setup_variants

    renderers = [name for name in registry.builtins() if registry.get(name).available()[0]]
    variants = [spec for spec in registry.specs() if spec.partition(":")[0] in renderers and spec not in renderers]
    if "progressive" in renderers:
        variants += [v for v in setup_variants() if v not in renderers and v not in variants]
    return renderers, variants


def bench_setup(car: Path, folder: Path, *, size: tuple[int, int], repeats: int, renderers: list[str],
                variants: list[str] = (), progress=None, interior_triangles: int = INTERIOR_TRIANGLES,
                **scene_size) -> list[Figure]:
    """The ``setup-seconds`` and ``setup-rss`` figures of every renderer in ``renderers`` (on the car, the
    generated interior and the scaled scenes) and of every spec in ``variants`` (on the car and the
    interior); ``scene_size``: :func:`scaled_scene`'s ``triangles`` and ``map_size`` per ×."""
    interior = interior_scene(folder)
    scenes = {"car": car, "interior": interior, **{f"{s}x": scaled_scene(s, folder, **scene_size) for s in SCALES}}
    figures = []
    failed = []
    measured: dict[str, dict[str, list[dict]]] = {}
    for spec in [*renderers, *variants]:
        runs: dict[str, list[dict]] = {}
        try:
            for label, path in scenes.items():
                if spec not in renderers and label not in ("car", "interior"):
                    continue
                probe(spec, path, size)  # warm-up: fills the decoded-file and image caches
                runs[label] = [probe(spec, path, size) for _ in range(max(repeats, 1))]
                if progress:
                    progress(f"{spec} {label}")
        except RuntimeError as exc:  # one renderer's failure leaves the others' figures
            failed.append(str(exc))
            continue
        measured[spec] = runs
        seconds = {k: [r["load"] + r["setup"] for r in v] for k, v in runs.items()}
        rss = {k: [r["rss_mib"] for r in v] for k, v in runs.items()}

        def note(k):
            rs = runs[k]
            text = (f"scene load {median([r['load'] for r in rs]):.2f} s + set-up {median([r['setup'] for r in rs]):.2f} s; "
                    f"import {median([r['import'] for r in rs]):.2f} s; second step {median([r['second'] for r in rs]):.2f} s")
            bake = median([r.get("bake", 0.0) for r in rs])
            return text + (f" (of it the irradiance volume's bake {bake:.2f} s)" if bake > 0 else "")

        base = spec.partition(":")[0]
        if spec in renderers:
            ref, ref_runs = f"{spec} 1x", runs["1x"]
        elif base in measured:  # a variant against its renderer's defaults on the same scene
            ref, ref_runs = f"{base} car", measured[base]["car"]
        else:
            ref, ref_runs = f"{spec} car", runs["car"]
        ref_seconds = [r["load"] + r["setup"] for r in ref_runs]
        figures.append(Figure("setup-seconds", f"{spec} car", ref, median(seconds["car"]), median(ref_seconds),
                              "s", repeats, note("car"), seconds["car"], ref_seconds))
        figures.append(Figure("setup-rss", f"{spec} car", ref, median(rss["car"]),
                              median([r["rss_mib"] for r in ref_runs]), "MiB", repeats, "", rss["car"],
                              [r["rss_mib"] for r in ref_runs]))
        # the interior against the car: a downloaded interior's size and shape over the built-in scene's
        figures.append(Figure("setup-seconds", f"{spec} interior", f"{spec} car", median(seconds["interior"]),
                              median(seconds["car"]), "s", repeats, note("interior"), seconds["interior"],
                              seconds["car"]))
        figures.append(Figure("setup-rss", f"{spec} interior", f"{spec} car", median(rss["interior"]),
                              median(rss["car"]), "MiB", repeats, "", rss["interior"], rss["car"]))
        for s_ in SCALES[1:]:
            k = f"{s_}x"
            if k not in runs:
                continue
            figures.append(Figure("setup-seconds", f"{spec} {k}", f"{spec} 1x", median(seconds[k]),
                                  median(seconds["1x"]), "s", repeats, f"growth (linear: {s_}); {note(k)}",
                                  seconds[k], seconds["1x"]))
            figures.append(Figure("setup-rss", f"{spec} {k}", f"{spec} 1x", median(rss[k]), median(rss["1x"]),
                                  "MiB", repeats, f"growth (linear: {s_})", rss[k], rss["1x"]))
    if failed and not figures:
        raise RuntimeError("; ".join(failed))
    for why in failed:
        import warnings

        warnings.warn(f"setup-seconds: {why}", stacklevel=2)
    return figures
