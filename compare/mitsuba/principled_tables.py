"""The Dr.Jit side of :mod:`compare.mitsuba.principled`, shared by the plugins that model Blender's
Principled BSDF: Cycles' lookup tables as textures, and the exact dielectric Fresnel.

:func:`tables` builds, once per Mitsuba variant and at load time (never while a kernel is being
traced), the textures of :mod:`compare.mitsuba.principled` (``ggx_gen_schlick_ior_s``, 3D) and of
:mod:`compare.brdf.multiscatter` (``ggx_E``, 2D, and ``ggx_Eavg``, 1D), each read on Cycles' grid
(texel i at coordinate i/(n-1), linear interpolation, clamped), and returns the lookups.
"""

from __future__ import annotations

from compare.brdf import multiscatter
from compare.mitsuba import principled

__all__ = ["tables"]

_TABLES: dict[str, object] = {}


def tables(mv):
    """The lookups for variant module ``mv`` (e.g. ``mitsuba.llvm_ad_rgb``): an object with
    ``layer_s(r, cos_i, eta)`` (S of the specular layer's albedo estimate), ``energy(r, cos_i)``
    (E and E_avg of GGX), ``compensation(fss, r, cos_i)`` (Multiscatter GGX's lobe scale ``K``
    and layer factor ``L`` for an average Fresnel ``fss``: a Float or a Color3f) and
    ``fresnel_dielectric(c, eta)`` (:func:`compare.mitsuba.principled.fresnel_dielectric` for
    c in [0, 1] and eta > 1)."""
    key = repr((mv.Float, mv.Color3f))  # one per variant (every variant module is named 'mitsuba')
    if key not in _TABLES:
        _TABLES[key] = _Tables(mv)
    return _TABLES[key]


class _Tables:
    def __init__(self, mv):
        import drjit as dr  # noqa: PLC0415 - Mitsuba is loaded lazily

        self.mv, self.dr = mv, dr
        # use_accel=False: CUDA's texture units interpolate with 8-bit weights; the software path is
        # float32 on every backend.
        kw = dict(use_accel=False, filter_mode=dr.FilterMode.Linear, wrap_mode=dr.WrapMode.Clamp)
        self.s = mv.Texture3f(mv.TensorXf(principled.LAYER_S_TABLE_3D.astype("float32")[..., None]), **kw)
        self.e = mv.Texture2f(mv.TensorXf(multiscatter.GGX_E_TABLE.astype("float32")[..., None]), **kw)
        self.e_avg = mv.Texture1f(mv.TensorXf(multiscatter.GGX_EAVG_TABLE.astype("float32")[..., None]), **kw)

    def _coord(self, x, n):
        return (self.dr.clip(x, 0.0, 1.0) * (n - 1) + 0.5) * (1.0 / n)

    def layer_s(self, r, cos_i, eta):
        """S(r, cos_i, eta): ``lookup_table_read_3D`` at z = sqrt(|(eta - 1)/(eta + 1)|)."""
        dr, n = self.dr, principled.LAYER_TABLE_SIZE
        z = dr.sqrt(dr.abs((eta - 1.0) / (eta + 1.0)))
        return self.s.eval(self.mv.Point3f(self._coord(r, n), self._coord(cos_i, n), self._coord(z, n)))[0]

    def energy(self, r, cos_i):
        """(E(r, cos_i), E_avg(r)) of single-scattering GGX."""
        n = multiscatter.ENERGY_TABLE_SIZE
        u = self._coord(r, n)
        return (self.e.eval(self.mv.Point2f(u, self._coord(cos_i, n)))[0],
                self.e_avg.eval(self.mv.Point1f(u))[0])

    def compensation(self, fss, r, cos_i):
        """(K, L) = (1 + F_ms (1 - E)/E, E + F_ms (1 - E)) with F_ms = F_ss E_avg / (1 - F_ss (1 - E_avg))."""
        e, e_avg = self.energy(r, cos_i)
        f_ms = fss * e_avg / (1.0 - fss * (1.0 - e_avg))
        return 1.0 + f_ms * ((1.0 - e) / e), e + f_ms * (1.0 - e)

    def fresnel_dielectric(self, c, eta):
        """Unpolarised Fresnel reflectance at ``eta`` > 1 for c = cos in [0, 1] (no total internal reflection)."""
        dr = self.dr
        g = dr.sqrt(eta * eta - 1.0 + c * c)
        a = (g - c) / (g + c)
        b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0)
        return 0.5 * a * a * (1.0 + b * b)
