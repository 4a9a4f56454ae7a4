"""Translate a :class:`compare.scene.loader.Scene` into a Mitsuba 3 scene dictionary.

Four material modes:

``shared``
    the suite's own glTF metallic-roughness BSDF plugin (:mod:`compare.brdf`),
    the same definition the rasterizer evaluates in GLSL, so that
    reference-versus-rasterizer error measures lighting, not materials.
``cycles``
    the same plugin with ``flavour = "cycles"``: Blender's Principled BSDF v2
    as :mod:`compare.blender.export` sets it up (:mod:`compare.mitsuba.principled`),
    for references meant to look like Blender Cycles, with each material's
    ``distribution`` (Blender's default Multiscatter GGX unless the scene
    says ``ggx``; :mod:`compare.brdf.multiscatter`).
``cycles-ggx``
    ``cycles`` with every material's distribution GGX (single scattering): the
    counterpart of Blender renders with ``distribution = 'GGX'`` (``cycles:ggx``).
``diffuse``
    Lambert only (reflectance = base colour), for validation against closed
    forms such as the white furnace, where any specular lobe would get in the way.

Maps: base colour (sRGB), metallic-roughness (split into its B and G channels),
emission (sRGB, times the emission), normal (under :mod:`compare.mitsuba.normalmap`'s ``gltf_normalmap``,
in glTF's tangent frame: the mesh's TANGENT or MikkTSpace's, carried as mesh attributes; decoded as glTF
defines it, :data:`NORMALMAP_FLIP_Y`), each with the material's texture transform,
wrap and filter (:func:`bitmap_dict`). An occlusion map is left out: a path
tracer computes the occlusion it stands for. An alpha mask puts the BSDF under
Mitsuba's ``mask`` (a null interaction where the surface is a hole).

The ``cycles`` mapping
----------------------
Base colour, metallic and roughness go in unchanged (Blender squares the
roughness like glTF). The model is what Cycles evaluates for the exporter's
Principled node (``IOR`` = ior, ``Specular IOR Level`` = specular / 2,
``Specular Tint`` = specular colour, each with its map, and by default 1.5, 0.5,
white; Diffuse Roughness 0, ``distribution`` GGX or Multiscatter GGX): GGX with
height-correlated Smith masking (as ``shared``); the exact dielectric Fresnel
curve at the IOR the level adjusts, remapped to the tinted F0, on the
dielectric specular layer (``shared``: Schlick, glTF's F0 and specular weight), F82-tint
with F0 = base colour on the metal layer (Schlick with the default white tint); and
a Lambert lobe ``(1 - m)(1 - max E_s(r, n.v)) c / pi`` under the specular layer,
where ``E_s`` is Cycles' own albedo estimate of that layer, tabulated as
Cycles tabulates it (``ggx_gen_schlick_ior_s``) and depending on the view
direction only (``shared``: ``(1 - m)(1 - F_d(v.h))`` per light direction);
with Multiscatter GGX, each specular lobe and that layer albedo are scaled by
Cycles' energy compensation (:mod:`compare.brdf.multiscatter`).
Until this mode used the plugin it was Mitsuba's ``principled`` BSDF (Disney
2015: Disney diffuse with retro-reflection, Schlick Fresnel, no layering), which
made the Cornell box 18-47 % brighter per region than Cycles.

What remains different from Cycles: the reference's roughness floor (alpha >= 1e-4,
roughness 0.01, Mitsuba's own clamp: a mirror to within 1e-4 rad; Cycles keeps roughness
down to ~0.004 glossy, below that a mirror; the rasterizer's floor, 0.045, is not the
reference's), the float32 guards of V, Cycles' bending of shading normals for
specular reflection on smooth-shaded meshes (``ensure_valid_specular_reflection``),
Monte Carlo noise in the two tabulations of ``E_s`` (~3e-4), and sampling
(lobe choice, light sampling, Sobol versus Mitsuba's samplers), which changes
noise, not the expectation. Measured with :func:`compare.run.likeness.cycles_likeness`
against Cycles with the same distribution: see ``docs/cycles-likeness.md``.
(The single-scattering model alone, against Blender renders that set GGX:
Cornell box 64x48 at 64 spp 1.06, kitchen and car at 96x72 1.11 and 1.39; at
1024/512 spp noise-matched 1.00, 1.02 and 1.06. Variants measured and dropped
then: Schlick in place of the exact Fresnel, the specular lobe's true
directional albedo in place of Cycles' table, glTF's per-direction
``1 - F(v.h)``, each 1-8 % off in region means.)

:data:`MATERIAL_MODELS` names the model behind a mode whose meaning changed
after it was introduced; the reference's cache key includes it.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from compare.brdf import MATERIAL_MODES, PRINCIPLED_MODES
from compare.mitsuba.principled import NEUTRAL_LEVEL
from compare.scene.loader import AreaLight, Material, Scene

#: BSDF plugin name of the shared BRDF (registered by compare.mitsuba.bsdf).
SHARED_BSDF = "gltf_pbr"
#: Model identifiers of modes whose model changed (part of the reference's cache key).
MATERIAL_MODELS = {"cycles": "gltf_pbr:cycles:per-material-distribution:principled-layers",
                   "cycles-ggx": "gltf_pbr:cycles:principled-layers"}


#: Scenes whose extent (the diagonal of everything the camera, lights and meshes span) is below
#: this are rendered scaled up by a power of ten (:func:`world_scale`).
MIN_EXTENT = 0.1


def world_scale(scene: Scene) -> float:
    """The factor by which the reference renders ``scene``'s world (1 for most scenes).

    Mitsuba 3 offsets secondary rays by about (1 + max|p|)·8.9e-5 scene units, a
    fixed floor that at millimetre scale is a fair part of the geometry (contact
    shadows shrink, light leaks: +2.4 % mean on ``scenes/stress/scale_1e-3.toml``).
    Radiance does not change when a whole scene (camera, lights, meshes) is scaled,
    so a scene smaller than :data:`MIN_EXTENT` is rendered scaled by the power of
    ten that brings its extent to [1, 10).
    """
    pts = np.array([*scene.extent(), scene.camera.position, scene.camera.target,
                    *[p.position for p in scene.punctual if p.kind != "directional"]], dtype=np.float64)
    pts = pts[np.isfinite(pts).all(axis=1)]  # a scene without meshes has infinite mesh bounds
    extent = float(np.linalg.norm(pts.max(0) - pts.min(0)))
    if not (np.isfinite(extent) and 0 < extent < MIN_EXTENT):
        return 1.0
    return float(10.0 ** math.ceil(-math.log10(extent)))


def sensor_dict(scene: Scene, *, spp: int, sampler: str = "independent", scale: float = 1.0) -> dict:
    """Pinhole sensor with a box pixel filter (pixel (i, j) covers [i, i+1)×[j, j+1)); positions × ``scale``."""
    import mitsuba as mi

    cam = scene.camera
    origin = [scale * x for x in cam.position]
    target = [scale * x for x in cam.target]
    return {
        "type": "perspective",
        "fov": cam.fov,
        "fov_axis": "y",
        "near_clip": 1e-4,
        "far_clip": 1e6,
        "to_world": mi.ScalarTransform4f().look_at(origin=origin, target=target, up=list(cam.up)),
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


def bitmap_dict(mat: Material, which: str, filename, *, raw: bool) -> dict:
    """A Mitsuba texture of ``mat``'s map ``which`` (:meth:`~compare.scene.model.Material.sampling`) read from
    ``filename`` (the map, or a map derived from it): a ``bitmap`` with the map's texture transform, wrap and
    magnification filter, on its texture coordinate set (:func:`compare.mitsuba.textures.uv_mapped`). A path
    tracer averages many samples per pixel, so minification needs no mip levels."""
    import mitsuba as mi

    s = mat.sampling(which)
    d = {"type": "bitmap", "filename": str(filename), "raw": raw, "wrap_mode": s.wrap[0],
         "filter_type": "nearest" if s.filter == "nearest" else "bilinear"}
    if s.has_uv_transform:
        d["to_uv"] = mi.ScalarTransform3f(s.uv_transform().tolist())
    if s.texcoord or s.wrap[0] != s.wrap[1]:
        from compare.mitsuba.textures import uv_mapped

        return uv_mapped(d, s.texcoord, s.wrap)
    return d


#: Whether the maps' y is negated. No: the reference reads them in glTF's own frame, whose bitangent
#: cross(n, tangent) · w is the map's +Y by definition (:mod:`compare.mitsuba.normalmap`). (Mitsuba's
#: ``normalmap``, used before, reads them in a frame whose second axis, n × dp/du, points towards
#: increasing v, down the image: there y was negated.)
NORMALMAP_FLIP_Y = False


def _tangent_frame() -> dict:
    """The properties that name the mesh attributes of glTF's tangent frame (:func:`mesh_object`)."""
    from compare.mitsuba.normalmap import ATTRIBUTE_TANGENT, ATTRIBUTE_TANGENT_SIGN

    return {"tangent": ATTRIBUTE_TANGENT, "tangent_sign": ATTRIBUTE_TANGENT_SIGN}


