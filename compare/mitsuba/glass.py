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
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from compare.brdf.multiscatter import lookup_2d, lookup_3d

__all__ = ["PLUGIN_NAME", "TABLE_PATH", "energy_scale", "masking_ratio", "register"]

PLUGIN_NAME = "rough_glass"
TABLE_PATH = Path(__file__).with_name("glass_energy.npz")
_CLASSES: dict[str, type] = {}


def _load() -> dict[str, np.ndarray]:
    with np.load(TABLE_PATH) as data:
        return {k: data[k].astype(np.float64) for k in ("ggx_glass_E", "ggx_glass_Eavg", "ggx_glass_inv_E",
                                                        "ggx_glass_inv_Eavg")}


#: ``E[z, mu, r]`` and ``E_avg[z, r]`` on Cycles' 16-point grids (z = sqrt((ior - 1)/(ior + 1))), from outside
#: (ior > 1) and from inside (``_inv``: relative IOR 1/ior).
TABLES = _load()


def energy_scale(roughness, cos_i, ior, tint=(1.0, 1.0, 1.0)):
    """Cycles' factor on rough glass, per channel: ``1 + F_ms (1 - E) / E`` (see the module notes).

    ``cos_i`` < 0 is the view from inside (the ``_inv`` tables); ``ior`` the material's (> 1).
    """
    c = np.asarray(cos_i, dtype=np.float64)
    inside = c < 0.0
    mu = np.abs(c)
    z = np.sqrt(np.abs((ior - 1.0) / (ior + 1.0)))
    r = np.clip(np.asarray(roughness, dtype=np.float64), 0.0, 1.0)
    e = np.where(inside, lookup_3d(TABLES["ggx_glass_inv_E"], r, mu, z), lookup_3d(TABLES["ggx_glass_E"], r, mu, z))
    e_avg = np.where(inside, lookup_2d(TABLES["ggx_glass_inv_Eavg"], r, z), lookup_2d(TABLES["ggx_glass_Eavg"], r, z))
    fss = np.asarray(tint, dtype=np.float64)
    e, e_avg = np.asarray(e)[..., None], np.asarray(e_avg)[..., None]
    f_ms = fss * e_avg / (1.0 - fss * (1.0 - e_avg))
    return 1.0 + f_ms * (1.0 - e) / e


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
    from compare.mitsuba.backend import register_bsdf_plugin  # noqa: PLC0415 - Mitsuba is loaded lazily

    return register_bsdf_plugin(PLUGIN_NAME, _make_class, _CLASSES, variant)


def _make_class(mv, mitsuba):
    import drjit as dr  # noqa: PLC0415

    kw = dict(use_accel=False, filter_mode=dr.FilterMode.Linear, wrap_mode=dr.WrapMode.Clamp)
    tex3 = {k: mv.Texture3f(mv.TensorXf(TABLES[k].astype("float32")[..., None]), **kw)
            for k in ("ggx_glass_E", "ggx_glass_inv_E")}
    tex2 = {k: mv.Texture2f(mv.TensorXf(TABLES[k].astype("float32")[..., None]), **kw)
            for k in ("ggx_glass_Eavg", "ggx_glass_inv_Eavg")}
    n = 16

    def coord(x):
        return (dr.clip(x, 0.0, 1.0) * (n - 1) + 0.5) * (1.0 / n)

    class RoughGlassBSDF(mv.BSDF):
        """Height-correlated masking (and Cycles' compensation) around a nested rough dielectric
        (see :mod:`compare.mitsuba.glass`)."""

        def __init__(self, props):
            mv.BSDF.__init__(self, props)
            self.nested = props["bsdf"]
            self.roughness = float(props.get("roughness", 0.0))
            self.alpha = max(self.roughness * self.roughness, 1e-4)
            self.compensate = bool(props.get("compensate", False))
            self.ior = float(props.get("ior", 1.5))
            if not self.ior > 1.0:
                raise ValueError(f"{PLUGIN_NAME}: ior must be > 1, got {self.ior}")
            self.tint = props.get_texture("tint", 1.0)
            self.z = float(np.sqrt((self.ior - 1.0) / (self.ior + 1.0)))
            self.m_components = [self.nested.flags(i) for i in range(self.nested.component_count())]
            self.m_flags = self.nested.flags()

        def _masking(self, wi, wo):
            """(1 + Λi)(1 + Λo) / (1 + Λi + Λo): height-correlated over separable Smith masking."""
            a2 = self.alpha * self.alpha

            def lam(c):
                c2 = dr.maximum(c * c, 1e-12)
                return 0.5 * (dr.sqrt(1.0 + a2 * dr.maximum(1.0 / c2 - 1.0, 0.0)) - 1.0)

            li, lo = lam(wi.z), lam(wo.z)
            return (1.0 + li) * (1.0 + lo) / (1.0 + li + lo)

        def _scale(self, si, active):
            if not self.compensate:
                return 1.0
            inside = si.wi.z < 0.0
            mu = dr.abs(si.wi.z)
            p3 = mv.Point3f(coord(self.roughness), coord(mu), coord(self.z))
            p2 = mv.Point2f(coord(self.roughness), coord(self.z))
            e = dr.select(inside, tex3["ggx_glass_inv_E"].eval(p3)[0], tex3["ggx_glass_E"].eval(p3)[0])
            e_avg = dr.select(inside, tex2["ggx_glass_inv_Eavg"].eval(p2)[0], tex2["ggx_glass_Eavg"].eval(p2)[0])
            fss = self.tint.eval(si, active)
            f_ms = fss * e_avg / (1.0 - fss * (1.0 - e_avg))
            return 1.0 + f_ms * ((1.0 - e) / dr.maximum(e, 1e-6))

        def eval(self, ctx, si, wo, active=True):
            return self.nested.eval(ctx, si, wo, active) * (self._masking(si.wi, wo) * self._scale(si, active))

        def pdf(self, ctx, si, wo, active=True):
            return self.nested.pdf(ctx, si, wo, active)

        def eval_pdf(self, ctx, si, wo, active=True):
            value, pdf = self.nested.eval_pdf(ctx, si, wo, active)
            return value * (self._masking(si.wi, wo) * self._scale(si, active)), pdf

        def sample(self, ctx, si, sample1, sample2, active=True):
            bs, weight = self.nested.sample(ctx, si, sample1, sample2, active)
            return bs, weight * (self._masking(si.wi, bs.wo) * self._scale(si, active))

        def traverse(self, callback):
            pass

        def parameters_changed(self, keys=()):
            pass

        def to_string(self):
            return (f"RoughGlassBSDF[roughness = {self.roughness}, ior = {self.ior}, "
                    f"compensate = {self.compensate}]")

    return RoughGlassBSDF
