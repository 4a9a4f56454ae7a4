"""The class of ``gltf_pbr``, the shared glTF BRDF and its ``cycles`` flavour (:mod:`compare.mitsuba.bsdf`:
read its docstring). Bound to a variant: see :mod:`compare.mitsuba.plugins`.
"""

from __future__ import annotations

import math

import drjit as dr
from mitsuba import BSDFFlags, ParamFlags

from compare.brdf import DIELECTRIC_F0, H_LEN2_MIN, REFERENCE_ALPHA_MIN, SPECULAR_PROB_MIN, multiscatter
from compare.brdf.iridescence import drjit_ops, iridescence_fresnel
from compare.mitsuba import ggx, principled
from compare.mitsuba.plugins import base, bound_variant, for_variant
from compare.mitsuba.principled_tables import tables

__all__ = ["CyclesLayer", "GltfPbrBSDF", "f82_b", "fresnel_f82", "schlick_weight"]

mv = bound_variant(__name__)
PluginBSDF = for_variant(base).PluginBSDF
Float, UInt32, Color3f, Vector3f = mv.Float, mv.UInt32, mv.Color3f, mv.Vector3f
DIFFUSE = BSDFFlags.DiffuseReflection | BSDFFlags.FrontSide
GLOSSY = BSDFFlags.GlossyReflection | BSDFFlags.FrontSide
_OPS = drjit_ops(dr)


def schlick_weight(v_dot_h):
    """Schlick's ``(1 - v.h)^5``, ``v.h`` clamped to [0, 1]."""
    x = dr.clip(1.0 - v_dot_h, 0.0, 1.0)
    x2 = x * x
    return x2 * x2 * x


def _mean3(c):
    return (c[0] + c[1] + c[2]) * (1.0 / 3.0)


def _max3(c):
    return dr.maximum(dr.maximum(c[0], c[1]), c[2])


def f82_b(cc, tint):
    """Cycles' fresnel_f82tint_B with the tint clamped to at most 1."""
    f = 6.0 / 7.0
    f5 = f ** 5
    return (cc + (1.0 - cc) * f5) * (7.0 / (f5 * f)) * (1.0 - dr.minimum(tint, 1.0))


def fresnel_f82(cc, b, c):
    """Cycles' F82-tint Fresnel of a metal of colour ``cc`` at cosine ``c`` (:func:`f82_b` gives ``b``)."""
    x = dr.clip(1.0 - c, 0.0, 1.0)
    x5 = schlick_weight(c)
    return dr.clip(cc + (1.0 - cc) * x5 - b * (c * x5 * x), 0.0, 1.0)


def _compensation(cc, b, lay, r, cos_i):
    """(K_m, K_d, L_d), each Color3f, of compare.mitsuba.principled: Multiscatter GGX's lobe scales
    and layer factor."""
    k_m, _ = tables(mv).compensation(cc + (1.0 - cc) * (1.0 / 21.0) - b * (1.0 / 126.0), r, cos_i)
    k_d, l_d = tables(mv).compensation(lay.fss, r, cos_i)
    return k_m, k_d, l_d