def _normal_mapped(mat: Material, bsdf: dict) -> dict:
    """``bsdf`` under ``gltf_normalmap`` (:mod:`compare.mitsuba.normalmap`: Mitsuba's ``normalmap`` with
    the map read in glTF's tangent frame) when the material has a normal map."""
    if mat.normal_texture is None and mat.anisotropy_strength == 0.0:
        return bsdf
    from compare.mitsuba.normalmap import PLUGIN_NAME, register
    from compare.scene.textures import normal_map

    register()
    if mat.normal_texture is None:  # a flat map: the frame alone, whose tangent an anisotropy direction turns
        flat: dict = {"type": "rgb", "value": [0.5, 0.5, 1.0]}
        return {"type": PLUGIN_NAME, "bsdf": bsdf, **_tangent_frame(), "normalmap": flat}
    return {"type": PLUGIN_NAME, "bsdf": bsdf, **_tangent_frame(),
            "normalmap": bitmap_dict(mat, "normal_texture", normal_map(mat.normal_texture, mat.normal_scale,
                                                                       flip_y=NORMALMAP_FLIP_Y), raw=True)}


def _opacity(mat: Material, vc: bool = False) -> dict | float | None:
    """glTF's alpha as Mitsuba's ``mask`` opacity, or None for an opaque material. A masked material's
    opacity is glTF's test, coverage >= cutoff, per texel (:func:`compare.scene.textures.opacity_map`); a
    blended one's is the coverage itself (stochastic coverage: a ray passes with probability 1 − α, so the
    mean over paths is glTF's over-blend, shadows included). ``vc``: the mesh's vertex alpha multiplies the
    coverage of a blended material (a masked one's test is on the map's coverage)."""
    if mat.alpha_mode == "blend":
        if mat.base_color_texture is None:
            opacity: dict | float = float(mat.alpha)
        else:
            from compare.scene.textures import blend_map

            opacity = bitmap_dict(mat, "base_color_texture", blend_map(mat.base_color_texture, mat.alpha), raw=True)
        if vc:
            from compare.mitsuba.textures import tinted

            opacity = tinted(opacity, alpha=True)
        return opacity
    if not mat.is_masked:
        return None
    if mat.base_color_texture is None:
        return float(mat.alpha >= mat.alpha_cutoff)
    from compare.scene.textures import opacity_map

    return bitmap_dict(mat, "base_color_texture", opacity_map(mat.base_color_texture, mat.alpha, mat.alpha_cutoff), raw=True)


