"""glTF's clear coat (``KHR_materials_clearcoat``): a dielectric GGX layer of IOR 1.5 over the material.

The specification's layering, with the coat's Fresnel at the half vector::

    F_c      = 0.04 + (1 − 0.04) (1 − v·h)^5
    coated   = base · (1 − w F_c) + w F_c D(α_c) V(α_c)          (w = clearcoat, α_c = roughness_c²)

``D`` and ``V`` are the shared BRDF's GGX distribution and height-correlated Smith visibility
(:mod:`compare.brdf`), with the reference's α floor (:data:`~compare.brdf.REFERENCE_ALPHA_MIN`). The coat's
normal ``n`` is the surface's geometric normal, or glTF's ``clearcoatNormalTexture`` where the material has
one (then D, V and the cosine are the coat normal's; ``F_c`` is at the half vector either way; the
rasterizer draws the geometric normal and declares the map left out). This module is the definition; the reference's Mitsuba plugin
(:mod:`compare.mitsuba.coat`) evaluates the same formula and is tested against it.
"""

from __future__ import annotations

import numpy as np

from compare.brdf import DIELECTRIC_F0, H_LEN2_MIN, REFERENCE_ALPHA_MIN, alpha_from_roughness, fresnel_schlick, ggx_d, smith_v_height_correlated

__all__ = ["COAT_F0", "coat_geometry", "coat_lobe", "coated"]

#: F0 of the coat (glTF: IOR 1.5).
COAT_F0 = DIELECTRIC_F0


def coat_geometry(n, v, l, roughness):  # noqa: E741
    """(n·v, v·h, D V, ok) of a coat's GGX lobe about ``n`` at the reference's α floor; D V is 0 where not ``ok``
    (either direction below the coat, or a degenerate half vector). Shared by glTF's coat and the reference's
    model of Cycles' (:func:`compare.mitsuba.principled.coat_lobe_cycles`), which differ in Fresnel and layering."""
    n, v, l = (np.asarray(a, dtype=np.float64) for a in (n, v, l))
    nv, nl = np.sum(n * v, -1), np.sum(n * l, -1)
    hu = v + l
    len2 = np.sum(hu * hu, -1)
    ok = (nv > 0) & (nl > 0) & (len2 > H_LEN2_MIN)
    h = hu / np.sqrt(np.maximum(len2, H_LEN2_MIN))[..., None]
    nh = np.clip(np.sum(n * h, -1), 0.0, 1.0)
    vh = np.clip(np.sum(v * h, -1), 0.0, 1.0)
    alpha = alpha_from_roughness(roughness, REFERENCE_ALPHA_MIN)  # the reference's coat
    sin2 = np.sum(np.cross(n, h) ** 2, -1)  # |n × h|², exact where 1 − (n·h)² cancels
    dv = ggx_d(nh, alpha, sin2) * smith_v_height_correlated(np.where(ok, nv, 1.0), nl, alpha)
    return nv, vh, np.where(ok, dv, 0.0), ok


def coat_lobe(n, v, l, clearcoat, roughness):  # noqa: E741
    """(w F_c, w F_c D V): the coat's share at the half vector and its specular term (not times n·l)."""
    _, vh, dv, ok = coat_geometry(n, v, l, roughness)
    share = np.asarray(clearcoat, dtype=np.float64) * fresnel_schlick(COAT_F0, vh)
    return np.where(ok, share, 0.0), share * dv


def coated(base_value, n, v, l, clearcoat, roughness):  # noqa: E741
    """The coated material's value from the base's ``base_value`` (N, 3) at the same directions."""
    share, spec = coat_lobe(n, v, l, clearcoat, roughness)
    return np.asarray(base_value, dtype=np.float64) * (1.0 - share)[..., None] + spec[..., None]
