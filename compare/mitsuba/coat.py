"""glTF's clear coat over any BSDF, as a Mitsuba 3 plugin (``gltf_coat``): the layering of
:mod:`compare.brdf.coat` (read it), evaluated with Dr.Jit.

Properties: ``base`` (the nested BSDF, the material under the coat), ``clearcoat`` (w) and ``roughness``
(the coat's perceptual roughness), each a float or a texture (glTF's factor times its map), and optionally
``normalmap``: glTF's clearcoatNormalTexture, encoded (n + 1) / 2, read in glTF's tangent frame as the
base's (:mod:`compare.mitsuba.normalmap`), with ``tangent`` and ``tangent_sign`` the names of the mesh
attributes that hold it (the coat sits outside the base's normal map, so its surface interaction carries
the unperturbed shading frame). The coat's lobe (its D, V and cosine) is then evaluated and sampled in
the frame of that normal; its share at the half vector does not depend on the frame; the base keeps the
surface's frame. Directions must lie above the surface as well as above the coat's normal.

``flavour``: ``"gltf"`` (default), glTF's layering (the share ``w F_c(v.h)``, Schlick with F0 = 0.04, taken
from the base per direction), or ``"cycles"``, Principled v2's coat as Cycles builds it
(:func:`compare.mitsuba.principled.coat_lobe_cycles`: the exact Fresnel of Coat IOR 1.5, Multiscatter GGX's
energy compensation, and the base scaled by one minus the coat's albedo estimate at the view direction).

Sampling: the coat's GGX visible normals with probability ``p_c = clip(w F_c(cos θ_i), 0.1 w, 0.9)``
(Schlick at the view's cosine, floored so that a glancing coat over a bright base is still found),
else the base's own sampling; the returned weight is ``eval / pdf`` of the mixture (one-sample MIS),
so either lobe may have produced the direction.

The class is ``GltfCoatBSDF`` of :mod:`compare.mitsuba.plugins.coat`, a
:class:`compare.mitsuba.plugins.base.LayeredBSDF` (bound to a variant: :mod:`compare.mitsuba.plugins`).
"""

from __future__ import annotations

__all__ = ["PLUGIN_NAME", "register"]

PLUGIN_NAME = "gltf_coat"


def register(variant: str | None = None):
    """Register ``gltf_coat`` with the active (or given) variant; returns the ``mitsuba`` module."""
    from compare.mitsuba.backend import load_active_mitsuba  # noqa: PLC0415 - Mitsuba is loaded lazily

    load_active_mitsuba(variant)  # first: the class subclasses the classes of the variant set
    from compare.mitsuba.plugins import coat as classes, register_plugin  # noqa: PLC0415

    return register_plugin(PLUGIN_NAME, classes, "GltfCoatBSDF")
