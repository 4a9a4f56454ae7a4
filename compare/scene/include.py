"""``[[include]]`` of a scene file: a glTF file's meshes, materials, lights and camera as scene objects.

The reader is :mod:`compare.scene.gltf_read`; the objects are :mod:`compare.scene.model`'s;
every error names the scene file and the field (:mod:`compare.scene.fields`).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from compare.scene import geometry
from compare.scene import fields as sf
from compare.scene import model as sm
from compare.scene.geometry import TriangleMesh
from compare.scene.textures import factor_map, texture_problem
from compare.scene.gltf_read import (DEFAULT_CAMERA_WIDTH, DEFAULT_PUNCTUAL_SIZE, WATTS_PER_LUMEN, GltfCamera, GltfError, GltfLight,
                   load_gltf)



@dataclass
class Included:
    """Scene objects made from one ``[[include]]``."""

    materials: dict
    meshes: list
    lights: list
    camera: dict | None
    """Camera fields (position, target, up, fov, resolution) for the TOML ``[camera]`` to fill in from."""
    files: list[Path]
    notes: list[str]
    prefix: str = ""
    """The names' prefix (``[[include]] prefix``), so that a TOML material meant to restyle one can be checked."""


INCLUDE_FIELDS = {"file", "translate", "rotate", "scale", "prefix", "emissive_quads", "punctual", "punctual_size",
                  "light_scale", "camera", "units"}
#: ``units`` of an include: metres per unit of the file (glTF says metres; many downloads are not).
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254, "ft": 0.3048}
#: Sizes (metres across) outside which a model read as metres is probably in other units.
PLAUSIBLE_SIZE = (0.005, 1000.0)


@dataclass(frozen=True)
class _Settings:
    """One ``[[include]]`` table, validated."""

    path: Path
    given: str
    prefix: str
    quads: str
    punctual: str
    punctual_size: float
    light_scale: float
    camera: Any
    xf: np.ndarray
    units: str | None


def include(ctx, where: str, raw: Any) -> Included:
    """Validate one ``[[include]]`` table of a scene file and map its glTF file onto scene objects.

    ``ctx`` is :mod:`compare.scene.loader`'s loading context (file name for messages,
    scene folder for paths); errors name ``where`` and the field.
    """
    st = _settings(ctx, where, raw)
    try:
        # A downloaded file's own URIs stay inside its folder, wherever the scene file put it.
        doc = load_gltf(st.path, root=st.path.parent)
    except GltfError as exc:  # name the file as the scene does, relative to its folder
        raise ctx.err(f"{where}.file", str(exc).replace(str(st.path), st.given, 1)) from exc
    notes = list(doc.warnings)
    materials = _Materials(ctx, where, st, doc)
    meshes, lights = _objects(st, doc, materials, notes)
    camera = _camera(ctx, where, st, doc)
    for note in notes:
        warnings.warn(f"{ctx.path}: {where}: {st.path.name}: {note}", stacklevel=4)
    return Included(materials.made, meshes, lights, camera, [*doc.files], notes, st.prefix)


