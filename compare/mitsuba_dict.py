"""Translate a :class:`compare.scene.Scene` into a Mitsuba 3 scene dictionary.

Two material modes:

``shared``
    the suite's own glTF metallic-roughness BSDF plugin (:mod:`compare.brdf`),
    the same definition the rasterizer evaluates in GLSL, so that
    reference-versus-rasterizer error measures lighting, not materials.
``cycles``
    Mitsuba's ``principled`` BSDF with the same parameters, for references meant
    to look like Blender Cycles (whose Principled BSDF it mirrors).
``diffuse``
    Lambert only (reflectance = base colour), for validation against closed
    forms such as the white furnace, where any specular lobe would get in the way.
"""

from __future__ import annotations

import numpy as np

from .scene import AreaLight, Material, Scene

MATERIAL_MODES = ("shared", "cycles", "diffuse")
#: BSDF plugin name of the shared BRDF (registered by compare.brdf.mitsuba_plugin).
SHARED_BSDF = "gltf_pbr"


def sensor_dict(scene: Scene, *, spp: int, sampler: str = "independent") -> dict:
    """Pinhole sensor with a box pixel filter (pixel (i, j) covers [i, i+1)×[j, j+1))."""
    import mitsuba as mi

    cam = scene.camera
    return {
        "type": "perspective",
        "fov": cam.fov,
        "fov_axis": "y",
        "near_clip": 1e-4,
        "far_clip": 1e6,
        "to_world": mi.ScalarTransform4f().look_at(origin=list(cam.position), target=list(cam.target), up=list(cam.up)),
        "film": {
            "type": "hdrfilm",
            "width": cam.width,
            "height": cam.height,
            "pixel_format": "rgb",
            "component_format": "float32",
            # A box filter is what averaging uniformly jittered frames gives the rasterizer.
            "rfilter": {"type": "box"},
        },
        "sampler": {"type": sampler, "sample_count": int(spp)},
    }


def material_dict(mat: Material, mode: str) -> dict:
    """BSDF dictionary for one material in ``mode`` ('shared' or 'cycles')."""
    base = ({"type": "bitmap", "filename": str(mat.base_color_texture), "raw": False}
            if mat.base_color_texture else {"type": "rgb", "value": list(mat.base_color)})
    if mode == "shared":
        from .brdf.mitsuba_plugin import register

        register()
        return {"type": SHARED_BSDF, "base_color": base, "metallic": mat.metallic, "roughness": mat.roughness}
    if mode == "cycles":
        from .brdf.mitsuba_plugin import register

        register()
        return {"type": SHARED_BSDF, "flavour": "cycles", "base_color": base, "metallic": mat.metallic,
                "roughness": mat.roughness}
    if mode == "diffuse":
        return {"type": "diffuse", "reflectance": base}
    raise ValueError(f"materials: expected one of {', '.join(MATERIAL_MODES)}, got {mode!r}")


def light_dict(light: AreaLight) -> dict:
    """A one-sided rectangle emitter; Mitsuba's rectangle is [-1, 1]² at z = 0 with normal +Z."""
    import mitsuba as mi

    u = np.asarray(light.tangent) * light.size[0] / 2
    v = light.bitangent * light.size[1] / 2
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = u, v, light.normal, light.center
    return {
        "type": "rectangle",
        "to_world": mi.ScalarTransform4f(m.tolist()),
        "emitter": {"type": "area", "radiance": {"type": "rgb", "value": list(light.radiance)}},
        # The emitter itself reflects nothing: the rasterizer shows lights as pure emission too.
        "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.0, 0.0, 0.0]}},
    }


def environment_dict(scene: Scene) -> dict | None:
    """Mitsuba emitter for the scene's environment, or None.

    A constant environment is Mitsuba's ``constant`` emitter; every map (a file,
    a procedural map generated into the cache, a Blender studio light; see
    :func:`compare.environments.environment_path`) is an ``envmap`` with
    ``scale = intensity`` and ``to_world`` = rotation about +Y. The
    orientation convention of :mod:`compare.environments` *is* the envmap's,
    so the file is passed unchanged.
    """
    env = scene.environment
    if env is None:
        return None
    if env.constant is not None:
        return {"type": "constant", "radiance": {"type": "rgb", "value": [c * env.intensity for c in env.constant]}}
    import mitsuba as mi

    from .environments import environment_path

    return {
        "type": "envmap",
        "filename": str(environment_path(env)),
        "scale": env.intensity,
        "to_world": mi.ScalarTransform4f().rotate(axis=[0, 1, 0], angle=env.rotation),
    }


def mesh_object(name: str, scene: Scene, mesh_index: int, mode: str):
    """A ``mi.Mesh`` filled from the shared triangle data, with its BSDF (and emitter) attached."""
    import mitsuba as mi

    mesh = scene.meshes[mesh_index]
    tri = mesh.triangles()
    mat = scene.materials[mesh.material]
    props = mi.Properties()
    props["bsdf"] = mi.load_dict(material_dict(mat, mode))
    if mat.is_emissive:
        props["emitter"] = mi.load_dict({"type": "area", "radiance": {"type": "rgb", "value": list(mat.emission)}})
    m = mi.Mesh(name, len(tri.positions), tri.triangle_count, props, has_vertex_normals=True,
                has_vertex_texcoords=True)
    params = mi.traverse(m)
    params["vertex_positions"] = tri.positions.ravel()
    params["vertex_normals"] = tri.normals.ravel()
    params["vertex_texcoords"] = tri.uvs.ravel()
    params["faces"] = tri.indices.ravel()
    params.update()
    return m


def scene_dict(scene: Scene, *, spp: int, materials: str = "shared", sampler: str = "independent",
               max_depth: int | None = None) -> dict:
    """The whole Mitsuba scene dictionary for ``scene``.

    ``max_depth`` overrides the scene's path depth (2 = direct light only).
    """
    if materials not in MATERIAL_MODES:
        raise ValueError(f"materials: expected one of {', '.join(MATERIAL_MODES)}, got {materials!r}")
    depth = scene.max_depth if max_depth is None else max_depth
    d: dict = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": int(depth), "hide_emitters": False},
        "sensor": sensor_dict(scene, spp=spp, sampler=sampler),
    }
    for k in range(len(scene.meshes)):
        d[f"mesh{k:03d}"] = mesh_object(f"mesh{k:03d}", scene, k, materials)
    for k, light in enumerate(scene.lights):
        d[f"light{k:03d}"] = light_dict(light)
    env = environment_dict(scene)
    if env is not None:
        d["environment"] = env
    return d

