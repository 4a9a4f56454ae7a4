"""Which material each pixel sees first: the share of the image a scene feature covers.

A run records what a renderer leaves out of a scene ("transmission not rendered (3 materials,
12 % of the pixels)"); the pixels are those whose camera ray through the pixel centre first hits
a mesh of one of those materials, found by Mitsuba's ray tracer on the reference's own scene.
"""

from __future__ import annotations

import numpy as np

__all__ = ["first_hits", "material_coverage"]


def first_hits(scene) -> np.ndarray:
    """The index into ``scene.meshes`` of the mesh each pixel's centre ray hits first, (H, W) int; −1 for
    none (the background, a light's rectangle)."""
    from compare.mitsuba.bsdf import register
    from compare.mitsuba.scene_dict import scene_dict

    mi = register()
    import drjit as dr

    mi_scene = mi.load_dict(scene_dict(scene, spp=1))
    w, h = scene.camera.width, scene.camera.height
    ys, xs = np.mgrid[0:h, 0:w]
    pos = mi.Point2f(((xs.ravel() + 0.5) / w).astype(np.float32), ((ys.ravel() + 0.5) / h).astype(np.float32))
    sensor = mi_scene.sensors()[0]
    ray, _ = sensor.sample_ray(0.0, 0.5, pos, mi.Point2f(0.5, 0.5))
    si = mi_scene.ray_intersect(ray)
    index = dr.full(mi.Int32, -1, w * h)
    for shape in mi_scene.shapes():
        sid = shape.id()
        if sid.startswith("mesh") and sid[4:].isdigit():
            index = dr.select((si.shape == mi.ShapePtr(shape)) & si.is_valid(), int(sid[4:]), index)
    return np.asarray(index).reshape(h, w)


def material_coverage(scene) -> dict[str, float]:
    """Fraction of the pixels (their centres) whose first hit is each material, by material name."""
    hits = first_hits(scene)
    out: dict[str, float] = {}
    for k, mesh in enumerate(scene.meshes):
        out[mesh.material] = out.get(mesh.material, 0.0) + float(np.count_nonzero(hits == k)) / hits.size
    return out
