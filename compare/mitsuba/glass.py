"""Rough glass with height-correlated masking, and Cycles' energy compensation of it, as a Mitsuba 3 plugin
(``rough_glass``) around a nested ``roughdielectric``.

Masking. Mitsuba's ``roughdielectric`` masks with the separable Smith term ``G1(wi) G1(wo)``; the suite's
one BRDF (:mod:`compare.brdf`) and Cycles use the height-correlated one, ``1 / (1 + Λ(wi) + Λ(wo))``, which
keeps more light: up to 10 % of a rough glass lobe's albedo at roughness 1. The plugin multiplies the nested
lobe by their ratio ``(1 + Λi)(1 + Λo) / (1 + Λi + Λo)`` (directions only: reflection and transmission
alike), so that the reference's glass reflects and transmits with the masking of its other surfaces.
(``KHR_materials_transmission``'s non-normative implementation notes write the BTDF with the separable form;
its normative text names only the distribution.)

Compensation (``compensate = true``: Multiscatter GGX, Blender's default, the Principled modes): Cycles scales
the single-scattering glass by ``1 + F_ms (1 - E) / E``, ``E`` the lobe's albedo (reflection and
transmission with the dielectric Fresnel) at the view's cosine, roughness and IOR, and
``F_ms = F_ss E_avg / (1 - F_ss (1 - E_avg))`` with ``F_ss`` the transmission tint (Cycles:
``microfacet_ggx_preserve_energy`` after ``bsdf_microfacet_setup_fresnel_generalized_schlick``). Seen from
inside (``cos_i < 0``) the relative IOR is 1/ior (the ``_inv`` tables). ``E`` and ``E_avg`` are this
plugin's own lobe's, tabulated on Cycles' grids by ``python -m tools.fit_glass`` (``glass_energy.npz``);
they agree with Cycles' own tables (``tests/test_principled_inputs.py``). :func:`energy_scale` is the numpy
definition.

Properties: ``bsdf`` (the nested ``roughdielectric``), ``roughness`` (perceptual; alpha = roughness², as the
nested one's), ``compensate`` (bool, default false), ``ior`` (> 1) and ``tint`` (the transmission tint, rgb
or texture). ``pdf`` is the nested one; ``eval`` and ``sample``'s weight are the nested ones times the
masking ratio (and the scale).

The class is ``RoughGlassBSDF`` of :mod:`compare.mitsuba.plugins.glass` (bound to a variant:
:mod:`compare.mitsuba.plugins`); the tables and :func:`energy_scale` live in :mod:`compare.mitsuba.glass_energy`.
"""

from __future__ import annotations

import numpy as np

from compare.mitsuba.glass_energy import TABLE_PATH, TABLES, energy_scale

__all__ = ["PLUGIN_NAME", "TABLES", "TABLE_PATH", "energy_scale", "masking_ratio", "register"]

PLUGIN_NAME = "rough_glass"


def masking_ratio(wi, wo, roughness):
    """``(1 + Λi)(1 + Λo) / (1 + Λi + Λo)``: the shared BRDF's height-correlated masking (:mod:`compare.brdf`)
    over the separable one, ``G2 / (G1(wi) G1(wo))``, per pair of directions (local frame, normal +z; either
    side)."""
    from compare.brdf import smith_g1, smith_v_height_correlated

    alpha = max(float(roughness) ** 2, 1e-4)
    ci, co = np.abs(np.asarray(wi)[..., 2]), np.abs(np.asarray(wo)[..., 2])
    g2 = 4.0 * ci * co * smith_v_height_correlated(ci, co, alpha)
    return g2 / (smith_g1(ci, alpha) * smith_g1(co, alpha))


def register(variant: str | None = None):
    """Register ``rough_glass`` with the active (or given) variant; returns the ``mitsuba`` module."""
    from compare.mitsuba.backend import load_active_mitsuba  # noqa: PLC0415 - Mitsuba is loaded lazily

    load_active_mitsuba(variant)  # first: the class subclasses the classes of the variant set
    from compare.mitsuba.plugins import glass as classes, register_plugin  # noqa: PLC0415

    return register_plugin(PLUGIN_NAME, classes, "RoughGlassBSDF")