def _masked(mat: Material, bsdf: dict, vc: bool = False) -> dict:
    """``bsdf`` with glTF's sides and alpha. Double-sided: Mitsuba's ``twosided`` (a back face shades as the
    front, its normal turned to the ray). Single-sided (glTF's ``doubleSided: false``): back faces culled,
    for every ray (the specification culls them for rasterized camera rays; a path tracer meets a back face
    from behind only, so no ray sees it), as opacity 0 behind under ``mask``. Transmissive materials are
    neither: a solid's inside is its back, which refraction needs. Alpha (:func:`_opacity`): under ``mask``,
    a null interaction where the surface is a hole, which camera rays, light paths and shadows pass."""
    opacity = _opacity(mat, vc)
    if mat.transmission == 0.0:
        if mat.double_sided:
            bsdf = {"type": "twosided", "bsdf": bsdf}
        else:
            from compare.mitsuba.textures import front_side, product

            opacity = front_side() if opacity is None else product(opacity, front_side())
    return bsdf if opacity is None else {"type": "mask", "opacity": opacity, "bsdf": bsdf}


def material_dict(mat: Material, mode: str, *, vertex_colors: bool = False) -> dict:
    """BSDF dictionary for one material in ``mode`` (one of :data:`MATERIAL_MODES`); ``vertex_colors``:
    on a mesh with glTF's COLOR_0, which multiplies the base colour (and the tint of its glass) and alpha.

    glTF layers the coat over the sheen, and its normal map bends everything but the coat (which has its
    own): the base, its transmission and the sheen. Blender's Principled BSDF (the Principled modes) layers
    the sheen over the coat; its sheen takes the normal map where there is no coat (with a coat Cycles
    mixes the two normals by the coat's weight; here the sheen then keeps the surface's)."""
    vc = vertex_colors
    surface = _transmissive(mat, mode, _surface_dict(mat, mode, vc), vc)
    if mode in PRINCIPLED_MODES:
        if mat.clearcoat == 0.0:
            return _masked(mat, _normal_mapped(mat, _sheened(mat, mode, surface)), vc)
        return _masked(mat, _sheened(mat, mode, _coated(mat, mode, _normal_mapped(mat, surface))), vc)
    return _masked(mat, _coated(mat, mode, _normal_mapped(mat, _sheened(mat, mode, surface))), vc)


def _flavour(mode: str) -> str:
    """The layer plugins' ``flavour`` for a material mode: Blender's Principled model in its modes, else glTF's."""
    return "cycles" if mode in PRINCIPLED_MODES else "gltf"


def _sheened(mat: Material, mode: str, bsdf: dict) -> dict:
    """``bsdf`` under glTF's sheen (:mod:`compare.mitsuba.sheen`, the model of :mod:`compare.brdf.sheen`; in
    the Principled modes Cycles' sheen)."""
    if max(mat.sheen_color) == 0.0 or mode == "diffuse":
        return bsdf
    from compare.mitsuba.sheen import PLUGIN_NAME, register

    register()
    return {"type": PLUGIN_NAME, "base": bsdf, "roughness": _layer_value(mat, "sheen_roughness"),
            "color": _layer_value(mat, "sheen_color"), "flavour": _flavour(mode)}


