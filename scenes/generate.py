"""Regenerate the mesh data and the generated stress scenes under scenes/ (deterministic).

    .venv/bin/python scenes/generate.py            # rewrite everything
    .venv/bin/python scenes/generate.py --check    # exit 1 if a committed file is out of date

Written here, never at scene load time (scene files are data):

* ``kitchen/kitchen.glb`` and ``car/coupe.glb`` from :mod:`scenes.procedural_meshes`,
  with the materials of ``kitchen.toml`` / ``car.toml`` (the TOML is the single
  source: its materials are copied into the GLB so the file looks right in any
  glTF viewer, and replace the GLB's when the scene is loaded);
* ``stress/many_lights.toml`` (64 area lights), ``stress/scale_1e-3.toml`` and
  ``stress/scale_1e4.toml`` (one scene at two scales), ``stress/dark.toml``
  (the Cornell box at 1e-6 of its light), ``stress/degenerate.obj``,
  ``stress/long_accumulation.toml`` (edges placed between the jitter samples)
  ``stress/env/sun_sky.exr`` (a sky with a 1e5 sun) and ``stress/textures.toml`` with its maps
  (texture extremes);
* the kitchen's and the car's material maps (:mod:`scenes.procedural_textures`).
"""

from __future__ import annotations

import argparse
import functools
import sys
import tomllib
from pathlib import Path
from typing import Callable

import math

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

sys.path.insert(0, str(HERE))

import procedural_meshes as pm  # noqa: E402
import procedural_textures as pt  # noqa: E402
from compare.scene.gltf_write import GltfWriter  # noqa: E402


# ----------------------------------------------------------------------------- GLB stand-ins


def _materials_of(scene_toml: Path) -> dict[str, dict]:
    return tomllib.loads(scene_toml.read_text(encoding="utf-8")).get("materials", {})


def stand_in_glb(parts: list[pm.Part], materials: dict[str, dict], generator: str) -> bytes:
    """One node per part, materials by name from the scene's TOML, with their maps embedded (so that the
    file looks right in any glTF viewer, and its compressed variants carry maps to compress)."""
    w = GltfWriter(generator=generator)
    index = {}
    for name, m in materials.items():
        index[name] = w.material(name, m.get("base_color", [0.8, 0.8, 0.8]), m.get("metallic", 0.0),
                                 m.get("roughness", 0.5), m.get("emission", [0.0, 0.0, 0.0]))
        doc = w.doc["materials"][index[name]]
        scale = m.get("texture_scale")
        if "base_color_texture" in m:  # glTF multiplies a map by its factor; the TOML's map replaces it
            doc["pbrMetallicRoughness"]["baseColorTexture"] = w.texture(TEXTURE_OUTPUTS[m["base_color_texture"]](),
                                                                        scale=scale)
            doc["pbrMetallicRoughness"]["baseColorFactor"][:3] = [1.0, 1.0, 1.0]
        if "normal_texture" in m:
            doc["normalTexture"] = {**w.texture(TEXTURE_OUTPUTS[m["normal_texture"]](), scale=scale),
                                    "scale": float(m.get("normal_scale", 1.0))}
        if "metallic_roughness_texture" in m:
            doc["pbrMetallicRoughness"]["metallicRoughnessTexture"] = w.texture(
                TEXTURE_OUTPUTS[m["metallic_roughness_texture"]](), scale=scale)
            doc["pbrMetallicRoughness"].update(metallicFactor=1.0, roughnessFactor=1.0)
        if m.get("alpha_mode") == "mask":
            doc.update(alphaMode="MASK", alphaCutoff=float(m.get("alpha_cutoff", 0.5)))
    for name, mesh, material in parts:
        if material not in index:
            raise KeyError(f"part {name!r} uses material {material!r}, which the scene file does not define")
        w.node(name, mesh=w.mesh(name, [(mesh, index[material])], uvs=True))
    return w.glb()


def kitchen_glb() -> bytes:
    return stand_in_glb(pm.kitchen_parts(), _materials_of(HERE / "kitchen.toml"), "compare scenes/generate.py kitchen")


def coupe_glb() -> bytes:
    return stand_in_glb(pm.coupe_parts(), _materials_of(HERE / "car.toml"), "compare scenes/generate.py coupe")


# ----------------------------------------------------------------------------- outputs


def outputs() -> dict[str, Callable[[], bytes]]:
    """Relative path → function returning the file's bytes."""
    return {"kitchen/kitchen.glb": kitchen_glb, "car/coupe.glb": coupe_glb, **TEXTURE_OUTPUTS, **STRESS_OUTPUTS,
            **EFFECT_OUTPUTS}


# ----------------------------------------------------------------------------- compressed variants

#: The car as web-optimised downloads ship it, one file per decode path of compare.scene.gltf_decode. Written by
#: real tools (``--compressed``: gltfpack and glTF-Transform from scenes/package.json, Pillow, and alktx2 from
#: the ``scenes`` extra), not checked byte for byte (encoders differ between builds): tests/test_gltf_decode.py
#: checks that each decodes to coupe.glb within its codec's error.
COMPRESSED = {
    "car/coupe-meshopt.glb": ("gltfpack", ["-cc", "-kn", "-km"]),       # EXT_meshopt_compression + quantization
    "car/coupe-draco.glb": ("gltf-transform", ["draco"]),               # KHR_draco_mesh_compression
    "car/coupe-webp.glb": ("EXT_texture_webp", "image/webp"),
    "car/coupe-ktx2.glb": ("KHR_texture_basisu", "image/ktx2"),
}


