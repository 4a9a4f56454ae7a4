"""What the test modules share: the checkout's paths, the optional components' checks, and the scenes,
helpers and stand-in renderers that more than one module uses.

Test modules import from here (``from tests.helpers import ...``), never from each other; conftest.py turns
the checks into markers (``@pytest.mark.bpy``, ``@pytest.mark.web``, ``@pytest.mark.npm("package")``): a test
so marked is skipped with the component's own reason where the component is missing.
"""

from __future__ import annotations

import contextlib
import functools
import io
import json
import math
import re
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from compare.mitsuba.reference import Checkpoint
from compare.renderers import doubling_steps
from compare.report.results import Results, RunSettings
from compare.run import runner as run_mod
from compare.scene.loader import load_scene, parse_scene

# ----------------------------------------------------------------------------- the checkout

#: The checkout (the tests also check the offline tools and the shipped scenes).
ROOT = Path(__file__).resolve().parent.parent
SCENES = ROOT / "scenes"
CORNELL = SCENES / "cornell.toml"
#: The generated closed-form scenes (scenes/generate.py).
EFFECTS = SCENES / "effects"
#: The npm packages of the web engines and the offline tools (``npm ci --prefix web``).
NODE_MODULES = ROOT / "web" / "node_modules"
#: Small environment preprocessing for tests: 16² cube faces and few GGX samples ...
FAST_IBL = {"ibl_size": 16, "ibl_levels": 5, "ibl_samples": 16}
#: ... or 32² ones, where a bound was measured with them.
SMALL_IBL = {"ibl_size": 32, "ibl_levels": 6, "ibl_samples": 32}

# ----------------------------------------------------------------------------- optional components
# Each check returns why the component is missing (its own message), or None where it is there.


@functools.cache
def bpy_missing() -> str | None:
    """Blender's Python module (the ``blender`` extra), for the Cycles and EEVEE renders."""
    from compare.blender.render import blender_available

    ok, why = blender_available()
    return None if ok else f"Blender renders need bpy: {why}"


@functools.cache
def web_missing() -> str | None:
    """The web engines (the registry's ``web`` group): Chromium, Playwright and their npm packages."""
    from compare.renderers.registry import Registry

    registry = Registry()
    for name in registry.groups()["web"]:
        ok, why = registry.get(name).available()
        if not ok:
            return f"web engines unavailable: {name}: {why}"
    return None


@functools.cache
def npm_missing(*packages: str) -> str | None:
    """Node.js and the npm ``packages`` in web/node_modules."""
    if shutil.which("node") is None:
        return f"the npm package {', '.join(packages)} needs Node.js, which is not installed (apt-get install nodejs)"
    for package in packages:
        if not (NODE_MODULES / package).is_dir():
            return (f"the npm package {package} is not in {NODE_MODULES} "
                    "(scripts/suite.sh setup, or npm ci --prefix web)")
    return None


#: Marker name → its check; the marker's arguments are the check's.
CAPABILITIES = {"bpy": bpy_missing, "web": web_missing, "npm": npm_missing}


def require(name: str, *args: str) -> None:
    """Skip the running test where the component of marker ``name`` is missing (for a test that finds out
    late that it needs one)."""
    why = CAPABILITIES[name](*args)
    if why:
        pytest.skip(why)


# ----------------------------------------------------------------------------- the Khronos glTF-Validator


def validate_gltf(files: list[Path]) -> dict[str, dict]:
    """The validator's report of each file (web/validate_gltf.mjs)."""
    done = subprocess.run(["node", str(ROOT / "web" / "validate_gltf.mjs"), *map(str, files)], capture_output=True,
                          text=True, timeout=600, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout)


# ----------------------------------------------------------------------------- a textured floor

#: The textured floor's light, and its map's quadrants (row, column: image top = +z, left = -x) and colours.
QUADRANT_LIGHT = """[[lights]]
        center = [0.0, 1.4, 0.3]
        size = [1.2, 1.2]
        normal = [0, -1, 0]
        radiance = [4, 4, 4]"""
QUADRANTS = {(0, 0): (230, 40, 40), (0, 1): (40, 200, 60), (1, 0): (50, 60, 220), (1, 1): (240, 230, 60)}


def quadrant_scene(tmp_path, material: str, *, light: bool = True, environment: bool = False, extra: str = ""):
    """A 2 x 2 floor quad (the map's quadrants: image top = +z, left = -x) beside a grey control quad,
    under one light, direct light only."""
    img = np.zeros((64, 64, 3), dtype=np.uint8)
    for (r, c), colour in QUADRANTS.items():
        img[32 * r:32 * r + 32, 32 * c:32 * c + 32] = colour
    Image.fromarray(img).save(tmp_path / "quadrants.png")
    mrmap = np.zeros((64, 64, 3), dtype=np.uint8)
    mrmap[:, :32] = (0, 255, 0)        # left half: rough dielectric
    mrmap[:, 32:] = (0, 204, 255)      # right half: metal of roughness 0.8
    Image.fromarray(mrmap).save(tmp_path / "mr.png")
    ao = np.zeros((64, 64, 3), dtype=np.uint8)
    ao[:, 32:] = 255                   # left half occluded, right half open
    Image.fromarray(ao).save(tmp_path / "ao.png")
    (tmp_path / "t.toml").write_text(textwrap.dedent(f'''
        [camera]
        position = [0.0, 2.2, 2.6]
        target = [0.2, 0.0, 0.0]
        fov = 45
        resolution = [80, 60]
        [materials.floor]
        {material}
        [materials.grey]
        base_color = [0.5, 0.5, 0.5]
        roughness = 1.0
        [[meshes]]
        name = "floor"
        shape = "quad"
        size = [2.0, 2.0]
        material = "floor"
        [[meshes]]
        name = "control"
        shape = "quad"
        size = [0.8, 0.8]
        material = "grey"
        translate = [1.6, 0.0, 0.0]
        {extra}
        {QUADRANT_LIGHT if light else ""}
        {"[environment]" if environment else ""}
        {"constant = [0.6, 0.6, 0.6]" if environment else ""}
        [render]
        max_depth = 2
        '''))
    return load_scene(tmp_path / "t.toml")