def _coated(mat: Material, mode: str, bsdf: dict) -> dict:
    """``bsdf`` under glTF's clear coat (:mod:`compare.mitsuba.coat`, the layering of
    :mod:`compare.brdf.coat`; in the Principled modes Cycles' coat), outside the base's normal map: on the
    geometric normal, or its own map (glTF's clearcoatNormalTexture)."""
    if mat.clearcoat == 0.0 or mode == "diffuse":
        return bsdf
    from compare.mitsuba.coat import PLUGIN_NAME, register

    register()
    coat = {"type": PLUGIN_NAME, "base": bsdf, "clearcoat": _layer_value(mat, "clearcoat"),
            "roughness": _layer_value(mat, "clearcoat_roughness"),
            "flavour": _flavour(mode)}
    if mat.clearcoat_normal_texture is not None:
        from compare.scene.textures import normal_map

        # the coat's own normal, in glTF's tangent frame as the base's (_normal_mapped)
        coat["normalmap"] = bitmap_dict(mat, "clearcoat_normal_texture", normal_map(mat.clearcoat_normal_texture, mat.clearcoat_normal_scale,
                                                        flip_y=NORMALMAP_FLIP_Y), raw=True)
        coat.update(_tangent_frame())
    return coat


def _dielectric(mat: Material, mode: str, vc: bool = False) -> dict:
    """glTF's transmission lobe (``KHR_materials_transmission``) with its reflection: Mitsuba's dielectric
    of the material's ``ior`` (exact Fresnel), tinted by the base colour as glTF's BTDF is; rough with GGX
    α = roughness², smooth at roughness 0. With ``thickness`` 0 the surface is thin-walled (glTF: no
    refraction): Mitsuba's ``thindielectric``, which is smooth (the roughness of a thin wall's
    transmission is not drawn). The base colour's tint applies to the transmitted part only, at each
    interface. The Principled modes render what Blender renders: the square root of the tint at each
    interface, no thin wall (Principled has none: thickness 0 is a solid there), and with Multiscatter GGX
    Cycles' energy compensation of rough glass. Rough glass is masked as the shared BRDF is (height-correlated
    Smith, :mod:`compare.mitsuba.glass`). ``vc``: the mesh's vertex colour multiplies the tint (in the
    Principled modes at each interface, as it multiplies the square root of the base colour there)."""
    ior = float(min(mat.ior, 1e3))
    if mode in PRINCIPLED_MODES:  # Cycles tints each interface by √(base colour), two of them the colour
        from compare.scene.textures import sqrt_colour_map

        tint = ({"type": "rgb", "value": [math.sqrt(min(max(c, 0.0), 1.0)) for c in mat.base_color]}
                if mat.base_color_texture is None
                else bitmap_dict(mat, "base_color_texture", sqrt_colour_map(mat.base_color_texture), raw=True))
    else:
        tint = ({"type": "rgb", "value": list(mat.base_color)} if mat.base_color_texture is None
                else bitmap_dict(mat, "base_color_texture", mat.base_color_texture, raw=False))
    if vc:
        from compare.mitsuba.textures import tinted

        tint = tinted(tint)
    if mode == "diffuse":
        return {"type": "diffuse", "reflectance": tint}
    if mat.thickness == 0.0 and mode not in PRINCIPLED_MODES:  # Principled has no thin wall: a solid, as Cycles
        return {"type": "thindielectric", "int_ior": ior, "ext_ior": 1.0, "specular_transmittance": tint}
    if "dispersion" in mat.uses() and mode not in PRINCIPLED_MODES:  # (Principled has no dispersion input)
        from compare.mitsuba.dispersion import PLUGIN_NAME as DISPERSIVE, register as register_dispersive
        from compare.scene.model import channel_iors

        register_dispersive()
        rough = mat.roughness > 0.0 or mat.metallic_roughness_texture is not None
        # a rough lobe needs two different indices: the red one is kept just above 1
        iors = [max(n, 1.0 + 1e-4) if rough else n for n in channel_iors(ior, mat.dispersion)]
        return {"type": DISPERSIVE, "rough": rough,
                **{f"bsdf_{k}": _interface(mat, mode, n, tint) for k, n in enumerate(iors)}}
    return _interface(mat, mode, ior, tint)


def _interface(mat: Material, mode: str, ior: float, tint: dict) -> dict:
    """The dielectric interface of index ``ior`` (smooth, rough or index-matched) tinted by ``tint``; rough
    by the metallic-roughness map's G where the material has one (it replaces the factor)."""
    mapped = mat.metallic_roughness_texture is not None
    if (mat.roughness == 0.0 and not mapped) or ior <= 1.0:
        # ior 1 (valid glTF, an index-matched interface): refraction by any microfacet leaves the direction
        # as it is, so rough or smooth the light goes straight through, tinted; Mitsuba's rough dielectric
        # refuses equal indices, its smooth one is exact here
        return {"type": "dielectric", "int_ior": ior, "ext_ior": 1.0, "specular_transmittance": tint}
    alpha: dict | float = float(mat.roughness) ** 2
    roughness: dict | float = float(mat.roughness)
    if mapped:
        from compare.scene.textures import alpha_map, split_metallic_roughness

        alpha = bitmap_dict(mat, "metallic_roughness_texture", alpha_map(mat.metallic_roughness_texture), raw=True)
        roughness = bitmap_dict(mat, "metallic_roughness_texture",
                                split_metallic_roughness(mat.metallic_roughness_texture)[1], raw=True)
    rough = {"type": "roughdielectric", "distribution": "ggx", "alpha": alpha, "int_ior": ior,
             "ext_ior": 1.0, "specular_transmittance": tint}
    from compare.mitsuba.glass import PLUGIN_NAME, register

    register()  # height-correlated masking, as the shared BRDF; Multiscatter GGX glass: Cycles' compensation
    compensate = mode in PRINCIPLED_MODES and (PRINCIPLED_MODES[mode] or mat.distribution) == "multi_ggx"
    return {"type": PLUGIN_NAME, "bsdf": rough, "roughness": roughness, "ior": ior, "tint": tint,
            "compensate": compensate}