def _node_tool(tool: str, args: list[str], src: Path, dst: Path) -> None:
    import subprocess

    binary = HERE / "node_modules" / ".bin" / tool
    if not binary.exists():
        subprocess.run(["npm", "ci", "--prefix", str(HERE), "--no-audit", "--no-fund"], check=True)
    cmd = [str(binary), "-i", str(src), "-o", str(dst), *args] if tool == "gltfpack" else \
        [str(binary), *args, str(src), str(dst)]
    subprocess.run(cmd, check=True, capture_output=True)


def recode_images(glb: bytes, extension: str, mime: str, encode: Callable[[bytes, bool], bytes]) -> bytes:
    """``glb`` with every embedded image re-encoded by ``encode(png, srgb)`` and named by ``extension``
    (required: no fallback image), as a texture-compression tool writes it."""
    from compare.scene.glb import pack_glb, parse_glb

    doc, binary = parse_glb(glb)
    srgb = set()
    for m in doc.get("materials", []):
        info = m.get("pbrMetallicRoughness", {}).get("baseColorTexture")
        for t in [info, m.get("emissiveTexture")]:
            if t:
                srgb.add(doc["textures"][t["index"]]["source"])
    out, views = bytearray(), []
    recoded = {}
    for i, img in enumerate(doc.get("images", [])):
        v = doc["bufferViews"][img["bufferView"]]
        recoded[img["bufferView"]] = encode(binary[v["byteOffset"]: v["byteOffset"] + v["byteLength"]], i in srgb)
        img["mimeType"] = mime
    for i, v in enumerate(doc["bufferViews"]):
        data = recoded.get(i, binary[v.get("byteOffset", 0): v.get("byteOffset", 0) + v["byteLength"]])
        out += b"\0" * (-len(out) % 4)
        views.append({**v, "byteOffset": len(out), "byteLength": len(data)})
        out += data
    doc["bufferViews"], doc["buffers"] = views, [{"byteLength": len(out)}]
    for tex in doc.get("textures", []):
        tex.setdefault("extensions", {})[extension] = {"source": tex.pop("source")}
    for key in ("extensionsUsed", "extensionsRequired"):
        doc[key] = sorted(set(doc.get(key, [])) | {extension})
    return pack_glb(doc, bytes(out))


def _webp(png: bytes, srgb: bool) -> bytes:
    import io

    from PIL import Image

    buf = io.BytesIO()
    with Image.open(io.BytesIO(png)) as im:
        im.save(buf, format="WEBP", quality=90, method=6)
    return buf.getvalue()


def _ktx2(png: bytes, srgb: bool) -> bytes:
    import alktx2  # the `scenes` extra: Basis Universal's encoder

    # UASTC, as glTF-Transform's `uastc` writes maps that must stay sharp; one thread for a repeatable file
    return alktx2.encode_bytes_to_ktx2(png, mime="png", codec="uastc", srgb=srgb, linear=not srgb, threads=1,
                                       zstd_supercompression_level=18, mipmaps=False)


def write_compressed(out: Path) -> None:
    """Write :data:`COMPRESSED` from the committed ``car/coupe.glb``."""
    src = HERE / "car" / "coupe.glb"
    for rel, (tool, arg) in COMPRESSED.items():
        dst = out / rel
        dst.parent.mkdir(parents=True, exist_ok=True)
        if tool.startswith(("EXT_", "KHR_")):
            dst.write_bytes(recode_images(src.read_bytes(), tool, arg, _webp if "webp" in rel else _ktx2))
        else:
            _node_tool(tool, arg, src, dst)
        print(f"wrote {dst} ({dst.stat().st_size / 1024:.0f} KiB)")


# ----------------------------------------------------------------------------- material maps


#: (seed, tint) of the kitchen's two woods.
WOOD, WOOD_DARK = (1, (0.42, 0.25, 0.13)), (4, (0.33, 0.19, 0.095))


@functools.cache
def _wood(kind: tuple[int, tuple[float, float, float]]) -> dict:
    seed, tint = kind
    return pt.wood(256, seed=seed, tint=tint)


@functools.cache
def _tiles() -> dict:
    return pt.tiles(128)


def _paint() -> bytes:
    body = next(mesh for name, mesh, _ in pm.coupe_parts() if name == "body")
    return pt.png_bytes(pt.paint_stripes(body.uvs.astype(np.float64), body.positions.astype(np.float64)))


def _png(make: Callable[[], np.ndarray]) -> Callable[[], bytes]:
    return lambda: pt.png_bytes(make())