def quadrant_regions(scene) -> dict[str, np.ndarray]:
    """Pixels whose camera ray hits the floor well inside one quadrant (or the control quad)."""
    cam = scene.camera
    jj, ii = np.mgrid[0:cam.height, 0:cam.width]
    d = cam.ray_directions(ii + 0.5, jj + 0.5)
    o = np.asarray(cam.position)
    t = -o[1] / np.where(d[..., 1] < 0, d[..., 1], -1e-30)
    p = o + d * t[..., None]
    x, z = p[..., 0], p[..., 2]
    out = {}
    for (r, c) in QUADRANTS:
        xs = (x > -0.9) & (x < -0.1) if c == 0 else (x > 0.1) & (x < 0.9)
        zs = (z > 0.1) & (z < 0.9) if r == 0 else (z > -0.9) & (z < -0.1)
        out[f"quadrant {r}{c}"] = (t > 0) & xs & zs
    out["control"] = (t > 0) & (np.abs(x - 1.6) < 0.3) & (np.abs(z) < 0.3)
    return out


def tilt_scenes(tmp_path, degrees: float = 25.0, material: str = 'base_color = [0.8, 0.8, 0.8]\nroughness = 1.0'):
    """A Lambert square under a distant light, once flat with a constant normal map tilted by ``degrees``
    towards +Y (up the image), and as geometry: the square tilted that way (towards the image's top
    edge, +z) and the other way."""
    t = math.radians(degrees)
    c = np.array([0.0, math.sin(t), math.cos(t)])
    Image.fromarray(np.tile(np.round((c + 1) / 2 * 255).astype(np.uint8), (8, 8, 1))).save(tmp_path / "n.png")

    def scene(name, material, rotate):
        (tmp_path / f"{name}.toml").write_text(textwrap.dedent(f'''
            [camera]
            position = [0.0, 3.0, 3.0]
            target = [0.0, 0.0, 0.0]
            fov = 40
            resolution = [64, 48]
            [materials.m]
            {base}
            {material}
            [[meshes]]
            name = "square"
            shape = "quad"
            size = [1.5, 1.5]
            material = "m"
            rotate = [{rotate}, 0.0, 0.0]
            [[lights]]
            center = [0.0, 24.0, 12.0]
            size = [1.0, 1.0]
            normal = [0, -2, -1]
            radiance = [480, 480, 480]
            [render]
            max_depth = 2
            '''))
        return load_scene(tmp_path / f"{name}.toml")

    base = material.replace("\n", "\n            ")
    return (scene("mapped", 'normal_texture = "n.png"', 0.0), scene("tilted", "", degrees),
            scene("other", "", -degrees))


def tilt_ratio(a, b, *others):
    """Median per-pixel ratio a / b where every image shows the square."""
    both = (a[..., 0] > 0.02) & (b[..., 0] > 0.02)
    for o in others:
        both &= o[..., 0] > 0.02
    assert both.sum() > 100
    return float(np.median(a[both][:, 0] / b[both][:, 0]))


#: Texture transforms that move whole quadrants of the map (the floor's regions stay one colour each), with
#: the quadrant (row, column) of the map that region (r, c) then shows: glTF's rotation matrix
#: [[cos, sin], [-sin, cos]] takes (u, v) to (v, 1 - u) at 90 degrees (repeat wrap).
QUADRANT_MAPS = [
    ("texture_offset = [0.5, 0.0]", lambda r, c: (r, 1 - c)),
    ("texture_rotation = 90", lambda r, c: (1 - c, r)),
    ("texture_rotation = 180", lambda r, c: (1 - r, 1 - c)),
    ("texture_offset = [0.5, 0.5]\ntexture_scale = [-1.0, 1.0]", lambda r, c: (1 - r, c)),
]


# ----------------------------------------------------------------------------- an alpha-masked card

#: Quadrants of the card (image row, column) that are solid; the other two are holes.
CARD_SOLID = ((0, 1), (1, 0))
CARD_SIZE = 1.6


def card_png(path, *, alpha_solid: int = 255, alpha_hole: int = 0):
    """A 64 x 64 RGBA map: green where solid, magenta (never seen) in the holes."""
    img = np.zeros((64, 64, 4), dtype=np.uint8)
    img[...] = (220, 40, 220, alpha_hole)
    for r, c in CARD_SOLID:
        img[32 * r:32 * r + 32, 32 * c:32 * c + 32] = (60, 200, 70, alpha_solid)
    Image.fromarray(img, "RGBA").save(path)


CARD_LIGHT = """[[lights]]
        center = [0.1, 1.5, 0.1]
        size = [0.7, 0.7]
        normal = [0, -1, 0]
        radiance = [6, 6, 6]"""


def card_scene(folder, card: str, *, light: str = CARD_LIGHT, extra: str = ""):
    """A grey floor, and 0.6 above it ``card`` (TOML meshes), under one light above the card."""
    card_png(folder / "card.png")
    (folder / "t.toml").write_text(textwrap.dedent(f'''
        [camera]
        position = [0.0, 2.4, 2.3]
        target = [0.0, 0.2, 0.0]
        fov = 50
        resolution = [80, 60]
        [materials.grey]
        base_color = [0.6, 0.6, 0.6]
        roughness = 1.0
        [materials.leaf]
        base_color_texture = "card.png"
        roughness = 1.0
        alpha_mode = "mask"
        alpha_cutoff = 0.5
        [materials.green]
        base_color = [{(60 / 255) ** 2.2:.6f}, {(200 / 255) ** 2.2:.6f}, {(70 / 255) ** 2.2:.6f}]
        roughness = 1.0
        [materials.ghost]
        base_color = [0.9, 0.1, 0.1]
        alpha_mode = "mask"
        alpha = 0.4
        [[meshes]]
        name = "floor"
        shape = "quad"
        size = [4.0, 4.0]
        material = "grey"
        {card}
        {light}
        [render]
        max_depth = 2
        '''))
    return load_scene(folder / "t.toml")