def _specular_f0(mat: Material):
    """The dielectric's F0 of glTF's ior and specular colour (:func:`compare.brdf.dielectric_specular`,
    without the weight), per texel where the specular colour has a map."""
    from compare.brdf import dielectric_specular

    colour = _layer_map(mat, "specular_color")
    if colour is None:
        f0, _ = dielectric_specular(mat.ior, 1.0, mat.specular_color)
        return {"type": "rgb", "value": [float(x) for x in f0]}
    from compare.scene.textures import specular_f0_map

    return bitmap_dict(mat, "specular_color", specular_f0_map(colour[2], mat.specular_color, mat.ior), raw=True)


def _unbounded(texture: dict) -> dict:
    """A constant colour that may exceed 1 (a tint): Mitsuba's ``rgb`` accepts reflectances only."""
    if texture.get("type") == "rgb":
        return {"type": "srgb", "color": texture["value"], "unbounded": True}
    return texture


def _layer_map(mat: Material, name: str):
    """The map of a material extension's parameter (field, channel, path), or None."""
    return next((m for m in mat.layer_maps if m[0] == name), None)


def _layer_value(mat: Material, name: str, scale: float = 1.0):
    """A material extension's parameter: its factor, or the factor times its map (a texture); times ``scale``
    (a scalar parameter)."""
    found = _layer_map(mat, name)
    factor = getattr(mat, name)
    if scale != 1.0:
        factor = factor * scale
    if found is not None:
        from compare.scene.textures import channel_map

        return bitmap_dict(mat, name, channel_map(found[2], found[1], factor), raw=True)
    if isinstance(factor, tuple):
        return {"type": "rgb", "value": [float(x) for x in factor]}
    return float(factor)


def _transmissive(mat: Material, mode: str, bsdf: dict, vc: bool = False) -> dict:
    """``bsdf`` blended with the transmission lobe by glTF's layering: the dielectric part
    ((1 − metallic) of the base) is ``mix(diffuse base, transmission, transmission)``. Mitsuba's
    ``blendbsdf`` picks one by the weight per interaction; a metallic part stays the metal of ``bsdf``."""
    if mat.transmission == 0.0 or mode == "diffuse":
        return bsdf
    glass = _dielectric(mat, mode, vc)
    weight = _layer_value(mat, "transmission")
    mapped = mat.metallic_roughness_texture is not None  # the map's metallic (B) replaces the factor
    if mat.metallic == 0.0 and not mapped:
        return {"type": "blendbsdf", "weight": weight, "bsdf_0": bsdf, "bsdf_1": glass}
    metallic: dict | float = float(mat.metallic)
    if mapped:
        from compare.scene.textures import split_metallic_roughness

        metallic = bitmap_dict(mat, "metallic_roughness_texture",
                               split_metallic_roughness(mat.metallic_roughness_texture)[0], raw=True)
    no_map = dataclasses.replace(mat, metallic_roughness_texture=None)  # the parts' metallic is their own
    dielectric = _surface_dict(dataclasses.replace(no_map, metallic=0.0), mode, vc)
    metal = _surface_dict(dataclasses.replace(no_map, metallic=1.0), mode, vc)
    if mapped:  # the parts (gltf_pbr) keep the map's roughness (G)
        dielectric["roughness"] = metal["roughness"] = bitmap_dict(
            mat, "metallic_roughness_texture", split_metallic_roughness(mat.metallic_roughness_texture)[1], raw=True)
    return {"type": "blendbsdf", "weight": metallic, "bsdf_0": {
        "type": "blendbsdf", "weight": weight, "bsdf_0": dielectric, "bsdf_1": glass},
        "bsdf_1": metal}


