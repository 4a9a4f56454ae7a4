"""The shared glTF 2.0 BRDF as a Mitsuba 3 BSDF plugin (``gltf_pbr``).

Same model, clamps and constants as :mod:`compare.brdf` (read its docstring),
written with Dr.Jit so that it runs in JIT variants (``llvm_ad_rgb``,
``cuda_ad_rgb``) and in ``scalar_rgb``. Usage::

    from compare.mitsuba.bsdf import register
    mi = register()                      # the active variant, or the best one
    bsdf = mi.load_dict({"type": "gltf_pbr", "base_color": {"type": "rgb", "value": [0.8, 0.1, 0.1]},
                         "metallic": 0.0, "roughness": 0.5})

Properties (each a float/rgb or a nested texture; defaults are glTF's):

``base_color``  linear base colour, default 1.0
``metallic``    default 1.0
``roughness``   perceptual roughness, default 1.0
``flavour``     string, ``"gltf"`` (default) or ``"cycles"``
``distribution`` string, flavour ``"cycles"`` only: ``"multi_ggx"`` (default, Blender's
                Multiscatter GGX) or ``"ggx"`` (single scattering)
``specular_f0``, ``specular_weight``  flavour ``"gltf"`` only: glTF's ior and specular extensions,
                the dielectric's F0 (rgb) and weight (:func:`compare.brdf.dielectric_specular`);
                without them the core model (F0 = 0.04) runs its own code.
``ior``, ``specular_ior_level``, ``specular_tint``  flavour ``"cycles"`` only: Blender's
                Principled v2 inputs of those names (float >= 1; float or texture, default 0.5;
                rgb or texture, default white), :func:`compare.mitsuba.principled.specular_ior`.

Flavours. ``"gltf"`` is the shared BRDF of :mod:`compare.brdf`, the same
definition as the rasterizer's GLSL. ``"cycles"`` is Blender's Principled BSDF
v2 as :mod:`compare.blender.export` configures it, the model of
:mod:`compare.mitsuba.principled` (read its docstring): the same GGX D and
height-correlated Smith V, but the exact dielectric Fresnel curve at the
adjusted IOR, remapped to the tinted F0, in place of Schlick with F0 = 0.04
(metals: Cycles' F82-tint, Schlick when the tint is white), and the Lambert lobe weighted by the view-only
``(1 - m)(1 - max_rgb E_s(r, cos_i))`` (Cycles' albedo scaling under the specular layer,
``E_s`` read from :data:`compare.mitsuba.principled.LAYER_S_TABLE_3D`, held in a
Dr.Jit ``Texture3f`` with Cycles' grid and trilinear interpolation) in place of
the per-direction ``(1 - m)(1 - F_d(v.h))``; with ``distribution = "multi_ggx"``
each specular lobe times Multiscatter GGX's view-dependent energy compensation
and the diffuse's layering albedo times its factor
(:mod:`compare.brdf.multiscatter`, tables ``ggx_E`` and ``ggx_Eavg`` as
Dr.Jit textures on Cycles' grid). The ``"gltf"`` flavour traces
exactly the code it always has, so its results are bit-identical to the
plugin without the option.

Conventions (Mitsuba's): directions in the local shading frame (z = normal),
``si.wi`` towards the viewer; ``eval`` returns ``f * cos(theta_o)``. One-sided,
like Mitsuba's ``diffuse`` and ``roughconductor``: zero when ``wi`` or ``wo`` is
below the horizon. Components: 0 = diffuse (``DiffuseReflection``), 1 = specular
(``GlossyReflection``); a ``BSDFContext`` may select either.

Sampling: with probability ``p_spec`` (:func:`compare.brdf.specular_sampling_probability`:
the Fresnel-weighted specular versus the diffuse albedo estimate at
``cos(theta_i)``, floored at 0.1 while a diffuse lobe exists; the ``cycles``
flavour uses its own Fresnel and diffuse weight in the same estimate,
:func:`compare.mitsuba.principled.specular_sampling_probability`) a GGX visible
normal is drawn (Dupuy & Benyoub 2023, spherical caps; the distribution of Heitz
2018) and ``wi`` reflected about it; otherwise a cosine-weighted direction.
``pdf`` is the mixture ``p_spec pdf_spec + (1 - p_spec) cos/pi`` whichever lobe
produced the direction (one-sample MIS), and ``sample``'s weight is
``eval / pdf`` of the returned direction.

Registration is per variant (``mi.register_bsdf`` registers with the variant
active at the call); :func:`register` is idempotent per variant and builds the
class from that variant's module, so an instance keeps working after
``mi.set_variant`` switches to another variant.
"""

