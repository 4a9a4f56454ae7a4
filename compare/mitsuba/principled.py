"""Blender's Principled BSDF v2 as :mod:`compare.blender.export` sets it up, numpy reference.

The reference's ``cycles`` material mode (:mod:`compare.mitsuba.scene_dict`) renders
this model with the Mitsuba plugin (:mod:`compare.mitsuba.bsdf`,
``flavour = "cycles"``), so that a Mitsuba reference can be compared with
Blender Cycles pixel for pixel. It is the float64 reference of that flavour;
the plugin is tested against it (``tests/test_brdf_agreement.py``).

The model
---------
What Cycles' Principled BSDF (Blender 4.0 to 5.x, ``svm/closure.h``,
``closure/bsdf_microfacet.h``) builds for the exporter's node settings: IOR
1.5, Specular IOR Level 0.5, Specular Tint white, Diffuse Roughness 0, no coat,
sheen, subsurface or transmission, and either distribution: ``multi_ggx``
(Blender's default, Multiscatter GGX) or ``ggx`` (single scattering). With
``v`` towards the viewer, ``l`` towards the light, ``h = normalize(v + l)``,
base colour ``c``, metallic ``m``, perceptual roughness ``r`` (``alpha = r**2``)::

    f = [m F_m(v.h) K_m + (1 - m) F_d(v.h) K_d] D G2 / (4 n.v n.l)  +  w_d(r, n.v) c / pi
    F_m(x) = c + (1 - c)(1 - x)^5                 F82-tint with a white tint = Schlick
    F_d(x) = exact dielectric Fresnel, IOR 1.5      (F_d(1) = F0 = 0.04)
    w_d    = (1 - m)(1 - E_s(r, n.v) L_d)          albedo-scaled Lambert under the specular layer
    E_s    = F0 + (1 - F0) S(r, n.v)

``K`` and ``L`` are Multiscatter GGX's energy compensation
(:mod:`compare.brdf.multiscatter`: ``K = lobe_scale``, ``L = layer_factor``,
with each lobe's average Fresnel ``F_ss``, per channel for the metal); with
``ggx`` both are 1.

D is GGX and G2 the height-correlated Smith term, the same functions as the
shared BRDF (:mod:`compare.brdf`; ``D G2 / (4 n.v n.l) = D V``). ``E_s`` is
Cycles' estimate of the dielectric specular layer's albedo
(``bsdf_microfacet_estimate_albedo``, ``closure_layering_weight``): ``S`` is
its table ``ggx_gen_schlick_ior_s``, the mean over GGX visible normals ``h``
drawn for ``v`` of ``(F_d(v.h) - F0) / (1 - F0)``, counting 0 where the
reflected direction falls below the horizon. It averages the Fresnel
interpolation factor only, so ``E_s`` is *not* the specular lobe's directional
albedo: at roughness 1 the GGX lobe's albedo with F = 1 is only 0.31 at
normal incidence (0.41 averaged over directions; Cycles' ``ggx_E`` and
``ggx_Eavg``), a loss ``E_s`` does not see, so the diffuse is darkened by more
than the specular layer reflects. The diffuse weight depends on the view
direction only, so the BSDF is not reciprocal;
Cycles evaluates it with ``v`` = the direction towards the previous path
vertex, which is Mitsuba's ``si.wi``.

:func:`layer_table` recomputes the table the way ``cycles_precompute.cpp``
does (16 x 16 x 16 over roughness, ``n.v`` and ``z = F0**(1/4)``, grid point
``i`` at ``i/15``), for the two z slices that bracket IOR 1.5 (z = 6/15 and
7/15; IOR 1.5 sits at z = sqrt(0.2) = 0.4472), interpolated in z as Cycles'
``lookup_table_read_3D`` does; :data:`LAYER_S_TABLE` is its result at 128 x 128
stratified samples per cell. Looked up, it reproduces values read from Cycles'
own table within 3e-4 (roughness 0, 0.25, 0.5, 1 at n.v = 1, 0.7, 0.4, 0.1;
``tests/test_brdf_agreement.py``).
:func:`layer_s` looks it up with ``lookup_table_read_2D``'s bilinear
interpolation (texel i at coordinate i/15).

Differences from Cycles that remain
-----------------------------------
* ``alpha >= REFERENCE_ALPHA_MIN`` (1e-4, roughness 0.01: Mitsuba's own clamp, a lobe 1e-4 rad
  wide); Cycles takes roughness below ~0.004 as a perfect mirror and keeps everything in between.
  The table is indexed with the unclamped roughness, as in Cycles.
* V uses the shared BRDF's float32 guards (``COS_MIN``); Cycles has none.
* Cycles bends the shading normal of its specular closures when a reflection
  would go below the geometric surface (``ensure_valid_specular_reflection``);
  the scenes here are flat-shaded or close to it.
* The table is a Monte Carlo estimate in both (2^20 Sobol samples per cell in
  Cycles); the two differ by up to ~3e-4 in S, 1e-4 relative in the diffuse
  weight.
"""