def _settings(ctx, where: str, raw: Any) -> _Settings:
    t = sf.table(ctx, where, raw, INCLUDE_FIELDS)
    given = sf.require(ctx, where, t, "file")
    path = sf.file_field(ctx, f"{where}.file", given, (".gltf", ".glb"))
    prefix = t.get("prefix", f"{path.stem}/")
    if not isinstance(prefix, str):
        raise ctx.err(f"{where}.prefix", f"expected a string, got {sf.fmt(prefix)}")
    quads = t.get("emissive_quads", "lights")
    if quads not in ("lights", "meshes"):
        raise ctx.err(f"{where}.emissive_quads", f"expected 'lights' or 'meshes', got {sf.fmt(quads)}")
    punctual = t.get("punctual", "lights")
    if punctual not in ("lights", "area", "ignore"):
        raise ctx.err(f"{where}.punctual", f"expected 'lights', 'area' or 'ignore', got {sf.fmt(punctual)}")
    size = sf.number(ctx, f"{where}.punctual_size", t.get("punctual_size", DEFAULT_PUNCTUAL_SIZE), positive=True)
    light_scale = sf.number(ctx, f"{where}.light_scale", t.get("light_scale", WATTS_PER_LUMEN), positive=True)
    cam_sel = t.get("camera", 0)
    if isinstance(cam_sel, bool) and cam_sel:
        cam_sel = 0
    if not (cam_sel is False or isinstance(cam_sel, str) or (isinstance(cam_sel, int) and cam_sel >= 0)):
        raise ctx.err(f"{where}.camera", f"expected a camera name, an index or false, got {sf.fmt(cam_sel)}")
    scale = t.get("scale", [1, 1, 1])
    if isinstance(scale, (int, float)) and not isinstance(scale, bool):
        scale = [scale] * 3
    sv = sf.vector(ctx, f"{where}.scale", scale, 3)
    if any(abs(s) < 1e-12 for s in sv):
        raise ctx.err(f"{where}.scale", f"expected non-zero scale factors, got {sf.fmt(scale)}")
    units = t.get("units")
    if units is not None and units not in UNITS:
        raise ctx.err(f"{where}.units", f"expected one of {', '.join(repr(u) for u in UNITS)}, got {sf.fmt(units)}")
    sv = tuple(v * UNITS[units or "m"] for v in sv)
    xf = geometry.transform_matrix(sf.vector(ctx, f"{where}.translate", t.get("translate", [0, 0, 0]), 3),
                                   sf.vector(ctx, f"{where}.rotate", t.get("rotate", [0, 0, 0]), 3), sv)
    return _Settings(path, given, prefix, quads, punctual, size, light_scale, cam_sel, xf, units)


class _Materials:
    """The scene model's materials of a glTF document's, made as primitives name them."""

    def __init__(self, ctx, where: str, st: _Settings, doc):
        self.ctx, self.where, self.st, self.doc = ctx, where, st, doc
        self.made: dict[str, Any] = {}

    def name(self, index: int | None) -> str:
        """The scene material of glTF material ``index`` (None: glTF's default material), made on first use."""
        doc, prefix, made = self.doc, self.st.prefix, self.made
        if index is None:
            name = f"{prefix}default"
            made.setdefault(name, sm.Material(name=name, base_color=(1.0, 1.0, 1.0), metallic=1.0, roughness=1.0))
            return name
        if not 0 <= index < len(doc.materials):
            raise self.ctx.err(f"{self.where}.file", f"{self.st.given}: primitive material index {index} out of range")
        m = doc.materials[index]
        same = [i for i, o in enumerate(doc.materials) if o.name == m.name]
        name = f"{prefix}{m.name}" + (f"#{index}" if len(same) > 1 else "")
        if name not in made:
            made[name] = self._material(name, index, m)
        return name

    def _texture(self, index: int, i: int | None) -> Path | None:
        doc = self.doc
        path = doc.images[i] if i is not None and 0 <= i < len(doc.images) else None
        problem = texture_problem(path) if path is not None else None
        if problem:
            raise self.ctx.err(f"{self.where}.file", f"{self.st.given}: materials[{index}]: image {i}: {problem}")
        return path

    def _material(self, name: str, index: int, m):
        tex = lambda i: self._texture(index, i)  # noqa: E731
        base_map, mr_map = tex(m.base_color_image), tex(m.metallic_roughness_image)
        # glTF multiplies a map by its factor; in the scene model a map replaces it: a factor other
        # than 1 is baked into the map
        if base_map is not None and any(c != 1.0 for c in m.base_color):
            base_map = factor_map(base_map, m.base_color, srgb=True)
        if mr_map is not None and (m.metallic, m.roughness) != (1.0, 1.0):
            mr_map = factor_map(mr_map, (1.0, m.roughness, m.metallic), srgb=False)
        return sm.Material(name=name, base_color=m.base_color, metallic=m.metallic, roughness=m.roughness,
                           emission=m.emission, base_color_texture=base_map, metallic_roughness_texture=mr_map,
                           emissive_texture=tex(m.emissive_image), occlusion_texture=tex(m.occlusion_image),
                           occlusion_strength=m.occlusion_strength, normal_texture=tex(m.normal_image),
                           normal_scale=m.normal_scale, alpha_mode=m.alpha_mode, alpha=m.alpha,
                           alpha_cutoff=m.alpha_cutoff, double_sided=m.double_sided, map_sampling=m.sampling,
                           **m.layers,
                           layer_maps=tuple((f, c, tex(i)) for f, c, i in m.layer_images if tex(i) is not None),
                           clearcoat_normal_texture=tex(m.clearcoat_normal_image),
                           clearcoat_normal_scale=m.clearcoat_normal_scale)