from __future__ import annotations

import math

from compare.brdf import REFERENCE_ALPHA_MIN, DIELECTRIC_F0, H_LEN2_MIN, SPECULAR_PROB_MIN, multiscatter
from compare.mitsuba import ggx, principled
from compare.mitsuba.principled_tables import tables

__all__ = ["FLAVOURS", "PLUGIN_NAME", "evaluate", "register", "registered_variants"]

#: Name under which the plugin is registered (``{"type": PLUGIN_NAME, ...}``).
PLUGIN_NAME = "gltf_pbr"
#: Values of the ``flavour`` property: the shared glTF BRDF, Blender's Principled BSDF v2.
FLAVOURS = principled.FLAVOURS
#: Properties of flavour ``cycles`` only: Blender's Principled BSDF v2 inputs of the same names.
CYCLES_INPUTS = ("ior", "specular_ior_level", "specular_tint")

_CLASSES: dict[str, type] = {}


def registered_variants() -> tuple[str, ...]:
    """Variants in which :data:`PLUGIN_NAME` has been registered by this process."""
    return tuple(_CLASSES)


def register(variant: str | None = None):
    """Register ``gltf_pbr`` with Mitsuba for a variant and return the ``mitsuba`` module.

    Parameters
    ----------
    variant : str, optional
        Variant to register with (and make active). Default: the variant that
        is active now, or, when Mitsuba has not been loaded yet, the one
        :func:`compare.mitsuba.backend.load_mitsuba` picks.

    Returns
    -------
    module
        ``mitsuba``, with the variant active. Calling again is cheap and does
        not register twice.
    """
    from compare.mitsuba.backend import register_bsdf_plugin  # noqa: PLC0415 - Mitsuba is loaded lazily

    return register_bsdf_plugin(PLUGIN_NAME, _make_class, _CLASSES, variant)


