"""The job file an external renderer receives, and the checkpoint folder it writes back.

The protocol (documented for renderer authors in ``docs/renderers.md``):

* the suite writes a folder with ``job.json`` (:data:`JOB_SCHEMA`), ``scene.gltf``
  (the scene in glTF 2.0: world-space meshes, metallic-roughness materials with
  their textures, the camera) and, for scenes with an environment, ``environment.exr``;
* the renderer writes ``step-<N>.exr`` (linear RGB, the job's size) for every
  checkpoint and ``timings.json`` into ``output_dir``;
* :func:`read_checkpoints` reads them back, checks them and gives the
  checkpoints of a :class:`~compare.renderers.base.Rendering` (``compare
  measure`` reads folders made anywhere the same way).
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
import re
import shutil
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from compare.util.files import write_bytes_atomic, write_text_atomic
from compare.renderers.base import Checkpoint, RendererError, Rendering

__all__ = ["JOB_SCHEMA", "JOB_SCHEMAS", "export_gltf", "read_checkpoints", "step_files", "write_job"]

#: Version of ``job.json``; a change of meaning of any field moves it. 2 adds ``scene.punctual`` (point,
#: spot and directional lights) and their ``KHR_lights_punctual`` in the glTF; a renderer that reads schema 1
#: gets their stand-in squares among ``scene.lights`` instead (:meth:`Renderer.prepare`).
JOB_SCHEMA = 2
JOB_SCHEMAS = (1, 2)
#: glTF's photometric unit: lm per W at 555 nm, by which the glTF's light intensities are the job's × 683.
LUMENS_PER_WATT = 683.0
SPOT_FALLOFF = ("glTF KHR_lights_punctual: clamp((cos t - cos outer) / (cos inner - cos outer), 0, 1)^2, t the "
                "angle from direction")
ORIENTATION = ("u = atan2(x, -z)/(2*pi) wrapped to [0,1), v = acos(y)/pi; row 0 = +Y; the map is turned by "
               "rotation_deg about +Y: a world direction d looks up the map at R^-1 d, with "
               "R = [[c,0,s],[0,1,0],[-s,0,c]], c = cos, s = sin of rotation_deg (Mitsuba's envmap convention)")
_STEP = re.compile(r"step-0*(\d+)\.exr")


def _vec(v) -> list[float]:
    return [float(x) for x in np.asarray(v, dtype=np.float64).ravel()]


def export_gltf(scene, out: Path) -> Path:
    """Write ``scene`` as glTF 2.0 (``.gltf`` with an embedded buffer) beside copies of its textures.

    Meshes are in world space (their nodes have no transform), one material per
    scene material (base colour, metallic, roughness, emission, textures), one
    perspective camera node looking down its −Z. Area lights are not meshes of
    the file: the job lists them (glTF has no rectangular light). Nothing but ``out`` and the copies
    ``texture-<n>.<ext>`` beside it is written, and never over one of the scene's own files.
    """
    from compare.scene.gltf_write import GltfWriter
    from compare.scene.model import LAYER_MAPS, LAYERS

    out = Path(out)
    sources = {Path(p).resolve() for p in _scene_files(scene)}
    if out.resolve() in sources:
        raise RendererError(f"the job's glTF {out} would replace a file of the scene; give the job its own folder")
    out.parent.mkdir(parents=True, exist_ok=True)
    w = GltfWriter(generator="compare job")
    index: dict[str, int] = {}
    textures: dict[Path, int] = {}

    def texture(src: Path, srgb: bool) -> int:
        """The image index of ``src``, copied beside the glTF once; a float map (the scene model's EXR of a
        factor baked into a map) as the 8-bit PNG glTF readers take, sRGB-encoded where the map is a
        colour."""
        png = src.suffix.lower() in (".png", ".jpg", ".jpeg")
        key = src if png else (src, srgb)  # a file glTF readers take is copied once, whatever it is used as
        if key not in textures:
            name = f"texture-{len(textures)}{src.suffix.lower() if png else '.png'}"
            dest = out.parent / name
            if dest.resolve() in sources:  # a job folder inside the model's own: never over its maps
                raise RendererError(f"the job's copy {dest} would replace a map of the scene; give the job "
                                    "its own folder")
            if png:
                shutil.copyfile(src, dest)
            else:
                write_bytes_atomic(dest, _png8(src, srgb=srgb))
            textures[key] = w._add("images", {"uri": name})  # noqa: SLF001 - the writer's own list
        return textures[key]

    samplers: dict[tuple, int] = {}
    from compare.scene.gltf_read import GL_FILTERS, GL_WRAPS

    # glTF's sampler codes, the reader's tables turned around
    gl_wraps, gl_filters = ({v: k for k, v in table.items()} for table in (GL_WRAPS, GL_FILTERS))

    def info(m, which: str, src, srgb: bool = False) -> dict:
        """A texture info of map ``src`` (a colour map if ``srgb``), material ``m``'s map ``which``
        (:meth:`~compare.scene.model.Material.sampling`): its texture coordinate set, sampler and transform."""
        s = m.sampling(which)
        key = (s.wrap, s.filter, s.mipmaps)
        if key not in samplers:
            mag = gl_filters[s.filter]
            # minification as the renderers read it: mip levels (*_MIPMAP_LINEAR) unless the file said otherwise
            minify = {9728: 9986, 9729: 9987}[mag] if s.mipmaps else mag
            samplers[key] = w._add("samplers", {"wrapS": gl_wraps[s.wrap[0]], "wrapT": gl_wraps[s.wrap[1]],  # noqa: SLF001
                                                "magFilter": mag, "minFilter": minify})
        tex = w._add("textures", {"source": texture(Path(src), srgb), "sampler": samplers[key]})  # noqa: SLF001
        out: dict = {"index": tex}
        if s.texcoord:
            out["texCoord"] = s.texcoord
        if s.has_uv_transform:
            out["extensions"] = {"KHR_texture_transform": {"offset": list(s.offset),
                                                           "rotation": math.radians(s.rotation),
                                                           "scale": list(s.scale)}}
            w._use("KHR_texture_transform")  # noqa: SLF001
        return out

    for name, m in scene.materials.items():
        index[name] = w.material(name, m.base_color, m.metallic, m.roughness, m.emission)
        w.doc["materials"][index[name]]["doubleSided"] = bool(m.double_sided)
        pbr = w.doc["materials"][index[name]]["pbrMetallicRoughness"]
        # a map replaces its factor in the scene model; glTF multiplies them: the factor it replaces is 1
        if m.base_color_texture is not None:
            pbr["baseColorTexture"] = info(m, "base_color_texture", m.base_color_texture, srgb=True)
            pbr["baseColorFactor"][:3] = [1.0, 1.0, 1.0]
        if m.metallic_roughness_texture is not None:
            pbr["metallicRoughnessTexture"] = info(m, "metallic_roughness_texture", m.metallic_roughness_texture)
            pbr["metallicFactor"] = pbr["roughnessFactor"] = 1.0
        if m.emissive_texture is not None:
            w.doc["materials"][index[name]]["emissiveTexture"] = info(m, "emissive_texture", m.emissive_texture, srgb=True)
        if m.normal_texture is not None:
            w.doc["materials"][index[name]]["normalTexture"] = {**info(m, "normal_texture", m.normal_texture), "scale": m.normal_scale}
        if m.is_masked:
            pbr["baseColorFactor"][3] = float(m.alpha)
            w.doc["materials"][index[name]].update(alphaMode="MASK", alphaCutoff=float(m.alpha_cutoff))
        if m.alpha_mode == "blend":
            pbr["baseColorFactor"][3] = float(m.alpha)
            w.doc["materials"][index[name]]["alphaMode"] = "BLEND"
        for layer in LAYERS:  # the material extensions, written back as the file had them
            value = getattr(m, layer.field)
            if value != layer.default:
                exts = w.doc["materials"][index[name]].setdefault("extensions", {})
                exts.setdefault(layer.extension, {})[layer.key] = (
                    [float(c) for c in value] if layer.color else float(value))
                w._use(layer.extension)  # noqa: SLF001
        for fld, channel, src in m.layer_maps:  # and the maps that multiply them
            key = next(k for k, (f, _) in LAYER_MAPS.items() if f == fld)
            ext = next(layer.extension for layer in LAYERS if layer.field == fld)
            table = w.doc["materials"][index[name]].setdefault("extensions", {}).setdefault(ext, {})
            table[key] = info(m, fld, src, srgb=channel == "rgb")
            w._use(ext)  # noqa: SLF001
        if m.clearcoat_normal_texture is not None and m.clearcoat > 0.0:
            table = w.doc["materials"][index[name]].setdefault("extensions", {}).setdefault(
                "KHR_materials_clearcoat", {})
            table["clearcoatNormalTexture"] = {**info(m, "clearcoat_normal_texture", m.clearcoat_normal_texture),
                                               "scale": float(m.clearcoat_normal_scale)}
            w._use("KHR_materials_clearcoat")  # noqa: SLF001
        if m.occlusion_texture is not None:
            w.doc["materials"][index[name]]["occlusionTexture"] = {**info(m, "occlusion_texture", m.occlusion_texture),
                                                                   "strength": m.occlusion_strength}
    for mesh in scene.meshes:
        mat = scene.materials[mesh.material]
        tri = mesh.triangles(tangents=mat.normal_mapped, tangent_uv=mat.tangent_uv)
        uvs = tri.uvs is not None and len(tri.uvs) == len(tri.positions)
        w.node(mesh.name, mesh=w.mesh(mesh.name, [(tri, index[mesh.material])], uvs=uvs))
    for light in scene.punctual:  # glTF's units (cd, lux) at 683 lm/W; the node's −Z along the light
        peak = max(light.intensity)
        li = w.light(light.name, light.kind, peak * LUMENS_PER_WATT, tuple(c / peak for c in light.intensity))
        entry = w.doc["extensions"]["KHR_lights_punctual"]["lights"][li]
        if light.kind == "spot":
            entry["spot"] = {"innerConeAngle": math.radians(light.inner_cone),
                             "outerConeAngle": math.radians(light.outer_cone)}
        if light.range is not None:
            entry["range"] = float(light.range)
        w.node(light.name, light=li, matrix=light.node_matrix())
    cam = scene.camera
    m = np.linalg.inv(cam.view_matrix())  # camera → world: glTF cameras look down their −Z, +Y up
    w.node("camera", camera=w.camera("camera", cam.fov, aspect=cam.aspect), matrix=m)
    return w.write(out)


def _png8(src: Path, *, srgb: bool) -> bytes:
    """The map ``src`` (linear floats) as 8-bit PNG bytes, RGBA where it has an alpha below 1."""
    import io

    from compare.image.pillow import Image
    from compare.image.tonemap import srgb_encode
    from compare.scene.textures import load_alpha, load_texture

    rgb = np.clip(load_texture(src, srgb=False).astype(np.float64), 0.0, 1.0)
    if srgb:
        rgb = srgb_encode(rgb)
    alpha = load_alpha(src).astype(np.float64)
    channels = [rgb] if np.all(alpha >= 1.0) else [rgb, alpha[..., None]]
    codes = np.clip(np.rint(np.concatenate(channels, axis=2) * 255.0), 0, 255).astype(np.uint8)
    buf = io.BytesIO()
    Image.fromarray(codes, "RGB" if codes.shape[2] == 3 else "RGBA").save(buf, format="PNG")
    return buf.getvalue()


def _scene_files(scene) -> list[Path]:
    """Every map file a material of ``scene`` names (what the job writer must never write over)."""
    from compare.scene.model import Material

    files: list[Path] = []
    for m in scene.materials.values():
        for f in dataclasses.fields(Material):
            value = getattr(m, f.name)
            if isinstance(value, Path):
                files.append(value)
        files.extend(p for _, _, p in m.layer_maps)
    return files


def write_job(scene, folder: Path, *, renderer: str, unit: str, checkpoints: list[int], seed: int,
              output_dir: Path, cache_dir=None, schema: int = JOB_SCHEMA) -> Path:
    """Write ``job.json`` (of ``schema``), ``scene.gltf`` and the environment into ``folder``; returns the
    job's path. A scene with point, spot or directional lights needs schema 2 (:meth:`Renderer.prepare`
    turns them into area lights for a schema-1 renderer first)."""
    if scene.punctual and schema < 2:
        raise ValueError(f"job schema {schema} has no point, spot or directional lights: prepare the scene first")
    from compare.scene.environments import environment_image
    from compare.image.exr import write_exr

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    gltf = export_gltf(scene, folder / "scene.gltf")
    env = None
    if scene.environment is not None:
        image = environment_image(scene.environment, cache_dir)
        exr = folder / "environment.exr"
        # intensity and rotation stay fields of the job: the map holds the source's pixels
        write_exr(exr, np.asarray(image, dtype=np.float32))
        env = {"file": str(exr.resolve()), "intensity": float(scene.environment.intensity),
               "rotation_deg": float(scene.environment.rotation), "orientation": ORIENTATION,
               # false: the map lights the scene, but a camera ray that hits nothing sees black
               "background": bool(scene.environment.background)}
    cam = scene.camera
    job = {
        "schema": int(schema),
        **({"lumens_per_watt": LUMENS_PER_WATT} if schema >= 2 else {}),
        "renderer": renderer,
        "scene": {
            "name": scene.name,
            "toml": str(Path(scene.path).resolve()),
            "hash": scene.hash,
            "gltf": str(gltf.resolve()),
            "lights": [{"name": l.name, "center": _vec(l.center), "size": _vec(l.size), "normal": _vec(l.normal),
                        "tangent": _vec(l.tangent), "bitangent": _vec(l.bitangent),
                        "corners": [_vec(c) for c in l.corners()], "radiance": _vec(l.radiance),
                        "two_sided": False} for l in scene.lights],
            **({"punctual": [{"name": p.name, "kind": p.kind, "position": _vec(p.position),
                              "direction": _vec(p.direction), "intensity": _vec(p.intensity),
                              "intensity_unit": "W/m^2" if p.kind == "directional" else "W/sr",
                              "inner_cone_deg": float(p.inner_cone), "outer_cone_deg": float(p.outer_cone),
                              "range": p.range, "falloff": SPOT_FALLOFF if p.kind == "spot" else None}
                             for p in scene.punctual]} if schema >= 2 else {}),
            "environment": env,
            "max_depth": int(scene.max_depth),
        },
        "camera": {"position": _vec(cam.position), "target": _vec(cam.target), "up": _vec(cam.up),
                   "fov_deg": float(cam.fov), "width": int(cam.width), "height": int(cam.height)},
        "checkpoints": [int(c) for c in checkpoints],
        "unit": unit,
        "seed": int(seed),
        "output_dir": str(Path(output_dir).resolve()),
    }
    path = folder / "job.json"
    _check_job(job, path)
    write_text_atomic(path, json.dumps(job, indent=1))
    return path


@functools.cache
def _job_validator():
    import jsonschema

    schema = (resources.files("compare") / "schemas" / "job.schema.json").read_text(encoding="utf-8")
    return jsonschema.Draft202012Validator(json.loads(schema))


def _check_job(job: dict, path: Path) -> None:
    """Refuse a job that breaks compare/schemas/job.schema.json (what a renderer author is promised) with one
    error naming the file and the field, before a renderer reads it."""
    from jsonschema.exceptions import best_match

    error = best_match(_job_validator().iter_errors(job))
    if error is not None:
        where = "".join(f"[{k}]" if isinstance(k, int) else f".{k}" for k in error.absolute_path).lstrip(".")
        raise RendererError(f"{path}: {where or 'the job'}: {error.message} (compare/schemas/job.schema.json)")


def _number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v >= 0


def step_files(folder: Path) -> dict[int, Path]:
    """The checkpoint images of ``folder`` by step (``step-<N>.exr``, N > 0, leading zeros allowed)."""
    found = {}
    for p in Path(folder).glob("step-*.exr"):
        m = _STEP.fullmatch(p.name)
        if m and int(m.group(1)) > 0:
            found[int(m.group(1))] = p
    return dict(sorted(found.items()))


def read_checkpoints(folder: Path, *, who: str, size: tuple[int, int], checkpoints: list[int] | None) -> Rendering:
    """The checkpoints in ``folder`` (``step-<N>.exr`` and ``timings.json``), checked.

    Parameters
    ----------
    who
        How messages name the source (``renderer 'mine'``, ``compare measure``).
    size
        (width, height) every image must have.
    checkpoints
        The steps that must be there; None takes every ``step-<N>.exr`` found.

    Raises
    ------
    RendererError
        A missing or malformed ``timings.json``, a missing checkpoint, an
        unreadable image, one of the wrong size, NaN or infinite pixels.
    """
    from compare.util.errors import ImageError
    from compare.image.exr import read_exr

    folder = Path(folder)
    tpath = folder / "timings.json"
    try:
        timings = json.loads(tpath.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise RendererError(f"{who}: {tpath} is missing (it must hold setup_seconds and seconds per checkpoint)") \
            from None
    except (OSError, ValueError) as exc:
        raise RendererError(f"{who}: {tpath}: not valid JSON ({exc})") from None
    if not isinstance(timings, dict):
        raise RendererError(f"{who}: {tpath}: expected an object with setup_seconds and seconds")
    setup = timings.get("setup_seconds", 0.0)
    if not _number(setup):
        raise RendererError(f"{who}: {tpath}: setup_seconds: expected a finite number >= 0, got {setup!r}")
    seconds = timings.get("seconds")
    if not isinstance(seconds, dict):
        raise RendererError(f"{who}: {tpath}: seconds: expected an object of cumulative seconds by step, "
                            f'e.g. {{"1": 0.01, "2": 0.02}}, got {seconds!r}')
    meta = timings.get("metadata") or {}
    if not isinstance(meta, dict):
        raise RendererError(f"{who}: {tpath}: metadata: expected an object, got {type(meta).__name__}")
    found = step_files(folder)
    steps = sorted(found) if checkpoints is None else list(checkpoints)
    if not steps:
        raise RendererError(f"{who}: {folder} holds no step-<N>.exr checkpoint")
    w, h = size
    out = []
    for step in steps:
        path = found.get(step)
        if path is None:
            raise RendererError(f"{who}: {folder / f'step-{step}.exr'} is missing (every checkpoint of {steps} "
                                "must be written)")
        t = seconds.get(str(step))
        if not _number(t):
            raise RendererError(f"{who}: {tpath}: seconds[\"{step}\"]: expected cumulative seconds (a finite "
                                f"number >= 0), got {t!r}")
        try:
            image, _ = read_exr(path)
        except ImageError as exc:
            raise RendererError(f"{who}: {exc}") from None
        if image.shape[:2] != (h, w):
            raise RendererError(f"{who}: {path.name} is {image.shape[1]}x{image.shape[0]}, the scene is {w}x{h}")
        bad = ~np.isfinite(image).all(axis=-1)
        if bad.any():
            raise RendererError(f"{who}: {path.name}: {int(bad.sum())} pixel(s) are NaN or infinite")
        out.append(Checkpoint(step, float(t), np.ascontiguousarray(image[..., :3], dtype=np.float32)))
    return Rendering(out, float(setup), {str(k): v for k, v in meta.items()})