class CyclesLayer:
    """Per-point constants of the Principled v2 specular layer (compare.mitsuba.principled):
    its IOR after Specular IOR Level, tinted F0, remapping of the real Fresnel, F_ss, presence."""

    def __init__(self, ior, level, tint):
        f0 = principled.f0_from_ior(ior) * 2.0 * dr.maximum(level, 0.0)
        sq = dr.sqrt(dr.clip(f0, 0.0, 0.99))
        self.eta = dr.select(level == principled.NEUTRAL_LEVEL, ior, (1.0 + sq) / (1.0 - sq))
        self.on = self.eta != 1.0
        eta = dr.select(self.on, self.eta, 1.5)  # keeps the remapping finite where the layer is absent
        self.eta_safe = eta
        self.f0e = principled.f0_from_ior(eta)
        self.inv = 1.0 / (1.0 - self.f0e)
        self.f0t = dr.clip(f0 * tint, 0.0, 1.0)
        s_avg = dr.clip((multiscatter.fresnel_dielectric_fss(eta) - self.f0e) * self.inv, 0.0, 1.0)
        self.fss = dr.select(self.on, self.f0t + (1.0 - self.f0t) * s_avg, 0.0)

    def fresnel(self, c):
        """Color3f: ``f0t + (1 - f0t) s(c)``, zero where the layer is absent."""
        s = dr.clip((tables(mv).fresnel_dielectric(c, self.eta_safe) - self.f0e) * self.inv, 0.0, 1.0)
        return dr.select(self.on, self.f0t + (1.0 - self.f0t) * s, 0.0)

    def albedo(self, r, cos_i):
        """E_s(r, cos_i) = f0t + (1 - f0t) S(r, cos_i, eta) (Cycles' trilinear lookup)."""
        s = tables(mv).layer_s(r, cos_i, self.eta_safe)
        return dr.select(self.on, self.f0t + (1.0 - self.f0t) * s, 0.0)


def _check_flavour_inputs(name, props, flavour, distribution, dielectric):
    """One clear error for a property that the flavour does not have, or an unknown distribution."""
    if flavour != "cycles" and "distribution" in props:
        raise ValueError(f"{name}: distribution applies to flavour 'cycles' only "
                         f"(flavour {flavour!r} is glTF's single-scattering GGX)")
    if distribution not in multiscatter.DISTRIBUTIONS:
        raise ValueError(f"{name}: distribution must be one of "
                         f"{', '.join(multiscatter.DISTRIBUTIONS)}, got {distribution!r}")
    if dielectric and flavour == "cycles":
        raise ValueError(f"{name}: specular_f0 and specular_weight apply to flavour 'gltf' only "
                         "(flavour 'cycles' has ior, specular_ior_level and specular_tint)")
    principled_inputs = [k for k in principled.CYCLES_INPUTS if k in props]
    if principled_inputs and flavour != "cycles":
        raise ValueError(f"{name}: {', '.join(principled_inputs)} apply to flavour 'cycles' only "
                         "(flavour 'gltf' has specular_f0 and specular_weight)")