def _make_class(mv, mitsuba):
    """Build the BSDF class against one variant module ``mv`` (e.g. ``mitsuba.llvm_ad_rgb``).

    Variant-independent enums (``BSDFFlags``, ``ParamFlags``) come from ``mitsuba``.
    """
    import drjit as dr  # noqa: PLC0415

    Float = mv.Float
    UInt32 = mv.UInt32
    Color3f = mv.Color3f
    Vector3f = mv.Vector3f
    Flags = mitsuba.BSDFFlags
    ParamFlags = mitsuba.ParamFlags
    diffuse_flags = Flags.DiffuseReflection | Flags.FrontSide
    glossy_flags = Flags.GlossyReflection | Flags.FrontSide

    def schlick_weight(v_dot_h):
        x = dr.clip(1.0 - v_dot_h, 0.0, 1.0)
        x2 = x * x
        return x2 * x2 * x

    def mean3(c):
        return (c[0] + c[1] + c[2]) * (1.0 / 3.0)

    def compensation(cc, b, lay, r, cos_i):
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

    def max3(c):
        return dr.maximum(dr.maximum(c[0], c[1]), c[2])

    def f82_b(cc, tint):
        """Cycles' fresnel_f82tint_B with the tint clamped to at most 1."""
        f = 6.0 / 7.0
        f5 = f ** 5
        return (cc + (1.0 - cc) * f5) * (7.0 / (f5 * f)) * (1.0 - dr.minimum(tint, 1.0))

    def fresnel_f82(cc, b, c):
        x = dr.clip(1.0 - c, 0.0, 1.0)
        x5 = schlick_weight(c)
        return dr.clip(cc + (1.0 - cc) * x5 - b * (c * x5 * x), 0.0, 1.0)

    class GltfPbrBSDF(mv.BSDF):
        """glTF 2.0 metallic-roughness BSDF (see :mod:`compare.mitsuba.bsdf`)."""

        def __init__(self, props):
            mv.BSDF.__init__(self, props)
            self.base_color = props.get_texture("base_color", 1.0)
            self.metallic = props.get_texture("metallic", 1.0)
            self.roughness = props.get_texture("roughness", 1.0)
            self.flavour = principled.check_flavour(PLUGIN_NAME, props.get("flavour", "gltf"))
            self.distribution = props.get("distribution", multiscatter.DEFAULT_DISTRIBUTION)
            if self.flavour != "cycles" and "distribution" in props:
                raise ValueError(f"{PLUGIN_NAME}: distribution applies to flavour 'cycles' only "
                                 f"(flavour {self.flavour!r} is glTF's single-scattering GGX)")
            if self.distribution not in multiscatter.DISTRIBUTIONS:
                raise ValueError(f"{PLUGIN_NAME}: distribution must be one of "
                                 f"{', '.join(multiscatter.DISTRIBUTIONS)}, got {self.distribution!r}")
            self.multiscatter = self.flavour == "cycles" and self.distribution == "multi_ggx"
            # glTF's ior and specular extensions (compare.brdf.dielectric_specular): the dielectric's F0
            # (RGB) and weight; without them the core model's code runs unchanged.
            self.dielectric = "specular_f0" in props or "specular_weight" in props
            if self.dielectric and self.flavour == "cycles":
                raise ValueError(f"{PLUGIN_NAME}: specular_f0 and specular_weight apply to flavour 'gltf' only "
                                 "(flavour 'cycles' has ior, specular_ior_level and specular_tint)")
            principled_inputs = [k for k in CYCLES_INPUTS if k in props]
            if principled_inputs and self.flavour != "cycles":
                raise ValueError(f"{PLUGIN_NAME}: {', '.join(principled_inputs)} apply to flavour 'cycles' only "
                                 "(flavour 'gltf' has specular_f0 and specular_weight)")
            self.specular_f0 = props.get_texture("specular_f0", DIELECTRIC_F0)
            self.specular_weight = props.get_texture("specular_weight", 1.0)
            # Blender's Principled v2 inputs (flavour "cycles"); the IOR has no map in glTF.
            self.ior = float(props.get("ior", principled.IOR))
            if not (self.ior >= 1.0 and math.isfinite(self.ior)):
                raise ValueError(f"{PLUGIN_NAME}: ior must be a finite number >= 1, got {self.ior}")
            self.specular_ior_level = props.get_texture("specular_ior_level", principled.NEUTRAL_LEVEL)
            self.specular_tint = props.get_texture("specular_tint", 1.0)
            if self.flavour == "cycles":
                tables(mv)  # built at load time, never while a kernel is traced
            self.m_components = [diffuse_flags, glossy_flags]
            self.m_flags = diffuse_flags | glossy_flags

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

        def _cycles_lobes(self, extra, m, r, cos_i, x):
            """Flavour ``cycles``: (the specular lobes' Fresnel-and-compensation at x = v.h, per channel;
            the diffuse weight at the view's cos_i)."""
            cc, b, lay = extra
            f_m, f_d, e_s = fresnel_f82(cc, b, x), lay.fresnel(x), lay.albedo(r, cos_i)
            if self.multiscatter:
                k_m, k_d, l_d = compensation(cc, b, lay, r, cos_i)
                f_m, f_d, e_s = f_m * k_m, f_d * k_d, e_s * l_d
            return f_m * m + f_d * (1.0 - m), (1.0 - m) * dr.clip(1.0 - max3(e_s), 0.0, 1.0)

        def _extra_params(self, si, c, active):
            """What the flavour needs besides c, m, r: the Principled layer (``cycles``), glTF's
            dielectric (F0, weight) with the ior/specular extensions, or None (the core model)."""
            if self.flavour == "cycles":
                return self._cycles_params(si, c, active)
            return self._dielectric_params(si, active) if self.dielectric else None

        def _dielectric_params(self, si, active):
            """(F0, weight) of glTF's ior and specular extensions at the surface point."""
            return self.specular_f0.eval(si, active), dr.clip(self.specular_weight.eval_1(si, active), 0.0, 1.0)

        @staticmethod
        def _lobes_enabled(ctx):
            return (ctx.is_enabled(Flags.DiffuseReflection, 0),
                    ctx.is_enabled(Flags.GlossyReflection, 1))

        def _lobe_probabilities(self, cos_i, c, m, r, has_diffuse, has_specular, extra=None):
            """(p_spec, p_diff) of compare.brdf.specular_sampling_probability (flavour ``cycles``:
            compare.mitsuba.principled.specular_sampling_probability); p_diff is computed directly
            (not as 1 - p_spec), which keeps it accurate in float32."""
            if not has_specular:
                return Float(0.0), Float(1.0)
            if not has_diffuse:
                return Float(1.0), Float(0.0)
            ci = dr.clip(cos_i, 0.0, 1.0)
            w = schlick_weight(ci)
            if self.flavour == "cycles":
                f, w_diff = self._cycles_lobes(extra, m, r, ci, ci)
                w_s = mean3(f)
                w_d = w_diff * mean3(c)
            elif self.dielectric:
                f0d, sw = extra
                fr = f0d + (1.0 - f0d) * w
                w_s = mean3(m * (c + (1.0 - c) * w) + (1.0 - m) * sw * fr)
                w_d = (1.0 - m) * (1.0 - sw * dr.maximum(dr.maximum(fr.x, fr.y), fr.z)) * mean3(c)
            else:
                f0 = DIELECTRIC_F0 + (c - DIELECTRIC_F0) * m
                w_s = mean3(f0 + (1.0 - f0) * w)
                w_d = (1.0 - m) * (1.0 - (DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * w)) * mean3(c)
            inv_total = 1.0 / dr.select(w_s + w_d > 0.0, w_s + w_d, 1.0)
            has_d = w_d > 0.0
            p_spec = dr.select(has_d, dr.maximum(w_s * inv_total, SPECULAR_PROB_MIN), 1.0)
            p_diff = dr.select(has_d, dr.minimum(w_d * inv_total, 1.0 - SPECULAR_PROB_MIN), 0.0)
            return p_spec, p_diff

        # -- the model: value (times cos_o) and pdf of one direction ------------------
        def _eval_pdf(self, ctx, si, wo, active):
            has_d, has_s = self._lobes_enabled(ctx)
            wi = si.wi
            cos_i = wi.z
            cos_o = wo.z
            h, len2 = ggx.half_vector(dr, wi, wo)
            valid = active & (cos_i > 0.0) & (cos_o > 0.0) & (len2 > H_LEN2_MIN)
            c, m, alpha, r = self._params(si, valid)

            vh = dr.clip(dr.dot(wi, h), 0.0, 1.0)
            d = ggx.ggx_d(dr, h, alpha)
            vis = ggx.smith_vis(dr, cos_i, cos_o, alpha)

            w = schlick_weight(vh)
            extra = self._extra_params(si, c, valid)
            if self.flavour == "cycles":
                f, w_diff = self._cycles_lobes(extra, m, r, cos_i, vh)
            elif self.dielectric:
                f0d, sw = extra
                fr = f0d + (1.0 - f0d) * w
                f = m * (c + (1.0 - c) * w) + (1.0 - m) * sw * fr
                w_diff = (1.0 - m) * (1.0 - sw * dr.maximum(dr.maximum(fr.x, fr.y), fr.z))
            else:
                f0 = DIELECTRIC_F0 + (c - DIELECTRIC_F0) * m
                f = f0 + (1.0 - f0) * w
                fd = DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * w
                w_diff = (1.0 - m) * (1.0 - fd)

            value = Color3f(0.0)
            if has_s:
                value += f * (d * vis)
            if has_d:
                value += c * (w_diff * (1.0 / dr.pi))
            value = value * dr.maximum(cos_o, 0.0)

            pdf_spec = ggx.vndf_pdf(dr, d, cos_i, alpha)
            pdf_diff = dr.maximum(cos_o, 0.0) * (1.0 / dr.pi)
            p_spec, p_diff = self._lobe_probabilities(cos_i, c, m, r, has_d, has_s, extra)
            pdf = p_spec * pdf_spec + p_diff * pdf_diff

            value = dr.select(valid, value, Color3f(0.0))
            pdf = dr.select(valid, pdf, 0.0)
            return value, pdf

        def eval(self, ctx, si, wo, active=True):
            value, _ = self._eval_pdf(ctx, si, wo, active)
            return value

        def pdf(self, ctx, si, wo, active=True):
            _, pdf = self._eval_pdf(ctx, si, wo, active)
            return pdf

        def eval_pdf(self, ctx, si, wo, active=True):
            return self._eval_pdf(ctx, si, wo, active)

        def sample(self, ctx, si, sample1, sample2, active=True):
            has_d, has_s = self._lobes_enabled(ctx)
            wi = si.wi
            cos_i = wi.z
            active = active & (cos_i > 0.0)
            bs = dr.zeros(mv.BSDFSample3f)
            if not (has_d or has_s):
                return bs, Color3f(0.0)
            c, m, alpha, r = self._params(si, active)
            p_spec, _ = self._lobe_probabilities(cos_i, c, m, r, has_d, has_s, self._extra_params(si, c, active))
            pick_spec = sample1 < p_spec

            # specular: reflect wi about a GGX visible normal (spherical caps)
            wo_spec = ggx.sample_visible_reflection(dr, Vector3f, wi, alpha, sample2)
            # diffuse: cosine-weighted hemisphere
            wo_diff = mv.warp.square_to_cosine_hemisphere(sample2)

            wo = dr.select(pick_spec, wo_spec, wo_diff)
            value, pdf = self._eval_pdf(ctx, si, wo, active)
            ok = active & (wo.z > 0.0) & (pdf > 0.0)

            bs.wo = wo
            bs.pdf = dr.select(ok, pdf, 0.0)
            bs.eta = 1.0
            bs.sampled_component = dr.select(pick_spec, UInt32(1), UInt32(0))
            bs.sampled_type = dr.select(pick_spec, UInt32(+Flags.GlossyReflection),
                                        UInt32(+Flags.DiffuseReflection))
            weight = dr.select(ok, value / dr.select(ok, pdf, 1.0), Color3f(0.0))
            return bs, weight

        def eval_diffuse_reflectance(self, si, active=True):
            c, m, _, _ = self._params(si, active)
            return c * (1.0 - m)

        def traverse(self, callback):
            callback.put("base_color", self.base_color, ParamFlags.Differentiable)
            callback.put("metallic", self.metallic, ParamFlags.Differentiable)
            callback.put("roughness", self.roughness,
                         ParamFlags.Differentiable | ParamFlags.Discontinuous)

        def parameters_changed(self, keys=()):
            pass  # nothing is precomputed from the textures

        def to_string(self):
            dist = f"  distribution = {self.distribution},\n" if self.flavour == "cycles" else ""
            return (f"GltfPbrBSDF[\n  flavour = {self.flavour},\n{dist}  base_color = {self.base_color},\n"
                    f"  metallic = {self.metallic},\n  roughness = {self.roughness}\n]")

    return GltfPbrBSDF


