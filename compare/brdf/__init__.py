"""The one BRDF of the suite: glTF 2.0 metallic-roughness, numpy reference.

This module is the float64 reference of the material model that the rasterizer's
GLSL (:mod:`compare.brdf.glsl`, file ``brdf.glsl``) and the Mitsuba BSDF plugin
(:mod:`compare.mitsuba.bsdf`) implement in float32. The three forms are
tested against each other (``tests/test_brdf_agreement.py``), so that a
reference-versus-rasterizer difference measures lighting approximations, not a
material mismatch.

The model
---------
With unit vectors ``n`` (normal), ``v`` (towards the viewer), ``l`` (towards the
light), ``h = normalize(v + l)``, base colour ``c``, metallic ``m`` and
perceptual roughness ``r``::

    alpha  = max(r**2, ALPHA_MIN)                          (r, m clamped to [0, 1])
    F0     = mix(0.04, c, m)
    F      = F0 + (1 - F0) (1 - v.h)^5                      Schlick, per channel
    F_d    = 0.04 + 0.96 (1 - v.h)^5                        the dielectric Fresnel
    D      = alpha^2 / (pi ((n.h)^2 (alpha^2 - 1) + 1)^2)  GGX / Trowbridge-Reitz
    V      = G2 / (4 n.l n.v)                              height-correlated Smith
           = 0.5 / (n.l sqrt(n.v^2 (1 - a^2) + a^2) + n.v sqrt(n.l^2 (1 - a^2) + a^2))
    f      = F D V  +  (1 - m) (1 - F_d) c / pi

``f`` is the glTF 2.0 specification's appendix B form
``mix(dielectric_brdf, metal_brdf, metallic)`` with
``dielectric_brdf = fresnel_mix(ior=1.5, base=c/pi, layer=D V)`` and
``metal_brdf = conductor_fresnel(f0=c, D V)``, expanded: the two specular terms
add up to one Schlick term with ``F0 = mix(0.04, c, m)``, and **the diffuse lobe
is weighted by (1 - F_d)**, the scalar dielectric Fresnel (not by the coloured
``F``). The plain sum ``F D V + (1 - m) c / pi`` would put a white dielectric's
albedo above one at every angle (by its specular albedo); with the (1 - F_d)
weight it stays at or below one near normal incidence (cos(theta_v) >= 0.75,
``tests/test_brdf_extremes.py``) but **not at grazing angles**: there the
specular lobe tends to F = 1 while most light directions still see
v.h ~ 0.7 and a diffuse weight of ~0.96. A white dielectric's albedo reaches
1.03 at cos(theta_v) = 0.5 and 1.86 at 0.01 for roughness 0 (1.01 for
roughness 1). This is a property of the glTF form (its sample renderer shares
it); a conserving variant (albedo scaling of the diffuse lobe by
1 - E_spec(v), Kulla-Conty) needs a table and would have to go into all three
forms at once.

Numerical conventions (identical in all three forms)
----------------------------------------------------
* The BRDF is one-sided: zero unless ``n.v > 0`` and ``n.l > 0``; it is also zero
  when ``|v + l|^2 <= H_LEN2_MIN`` (v and l opposite each other within 1e-6 rad of
  the horizon, where the half vector is undefined in float32).
* ``alpha >= ALPHA_MIN = 0.002025`` (perceptual roughness 0.045, Filament's
  desktop value). Finiteness alone would allow far less: GGX's peak
  ``1 / (pi alpha^2)`` and the naive denominator ``alpha^4`` stay normal float32
  numbers down to ``alpha ~ 3e-10``. The binding constraint is precision: near the
  peak, float32 rounding of the half vector (about 2 ulp, 1.2e-7) perturbs
  ``sin^2(theta_h)`` by ~2.4e-7 * sin(theta_h), a relative error in D of about
  ``5e-7 / alpha`` for world-space inputs; at 0.002025 that is 2.4e-4, the
  tolerance of the GLSL test there (``docs/performance-notes.md``). Smaller alphas would
  buy a sharper highlight with a D that float32 no longer pins down. Roughness 0
  is therefore a very sharp glossy lobe, not a delta mirror. (Mitsuba's own
  microfacet code clamps at 1e-4; Filament's fp16 value is 0.089^2.)
* D uses the Lagrange identity ``(n.h)^2 (a^2 - 1) + 1 = |n x h|^2 + (n.h a)^2``
  (Filament), which avoids the cancellation of ``1 - (n.h)^2`` in float32.
* In V only, both cosines are raised to ``COS_MIN = 1e-4`` (Filament's
  ``MIN_N_DOT_V``, applied to both for reciprocity): V grows like
  ``1 / (alpha (n.v + n.l))`` at grazing angles and would overflow float32.
* ``v.h`` is clamped to [0, 1] before Schlick's power, computed as x^2 x^2 x.

References
----------
* glTF 2.0 specification, appendix B "BRDF implementation",
  https://registry.khronos.org/glTF/specs/2.0/glTF-2.0.html#appendix-b-brdf-implementation
* B. Walter et al., "Microfacet models for refraction through rough surfaces",
  EGSR 2007 (GGX).
* E. Heitz, "Understanding the masking-shadowing function in microfacet-based
  BRDFs", JCGT 3(2), 2014 (height-correlated Smith G2, its V form).
* C. Schlick, "An inexpensive BRDF model for physically-based rendering",
  Computer Graphics Forum 13(3), 1994.
* R. Guy, M. Agopian, "Physically Based Rendering in Filament" (2018-),
  https://google.github.io/filament/Filament.html (V form, Lagrange form of D,
  minimum roughness, NoV clamp).
* E. Heitz, "Sampling the GGX distribution of visible normals", JCGT 7(4), 2018;
  J. Dupuy, A. Benyoub, "Sampling visible GGX normals with spherical caps",
  HPG 2023 (the sampler of :func:`sample_ggx_vndf`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = [
    "ALPHA_MIN",
    "COS_MIN",
    "DENOM_MIN",
    "DIELECTRIC_F0",
    "H_LEN2_MIN",
    "REFERENCE_ALPHA_MIN",
    "SPECULAR_PROB_MIN",
    "alpha_from_roughness",
    "dielectric_specular",
    "directional_albedo",
    "eval_brdf",
    "eval_brdf_lobes",
    "fresnel_schlick",
    "ggx_d",
    "pdf_ggx_vndf_reflection",
    "sample_ggx_vndf",
    "smith_g1",
    "smith_v_height_correlated",
    "specular_sampling_probability",
]

#: The material models a renderer may be asked to render a scene's glTF materials with (``--materials``
#: of ``compare run`` and ``compare render``): name → what it is. Each renderer takes the ones it has.
MATERIAL_MODES = {
    "shared": "the glTF metallic-roughness BRDF every renderer of the suite shares (GGX single scattering, "
              "Schlick Fresnel)",
    "cycles": "Blender's Principled BSDF v2, with each material's distribution (Blender's default Multiscatter GGX)",
    "cycles-ggx": "Blender's Principled BSDF v2 with GGX single scattering in every material",
    "diffuse": "Lambert only (closed-form checks)",
}
#: Modes that model Blender's Principled BSDF, with the distribution they force (None: each material's).
PRINCIPLED_MODES = {"cycles": None, "cycles-ggx": "ggx"}
#: Modes for closed-form checks only, not offered to a run.
CLOSED_FORM_MODES = ("diffuse",)
#: Smallest GGX alpha (= 0.045**2, Filament's desktop MIN_ROUGHNESS) of the renderers that need a floor
#: (the rasterizer, in float32 near the peak); see the module notes.
ALPHA_MIN = 0.002025
#: Smallest GGX alpha of the reference: what the file says, down to Mitsuba's own microfacet clamp
#: (roughness 0.01, a lobe 1e-4 rad wide: a mirror). The reference's plugins evaluate D and their pdf from
#: the same half vector, so float32's imprecision near the peak cancels in their sample weights.
REFERENCE_ALPHA_MIN = 1e-4
#: Floor of n.v and n.l inside the visibility term V only (Filament's MIN_N_DOT_V).
COS_MIN = 1e-4
#: Normal-incidence reflectance of the dielectric base (ior 1.5: ((1.5-1)/(1.5+1))^2).
DIELECTRIC_F0 = 0.04
#: |v + l|^2 at or below which the BRDF is zero (half vector undefined).
H_LEN2_MIN = 1e-12
#: Smallest probability of sampling the specular lobe while a diffuse lobe exists.
SPECULAR_PROB_MIN = 0.1

DENOM_MIN = 1e-30  # guard of D's denominator; never active for unit vectors


def _dot(a, b):
    return np.sum(a * b, axis=-1)


def alpha_from_roughness(roughness, alpha_min: float = ALPHA_MIN):
    """GGX alpha from glTF perceptual roughness: ``max(clip(r, 0, 1)**2, alpha_min)``.

    Parameters
    ----------
    roughness : array_like
        Perceptual roughness (glTF ``roughnessFactor`` times texture).
    alpha_min : float
        The floor: :data:`ALPHA_MIN` for the renderers that need one (the rasterizer, this module's
        default), :data:`REFERENCE_ALPHA_MIN` for the reference (what the file says, down to a mirror).

    Returns
    -------
    ndarray
        alpha, float64, same shape.
    """
    r = np.clip(np.asarray(roughness, dtype=np.float64), 0.0, 1.0)
    return np.maximum(r * r, alpha_min)


def ggx_d(n_dot_h, alpha, sin2_theta_h=None):
    """GGX (Trowbridge-Reitz) normal distribution D(h), normalised so that
    ``integral D(h) (n.h) dh = 1``.

    Evaluated as ``(alpha / (sin^2 + (n.h alpha)^2))^2 / pi`` (Filament's
    Lagrange-identity form), which equals the textbook
    ``alpha^2 / (pi ((n.h)^2 (alpha^2 - 1) + 1)^2)`` for unit vectors.

    Parameters
    ----------
    n_dot_h : array_like
        Cosine between normal and half vector, in [0, 1].
    alpha : array_like
        GGX alpha (already clamped, see :func:`alpha_from_roughness`).
    sin2_theta_h : array_like, optional
        ``|n x h|^2``; computed as ``1 - n_dot_h^2`` when omitted. Pass it when
        the vectors are at hand: it is free of cancellation near the peak.

    References
    ----------
    Walter et al. 2007, eq. 33; Filament, section 4.4.2.
    """
    nh = np.asarray(n_dot_h, dtype=np.float64)
    alpha = np.asarray(alpha, dtype=np.float64)
    if sin2_theta_h is None:
        sin2_theta_h = np.maximum(1.0 - nh * nh, 0.0)
    a = nh * alpha
    k = alpha / np.maximum(np.asarray(sin2_theta_h, dtype=np.float64) + a * a, DENOM_MIN)
    return k * k / np.pi


def smith_g1(cos_theta, alpha):
    """Smith masking G1 for GGX: ``2 cos / (cos + sqrt(cos^2 (1 - a^2) + a^2))``.

    Used by the visible-normal pdf. No cosine floor is applied (the pdf must
    match the sampler exactly). Returns 0 for ``cos_theta <= 0``.

    References
    ----------
    Heitz 2014, eq. 72 with the GGX Lambda (eq. 86).
    """
    c = np.asarray(cos_theta, dtype=np.float64)
    a2 = np.asarray(alpha, dtype=np.float64) ** 2
    cp = np.maximum(c, 0.0)
    return 2.0 * cp / (cp + np.sqrt(cp * cp * (1.0 - a2) + a2))


def smith_v_height_correlated(n_dot_v, n_dot_l, alpha):
    """Height-correlated Smith visibility ``V = G2 / (4 n.l n.v)`` for GGX.

    ``V = 0.5 / (n.l sqrt(n.v^2 (1 - a^2) + a^2) + n.v sqrt(n.l^2 (1 - a^2) + a^2))``
    with both cosines raised to :data:`COS_MIN` first (so V stays finite).

    References
    ----------
    Heitz 2014, eq. 99 (height-correlated G2); Filament, section 4.4.2, eq. 15;
    glTF 2.0 appendix B.3.2.
    """
    nv = np.maximum(np.asarray(n_dot_v, dtype=np.float64), COS_MIN)
    nl = np.maximum(np.asarray(n_dot_l, dtype=np.float64), COS_MIN)
    a2 = np.asarray(alpha, dtype=np.float64) ** 2
    gv = nl * np.sqrt(nv * nv * (1.0 - a2) + a2)
    gl = nv * np.sqrt(nl * nl * (1.0 - a2) + a2)
    return 0.5 / (gv + gl)


def fresnel_schlick(f0, v_dot_h):
    """Schlick's Fresnel ``F0 + (1 - F0) (1 - v.h)^5``.

    Parameters
    ----------
    f0 : array_like
        Normal-incidence reflectance, scalar or RGB (last axis 3).
    v_dot_h : array_like
        Cosine between view and half vector; clamped to [0, 1]. For RGB ``f0``
        pass it with a trailing axis of length 1 (``vh[..., None]``).

    References
    ----------
    Schlick 1994, eq. 15.
    """
    x = np.clip(1.0 - np.asarray(v_dot_h, dtype=np.float64), 0.0, 1.0)
    x2 = x * x
    x5 = x2 * x2 * x
    f0 = np.asarray(f0, dtype=np.float64)
    return f0 + (1.0 - f0) * x5


class _Geometry(NamedTuple):
    """The inputs of a BRDF evaluation as float64 arrays, and the half-vector terms both models use."""

    base: np.ndarray
    m: np.ndarray
    r: np.ndarray
    alpha: np.ndarray
    nv: np.ndarray
    nl: np.ndarray
    nh: np.ndarray
    vh: np.ndarray
    sin2: np.ndarray
    front: np.ndarray


def _geometry(n, v, l, base_color, metallic, roughness, alpha_min: float = ALPHA_MIN) -> _Geometry:  # noqa: E741
    """Validate and convert the arguments of a BRDF evaluation; the half vector's cosines.

    Shared by the glTF model here and the Principled v2 model of :mod:`compare.mitsuba.principled`.
    """
    n = np.asarray(n, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    l = np.asarray(l, dtype=np.float64)  # noqa: E741 - the usual name of the light direction
    base = np.asarray(base_color, dtype=np.float64)
    m = np.clip(np.asarray(metallic, dtype=np.float64), 0.0, 1.0)
    r = np.clip(np.asarray(roughness, dtype=np.float64), 0.0, 1.0)
    for name, arr in (("n", n), ("v", v), ("l", l), ("base_color", base)):
        if arr.shape[-1:] != (3,):
            raise ValueError(f"{name} must have a last axis of length 3, got shape {arr.shape}")
    nv = _dot(n, v)
    nl = _dot(n, l)
    hu = v + l
    len2 = _dot(hu, hu)
    front = (nv > 0.0) & (nl > 0.0) & (len2 > H_LEN2_MIN)
    h = hu / np.sqrt(np.maximum(len2, H_LEN2_MIN))[..., None]
    nxh = np.cross(n, h)
    return _Geometry(base, m, r, alpha_from_roughness(r, alpha_min), nv, nl, np.clip(_dot(n, h), 0.0, 1.0),
                     np.clip(_dot(v, h), 0.0, 1.0), _dot(nxh, nxh), front)


def dielectric_specular(ior: float = 1.5, specular: float = 1.0, specular_color=(1.0, 1.0, 1.0)):
    """glTF's dielectric Fresnel parameters (``KHR_materials_ior``, ``KHR_materials_specular``):
    ``(F0, weight)`` with ``F0 = min(((ior − 1)/(ior + 1))² × specular_color, 1)`` (RGB) and the weight
    ``specular``. The dielectric part of the material is then ``(1 − weight·max(F)) × diffuse +
    weight·F × D V`` with ``F = F0 + (1 − F0)(1 − v·h)⁵`` (the specification's ``fresnel_mix``)."""
    f0 = ((float(ior) - 1.0) / (float(ior) + 1.0)) ** 2
    return np.minimum(f0 * np.asarray(specular_color, dtype=np.float64), 1.0), float(specular)


def eval_brdf_lobes(n, v, l, base_color, metallic, roughness, *, dielectric=None, alpha_min: float = ALPHA_MIN):
    """The specular and diffuse terms of :func:`eval_brdf`, separately.

    ``dielectric``: ``(F0, weight)`` of :func:`dielectric_specular` for a material with glTF's ior or
    specular extensions; None is the core model (F0 = 0.04, weight 1), evaluated as it always was.
    ``alpha_min``: the α floor (:func:`alpha_from_roughness`).

    Returns
    -------
    specular, diffuse : ndarray
        ``F D V`` and ``(1 - m)(1 - F_d) c / pi``, each ``(..., 3)`` float64, both
        zero below the horizon.
    """
    g = _geometry(n, v, l, base_color, metallic, roughness, alpha_min)
    base, m, nv, nl, vh, front = g.base, g.m, g.nv, g.nl, g.vh, g.front
    d = ggx_d(g.nh, g.alpha, g.sin2)
    vis = smith_v_height_correlated(nv, nl, g.alpha)
    if dielectric is None:
        f0 = DIELECTRIC_F0 + (base - DIELECTRIC_F0) * m[..., None]
        f = fresnel_schlick(f0, vh[..., None])
        fd = fresnel_schlick(DIELECTRIC_F0, vh)
        diff_weight = (1.0 - m) * (1.0 - fd)
    else:
        f0d, weight = np.asarray(dielectric[0], dtype=np.float64), float(dielectric[1])
        fr = fresnel_schlick(f0d, vh[..., None])
        f = m[..., None] * fresnel_schlick(base, vh[..., None]) + (1.0 - m)[..., None] * weight * fr
        diff_weight = (1.0 - m) * (1.0 - weight * np.max(fr, axis=-1))
    spec = f * (d * vis)[..., None]
    diff = diff_weight[..., None] * base / np.pi
    mask = front[..., None]
    return np.where(mask, spec, 0.0), np.where(mask, diff, 0.0)


def eval_brdf(n, v, l, base_color, metallic, roughness, *, alpha_min: float = ALPHA_MIN):
    """The glTF 2.0 metallic-roughness BRDF f(n, v, l) (not multiplied by n.l).

    Parameters
    ----------
    n, v, l : array_like, shape (..., 3)
        Unit normal, unit direction towards the viewer, unit direction towards
        the light. Not normalised here (neither does the GLSL nor the plugin).
    base_color : array_like, shape (..., 3)
        Linear base colour.
    metallic, roughness : array_like, shape (...)
        glTF metallic and perceptual roughness; clamped to [0, 1].
    alpha_min : float, keyword-only
        The α floor (:func:`alpha_from_roughness`): :data:`REFERENCE_ALPHA_MIN` for the reference's.

    Returns
    -------
    ndarray, shape (..., 3), float64
        The BRDF value in sr^-1; zero below either horizon. All leading
        dimensions broadcast.

    Notes
    -----
    ``f = F D V + (1 - m)(1 - F_d) c / pi``; see the module docstring for every
    term, the clamps and the references.
    """
    spec, diff = eval_brdf_lobes(n, v, l, base_color, metallic, roughness, alpha_min=alpha_min)
    return spec + diff


def specular_sampling_probability(cos_theta_i, base_color, metallic):
    """Probability with which the Mitsuba plugin samples the specular lobe.

    A cheap estimate of the two lobes' albedos at the incident cosine:
    ``w_s = mean_rgb(F_schlick(F0, cos))`` and
    ``w_d = (1 - m)(1 - F_schlick(0.04, cos)) mean_rgb(c)``; the probability is
    ``max(w_s / (w_s + w_d), SPECULAR_PROB_MIN)``, and 1 when ``w_d == 0`` (no
    diffuse lobe). The floor keeps sharp highlights sampled on bright
    dielectrics. Both lobes' pdfs are mixed with these weights (one-sample MIS).
    """
    c = np.clip(np.asarray(cos_theta_i, dtype=np.float64), 0.0, 1.0)
    base = np.asarray(base_color, dtype=np.float64)
    m = np.clip(np.asarray(metallic, dtype=np.float64), 0.0, 1.0)
    f0 = DIELECTRIC_F0 + (base - DIELECTRIC_F0) * m[..., None]
    w_s = np.mean(fresnel_schlick(f0, c[..., None]), axis=-1)
    w_d = (1.0 - m) * (1.0 - fresnel_schlick(DIELECTRIC_F0, c)) * np.mean(base, axis=-1)
    total = w_s + w_d
    ratio = w_s / np.where(total > 0.0, total, 1.0)
    return np.where(w_d > 0.0, np.maximum(ratio, SPECULAR_PROB_MIN), 1.0)


def sample_ggx_vndf(wi, alpha, u):
    """Sample a GGX visible normal (local frame, z = normal), spherical caps method.

    Parameters
    ----------
    wi : array_like, shape (..., 3)
        Unit direction towards the viewer, ``wi.z > 0``.
    alpha : array_like, shape (...)
        GGX alpha.
    u : array_like, shape (..., 2)
        Uniform numbers in [0, 1).

    Returns
    -------
    ndarray, shape (..., 3)
        Unit microfacet normal h, distributed as ``G1(wi) max(0, wi.h) D(h) / wi.z``.

    References
    ----------
    Dupuy & Benyoub, "Sampling visible GGX normals with spherical caps", HPG 2023,
    listing 3 (isotropic case); equivalent to Heitz 2018.
    """
    wi = np.asarray(wi, dtype=np.float64)
    a = np.asarray(alpha, dtype=np.float64)[..., None]
    u = np.asarray(u, dtype=np.float64)
    ws = np.concatenate([wi[..., :2] * a, wi[..., 2:]], axis=-1)
    ws = ws / np.linalg.norm(ws, axis=-1, keepdims=True)
    phi = 2.0 * np.pi * u[..., 0]
    z = (1.0 - u[..., 1]) * (1.0 + ws[..., 2]) - ws[..., 2]
    sin_t = np.sqrt(np.clip(1.0 - z * z, 0.0, 1.0))
    c = np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi), z], axis=-1)
    hs = c + ws
    h = np.concatenate([hs[..., :2] * a, hs[..., 2:]], axis=-1)
    norm = np.linalg.norm(h, axis=-1, keepdims=True)
    return h / np.maximum(norm, 1e-300)


