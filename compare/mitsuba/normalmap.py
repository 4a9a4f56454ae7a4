"""glTF's normal map around any BSDF, as a Mitsuba 3 plugin (``gltf_normalmap``): the nested BSDF evaluated
in the frame of the perturbed normal, with the normal read in glTF's tangent frame.

glTF puts a normal map in the frame of the mesh's ``TANGENT`` (per vertex, interpolated; MikkTSpace's when a
file has none): ``t`` its xyz, ``w = ±1`` the bitangent's sign, ``b = cross(n, t) · w``. Mitsuba's own
``normalmap`` reads the map in its shading frame instead, whose tangent is the triangle's ``dp/du`` (per
triangle, and blind to ``TANGENT``). This plugin builds glTF's frame, as the rasterizer does
(``compare/progressive/frame/material.glsl``, ``material_normal``): at a surface point, with ``n`` the
interpolated shading normal and ``T, w`` the interpolated mesh attributes :data:`ATTRIBUTE_TANGENT` and
:data:`ATTRIBUTE_TANGENT_SIGN` (:func:`tangent_attributes`),

    t = normalize(T − n (n·T)),  b = cross(n, t) · sign(w),  n' = normalize(x t + y b + z n),

with ``(x, y, z) = 2 rgb − 1`` the map's texel as glTF defines it (+X along +u, +Y up the image, +Z out; the
normal scale already on x and y: :func:`compare.scene.textures.normal_map` with ``flip_y`` False). A point
whose tangent vanishes (a degenerate UV chart) falls back to Mitsuba's shading frame.

Everything else is Mitsuba 3.9's ``normalmap`` (``src/bsdfs/normalmap.cpp``): the nested BSDF sees a
surface interaction whose shading frame is the perturbed one (its tangent the glTF tangent projected on the
perturbed plane) and directions in it; a perturbed normal that the view direction lies below is mirrored
about the unperturbed normal (``flip_invalid_normals``, default true: ``(x, y, z) → (−x, −y, z)`` in the
shading frame); a pair of directions on opposite sides of the unperturbed and the perturbed normals has no
value and no pdf; and Estevez et al.'s shadowing term (``use_shadowing_function``, default true) smooths
the terminator: ``2 / (1 + sqrt(1 + α² tan²θ_o))``, ``α² = min(tan²θ_n' / 8, 1)``.

Properties: ``bsdf`` (the nested BSDF), ``normalmap`` (the encoded map, a raw bitmap), ``tangent`` and
``tangent_sign`` (the names of the mesh attributes), ``flip_invalid_normals``, ``use_shadowing_function``.

The class is ``GltfNormalMapBSDF`` of :mod:`compare.mitsuba.plugins.normalmap` (bound to a variant:
:mod:`compare.mitsuba.plugins`); :func:`~compare.mitsuba.plugins.normalmap.gltf_normal` there is the frame,
which the clear coat's own normal map (:mod:`compare.mitsuba.coat`) reads too.
"""

from __future__ import annotations

import numpy as np

__all__ = ["ATTRIBUTE_TANGENT", "ATTRIBUTE_TANGENT_SIGN", "PLUGIN_NAME", "register", "tangent_attributes"]

PLUGIN_NAME = "gltf_normalmap"
#: The mesh attributes of glTF's TANGENT: xyz (3 channels) and w (1 channel); Mitsuba interpolates an
#: attribute named "vertex_*" over a triangle.
ATTRIBUTE_TANGENT, ATTRIBUTE_TANGENT_SIGN = "vertex_tangent", "vertex_tangent_sign"


def tangent_attributes(tangents: np.ndarray) -> dict[str, tuple[int, np.ndarray]]:
    """The mesh attributes (name → (channels, flat float32 values)) of glTF tangents (N, 4)."""
    t = np.asarray(tangents, dtype=np.float32).reshape(-1, 4)
    return {ATTRIBUTE_TANGENT: (3, np.ascontiguousarray(t[:, :3]).ravel()),
            ATTRIBUTE_TANGENT_SIGN: (1, np.ascontiguousarray(t[:, 3]))}


def register(variant: str | None = None):
    """Register ``gltf_normalmap`` with the active (or given) variant; returns the ``mitsuba`` module."""
    from compare.mitsuba.backend import load_active_mitsuba  # noqa: PLC0415 - Mitsuba is loaded lazily

    load_active_mitsuba(variant)  # first: the class subclasses the classes of the variant set
    from compare.mitsuba.plugins import normalmap as classes, register_plugin  # noqa: PLC0415

    return register_plugin(PLUGIN_NAME, classes, "GltfNormalMapBSDF")