#: The built-in scenes' maps (scenes.procedural_textures), named by kitchen.toml and car.toml.
TEXTURE_OUTPUTS: dict = {
    "kitchen/textures/wood.png": _png(lambda: _wood(WOOD)["base"]),
    "kitchen/textures/wood_normal.png": _png(lambda: _wood(WOOD)["normal"]),
    "kitchen/textures/wood_mr.png": _png(lambda: _wood(WOOD)["mr"]),
    "kitchen/textures/wood_dark.png": _png(lambda: _wood(WOOD_DARK)["base"]),
    "kitchen/textures/wood_dark_normal.png": _png(lambda: _wood(WOOD_DARK)["normal"]),
    "kitchen/textures/tile.png": _png(lambda: _tiles()["base"]),
    "kitchen/textures/tile_normal.png": _png(lambda: _tiles()["normal"]),
    "kitchen/textures/stone.png": _png(lambda: pt.speckled_stone(256)),
    "car/textures/paint.png": _paint,
    "car/textures/tread_normal.png": _png(lambda: pt.tread(64, 64)),
    "car/textures/badge.png": _png(lambda: pt.badge(128)),
}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--check", action="store_true", help="only report files that differ from what would be written")
    ap.add_argument("--out", type=Path, default=HERE, help="folder to write into (default: scenes/)")
    ap.add_argument("--compressed", action="store_true",
                    help="write the car's compressed variants (needs npm and the `scenes` extra)")
    args = ap.parse_args(argv)
    if args.compressed:
        write_compressed(args.out)
        return 0
    stale = []
    for rel, make in outputs().items():
        data = make()
        path = args.out / rel
        if path.is_file() and path.read_bytes() == data:
            continue
        stale.append(rel)
        if not args.check:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(data)
            print(f"wrote {path} ({len(data) / 1024:.0f} KiB)")
    if args.check and stale:
        print("out of date: " + ", ".join(stale))
        return 1
    return 0


# ----------------------------------------------------------------------------- stress scenes


def _fmt(v) -> str:
    if isinstance(v, str):
        return '"' + v + '"'
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_fmt(x) for x in v) + "]"
    if isinstance(v, float):
        return repr(float(f"{v:.12g}"))
    return str(v)


def toml_text(header: str, doc: dict) -> str:
    """A scene dict as TOML: scalars first, then tables, then arrays of tables (enough for scene files)."""
    # Not tomli-w: it writes every array one number per line, which would triple the committed scenes
    # (stress/many_lights.toml: 567 lines to 1826) and make a light's centre five lines long.
    lines = [f"# {line}".rstrip() for line in header.strip().splitlines()]
    scalars = {k: v for k, v in doc.items() if not isinstance(v, (dict, list)) or
               (isinstance(v, list) and not (v and isinstance(v[0], dict)))}
    lines += [f"{k} = {_fmt(v)}" for k, v in scalars.items()]

    def table(name: str, t: dict) -> None:
        plain = {k: v for k, v in t.items() if not isinstance(v, dict)}
        if plain or not t:
            lines.extend(["", f"[{name}]"] + [f"{k} = {_fmt(v)}" for k, v in plain.items()])
        for k, v in t.items():
            if isinstance(v, dict):
                table(f"{name}.{k}", v)

    for k, v in doc.items():
        if isinstance(v, dict):
            table(k, v)
    for k, v in doc.items():
        if isinstance(v, list) and v and isinstance(v[0], dict):
            for item in v:
                lines.extend(["", f"[[{k}]]"] + [f"{kk} = {_fmt(vv)}" for kk, vv in item.items()])
    return "\n".join(lines) + "\n"


def many_lights() -> bytes:
    """64 small area lights in an 8 × 8 grid over a floor with three objects; colours vary per light."""
    doc: dict = {
        "name": "64 area lights",
        "camera": {"position": [0.0, 3.4, 4.2], "target": [0.0, 0.2, 0.0], "fov": 45.0, "resolution": [320, 240]},
        "render": {"max_depth": 4},
        "materials": {"floor": {"base_color": [0.7, 0.7, 0.7], "roughness": 1.0},
                      "clay": {"base_color": [0.6, 0.55, 0.5], "roughness": 0.7},
                      "metal": {"base_color": [0.9, 0.9, 0.9], "metallic": 1.0, "roughness": 0.3}},
        "meshes": [
            {"name": "floor", "shape": "quad", "size": [6.0, 6.0], "material": "floor"},
            {"name": "sphere", "shape": "sphere", "radius": 0.4, "translate": [-0.7, 0.4, 0.3], "material": "metal"},
            {"name": "box", "shape": "box", "size": [0.6, 0.6, 0.6], "translate": [0.6, 0.3, -0.2],
             "rotate": [0.0, 30.0, 0.0], "material": "clay"},
            {"name": "post", "shape": "cylinder", "radius": 0.05, "height": 1.4, "translate": [0.1, 0.7, 0.9],
             "material": "clay"},
        ],
        "lights": [],
    }
    for i in range(8):
        for j in range(8):
            u, v = i / 7, j / 7
            doc["lights"].append({
                "name": f"light {i}.{j}", "center": [-1.575 + 0.45 * i, 2.2, -1.575 + 0.45 * j],
                "size": [0.14, 0.14], "normal": [0.0, -1.0, 0.0], "tangent": [1.0, 0.0, 0.0],
                "radiance": [round(6.0 + 6.0 * u, 3), round(8.0 - 2.0 * abs(u - v), 3), round(6.0 + 6.0 * v, 3)]})
    header = """64 area lights (generated by scenes/generate.py): an 8 x 8 grid of small lights, each with its own
colour, over a floor with a metal sphere, a box and a thin post. Tests the per-light bookkeeping of the
sample distributor (n_i = round(m / 64 / 4) samples per light) and many overlapping shadows."""
    return toml_text(header, doc).encode()