CARD_MASKED = f'''[[meshes]]
        name = "card"
        shape = "quad"
        size = [{CARD_SIZE}, {CARD_SIZE}]
        material = "leaf"
        translate = [0.0, 0.6, 0.0]'''
# The card's solid quadrants as real geometry (image top = +z, left = -x on a quad).
CARD_GEOMETRY = "\n".join(f'''[[meshes]]
        name = "solid {r}{c}"
        shape = "quad"
        size = [{CARD_SIZE / 2}, {CARD_SIZE / 2}]
        material = "green"
        translate = [{(c - 0.5) * CARD_SIZE / 2}, 0.6, {(0.5 - r) * CARD_SIZE / 2}]''' for r, c in CARD_SOLID)


def card_regions(scene) -> dict[str, np.ndarray]:
    """Pixels whose ray crosses the card's plane well inside a solid quadrant ("card") or a hole
    ("through a hole": the floor seen through it), and pixels that see the floor beside the card."""
    cam = scene.camera
    jj, ii = np.mgrid[0:cam.height, 0:cam.width]
    d = cam.ray_directions(ii + 0.5, jj + 0.5)
    o = np.asarray(cam.position)
    t = (0.6 - o[1]) / np.where(d[..., 1] < 0, d[..., 1], -1e-30)
    p = o + d * t[..., None]
    x, z = p[..., 0], p[..., 2]
    h = CARD_SIZE / 2
    inner = (np.abs(x) > 0.1) & (np.abs(x) < h - 0.1) & (np.abs(z) > 0.1) & (np.abs(z) < h - 0.1) & (t > 0)
    solid = ((x > 0) & (z > 0)) | ((x < 0) & (z < 0))
    tf = -o[1] / np.where(d[..., 1] < 0, d[..., 1], -1e-30)
    pf = o + d * tf[..., None]
    beside = (np.abs(x) > h + 0.15) & (np.abs(pf[..., 0]) < 1.4) & (np.abs(pf[..., 2]) < 1.4) & (tf > 0)
    return {"card": inner & solid, "through a hole": inner & ~solid, "floor beside": beside}


# ----------------------------------------------------------------------------- cards seen face on

def facing_scene(include: str, *, distance: float = 2.0, fov: float = 40.0, size=(16, 16), sky: float = 1.0,
               extra: str = "") -> str:
    """A scene file's text: ``include`` seen face on from +Z at ``distance`` under a uniform sky of ``sky``."""
    return f"""
    include = "{include}"

    [camera]
    position = [0.0, 0.0, {distance}]
    target = [0.0, 0.0, 0.0]
    fov = {fov}
    resolution = [{size[0]}, {size[1]}]

    [environment]
    constant = [{sky}, {sky}, {sky}]
    """ + extra


# ----------------------------------------------------------------------------- a vertex-coloured card

COLORED_CARD_SCENE = facing_scene("plane.gltf")


def colored_card(folder, base=(0.8, 0.8, 0.8, 1.0), colors=None, *, accessor=None, alpha_mode=None):
    """A glTF card facing +Z (two triangles) whose vertices carry ``colors`` (4×3 or 4×4), written as
    ``accessor`` says: "float", "ubyte" or "ushort" (normalized)."""
    from compare.scene.gltf_write import GltfWriter

    w = GltfWriter()
    mat = w.material("card", base[:3], 0.0, 1.0)
    w.doc["materials"][mat]["pbrMetallicRoughness"]["baseColorFactor"] = list(base)
    if alpha_mode:
        w.doc["materials"][mat]["alphaMode"] = alpha_mode
    pos = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], dtype=np.float32)
    nrm = np.tile(np.array([[0, 0, 1]], dtype=np.float32), (4, 1))
    attrs = {"POSITION": w.accessor(pos, bounds=True), "NORMAL": w.accessor(nrm)}
    if colors is not None:
        c = np.asarray(colors, dtype=np.float32)
        if accessor in (None, "float"):
            attrs["COLOR_0"] = w.accessor(c)
        else:
            scale, dtype, ctype = (255, np.uint8, 5121) if accessor == "ubyte" else (65535, np.uint16, 5123)
            data = np.round(c * scale).astype(dtype)
            if accessor == "ubyte" and data.shape[1] == 3:  # a VEC3 of bytes: rows padded to 4 bytes
                data = np.concatenate([data, np.zeros((4, 1), dtype)], axis=1)
                stride = 4
            else:
                stride = None
            view = w.view(data.tobytes())
            if stride:
                w.doc["bufferViews"][view]["byteStride"] = stride
            attrs["COLOR_0"] = w._add("accessors", {  # noqa: SLF001
                "bufferView": view, "componentType": ctype, "normalized": True, "count": 4,
                "type": "VEC3" if c.shape[1] == 3 else "VEC4"})
    idx = w.accessor(np.array([[0, 1, 2], [0, 2, 3]], dtype=np.uint32), indices=True)
    w._add("meshes", {"name": "card", "primitives": [{"attributes": attrs, "indices": idx,  # noqa: SLF001
                                                      "material": mat}]})
    w.node("card", mesh=len(w.doc["meshes"]) - 1)
    return w.write(folder / "plane.gltf")


RED_CORNERS = [[1, 0, 0]] * 4


