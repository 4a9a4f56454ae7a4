"""The class of ``gltf_normalmap``, glTF's normal map around any BSDF, and :func:`gltf_normal`, glTF's tangent
frame (:mod:`compare.mitsuba.normalmap`: read its docstring). Bound to a variant: see :mod:`compare.mitsuba.plugins`.
"""

from __future__ import annotations

import drjit as dr

from compare.mitsuba.plugins import base, bound_variant, for_variant

__all__ = ["GltfNormalMapBSDF", "decode", "gltf_normal", "shadow_terminator"]

mv = bound_variant(__name__)
PluginBSDF = for_variant(base).PluginBSDF
Vector3f, Frame3f = mv.Vector3f, mv.Frame3f
#: Below this squared length the projected tangent is taken as missing (a degenerate UV chart).
TANGENT_LEN2_MIN = 1e-12


def decode(texel):
    """A normal map's texel (rgb in [0, 1]) as the vector 2 rgb − 1 it encodes."""
    return Vector3f(2.0 * texel[0] - 1.0, 2.0 * texel[1] - 1.0, 2.0 * texel[2] - 1.0)


def gltf_normal(si, c, tangent: str, sign: str, active=True):
    """glTF's tangent-space normal ``c`` (x along the tangent, y along the bitangent, z along the normal) at
    ``si``, in ``si``'s shading frame (normalised), and the glTF tangent there, both local.

    The frame is glTF's: ``t = normalize(T − n (n·T))``, ``b = cross(n, t) · sign(w)`` with ``n`` the
    shading normal and ``T``, ``w`` the mesh attributes named ``tangent`` and ``sign`` interpolated at
    ``si``; where ``T`` has no part off ``n`` (or the shape lacks it: JIT variants read 0), the shading
    frame's own tangent."""
    n = si.sh_frame.n
    a = si.shape.eval_attribute_3(tangent, si, active)
    w = si.shape.eval_attribute_1(sign, si, active)
    t = Vector3f(a[0], a[1], a[2])
    t = t - n * dr.dot(n, t)
    t = dr.select(dr.squared_norm(t) > TANGENT_LEN2_MIN, dr.normalize(t), si.sh_frame.s)
    b = dr.cross(n, t) * dr.select(w < 0.0, -1.0, 1.0)  # the rasterizer's test: w = 0 counts as +1
    return dr.normalize(si.to_local(t * c.x + b * c.y + n * c.z)), si.to_local(t)


def shadow_terminator(n, wo):
    """Estevez et al.'s shadowing term for a perturbed normal ``n`` and a direction ``wo``, both in the
    unperturbed shading frame (Mitsuba's ``eval_shadow_terminator``)."""
    def tan2(v):
        return dr.maximum(1.0 - v.z * v.z, 0.0) / (v.z * v.z)

    alpha2 = dr.minimum(0.125 * tan2(n), 1.0)
    return 2.0 / (1.0 + dr.sqrt(1.0 + alpha2 * tan2(wo)))


class GltfNormalMapBSDF(PluginBSDF):
    """The nested BSDF ``bsdf`` in the frame of a normal map read in glTF's tangent frame
    (see :mod:`compare.mitsuba.normalmap`)."""

    def __init__(self, props):
        super().__init__(props)
        self.nested = props["bsdf"]
        self.normalmap = props.get_texture("normalmap")
        missing = [k for k in ("tangent", "tangent_sign") if k not in props]
        if missing:
            raise ValueError(f"{props.plugin_name()}: needs the mesh attributes' names {', '.join(missing)}")
        self.tangent, self.sign = str(props["tangent"]), str(props["tangent_sign"])
        self.flip_invalid = bool(props.get("flip_invalid_normals", True))
        self.shadowing = bool(props.get("use_shadowing_function", True))
        self.m_components = [self.nested.flags(i) for i in range(self.nested.component_count())]
        self.m_flags = self.nested.flags()

    def _frames(self, si, active):
        """(the perturbed frame in ``si``'s shading frame, a copy of ``si`` with that frame in world space
        and ``wi`` in it), as Mitsuba's ``normalmap`` builds them."""
        n, t = gltf_normal(si, decode(self.normalmap.eval_3(si, active)), self.tangent, self.sign, active)
        if self.flip_invalid:  # the view below the perturbed normal: mirror it about the unperturbed one
            n = dr.select(si.wi.z * dr.dot(si.wi, n) <= 0.0, Vector3f(-n.x, -n.y, n.z), n)
        s = t - n * dr.dot(n, t)
        s = dr.select(dr.squared_norm(s) > TANGENT_LEN2_MIN, dr.normalize(s), Frame3f(n).s)
        local = Frame3f(s, dr.cross(n, s), n)
        perturbed = mv.SurfaceInteraction3f(si)
        perturbed.sh_frame = Frame3f(si.to_world(local.s), si.to_world(local.t), si.to_world(local.n))
        perturbed.wi = local.to_local(si.wi)
        return local, perturbed

    def _shadowing(self, local, wo):
        return shadow_terminator(local.n, wo) if self.shadowing else 1.0

    def eval(self, ctx, si, wo, active=True):
        local, perturbed = self._frames(si, active)
        wo_p = local.to_local(wo)
        active = active & (wo.z * wo_p.z > 0.0)  # both sides agree: the unperturbed and the perturbed normal
        value = self.nested.eval(ctx, perturbed, wo_p, active) * self._shadowing(local, wo)
        return dr.select(active, value, 0.0)

    def pdf(self, ctx, si, wo, active=True):
        local, perturbed = self._frames(si, active)
        wo_p = local.to_local(wo)
        active = active & (wo.z * wo_p.z > 0.0)
        return dr.select(active, self.nested.pdf(ctx, perturbed, wo_p, active), 0.0)

    def eval_pdf(self, ctx, si, wo, active=True):
        local, perturbed = self._frames(si, active)
        wo_p = local.to_local(wo)
        active = active & (wo.z * wo_p.z > 0.0)
        value, pdf = self.nested.eval_pdf(ctx, perturbed, wo_p, active)
        return (dr.select(active, value * self._shadowing(local, wo), 0.0), dr.select(active, pdf, 0.0))

    def sample(self, ctx, si, sample1, sample2, active=True):
        local, perturbed = self._frames(si, active)
        bs, weight = self.nested.sample(ctx, perturbed, sample1, sample2, active)
        active = active & dr.any(weight != 0.0)
        wo = local.to_world(bs.wo)
        active = active & (bs.wo.z * wo.z > 0.0)
        bs.pdf = dr.select(active, bs.pdf, 0.0)
        bs.wo = wo
        return bs, dr.select(active, weight * self._shadowing(local, wo), 0.0)

    def eval_diffuse_reflectance(self, si, active=True):
        return self.nested.eval_diffuse_reflectance(si, active)

    def _fields(self):
        return [("tangent", self.tangent), ("tangent_sign", self.sign), ("nested", self.nested)]
