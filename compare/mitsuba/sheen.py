"""glTF's sheen over any BSDF, as a Mitsuba 3 plugin (``gltf_sheen``): the model of
:mod:`compare.brdf.sheen` (read it), evaluated with Dr.Jit, the albedo table as a bilinear texture.

Properties: ``base`` (the nested BSDF), ``color`` (linear RGB) and ``roughness`` (the sheen's perceptual
roughness), each a value or a texture (glTF's factor times its map).

``flavour``: ``"gltf"`` (default), glTF's Charlie sheen and its albedo scaling, or ``"cycles"``,
Principled v2's sheen as Cycles builds it (:func:`compare.mitsuba.principled.sheen_lobe_cycles`: Zeltner
et al.'s linearly transformed cosine from Cycles' table, the base scaled by one minus the sheen's albedo
at the view direction).

Sampling: the cosine-weighted hemisphere with probability ``p = clip(max(color) E(cos θ_i), 0.05, 0.5)``
(the lobe is broad), else the base's own sampling; the weight is ``eval / pdf`` of the mixture.

The class is ``GltfSheenBSDF`` of :mod:`compare.mitsuba.plugins.sheen`, a
:class:`compare.mitsuba.plugins.base.LayeredBSDF` (bound to a variant: :mod:`compare.mitsuba.plugins`).
"""

from __future__ import annotations

__all__ = ["PLUGIN_NAME", "register"]

PLUGIN_NAME = "gltf_sheen"


def register(variant: str | None = None):
    """Register ``gltf_sheen`` with the active (or given) variant; returns the ``mitsuba`` module."""
    from compare.mitsuba.backend import load_active_mitsuba  # noqa: PLC0415 - Mitsuba is loaded lazily

    load_active_mitsuba(variant)  # first: the class subclasses the classes of the variant set
    from compare.mitsuba.plugins import register_plugin, sheen as classes  # noqa: PLC0415

    return register_plugin(PLUGIN_NAME, classes, "GltfSheenBSDF")