# ----------------------------------------------------------------------------- a model beside its own maps

def png_bytes(rgb: np.ndarray, mode: str = "RGB") -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(rgb, mode).save(buf, format="PNG")
    return buf.getvalue()


def coated_model(folder: Path) -> Path:
    """A .gltf beside its own maps (as a download unpacks): a card whose clearcoat and clearcoat
    roughness come from external PNGs, the last of them the extension's last map."""
    from compare.scene import geometry
    from compare.scene.gltf_write import GltfWriter

    stripes = np.zeros((4, 8, 3), dtype=np.uint8)
    stripes[:, 4:] = 255
    (folder / "CoatStrength.png").write_bytes(png_bytes(stripes))
    (folder / "RoughnessStripes.png").write_bytes(png_bytes(stripes[:, ::-1].copy()))
    w = GltfWriter()
    mat = w.material("card", (0.8, 0.2, 0.1), 0.0, 0.5)
    infos = []
    for uri in ("CoatStrength.png", "RoughnessStripes.png"):
        image = w._add("images", {"uri": uri})  # noqa: SLF001 - an external image, as downloads have
        infos.append({"index": w._add("textures", {"source": image})})  # noqa: SLF001
    w.doc["materials"][mat]["extensions"] = {"KHR_materials_clearcoat": {
        "clearcoatFactor": 1.0, "clearcoatTexture": infos[0],
        "clearcoatRoughnessFactor": 1.0, "clearcoatRoughnessTexture": infos[1]}}
    w._use("KHR_materials_clearcoat")  # noqa: SLF001
    w.node("card", mesh=w.mesh("card", [(geometry.quad((2.0, 2.0)), mat)], uvs=True),
           rotation=[np.sin(np.pi / 4), 0.0, 0.0, np.cos(np.pi / 4)])  # +Y normal turned to +Z
    return w.write(folder / "card.gltf")


COATED_SCENE = facing_scene("model/card.gltf", distance=3.0, fov=50.0, size=(24, 16), sky=0.5)

# ----------------------------------------------------------------------------- a single- or double-sided card

SIDES_ENV = 0.5


def sided_card(make_scene, tmp_path, *, double_sided, from_behind: bool):
    """A grey card (a glTF with doubleSided as given) facing +Z, seen from +Z or from behind, under a
    constant environment."""
    from compare.scene import geometry
    from compare.scene.gltf_write import GltfWriter

    w = GltfWriter()
    mat = w.material("card", (0.2, 0.2, 0.2), 0.0, 1.0)
    if double_sided is not None:
        w.doc["materials"][mat]["doubleSided"] = double_sided
    w.node("card", mesh=w.mesh("card", [(geometry.quad((1.0, 1.0)), mat)]),
           rotation=[np.sin(np.pi / 4), 0.0, 0.0, np.cos(np.pi / 4)])  # +Y normal turned to +Z
    w.write(tmp_path / "card.gltf")
    z = -2.0 if from_behind else 2.0
    return load_scene(make_scene(f"""
        include = "card.gltf"

        [camera]
        position = [0.0, 0.0, {z}]
        target = [0.0, 0.0, 0.0]
        fov = 30.0
        resolution = [16, 16]

        [environment]
        constant = [{SIDES_ENV}, {SIDES_ENV}, {SIDES_ENV}]
        """))


def centre_mean(image):
    """The mean of the 16 × 16 image's centre, where the card is."""
    return float(image[6:10, 6:10].mean())

# ----------------------------------------------------------------------------- one sphere of one material


def sphere_scene(make_scene, material: str, *, name: str = "glass", fov: float = 30.0, size: int = 24,
                 sky: float = 0.5, depth: int = 64, extra: str = "", file: str = "scene.toml",
                 environment: str | None = None):
    """A smooth sphere of radius 0.5 at the origin, of the material ``name`` (its TOML fields ``material``),
    seen from 3 m along +z in a ``fov``-degree view of ``size`` × ``size`` pixels under a constant sky of
    radiance ``sky`` (or the ``[environment]`` table's fields ``environment``), paths of at most ``depth``
    bounces; ``extra`` (TOML: more materials and meshes) goes with it into ``file``."""
    environment = environment or f"constant = [{sky}, {sky}, {sky}]"
    return load_scene(make_scene(f"""
        [camera]
        position = [0.0, 0.0, 3.0]
        target = [0.0, 0.0, 0.0]
        fov = {fov}
        resolution = [{size}, {size}]

        [render]
        max_depth = {depth}

        [materials.{name}]
        {material}

        [[meshes]]
        shape = "sphere"
        radius = 0.5
        segments = 96
        rings = 48
        material = "{name}"

        [environment]
        {environment}
        """, extra, name=file))


def material_round_trip(make_scene, name: str, **fields):
    """``(scene, again)``: the :func:`sphere_scene` of the material ``name`` with ``fields`` (TOML keys and
    their values) under a white sky, and that material as the job's glTF (``job/scene.gltf`` beside the
    scene file) reads back."""
    from compare.renderers.job import export_gltf
    from compare.scene.gltf_read import load_gltf

    material = "\n".join(f"{key} = {json.dumps(value)}" for key, value in fields.items())
    scene = sphere_scene(make_scene, material, name=name, sky=1.0)
    job = scene.path.parent / "job"
    job.mkdir()
    return scene, load_gltf(export_gltf(scene, job / "scene.gltf")).materials[0]


