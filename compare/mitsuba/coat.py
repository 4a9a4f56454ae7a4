"""glTF's clear coat over any BSDF, as a Mitsuba 3 plugin (``gltf_coat``): the layering of
:mod:`compare.brdf.coat` (read it), evaluated with Dr.Jit.

Properties: ``base`` (the nested BSDF, the material under the coat), ``clearcoat`` (w) and ``roughness``
(the coat's perceptual roughness), each a float or a texture (glTF's factor times its map), and optionally
``normalmap``: glTF's clearcoatNormalTexture in the shading frame's tangent space, encoded (n + 1) / 2 as
Mitsuba's ``normalmap`` reads one. The coat's lobe (its D, V and cosine) is then evaluated and sampled in
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
"""

from __future__ import annotations


from compare.brdf import REFERENCE_ALPHA_MIN, H_LEN2_MIN
from compare.brdf.coat import COAT_F0
from compare.brdf.multiscatter import fresnel_dielectric_fss
from compare.mitsuba import ggx, principled
from compare.mitsuba.principled_tables import tables

__all__ = ["PLUGIN_NAME", "register"]

PLUGIN_NAME = "gltf_coat"
_CLASSES: dict[str, type] = {}
#: The Cycles coat's F0 and average Fresnel at Coat IOR 1.5 (Cycles' fresnel_dielectric_Fss).
COAT_F0_CYCLES = float(principled.f0_from_ior(principled.COAT_IOR))
FSS_COAT = float(fresnel_dielectric_fss(principled.COAT_IOR))


def register(variant: str | None = None):
    """Register ``gltf_coat`` with the active (or given) variant; returns the ``mitsuba`` module."""
    from compare.mitsuba.backend import register_bsdf_plugin  # noqa: PLC0415 - Mitsuba is loaded lazily

    return register_bsdf_plugin(PLUGIN_NAME, _make_class, _CLASSES, variant)