def _objects(st: _Settings, doc, materials: _Materials, notes: list[str]) -> tuple[list, list]:
    """The document's meshes and lights: emissive rectangles and punctual lights as area lights."""
    meshes, lights = [], []
    used: dict[str, int] = {}
    for prim in doc.primitives:
        mat = materials.name(prim.material)
        matrix = st.xf @ prim.matrix
        base = f"{st.prefix}{prim.name}"
        used[base] = used.get(base, 0) + 1
        name = base if used[base] == 1 else f"{base}#{used[base]}"
        problem = geometry.reach_problem(matrix, prim.mesh)  # after the include's own transform (its units)
        if problem:  # at load, not in a renderer: one error naming the file and the part
            raise GltfError(f"{st.path}: {prim.name}: its vertices reach {problem}")
        # "include_matrix": the include's own transform (its units, placement), for a renderer that reads the file
        # itself (Blender's glTF importer) and places it as the scene does
        mesh = sm.Mesh(name=name, shape="gltf", material=mat, params={"triangles": prim.mesh, "include_matrix": st.xf},
                       transform=matrix, file=st.path)
        # A light has one radiance: a quad whose emission has a map stays a mesh (its map is drawn).
        material = materials.made[mat]
        unlit = prim.material is not None and doc.materials[prim.material].unlit
        light_like = material.is_emissive and material.emissive_texture is None and not unlit
        rect = _emissive_rectangle(mesh.triangles()) if st.quads == "lights" and light_like else None
        if rect is None:
            meshes.append(mesh)
        else:
            center, rsize, normal, tangent = rect
            light, note = sm.floored_light(sm.AreaLight(name, center, rsize, normal, tangent, material.emission))
            lights.append(light)
            if note:
                notes.append(note)
    if st.units is None and doc.primitives:
        boxes = np.array([geometry.world_bounds(st.xf @ p.matrix, p.mesh) for p in doc.primitives])  # (n, lo/hi, 3)
        lo, hi = boxes[:, 0].min(0), boxes[:, 1].max(0)
        note = units_note(float(np.max(hi - lo)))
        if note:
            notes.append(note)
    if st.punctual != "ignore":
        world_scale = abs(np.linalg.det(st.xf[:3, :3])) ** (1.0 / 3.0)
        for light in doc.lights:
            made = _punctual_light(light, st.xf, st.punctual_size * world_scale, st.light_scale, st.prefix, notes)
            if made is not None:
                lights.extend(made.stand_ins() if st.punctual == "area" else [made])
                if st.punctual == "area" and made.kind == "directional":
                    notes.append(f"directional light {light.name!r} skipped (punctual = 'area' has no stand-in "
                                 "for it)")
    elif doc.lights:
        notes.append(f"{len(doc.lights)} KHR_lights_punctual light(s) ignored (punctual = 'ignore')")
    return meshes, lights


def units_note(size: float) -> str | None:
    """A note suggesting ``units`` when a model ``size`` metres across is implausible for metres, else None."""
    if PLAUSIBLE_SIZE[0] <= size <= PLAUSIBLE_SIZE[1] or not size > 0:  # 0: degenerate, not mis-scaled
        return None
    return (f"the model is {size:.4g} m across when read as metres (glTF's unit); if it was authored in other "
            f"units, set units = \"cm\", \"mm\" or \"in\" in its [[include]] (it would be {size * UNITS['cm']:.3g} m, "
            f"{size * UNITS['mm']:.3g} m or {size * UNITS['in']:.3g} m across)")


def _camera(ctx, where: str, st: _Settings, doc) -> dict | None:
    """The camera fields of the glTF camera the table selects, or None."""
    cam_sel = st.camera
    if cam_sel is False or not doc.cameras:
        return None
    if isinstance(cam_sel, str):
        found = [c for c in doc.cameras if c.name == cam_sel]
        if not found:
            raise ctx.err(f"{where}.camera", f"no camera named {cam_sel!r} in {st.path.name} "
                                             f"(cameras: {', '.join(c.name for c in doc.cameras)})")
        cam = found[0]
    elif cam_sel < len(doc.cameras):
        cam = doc.cameras[cam_sel]
    else:
        raise ctx.err(f"{where}.camera", f"index {cam_sel} out of range ({len(doc.cameras)} camera(s))")
    return _camera_fields(cam, st.xf)


