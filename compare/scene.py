"""The neutral scene model every renderer reads, loaded from TOML.

A scene file is data: nothing in it is executed, every path in it is resolved
relative to the file and refused if it leaves the file's folder, and every
error names the file and the field, e.g.::

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
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from . import geometry
from .errors import MissingComponentError, SceneError
from .fsutil import sha256_bytes

MESH_SHAPES = ("quad", "box", "sphere", "cylinder", "file")
MESH_FILE_SUFFIXES = (".ply", ".obj")
TEXTURE_SUFFIXES = (".png", ".jpg", ".jpeg", ".exr")
ENV_FILE_SUFFIXES = (".exr", ".hdr")
#: A material counts as glossy (needs specular lighting work) below this roughness, or when metallic.
GLOSSY_ROUGHNESS = 0.6
#: Indirect diffuse light in the rasterizer: none (the paper's technique) or an irradiance volume.
INDIRECT_MODES = ("none", "probes")
#: Default probes per axis and bounces of the irradiance volume (compare.progressive.probes).
DEFAULT_PROBE_GRID = (6, 6, 6)
DEFAULT_PROBE_BOUNCES = 2
#: Largest number of probes along one axis (keeps the volume's textures small).
MAX_PROBES_PER_AXIS = 64


@dataclass(frozen=True)
class Camera:
    """Pinhole camera: position, look-at target, up vector, vertical FOV in degrees, resolution (w, h)."""

    position: tuple[float, float, float]
    target: tuple[float, float, float]
    up: tuple[float, float, float] = (0.0, 1.0, 0.0)
    fov: float = 45.0
    resolution: tuple[int, int] = (320, 240)

    @property
    def width(self) -> int:
        return self.resolution[0]

    @property
    def height(self) -> int:
        return self.resolution[1]

    @property
    def aspect(self) -> float:
        return self.resolution[0] / self.resolution[1]

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Orthonormal (right, up, forward) in world space; image x grows along right."""
        f = np.subtract(self.target, self.position).astype(np.float64)
        f /= np.linalg.norm(f)
        r = np.cross(f, self.up)
        r /= np.linalg.norm(r)
        u = np.cross(r, f)
        return r, u, f

    def ray_directions(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Unit world directions through continuous film positions (x right, y down, in pixels).

        Pixel (i, j) covers [i, i+1) × [j, j+1) with row 0 at the top, as in
        Mitsuba's film and the rasterizer's readback.
        """
        r, u, f = self.basis()
        t = math.tan(math.radians(self.fov) / 2)
        sx = (2 * np.asarray(x, dtype=np.float64) / self.width - 1) * t * self.aspect
        sy = (1 - 2 * np.asarray(y, dtype=np.float64) / self.height) * t
        d = f + sx[..., None] * r + sy[..., None] * u
        return d / np.linalg.norm(d, axis=-1, keepdims=True)

    def view_matrix(self) -> np.ndarray:
        """World → camera (OpenGL convention: camera looks down −Z, +Y up, +X right)."""
        r, u, f = self.basis()
        m = np.eye(4)
        m[0, :3], m[1, :3], m[2, :3] = r, u, -f
        m[:3, 3] = -m[:3, :3] @ np.asarray(self.position, dtype=np.float64)
        return m

    def projection_matrix(self, near: float, far: float, jitter: tuple[float, float] = (0.0, 0.0)) -> np.ndarray:
        """OpenGL perspective projection; ``jitter`` is a sub-pixel offset in pixels (x right, y up).

        Jitter (0, 0) puts pixel centres at (i + 0.5, j + 0.5), the same
        convention as Mitsuba's film.
        """
        t = 1.0 / math.tan(math.radians(self.fov) / 2)
        m = np.zeros((4, 4))
        m[0, 0] = t / self.aspect
        m[1, 1] = t
        m[2, 2] = (far + near) / (near - far)
        m[2, 3] = 2 * far * near / (near - far)
        m[3, 2] = -1.0
        # A shift of d pixels is 2d/width in NDC; added to clip x as 2d/width · w_clip.
        m[0, 2] = -2.0 * jitter[0] / self.width
        m[1, 2] = -2.0 * jitter[1] / self.height
        return m


@dataclass(frozen=True)
class Material:
    """glTF 2.0 metallic-roughness material (linear base colour, perceptual roughness)."""

    name: str
    base_color: tuple[float, float, float] = (0.8, 0.8, 0.8)
    metallic: float = 0.0
    roughness: float = 0.5
    emission: tuple[float, float, float] = (0.0, 0.0, 0.0)
    base_color_texture: Path | None = None
    metallic_roughness_texture: Path | None = None

    @property
    def is_emissive(self) -> bool:
        return max(self.emission) > 0.0

    @property
    def is_glossy(self) -> bool:
        return self.metallic > 0.0 or self.roughness < GLOSSY_ROUGHNESS


@dataclass(frozen=True)
class Mesh:
    """One mesh: a primitive or a file, a transform and a material name."""

    name: str
    shape: str
    material: str
    params: dict[str, Any]
    transform: np.ndarray = field(default_factory=lambda: np.eye(4), compare=False)
    file: Path | None = None

    def triangles(self) -> geometry.TriangleMesh:
        """World-space triangles of this mesh."""
        p = self.params
        if self.shape == "quad":
            local = geometry.quad_from_corners(p["corners"]) if "corners" in p else geometry.quad(p["size"])
        elif self.shape == "box":
            local = geometry.box(p["size"])
        elif self.shape == "sphere":
            local = geometry.sphere(p["radius"], p.get("segments", 64), p.get("rings", 32))
        elif self.shape == "cylinder":
            local = geometry.cylinder(p["radius"], p["height"], p.get("segments", 64))
        elif self.shape == "gltf":  # made by an [[include]]: triangles in the glTF node's frame
            local = p["triangles"]
        else:
            assert self.file is not None
            local = geometry.load_ply(self.file) if self.file.suffix.lower() == ".ply" else geometry.load_obj(self.file)
        return local.transformed(self.transform)


@dataclass(frozen=True)
class AreaLight:
    """A one-sided rectangular area light emitting along ``normal``.

    ``tangent`` is the direction of the first side (``size[0]``); the second
    side runs along ``bitangent = normal × tangent``, so that
    tangent × bitangent = normal.
    """

    name: str
    center: tuple[float, float, float]
    size: tuple[float, float]
    normal: tuple[float, float, float]
    tangent: tuple[float, float, float]
    radiance: tuple[float, float, float]

    @property
    def area(self) -> float:
        return self.size[0] * self.size[1]

    @property
    def bitangent(self) -> np.ndarray:
        return np.cross(self.normal, self.tangent)

    @property
    def power(self) -> np.ndarray:
        """Emitted power Φ = π·A·L per channel (Lambertian, one-sided)."""
        return math.pi * self.area * np.asarray(self.radiance)

    def corners(self) -> np.ndarray:
        """Four corners (4, 3), counter-clockwise seen from the lit side."""
        c = np.asarray(self.center, dtype=np.float64)
        du = np.asarray(self.tangent) * self.size[0] / 2
        dv = self.bitangent * self.size[1] / 2
        return np.array([c - du - dv, c + du - dv, c + du + dv, c - du + dv])


@dataclass(frozen=True)
class Environment:
    """Distant environment light: a constant radiance, an equirectangular map file, a procedural
    map or one of Blender's studio-light HDRIs (exactly one; see :mod:`compare.environments`).

    ``rotation`` turns the map about +Y by that many degrees; ``intensity`` scales it.
    """

    constant: tuple[float, float, float] | None = None
    file: Path | None = None
    intensity: float = 1.0
    rotation: float = 0.0
    procedural: str | None = None
    """``"sky"``, ``"studio"`` or ``"axes"`` (:data:`compare.environments.PROCEDURAL`)."""
    parameters: tuple[tuple[str, Any], ...] = ()
    """The procedural map's parameters, complete (defaults filled in), sorted by name."""
    blender: str | None = None
    """Name of a Blender studio light (``"interior"``, ``"courtyard"``, ...)."""


@dataclass(frozen=True)
class Features:
    """What a scene needs, so renderers and reports can leave out the rest."""

    environment: bool
    area_lights: bool
    glossy: bool
    metallic: bool
    textures: bool
    emissive_meshes: bool

    def names(self) -> list[str]:
        """Names of the features present."""
        return [f.name for f in dataclasses.fields(self) if getattr(self, f.name)]

    def omitted(self) -> dict[str, str]:
        """Work a renderer can skip, with the reason (for reports)."""
        out = {}
        if not self.environment:
            out["environment lighting (IBL prefiltering, env samples, occlusion)"] = "the scene has no environment"
        if not self.area_lights:
            out["area-light shadow maps and direct-light samples"] = "the scene has no area lights"
        if not self.textures:
            out["texture upload and sampling"] = "no material uses a texture"
        return out


@dataclass(frozen=True)
class Scene:
    """A validated scene. Build it with :func:`load_scene`."""

    path: Path
    name: str
    camera: Camera
    materials: dict[str, Material]
    meshes: tuple[Mesh, ...]
    lights: tuple[AreaLight, ...]
    environment: Environment | None
    max_depth: int
    referenced_files: tuple[Path, ...]
    file_hash: str
    # Rasterizer-only options ([render] table): they do not change the reference's pixels,
    # so they stay out of :attr:`hash` beyond the file's own bytes (which carry them).
    indirect: str = "none"
    """Indirect diffuse light of the rasterizer: ``"none"`` or ``"probes"`` (an irradiance volume)."""
    probe_grid: tuple[int, int, int] = DEFAULT_PROBE_GRID
    """Probes along x, y, z of the irradiance volume (each >= 2)."""
    probe_bounces: int = DEFAULT_PROBE_BOUNCES
    """Diffuse bounces baked into the irradiance volume (>= 1)."""

    def features(self) -> Features:
        """What this scene needs (environment, area lights, glossy materials, textures, ...)."""
        used = [self.materials[m.material] for m in self.meshes]
        return Features(
            environment=self.environment is not None,
            area_lights=bool(self.lights),
            glossy=any(m.is_glossy for m in used),
            metallic=any(m.metallic > 0 for m in used),
            textures=any(m.base_color_texture or m.metallic_roughness_texture for m in used),
            emissive_meshes=any(m.is_emissive for m in used),
        )

    @cached_property
    def hash(self) -> str:
        """Stable content hash of the scene file, every file it references and any overrides."""
        return sha256_bytes(self.file_hash, repr(self.camera.resolution), str(self.max_depth))

    def with_resolution(self, width: int, height: int) -> "Scene":
        """The same scene rendered at another resolution."""
        if width < 1 or height < 1:
            raise SceneError(f"{self.path}: camera.resolution: expected two positive integers, got [{width}, {height}]")
        cam = dataclasses.replace(self.camera, resolution=(int(width), int(height)))
        return dataclasses.replace(self, camera=cam)

    def with_max_depth(self, max_depth: int) -> "Scene":
        """The same scene with another path depth for the reference (2 = direct light only)."""
        return dataclasses.replace(self, max_depth=int(max_depth))

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """World-space axis-aligned bounds (min, max) of all meshes."""
        lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
        for m in self.meshes:
            p = m.triangles().positions
            lo, hi = np.minimum(lo, p.min(0)), np.maximum(hi, p.max(0))
        return lo, hi

    def extent(self) -> tuple[np.ndarray, np.ndarray]:
        """World-space axis-aligned bounds (min, max) of every mesh and light rectangle."""
        lo, hi = self.bounds()
        for light in self.lights:
            c = light.corners()
            lo, hi = np.minimum(lo, c.min(0)), np.maximum(hi, c.max(0))
        return lo, hi


# ----------------------------------------------------------------------------- loading


class _Ctx:
    """Carries the file name for error messages and the scene folder for paths."""

    def __init__(self, path: Path):
        self.path = path
        self.root = path.parent.resolve()
        self.files: list[Path] = []

    def err(self, where: str, msg: str) -> SceneError:
        return SceneError(f"{self.path}: {where}: {msg}")


def _fmt(value: Any) -> str:
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, list):
        return "[" + ", ".join(_fmt(v) for v in value) + "]"
    if isinstance(value, dict):
        return "a table"
    return str(value)


