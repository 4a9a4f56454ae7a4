"""The neutral scene model every renderer reads, loaded from TOML.

A scene file is data: nothing in it is executed, every path in it is resolved
relative to the file (it may lead out of the file's folder; the URIs inside an
included glTF may not leave the glTF's folder), and every error names the file
and the field, e.g.::

    scenes/x.toml: lights[2].size: expected two positive numbers, got [0.5, -1]

Units are metres; the world is right-handed with +Y up. Area lights are
one-sided rectangles that emit along their normal, given as radiance
(W·sr⁻¹·m⁻²) or as power (W; radiance = Φ / (π·A) for a Lambertian emitter).
Materials follow glTF 2.0 metallic-roughness (α = roughness²).

See ``scenes/README.md`` for the file format with an example of every field.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
import warnings
from pathlib import Path
from typing import Any, Callable

import numpy as np

from compare.scene import framing, geometry
from compare.brdf.multiscatter import DEFAULT_DISTRIBUTION, DISTRIBUTIONS

from compare.util.errors import CompareError, MissingComponentError, SceneError
from compare.util.files import sha256_bytes
from compare.scene.fields import boolean as _boolean
from compare.scene.fields import Ctx as _Ctx, color as _color, file_field as _file, fmt as _fmt, number as _number
from compare.scene.fields import float32_problem as _float32_problem, require as _require, table as _table
from compare.scene.fields import unit_vector as _unit, vector as _vector
from compare.scene.model import *  # noqa: F403 - the model is this module's face
from compare.scene.model import (DEFAULT_PROBE_BOUNCES, DEFAULT_PROBE_GRID, ENV_FILE_SUFFIXES,
                          INDIRECT_MODES, MAX_PROBES_PER_AXIS, MESH_FILE_SUFFIXES, MESH_SHAPES, TEXTURE_SUFFIXES,
                          DEFAULT_STAND_IN_SIZE, PUNCTUAL_KINDS, AreaLight, Camera, Environment, Material, Mesh,
                          PunctualLight, Scene, floored_light, mesh_bounds)
from compare.scene.model import ALPHA_MODES, LAYERS, TEXTURE_FILTERS, TEXTURE_WRAPS


def _camera(ctx: _Ctx, raw: Any, framed: Callable[[], tuple[np.ndarray, np.ndarray]]) -> Camera:
    """The ``[camera]`` table: a position, or an ``orbit`` about a target (:mod:`compare.scene.framing`);
    ``framed()`` gives the bounds that ``target = "auto"`` and ``radius = "auto"`` frame."""
    t = _table(ctx, "camera", raw, {"position", "target", "up", "fov", "resolution", "orbit"})
    fov = _number(ctx, "camera.fov", t.get("fov", 45.0))
    if not 0 < fov < 180:
        raise ctx.err("camera.fov", f"expected a vertical field of view in degrees in (0, 180), got {_fmt(t['fov'])}")
    res = t.get("resolution", [320, 240])
    if not (isinstance(res, list) and len(res) == 2 and all(isinstance(x, int) and not isinstance(x, bool) and x > 0
                                                            for x in res)):
        raise ctx.err("camera.resolution", f"expected two positive integers, got {_fmt(res)}")
    if "orbit" in t and "position" in t:
        raise ctx.err("camera.orbit", "give either a position or an orbit, not both")
    if t.get("target") == "auto":
        target = tuple(float(v) for v in framing.bounds_center(*framed()))
    else:
        target = _vector(ctx, "camera.target", _require(ctx, "camera", t, "target"), 3)
    if "orbit" in t:
        orbit = _table(ctx, "camera.orbit", t["orbit"], {"theta", "phi", "radius"})
        theta = _number(ctx, "camera.orbit.theta", orbit.get("theta", framing.DEFAULT_ORBIT[0]))
        phi = _number(ctx, "camera.orbit.phi", orbit.get("phi", framing.DEFAULT_ORBIT[1]))
        if not 0 < phi < 180:
            raise ctx.err("camera.orbit.phi", f"expected degrees from +Y in (0, 180), got {_fmt(orbit['phi'])}")
        radius = orbit.get("radius", "auto")
        if radius == "auto":
            radius = framing.fit_radius(*framed(), target, fov, res[0] / res[1])
        else:
            radius = _number(ctx, "camera.orbit.radius", radius)
            if not radius > 0:
                raise ctx.err("camera.orbit.radius", f'expected metres > 0 or "auto", got {_fmt(orbit["radius"])}')
        pos = tuple(float(v) for v in framing.orbit_position(target, theta, phi, radius))
    else:
        pos = _vector(ctx, "camera.position", _require(ctx, "camera", t, "position"), 3)
    for field, v in (("position", pos), ("target", target)):
        problem = geometry.world_range_problem(max(abs(x) for x in v))
        if problem:
            raise ctx.err(f"camera.{field}", f"reaches {problem}")
    if np.linalg.norm(np.subtract(target, pos)) < 1e-12:
        raise ctx.err("camera.target", "must differ from camera.position")
    up = tuple(_unit(ctx, "camera.up", t.get("up", [0, 1, 0])))
    fwd = np.subtract(target, pos)
    if np.linalg.norm(np.cross(fwd / np.linalg.norm(fwd), up)) < 1e-6:
        raise ctx.err("camera.up", f"is parallel to the viewing direction, got {_fmt(t.get('up', [0, 1, 0]))}")
    return Camera(pos, target, up, fov, (res[0], res[1]))  # type: ignore[arg-type]


def _check_restyles(ctx: _Ctx, includes, mats_raw: dict, used: set[str]) -> None:
    """A TOML material named with an include's prefix restyles one of its materials: one that matches none
    (and that no TOML mesh uses either) is an error naming the imported names it may have meant (a glTF
    with two materials of one name has them as ``<name>#<index>``, by their index in the file)."""
    for name in mats_raw:
        if name in used or any(name in inc.materials for inc in includes):
            continue
        for inc in includes:
            if inc.prefix and name.startswith(inc.prefix):
                base = name.split("#", 1)[0]
                near = sorted(n for n in inc.materials if n.split("#", 1)[0] == base)
                hint = (f"the file has {len(near)} materials of that name: {', '.join(near)}" if near else
                        f"its materials are {', '.join(sorted(inc.materials)[:8])}"
                        + (", ..." if len(inc.materials) > 8 else ""))
                raise ctx.err(f"materials.{name}", f"restyles no imported material and no mesh uses it ({hint})")


def _material(ctx: _Ctx, name: str, raw: Any) -> Material:
    w = f"materials.{name}"
    t = _table(ctx, w, raw, {"base_color", "metallic", "roughness", "emission", "base_color_texture",
                             "metallic_roughness_texture", "emissive_texture", "occlusion_texture",
                             "occlusion_strength", "normal_texture", "normal_scale", "distribution", "texture_offset",
                             "texture_rotation", "texture_scale", "texture_wrap", "texture_filter",
                             "alpha_mode", "alpha", "alpha_cutoff", "double_sided",
                             *(layer.field for layer in LAYERS)})
    wrap = t.get("texture_wrap", "repeat")
    if wrap not in TEXTURE_WRAPS:
        raise ctx.err(f"{w}.texture_wrap", f"expected one of {', '.join(map(repr, TEXTURE_WRAPS))}, got {_fmt(wrap)}")
    filt = t.get("texture_filter", "linear")
    if filt not in TEXTURE_FILTERS:
        raise ctx.err(f"{w}.texture_filter", f"expected one of {', '.join(map(repr, TEXTURE_FILTERS))}, "
                                             f"got {_fmt(filt)}")
    scale = _vector(ctx, f"{w}.texture_scale", t.get("texture_scale", [1.0, 1.0]), 2)
    if 0.0 in scale:
        raise ctx.err(f"{w}.texture_scale", f"expected two non-zero numbers, got {_fmt(t.get('texture_scale'))}")
    alpha_mode = t.get("alpha_mode", "opaque")
    if alpha_mode not in ALPHA_MODES:
        raise ctx.err(f"{w}.alpha_mode", f"expected one of {', '.join(map(repr, ALPHA_MODES))}, got {_fmt(alpha_mode)}")
    dist = t.get("distribution", DEFAULT_DISTRIBUTION)
    if dist not in DISTRIBUTIONS:
        raise ctx.err(f"{w}.distribution", f"expected one of {', '.join(map(repr, DISTRIBUTIONS))} (Blender's "
                                           f"Principled BSDF distribution), got {_fmt(dist)}")
    mat = Material(
        name=name,
        base_color=_color(ctx, f"{w}.base_color", t.get("base_color", [0.8, 0.8, 0.8]), hi=1.0),
        metallic=_number(ctx, f"{w}.metallic", t.get("metallic", 0.0), lo=0.0, hi=1.0),
        roughness=_number(ctx, f"{w}.roughness", t.get("roughness", 0.5), lo=0.0, hi=1.0),
        emission=_color(ctx, f"{w}.emission", t.get("emission", [0, 0, 0])),
        base_color_texture=(_texture(ctx, f"{w}.base_color_texture", t["base_color_texture"])
                            if "base_color_texture" in t else None),
        metallic_roughness_texture=(_texture(ctx, f"{w}.metallic_roughness_texture", t["metallic_roughness_texture"])
                                    if "metallic_roughness_texture" in t else None),
        emissive_texture=(_texture(ctx, f"{w}.emissive_texture", t["emissive_texture"])
                          if "emissive_texture" in t else None),
        occlusion_texture=(_texture(ctx, f"{w}.occlusion_texture", t["occlusion_texture"])
                           if "occlusion_texture" in t else None),
        occlusion_strength=_number(ctx, f"{w}.occlusion_strength", t.get("occlusion_strength", 1.0), lo=0.0, hi=1.0),
        normal_texture=(_texture(ctx, f"{w}.normal_texture", t["normal_texture"]) if "normal_texture" in t else None),
        normal_scale=_number(ctx, f"{w}.normal_scale", t.get("normal_scale", 1.0)),
        texture_offset=_vector(ctx, f"{w}.texture_offset", t.get("texture_offset", [0.0, 0.0]), 2),
        texture_rotation=_number(ctx, f"{w}.texture_rotation", t.get("texture_rotation", 0.0)),
        texture_scale=scale,
        texture_wrap=wrap,
        texture_filter=filt,
        distribution=dist,
        alpha_mode=alpha_mode,
        alpha=_number(ctx, f"{w}.alpha", t.get("alpha", 1.0), lo=0.0, hi=1.0),
        alpha_cutoff=_number(ctx, f"{w}.alpha_cutoff", t.get("alpha_cutoff", 0.5), lo=0.0, hi=1.0),
        double_sided=_boolean(ctx, f"{w}.double_sided", t.get("double_sided", True)),
        **{layer.field: _layer(ctx, f"{w}.{layer.field}", layer, t[layer.field]) for layer in LAYERS
           if layer.field in t},
    )
    if mat.alpha_mode != "opaque" and mat.is_emissive:
        raise ctx.err(f"{w}.alpha_mode", f"an emissive material cannot be alpha-{mat.alpha_mode}ed (the "
                                         "reference's emitters have no holes); drop the emission or the alpha mode")
    return mat


def _layer(ctx: _Ctx, where: str, layer, v: Any):
    """A material extension's parameter (:data:`compare.scene.model.LAYERS`) within its range."""
    if layer.color:
        return _color(ctx, where, v, hi=None if math.isinf(layer.hi) else layer.hi)
    if math.isinf(layer.hi):
        if isinstance(v, float) and v == math.inf:  # TOML's inf: the extension's own default (no absorption)
            return math.inf
        return _number(ctx, where, v, lo=layer.lo, positive=layer.lo > 0)
    return _number(ctx, where, v, lo=layer.lo, hi=layer.hi)


def _texture(ctx: _Ctx, where: str, v: Any) -> Path:
    """A texture file, read once here: unreadable, NaN or negative values are refused at load."""
    from compare.scene.textures import texture_problem

    path = _file(ctx, where, v, TEXTURE_SUFFIXES)
    problem = texture_problem(path)
    if problem:
        raise ctx.err(where, f"{v}: {problem}")
    return path


def _mesh(ctx: _Ctx, k: int, raw: Any, materials: dict[str, Material]) -> Mesh:
    w = f"meshes[{k}]"
    common = {"name", "shape", "material", "translate", "rotate", "scale"}
    if not isinstance(raw, dict):
        raise ctx.err(w, f"expected a table, got {_fmt(raw)}")
    shape = _require(ctx, w, raw, "shape")
    if shape not in MESH_SHAPES:
        raise ctx.err(f"{w}.shape", f"expected one of {', '.join(MESH_SHAPES)}, got {_fmt(shape)}")
    extra = {"quad": {"size", "corners"}, "box": {"size"}, "sphere": {"radius", "segments", "rings"},
             "cylinder": {"radius", "height", "segments"}, "file": {"file"}}[shape]
    t = _table(ctx, w, raw, common | extra)
    name = t.get("name", f"mesh{k}")
    if not isinstance(name, str):
        raise ctx.err(f"{w}.name", f"expected a string, got {_fmt(name)}")
    mat = _require(ctx, w, t, "material")
    if mat not in materials:
        known = ", ".join(sorted(materials)) or "none defined"
        raise ctx.err(f"{w}.material", f"unknown material {_fmt(mat)} (known: {known})")
    params: dict[str, Any] = {}
    file = None
    if shape == "quad":
        if ("size" in t) == ("corners" in t):
            raise ctx.err(w, "a quad needs exactly one of 'size' or 'corners'")
        if "size" in t:
            params["size"] = _vector(ctx, f"{w}.size", t["size"], 2, positive=True)
        else:
            c = t["corners"]
            if not (isinstance(c, list) and len(c) == 4):
                raise ctx.err(f"{w}.corners", f"expected four [x, y, z] points, got {_fmt(c)}")
            pts = np.array([_vector(ctx, f"{w}.corners[{i}]", p, 3) for i, p in enumerate(c)])
            if np.linalg.norm(np.cross(pts[1] - pts[0], pts[2] - pts[0])) < 1e-12:
                raise ctx.err(f"{w}.corners", "the first three corners are collinear (zero-area quad)")
            params["corners"] = pts
    elif shape == "box":
        params["size"] = _vector(ctx, f"{w}.size", _require(ctx, w, t, "size"), 3, positive=True)
    elif shape in ("sphere", "cylinder"):
        params["radius"] = _number(ctx, f"{w}.radius", _require(ctx, w, t, "radius"), positive=True)
        if shape == "cylinder":
            params["height"] = _number(ctx, f"{w}.height", _require(ctx, w, t, "height"), positive=True)
        for key, lo in (("segments", 3), ("rings", 2)):
            if key in t:
                v = t[key]
                if not (isinstance(v, int) and not isinstance(v, bool) and lo <= v <= 4096):
                    raise ctx.err(f"{w}.{key}", f"expected an integer in [{lo}, 4096], got {_fmt(v)}")
                params[key] = v
    else:
        file = _file(ctx, f"{w}.file", _require(ctx, w, t, "file"), MESH_FILE_SUFFIXES)
    scale = t.get("scale", [1, 1, 1])
    if isinstance(scale, (int, float)) and not isinstance(scale, bool):
        scale = [scale] * 3
    sv = _vector(ctx, f"{w}.scale", scale, 3)
    if any(abs(s) < 1e-12 for s in sv):
        raise ctx.err(f"{w}.scale", f"expected non-zero scale factors, got {_fmt(scale)}")
    m = geometry.transform_matrix(
        _vector(ctx, f"{w}.translate", t.get("translate", [0, 0, 0]), 3),
        _vector(ctx, f"{w}.rotate", t.get("rotate", [0, 0, 0]), 3),
        sv,
    )
    mesh = Mesh(name=name, shape=shape, material=mat, params=params, transform=m, file=file)
    try:
        mesh.triangles()  # reads a mesh file, and checks every mesh's world coordinates
    except geometry.MeshFileError as exc:
        raise ctx.err(f"{w}.file", str(exc)) from exc
    except geometry.MeshRangeError as exc:
        raise ctx.err(w, str(exc)) from exc
    return mesh


#: W/lm at 555 nm: what a punctual light's intensity (cd, or lux for a directional light) is multiplied by.
WATTS_PER_LUMEN = 1.0 / 683.0


def _punctual(ctx: _Ctx, k: int, t: dict, kind: str) -> PunctualLight:
    """A ``[[lights]]`` table of type point, spot or directional."""
    w = f"lights[{k}]"
    fields = {"name", "type", "color", "intensity", "light_scale", "range", "stand_in_size"}
    fields |= {"position"} if kind == "point" else {"position", "direction", "inner_cone", "outer_cone"} \
        if kind == "spot" else {"direction"}
    t = _table(ctx, w, t, fields)
    position = (_vector(ctx, f"{w}.position", _require(ctx, w, t, "position"), 3) if kind != "directional"
                else (0.0, 0.0, 0.0))
    direction = (tuple(_unit(ctx, f"{w}.direction", _require(ctx, w, t, "direction"))) if kind != "point"
                 else (0.0, -1.0, 0.0))
    color = _color(ctx, f"{w}.color", t.get("color", [1.0, 1.0, 1.0]))
    intensity = _number(ctx, f"{w}.intensity", _require(ctx, w, t, "intensity"))
    scale = _number(ctx, f"{w}.light_scale", t.get("light_scale", WATTS_PER_LUMEN))
    if not (intensity >= 0 and scale > 0):
        raise ctx.err(f"{w}.intensity", f"expected an intensity >= 0 and a light_scale > 0, got {_fmt(intensity)} "
                                        f"and {_fmt(scale)}")
    radiometric = tuple(c * intensity * scale for c in color)
    if max(radiometric) <= 0:
        raise ctx.err(f"{w}.intensity", "a light must emit something (all zero)")
    for r in radiometric:
        problem = _float32_problem(r)
        if problem:
            raise ctx.err(f"{w}.intensity", f"gives a radiometric intensity of which {problem}")
    inner = _number(ctx, f"{w}.inner_cone", t.get("inner_cone", 0.0))
    outer = _number(ctx, f"{w}.outer_cone", t.get("outer_cone", 45.0))
    if not 0 <= inner < outer <= 90:
        raise ctx.err(f"{w}.outer_cone", f"expected 0 <= inner_cone < outer_cone <= 90 (degrees from the axis), got "
                                         f"{_fmt(inner)} and {_fmt(outer)}")
    rng = t.get("range")
    if rng is not None and not (_number(ctx, f"{w}.range", rng) > 0):
        raise ctx.err(f"{w}.range", f"expected metres > 0, got {_fmt(rng)}")
    size = _number(ctx, f"{w}.stand_in_size", t.get("stand_in_size", DEFAULT_STAND_IN_SIZE))
    if not size > 0:
        raise ctx.err(f"{w}.stand_in_size", f"expected metres > 0, got {_fmt(size)}")
    problem = geometry.world_range_problem(float(np.max(np.abs(position))))
    if problem:
        raise ctx.err(f"{w}.position", f"reaches {problem}")
    name = t.get("name", f"light{k}")
    if not isinstance(name, str):
        raise ctx.err(f"{w}.name", f"expected a string, got {_fmt(name)}")
    return PunctualLight(name, kind, tuple(position), direction, radiometric, inner, outer,  # type: ignore[arg-type]
                         None if rng is None else float(rng), size)


def _light(ctx: _Ctx, k: int, raw: Any) -> AreaLight | PunctualLight:
    w = f"lights[{k}]"
    kind = raw.get("type", "rect") if isinstance(raw, dict) else "rect"
    if kind in PUNCTUAL_KINDS:
        return _punctual(ctx, k, raw, kind)
    t = _table(ctx, w, raw, {"name", "type", "center", "size", "normal", "tangent", "radiance", "power"})
    if kind != "rect":
        raise ctx.err(f"{w}.type", f"expected 'rect' (the default), 'point', 'spot' or 'directional', got {_fmt(kind)}")
    center = _vector(ctx, f"{w}.center", _require(ctx, w, t, "center"), 3)
    size = _vector(ctx, f"{w}.size", _require(ctx, w, t, "size"), 2, positive=True)
    normal = _unit(ctx, f"{w}.normal", _require(ctx, w, t, "normal"))
    if "tangent" in t:
        tangent = _unit(ctx, f"{w}.tangent", t["tangent"])
        tangent = tangent - normal * float(tangent @ normal)  # make it exactly perpendicular
        if np.linalg.norm(tangent) < 1e-6:
            raise ctx.err(f"{w}.tangent", f"is parallel to the normal, got {_fmt(t['tangent'])}")
        tangent /= np.linalg.norm(tangent)
    else:
        helper = np.array([1.0, 0, 0]) if abs(normal[0]) < 0.9 else np.array([0, 0, 1.0])
        tangent = helper - normal * float(helper @ normal)
        tangent /= np.linalg.norm(tangent)
    if ("radiance" in t) == ("power" in t):
        raise ctx.err(w, "give exactly one of 'radiance' (W/sr/m²) or 'power' (W)")
    if "radiance" in t:
        radiance = _color(ctx, f"{w}.radiance", t["radiance"])
    else:
        power = _color(ctx, f"{w}.power", t["power"])
        radiance = tuple(p / (math.pi * size[0] * size[1]) for p in power)
    if max(radiance) <= 0:
        raise ctx.err(f"{w}.radiance" if "radiance" in t else f"{w}.power", "a light must emit something (all zero)")
    for r in radiance:
        problem = _float32_problem(r)
        if problem:
            raise ctx.err(f"{w}.power", f"gives a radiance of which {problem}")
    problem = geometry.world_range_problem(float(np.max(np.abs(center)) + max(size)))
    if problem:
        raise ctx.err(f"{w}.center", f"the light reaches {problem}")
    name = t.get("name", f"light{k}")
    if not isinstance(name, str):
        raise ctx.err(f"{w}.name", f"expected a string, got {_fmt(name)}")
    light, note = floored_light(AreaLight(name, center, size, tuple(normal), tuple(tangent), radiance))  # type: ignore[arg-type]
    if note:
        warnings.warn(f"{ctx.path}: {w}: {note}", stacklevel=4)
    return light


def _environment(ctx: _Ctx, raw: Any) -> Environment:
    from compare.scene import environments, procedural_env

    sources = ("constant", "file", "procedural", "blender")
    kind = raw.get("procedural") if isinstance(raw, dict) else None
    params = set(procedural_env.PROCEDURAL[kind][0]) if kind in procedural_env.PROCEDURAL else set()
    t = _table(ctx, "environment", raw, {*sources, "intensity", "rotation", "background"} | params)
    if sum(k in t for k in sources) != 1:
        raise ctx.err("environment", "give exactly one of 'constant' (radiance), 'file' (equirectangular map), "
                                     "'procedural' (\"sky\", \"studio\", \"axes\") or 'blender' (a studio-light name)")
    constant = _color(ctx, "environment.constant", t["constant"]) if "constant" in t else None
    file = _file(ctx, "environment.file", t["file"], ENV_FILE_SUFFIXES) if "file" in t else None
    intensity = _number(ctx, "environment.intensity", t.get("intensity", 1.0), lo=0.0)
    rotation = _number(ctx, "environment.rotation", t.get("rotation", 0.0))
    # background = false: the environment lights the scene but camera rays that hit nothing see black
    shown = t.get("background", True)
    if kind == "studio" and isinstance(shown, (int, float)) and not isinstance(shown, bool):
        raise ctx.err("environment.background", f"expected true or false, got {shown!r} (the studio map's wall "
                                                "radiance is its parameter 'walls')")
    background = _boolean(ctx, "environment.background", shown)
    env = Environment(constant, file, intensity, rotation, background=background)
    try:
        if "procedural" in t:
            if kind not in procedural_env.PROCEDURAL:
                raise ValueError(f"procedural: expected one of {', '.join(map(repr, procedural_env.PROCEDURAL))}, "
                                 f"got {_fmt(kind)}")
            full = procedural_env.validate_procedural(kind, {k: t[k] for k in params if k in t})
            env = dataclasses.replace(env, procedural=kind, parameters=tuple(sorted(full.items())))
        elif "blender" in t:
            if not isinstance(t["blender"], str):
                raise ValueError(f"blender: expected a studio-light name (string), got {_fmt(t['blender'])}")
            env = dataclasses.replace(env, blender=t["blender"])
        # The map's bytes go into the scene hash (a procedural map is generated into the cache here).
        path = environments.environment_path(env) if file is None and constant is None else None
    except ValueError as exc:
        field, _, msg = str(exc).partition(": ")
        raise ctx.err(f"environment.{field}", msg) from None
    except MissingComponentError as exc:
        raise ctx.err("environment.blender", str(exc)) from None
    if path is not None:
        ctx.files.append(path)
    return env


def parse_scene(data: dict[str, Any], path: Path) -> Scene:
    """Validate a parsed TOML document (``path`` is used for messages and relative paths)."""
    ctx = _Ctx(Path(path))
    _table(ctx, "", data, {"name", "camera", "materials", "meshes", "lights", "environment", "render", "include"})
    name = data.get("name", ctx.path.stem)
    if not isinstance(name, str):
        raise ctx.err("name", f"expected a string, got {_fmt(name)}")
    includes = _includes(ctx, data.get("include", []))
    cam_raw = data.get("camera")
    included_cam = next((inc.camera for inc in includes if inc.camera), None)
    if included_cam is not None and (cam_raw is None or (isinstance(cam_raw, dict)
                                                         and not {"position", "orbit"} & set(cam_raw))):
        cam_raw = {**included_cam, **(cam_raw or {})}  # the TOML's own [camera] fields win
    # A camera that frames nothing is checked first (its errors come before the meshes'); one that frames
    # the models ("auto") after them.
    framed = cam_raw is None or (isinstance(cam_raw, dict) and (cam_raw.get("target") == "auto" or (
        isinstance(cam_raw.get("orbit"), dict) and cam_raw["orbit"].get("radius", "auto") == "auto")))
    camera = None if framed else _camera(ctx, cam_raw, lambda: mesh_bounds(()))
    mats_raw = data.get("materials", {})
    if not isinstance(mats_raw, dict):
        raise ctx.err("materials", f"expected a table of named materials, got {_fmt(mats_raw)}")
    materials = {n: m for inc in includes for n, m in inc.materials.items()}
    materials.update({n: _material(ctx, n, m) for n, m in mats_raw.items()})  # a TOML material replaces an imported one
    meshes_raw = data.get("meshes", [])
    if not isinstance(meshes_raw, list):
        raise ctx.err("meshes", "expected an array of tables ([[meshes]])")
    meshes = tuple(_mesh(ctx, k, m, materials) for k, m in enumerate(meshes_raw))
    _check_restyles(ctx, includes, mats_raw, {m.material for m in meshes})
    meshes += tuple(m for inc in includes for m in inc.meshes)
    if not meshes:
        raise ctx.err("meshes", "a scene needs at least one mesh")
    # "auto" frames the included models (a floor or backdrop the TOML adds around them does not count), or
    # every mesh of a scene without includes
    subject = [m for inc in includes for m in inc.meshes] or list(meshes)
    if camera is None and cam_raw is None:
        if not includes:
            _require(ctx, "", data, "camera")
        cam_raw = {"target": "auto", "orbit": {}}
        warnings.warn(f"{ctx.path}: no [camera] and no camera in the included file(s): framed by an orbit "
                      f"(theta {framing.DEFAULT_ORBIT[0]:g}°, phi {framing.DEFAULT_ORBIT[1]:g}°) about the models' "
                      "bounds; set [camera] orbit = { theta = …, phi = …, radius = … } to choose the view "
                      "(`compare inspect` prints the bounds)", stacklevel=3)
    if camera is None:
        camera = _camera(ctx, cam_raw, lambda: mesh_bounds(subject))
    lights_raw = data.get("lights", [])
    if not isinstance(lights_raw, list):
        raise ctx.err("lights", "expected an array of tables ([[lights]])")
    parsed = [_light(ctx, k, v) for k, v in enumerate(lights_raw)]
    parsed += [light for inc in includes for light in inc.lights]
    lights = tuple(light for light in parsed if isinstance(light, AreaLight))
    punctual = tuple(light for light in parsed if isinstance(light, PunctualLight))
    ctx.files.extend(f for inc in includes for f in inc.files)
    env = _environment(ctx, data["environment"]) if "environment" in data else None
    render = _table(ctx, "render", data.get("render", {}), {"max_depth", "indirect", "probe_grid", "probe_bounces",
                                                            "reference_spp"})
    if "reference_spp" in render:  # a scene's own constant, from before --spp auto measured the spp
        warnings.warn(f"{ctx.path}: render.reference_spp is no longer read: `compare run --spp auto` measures the "
                      "samples per pixel the ground truth needs (--spp-target, --spp-cap)", stacklevel=3)
    max_depth = render.get("max_depth", 16)
    if not (isinstance(max_depth, int) and not isinstance(max_depth, bool) and (max_depth == -1 or max_depth >= 1)):
        raise ctx.err("render.max_depth", f"expected -1 (unbounded) or an integer >= 1, got {_fmt(max_depth)}")
    emissive = any(materials[m.material].is_emissive for m in meshes)
    # A map file or a procedural map counts as emitting; a zero constant or intensity does not.
    env_emits = env is not None and env.intensity > 0 and (env.constant is None or max(env.constant) > 0)
    if not (any(max(lt.radiance) > 0 for lt in lights) or punctual or env_emits or emissive):
        # Every renderer would draw black, and a black image cannot be told from a black ground truth.
        raise ctx.err("lights", "the scene has no light: add [[lights]] with radiance > 0, an [environment] above "
                                "zero or an emissive material")
    files = tuple(sorted(set(ctx.files)))
    indirect, probe_grid, probe_bounces = _indirect(ctx, render)
    return Scene(ctx.path, name, camera, materials, meshes, lights, env, max_depth, files,
                 file_hash=_content_hash(ctx.path, files, data), indirect=indirect, probe_grid=probe_grid,
                 probe_bounces=probe_bounces, punctual=punctual)


def _indirect(ctx: _Ctx, render: dict[str, Any]) -> tuple[str, tuple[int, int, int], int]:
    """The rasterizer's indirect-light fields of ``[render]``: indirect, probe_grid, probe_bounces."""
    indirect = render.get("indirect", "none")
    if indirect not in INDIRECT_MODES:
        raise ctx.err("render.indirect",
                      f"expected one of {', '.join(map(repr, INDIRECT_MODES))}, got {_fmt(indirect)}")
    grid = render.get("probe_grid", list(DEFAULT_PROBE_GRID))
    if not (isinstance(grid, list) and len(grid) == 3
            and all(isinstance(n, int) and not isinstance(n, bool) and 2 <= n <= MAX_PROBES_PER_AXIS for n in grid)):
        raise ctx.err("render.probe_grid", f"expected three integers in [2, {MAX_PROBES_PER_AXIS}] (probes along x, "
                                           f"y, z), got {_fmt(grid)}")
    bounces = render.get("probe_bounces", DEFAULT_PROBE_BOUNCES)
    if not (isinstance(bounces, int) and not isinstance(bounces, bool) and bounces >= 1):
        raise ctx.err("render.probe_bounces", f"expected an integer >= 1, got {_fmt(bounces)}")
    return indirect, (grid[0], grid[1], grid[2]), bounces


def _includes(ctx: _Ctx, raw: Any) -> list:
    """The ``include`` field: one glTF file name, a table, or an array of either (``[[include]]``)."""
    from compare.scene import include as scene_include

    items = raw if isinstance(raw, list) else [raw]
    out = []
    for k, item in enumerate(items):
        where = f"include[{k}]" if isinstance(raw, list) else "include"
        out.append(scene_include.include(ctx, where, {"file": item} if isinstance(item, str) else item))
    return out


def _content_hash(path: Path, files: tuple[Path, ...], data: dict) -> str:
    parts: list[bytes | str] = [repr(_canonical(data))]
    for f in files:
        parts += [f.name, f.read_bytes()]
    return sha256_bytes(*parts)


def _canonical(v: Any) -> Any:
    """Key-sorted form, so the hash ignores formatting and comments but not values."""
    if isinstance(v, dict):
        return tuple((k, _canonical(v[k])) for k in sorted(v))
    if isinstance(v, list):
        return tuple(_canonical(x) for x in v)
    return v


def load_scene(path: str | Path) -> Scene:
    """Load and validate a scene file; raises :class:`SceneError` naming the file and field.

    A ``.glb`` or ``.gltf`` file is a scene by itself, as if a TOML beside it said ``include = "<file>"``:
    its own camera (or an orbit framing it), lights and materials.
    """
    path = Path(path)
    if path.suffix.lower() in (".glb", ".gltf"):
        if not path.is_file():
            raise SceneError(f"{path}: scene file not found")
        try:
            return parse_scene({"include": path.name}, path)
        except SceneError as exc:
            if "has no light" not in str(exc):
                raise
            raise SceneError(f"{path}: the file has no light (no KHR_lights_punctual, no emissive material): "
                             f"light it from a scene file beside it, e.g. include = \"{path.name}\" and an "
                             "[environment] (scenes/README.md)") from None
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise SceneError(f"{path}: scene file not found") from None
    except OSError as exc:
        raise SceneError(f"{path}: cannot read scene file: {exc}") from exc
    try:
        data = tomllib.loads(raw.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise SceneError(f"{path}: not UTF-8 text: {exc}") from exc
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path}: invalid TOML: {exc}") from exc
    try:
        return parse_scene(data, path)
    except CompareError:
        raise
    except (TypeError, ValueError, IndexError, KeyError, AttributeError, OverflowError) as exc:
        # Fields are checked by name where they are read; a value of the wrong TOML type further
        # down (a list where a name belongs) ends here, as one error naming the file.
        raise SceneError(f"{path}: malformed scene ({type(exc).__name__}: {exc}); see scenes/README.md for "
                         "the format") from None