from __future__ import annotations

import numpy as np

from compare.brdf import (DIELECTRIC_F0, REFERENCE_ALPHA_MIN, SPECULAR_PROB_MIN, _geometry, fresnel_schlick, ggx_d,
               sample_ggx_vndf, smith_v_height_correlated)
from compare.brdf.multiscatter import (DEFAULT_DISTRIBUTION, DISTRIBUTIONS, fresnel_dielectric_fss, fresnel_f82_fss,
                           layer_factor, lobe_scale, lookup_2d)

__all__ = [
    "FSS_DIELECTRIC",
    "IOR",
    "LAYER_S_TABLE",
    "LAYER_TABLE_SIZE",
    "eval_principled",
    "eval_principled_lobes",
    "fresnel_dielectric",
    "layer_s",
    "layer_table",
    "specular_layer_albedo",
    "specular_sampling_probability",
    "DEFAULT_DISTRIBUTION",
    "DISTRIBUTIONS",
]

#: Index of refraction of the dielectric specular layer (Principled's default; F0 = 0.04).
IOR = 1.5
#: Average Fresnel of the dielectric specular layer (Cycles' ``fresnel_dielectric_Fss(1.5)``).
FSS_DIELECTRIC = float(fresnel_dielectric_fss(IOR))
#: Points per axis of Cycles' ``ggx_gen_schlick_ior_s`` table.
LAYER_TABLE_SIZE = 16

