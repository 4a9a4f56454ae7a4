"""The class of ``gltf_coat``, glTF's clear coat over any BSDF (:mod:`compare.mitsuba.coat`: read its
docstring). Bound to a variant: see :mod:`compare.mitsuba.plugins`.
"""

from __future__ import annotations

import drjit as dr

from compare.brdf import H_LEN2_MIN, REFERENCE_ALPHA_MIN
from compare.brdf.coat import COAT_F0
from compare.brdf.multiscatter import fresnel_dielectric_fss
from compare.mitsuba import ggx, principled
from compare.mitsuba.plugins import base, bound_variant, for_variant, normalmap
from compare.mitsuba.principled_tables import tables

__all__ = ["COAT_F0_CYCLES", "FSS_COAT", "GltfCoatBSDF"]

mv = bound_variant(__name__)
LayeredBSDF = for_variant(base).LayeredBSDF
_normalmap = for_variant(normalmap)
Color3f, Vector3f = mv.Color3f, mv.Vector3f
#: The Cycles coat's F0 and average Fresnel at Coat IOR 1.5 (Cycles' fresnel_dielectric_Fss).
COAT_F0_CYCLES = float(principled.f0_from_ior(principled.COAT_IOR))
FSS_COAT = float(fresnel_dielectric_fss(principled.COAT_IOR))


def _schlick(c):
    """glTF's coat Fresnel, Schlick with F0 = 0.04, at cosine ``c`` clamped to [0, 1]."""
    x = dr.clip(1.0 - c, 0.0, 1.0)
    x2 = x * x
    return COAT_F0 + (1.0 - COAT_F0) * x2 * x2 * x


def _coat_lobe(wi, wo, weight, rough, flavour):
    """(what the base keeps, the coat's lobe w F_c D V cos_o, the coat's VNDF pdf of wo) at wi, wo in the
    coat's frame."""
    alpha, r = rough
    cos_i, cos_o = wi.z, wo.z
    h, len2 = ggx.half_vector(dr, wi, wo)
    ok = (cos_i > 0.0) & (cos_o > 0.0) & (len2 > H_LEN2_MIN)
    vh = dr.clip(dr.dot(wi, h), 0.0, 1.0)
    d = ggx.ggx_d(dr, h, alpha)
    vis = ggx.smith_vis(dr, cos_i, cos_o, alpha)
    ci = dr.maximum(cos_i, 0.0)
    pdf = ggx.vndf_pdf(dr, d, cos_i, alpha)
    if flavour == "cycles":
        t = tables(mv)
        k, lf = t.compensation(FSS_COAT, r, ci)
        share = weight * t.fresnel_dielectric(vh, principled.COAT_IOR) * k
        e = COAT_F0_CYCLES + (1.0 - COAT_F0_CYCLES) * t.layer_s(r, ci, principled.COAT_IOR)
        keep = dr.select(cos_i > 0.0, dr.clip(1.0 - weight * e * lf, 0.0, 1.0), 1.0)
    else:
        share = weight * _schlick(vh)
        keep = 1.0 - dr.select(ok, share, 0.0)
    return keep, dr.select(ok, share * d * vis * dr.maximum(cos_o, 0.0), 0.0), dr.select(ok, pdf, 0.0)


class GltfCoatBSDF(LayeredBSDF):
    """A clear coat over the nested BSDF ``base`` (see :mod:`compare.mitsuba.coat`)."""

    def __init__(self, props):
        super().__init__(props)
        self.weight = props.get_texture("clearcoat", 1.0)
        self.roughness = props.get_texture("roughness", 0.0)
        self.normalmap = props.get_texture("normalmap") if "normalmap" in props else None
        if self.normalmap is not None:  # read in glTF's tangent frame, as the base's (gltf_normalmap)
            missing = [k for k in ("tangent", "tangent_sign") if k not in props]
            if missing:
                raise ValueError(f"{props.plugin_name()}: a normalmap needs the mesh attributes' names "
                                 f"{', '.join(missing)}")
            self.tangent, self.sign = str(props["tangent"]), str(props["tangent_sign"])
        self.flavour = principled.check_flavour(props.plugin_name(), props.get("flavour", "gltf"))
        if self.flavour == "cycles":
            tables(mv)  # built at load time, never while a kernel is traced

    def _point(self, si, active):
        """(w, (alpha, roughness), the coat's frame in the shading frame or None, the view in that frame)."""
        w = dr.clip(self.weight.eval_1(si, active), 0.0, 1.0)
        r = dr.clip(self.roughness.eval_1(si, active), 0.0, 1.0)
        frame = None
        if self.normalmap is not None:  # the coat's own normal map, in glTF's tangent frame
            c = _normalmap.decode(self.normalmap.eval_3(si, active))
            frame = mv.Frame3f(_normalmap.gltf_normal(si, c, self.tangent, self.sign, active)[0])
        wi = si.wi if frame is None else frame.to_local(si.wi)
        return w, (dr.maximum(r * r, REFERENCE_ALPHA_MIN), r), frame, wi

    def _lobe(self, point, si, wo):
        """:func:`_coat_lobe` in the coat's frame; nothing below the surface (wi or wo under the shading normal)."""
        weight, rough, frame, wi = point
        if frame is None:
            keep, spec, pdf = _coat_lobe(wi, wo, weight, rough, self.flavour)
        else:
            keep, spec, pdf = _coat_lobe(wi, frame.to_local(wo), weight, rough, self.flavour)
            ok = (si.wi.z > 0.0) & (wo.z > 0.0)
            keep, spec, pdf = dr.select(ok, keep, 1.0), dr.select(ok, spec, 0.0), dr.select(ok, pdf, 0.0)
        return keep, Color3f(spec), pdf

    @staticmethod
    def _p(cos_i, weight):
        return dr.clip(weight * _schlick(cos_i), 0.1 * weight, 0.9)

    def _probability(self, point, si):
        weight, _, frame, _ = point
        return self._p(si.wi.z if frame is None else dr.dot(si.wi, frame.n), weight)

    def _choice(self, point, si):
        weight, _, _, wi = point
        return self._p(wi.z, weight), (wi.z > 0.0) & (si.wi.z > 0.0)

    def _sample_lobe(self, point, si, sample2):
        _, (alpha, _), frame, wi = point
        wo = ggx.sample_visible_reflection(dr, Vector3f, wi, alpha, sample2)
        return wo if frame is None else frame.to_world(wo)

    def _fields(self):
        return [("flavour", self.flavour), ("clearcoat", self.weight), ("roughness", self.roughness)]