def _make_class(mv, mitsuba):
    import drjit as dr  # noqa: PLC0415

    UInt32, Color3f, Vector3f = mv.UInt32, mv.Color3f, mv.Vector3f
    Flags = mitsuba.BSDFFlags

    class GltfCoatBSDF(mv.BSDF):
        """A clear coat over the nested BSDF ``base`` (see :mod:`compare.mitsuba.coat`)."""

        def __init__(self, props):
            mv.BSDF.__init__(self, props)
            self.base = props["base"]
            self.weight = props.get_texture("clearcoat", 1.0)
            self.roughness = props.get_texture("roughness", 0.0)
            self.normalmap = props.get_texture("normalmap") if "normalmap" in props else None
            self.flavour = principled.check_flavour(PLUGIN_NAME, props.get("flavour", "gltf"))
            if self.flavour == "cycles":
                tables(mv)  # built at load time, never while a kernel is traced
            n = self.base.component_count()
            coat = Flags.GlossyReflection | Flags.FrontSide
            self.m_components = [self.base.flags(i) for i in range(n)] + [coat]
            self.m_flags = self.base.flags() | coat

        def _params(self, si, active):
            w = dr.clip(self.weight.eval_1(si, active), 0.0, 1.0)
            r = dr.clip(self.roughness.eval_1(si, active), 0.0, 1.0)
            return w, (dr.maximum(r * r, REFERENCE_ALPHA_MIN), r)

        def _coat(self, wi, wo, weight, rough):
            """(what the base keeps, the coat's lobe w F_c D V cos_o) at wi, wo, and the coat's VNDF pdf of wo."""
            alpha, r = rough
            cos_i, cos_o = wi.z, wo.z
            h, len2 = ggx.half_vector(dr, wi, wo)
            ok = (cos_i > 0.0) & (cos_o > 0.0) & (len2 > H_LEN2_MIN)
            vh = dr.clip(dr.dot(wi, h), 0.0, 1.0)
            d = ggx.ggx_d(dr, h, alpha)
            vis = ggx.smith_vis(dr, cos_i, cos_o, alpha)
            ci = dr.maximum(cos_i, 0.0)
            pdf = ggx.vndf_pdf(dr, d, cos_i, alpha)
            if self.flavour == "cycles":
                t = tables(mv)
                k, lf = t.compensation(FSS_COAT, r, ci)
                share = weight * t.fresnel_dielectric(vh, principled.COAT_IOR) * k
                e = COAT_F0_CYCLES + (1.0 - COAT_F0_CYCLES) * t.layer_s(r, ci, principled.COAT_IOR)
                keep = dr.select(cos_i > 0.0, dr.clip(1.0 - weight * e * lf, 0.0, 1.0), 1.0)
            else:
                x = dr.clip(1.0 - vh, 0.0, 1.0)
                x2 = x * x
                share = weight * (COAT_F0 + (1.0 - COAT_F0) * x2 * x2 * x)
                keep = 1.0 - dr.select(ok, share, 0.0)
            return (keep, dr.select(ok, share * d * vis * dr.maximum(cos_o, 0.0), 0.0), dr.select(ok, pdf, 0.0))

        def _frame(self, si, active):
            """The coat's frame in the shading frame: its own normal map's normal, or None (the surface's)."""
            if self.normalmap is None:
                return None
            c = self.normalmap.eval(si, active)
            n = dr.normalize(Vector3f(2.0 * c.x - 1.0, 2.0 * c.y - 1.0, 2.0 * c.z - 1.0))
            return mv.Frame3f(n)

        def _coat_at(self, frame, wi, wo, weight, rough):
            """_coat in the coat's frame; nothing below the surface (wi or wo under the shading normal)."""
            if frame is None:
                return self._coat(wi, wo, weight, rough)
            keep, spec, pdf = self._coat(frame.to_local(wi), frame.to_local(wo), weight, rough)
            ok = (wi.z > 0.0) & (wo.z > 0.0)
            return dr.select(ok, keep, 1.0), dr.select(ok, spec, 0.0), dr.select(ok, pdf, 0.0)

        @staticmethod
        def _p_coat(cos_i, weight):
            x = dr.clip(1.0 - cos_i, 0.0, 1.0)
            x2 = x * x
            f = COAT_F0 + (1.0 - COAT_F0) * x2 * x2 * x
            return dr.clip(weight * f, 0.1 * weight, 0.9)

        def eval_pdf(self, ctx, si, wo, active=True):
            base_value, base_pdf = self.base.eval_pdf(ctx, si, wo, active)
            weight, rough = self._params(si, active)
            frame = self._frame(si, active)
            keep, spec, coat_pdf = self._coat_at(frame, si.wi, wo, weight, rough)
            p = self._p_coat(si.wi.z if frame is None else dr.dot(si.wi, frame.n), weight)
            value = base_value * keep + Color3f(spec)
            pdf = p * coat_pdf + (1.0 - p) * base_pdf
            return dr.select(active, value, Color3f(0.0)), dr.select(active, pdf, 0.0)

        def eval(self, ctx, si, wo, active=True):
            return self.eval_pdf(ctx, si, wo, active)[0]

        def pdf(self, ctx, si, wo, active=True):
            return self.eval_pdf(ctx, si, wo, active)[1]

        def sample(self, ctx, si, sample1, sample2, active=True):
            weight, rough = self._params(si, active)
            alpha = rough[0]
            frame = self._frame(si, active)
            wi = si.wi if frame is None else frame.to_local(si.wi)  # the coat's lobe is sampled in its frame
            p = self._p_coat(wi.z, weight)
            pick = (sample1 < p) & (wi.z > 0.0) & (si.wi.z > 0.0)
            bs, base_weight = self.base.sample(ctx, si, dr.clip((sample1 - p) / dr.maximum(1.0 - p, 1e-6), 0.0,
                                                                0.999999), sample2, active & ~pick)
            wo_coat = ggx.sample_visible_reflection(dr, Vector3f, wi, alpha, sample2)
            wo = dr.select(pick, wo_coat if frame is None else frame.to_world(wo_coat), bs.wo)
            # A delta lobe of the base (a smooth dielectric under the coat) has no pdf to mix: its sample
            # keeps the base's weight, less what the coat reflects, over the probability of the base.
            delta = (~pick) & ((bs.sampled_type & UInt32(+Flags.Delta)) != 0)
            keep, _, _ = self._coat_at(frame, si.wi, bs.wo, weight, rough)
            value, pdf = self.eval_pdf(ctx, si, wo, active)
            ok = active & (pdf > 0.0) & ~delta
            out = dr.zeros(mv.BSDFSample3f)
            out.wo = wo
            out.pdf = dr.select(delta, bs.pdf * (1.0 - p), dr.select(ok, pdf, 0.0))
            out.eta = dr.select(pick, 1.0, bs.eta)
            out.sampled_component = dr.select(pick, UInt32(self.base.component_count()), bs.sampled_component)
            out.sampled_type = dr.select(pick, UInt32(+Flags.GlossyReflection), bs.sampled_type)
            weight = dr.select(ok, value / dr.select(ok, pdf, 1.0), Color3f(0.0))
            weight = dr.select(delta & active, base_weight * keep / dr.maximum(1.0 - p, 1e-6), weight)
            return out, weight

        def traverse(self, callback):
            pass

        def parameters_changed(self, keys=()):
            pass

        def to_string(self):
            return (f"GltfCoatBSDF[flavour = {self.flavour}, clearcoat = {self.weight}, "
                    f"roughness = {self.roughness}]")

    return GltfCoatBSDF