# S(roughness, n.v) at IOR 1.5; row j: n.v = j/15, column i: roughness = i/15 (layer_table()).
LAYER_S_TABLE = np.array([
    [0.999391, 0.901216, 0.742371, 0.589308, 0.459531, 0.355986, 0.276103, 0.215648, 0.170369, 0.136608,
     0.111446, 0.092646, 0.078536, 0.067882, 0.059783, 0.053579],
    [0.670925, 0.666810, 0.625384, 0.535042, 0.432818, 0.339971, 0.263661, 0.204645, 0.159859, 0.126628,
     0.101853, 0.083326, 0.069423, 0.058740, 0.050586, 0.044217],
    [0.454662, 0.453838, 0.440854, 0.403991, 0.345888, 0.282236, 0.224961, 0.177339, 0.139988, 0.111155,
     0.089022, 0.072422, 0.059638, 0.049850, 0.042339, 0.036368],
    [0.309461, 0.309192, 0.304337, 0.288822, 0.259320, 0.220914, 0.181537, 0.146243, 0.117370, 0.093887,
     0.075573, 0.061336, 0.050420, 0.041855, 0.035115, 0.029978],
    [0.210543, 0.210458, 0.208661, 0.202073, 0.187854, 0.166358, 0.141512, 0.117049, 0.095449, 0.077367,
     0.062857, 0.051192, 0.041978, 0.034736, 0.028904, 0.024270],
    [0.142526, 0.142510, 0.141878, 0.139333, 0.132835, 0.121666, 0.106865, 0.091004, 0.075811, 0.062413,
     0.051186, 0.041989, 0.034583, 0.028541, 0.023705, 0.019792],
    [0.095529, 0.095538, 0.095644, 0.094719, 0.092035, 0.086735, 0.078704, 0.068954, 0.058846, 0.049382,
     0.041041, 0.034051, 0.028177, 0.023264, 0.019305, 0.015860],
    [0.063031, 0.063047, 0.063262, 0.063132, 0.062441, 0.060334, 0.056422, 0.051028, 0.044669, 0.038215,
     0.032265, 0.027108, 0.022567, 0.018829, 0.015604, 0.012859],
    [0.040635, 0.040651, 0.040875, 0.041179, 0.041304, 0.040863, 0.039352, 0.036643, 0.033022, 0.028988,
     0.025033, 0.021259, 0.017923, 0.014988, 0.012495, 0.010244],
    [0.025332, 0.025345, 0.025538, 0.025919, 0.026414, 0.026755, 0.026520, 0.025494, 0.023712, 0.021425,
     0.018875, 0.016337, 0.013940, 0.011786, 0.009913, 0.008289],
    [0.015033, 0.015044, 0.015195, 0.015556, 0.016176, 0.016762, 0.017174, 0.017098, 0.016487, 0.015353,
     0.013862, 0.012254, 0.010655, 0.009142, 0.007758, 0.006582],
    [0.008277, 0.008285, 0.008394, 0.008705, 0.009219, 0.009887, 0.010500, 0.010904, 0.010933, 0.010527,
     0.009860, 0.008975, 0.007945, 0.006926, 0.005953, 0.005108],
    [0.004031, 0.004035, 0.004108, 0.004388, 0.004747, 0.005307, 0.005942, 0.006461, 0.006819, 0.006878,
     0.006681, 0.006277, 0.005712, 0.005099, 0.004470, 0.003851],
    [0.001560, 0.001563, 0.001605, 0.001797, 0.002039, 0.002447, 0.002943, 0.003454, 0.003880, 0.004146,
     0.004242, 0.004149, 0.003943, 0.003625, 0.003249, 0.002934],
    [0.000341, 0.000343, 0.000362, 0.000458, 0.000582, 0.000856, 0.001160, 0.001532, 0.001898, 0.002208,
     0.002417, 0.002520, 0.002506, 0.002419, 0.002257, 0.002028],
    [0.000000, 0.000000, 0.000001, 0.000022, 0.000041, 0.000115, 0.000294, 0.000442, 0.000643, 0.000881,
     0.001129, 0.001267, 0.001418, 0.001462, 0.001453, 0.001374],
])


def _f0_from_ior(eta):
    return ((eta - 1.0) / (eta + 1.0)) ** 2


def fresnel_dielectric(cos_theta, eta=IOR):
    """Unpolarised Fresnel reflectance of a dielectric interface (Cycles' ``fresnel_dielectric_cos``).

    Parameters
    ----------
    cos_theta : array_like
        Cosine between the incident direction and the (micro)normal; its
        absolute value is used.
    eta : float
        Relative index of refraction (inside over outside).

    Returns
    -------
    ndarray
        Reflectance in [0, 1]; 1 under total internal reflection.
    """
    c = np.abs(np.asarray(cos_theta, dtype=np.float64))
    g2 = eta * eta - 1.0 + c * c
    g = np.sqrt(np.maximum(g2, 0.0))
    a = (g - c) / np.maximum(g + c, 1e-300)
    b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0)
    return np.where(g2 > 0.0, 0.5 * a * a * (1.0 + b * b), 1.0)