def pdf_ggx_vndf_reflection(wi, wo, alpha):
    """Solid-angle pdf of ``wo = reflect(wi, h)`` with h from :func:`sample_ggx_vndf`.

    ``pdf = D(h) G1(wi) / (4 wi.z) = D(h) / (2 (wi.z + sqrt(wi.z^2 (1 - a^2) + a^2)))``,
    zero unless ``wi.z > 0`` and ``wo.z > 0``.

    References
    ----------
    Heitz 2018, eq. 17 with the reflection Jacobian 1 / (4 wo.h).
    """
    wi = np.asarray(wi, dtype=np.float64)
    wo = np.asarray(wo, dtype=np.float64)
    alpha = np.asarray(alpha, dtype=np.float64)
    ci, co = wi[..., 2], wo[..., 2]
    hu = wi + wo
    len2 = _dot(hu, hu)
    ok = (ci > 0.0) & (co > 0.0) & (len2 > H_LEN2_MIN)
    h = hu / np.sqrt(np.maximum(len2, H_LEN2_MIN))[..., None]
    sin2 = h[..., 0] ** 2 + h[..., 1] ** 2
    d = ggx_d(np.clip(h[..., 2], 0.0, 1.0), alpha, sin2)
    cp = np.maximum(ci, 0.0)
    a2 = alpha * alpha
    pdf = d / (2.0 * (cp + np.sqrt(cp * cp * (1.0 - a2) + a2)))
    return np.where(ok, pdf, 0.0)