#: Smallest normal and largest float32 numbers: every renderer computes in float32, where a scene
#: number outside this range (other than 0) turns into 0 or infinity.
_FLOAT32_TINY = 1.1754944e-38
_FLOAT32_MAX = 3.4028235e38


def _float32_problem(v: float) -> str | None:
    """Why ``v`` cannot be carried by float32 (None if it can)."""
    if v != 0 and abs(v) < _FLOAT32_TINY:
        return f"{v:g} is below float32's smallest normal number (1.2e-38): every renderer would compute 0"
    if abs(v) > _FLOAT32_MAX:
        return f"{v:g} is beyond float32's range (3.4e38): every renderer would compute infinity"
    return None


def _number(ctx: _Ctx, where: str, v: Any, *, lo: float | None = None, hi: float | None = None,
            positive: bool = False) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ctx.err(where, f"expected a finite number, got {_fmt(v)}")
    problem = _float32_problem(float(v))
    if problem:
        raise ctx.err(where, problem)
    if positive and v <= 0:
        raise ctx.err(where, f"expected a positive number, got {_fmt(v)}")
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        rng = (f"in [{lo:g}, {hi:g}]" if lo is not None and hi is not None
               else f"at most {hi:g}" if hi is not None else f"at least {lo:g}")
        raise ctx.err(where, f"expected a number {rng}, got {_fmt(v)}")
    return float(v)