def hemisphere_directions(rng, k: int) -> np.ndarray:
    """``k`` random unit directions (k, 3) of the upper hemisphere, none closer to the surface than a
    z of about 0.05 before normalizing (grazing pairs test little but float noise)."""
    d = rng.normal(size=(k, 3))
    d[:, 2] = np.abs(d[:, 2]) + 0.05
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def mirror_scene(make_scene, name: str, material: str):
    """A 4 m square of the material ``name`` (its TOML fields ``material``) facing a camera 2 m away (an 8°
    view of 16 × 16 pixels), a white emitter of radiance 1 behind the camera facing it, paths of at most 4
    bounces: the camera sees the emitter reflected at normal incidence."""
    return load_scene(make_scene(f"""
        [camera]
        position = [0.0, 0.0, 2.0]
        target = [0.0, 0.0, 0.0]
        fov = 8.0
        resolution = [16, 16]

        [render]
        max_depth = 4

        [materials.{name}]
        {material}

        [[meshes]]
        shape = "quad"
        corners = [[-2, -2, 0], [2, -2, 0], [2, 2, 0], [-2, 2, 0]]
        material = "{name}"

        [[lights]]
        center = [0.0, 0.0, 3.0]
        size = [4.0, 4.0]
        normal = [0.0, 0.0, -1.0]
        radiance = [1.0, 1.0, 1.0]
        """))


# ----------------------------------------------------------------------------- web engines against three.js

#: A dark, asymmetric card off the image centre under a bright sky, seen at an angle by a camera whose
#: target is not the origin, in a 4:3 image (an engine that fits its field of view to the model's aspect
#: must still frame it as the suite does); a small area light that the engines without area lights leave out.
FRAMING = """
    name = "framing"
    [camera]
    position = [1.2, 0.8, 3.0]
    target = [0.3, 0.1, 0.0]
    fov = 40.0
    resolution = [64, 48]
    [environment]
    constant = [1.0, 1.0, 1.0]
    [materials.dark]
    base_color = [0.0, 0.0, 0.0]
    roughness = 1.0
    [[meshes]]
    name = "card"
    shape = "quad"
    material = "dark"
    corners = [[-0.2, -0.5, 0.0], [0.9, -0.4, 0.0], [0.7, 0.6, 0.0], [-0.1, 0.3, 0.0]]
    [[lights]]
    name = "small"
    center = [0.0, 2.0, 1.0]
    size = [0.1, 0.1]
    normal = [0.0, -1.0, 0.0]
    radiance = [1.0, 1.0, 1.0]
"""

#: The axes test map turned 30 degrees around a camera at the origin, with a speck of a mesh far behind the
#: camera (a scene needs one): the image is the background alone, which shows the map's orientation.
AXES_ENVIRONMENT = """
    name = "axes environment"
    [camera]
    position = [0.0, 0.0, 0.0]
    target = [1.0, 0.3, 0.2]
    fov = 70.0
    resolution = [48, 36]
    [environment]
    procedural = "axes"
    rotation = 30.0
    [materials.m]
    base_color = [0.5, 0.5, 0.5]
    [[meshes]]
    name = "speck behind the camera"
    shape = "quad"
    material = "m"
    corners = [[-50.0, -50.0, -50.0], [-50.0, -50.01, -50.0], [-50.01, -50.01, -50.0], [-50.01, -50.0, -50.0]]
"""


class WebPages:
    """One Chromium for the renders of a test module: each engine's page is a new tab of it.

    A module keeps one and closes it in a module-scoped fixture; a test that starts its own
    :class:`~compare.renderers.RenderContext` closes it first, since Playwright's sync API runs one driver
    per thread at a time."""

    def __init__(self):
        self._contexts = []

    def render(self, renderer, scene, steps: int = 2, checkpoints=None):
        """``renderer``'s :class:`~compare.renderers.Rendering` of ``scene`` as given, with a checkpoint at
        each of ``checkpoints`` (``steps`` alone by default)."""
        from compare.renderers import RenderContext

        if not self._contexts:
            self._contexts.append(RenderContext(RunSettings(frames=steps)))
        return renderer.render(scene, steps=steps, checkpoints=list(checkpoints or [steps]), seed=0,
                               context=self._contexts[0])

    def prepared(self, renderer, scene, steps: int = 2):
        """``(rendering, changed)``: ``scene`` rendered as a run gives it to ``renderer`` (its ``prepare``),
        and what that changed or left out."""
        given, changed = renderer.prepare(scene)
        return self.render(renderer, given, steps), changed

    def close(self) -> None:
        """End the shared Chromium (the next render starts another)."""
        while self._contexts:
            self._contexts.pop().close()