#: The scale-invariance scene at unit scale; :func:`scaled` multiplies every length.
SCALE_BASE: dict = {
    "camera": {"position": [0.0, 1.2, 3.2], "target": [0.0, 0.3, 0.0], "fov": 40.0, "resolution": [320, 240]},
    "render": {"max_depth": 4},
    "materials": {"floor": {"base_color": [0.6, 0.6, 0.6], "roughness": 0.8},
                  "red": {"base_color": [0.7, 0.1, 0.1], "roughness": 0.4},
                  "metal": {"base_color": [0.9, 0.85, 0.7], "metallic": 1.0, "roughness": 0.3}},
    "meshes": [
        {"name": "floor", "shape": "quad", "size": [4.0, 4.0], "material": "floor"},
        {"name": "box", "shape": "box", "size": [0.6, 0.6, 0.6], "translate": [-0.5, 0.3, 0.0],
         "rotate": [0.0, 25.0, 0.0], "material": "red"},
        {"name": "sphere", "shape": "sphere", "radius": 0.35, "translate": [0.55, 0.35, 0.2], "material": "metal"},
        {"name": "pole", "shape": "cylinder", "radius": 0.03, "height": 1.0, "translate": [0.1, 0.5, -0.6],
         "material": "red"},
    ],
    "lights": [{"name": "key", "center": [0.3, 1.6, 0.4], "size": [0.5, 0.3], "normal": [-0.2, -1.0, -0.1],
                "tangent": [1.0, 0.0, 0.0], "radiance": [30.0, 30.0, 30.0]}],
}
#: Fields holding lengths, per section, that :func:`scaled` multiplies.
LENGTH_FIELDS = {"camera": ("position", "target"), "meshes": ("size", "radius", "height", "translate", "corners"),
                 "lights": ("center", "size")}


def scaled(doc: dict, factor: float) -> dict:
    """The same scene with every length multiplied by ``factor`` (radiance is scale-invariant)."""
    import copy

    out = copy.deepcopy(doc)

    def mul(v):
        return [mul(x) for x in v] if isinstance(v, list) else float(f"{v * factor:.12g}")

    for key in LENGTH_FIELDS["camera"]:
        out["camera"][key] = mul(out["camera"][key])
    for section in ("meshes", "lights"):
        for item in out.get(section, []):
            for key in LENGTH_FIELDS[section]:
                if key in item:
                    item[key] = mul(item[key])
    return out


def scale_scene(factor: float, label: str) -> bytes:
    doc = {"name": f"scale {label}", **scaled(SCALE_BASE, factor)}
    header = f"""One small scene (floor, box, metal sphere, thin pole, one area light) with every length multiplied
by {label} (generated by scenes/generate.py from SCALE_BASE). Radiance does not depend on scale, so both
renderers must give the image of the unit-scale scene: this exercises shadow-map depth precision and bias
(in texels and relative depth), ray epsilons and near/far planes."""
    return toml_text(header, doc).encode()


def dark_scene() -> bytes:
    """The Cornell box with its light at 1e-6 of its radiance."""
    text = (HERE / "cornell.toml").read_text(encoding="utf-8")
    old = "radiance = [18.387, 13.9873, 6.75357]"
    if old not in text:
        raise ValueError(f"scenes/cornell.toml no longer has {old!r}; update dark_scene()")
    body = text[text.index("[camera]"):].replace(old, "radiance = [1.8387e-05, 1.39873e-05, 6.75357e-06]")
    header = """A very dark scene (generated by scenes/generate.py from cornell.toml): the Cornell box with its
light at 1e-6 of its radiance. Both renderers are linear in radiance, so the image times 1e6 must be
the Cornell box's image: any absolute epsilon or clamp in a shader or integrator shows here."""
    return ("\n".join(f"# {line}" for line in header.splitlines()) + '\nname = "Dark Cornell box"\n\n'
            + body).encode()


# ----------------------------------------------------------------------------- effect scenes: punctual lights

#: A white rough plane seen from above at 45 degrees: under one punctual light each, the closed-form scenes of
#: tests/test_punctual.py (radiance = albedo / pi x intensity x cone x cos / d^2, or x E cos for the sun).
_PLANE = """
[camera]
position = [0.0, 5.0, 5.0]
target = [0.0, 0.0, 0.0]
fov = 60.0
resolution = [96, 72]

[materials.white]
base_color = [0.8, 0.8, 0.8]
roughness = 1.0

[[meshes]]
name = "plane"
shape = "quad"
size = [40.0, 40.0]
material = "white"
"""
#: The lights, in radiometric units (light_scale = 1: W/sr, or W/m^2 for the sun).
PUNCTUAL_EFFECTS = {
    "point": ("a point light 2 m over the plane", '[[lights]]\nname = "bulb"\ntype = "point"\n'
              'position = [0.3, 2.0, 0.2]\nintensity = 40.0\nlight_scale = 1.0\n'),
    "spot": ("a tilted orange spot light whose cone edge crosses the image",
             '[[lights]]\nname = "spot"\ntype = "spot"\nposition = [0.0, 3.0, 0.0]\ndirection = [0.3, -1.0, 0.1]\n'
             'intensity = 60.0\nlight_scale = 1.0\ninner_cone = 10.0\nouter_cone = 30.0\ncolor = [1.0, 0.5, 0.25]\n'),
    "directional": ("a directional light 30 degrees from the zenith",
                    '[[lights]]\nname = "sun"\ntype = "directional"\ndirection = [0.5, -0.8660254, 0.0]\n'
                    'intensity = 3.0\nlight_scale = 1.0\n'),
}