class GltfPbrBSDF(PluginBSDF):
    """glTF 2.0 metallic-roughness BSDF (see :mod:`compare.mitsuba.bsdf`)."""

    def __init__(self, props):
        super().__init__(props)
        name = props.plugin_name()
        self.base_color = props.get_texture("base_color", 1.0)
        self.metallic = props.get_texture("metallic", 1.0)
        self.roughness = props.get_texture("roughness", 1.0)
        self.flavour = principled.check_flavour(name, props.get("flavour", "gltf"))
        self.distribution = props.get("distribution", multiscatter.DEFAULT_DISTRIBUTION)
        self.multiscatter = self.flavour == "cycles" and self.distribution == "multi_ggx"
        # glTF's ior and specular extensions (compare.brdf.dielectric_specular): the dielectric's F0
        # (RGB) and weight; without them the core model's code runs unchanged.
        self.dielectric = "specular_f0" in props or "specular_weight" in props
        _check_flavour_inputs(name, props, self.flavour, self.distribution, self.dielectric)
        self.specular_f0 = props.get_texture("specular_f0", DIELECTRIC_F0)
        self.specular_weight = props.get_texture("specular_weight", 1.0)
        # Blender's Principled v2 inputs (flavour "cycles"); the IOR has no map in glTF.
        self.ior = float(props.get("ior", principled.IOR))
        if not (self.ior >= 1.0 and math.isfinite(self.ior)):
            raise ValueError(f"{name}: ior must be a finite number >= 1, got {self.ior}")
        self.specular_ior_level = props.get_texture("specular_ior_level", principled.NEUTRAL_LEVEL)
        self.specular_tint = props.get_texture("specular_tint", 1.0)
        if self.flavour == "cycles":
            tables(mv)  # built at load time, never while a kernel is traced
        # glTF's anisotropy (KHR_materials_anisotropy): the specular lobe stretched along the local frame's x
        # axis (glTF's tangent, under gltf_normalmap) turned by the rotation, and by the map's direction
        self.anisotropy = float(props.get("anisotropy_strength", 0.0))
        rotation = float(props.get("anisotropy_rotation", 0.0))
        if not (0.0 <= self.anisotropy <= 1.0 and math.isfinite(rotation)):
            raise ValueError(f"{name}: anisotropy_strength must be in [0, 1] and anisotropy_rotation finite")
        if self.anisotropy > 0.0 and self.flavour == "cycles":
            raise ValueError(f"{name}: anisotropy applies to flavour 'gltf' only")
        self.direction = (math.cos(rotation), math.sin(rotation))
        self.anisotropy_map = props.get_texture("anisotropy_map") if "anisotropy_map" in props else None
        # glTF's thin-film iridescence (KHR_materials_iridescence, compare.brdf.iridescence): its Fresnel mixed
        # into each lobe's by the factor (a number or a map times it); the film's thickness a number or
        # mix(minimum, maximum, map)
        factor = props.get("iridescence", 0.0)
        self.has_film = not isinstance(factor, (int, float)) or factor != 0.0
        self.iridescence = props.get_texture("iridescence", 0.0)
        self.film_ior = float(props.get("iridescence_ior", 1.3))
        self.film_thickness = float(props.get("iridescence_thickness", 400.0))
        self.film_thickness_min = float(props.get("iridescence_thickness_min", 0.0))
        self.film_map = (props.get_texture("iridescence_thickness_map")
                         if "iridescence_thickness_map" in props else None)
        if not ((not isinstance(factor, (int, float)) or 0.0 <= factor <= 1.0) and self.film_ior >= 1.0
                and self.film_thickness >= 0.0 and self.film_thickness_min >= 0.0):
            raise ValueError(f"{name}: iridescence must be in [0, 1], iridescence_ior >= 1 and "
                             "iridescence_thickness(_min) >= 0")
        if self.has_film and self.flavour == "cycles":
            raise ValueError(f"{name}: iridescence applies to flavour 'gltf' only")
        self.m_components = [DIFFUSE, GLOSSY]
        self.m_flags = DIFFUSE | GLOSSY

    # -- material parameters at a surface point --------------------------------
    def _params(self, si, active):
        c = self.base_color.eval(si, active)
        m = dr.clip(self.metallic.eval_1(si, active), 0.0, 1.0)
        r = dr.clip(self.roughness.eval_1(si, active), 0.0, 1.0)
        alpha = dr.maximum(r * r, REFERENCE_ALPHA_MIN)
        return c, m, alpha, r

    def _cycles_params(self, si, c, active):
        """(clamped base colour, the metal's F82 B, the specular layer) of flavour ``cycles``."""
        tint = dr.maximum(self.specular_tint.eval(si, active), 0.0)
        lay = CyclesLayer(Float(self.ior), self.specular_ior_level.eval_1(si, active), tint)
        cc = dr.clip(c, 0.0, 1.0)
        return cc, f82_b(cc, tint), lay

    def _extra_params(self, si, c, active):
        """What the flavour needs besides c, m, r: the Principled layer (``cycles``), glTF's
        dielectric (F0, weight) with the ior/specular extensions, or None (the core model)."""
        if self.flavour == "cycles":
            return self._cycles_params(si, c, active)
        return self._dielectric_params(si, active) if self.dielectric else None

    def _film(self, si, active):
        """(the iridescence factor, the film's thickness in nm) at the surface point; None without a film."""
        if not self.has_film:
            return None
        k = dr.clip(self.iridescence.eval_1(si, active), 0.0, 1.0)
        if self.film_map is None:
            return k, self.film_thickness
        g = dr.clip(self.film_map.eval_1(si, active), 0.0, 1.0)
        return k, dr.lerp(self.film_thickness_min, self.film_thickness, g)

    def _anisotropy(self, si, active):
        """(strength, cos, sin of the direction from the tangent) at the surface point; None when isotropic.
        The map's RG is the direction in the tangent frame ([0, 1] → [−1, 1]), turned by the rotation; its B
        multiplies the strength (the extension's text)."""
        if self.anisotropy == 0.0:
            return None
        cr, sr = self.direction
        if self.anisotropy_map is None:
            return self.anisotropy, cr, sr
        t = self.anisotropy_map.eval(si, active)
        x, y = 2.0 * t[0] - 1.0, 2.0 * t[1] - 1.0
        length = dr.sqrt(x * x + y * y)
        ok = length > 1e-6  # a zero direction has no axis: the tangent's, as the rotation turns it
        inv = dr.select(ok, dr.rcp(dr.select(ok, length, 1.0)), 0.0)
        x, y = dr.select(ok, x * inv, 1.0), dr.select(ok, y * inv, 0.0)
        return dr.clip(self.anisotropy * t[2], 0.0, 1.0), cr * x - sr * y, sr * x + cr * y

    def _dielectric_params(self, si, active):
        """(F0, weight) of glTF's ior and specular extensions at the surface point."""
        return self.specular_f0.eval(si, active), dr.clip(self.specular_weight.eval_1(si, active), 0.0, 1.0)

    # -- the flavours' lobes ----------------------------------------------------
    def _cycles_lobes(self, extra, m, r, cos_i, x):
        """Flavour ``cycles``: (the specular lobes' Fresnel-and-compensation at x = v.h, per channel;
        the diffuse weight at the view's cos_i)."""
        cc, b, lay = extra
        f_m, f_d, e_s = fresnel_f82(cc, b, x), lay.fresnel(x), lay.albedo(r, cos_i)
        if self.multiscatter:
            k_m, k_d, l_d = _compensation(cc, b, lay, r, cos_i)
            f_m, f_d, e_s = f_m * k_m, f_d * k_d, e_s * l_d
        return f_m * m + f_d * (1.0 - m), (1.0 - m) * dr.clip(1.0 - _max3(e_s), 0.0, 1.0)

    def _lobes(self, extra, c, m, r, cos_i, x, film=None):
        """(the specular lobe's Fresnel at x = v.h, per channel; the diffuse weight) of the flavour, the
        view at cosine ``cos_i``, under the thin ``film`` (:meth:`_film`): the one definition that the value
        and the lobe probabilities share."""
        if self.flavour == "cycles":
            return self._cycles_lobes(extra, m, r, cos_i, x)
        w = schlick_weight(x)
        if self.dielectric:
            f0d, sw = extra
            fr = f0d + (1.0 - f0d) * w
            metal = c + (1.0 - c) * w
            if film is not None:
                metal, fr = self._iridescent(metal, c, x, film), self._iridescent(fr, f0d, x, film)
            return (m * metal + (1.0 - m) * sw * fr,
                    (1.0 - m) * (1.0 - sw * dr.maximum(dr.maximum(fr.x, fr.y), fr.z)))
        if film is not None:  # each lobe's Fresnel mixed with its film's; the base weighted by the largest
            metal = self._iridescent(c + (1.0 - c) * w, c, x, film)
            fr = self._iridescent(Color3f(DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * w), Color3f(DIELECTRIC_F0), x,
                                  film)
            return m * metal + (1.0 - m) * fr, (1.0 - m) * (1.0 - _max3(fr))
        f0 = DIELECTRIC_F0 + (c - DIELECTRIC_F0) * m
        fd = DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * w
        return f0 + (1.0 - f0) * w, (1.0 - m) * (1.0 - fd)

    def _iridescent(self, fresnel, f0, x, film):
        """``mix(fresnel, F_iridescence, iridescence)``: the thin film over a base of reflectance ``f0``. A film
        of thickness 0 is no film (its index goes to the outside's: the extension's sample renderer)."""
        k, thickness = film
        f = iridescence_fresnel(_OPS, x, thickness, self.film_ior, [f0[0], f0[1], f0[2]])
        f = Color3f(f[0], f[1], f[2])
        if self.film_map is not None:
            f = dr.select(thickness > 0.0, f, fresnel)
        return fresnel + (f - fresnel) * k

    @staticmethod
    def _lobes_enabled(ctx):
        return (ctx.is_enabled(BSDFFlags.DiffuseReflection, 0),
                ctx.is_enabled(BSDFFlags.GlossyReflection, 1))

    def _lobe_probabilities(self, cos_i, c, m, r, has_diffuse, has_specular, extra=None, film=None):
        """(p_spec, p_diff) of compare.brdf.specular_sampling_probability (flavour ``cycles``:
        compare.mitsuba.principled.specular_sampling_probability); p_diff is computed directly
        (not as 1 - p_spec), which keeps it accurate in float32."""
        if not has_specular:
            return Float(0.0), Float(1.0)
        if not has_diffuse:
            return Float(1.0), Float(0.0)
        ci = dr.clip(cos_i, 0.0, 1.0)
        f, w_diff = self._lobes(extra, c, m, r, ci, ci, film)
        w_s = _mean3(f)
        w_d = w_diff * _mean3(c)
        inv_total = 1.0 / dr.select(w_s + w_d > 0.0, w_s + w_d, 1.0)
        has_d = w_d > 0.0
        p_spec = dr.select(has_d, dr.maximum(w_s * inv_total, SPECULAR_PROB_MIN), 1.0)
        p_diff = dr.select(has_d, dr.minimum(w_d * inv_total, 1.0 - SPECULAR_PROB_MIN), 0.0)
        return p_spec, p_diff

    # -- anisotropy -----------------------------------------------------------------
    @staticmethod
    def _to_aniso(v, aniso):
        """``v`` in the frame whose x axis is the anisotropy direction (:meth:`_anisotropy`)."""
        _, c, s = aniso
        return Vector3f(c * v.x + s * v.y, c * v.y - s * v.x, v.z)

    @staticmethod
    def _from_aniso(v, aniso):
        _, c, s = aniso
        return Vector3f(c * v.x - s * v.y, s * v.x + c * v.y, v.z)

    @staticmethod
    def _alphas(alpha, aniso):
        """(α along the direction, α across it): glTF's mix(α, 1, strength²) and α."""
        k = aniso[0] * aniso[0]
        return dr.fma(1.0 - alpha, k, alpha), alpha

    def _specular_terms(self, wi, wo, h, alpha, aniso):
        """(D, V, the visible-normal pdf of ``wo``) of the specular lobe, isotropic or anisotropic."""
        if aniso is None:
            d = ggx.ggx_d(dr, h, alpha)
            return d, ggx.smith_vis(dr, wi.z, wo.z, alpha), ggx.vndf_pdf(dr, d, wi.z, alpha)
        ax, ay = self._alphas(alpha, aniso)
        wi_a = self._to_aniso(wi, aniso)
        d = ggx.ggx_d_aniso(dr, self._to_aniso(h, aniso), ax, ay)
        return (d, ggx.smith_vis_aniso(dr, wi_a, self._to_aniso(wo, aniso), ax, ay),
                ggx.vndf_pdf_aniso(dr, d, wi_a, ax, ay))

    def _sample_specular(self, wi, alpha, sample2, aniso):
        if aniso is None:
            return ggx.sample_visible_reflection(dr, Vector3f, wi, alpha, sample2)
        ax, ay = self._alphas(alpha, aniso)
        return self._from_aniso(ggx.sample_visible_reflection_aniso(dr, Vector3f, self._to_aniso(wi, aniso), ax, ay,
                                                                    sample2), aniso)

    # -- the model: value (times cos_o) and pdf of one direction ------------------
    def eval_pdf(self, ctx, si, wo, active=True):
        has_d, has_s = self._lobes_enabled(ctx)
        wi = si.wi
        cos_i = wi.z
        cos_o = wo.z
        h, len2 = ggx.half_vector(dr, wi, wo)
        valid = active & (cos_i > 0.0) & (cos_o > 0.0) & (len2 > H_LEN2_MIN)
        c, m, alpha, r = self._params(si, valid)

        vh = dr.clip(dr.dot(wi, h), 0.0, 1.0)
        d, vis, pdf_spec = self._specular_terms(wi, wo, h, alpha, self._anisotropy(si, valid))
        extra, film = self._extra_params(si, c, valid), self._film(si, valid)
        f, w_diff = self._lobes(extra, c, m, r, cos_i, vh, film)

        value = Color3f(0.0)
        if has_s:
            value += f * (d * vis)
        if has_d:
            value += c * (w_diff * (1.0 / dr.pi))
        value = value * dr.maximum(cos_o, 0.0)

        pdf_diff = dr.maximum(cos_o, 0.0) * (1.0 / dr.pi)
        p_spec, p_diff = self._lobe_probabilities(cos_i, c, m, r, has_d, has_s, extra, film)
        pdf = p_spec * pdf_spec + p_diff * pdf_diff

        value = dr.select(valid, value, Color3f(0.0))
        pdf = dr.select(valid, pdf, 0.0)
        return value, pdf

    def sample(self, ctx, si, sample1, sample2, active=True):
        has_d, has_s = self._lobes_enabled(ctx)
        wi = si.wi
        cos_i = wi.z
        active = active & (cos_i > 0.0)
        bs = dr.zeros(mv.BSDFSample3f)
        if not (has_d or has_s):
            return bs, Color3f(0.0)
        c, m, alpha, r = self._params(si, active)
        p_spec, _ = self._lobe_probabilities(cos_i, c, m, r, has_d, has_s, self._extra_params(si, c, active),
                                             self._film(si, active))
        pick_spec = sample1 < p_spec

        # specular: reflect wi about a GGX visible normal (spherical caps)
        wo_spec = self._sample_specular(wi, alpha, sample2, self._anisotropy(si, active))
        # diffuse: cosine-weighted hemisphere
        wo_diff = mv.warp.square_to_cosine_hemisphere(sample2)

        wo = dr.select(pick_spec, wo_spec, wo_diff)
        value, pdf = self.eval_pdf(ctx, si, wo, active)
        ok = active & (wo.z > 0.0) & (pdf > 0.0)

        bs.wo = wo
        bs.pdf = dr.select(ok, pdf, 0.0)
        bs.eta = 1.0
        bs.sampled_component = dr.select(pick_spec, UInt32(1), UInt32(0))
        bs.sampled_type = dr.select(pick_spec, UInt32(+BSDFFlags.GlossyReflection),
                                    UInt32(+BSDFFlags.DiffuseReflection))
        weight = dr.select(ok, value / dr.select(ok, pdf, 1.0), Color3f(0.0))
        return bs, weight

    def eval_diffuse_reflectance(self, si, active=True):
        c, m, _, _ = self._params(si, active)
        return c * (1.0 - m)

    def traverse(self, callback):
        callback.put("base_color", self.base_color, ParamFlags.Differentiable)
        callback.put("metallic", self.metallic, ParamFlags.Differentiable)
        callback.put("roughness", self.roughness, ParamFlags.Differentiable | ParamFlags.Discontinuous)

    def to_string(self):
        # one field a line, unlike the layers' one-line strings
        dist = f"  distribution = {self.distribution},\n" if self.flavour == "cycles" else ""
        return (f"GltfPbrBSDF[\n  flavour = {self.flavour},\n{dist}  base_color = {self.base_color},\n"
                f"  metallic = {self.metallic},\n  roughness = {self.roughness}\n]")