def _camera_fields(cam: GltfCamera, xf: np.ndarray) -> dict:
    m = xf @ cam.matrix
    pos = m[:3, 3]
    fwd = m[:3, :3] @ np.array([0.0, 0.0, -1.0])
    up = m[:3, :3] @ np.array([0.0, 1.0, 0.0])
    fwd /= np.linalg.norm(fwd)
    up /= np.linalg.norm(up)
    width = DEFAULT_CAMERA_WIDTH
    height = max(1, round(width / cam.aspect)) if cam.aspect else 240
    return {"position": [float(x) for x in pos], "target": [float(x) for x in pos + fwd],
            "up": [float(x) for x in up], "fov": math.degrees(cam.yfov), "resolution": [width, height]}


def _emissive_rectangle(tri: TriangleMesh):
    """(center, size, normal, tangent) if the two triangles form one planar rectangle, else None.

    The normal follows the first triangle's winding (its front face); the tangent is the first side of
    the first triangle in vertex order (for a quad drawn as (0, 1, 2), (0, 2, 3) that is corner 0 → 1).
    """
    if tri.triangle_count != 2:
        return None
    p = tri.positions.astype(np.float64)
    (ia, ib, ic), second = tri.indices[0], tri.indices[1]
    a, b, c = p[ia], p[ib], p[ic]
    edges = [b - a, c - b, a - c]
    lengths = [float(np.linalg.norm(e)) for e in edges]
    k = int(np.argmax(lengths))  # the hypotenuse
    e0, e1 = edges[(k + 1) % 3], edges[(k + 2) % 3]
    l0, l1 = lengths[(k + 1) % 3], lengths[(k + 2) % 3]
    scale = lengths[k]
    if min(l0, l1) < 1e-9 * max(scale, 1e-300) or abs(e0 @ e1) > 1e-5 * l0 * l1:
        return None
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n)
    ends = [(a, b), (b, c), (c, a)][k]
    right = [c, a, b][k]
    d = ends[0] + ends[1] - right
    q = p[second]
    known = np.array([a, b, c, d])
    dist = np.linalg.norm(q[:, None, :] - known[None, :, :], axis=-1).min(1)
    if dist.max() > 1e-5 * scale or not np.any(np.linalg.norm(q - d, axis=1) < 1e-5 * scale):
        return None
    if np.cross(q[1] - q[0], q[2] - q[0]) @ n <= 0:  # the second triangle must face the same way
        return None
    center = 0.5 * (ends[0] + ends[1])
    return (tuple(float(x) for x in center), (l0, l1), tuple(float(x) for x in n),
            tuple(float(x) for x in e0 / l0))


def _punctual_light(light: GltfLight, xf: np.ndarray, side: float, light_scale: float, prefix: str,
                    notes: list[str]):
    """The scene's :class:`~compare.scene.model.PunctualLight` of a glTF light (None if it emits nothing)."""
    m = xf @ light.matrix
    intensity = np.asarray(light.color) * light.intensity * light_scale  # W/sr, or W/m² for a directional light
    if not np.all(np.isfinite(intensity)) or max(intensity) <= 0 or min(intensity) < 0:
        notes.append(f"light {light.name!r} has colour × intensity {intensity.tolist()}: skipped (lights must be "
                     "finite, non-negative and emit something)")
        return None
    d = m[:3, :3] @ np.array([0.0, 0.0, -1.0])  # a glTF light shines down its node's -Z
    peak = float(np.max(np.abs(d)))
    # a point light under a zero scale has no direction and needs none (the reader refuses the others)
    d = d / peak / np.linalg.norm(d / peak) if peak > 0 else np.array([0.0, 0.0, -1.0])
    return sm.PunctualLight(f"{prefix}{light.name}", light.kind, tuple(float(x) for x in m[:3, 3]),
                            tuple(float(x) for x in d), tuple(float(x) for x in intensity),
                            math.degrees(light.inner_cone), math.degrees(light.outer_cone), light.range, side)