def _stratified_2d(n, rng):
    """n jittered-stratified points in [0,1)^2 (an m x m grid, m = ceil(sqrt(n)))."""
    m = int(np.ceil(np.sqrt(n)))
    i, j = np.meshgrid(np.arange(m), np.arange(m), indexing="ij")
    u = (np.stack([i.ravel(), j.ravel()], axis=-1) + rng.random((m * m, 2))) / m
    return u


def directional_albedo(roughness, cos_theta, base_color=(1.0, 1.0, 1.0), metallic=1.0,
                       n_samples=65536, *, seed=0, return_stderr=False):
    """Directional albedo ``E(v) = integral f(n, v, l) (n.l) dl`` (white furnace).

    Each lobe is integrated with its own importance sampling, so the estimate
    is unbiased and has low variance even at roughness 0: the specular term
    with GGX visible normals (weight ``F D V (n.l) / pdf``, which is
    ``F G2 / G1(v)`` in closed form), the diffuse term with cosine-weighted
    directions (weight ``(1 - m)(1 - F_d) c``). Points are jittered-stratified
    on an ``m x m`` grid, ``m = ceil(sqrt(n_samples))``, from a fixed seed.

    Parameters
    ----------
    roughness, cos_theta : array_like
        Perceptual roughness and n.v, broadcast together to a shape S.
        ``cos_theta`` must be in (0, 1].
    base_color : array_like, shape (3,) or S + (3,)
    metallic : array_like, broadcast to S
    n_samples : int
        Samples per lobe and entry (rounded up to a square).
    seed : int, keyword-only
        Seed of the jitter.
    return_stderr : bool, keyword-only
        Also return the standard error of the estimate (iid formula, an upper
        bound for stratified points).

    Returns
    -------
    albedo : ndarray, shape S + (3,)
    stderr : ndarray, shape S + (3,), only with ``return_stderr``.
    """
    if int(n_samples) < 1:
        raise ValueError(f"n_samples must be a positive integer, got {n_samples!r}")
    r, ct, m = np.broadcast_arrays(np.asarray(roughness, dtype=np.float64),
                                   np.asarray(cos_theta, dtype=np.float64),
                                   np.asarray(metallic, dtype=np.float64))
    shape = r.shape
    base = np.broadcast_to(np.asarray(base_color, dtype=np.float64), shape + (3,))
    if np.any(~(ct > 0.0)) or np.any(ct > 1.0):
        raise ValueError("cos_theta must lie in (0, 1]; the BRDF is zero below the horizon")
    rng = np.random.default_rng(seed)
    out = np.zeros(shape + (3,))
    err = np.zeros(shape + (3,))
    n_axis = np.array([0.0, 0.0, 1.0])
    for idx in np.ndindex(shape):
        c = ct[idx]
        v = np.array([np.sqrt(max(0.0, 1.0 - c * c)), 0.0, c])
        alpha = alpha_from_roughness(r[idx])
        # specular lobe: visible-normal sampling
        u = _stratified_2d(n_samples, rng)
        h = sample_ggx_vndf(np.broadcast_to(v, u.shape[:-1] + (3,)), np.full(len(u), alpha), u)
        l_s = 2.0 * _dot(v, h)[..., None] * h - v
        spec, _ = eval_brdf_lobes(n_axis, v, l_s, base[idx], m[idx], r[idx])
        pdf = pdf_ggx_vndf_reflection(np.broadcast_to(v, l_s.shape), l_s, alpha)
        ok = (pdf > 0.0)[..., None]
        w_s = np.where(ok, spec * np.maximum(l_s[..., 2:], 0.0) / np.where(ok, pdf[..., None], 1.0), 0.0)
        # diffuse lobe: cosine-weighted hemisphere
        u = _stratified_2d(n_samples, rng)
        rad = np.sqrt(u[:, 0])
        phi = 2.0 * np.pi * u[:, 1]
        l_d = np.stack([rad * np.cos(phi), rad * np.sin(phi), np.sqrt(np.maximum(0.0, 1.0 - u[:, 0]))], -1)
        _, diff = eval_brdf_lobes(n_axis, v, l_d, base[idx], m[idx], r[idx])
        w_d = diff * np.pi  # f cos / (cos / pi)
        out[idx] = w_s.mean(axis=0) + w_d.mean(axis=0)
        err[idx] = np.sqrt(w_s.var(axis=0) / len(w_s) + w_d.var(axis=0) / len(w_d))
    return (out, err) if return_stderr else out
