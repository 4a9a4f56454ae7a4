"""What a scene or a glTF file holds, for placing a camera and choosing units (``compare inspect``).

Bounds, triangle and material counts, the extensions the file uses and what becomes of each,
its maps with their sizes, its lights and cameras, and a note where the bounds are implausible
for metres. A render-fidelity ``config.json`` lists its scenarios (:mod:`compare.scene.scenarios`).
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Mapping

import numpy as np

__all__ = ["inspect_path", "format_inspection"]


def _bounds(parts) -> tuple[np.ndarray, np.ndarray]:
    """World bounds of (matrix, TriangleMesh) pairs."""
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for matrix, tri in parts:
        if len(tri.positions) == 0:
            continue
        p = tri.positions @ matrix[:3, :3].T + matrix[:3, 3]
        lo, hi = np.minimum(lo, p.min(0)), np.maximum(hi, p.max(0))
    return lo, hi


def _image_size(path: Path | None) -> str:
    """A map's size and kind, or why it cannot be read (an empty or truncated download: inspect says so for
    that map and goes on; a run stops on it with one error naming the material and image)."""
    if path is None:
        return "unusable"
    try:
        if path.suffix.lower() == ".exr":
            from compare.image.exr import read_exr

            h, w = read_exr(path)[0].shape[:2]
            return f"{w}×{h} float"
        from compare.image.pillow import Image

        with Image.open(path) as im:  # the header only
            return f"{im.width}×{im.height} {im.mode}"
    except (OSError, ValueError, SyntaxError) as e:  # Pillow's unreadable-file errors, OpenEXR's
        return f"unreadable ({path.name}: {str(e).replace(str(path), path.name) or type(e).__name__})"


def _gltf_info(path: Path) -> dict:
    from compare.scene.gltf_read import load_gltf

    doc = load_gltf(path)
    roles: dict[int, list[str]] = {}
    for m in doc.materials:
        uses = [(role, getattr(m, f"{role}_image"))
                for role in ("base_color", "metallic_roughness", "normal", "occlusion", "emissive")]
        uses += [(field, i) for field, _, i in m.layer_images]  # the material extensions' maps
        for role, i in uses:
            if i is not None:
                roles.setdefault(i, [])
                if role not in roles[i]:
                    roles[i].append(role)
    lo, hi = _bounds([(p.matrix, p.mesh) for p in doc.primitives])
    info = {
        "file": str(path), "bounds": (lo.tolist(), hi.tolist()),
        "triangles": int(sum(p.mesh.triangle_count for p in doc.primitives)),
        "parts": len(doc.primitives), "materials": len(doc.materials),
        "extensions": doc.extension_fates(),
        "maps": [{"image": i, "size": _image_size(p), "used as": ", ".join(roles.get(i, [])) or "unused"}
                 for i, p in enumerate(doc.images)],
        "lights": [{"name": light.name, "type": light.kind, "color": list(light.color), "intensity": light.intensity}
                   for light in doc.lights],
        "cameras": [c.name for c in doc.cameras],
        "notes": list(doc.warnings),
    }
    from compare.scene.include import units_note

    note = units_note(float(np.max(hi - lo))) if doc.primitives else None
    if note:
        info["notes"].append(note)
    return info


def _scenarios_info(path: Path, known: tuple[str, ...]) -> dict:
    """The scenarios of a render-fidelity ``config.json``: what each renders, without reading its files."""
    from compare.scene.scenarios import load_scenarios

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scenarios = load_scenarios(path)
    rows = []
    for sc in scenarios:
        cam = sc.camera()
        theta, phi, radius = sc.orbit
        rows.append({
            "name": sc.name, "model": sc.given[0], "model_found": sc.model.is_file(),
            "lighting": sc.given[1], "lighting_found": sc.lighting.is_file(),
            "lighting_readable": sc.lighting_readable, "size": [sc.width, sc.height],
            "target": list(sc.target), "orbit": {"theta": theta, "phi": phi, "radius": radius},
            "camera": {"position": list(cam.position), "forward": list(cam.forward), "up": list(cam.up),
                       "fov": cam.fov},
            "render_skybox": sc.render_skybox, "exclude": list(sc.exclude),
            "excluded_renderers": list(sc.suite_excluded(known)), "unavailable": sc.unavailable()})
    return {"file": str(path), "scenarios": rows, "notes": [str(w.message) for w in caught]}


def _features(scene, renders: Mapping[str, frozenset]) -> list[dict]:
    """Each feature beyond the core model that the scene's materials and meshes use, with its materials and
    the renderers (of ``renders``: name → the features it draws) that leave it out."""
    return [{"feature": feature, "materials": len(names),
             "left out by": sorted(name for name, drawn in renders.items() if feature not in drawn)}
            for feature, names in sorted(scene.material_features().items())]


def inspect_path(path: str | Path, renderers: tuple[str, ...] = (),
                 renders: Mapping[str, frozenset] | None = None, *, scenarios: bool | None = None) -> dict:
    """What the scene file (TOML), glTF file or render-fidelity scenario file (``.json``) ``path`` holds, as
    a JSON-ready dict; ``renderers``: the names a scenario's ``exclude`` may match (the registry's);
    ``renders``: renderer name → the features it draws, to say which renderers leave out what the scene
    uses (``features``); ``scenarios``: read ``path`` as a scenario file (True) or not (False) whatever its
    name ends with (None: by its suffix)."""
    path = Path(path)
    if scenarios if scenarios is not None else path.suffix.lower() == ".json":
        return _scenarios_info(path, tuple(renderers))
    if path.suffix.lower() in (".gltf", ".glb"):
        from compare.scene.geometry import MeshFileError
        from compare.util.errors import SceneError

        try:
            info = _gltf_info(path)
        except MeshFileError as exc:  # the message names the file and the JSON path
            raise SceneError(str(exc)) from None
        if renders is not None:
            from compare.scene.loader import parse_scene

            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # _gltf_info's notes say it all once
                # the file as a scene; a sky of its own, as the features do not depend on the light (a file
                # without lights is inspected all the same)
                scene = parse_scene({"include": path.name, "environment": {"constant": [1.0, 1.0, 1.0]}}, path)
                info["features"] = _features(scene, renders)
    else:
        from compare.scene.loader import load_scene

        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            scene = load_scene(path)
        lo, hi = scene.bounds()
        files = sorted({m.file for m in scene.meshes if m.shape == "gltf" and m.file is not None})
        info = {"file": str(path), "bounds": (lo.tolist(), hi.tolist()),
                "triangles": int(sum(m.triangles().triangle_count for m in scene.meshes)),
                "parts": len(scene.meshes), "materials": len(scene.materials),
                "lights": [{"name": light.name, "type": "rectangle", "size": list(light.size)}
                           for light in scene.lights],
                "camera": {"position": list(scene.camera.position), "target": list(scene.camera.target),
                           "fov": scene.camera.fov},
                "includes": [_gltf_info(f) for f in files],
                "notes": [str(w.message) for w in caught]}
        if renders is not None:
            info["features"] = _features(scene, renders)
    return info


def _format_scenarios(info: dict) -> str:
    """The scenario listing of :func:`_scenarios_info` as lines."""
    # rounding residue of the trigonometry (6e-17, -0) printed as the 0 it stands for
    fmt = lambda v: "[" + ", ".join(f"{(x if abs(x) > 1e-12 else 0.0) + 0.0:.4g}" for x in v) + "]"  # noqa: E731
    lines = [f"{info['file']}: {len(info['scenarios'])} scenario(s)"]
    for row in info["scenarios"]:
        o, c = row["orbit"], row["camera"]
        missing = lambda key: "" if row[f"{key}_found"] else "  (not found)"  # noqa: E731
        excluded = ", ".join(row["exclude"]) or "none"
        lines += [f"  {row['name']}",
                  f"    model        {row['model']}{missing('model')}",
                  f"    lighting     {row['lighting']}{missing('lighting')}"
                  + ("" if row["lighting_readable"] else " (not .exr or .hdr: the suite cannot light with it)")
                  + ("" if row["render_skybox"] else " (renderSkybox false)"),
                  f"    size         {row['size'][0]}×{row['size'][1]}",
                  f"    camera       orbit theta {o['theta']:g}°, phi {o['phi']:g}°, radius {o['radius']:g} m about "
                  f"{fmt(row['target'])}: at {fmt(c['position'])} looking along {fmt(c['forward'])}, "
                  f"fov {c['fov']:g}°",
                  f"    exclude      {excluded} (the suite's: {', '.join(row['excluded_renderers']) or 'none'})"]
    total, lacking = len(info["scenarios"]), sum(1 for row in info["scenarios"] if row["unavailable"])
    if lacking:
        why = "a file not found, or lighting the suite does not read"
        lines.append(f"  unavailable  none of the {total} scenario(s) can be rendered here ({why})" if lacking == total
                     else f"  unavailable  {lacking} of {total} scenario(s) cannot be rendered here ({why}); "
                          f"`compare run --skip-unavailable` renders the other {total - lacking}")
    lines += [f"  note         {note}" for note in info.get("notes", [])]
    return "\n".join(lines)


def format_inspection(info: dict, indent: str = "") -> str:
    """``inspect_path``'s dict as the lines ``compare inspect`` prints."""
    if "scenarios" in info:
        return _format_scenarios(info)
    lo, hi = info["bounds"]
    size = np.subtract(hi, lo).tolist()
    fmt = lambda v: "[" + ", ".join(f"{x:.4g}" for x in v) + "]"  # noqa: E731
    lines = [f"{indent}{info['file']}",
             f"{indent}  bounds       {fmt(lo)} … {fmt(hi)} m (size {fmt(size)}, centre "
             f"{fmt((np.add(lo, hi) / 2).tolist())})",
             f"{indent}  triangles    {info['triangles']:,} in {info['parts']} part(s), {info['materials']} material(s)"]
    if "camera" in info:
        c = info["camera"]
        lines.append(f"{indent}  camera       at {fmt(c['position'])} looking at {fmt(c['target'])}, "
                     f"fov {c['fov']:.4g}°")
    if info.get("cameras") is not None:
        lines.append(f"{indent}  cameras      {', '.join(info['cameras']) or 'none (frame one with [camera] orbit)'}")
    for name, fate in info.get("extensions", {}).items():
        lines.append(f"{indent}  extension    {name}: {fate}")
    for m in info.get("maps", []):
        lines.append(f"{indent}  map          image {m['image']}: {m['size']}, {m['used as']}")
    for f in info.get("features", []):
        fate = f"left out by {', '.join(f['left out by'])}" if f["left out by"] else "drawn by every renderer"
        lines.append(f"{indent}  feature      {f['feature']} ({f['materials']} material(s)): {fate}")
    for light in info["lights"]:
        desc = ", ".join(f"{k} {fmt(v) if isinstance(v, list) else v}" for k, v in light.items() if k != "name")
        lines.append(f"{indent}  light        {light['name']}: {desc}")
    for note in info.get("notes", []):
        lines.append(f"{indent}  note         {note}")
    for inc in info.get("includes", []):
        lines.append(format_inspection(inc, indent + "  "))
    return "\n".join(lines)