def _vector(ctx: _Ctx, where: str, v: Any, n: int, *, positive: bool = False, nonnegative: bool = False,
            lo: float | None = None, hi: float | None = None) -> tuple[float, ...]:
    words = {2: "two", 3: "three", 4: "four"}[n]
    kind = "positive " if positive else "non-negative " if nonnegative else ""
    ok = (isinstance(v, list) and len(v) == n
          and all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in v))
    if ok and positive:
        ok = all(x > 0 for x in v)
    if ok and nonnegative:
        ok = all(x >= 0 for x in v)
    if ok and (lo is not None or hi is not None):
        ok = all((lo is None or x >= lo) and (hi is None or x <= hi) for x in v)
    if not ok:
        rng = (f" in [{lo:g}, {hi:g}]" if lo is not None and hi is not None
               else f" at most {hi:g}" if hi is not None else f" at least {lo:g}" if lo is not None else "")
        raise ctx.err(where, f"expected {words} {kind}numbers{rng}, got {_fmt(v)}")
    for x in v:
        problem = _float32_problem(float(x))
        if problem:
            raise ctx.err(where, problem)
    return tuple(float(x) for x in v)


def _color(ctx: _Ctx, where: str, v: Any, *, hi: float | None = None) -> tuple[float, float, float]:
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        v = [v, v, v]
    return _vector(ctx, where, v, 3, nonnegative=True, hi=hi)  # type: ignore[return-value]


