"""GGX in Dr.Jit, once for every Mitsuba plugin of the suite (the base, the coat, the rough glass): the half
vector, the distribution D, the height-correlated Smith visibility V, Smith's Lambda and the ratio of the
height-correlated to the separable masking, the pdf of a reflection sampled from the visible normals, and that
sampling itself. They are the Dr.Jit form of :mod:`compare.brdf`'s NumPy definitions (one BRDF, checked
against each other by the tests). Plain functions of Dr.Jit arrays, ``dr`` passed in: the plugin classes of
every variant (:mod:`compare.mitsuba.plugins`) call them.
"""

from __future__ import annotations

from compare.brdf import COS_MIN, DENOM_MIN, H_LEN2_MIN

__all__ = ["ggx_d", "ggx_d_aniso", "half_vector", "masking_ratio", "sample_visible_reflection",
           "sample_visible_reflection_aniso", "smith_lambda", "smith_vis", "smith_vis_aniso", "vndf_pdf",
           "vndf_pdf_aniso"]


def half_vector(dr, wi, wo):
    """(unit half vector, squared length of wi + wo): the length decides whether it is defined."""
    hu = wi + wo
    len2 = dr.dot(hu, hu)
    return hu * dr.rsqrt(dr.maximum(len2, H_LEN2_MIN)), len2


def ggx_d(dr, h, alpha):
    """GGX's normal distribution D(h) for roughness ``alpha`` (in the form that keeps a tiny alpha finite)."""
    nh = dr.clip(h.z, 0.0, 1.0)
    sin2 = dr.fma(h.x, h.x, h.y * h.y)
    a = nh * alpha
    k = alpha / dr.maximum(sin2 + a * a, DENOM_MIN)
    return k * k * (1.0 / dr.pi)


def smith_vis(dr, cos_i, cos_o, alpha):
    """The height-correlated Smith visibility V = G2 / (4 cos_i cos_o)."""
    a2 = alpha * alpha
    nv = dr.maximum(cos_i, COS_MIN)
    nl = dr.maximum(cos_o, COS_MIN)
    return 0.5 / (nl * dr.sqrt(nv * nv * (1.0 - a2) + a2) + nv * dr.sqrt(nl * nl * (1.0 - a2) + a2))


def smith_lambda(dr, cos_theta, alpha):
    """Smith's Lambda of GGX for a direction of cosine ``cos_theta`` (either side: only its square counts)."""
    a2 = alpha * alpha
    c2 = dr.maximum(cos_theta * cos_theta, 1e-12)
    return 0.5 * (dr.sqrt(1.0 + a2 * dr.maximum(1.0 / c2 - 1.0, 0.0)) - 1.0)


def masking_ratio(dr, cos_i, cos_o, alpha):
    """``(1 + Λi)(1 + Λo) / (1 + Λi + Λo)``: the height-correlated masking over the separable one,
    ``G2 / (G1(wi) G1(wo))`` (the NumPy form: :func:`compare.mitsuba.glass.masking_ratio`)."""
    li, lo = smith_lambda(dr, cos_i, alpha), smith_lambda(dr, cos_o, alpha)
    return (1.0 + li) * (1.0 + lo) / (1.0 + li + lo)


def vndf_pdf(dr, d, cos_i, alpha):
    """The pdf of a reflected direction sampled from GGX's visible normals, given D at its half vector."""
    a2 = alpha * alpha
    ci = dr.maximum(cos_i, 0.0)
    return d / (2.0 * (ci + dr.sqrt(ci * ci * (1.0 - a2) + a2)))


def sample_visible_reflection(dr, vector3f, wi, alpha, sample2):
    """``wi`` reflected about a normal sampled from GGX's visible normals (spherical caps, Dupuy & Benyoub
    2023); ``vector3f`` is the variant's Vector3f."""
    ws = dr.normalize(vector3f(wi.x * alpha, wi.y * alpha, wi.z))
    sin_phi, cos_phi = dr.sincos(2.0 * dr.pi * sample2.x)
    z = dr.fma(1.0 - sample2.y, 1.0 + ws.z, -ws.z)
    sin_t = dr.sqrt(dr.clip(1.0 - z * z, 0.0, 1.0))
    hs = vector3f(sin_t * cos_phi + ws.x, sin_t * sin_phi + ws.y, z + ws.z)
    hv = vector3f(hs.x * alpha, hs.y * alpha, hs.z)
    hv = hv * dr.rsqrt(dr.maximum(dr.dot(hv, hv), DENOM_MIN))
    return 2.0 * dr.dot(wi, hv) * hv - wi


# Anisotropic GGX (KHR_materials_anisotropy): the same terms with roughness ``ax`` along the local x axis (the
# anisotropy direction) and ``ay`` along y, directions given in that frame. Written apart from the isotropic
# forms above, which stay as they are (the isotropic lobe keeps its float operations, and so its pixels).

def ggx_d_aniso(dr, h, ax, ay):
    """Anisotropic GGX D(h)."""
    x, y, z = h.x / ax, h.y / ay, dr.clip(h.z, 0.0, 1.0)
    q = dr.fma(x, x, dr.fma(y, y, z * z))
    return dr.select(h.z > 0.0, 1.0 / (dr.pi * ax * ay * dr.maximum(q * q, DENOM_MIN)), 0.0)


def _stretched_length(dr, w, ax, ay):
    """``sqrt(ax² wx² + ay² wy² + wz²)``: Λ's and the visible-normal pdf's common term."""
    return dr.sqrt(dr.fma(ax * ax, w.x * w.x, dr.fma(ay * ay, w.y * w.y, w.z * w.z)))


def smith_vis_aniso(dr, wi, wo, ax, ay):
    """The anisotropic height-correlated Smith visibility V = G2 / (4 cos_i cos_o) (glTF's V_GGX_anisotropic)."""
    nv = dr.maximum(wi.z, COS_MIN)
    nl = dr.maximum(wo.z, COS_MIN)
    return 0.5 / (nl * _stretched_length(dr, wi, ax, ay) + nv * _stretched_length(dr, wo, ax, ay))


def vndf_pdf_aniso(dr, d, wi, ax, ay):
    """The pdf of a reflected direction sampled from anisotropic GGX's visible normals, given D there."""
    ci = dr.maximum(wi.z, 0.0)
    return d / (2.0 * (ci + _stretched_length(dr, wi, ax, ay)))


def sample_visible_reflection_aniso(dr, vector3f, wi, ax, ay, sample2):
    """``wi`` reflected about a normal sampled from anisotropic GGX's visible normals (the spherical caps of
    :func:`sample_visible_reflection` in the frame stretched by ``ax``, ``ay``)."""
    ws = dr.normalize(vector3f(wi.x * ax, wi.y * ay, wi.z))
    sin_phi, cos_phi = dr.sincos(2.0 * dr.pi * sample2.x)
    z = dr.fma(1.0 - sample2.y, 1.0 + ws.z, -ws.z)
    sin_t = dr.sqrt(dr.clip(1.0 - z * z, 0.0, 1.0))
    hs = vector3f(sin_t * cos_phi + ws.x, sin_t * sin_phi + ws.y, z + ws.z)
    hv = vector3f(hs.x * ax, hs.y * ay, hs.z)
    hv = hv * dr.rsqrt(dr.maximum(dr.dot(hv, hv), DENOM_MIN))
    return 2.0 * dr.dot(wi, hv) * hv - wi
