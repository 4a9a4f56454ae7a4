"""glTF's thin-film iridescence (``KHR_materials_iridescence``): the Fresnel term of a thin dielectric film over
the base, as the extension defines it (Belcour & Barla 2017, the extension's approximation: Schlick Fresnel at
both interfaces, phase shifts of 0 or π, the spectral integral in closed form over the CIE XYZ sensitivities
turned into linear Rec. 709), written once for NumPy and Dr.Jit arrays (``xp``: :data:`NUMPY` or
:func:`drjit_ops`): the reference's plugin and the tests evaluate this one function.

In the material (the extension's implementation section): the specular Fresnel is
``mix(F_schlick, F_iridescence, iridescence)``, per lobe of glTF's mix (the metal's F0 its base colour, the
dielectric's 0.04 or the specular extension's), the diffuse base weighted by one minus the dielectric's
mixed Fresnel at its largest channel (the Khronos sample renderer's ``BRDF_lambertianIridescence``). The
thin film's thickness is ``iridescenceThicknessMaximum``, or mix(minimum, maximum, G) of the thickness map.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

__all__ = ["NUMPY", "XYZ_TO_REC709", "drjit_ops", "iridescence_fresnel"]

#: The extension's XYZ → linear Rec. 709 matrix (rows: R, G, B).
XYZ_TO_REC709 = ((3.2404542, -1.5371385, -0.4985314),
                 (-0.9692660, 1.8760108, 0.0415560),
                 (0.0556434, -0.2040259, 1.0572252))
#: The Gaussian fits of the XYZ sensitivities in Fourier space (the extension's evalSensitivity).
_VAL = (5.4856e-13, 4.4201e-13, 5.2481e-13)
_POS = (1.6810e+06, 1.7953e+06, 2.2084e+06)
_VAR = (4.3278e+09, 9.3046e+09, 6.6121e+09)
_X2 = (9.7470e-14, 2.2399e+06, 4.5282e+09)  # X's second lobe: amplitude, position, variance
_NORM = 1.0685e-7

#: The array operations the definition needs, for NumPy.
NUMPY = SimpleNamespace(sqrt=np.sqrt, cos=np.cos, exp=np.exp, where=np.where, clip=np.clip, maximum=np.maximum)


def drjit_ops(dr):
    """The array operations the definition needs, for Dr.Jit (``dr`` the drjit module)."""
    return SimpleNamespace(sqrt=dr.sqrt, cos=dr.cos, exp=dr.exp, where=dr.select, clip=dr.clip, maximum=dr.maximum)


def _schlick(xp, f0, c):
    x = xp.clip(1.0 - c, 0.0, 1.0)
    x2 = x * x
    return f0 + (1.0 - f0) * (x2 * x2 * x)


def _ior_to_f0(transmitted, incident):
    r = (transmitted - incident) / (transmitted + incident)
    return r * r


def _sensitivity(xp, opd, shift):
    """The RGB sensitivity (3 arrays) at optical path difference ``opd`` (nm) and phase shifts (3 arrays)."""
    phase = 2.0 * math.pi * opd * 1.0e-9
    xyz = [v * math.sqrt(2.0 * math.pi * s) * xp.cos(p * phase + sh) * xp.exp(-(phase * phase) * s)
           for v, p, s, sh in zip(_VAL, _POS, _VAR, shift)]
    a, p, s = _X2
    xyz[0] = xyz[0] + a * math.sqrt(2.0 * math.pi * s) * xp.cos(p * phase + shift[0]) * xp.exp(-s * (phase * phase))
    xyz = [x * (1.0 / _NORM) for x in xyz]
    return [row[0] * xyz[0] + row[1] * xyz[1] + row[2] * xyz[2] for row in XYZ_TO_REC709]


def iridescence_fresnel(xp, cos_theta1, thickness, film_ior, base_f0, outside_ior: float = 1.0):
    """F_iridescence (3 arrays, R, G, B) of a film of ``thickness`` nm and index ``film_ior`` (scalars) over a
    base of normal-incidence reflectance ``base_f0`` (3 arrays or numbers), seen at ``cos_theta1`` (v·h)."""
    c1 = xp.clip(cos_theta1, 0.0, 1.0)
    sin2 = (outside_ior / film_ior) ** 2 * (1.0 - c1 * c1)
    tir = sin2 >= 1.0  # a film of lower index than the outside reflects everything past its critical angle
    c2 = xp.sqrt(xp.clip(1.0 - sin2, 0.0, 1.0))
    r12 = _schlick(xp, _ior_to_f0(film_ior, outside_ior), c1)
    t121 = 1.0 - r12
    phi21 = math.pi - (math.pi if film_ior < outside_ior else 0.0)
    # the optical path difference of the film, 2 η d cos θ2 (Belcour & Barla; the extension's text writes cos θ1,
    # its sample renderer and three.js cos θ2, the angle inside the film)
    opd = 2.0 * film_ior * thickness * c2
    parts = []
    for f0 in base_f0:
        sq = xp.sqrt(xp.clip(f0, 0.0, 0.9999))  # (a base of F0 1 has no finite index)
        base_ior = (1.0 + sq) / (1.0 - sq)
        r23 = _schlick(xp, _ior_to_f0(base_ior, film_ior), c2)
        phi23 = xp.where(base_ior < film_ior, math.pi, 0.0)
        r123 = xp.clip(r12 * r23, 1e-5, 0.9999)
        rs = t121 * t121 * r23 / (1.0 - r123)
        parts.append((r123, rs, phi21 + phi23))
    terms = [r12 + rs for _, rs, _ in parts]  # m = 0
    cm = [rs - t121 for _, rs, _ in parts]
    for m in (1, 2):
        cm = [c * xp.sqrt(r123) for c, (r123, _, _) in zip(cm, parts)]
        sens = _sensitivity(xp, m * opd, [m * phi for _, _, phi in parts])
        terms = [t + c * 2.0 * s for t, c, s in zip(terms, cm, sens)]
    return [xp.where(tir, 1.0, xp.maximum(t, 0.0)) for t in terms]