def _unit(ctx: _Ctx, where: str, v: Any) -> np.ndarray:
    vec = np.asarray(_vector(ctx, where, v, 3))
    length = np.linalg.norm(vec)
    if length < 1e-12:
        raise ctx.err(where, f"expected a non-zero direction, got {_fmt(v)}")
    return vec / length


def _table(ctx: _Ctx, where: str, v: Any, allowed: set[str]) -> dict[str, Any]:
    if not isinstance(v, dict):
        raise ctx.err(where, f"expected a table, got {_fmt(v)}")
    unknown = sorted(set(v) - allowed)
    if unknown:
        raise ctx.err(f"{where}.{unknown[0]}" if where else unknown[0],
                      f"unknown field (allowed: {', '.join(sorted(allowed))})")
    return v


def _require(ctx: _Ctx, where: str, table: dict, key: str) -> Any:
    if key not in table:
        raise ctx.err(f"{where}.{key}" if where else key, "missing required field")
    return table[key]


def _file(ctx: _Ctx, where: str, v: Any, suffixes: tuple[str, ...]) -> Path:
    if not isinstance(v, str) or not v:
        raise ctx.err(where, f"expected a file path (string), got {_fmt(v)}")
    p = Path(v)
    if p.is_absolute():
        raise ctx.err(where, f"path {v!r} is absolute; give it relative to the scene file's folder")
    full = (ctx.root / p).resolve()
    if not full.is_relative_to(ctx.root):
        raise ctx.err(where, f"path {v!r} leaves the scene file's folder {ctx.root}")
    if full.suffix.lower() not in suffixes:
        raise ctx.err(where, f"{v!r}: unsupported file type (expected one of {', '.join(suffixes)})")
    if not full.is_file():
        raise ctx.err(where, f"file {v!r} not found (looked for {full})")
    ctx.files.append(full)
    return full