def _s_slice(z: float, samples: int) -> np.ndarray:
    """One z slice (16 x 16: row = n.v, column = roughness) of ``ggx_gen_schlick_ior_s``."""
    n = LAYER_TABLE_SIZE
    s = np.sqrt(np.clip(z, 1e-4, 0.99) ** 4)
    eta = (1.0 + s) / (1.0 - s)  # Cycles' ior_from_F0(z^4)
    f0 = _f0_from_ior(eta)
    g = (np.arange(samples) + 0.5) / samples
    u = np.stack(np.meshgrid(g, g, indexing="ij"), axis=-1).reshape(-1, 2)
    out = np.empty((n, n))
    for j in range(n):
        mu = np.clip(j / (n - 1), 1e-4, 1.0)
        wi = np.broadcast_to([np.sqrt(1.0 - mu * mu), 0.0, mu], (len(u), 3))
        for i in range(n):
            r = np.clip(i / (n - 1), 1e-4, 1.0)
            h = sample_ggx_vndf(wi, np.full(len(u), r * r), u)
            ch = np.sum(h * wi, axis=-1)
            wo_z = 2.0 * ch * h[:, 2] - wi[:, 2]
            s_real = np.clip((fresnel_dielectric(ch, eta) - f0) / (1.0 - f0), 0.0, 1.0)
            out[j, i] = np.mean(np.where(wo_z > 0.0, s_real, 0.0))
    return out


def layer_table(samples: int = 128, eta: float = IOR) -> np.ndarray:
    """Cycles' ``ggx_gen_schlick_ior_s`` at ``eta``, as Cycles reads it (see the module notes).

    Parameters
    ----------
    samples : int
        Stratified visible-normal samples per axis and cell (``samples**2`` per cell).
    eta : float
        IOR (> 1); the two bracketing z slices are computed and interpolated.

    Returns
    -------
    ndarray, shape (16, 16)
        Row j: n.v = j/15; column i: roughness = i/15.
    """
    n = LAYER_TABLE_SIZE
    z = np.sqrt(abs((eta - 1.0) / (eta + 1.0))) * (n - 1)
    k = min(int(z), n - 1)
    t = z - k
    lo = _s_slice(k / (n - 1), samples)
    if t == 0.0 or k == n - 1:
        return lo
    return (1.0 - t) * lo + t * _s_slice((k + 1) / (n - 1), samples)


def layer_s(roughness, cos_v, table=None):
    """``S(r, n.v)``: :data:`LAYER_S_TABLE` looked up as Cycles' ``lookup_table_read_2D`` (texel i at i/15)."""
    return lookup_2d(LAYER_S_TABLE if table is None else table, roughness, cos_v)


def specular_layer_albedo(roughness, cos_v):
    """``E_s = F0 + (1 - F0) S(r, n.v)``: the specular layer's albedo estimate that scales the diffuse."""
    return DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * layer_s(roughness, cos_v)


def _check_distribution(distribution: str) -> bool:
    """True for Multiscatter GGX; a clear error for anything but :data:`DISTRIBUTIONS`."""
    if distribution not in DISTRIBUTIONS:
        raise ValueError(f"distribution: expected one of {', '.join(DISTRIBUTIONS)}, got {distribution!r}")
    return distribution == "multi_ggx"


def _compensation(base, r, cos_v, multi: bool):
    """(K_m (..., 3), K_d (...), L_d (...)): Multiscatter GGX's factors, or ones for GGX."""
    if not multi:
        ones = np.ones(np.shape(cos_v))
        return np.ones(np.shape(cos_v) + (3,)), ones, ones
    mu = np.clip(cos_v, 0.0, 1.0)
    k_m = lobe_scale(fresnel_f82_fss(np.clip(base, 0.0, 1.0)), r, mu)
    return k_m, lobe_scale(FSS_DIELECTRIC, r, mu), layer_factor(FSS_DIELECTRIC, r, mu)