def _surface_dict(mat: Material, mode: str, vc: bool = False) -> dict:
    base = (bitmap_dict(mat, "base_color_texture", mat.base_color_texture, raw=False)
            if mat.base_color_texture else {"type": "rgb", "value": list(mat.base_color)})
    if vc:  # glTF's COLOR_0 multiplies the base colour
        from compare.mitsuba.textures import tinted

        base = tinted(base)
    metallic, roughness = mat.metallic, mat.roughness
    if mat.metallic_roughness_texture is not None and mode != "diffuse":
        from compare.scene.textures import split_metallic_roughness

        # glTF's channels (B = metallic, G = roughness) as two maps; like every map, they replace the factors.
        m_file, r_file = split_metallic_roughness(mat.metallic_roughness_texture)
        metallic = bitmap_dict(mat, "metallic_roughness_texture", m_file, raw=True)
        roughness = bitmap_dict(mat, "metallic_roughness_texture", r_file, raw=True)
    if mode == "shared":
        from compare.mitsuba.bsdf import register

        register()
        d = {"type": SHARED_BSDF, "base_color": base, "metallic": metallic, "roughness": roughness}
        if mat.anisotropy_strength > 0.0:  # in glTF's tangent frame: _normal_mapped puts it under one
            d.update(anisotropy_strength=float(mat.anisotropy_strength),
                     anisotropy_rotation=float(mat.anisotropy_rotation))
            found = _layer_map(mat, "anisotropy_strength")
            if found is not None:  # its encoded direction and strength, interpolated as stored
                d["anisotropy_map"] = bitmap_dict(mat, "anisotropy_strength", found[2], raw=True)
        if mat.iridescence > 0.0:
            d.update(iridescence=_layer_value(mat, "iridescence"), iridescence_ior=float(mat.iridescence_ior),
                     iridescence_thickness=float(mat.iridescence_thickness_max))
            found = _layer_map(mat, "iridescence_thickness_max")
            if found is not None:  # glTF: mix(minimum, maximum, the map's G)
                from compare.scene.textures import channel_map

                d.update(iridescence_thickness_min=float(mat.iridescence_thickness_min),
                         iridescence_thickness_map=bitmap_dict(mat, "iridescence_thickness_max",
                                                               channel_map(found[2], found[1], 1.0), raw=True))
        if ((mat.ior, mat.specular, mat.specular_color) != (1.5, 1.0, (1.0, 1.0, 1.0))
                or _layer_map(mat, "specular") or _layer_map(mat, "specular_color")):
            d.update(specular_f0=_specular_f0(mat), specular_weight=_layer_value(mat, "specular"))
        return d
    if mode in PRINCIPLED_MODES:
        from compare.mitsuba.bsdf import register

        register()
        d = {"type": SHARED_BSDF, "flavour": _flavour(mode), "base_color": base, "metallic": metallic,
             "roughness": roughness, "distribution": PRINCIPLED_MODES[mode] or mat.distribution}
        if ((mat.ior, mat.specular, mat.specular_color) != (1.5, 1.0, (1.0, 1.0, 1.0))
                or _layer_map(mat, "specular") or _layer_map(mat, "specular_color")):
            # the Principled inputs the Blender export sets (compare.blender.export.principled_inputs):
            # glTF's specular 1 is the neutral Specular IOR Level
            d.update(ior=float(min(mat.ior, 1e3)), specular_ior_level=_layer_value(mat, "specular", scale=NEUTRAL_LEVEL),
                     specular_tint=_unbounded(_layer_value(mat, "specular_color")))
        return d
    if mode == "diffuse":
        return {"type": "diffuse", "reflectance": base}
    raise ValueError(f"materials: expected one of {', '.join(MATERIAL_MODES)}, got {mode!r}")


def light_dict(light: AreaLight, scale: float = 1.0) -> dict:
    """A one-sided rectangle emitter; Mitsuba's rectangle is [-1, 1]² at z = 0 with normal +Z.
    Positions and sizes × ``scale`` (its radiance does not change)."""
    import mitsuba as mi

    u = np.asarray(light.tangent) * light.size[0] / 2 * scale
    v = light.bitangent * light.size[1] / 2 * scale
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = u, v, light.normal, np.asarray(light.center) * scale
    return {
        "type": "rectangle",
        "to_world": mi.ScalarTransform4f(m.tolist()),
        "emitter": {"type": "area", "radiance": {"type": "rgb", "value": list(light.radiance)}},
        # The emitter itself reflects nothing: the rasterizer shows lights as pure emission too.
        "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.0, 0.0, 0.0]}},
    }


#: Texels a side of the spot lights' cone profile (compare.mitsuba.scene_dict.punctual_dict).
SPOT_PROFILE_SIZE = 1024
#: The widest cone (degrees) Mitsuba's ``spot`` maps its texture over: it looks the texture up at
#: tan(θ) / tan(cutoff), which at a cutoff of exactly 90° is 0 everywhere (a black light). glTF allows 90°;
#: its falloff is the square of a ramp that reaches 0 at the outer cone, so what lies beyond 89.5° of a
#: 90° cone is below 1e-4 of the peak and is left out.
SPOT_MAPPING_MAX_DEG = 89.5


def _spot_mapping_cone(light) -> float:
    return min(float(light.outer_cone), SPOT_MAPPING_MAX_DEG)


def spot_profile(light) -> np.ndarray:
    """glTF's spot cone falloff as the texture Mitsuba's ``spot`` multiplies its intensity by: texel (u, v) of
    [0, 1]² looks along local (x, y, 1) with x, y = (2u − 1, 2v − 1) · tan(outer cone) (Mitsuba's
    ``direction_to_uv``), so the square of glTF's clamped ramp in cos θ is reproduced to the texture's
    bilinear interpolation, where Mitsuba's own falloff is linear in the angle."""
    n = SPOT_PROFILE_SIZE
    t = math.tan(math.radians(_spot_mapping_cone(light)))
    c = (np.arange(n) + 0.5) / n * 2.0 - 1.0
    x, y = np.meshgrid(c * t, c * t)
    values = light.falloff(1.0 / np.sqrt(1.0 + x * x + y * y)).astype(np.float32)
    return np.repeat(values[..., None], 3, axis=2)