def _camera(ctx: _Ctx, raw: Any) -> Camera:
    t = _table(ctx, "camera", raw, {"position", "target", "up", "fov", "resolution"})
    pos = _vector(ctx, "camera.position", _require(ctx, "camera", t, "position"), 3)
    target = _vector(ctx, "camera.target", _require(ctx, "camera", t, "target"), 3)
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
    fov = _number(ctx, "camera.fov", t.get("fov", 45.0))
    if not 0 < fov < 180:
        raise ctx.err("camera.fov", f"expected a vertical field of view in degrees in (0, 180), got {_fmt(t['fov'])}")
    res = t.get("resolution", [320, 240])
    if not (isinstance(res, list) and len(res) == 2 and all(isinstance(x, int) and not isinstance(x, bool) and x > 0
                                                            for x in res)):
        raise ctx.err("camera.resolution", f"expected two positive integers, got {_fmt(res)}")
    return Camera(pos, target, up, fov, (res[0], res[1]))  # type: ignore[arg-type]


def _material(ctx: _Ctx, name: str, raw: Any) -> Material:
    w = f"materials.{name}"
    t = _table(ctx, w, raw, {"base_color", "metallic", "roughness", "emission", "base_color_texture",
                             "metallic_roughness_texture"})
    return Material(
        name=name,
        base_color=_color(ctx, f"{w}.base_color", t.get("base_color", [0.8, 0.8, 0.8]), hi=1.0),
        metallic=_number(ctx, f"{w}.metallic", t.get("metallic", 0.0), lo=0.0, hi=1.0),
        roughness=_number(ctx, f"{w}.roughness", t.get("roughness", 0.5), lo=0.0, hi=1.0),
        emission=_color(ctx, f"{w}.emission", t.get("emission", [0, 0, 0])),
        base_color_texture=(_file(ctx, f"{w}.base_color_texture", t["base_color_texture"], TEXTURE_SUFFIXES)
                            if "base_color_texture" in t else None),
        metallic_roughness_texture=(_file(ctx, f"{w}.metallic_roughness_texture", t["metallic_roughness_texture"],
                                          TEXTURE_SUFFIXES) if "metallic_roughness_texture" in t else None),
    )


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


def _light(ctx: _Ctx, k: int, raw: Any) -> AreaLight:
    w = f"lights[{k}]"
    t = _table(ctx, w, raw, {"name", "type", "center", "size", "normal", "tangent", "radiance", "power"})
    kind = t.get("type", "rect")
    if kind != "rect":
        raise ctx.err(f"{w}.type", f"only rectangular area lights ('rect') are supported, got {_fmt(kind)}")
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
    return AreaLight(name, center, size, tuple(normal), tuple(tangent), radiance)  # type: ignore[arg-type]