def eval_principled_lobes(n, v, l, base_color, metallic, roughness, distribution=DEFAULT_DISTRIBUTION):
    """The specular and diffuse terms of :func:`eval_principled`, separately.

    Returns
    -------
    specular, diffuse : ndarray
        ``[m F_m K_m + (1 - m) F_d K_d] D V`` and ``(1 - m)(1 - E_s(r, n.v) L_d) c / pi``,
        each ``(..., 3)`` float64, both zero below the horizon.
    """
    multi = _check_distribution(distribution)
    g = _geometry(n, v, l, base_color, metallic, roughness, REFERENCE_ALPHA_MIN)  # the reference's model
    base, m, r, nv, vh, front = g.base, g.m, g.r, g.nv, g.vh, g.front
    k_m, k_d, l_d = _compensation(np.broadcast_to(base, np.shape(nv) + (3,)), np.broadcast_to(r, np.shape(nv)),
                                  nv, multi)
    dv = ggx_d(g.nh, g.alpha, g.sin2) * smith_v_height_correlated(nv, g.nl, g.alpha)
    f_metal = fresnel_schlick(np.clip(base, 0.0, 1.0), vh[..., None]) * k_m
    f_diel = (fresnel_dielectric(vh) * k_d)[..., None]
    spec = (m[..., None] * f_metal + (1.0 - m[..., None]) * f_diel) * dv[..., None]
    w_d = (1.0 - m) * np.clip(1.0 - specular_layer_albedo(r, np.clip(nv, 0.0, 1.0)) * l_d, 0.0, 1.0)
    diff = w_d[..., None] * base / np.pi
    mask = front[..., None]
    return np.where(mask, spec, 0.0), np.where(mask, diff, 0.0)


def eval_principled(n, v, l, base_color, metallic, roughness, distribution=DEFAULT_DISTRIBUTION):
    """Principled BSDF v2 f(n, v, l) (not multiplied by n.l); arguments as :func:`compare.brdf.eval_brdf`,
    and ``distribution`` (:data:`DISTRIBUTIONS`, default Blender's ``multi_ggx``)."""
    spec, diff = eval_principled_lobes(n, v, l, base_color, metallic, roughness, distribution)
    return spec + diff


def specular_sampling_probability(cos_theta_i, base_color, metallic, roughness,
                                  distribution=DEFAULT_DISTRIBUTION):
    """Probability with which the plugin's ``cycles`` flavour samples the specular lobe.

    As :func:`compare.brdf.specular_sampling_probability`, with this model's
    lobe weights at the incident cosine: ``w_s = m mean_rgb(F_m(cos) K_m) + (1 - m) F_d(cos) K_d``
    and ``w_d = (1 - m)(1 - E_s(r, cos) L_d) mean_rgb(c)``.
    """
    multi = _check_distribution(distribution)
    c = np.clip(np.asarray(cos_theta_i, dtype=np.float64), 0.0, 1.0)
    base = np.asarray(base_color, dtype=np.float64)
    m = np.clip(np.asarray(metallic, dtype=np.float64), 0.0, 1.0)
    r = np.clip(np.asarray(roughness, dtype=np.float64), 0.0, 1.0)
    shape = np.broadcast_shapes(c.shape, m.shape, r.shape, base.shape[:-1])
    k_m, k_d, l_d = _compensation(np.broadcast_to(base, shape + (3,)), np.broadcast_to(r, shape),
                                  np.broadcast_to(c, shape), multi)
    f_metal = np.mean(fresnel_schlick(np.clip(base, 0.0, 1.0), c[..., None]) * k_m, axis=-1)
    w_s = m * f_metal + (1.0 - m) * fresnel_dielectric(c) * k_d
    w_d = (1.0 - m) * np.clip(1.0 - specular_layer_albedo(r, c) * l_d, 0.0, 1.0) * np.mean(base, axis=-1)
    total = w_s + w_d
    ratio = w_s / np.where(total > 0.0, total, 1.0)
    return np.where(w_d > 0.0, np.maximum(ratio, SPECULAR_PROB_MIN), 1.0)