def threejs_and(pages: WebPages, renderer, scene, steps: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """The final images of three.js and of ``renderer`` (finite) for ``scene`` as a run gives it to each."""
    from compare.web.renderer import ThreeJsRenderer

    three = pages.prepared(ThreeJsRenderer("threejs"), scene, steps)[0].checkpoints[-1].image
    ours = pages.prepared(renderer, scene, steps)[0].checkpoints[-1].image
    assert np.isfinite(ours).all()
    return three, ours


def assert_frames_as_threejs(pages: WebPages, scene, *renderers) -> tuple[list, np.ndarray]:
    """The :data:`FRAMING` ``scene`` by three.js and by each of ``renderers``: each leaves the area light
    out with a note, its card's silhouette lands on three.js's pixels (a pixel or two along its edges), and
    where it reads back linear radiance (no ``output`` in its metadata) the sky is radiance 1. Returns the
    renderings and three.js's card mask."""
    from compare.image.tonemap import luminance
    from compare.web.renderer import ThreeJsRenderer

    three = pages.prepared(ThreeJsRenderer("threejs"), scene)[0].checkpoints[-1].image
    mask = luminance(three) < 0.5
    assert 300 < mask.sum() < 1500  # the card covers a good part of the image, off its centre
    renderings = []
    for renderer in renderers:
        rendering, changed = pages.prepared(renderer, scene)
        assert changed == ["1 area light(s) not rendered (neither their light nor their face)"]
        image = rendering.checkpoints[-1].image
        assert image.shape == (48, 64, 3) and np.isfinite(image).all()
        differ = int(((luminance(image) < 0.5) != mask).sum())
        assert differ <= 12, (renderer.name, differ)  # measured: 0 (Filament, the Sample Viewer)
        if "output" not in rendering.metadata:
            np.testing.assert_allclose(image[~mask].mean(), 1.0, rtol=0.02)
        renderings.append(rendering)
    return renderings, mask


def assert_point_light_as_threejs(pages: WebPages, make_scene, renderer) -> None:
    """The effect scene of a point light over a white rough plane, no environment, at 32 × 24: ``renderer``
    gives the plane the radiance three.js gives it (both glTF's inverse square of candela)."""
    text = (EFFECTS / "point_light.toml").read_text().replace("resolution = [96, 72]", "resolution = [32, 24]")
    three, ours = threejs_and(pages, renderer, load_scene(make_scene(text)))
    assert ours.mean() > 0.05
    np.testing.assert_allclose(ours.mean(), three.mean(), rtol=0.05)


def npm_availability(monkeypatch, web_root: Path, renderer, *present: str) -> tuple[bool, str]:
    """``renderer.available()`` where Chromium is found and web/ is ``web_root``, whose node_modules holds
    only the npm packages ``present`` (each an empty package.json)."""
    from compare.web import host

    monkeypatch.setattr(host, "chromium_path", lambda: "/bin/sh")
    monkeypatch.setattr(host, "web_root", lambda: web_root)
    for package in present:
        (web_root / "node_modules" / package).mkdir(parents=True, exist_ok=True)
        (web_root / "node_modules" / package / "package.json").write_text("{}")
    return renderer.available()


# ----------------------------------------------------------------------------- punctual lights over a plane

PLANE_ALBEDO = 0.8  # the white plane of scenes/effects


def ground_points(scene, dx: float = 0.5, dy: float = 0.5):
    """World points of the plane y = 0 seen through each pixel at (dx, dy) in it, (H, W, 3), and a mask of
    hits."""
    cam = scene.camera
    x, y = np.meshgrid(np.arange(cam.width) + dx, np.arange(cam.height) + dy)
    d = cam.ray_directions(x, y)
    o = np.asarray(cam.position)
    t = -o[1] / d[..., 1]
    p = o + t[..., None] * d
    hit = (t > 0) & (np.abs(p[..., 0]) < 19.0) & (np.abs(p[..., 2]) < 19.0)
    return p, hit


def punctual_closed_form(scene, light, n: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Radiance of a Lambert plane y = 0 (albedo 0.8, normal +Y) lit by one punctual light alone, averaged
    over an n × n grid in each pixel (the reference's box filter); and its spread within each pixel (the
    standard deviation over the grid), which sets the pixel-sampling noise of a render."""
    grid = (np.arange(n) + 0.5) / n
    samples = np.array([_punctual_closed_form_at(scene, light, ground_points(scene, dx, dy)[0])
                        for dx in grid for dy in grid])
    return samples.mean(0), samples.std(0)


def _punctual_closed_form_at(scene, light, p) -> np.ndarray:
    if light.kind == "directional":
        cos_n = max(-light.direction[1], 0.0)
        e = np.asarray(light.intensity) * cos_n
        return np.broadcast_to(PLANE_ALBEDO / math.pi * e, p.shape).copy()
    v = np.asarray(light.position) - p
    dist = np.linalg.norm(v, axis=-1)
    w = v / dist[..., None]
    cos_n = np.clip(w[..., 1], 0.0, None)
    cone = light.falloff((-w) @ np.asarray(light.direction))
    return PLANE_ALBEDO / math.pi * (cos_n * cone / dist ** 2)[..., None] * np.asarray(light.intensity)


def effect_scene(kind: str):
    """The generated closed-form scene of one kind of light (scenes/effects/, scenes/generate.py)."""
    return load_scene(EFFECTS / f"{kind}_light.toml")


# ----------------------------------------------------------------------------- a white furnace


def furnace_scene(albedo: float = 1.0, size: int = 24, *, double_sided: bool = True):
    """A diffuse unit sphere inside a uniform environment of radiance 1. ``double_sided`` False: single-sided,
    as a closed glTF solid is, so that a ray its smooth shading normals send below the facets leaves through
    the culled inside, as it would leave an ideal sphere (double-sided, the inside reflects it: indirect
    light a convex object does not have, 2e-5 of the direct here)."""
    data = {
        "camera": {"position": [0, 0, 4], "target": [0, 0, 0], "fov": 35, "resolution": [size, size]},
        "materials": {"white": {"base_color": [albedo] * 3, "roughness": 1.0, "double_sided": double_sided}},
        "meshes": [{"shape": "sphere", "radius": 1.0, "material": "white", "segments": 96, "rings": 48}],
        "environment": {"constant": [1.0, 1.0, 1.0]},
        "render": {"max_depth": -1},
    }
    return parse_scene(data, ROOT / "tests" / "furnace.toml")


def sphere_mask(size: int) -> np.ndarray:
    """Pixels well inside the sphere's silhouette (no edge pixels that mix in background)."""
    j, i = np.mgrid[0:size, 0:size]
    c = (size - 1) / 2
    return np.hypot(i - c, j - c) < 0.35 * size


# ----------------------------------------------------------------------------- synthetic renderers for `compare run`

#: A scene name that must show as text, never run.
EVIL = "<script>alert(1)</script>"


def synthetic_truth(w: int, h: int) -> np.ndarray:
    """A smooth HDR image with a bright patch (values up to ~20, like an area light)."""
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    img = np.stack([0.2 + 0.6 * x / w, 0.1 + 0.5 * y / h, 0.3 + 0.2 * np.sin(x / 3.0) ** 2], axis=-1)
    img[: h // 4, w // 3: 2 * w // 3] = [18.0, 14.0, 7.0]
    return img.astype(np.float32)


class FakeReference:
    """Stands in for compare.mitsuba.reference.ReferenceRenderer: truth + noise falling as 1/sqrt(spp)."""

    renders: list[tuple[int, int]] = []  # (spp, seed) of every ladder actually iterated

    def __init__(self, scene, *, materials="shared", cache_dir=None, progress=True, **_):
        self.scene = scene
        self.variant = "fake_rgb"
        self.load_seconds = 0.01
        self.variance = None  # no per-pixel variance of its passes

    def settings(self) -> dict:
        return {"scene_hash": self.scene.hash, "variant": self.variant,
                "resolution": list(self.scene.camera.resolution)}

    def iter_checkpoints(self, checkpoints, seed=0):
        from compare.mitsuba.reference import pass_plan

        w, h = self.scene.camera.resolution
        truth = synthetic_truth(w, h)
        rng = np.random.default_rng(seed)
        acc = np.zeros_like(truth, dtype=np.float64)
        total = 0
        for upto in pass_plan(checkpoints):
            n = upto - total
            # n samples of standard deviation 0.5 each: their sum has deviation 0.5·sqrt(n)
            acc += truth * n + rng.normal(0, 0.5, truth.shape) * np.sqrt(n)
            total = upto
            FakeReference.renders.append((total, seed))
            if total in checkpoints:
                yield Checkpoint(total, 0.01 * total, (acc / total).clip(0).astype(np.float32))

    def iter_ladder(self, spp, seed=0):
        yield from self.iter_checkpoints(doubling_steps(spp), seed)

    def render_layers(self, spp, seed=0):
        """Per-effect layers of the truth: the patch is emission, the rest 60 % direct, 40 % indirect."""
        layers = _synthetic_split(synthetic_truth(*self.scene.camera.resolution))
        layers["indirect_diffuse"] = layers.pop("rest") * 0.4
        layers["direct_area"] = layers["indirect_diffuse"] * 1.5
        layers["direct_area_unshadowed"] = layers["direct_area"] * 1.1
        image = layers["emission"] + layers["direct_area"] + layers["indirect_diffuse"]
        return image, layers, 0.01


def _synthetic_split(image: np.ndarray) -> dict[str, np.ndarray]:
    """The bright patch of synthetic_truth as emission, the rest as 'rest'."""
    patch = np.zeros(image.shape[:2], dtype=bool)
    h, w = image.shape[:2]
    patch[: h // 4, w // 3: 2 * w // 3] = True
    return {"emission": np.where(patch[..., None], image, 0).astype(np.float32),
            "rest": np.where(patch[..., None], 0, image).astype(np.float32)}


def fake_progressive(scene, *, frames, seed, options, checkpoints, ctx):
    """A biased, quickly converging stand-in for the progressive renderer."""
    area_model = options.get("area_model")
    w, h = scene.camera.resolution
    truth = synthetic_truth(w, h) * (0.8 if area_model == "paper" else 0.9)
    rng = np.random.default_rng(seed + 7)
    cps = [(f, 0.002 * f, (truth + rng.normal(0, 0.05, truth.shape) / f).clip(0).astype(np.float32))
           for f in checkpoints]
    layers = _synthetic_split(cps[-1][2])
    layers["direct_area"] = layers.pop("rest")  # the rasterizer has no indirect light
    return cps, 0.05, {"gl_renderer": "fake GL", "area_model": area_model or "radiometric", "frames": frames,
                       "first_frame_scale": options.get("first_frame_scale", 0.5)}, layers


def fake_blender(scene, *, engine, samples, seed, ladder, distribution=None, gltf_import=False):
    """Synthetic Blender renders: Cycles close to the truth, EEVEE biased; one render per ladder step."""
    w, h = scene.camera.resolution
    truth = synthetic_truth(w, h) * (1.0 if engine == "cycles" else 0.85)
    rng = np.random.default_rng(seed + (11 if engine == "cycles" else 13))
    cps = [(n, 0.01 * n, (truth + rng.normal(0, 0.05, truth.shape) / np.sqrt(n)).clip(0).astype(np.float32))
           for n in list(ladder) + [samples]]
    return cps, 1.5, {"engine": engine, "samples": samples, "blender": "fake 5.0.1"}, None


def fake_likeness(scene, *, spp, materials, seeds, cache_dir, cycles, match_noise, exposure, operator):
    """The likeness's reference passes, faked: the two Cycles renders it gets are the run's and one more."""
    from compare.run.likeness import Likeness, RegionStat

    a, b = cycles
    assert a.samples == b.samples == spp and seeds[1] == seeds[0] + 1 and not np.array_equal(a.image, b.image)
    region = RegionStat(name="all", pixels=100, cycles=[0.5] * 3, mitsuba=[0.5] * 3, se_cycles=[0.01] * 3,
                        se_mitsuba=[0.01] * 3)
    assert region.agrees
    return Likeness(scene=scene.name, spp=spp, resolution=scene.camera.resolution, materials=materials,
                    flip_seed=0.045, flip_cross=0.05, flip_mitsuba_seed=0.05, relmse_seed=0.01, relmse_cross=0.01,
                    relmse_mitsuba_seed=0.01, mitsuba_spp=spp,
                    regions=[region] * 15)


@contextlib.contextmanager
def synthetic_renderers(progressive=fake_progressive):
    """Patch run.py's renderers with the fakes above (usable outside function-scoped fixtures).

    Every patch goes through this one MonkeyPatch, undone on exit; mixing it
    with pytest's ``monkeypatch`` fixture on the same attribute would "restore"
    a fake after the test and leak it into later tests.
    """
    mp = pytest.MonkeyPatch()
    try:
        mp.setattr("compare.mitsuba.reference.ReferenceRenderer", FakeReference)
        mp.setattr("compare.progressive.renderer._progressive_checkpoints", progressive)
        mp.setattr("compare.progressive.renderer._create_gl_context", lambda: None)
        mp.setattr("compare.blender.renderer._blender_checkpoints", fake_blender)
        mp.setattr("compare.run.likeness.cycles_likeness", fake_likeness)
        mp.setattr("compare.blender.blender_available", lambda: (True, "fake"))
        yield
    finally:
        mp.undo()


def cornell_named(tmp_path: Path, name: str) -> Path:
    """The Cornell box under another name (to test escaping of scene-provided strings)."""
    text = CORNELL.read_text(encoding="utf-8")
    text = re.sub(r'^name = .*$', f"name = {json.dumps(name)}", text, count=1, flags=re.M)
    path = tmp_path / "scene.toml"
    path.write_text(text, encoding="utf-8")
    return path


def synthetic_report(out: Path, scenes: list[Path], *, size=(48, 36), frames=8, spp=16,
                     renderers=("mitsuba", "progressive"), report=True, **more) -> Results:
    """A full ``compare run`` output folder made with the synthetic renderers."""
    settings = RunSettings(frames=frames, spp=spp, sizes=[list(size)], renderers=list(renderers), **more)
    with synthetic_renderers():
        return run_mod.run(scenes, out, settings, progress=False, report=report)


def card_gltf(folder: Path) -> Path:
    """A 2 × 2 m grey card in the XY plane facing +Z (corners at ±1), as a .gltf (its buffer a data URI)."""
    from compare.scene import geometry
    from compare.scene.gltf_write import GltfWriter

    folder.mkdir(parents=True, exist_ok=True)
    w = GltfWriter()
    grey = w.material("grey", (0.5, 0.5, 0.5), 0.0, 0.6)
    card = geometry.quad((2.0, 2.0)).transformed(geometry.transform_matrix(rotate=(90.0, 0.0, 0.0)))
    w.node("card", mesh=w.mesh("card", [(card, grey)]))
    return w.write(folder / "card.gltf")


#: The scenarios of :func:`fidelity_report`, in its file's order: two rendered (the second excluding Cycles by
#: model-viewer's name for it, and a renderer the suite does not have; of another size, so that the synthetic
#: renderers' errors differ), one whose model is not there, one lit by an LDR image.
FIDELITY_SCENARIOS = [
    {"name": "front", "model": "models/card.gltf", "lighting": "env/room.hdr", "orbit": {"radius": 4},
     "dimensions": {"width": 32, "height": 24}},
    {"name": "side", "model": "models/card.gltf", "lighting": "env/room.hdr", "dimensions": {"width": 40, "height": 30},
     "orbit": {"theta": 40, "phi": 70, "radius": 4}, "exclude": ["blender-cycles", "stellar"]},
    {"name": "lost", "model": "models/gone.glb", "lighting": "env/room.hdr"},
    {"name": "ldr", "model": "models/card.gltf", "lighting": "env/sky.jpg"},
]
#: The renderers of :func:`fidelity_report` besides its ground truth (mitsuba).
FIDELITY_RENDERERS = ("progressive", "progressive:paper", "cycles")


def fidelity_report(folder: Path) -> Path:
    """``compare run --scenarios --skip-unavailable`` of :data:`FIDELITY_SCENARIOS` (each at its own size) with the
    synthetic renderers (:func:`synthetic_renderers`) and :data:`FIDELITY_RENDERERS`; returns the output folder."""
    import warnings

    from compare.cli.main import main
    from compare.image.hdr import write_hdr

    card_gltf(folder / "models")
    (folder / "env").mkdir(parents=True, exist_ok=True)
    write_hdr(folder / "env" / "room.hdr", np.full((8, 16, 3), 0.5, np.float32))
    config = folder / "config.json"
    config.write_text(json.dumps({"scenarios": FIDELITY_SCENARIOS}), encoding="utf-8")
    out = folder / "out"
    with synthetic_renderers(), warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the renderSkybox note and the one naming the scenarios left out
        status = main(["run", "--scenarios", str(config), "--skip-unavailable", "--renderers",
                       ",".join(FIDELITY_RENDERERS), "--frames", "4", "--spp", "4",
                       "--no-likeness", "--executor", "serial", "-o", str(out), "--quiet"])
    assert status == 0
    return out


# ----------------------------------------------------------------------------- the regression gate's external renderer

#: The small external renderer of the regression-gate tests, and the seeds of each of its runs.
GATE_RENDERER = Path(__file__).resolve().parent / "gate_renderer.py"
GATE_SEEDS = 5


def gate_renderer_config(folder: Path, *, bright=1.0, slow=1.0, jitter=0.0, salt=0) -> Path:
    """A renderer file with the ground truth ("truth", 64 steps) and the renderer under test ("mine", 8 steps)."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "renderers.toml"
    path.write_text(textwrap.dedent(f'''
        [renderer.truth]
        command = ["{sys.executable}", "{GATE_RENDERER}", "1", "0", "0", "0", "{{job}}"]
        unit = "frames"
        steps = 64
        [renderer.mine]
        command = ["{sys.executable}", "{GATE_RENDERER}", "{bright}", "{slow}", "{jitter}", "{salt}", "{{job}}"]
        unit = "frames"
        steps = 8
    '''))
    return path


def gate_run(folder: Path, **renderer) -> Path:
    """``compare run`` of the gate renderer at 32x24 with 5 seeds; returns results.json."""
    from compare.run.runner import run

    config = gate_renderer_config(folder / "config", **renderer)
    run([CORNELL], folder / "out", RunSettings(frames=8, sizes=[[32, 24]], renderers=["mine"], ground_truth="truth",
                                               seeds=GATE_SEEDS, renderer_config=str(config)),
        progress=False, report=False)
    return folder / "out" / "results.json"