def _environment(ctx: _Ctx, raw: Any) -> Environment:
    from . import environments  # the procedural maps and Blender's HDRIs

    sources = ("constant", "file", "procedural", "blender")
    kind = raw.get("procedural") if isinstance(raw, dict) else None
    params = set(environments.PROCEDURAL[kind][0]) if kind in environments.PROCEDURAL else set()
    t = _table(ctx, "environment", raw, {*sources, "intensity", "rotation"} | params)
    if sum(k in t for k in sources) != 1:
        raise ctx.err("environment", "give exactly one of 'constant' (radiance), 'file' (equirectangular map), "
                                     "'procedural' (\"sky\", \"studio\", \"axes\") or 'blender' (a studio-light name)")
    constant = _color(ctx, "environment.constant", t["constant"]) if "constant" in t else None
    file = _file(ctx, "environment.file", t["file"], ENV_FILE_SUFFIXES) if "file" in t else None
    intensity = _number(ctx, "environment.intensity", t.get("intensity", 1.0), lo=0.0)
    rotation = _number(ctx, "environment.rotation", t.get("rotation", 0.0))
    env = Environment(constant, file, intensity, rotation)
    try:
        if "procedural" in t:
            if kind not in environments.PROCEDURAL:
                raise ValueError(f"procedural: expected one of {', '.join(map(repr, environments.PROCEDURAL))}, "
                                 f"got {_fmt(kind)}")
            full = environments.validate_procedural(kind, {k: t[k] for k in params if k in t})
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
    if included_cam is not None and (cam_raw is None or (isinstance(cam_raw, dict) and "position" not in cam_raw)):
        cam_raw = {**included_cam, **(cam_raw or {})}  # the TOML's own [camera] fields win
    camera = _camera(ctx, cam_raw if cam_raw is not None else _require(ctx, "", data, "camera"))
    mats_raw = data.get("materials", {})
    if not isinstance(mats_raw, dict):
        raise ctx.err("materials", f"expected a table of named materials, got {_fmt(mats_raw)}")
    materials = {n: m for inc in includes for n, m in inc.materials.items()}
    materials.update({n: _material(ctx, n, m) for n, m in mats_raw.items()})  # a TOML material replaces an imported one
    meshes_raw = data.get("meshes", [])
    if not isinstance(meshes_raw, list):
        raise ctx.err("meshes", "expected an array of tables ([[meshes]])")
    meshes = tuple(_mesh(ctx, k, m, materials) for k, m in enumerate(meshes_raw))
    meshes += tuple(m for inc in includes for m in inc.meshes)
    if not meshes:
        raise ctx.err("meshes", "a scene needs at least one mesh")
    lights_raw = data.get("lights", [])
    if not isinstance(lights_raw, list):
        raise ctx.err("lights", "expected an array of tables ([[lights]])")
    lights = tuple(_light(ctx, k, v) for k, v in enumerate(lights_raw))
    lights += tuple(light for inc in includes for light in inc.lights)
    ctx.files.extend(f for inc in includes for f in inc.files)
    env = _environment(ctx, data["environment"]) if "environment" in data else None
    render = _table(ctx, "render", data.get("render", {}), {"max_depth", "indirect", "probe_grid", "probe_bounces"})
    max_depth = render.get("max_depth", 16)
    if not (isinstance(max_depth, int) and not isinstance(max_depth, bool) and (max_depth == -1 or max_depth >= 1)):
        raise ctx.err("render.max_depth", f"expected -1 (unbounded) or an integer >= 1, got {_fmt(max_depth)}")
    emissive = any(materials[m.material].is_emissive for m in meshes)
    # A map file or a procedural map counts as emitting; a zero constant or intensity does not.
    env_emits = env is not None and env.intensity > 0 and (env.constant is None or max(env.constant) > 0)
    if not (any(max(lt.radiance) > 0 for lt in lights) or env_emits or emissive):
        # Every renderer would draw black, and a black image cannot be told from a black ground truth.
        raise ctx.err("lights", "the scene has no light: add [[lights]] with radiance > 0, an [environment] above "
                                "zero or an emissive material")
    files = tuple(sorted(set(ctx.files)))
    indirect, probe_grid, probe_bounces = _indirect(ctx, render)
    return Scene(ctx.path, name, camera, materials, meshes, lights, env, max_depth, files,
                 file_hash=_content_hash(ctx.path, files, data), indirect=indirect, probe_grid=probe_grid,
                 probe_bounces=probe_bounces)


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
    from . import gltf  # deferred: only scenes with includes need it

    items = raw if isinstance(raw, list) else [raw]
    out = []
    for k, item in enumerate(items):
        where = f"include[{k}]" if isinstance(raw, list) else "include"
        out.append(gltf.include(ctx, where, {"file": item} if isinstance(item, str) else item))
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
    """Load and validate a scene file; raises :class:`SceneError` naming the file and field."""
    path = Path(path)
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
    return parse_scene(data, path)
