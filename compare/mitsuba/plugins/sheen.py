"""The class of ``gltf_sheen``, glTF's sheen over any BSDF (:mod:`compare.mitsuba.sheen`: read its
docstring). Bound to a variant: see :mod:`compare.mitsuba.plugins`.
"""

from __future__ import annotations

import drjit as dr

from compare.brdf.sheen import SHEEN_ALPHA_MIN, TABLE_SIZE, albedo_table
from compare.mitsuba import principled
from compare.mitsuba.plugins import base, bound_variant, for_variant

__all__ = ["GltfSheenBSDF"]

mv = bound_variant(__name__)
LayeredBSDF = for_variant(base).LayeredBSDF
_TEXTURE = dict(use_accel=False, filter_mode=dr.FilterMode.Linear, wrap_mode=dr.WrapMode.Clamp)
#: glTF's sheen albedo E(μ, r) (compare.brdf.sheen), bilinear.
_ALBEDO = mv.Texture2f(mv.TensorXf(albedo_table()[..., None]), **_TEXTURE)
#: Cycles' sheen table (A, B, albedo), x = cos_i, y = roughness, bilinear on its grid.
_LTC = mv.Texture2f(mv.TensorXf(principled.SHEEN_LTC.transpose(1, 2, 0).astype("float32")), **_TEXTURE)


def _albedo(mu, r):
    n = TABLE_SIZE
    # row = μ, column = r; a texture's x is the column
    pos = mv.Point2f((dr.clip(r, 0.0, 1.0) * (n - 1) + 0.5) * (1.0 / n),
                     (dr.clip(mu, 0.0, 1.0) * (n - 1) + 0.5) * (1.0 / n))
    return _ALBEDO.eval(pos)[0]


def _ltc(mu, r):
    """(A, B, albedo) of Cycles' sheen table at the view's cosine ``mu`` and roughness ``r``."""
    n = principled.SHEEN_LTC.shape[1]
    rr = dr.clip(r, principled.SHEEN_ROUGHNESS_MIN, 1.0)
    pos = mv.Point2f((dr.clip(mu, 0.0, 1.0) * (n - 1) + 0.5) * (1.0 / n), (rr * (n - 1) + 0.5) * (1.0 / n))
    return _LTC.eval(pos)


def _charlie(wi, wo, peak, r, alpha):
    """(albedo scaling of the base, sheen value times cos_o) of glTF's Charlie sheen for wi, wo."""
    cos_i, cos_o = wi.z, wo.z
    ok = (cos_i > 0.0) & (cos_o > 0.0)
    h = dr.normalize(wi + wo)
    nh = dr.clip(h.z, 0.0, 1.0)
    inv = 1.0 / alpha
    sin2 = dr.maximum(1.0 - nh * nh, 0.0)
    d = (2.0 + inv) * dr.power(sin2, 0.5 * inv) * (0.5 / dr.pi)
    v = 1.0 / (4.0 * dr.maximum(cos_o + cos_i - cos_o * cos_i, 1e-6))
    lobe = d * v * dr.maximum(cos_o, 0.0)
    scale = dr.minimum(1.0 - peak * _albedo(cos_i, r), 1.0 - peak * _albedo(cos_o, r))
    return dr.select(ok, scale, 1.0), dr.select(ok, lobe, 0.0)


def _ltc_sheen(wi, wo, peak, r):
    """As :func:`_charlie`, Cycles' LTC sheen: the frame's x axis is wi's tangential direction."""
    a, b, alb = _ltc(wi.z, r)
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


class GltfSheenBSDF(LayeredBSDF):
    """A sheen over the nested BSDF ``base`` (see :mod:`compare.mitsuba.sheen`)."""

    def __init__(self, props):
        super().__init__(props)
        self.color = props.get_texture("color", 0.0)
        self.roughness = props.get_texture("roughness", 0.0)
        self.flavour = principled.check_flavour(props.plugin_name(), props.get("flavour", "gltf"))

    def _point(self, si, active):
        """(colour, its peak, roughness, α) at the surface point."""
        c = self.color.eval(si, active)
        r = dr.clip(self.roughness.eval_1(si, active), 0.0, 1.0)
        return c, dr.maximum(dr.maximum(c.x, c.y), c.z), r, dr.maximum(r * r, SHEEN_ALPHA_MIN)

    def _lobe(self, point, si, wo):
        c, peak, r, alpha = point
        if self.flavour == "cycles":
            scale, lobe = _ltc_sheen(si.wi, wo, peak, r)
        else:
            scale, lobe = _charlie(si.wi, wo, peak, r, alpha)
        return scale, c * lobe, mv.warp.square_to_cosine_hemisphere_pdf(wo)

    def _probability(self, point, si):
        _, peak, r, _ = point
        return dr.clip(peak * _albedo(si.wi.z, r), 0.05, 0.5)  # the lobe is broad: never most of the samples

    def _choice(self, point, si):
        return self._probability(point, si), si.wi.z > 0.0

    def _sample_lobe(self, point, si, sample2):
        return mv.warp.square_to_cosine_hemisphere(sample2)

    def _fields(self):
        return [("flavour", self.flavour), ("color", self.color), ("roughness", self.roughness)]
