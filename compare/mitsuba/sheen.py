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
"""

from __future__ import annotations


from compare.brdf.sheen import SHEEN_ALPHA_MIN, TABLE_SIZE, albedo_table
from compare.mitsuba import principled

__all__ = ["PLUGIN_NAME", "register"]

PLUGIN_NAME = "gltf_sheen"
_CLASSES: dict[str, type] = {}


def register(variant: str | None = None):
    """Register ``gltf_sheen`` with the active (or given) variant; returns the ``mitsuba`` module."""
    from compare.mitsuba.backend import register_bsdf_plugin  # noqa: PLC0415 - Mitsuba is loaded lazily

    return register_bsdf_plugin(PLUGIN_NAME, _make_class, _CLASSES, variant)


def _make_class(mv, mitsuba):
    import drjit as dr  # noqa: PLC0415

    UInt32, Color3f = mv.UInt32, mv.Color3f
    Flags = mitsuba.BSDFFlags
    table = {}

    def albedo(mu, r):
        if "e" not in table:
            table["e"] = mv.Texture2f(mv.TensorXf(albedo_table()[..., None]), use_accel=False,
                                      filter_mode=dr.FilterMode.Linear, wrap_mode=dr.WrapMode.Clamp)
        n = TABLE_SIZE
        # row = μ, column = r; a texture's x is the column
        pos = mv.Point2f((dr.clip(r, 0.0, 1.0) * (n - 1) + 0.5) * (1.0 / n),
                         (dr.clip(mu, 0.0, 1.0) * (n - 1) + 0.5) * (1.0 / n))
        return table["e"].eval(pos)[0]

    def ltc(mu, r):
        """(A, B, albedo) of Cycles' sheen table (x = cos_i, y = roughness), bilinear on its grid."""
        if "ltc" not in table:
            data = principled.SHEEN_LTC.transpose(1, 2, 0).astype("float32")
            table["ltc"] = mv.Texture2f(mv.TensorXf(data), use_accel=False, filter_mode=dr.FilterMode.Linear,
                                        wrap_mode=dr.WrapMode.Clamp)
        n = principled.SHEEN_LTC.shape[1]
        rr = dr.clip(r, principled.SHEEN_ROUGHNESS_MIN, 1.0)
        pos = mv.Point2f((dr.clip(mu, 0.0, 1.0) * (n - 1) + 0.5) * (1.0 / n), (rr * (n - 1) + 0.5) * (1.0 / n))
        return table["ltc"].eval(pos)

    class GltfSheenBSDF(mv.BSDF):
        """A sheen over the nested BSDF ``base`` (see :mod:`compare.mitsuba.sheen`)."""

        def __init__(self, props):
            mv.BSDF.__init__(self, props)
            self.base = props["base"]
            self.color = props.get_texture("color", 0.0)
            self.roughness = props.get_texture("roughness", 0.0)
            self.flavour = principled.check_flavour(PLUGIN_NAME, props.get("flavour", "gltf"))
            albedo(mv.Float(0.5), mv.Float(0.5))  # the textures, made at load time
            ltc(mv.Float(0.5), mv.Float(0.5))
            n = self.base.component_count()
            sheen = Flags.GlossyReflection | Flags.FrontSide
            self.m_components = [self.base.flags(i) for i in range(n)] + [sheen]
            self.m_flags = self.base.flags() | sheen

        def _params(self, si, active):
            """(colour, its peak, roughness, α) at the surface point."""
            c = self.color.eval(si, active)
            r = dr.clip(self.roughness.eval_1(si, active), 0.0, 1.0)
            return c, dr.maximum(dr.maximum(c.x, c.y), c.z), r, dr.maximum(r * r, SHEEN_ALPHA_MIN)

        def _sheen(self, wi, wo, peak, r, alpha):
            """(albedo scaling of the base, sheen value times cos_o) for wi, wo."""
            if self.flavour == "cycles":
                return self._sheen_cycles(wi, wo, peak, r)
            cos_i, cos_o = wi.z, wo.z
            ok = (cos_i > 0.0) & (cos_o > 0.0)
            h = dr.normalize(wi + wo)
            nh = dr.clip(h.z, 0.0, 1.0)
            inv = 1.0 / alpha
            sin2 = dr.maximum(1.0 - nh * nh, 0.0)
            d = (2.0 + inv) * dr.power(sin2, 0.5 * inv) * (0.5 / dr.pi)
            v = 1.0 / (4.0 * dr.maximum(cos_o + cos_i - cos_o * cos_i, 1e-6))
            lobe = d * v * dr.maximum(cos_o, 0.0)
            scale = dr.minimum(1.0 - peak * albedo(cos_i, r), 1.0 - peak * albedo(cos_o, r))
            return dr.select(ok, scale, 1.0), dr.select(ok, lobe, 0.0)

        def _sheen_cycles(self, wi, wo, peak, r):
            """As _sheen, Cycles' LTC sheen: the frame's x axis is wi's tangential direction."""
            a, b, alb = ltc(wi.z, r)
            on = (dr.abs(a) >= 1e-5) & (alb >= 1e-5) & (wi.z > 0.0)
            t_len = dr.sqrt(dr.fma(wi.x, wi.x, wi.y * wi.y))
            has_t = t_len > 1e-7
            tx = dr.select(has_t, wi.x / dr.maximum(t_len, 1e-30), 1.0)
            ty = dr.select(has_t, wi.y / dr.maximum(t_len, 1e-30), 0.0)
            lx = wo.x * tx + wo.y * ty
            ly = wo.y * tx - wo.x * ty
            lz = wo.z
            len2 = dr.square(a * lx + b * lz) + dr.square(a * ly) + lz * lz
            d = lz * dr.square(a / dr.maximum(len2, 1e-30)) * (1.0 / dr.pi)
            scale = dr.clip(1.0 - peak * alb, 0.0, 1.0)
            return dr.select(on, scale, 1.0), dr.select(on & (lz > 0.0), alb * d, 0.0)

        @staticmethod
        def _p(cos_i, peak, r):
            return dr.clip(peak * albedo(cos_i, r), 0.05, 0.5)

        def eval_pdf(self, ctx, si, wo, active=True):
            base_value, base_pdf = self.base.eval_pdf(ctx, si, wo, active)
            c, peak, r, alpha = self._params(si, active)
            scale, lobe = self._sheen(si.wi, wo, peak, r, alpha)
            value = base_value * scale + c * lobe
            p = self._p(si.wi.z, peak, r)
            pdf = p * mv.warp.square_to_cosine_hemisphere_pdf(wo) + (1.0 - p) * base_pdf
            return dr.select(active, value, Color3f(0.0)), dr.select(active, pdf, 0.0)

        def eval(self, ctx, si, wo, active=True):
            return self.eval_pdf(ctx, si, wo, active)[0]

        def pdf(self, ctx, si, wo, active=True):
            return self.eval_pdf(ctx, si, wo, active)[1]

        def sample(self, ctx, si, sample1, sample2, active=True):
            wi = si.wi
            c, peak, r, alpha = self._params(si, active)
            p = self._p(wi.z, peak, r)
            pick = (sample1 < p) & (wi.z > 0.0)
            bs, base_weight = self.base.sample(ctx, si, dr.clip((sample1 - p) / dr.maximum(1.0 - p, 1e-6), 0.0,
                                                                0.999999), sample2, active & ~pick)
            wo = dr.select(pick, mv.warp.square_to_cosine_hemisphere(sample2), bs.wo)
            delta = (~pick) & ((bs.sampled_type & UInt32(+Flags.Delta)) != 0)
            scale, _ = self._sheen(wi, bs.wo, peak, r, alpha)
            value, pdf = self.eval_pdf(ctx, si, wo, active)
            ok = active & (pdf > 0.0) & ~delta
            out = dr.zeros(mv.BSDFSample3f)
            out.wo = wo
            out.pdf = dr.select(delta, bs.pdf * (1.0 - p), dr.select(ok, pdf, 0.0))
            out.eta = dr.select(pick, 1.0, bs.eta)
            out.sampled_component = dr.select(pick, UInt32(self.base.component_count()), bs.sampled_component)
            out.sampled_type = dr.select(pick, UInt32(+Flags.GlossyReflection), bs.sampled_type)
            weight = dr.select(ok, value / dr.select(ok, pdf, 1.0), Color3f(0.0))
            weight = dr.select(delta & active, base_weight * scale / dr.maximum(1.0 - p, 1e-6), weight)
            return out, weight

        def traverse(self, callback):
            pass

        def parameters_changed(self, keys=()):
            pass

        def to_string(self):
            return (f"GltfSheenBSDF[flavour = {self.flavour}, color = {self.color}, "
                    f"roughness = {self.roughness}]")

    return GltfSheenBSDF