def punctual_dict(light, scale: float = 1.0) -> dict:
    """Mitsuba's own emitter for a point (``point``), spot (``spot`` with glTF's cone, :func:`spot_profile`)
    or directional (``directional``) light. Positions × ``scale``; an intensity (W/sr) × ``scale``², so that
    the irradiance it gives at the scaled distances is the scene's."""
    import mitsuba as mi

    rgb = lambda v: {"type": "rgb", "value": [float(x) for x in v]}  # noqa: E731
    intensity = [c * scale * scale for c in light.intensity]
    position = [scale * x for x in light.position]
    if light.kind == "point":
        return {"type": "point", "position": position, "intensity": rgb(intensity)}
    if light.kind == "directional":
        return {"type": "directional", "direction": list(light.direction), "irradiance": rgb(light.intensity)}
    d = np.asarray(light.direction, dtype=np.float64)
    up = [0.0, 1.0, 0.0] if abs(d[1]) < 0.9 else [1.0, 0.0, 0.0]
    target = (np.asarray(position) + d).tolist()
    return {"type": "spot", "to_world": mi.ScalarTransform4f().look_at(origin=position, target=target, up=up),
            "intensity": rgb(intensity), "cutoff_angle": _spot_mapping_cone(light),
            "beam_width": _spot_mapping_cone(light),  # no falloff of Mitsuba's own: the profile is glTF's
            "texture": {"type": "bitmap", "bitmap": mi.Bitmap(spot_profile(light)), "raw": True,
                        "filter_type": "bilinear", "wrap_mode": "clamp"}}


def environment_dict(scene: Scene) -> dict | None:
    """Mitsuba emitter for the scene's environment, or None.

    A constant environment is Mitsuba's ``constant`` emitter; every map (a file,
    a procedural map generated into the cache, a Blender studio light; see
    :func:`compare.scene.environments.environment_path`) is an ``envmap`` with
    ``scale = intensity`` and ``to_world`` = rotation about +Y. The
    orientation convention of :mod:`compare.scene.environments` *is* the envmap's,
    so the file is passed unchanged, but for the compression noise below zero that
    the rasterizer sets to zero (:func:`compare.scene.environments.environment_file`): both
    renderers see the same radiance, and a map with real negative radiance is refused.
    """
    env = scene.environment
    if env is None:
        return None
    if env.constant is not None:
        return {"type": "constant", "radiance": {"type": "rgb", "value": [c * env.intensity for c in env.constant]}}
    from compare.mitsuba.backend import load_active_mitsuba
    from compare.scene.environments import environment_file

    mi = load_active_mitsuba()  # a variant is set
    return {
        "type": "envmap",
        "filename": str(environment_file(env)),
        "scale": env.intensity,
        "to_world": mi.ScalarTransform4f().rotate(axis=[0, 1, 0], angle=env.rotation),
    }


def absorbs(mat: Material) -> bool:
    """Whether the material is the boundary of an absorbing solid (``KHR_materials_volume``: transmission,
    a thickness, a finite attenuation distance)."""
    return (mat.transmission > 0.0 and mat.thickness > 0.0 and math.isfinite(mat.attenuation_distance)
            and min(mat.attenuation_color) < 1.0)


def medium_dict(mat: Material, scale: float = 1.0) -> dict:
    """The solid's interior: a purely absorbing homogeneous medium, Beer's law ``T = c^(x / d)``, i.e.
    σ_a = −ln(c) / d per channel (d in world units × ``scale``)."""
    c = np.clip(np.asarray(mat.attenuation_color, dtype=np.float64), 1e-12, 1.0)
    # a channel that nothing absorbs gets a millionth of the peak: volpath samples distances per channel, and
    # a zero coefficient there makes its free-flight pdf 0 (NaN weights)
    sigma = np.maximum(-np.log(c), 0.0) / (float(mat.attenuation_distance) * scale)
    sigma = np.maximum(sigma, 1e-6 * sigma.max())
    peak = float(sigma.max())
    # Mitsuba takes an RGB coefficient in [0, 1]: the colour of σ, and its peak as the medium's scale
    return {"type": "homogeneous", "sigma_t": {"type": "rgb", "value": [float(x / peak) if peak > 0 else 0.0
                                                                         for x in sigma]},
            "scale": peak if peak > 0 else 1.0, "albedo": {"type": "rgb", "value": [0.0, 0.0, 0.0]}}