def evaluate(wi, wo, base_color, metallic, roughness, *, variant: str | None = None, flavour: str = "gltf",
             distribution: str | None = None, dielectric=None, principled_inputs: dict | None = None):
    """Evaluate the plugin's ``eval_pdf`` for per-direction materials; numpy in, numpy out.

    The materials vary per row: they are passed as N x 1 ``bitmap`` textures
    (nearest filtering, raw values) and each row's ``si.uv`` points at its texel,
    so a JIT variant evaluates all rows in one call. ``scalar_rgb`` loops.

    Parameters
    ----------
    wi, wo : array_like, shape (N, 3)
        Local-frame directions (z = normal); ``wi`` towards the viewer.
    base_color : array_like, shape (N, 3)
    metallic, roughness : array_like, shape (N,)
    variant : str, optional
        Passed to :func:`register`.
    flavour : str
        The plugin's ``flavour`` (:data:`FLAVOURS`).
    distribution : str, optional
        The plugin's ``distribution`` (flavour ``cycles``); None leaves it unset (the default).
    dielectric : (F0, weight), optional
        glTF's ior and specular extensions (:func:`compare.brdf.dielectric_specular`) as the plugin's
        ``specular_f0`` and ``specular_weight``.
    principled_inputs : dict, optional
        Flavour ``cycles``: ``ior`` (float), ``specular_ior_level`` (per row, shape (N,)) and
        ``specular_tint`` (per row, shape (N, 3)), :data:`CYCLES_INPUTS`.

    Returns
    -------
    value : ndarray, shape (N, 3)
        ``f * cos(theta_o)`` as Mitsuba returns it (float32 values, as float64).
    pdf : ndarray, shape (N,)
    """
    import numpy as np  # noqa: PLC0415

    mi = register(variant)
    import drjit as dr  # noqa: PLC0415

    wi = np.asarray(wi, dtype=np.float32).reshape(-1, 3)
    wo = np.asarray(wo, dtype=np.float32).reshape(-1, 3)
    count = len(wi)
    base = np.broadcast_to(np.asarray(base_color, dtype=np.float32), (count, 3))
    met = np.broadcast_to(np.asarray(metallic, dtype=np.float32), (count,))
    rough = np.broadcast_to(np.asarray(roughness, dtype=np.float32), (count,))

    def bitmap(data):
        return {"type": "bitmap", "data": mi.TensorXf(np.ascontiguousarray(data.reshape(1, count, -1))),
                "raw": True, "filter_type": "nearest", "wrap_mode": "clamp"}

    props = {"type": PLUGIN_NAME, "base_color": bitmap(base), "flavour": flavour,
             "metallic": bitmap(met), "roughness": bitmap(rough)}
    if distribution is not None:
        props["distribution"] = distribution
    if dielectric is not None:  # (F0, weight) of compare.brdf.dielectric_specular
        props["specular_f0"] = {"type": "rgb", "value": [float(x) for x in np.broadcast_to(dielectric[0], 3)]}
        props["specular_weight"] = float(dielectric[1])
    for key, value in (principled_inputs or {}).items():
        if key == "ior":
            props[key] = float(value)
        else:
            props[key] = bitmap(np.broadcast_to(np.asarray(value, dtype=np.float32),
                                                (count, 3) if key == "specular_tint" else (count,)))
    bsdf = mi.load_dict(props)
    ctx = mi.BSDFContext()
    u = (np.arange(count, dtype=np.float64) + 0.5) / count
    if dr.is_jit_v(mi.Float):
        si = dr.zeros(mi.SurfaceInteraction3f, count)
        si.wi = mi.Vector3f(wi.T)
        si.uv = mi.Point2f(mi.Float(u), mi.Float(np.full(count, 0.5)))
        value, pdf = bsdf.eval_pdf(ctx, si, mi.Vector3f(wo.T))
        return np.array(value, dtype=np.float64).T.copy(), np.array(pdf, dtype=np.float64)
    values = np.zeros((count, 3))
    pdfs = np.zeros(count)
    si = dr.zeros(mi.SurfaceInteraction3f)
    for i in range(count):
        si.wi = mi.Vector3f(*map(float, wi[i]))
        si.uv = mi.Point2f(float(u[i]), 0.5)
        value, pdf = bsdf.eval_pdf(ctx, si, mi.Vector3f(*map(float, wo[i])))
        values[i] = [value[0], value[1], value[2]]
        pdfs[i] = pdf
    return values, pdfs