def punctual_plane(kind: str) -> bytes:
    what, light = PUNCTUAL_EFFECTS[kind]
    return (f"# A closed-form scene (generated by scenes/generate.py): {what}, over a white rough plane.\n"
            f'name = "{kind.capitalize()} light over a plane"\n' + _PLANE + "\n" + light).encode()


def cornell_point() -> bytes:
    """The Cornell box lit by a point light instead of its ceiling rectangle, of the rectangle's on-axis
    intensity L·A, just under the ceiling."""
    text = (HERE / "cornell.toml").read_text(encoding="utf-8")
    start = text.index("[[lights]]")
    end = text.index("radiance = [18.387, 13.9873, 6.75357]", start) + len("radiance = [18.387, 13.9873, 6.75357]")
    area = 0.130 * 0.105
    light = ('[[lights]]\nname = "ceiling bulb"\ntype = "point"\nposition = [0.278, 0.5387, 0.2795]  # 1 cm below '
             'the ceiling\nlight_scale = 1.0\n'
             f"intensity = 1.0\ncolor = [{18.387 * area:.6g}, {13.9873 * area:.6g}, {6.75357 * area:.6g}]  "
             "# the rectangle's L·A (W/sr)\n")
    body = text[text.index("[camera]"):start] + light + text[end:]
    return ("# The Cornell box with a point light instead of its ceiling rectangle (generated by scenes/generate.py"
            " from cornell.toml).\n" + 'name = "Cornell box, point light"\n\n' + body).encode()


# ----------------------------------------------------------------------------- effect scenes: materials

#: Rows of spheres, one material each: (scene file, what must hold, environment, materials as TOML bodies).
MATERIAL_EFFECTS = {
    "furnace": ("a white furnace: what each material reflects of a uniform environment of radiance 1. Clear "
                "glass and a white mirror return all of it; single-scattering GGX loses some on rough metal; "
                "glTF's diffuse weight 1 - F(v.h) gains a few % on white dielectrics at grazing views",
                "constant = [1.0, 1.0, 1.0]", [
        ("lambert", 'base_color = [1.0, 1.0, 1.0]\nroughness = 1.0'),
        ("mirror", 'base_color = [1.0, 1.0, 1.0]\nmetallic = 1.0\nroughness = 0.0'),
        ("rough_metal", 'base_color = [1.0, 1.0, 1.0]\nmetallic = 1.0\nroughness = 0.6'),
        ("glass", 'base_color = [1.0, 1.0, 1.0]\nroughness = 0.0\ntransmission = 1.0\nthickness = 1.0'),
        ("coated", 'base_color = [1.0, 1.0, 1.0]\nroughness = 1.0\nclearcoat = 1.0\nclearcoat_roughness = 0.1'),
        ("sheen", 'base_color = [1.0, 1.0, 1.0]\nroughness = 1.0\nsheen_color = [1.0, 1.0, 1.0]\nsheen_roughness = 0.5'),
        ("specular", 'base_color = [1.0, 1.0, 1.0]\nroughness = 0.3\nspecular = 1.0\nspecular_color = [1.0, 1.0, 1.0]\nior = 1.8'),
    ]),
    "metal_roughness": ("a metal-roughness grid (top row metals, bottom row dielectrics; roughness 0 to 1 "
                        "left to right)", 'procedural = "studio"\nwidth = 256',
                        [(f"{'metal' if m else 'plastic'}_{r:.2f}".replace(".", "_"),
                          f"base_color = [0.9, 0.6, 0.3]\nmetallic = {m:.1f}\nroughness = {r:.2f}")
                         for m in (1.0, 0.0) for r in (0.0, 0.25, 0.5, 0.75, 1.0)]),
    "transmission": ("glass spheres of IOR 1.33, 1.5 and 2.0 (each reflects ((n-1)/(n+1))^2 at normal "
                     "incidence), a thin-walled one and a rough one", 'procedural = "studio"\nwidth = 256', [
        (f"ior_{i}".replace(".", "_"), f"base_color = [1.0, 1.0, 1.0]\nroughness = 0.0\ntransmission = 1.0\n"
                                       f"thickness = 1.0\nior = {i}") for i in (1.33, 1.5, 2.0)] + [
        ("thin", 'base_color = [1.0, 1.0, 1.0]\nroughness = 0.0\ntransmission = 1.0'),
        ("rough", 'base_color = [0.9, 1.0, 0.9]\nroughness = 0.3\ntransmission = 1.0\nthickness = 1.0')]),
    "clearcoat": ("a red base under clear coats of weight 0, 0.5 and 1 and roughness 0 and 0.3 (a coat over "
                  "black reflects 4 % at normal incidence)", 'procedural = "studio"\nwidth = 256', [
        (f"coat_{w}_{r}".replace(".", "_"), f"base_color = [0.6, 0.05, 0.05]\nroughness = 0.6\nclearcoat = {w}\n"
                                            f"clearcoat_roughness = {r}") for w in (0.0, 0.5, 1.0) for r in (0.0, 0.3)]),
    "sheen": ("dark cloth with white, red and blue sheens of roughness 0.3 and 0.8 (albedo-scaled: the base "
              "loses what the sheen adds)", 'procedural = "studio"\nwidth = 256', [
        (f"sheen_{n}_{r}".replace(".", "_"), f"base_color = [0.1, 0.1, 0.1]\nroughness = 1.0\nsheen_color = {c}\n"
                                             f"sheen_roughness = {r}")
        for n, c in (("white", "[1.0, 1.0, 1.0]"), ("red", "[1.0, 0.1, 0.1]"), ("blue", "[0.1, 0.2, 1.0]"))
        for r in (0.3, 0.8)]),
    "specular": ("KHR_materials_specular: dielectric reflection weighted 0, 0.5 and 1, white and orange "
                 "tinted (F0 = min(((n-1)/(n+1))^2 x colour, 1) x weight)", 'procedural = "studio"\nwidth = 256', [
        (f"specular_{w}_{n}".replace(".", "_"), f"base_color = [0.2, 0.2, 0.2]\nroughness = 0.2\nspecular = {w}\n"
                                                f"specular_color = {c}")
        for n, c in (("white", "[1.0, 1.0, 1.0]"), ("orange", "[2.0, 1.0, 0.3]")) for w in (0.0, 0.5, 1.0)]),
    "emissive_strength": ("KHR_materials_emissive_strength: black spheres emitting (1, 0.5, 0.25) times 1, 4, "
                          "16 and 64 in the dark (every pixel of a sphere is its emission: the radiance is kept "
                          "past 1)", "constant = [0.0, 0.0, 0.0]", [
        (f"emissive_{k}", f"base_color = [0.0, 0.0, 0.0]\nroughness = 1.0\nemission = [{k:.1f}, {k / 2:.2f}, {k / 4:.3f}]")
        for k in (1, 4, 16, 64)]),
}