def mesh_object(name: str, scene: Scene, mesh_index: int, mode: str, scale: float = 1.0):
    """A ``mi.Mesh`` filled from the shared triangle data (positions × ``scale``), with its BSDF
    (and emitter) attached; a normal-mapped material's mesh with its tangent frame (glTF's TANGENT or
    MikkTSpace's) as mesh attributes."""
    import mitsuba as mi

    mesh = scene.meshes[mesh_index]
    mat = scene.materials[mesh.material]
    tri = mesh.triangles(tangents=mat.normal_mapped, tangent_uv=mat.tangent_uv)
    props = mi.Properties()
    props["bsdf"] = mi.load_dict(material_dict(mat, mode, vertex_colors=tri.colors is not None))
    if absorbs(mat) and mode != "diffuse":
        props["interior"] = mi.load_dict(medium_dict(mat, scale))
    if mat.is_emissive:
        radiance = {"type": "rgb", "value": list(mat.emission)}
        if mat.emissive_texture is not None:
            from compare.scene.textures import emission_map

            radiance = bitmap_dict(mat, "emissive_texture", emission_map(mat.emissive_texture, mat.emission), raw=True)
        props["emitter"] = mi.load_dict({"type": "area", "radiance": radiance})
    m = mi.Mesh(name, len(tri.positions), tri.triangle_count, props, has_vertex_normals=True,
                has_vertex_texcoords=True)
    params = mi.traverse(m)
    params["vertex_positions"] = (tri.positions * scale).ravel()
    params["vertex_normals"] = tri.normals.ravel()
    params["vertex_texcoords"] = tri.uvs.ravel()
    params["faces"] = tri.indices.ravel()
    params.update()
    if tri.uvs1 is not None and any(mat.sampling(n).texcoord for n in mat.map_names()):
        from compare.mitsuba.textures import ATTRIBUTE_UV1  # read by the compare_uv texture

        m.add_attribute(ATTRIBUTE_UV1, 3, np.column_stack([tri.uvs1, np.zeros(len(tri.uvs1))]).astype(np.float32).ravel())
    if tri.colors is not None:  # read by compare.mitsuba.textures's texture
        from compare.mitsuba.textures import ATTRIBUTE_ALPHA, ATTRIBUTE_RGB

        m.add_attribute(ATTRIBUTE_RGB, 3, tri.colors[:, :3].ravel())
        m.add_attribute(ATTRIBUTE_ALPHA, 1, tri.colors[:, 3].ravel())
    if mat.normal_mapped:  # read by compare.mitsuba.normalmap's BSDF and the coat's own map
        from compare.mitsuba.normalmap import tangent_attributes

        for name, (channels, values) in tangent_attributes(tri.tangents).items():
            m.add_attribute(name, channels, values)
    return m


def _integrator(scene: Scene, depth: int) -> dict:
    """Mitsuba's ``path``; with alpha masks the same algorithm with holes that are no bounce
    (:mod:`compare.mitsuba.layers`: ``path`` counts a hole as a bounce of ``max_depth``). A hidden
    background (:attr:`Scene.hides_background`): the layers integrator's own, or ``path`` / ``volpath``
    wrapped by :mod:`compare.mitsuba.background` (their ``hide_emitters`` would hide the lights seen too)."""
    features = scene.features()
    hidden = scene.hides_background
    if features.volume:  # absorbing solids: Mitsuba's volumetric path tracer (its masks count as bounces)
        volpath = {"type": "volpath", "max_depth": depth, "hide_emitters": False}
        return _hidden_background(volpath) if hidden else volpath
    if features.holes:
        from compare.mitsuba import layers as reference_layers

        reference_layers.register()
        return {"type": reference_layers.INTEGRATOR_NAME, "max_depth": depth, "layers": False,
                "holes": True, "background": not hidden}
    path = {"type": "path", "max_depth": depth, "hide_emitters": False}
    return _hidden_background(path) if hidden else path


def _hidden_background(inner: dict) -> dict:
    from compare.mitsuba.background import integrator_dict

    return integrator_dict(inner)


def scene_dict(scene: Scene, *, spp: int, materials: str = "shared", sampler: str = "independent",
               max_depth: int | None = None, scale: float | None = None) -> dict:
    """The whole Mitsuba scene dictionary for ``scene``.

    ``max_depth`` overrides the scene's path depth (2 = direct light only). Its world is
    scaled by ``scale``, by default :func:`world_scale` (1 unless the scene is tiny).
    """
    if materials not in MATERIAL_MODES:
        raise ValueError(f"materials: expected one of {', '.join(MATERIAL_MODES)}, got {materials!r}")
    depth = scene.max_depth if max_depth is None else max_depth
    scale = world_scale(scene) if scale is None else float(scale)
    d: dict = {
        "type": "scene",
        "integrator": _integrator(scene, int(depth)),
        "sensor": sensor_dict(scene, spp=spp, sampler=sampler, scale=scale),
    }
    for k in range(len(scene.meshes)):
        d[f"mesh{k:03d}"] = mesh_object(f"mesh{k:03d}", scene, k, materials, scale)
    for k, light in enumerate(scene.lights):
        d[f"light{k:03d}"] = light_dict(light, scale)
    for k, light in enumerate(scene.punctual):
        d[f"punctual{k:03d}"] = punctual_dict(light, scale)
    env = environment_dict(scene)
    if env is not None:
        d["environment"] = env
    return d