#: Vertical field of view of the sphere rows: narrow, so that the spheres at the ends stay round.
FOV = 12.0


def material_row(name: str) -> bytes:
    """Spheres of the materials of :data:`MATERIAL_EFFECTS` ``name`` in a row (two rows past six), over
    nothing, in the environment."""
    what, env, materials = MATERIAL_EFFECTS[name]
    cols = min(len(materials), 6) if len(materials) != 10 else 5
    rows = -(-len(materials) // cols)
    w, h = 64 * cols, 64 * rows + 16
    # the distance at which the grid (1.2 apart, radius 0.5) fills the view, a sphere's radius to spare
    half = max(0.6 * cols + 0.1, (0.6 * rows + 0.1) * w / h)
    distance = half / (math.tan(math.radians(FOV / 2)) * w / h) + 0.5
    lines = [f"# A material effect scene (generated by scenes/generate.py): {what}.",
             f'name = "Materials: {name.replace("_", " ")}"', "", "[camera]",
             f"position = [0.0, 0.0, {distance:.2f}]", "target = [0.0, 0.0, 0.0]", f"fov = {FOV}",
             f"resolution = [{w}, {h}]", "", "[render]", "max_depth = 16", "",
             "[environment]", env, ""]
    for k, (mname, body) in enumerate(materials):
        lines += [f"[materials.{mname}]", body, ""]
    for k, (mname, _) in enumerate(materials):
        x = (k % cols - (cols - 1) / 2) * 1.2
        y = ((rows - 1) / 2 - k // cols) * 1.2
        lines += ["[[meshes]]", f'name = "{mname}"', 'shape = "sphere"', "radius = 0.5", "segments = 64", "rings = 32",
                  f'material = "{mname}"', f"translate = [{x:.2f}, {y:.2f}, 0.0]", ""]
    return "\n".join(lines).encode()


def blend_card() -> bytes:
    """A card of coverage 0.5 (alphaMode BLEND) over a checkerboard plane in a uniform sky."""
    return b"""# A material effect scene (generated by scenes/generate.py): a red card of coverage 0.5 (alpha_mode
# "blend") standing over a black-and-white checkerboard in a uniform sky: through the card the board shows at
# half its radiance plus half the card's, and the card's shadow passes half the light.
name = "Materials: blended card"

[camera]
position = [0.0, 1.2, 3.0]
target = [0.0, 0.4, 0.0]
fov = 40.0
resolution = [192, 128]

[render]
max_depth = 8

[environment]
constant = [1.0, 1.0, 1.0]

[materials.board]
base_color_texture = "checker.png"
roughness = 1.0

[materials.card]
base_color = [0.8, 0.1, 0.1]
roughness = 0.8
alpha_mode = "blend"
alpha = 0.5

[[meshes]]
name = "board"
shape = "quad"
size = [4.0, 4.0]
material = "board"

[[meshes]]
name = "card"
shape = "quad"
corners = [[-0.6, 0.0, 0.3], [0.6, 0.0, 0.3], [0.6, 0.9, 0.3], [-0.6, 0.9, 0.3]]
material = "card"
"""


EFFECT_OUTPUTS: dict = {**{f"effects/{kind}_light.toml": (lambda k=kind: punctual_plane(k)) for kind in PUNCTUAL_EFFECTS},
                        "effects/cornell_point.toml": cornell_point,
                        **{f"effects/materials_{name}.toml": (lambda n=name: material_row(n)) for name in MATERIAL_EFFECTS},
                        "effects/materials_blend.toml": blend_card,
                        # an 8 x 8 board of two greys (8-bit sRGB values 0.05 and 0.9 of full scale)
                        "effects/checker.png": _png(lambda: np.kron((np.indices((8, 8)).sum(0) % 2)[..., None]
                                                                    * np.array([[[0.85, 0.85, 0.85]]]) + 0.05,
                                                                    np.ones((16, 16, 1))))}


def degenerate_obj() -> bytes:
    """A bumpy 6 × 6 patch, no normals, every vertex listed twice, with zero-area faces mixed in."""
    rng = np.random.default_rng(7)
    n = 7
    xs = np.linspace(-1.0, 1.0, n)
    heights = np.round(rng.uniform(0.0, 0.25, (n, n)), 4)
    lines = ["# Degenerate mesh for the stress suite (generated by scenes/generate.py): no normals,",
             "# every vertex listed twice (faces use either copy), zero-area faces: repeated indices,",
             "# three distinct indices at one position, collinear points, and a polygon with a repeated corner."]
    for i in range(n):
        for j in range(n):
            lines.append(f"v {xs[j]:.6g} {heights[i, j]:.6g} {xs[i]:.6g}")
    for i in range(n):  # the duplicate copies
        for j in range(n):
            lines.append(f"v {xs[j]:.6g} {heights[i, j]:.6g} {xs[i]:.6g}")
    count = n * n
    # Collinear extras: the midpoint of the first row's first edge.
    mid = 0.5 * (np.array([xs[0], heights[0, 0], xs[0]]) + np.array([xs[1], heights[0, 1], xs[0]]))
    lines.append(f"v {mid[0]:.6g} {mid[1]:.6g} {mid[2]:.6g}")
    extra = 2 * count + 1

    def vid(i, j):  # 1-based, either copy
        return i * n + j + 1 + (count if rng.random() < 0.5 else 0)

    faces = []
    for i in range(n - 1):
        for j in range(n - 1):
            a, b, c, d = vid(i, j), vid(i, j + 1), vid(i + 1, j + 1), vid(i + 1, j)
            faces.append(f"f {a} {d} {c}")
            faces.append(f"f {a} {c} {b}")
            if (i + j) % 3 == 0:
                faces.append(f"f {a} {a} {b}")                      # repeated index
            if (i + j) % 4 == 1:
                faces.append(f"f {a} {a + count if a <= count else a - count} {a}")  # one position, two copies
    faces.append(f"f 1 2 {extra}")                                  # collinear (zero area)
    faces.append(f"f 1 {extra} 2")
    faces.append(f"f {vid(2, 2)} {vid(2, 3)} {vid(2, 3)} {vid(3, 3)}")  # polygon with a repeated corner
    return ("\n".join(lines + faces) + "\n").encode()


def long_accumulation() -> bytes:
    """A 4 × 4 view of an emissive strip whose two edges cross pixel columns 1 and 2.

    Film x maps to world x = film_x / 2 − 1 on the plane z = 0 (camera at z = 1, 90° field of view,
    square image). With sub-pixel jitter, those two columns see the strip in some frames and black in
    the others, so their running means keep changing for as long as frames accumulate.
    """
    left, right = 1.3, 2.6
    xl, xr = left / 2 - 1, right / 2 - 1
    doc = {
        "name": "long accumulation",
        "camera": {"position": [0.0, 0.0, 1.0], "target": [0.0, 0.0, 0.0], "fov": 90.0, "resolution": [4, 4]},
        "materials": {"glow": {"base_color": [0.0, 0.0, 0.0], "roughness": 1.0, "emission": [0.7, 0.3, 0.11]}},
        "meshes": [{"name": "strip", "shape": "quad", "material": "glow",
                    "corners": [[xl, -3.0, 0.0], [xr, -3.0, 0.0], [xr, 3.0, 0.0], [xl, 3.0, 0.0]]}],
    }
    header = f"""Long accumulation (generated by scenes/generate.py): a 4 x 4 view of an emissive strip whose edges
cross pixel columns 1 and 2 (film x = {left} and {right}). With sub-pixel jitter those pixels are 0 in some
frames and the emission in others, so their running means keep changing: tests/test_stress.py compares
the rasterizer's float32 running mean after 1e4 (and 1e5, slow) frames with the float64 mean of the
same per-frame values. No lights, no environment: nothing but jitter and accumulation."""
    return toml_text(header, doc).encode()


def texture_stress() -> bytes:
    """Texture extremes: a glossy ground with a normal map of ridges 2 texels apart seen at grazing
    angles, crossed alpha-masked foliage cards casting shadows, a box with a 1 x 1 map and a banner
    with a map 8192 texels wide, under one area light and a constant sky."""
    cards = []
    for k, x in enumerate((-1.3, 0.0, 1.3)):
        z = -0.8 - 0.3 * k
        cards.append({"name": f"card {k}a", "shape": "quad", "material": "leaves",
                      "corners": [[x - 0.5, 0.0, z], [x + 0.5, 0.0, z], [x + 0.5, 1.2, z], [x - 0.5, 1.2, z]]})
        cards.append({"name": f"card {k}b", "shape": "quad", "material": "leaves",
                      "corners": [[x, 0.0, z + 0.5], [x, 0.0, z - 0.5], [x, 1.2, z - 0.5], [x, 1.2, z + 0.5]]})
    doc = {
        "name": "Texture extremes",
        "camera": {"position": [0.0, 0.45, 4.2], "target": [0.0, 0.3, -2.0], "fov": 50.0, "resolution": [320, 240]},
        "render": {"max_depth": 4},
        "materials": {
            "ridged": {"base_color": [0.5, 0.5, 0.5], "roughness": 0.3, "normal_texture": "textures/ridges.png",
                       "texture_scale": [24.0, 24.0]},
            "leaves": {"base_color": [0.1, 0.4, 0.1], "roughness": 0.6, "base_color_texture": "textures/leaves.png",
                       "alpha_mode": "mask", "alpha_cutoff": 0.5},
            "one": {"base_color_texture": "textures/one_texel.png", "roughness": 0.5},
            "banner": {"base_color_texture": "textures/wide.png", "roughness": 0.8, "texture_wrap": "clamp"},
        },
        "meshes": [
            {"name": "ground", "shape": "quad", "size": [12.0, 12.0], "material": "ridged"},
            *cards,
            {"name": "one-texel box", "shape": "box", "size": [0.5, 0.5, 0.5], "translate": [1.9, 0.25, 0.6],
             "rotate": [0.0, 20.0, 0.0], "material": "one"},
            {"name": "banner", "shape": "quad", "material": "banner",
             "corners": [[-3.0, 0.0, -3.0], [3.0, 0.0, -3.0], [3.0, 0.6, -3.0], [-3.0, 0.6, -3.0]]},
        ],
        "lights": [{"name": "key", "center": [0.8, 3.0, 1.0], "size": [1.0, 1.0], "normal": [0.0, -1.0, 0.0],
                    "tangent": [1.0, 0.0, 0.0], "radiance": [8.0, 8.0, 8.0]}],
        "environment": {"constant": [0.30, 0.34, 0.42]},
    }
    header = """Texture extremes (generated by scenes/generate.py, maps in stress/textures/): a glossy ground whose normal
map has ridges 2 texels apart (24 repeats over 12 m: far below a pixel) seen at grazing angles, where
mipmapping averages the normals away and a path tracer does not; three pairs of crossed alpha-masked foliage
cards that cast shadows through their holes; a box with a 1 x 1 map; a banner whose map is 8192 texels wide
(stripes 64 texels apart, clamped)."""
    return toml_text(header, doc).encode()


def sun_sky_exr() -> bytes:
    """A 256 × 128 equirectangular sky: a gradient from 0.3 (horizon) to 1.0 (zenith), black below the
    horizon, and a one-pixel sun of radiance 1e5 at 45° elevation."""
    import tempfile

    from compare.image.exr import write_exr

    w, h = 256, 128
    theta = (np.arange(h) + 0.5) / h * np.pi  # row centre, from +Y
    sky = np.where(theta < np.pi / 2, 0.3 + 0.7 * np.sqrt(np.clip(np.cos(theta), 0.0, None)), 0.0)
    img = np.repeat(np.repeat(sky[:, None, None], w, 1), 3, 2).astype(np.float32)
    img[..., 2] *= 1.15
    img[..., 0] *= 0.85
    img[h // 4, w // 3] = (1e5, 1e5, 1e5)  # theta = 45.7 deg
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "sun_sky.exr"
        write_exr(path, img, metadata={"description": "sky gradient with a 1e5 sun (scenes/generate.py)"})
        return path.read_bytes()


STRESS_OUTPUTS: dict = {
    "stress/many_lights.toml": many_lights,
    "stress/scale_1e-3.toml": lambda: scale_scene(1e-3, "1e-3"),
    "stress/scale_1e4.toml": lambda: scale_scene(1e4, "1e4"),
    "stress/dark.toml": dark_scene,
    "stress/degenerate.obj": degenerate_obj,
    "stress/long_accumulation.toml": long_accumulation,
    "stress/env/sun_sky.exr": sun_sky_exr,
    "stress/textures.toml": texture_stress,
    "stress/textures/ridges.png": _png(lambda: pt.ridges(256, 2)),
    "stress/textures/leaves.png": _png(lambda: pt.leaves(256)),
    "stress/textures/one_texel.png": _png(lambda: np.array([[[0.9, 0.45, 0.1]]])),
    "stress/textures/wide.png": _png(lambda: pt.wide_stripes(8192, 4, 64)),
}

if __name__ == "__main__":
    raise SystemExit(main())
