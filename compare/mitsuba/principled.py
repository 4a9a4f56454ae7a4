"""Blender's Principled BSDF v2 as :mod:`compare.blender.export` sets it up, numpy reference.

The reference's ``cycles`` material mode (:mod:`compare.mitsuba.scene_dict`) renders
this model with the Mitsuba plugin (:mod:`compare.mitsuba.bsdf`,
``flavour = "cycles"``), so that a Mitsuba reference can be compared with
Blender Cycles pixel for pixel. It is the float64 reference of that flavour;
the plugin is tested against it (``tests/test_brdf_agreement.py``,
``tests/test_principled_inputs.py``).

The model
---------
What Cycles' Principled BSDF (Blender 4.2 to 5.x, ``svm/closure.h``,
``closure/bsdf_microfacet.h``, ``closure/bsdf_util.h``) builds for the exporter's node settings:
``IOR``, ``Specular IOR Level`` and ``Specular Tint`` as the material says
(defaults 1.5, 0.5, white: F0 = 0.04), Diffuse Roughness 0, no subsurface or
thin film, and either distribution: ``multi_ggx`` (Blender's default,
Multiscatter GGX) or ``ggx`` (single scattering). With ``v`` towards the
viewer, ``l`` towards the light, ``h = normalize(v + l)``, base colour ``c``,
metallic ``m``, perceptual roughness ``r`` (``alpha = r**2``), IOR ``n``,
Specular IOR Level ``lv`` and Specular Tint ``t``::

    f = [m F_m(v.h) K_m + (1 - m) F_d(v.h) K_d] D G2 / (4 n.v n.l)  +  w_d(r, n.v) c / pi
    f0     = F0(n) 2 lv,  eta = ior_from_F0(f0)    the IOR adjustment (lv = 0.5: eta = n)
    F_d(x) = f0t + (1 - f0t) s(x),  f0t = min(f0 t, 1),  s(x) = (F(x, eta) - F0(eta)) / (1 - F0(eta))
                                                   generalized Schlick on the exact Fresnel curve
    F_m(x) = c + (1 - c)(1 - x)^5 - B x (1 - x)^6   F82-tint, B from c and min(t, 1) (B = 0: Schlick)
    w_d    = (1 - m)(1 - max_rgb(E_s(r, n.v) L_d))  albedo-scaled Lambert under the specular layer
    E_s    = f0t + (1 - f0t) S(r, n.v, eta)

No specular layer where ``eta = 1`` (IOR 1, or level 0: a dielectric is then
Lambert). ``K`` and ``L`` are Multiscatter GGX's energy compensation
(:mod:`compare.brdf.multiscatter`: ``K = lobe_scale``, ``L = layer_factor``,
with each lobe's average Fresnel ``F_ss``: ``mix(f0t, 1, s_avg)`` per channel for
the dielectric, ``s_avg`` the remapped ``fresnel_dielectric_Fss(eta)``, and
``mix(c, 1, 1/21) - B/126`` for the metal); with ``ggx`` both are 1.

The coat (Coat Weight ``w``, Coat Roughness, Coat IOR 1.5: :func:`coat_lobe_cycles`, the
``cycles`` flavour of :mod:`compare.mitsuba.coat`) goes over all of it as Cycles layers it: its lobe
``w F(v.h, 1.5) K_c D V`` and everything below scaled by ``1 - w E_c(r_c, n.v) L_c``, its own albedo
estimate at the view direction. The sheen (Sheen Weight × Sheen Tint ``s``, Sheen Roughness:
:func:`sheen_lobe_cycles`, the ``cycles`` flavour of :mod:`compare.mitsuba.sheen`) goes over the coat:
Zeltner et al.'s linearly transformed cosine ``s albedo D(l)`` from Cycles' table (not glTF's Charlie),
everything below scaled by ``1 - max(s) albedo``. Transmission is Mitsuba's dielectric at the IOR, tinted
at each interface by the square root of the base colour as Cycles' Principled glass is, rough glass masked
as Cycles masks it (height-correlated) and under Multiscatter GGX with Cycles' energy compensation
(:mod:`compare.mitsuba.scene_dict`, :mod:`compare.mitsuba.glass`).

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

:func:`layer_table_3d` recomputes the table the way ``cycles_precompute.cpp``
does (16 x 16 x 16 over roughness, ``n.v`` and ``z = F0**(1/4)``, grid point
``i`` at ``i/15``); :data:`LAYER_S_TABLE_3D` is its result at 128 x 128
stratified samples per cell (``principled_table.npz``, written by
``python -m tools.fit_principled``), and :func:`layer_s` looks it up with
``lookup_table_read_3D``'s trilinear interpolation. :data:`LAYER_S_TABLE`
is its slice at IOR 1.5 (z = sqrt(0.2) = 0.4472, between slices 6 and 7); it
reproduces values read from Cycles' own table within 3e-4 (roughness 0, 0.25,
0.5, 1 at n.v = 1, 0.7, 0.4, 0.1; ``tests/test_brdf_agreement.py``).

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

from pathlib import Path

import numpy as np

from compare.brdf import (REFERENCE_ALPHA_MIN, SPECULAR_PROB_MIN, _geometry, ggx_d, sample_ggx_vndf,
                          smith_v_height_correlated)
from compare.brdf.coat import coat_geometry
from compare.brdf.multiscatter import (DEFAULT_DISTRIBUTION, DISTRIBUTIONS, fresnel_dielectric_fss, layer_factor,
                                       lobe_scale, lookup_2d, lookup_3d)

__all__ = [
    "CYCLES_INPUTS",
    "FLAVOURS",
    "FSS_DIELECTRIC",
    "IOR",
    "LAYER_S_TABLE",
    "LAYER_S_TABLE_3D",
    "LAYER_TABLE_SIZE",
    "COAT_IOR",
    "coat_lobe_cycles",
    "SHEEN_LTC",
    "sheen_lobe_cycles",
    "sheen_ltc",
    "NEUTRAL_LEVEL",
    "dielectric_fresnel",
    "eval_principled",
    "eval_principled_lobes",
    "f0_from_ior",
    "f82_tint_b",
    "fresnel_dielectric",
    "fresnel_f82",
    "ior_from_f0",
    "layer_s",
    "layer_table",
    "layer_table_3d",
    "specular_ior",
    "specular_layer_albedo",
    "specular_sampling_probability",
    "DEFAULT_DISTRIBUTION",
    "DISTRIBUTIONS",
]

#: Index of refraction of the dielectric specular layer (Principled's default; F0 = 0.04).
IOR = 1.5
#: Values of the reference plugins' ``flavour`` property (``gltf_pbr``, ``gltf_coat``, ``gltf_sheen``,
#: ``rough_glass`` by ``compensate``): glTF's model, and this module's model of Blender's Principled BSDF v2.
FLAVOURS = ("gltf", "cycles")
#: Properties of ``gltf_pbr``'s flavour ``cycles`` only: Blender's Principled BSDF v2 inputs of the same names.
CYCLES_INPUTS = ("ior", "specular_ior_level", "specular_tint")
#: Coat IOR of the Blender export (glTF's coat has a fixed IOR of 1.5).
COAT_IOR = 1.5
#: Specular IOR Level that leaves the IOR as it is (Blender's neutral value).
NEUTRAL_LEVEL = 0.5
#: Specular Tint that leaves the layers untinted.
WHITE = (1.0, 1.0, 1.0)
#: Cycles' ggx_gen_schlick_ior_s recomputed (:func:`layer_table_3d`).
TABLE_PATH = Path(__file__).with_name("principled_table.npz")
#: Cycles' sheen LTC table (``table_sheen_ltc`` of Cycles' ``scene/shader.tables``, Apache-2.0, Blender
#: Foundation: Zeltner et al.'s fit; see THIRD_PARTY.md): it is a fit to a volumetric microflake model, so
#: it is copied, not recomputed.
SHEEN_LTC_PATH = Path(__file__).with_name("sheen_ltc.npz")
#: Cycles' clamp of the sheen's roughness.
SHEEN_ROUGHNESS_MIN = 1e-3
#: Average Fresnel of the dielectric specular layer (Cycles' ``fresnel_dielectric_Fss(1.5)``).
FSS_DIELECTRIC = float(fresnel_dielectric_fss(IOR))
#: Points per axis of Cycles' ``ggx_gen_schlick_ior_s`` table.
LAYER_TABLE_SIZE = 16

def check_flavour(plugin: str, flavour: str) -> str:
    """``flavour`` if it is one of :data:`FLAVOURS`, else one clear error naming the plugin."""
    if flavour not in FLAVOURS:
        raise ValueError(f"{plugin}: flavour must be one of {', '.join(FLAVOURS)}, got {flavour!r}")
    return flavour


def f0_from_ior(eta):
    """``((eta - 1)/(eta + 1))**2`` (Cycles' ``F0_from_ior``); arithmetic only, so a number, a numpy array or a
    Dr.Jit array (the plugins) all work."""
    return ((eta - 1.0) / (eta + 1.0)) ** 2


def ior_from_f0(f0):
    """The IOR whose normal-incidence reflectance is ``f0`` (Cycles' ``ior_from_F0``: F0 clamped to [0, 0.99])."""
    s = np.sqrt(np.clip(np.asarray(f0, dtype=np.float64), 0.0, 0.99))
    return (1.0 + s) / (1.0 - s)


def specular_ior(ior=IOR, level=NEUTRAL_LEVEL):
    """Principled v2's IOR adjustment: ``(eta, f0)`` of the dielectric specular layer.

    ``f0 = F0(ior) * 2 * level`` (Specular IOR Level 0.5 leaves the IOR as it is, 0 removes the
    layer, 1 doubles its F0) and ``eta = ior_from_F0(f0)``, the IOR of the layer's Fresnel curve;
    ``f0`` times the Specular Tint is the layer's F0. The layer exists where ``eta != 1``. For
    IOR >= 1, as glTF has it.
    """
    ior = np.asarray(ior, dtype=np.float64)
    level = np.maximum(np.asarray(level, dtype=np.float64), 0.0)
    f0 = f0_from_ior(ior) * 2.0 * level
    neutral = level == NEUTRAL_LEVEL
    return np.where(neutral, ior, ior_from_f0(f0)), np.where(neutral, f0_from_ior(ior), f0)


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
    eta = ior_from_f0(np.clip(z, 1e-4, 0.99) ** 4)
    f0 = f0_from_ior(eta)
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


def layer_table_3d(samples: int = 128) -> np.ndarray:
    """All of Cycles' ``ggx_gen_schlick_ior_s`` (16 x 16 x 16; slice k: z = k/15, where z = F0**(1/4)).

    What ``principled_table.npz`` holds at the default ``samples``; regenerate it with
    ``python -m tools.fit_principled``.
    """
    n = LAYER_TABLE_SIZE
    return np.stack([_s_slice(k / (n - 1), samples) for k in range(n)])


def _load_table() -> np.ndarray:
    with np.load(TABLE_PATH) as data:
        return data["ggx_gen_schlick_ior_s"].astype(np.float64)


#: Cycles' ``ggx_gen_schlick_ior_s``: [k, j, i] at z = k/15 (z = F0(eta)**(1/4)), n.v = j/15, roughness = i/15.
LAYER_S_TABLE_3D = _load_table()


def _table_z(eta):
    """The table's third coordinate for an IOR (Cycles: ``sqrt(|(eta - 1)/(eta + 1)|)``)."""
    eta = np.asarray(eta, dtype=np.float64)
    return np.sqrt(np.abs((eta - 1.0) / (eta + 1.0)))


def _slice_at(eta: float) -> np.ndarray:
    """The 2D table at one IOR: the 3D table's two bracketing slices mixed linearly in z, as
    ``lookup_table_read_3D`` mixes them (so a bilinear lookup in it is the trilinear lookup)."""
    n = LAYER_TABLE_SIZE
    z = float(np.clip(_table_z(eta), 0.0, 1.0)) * (n - 1)
    k = min(int(z), n - 1)
    t = z - k
    return (1.0 - t) * LAYER_S_TABLE_3D[k] + t * LAYER_S_TABLE_3D[min(k + 1, n - 1)]


#: S(roughness, n.v) at IOR 1.5; row j: n.v = j/15, column i: roughness = i/15.
LAYER_S_TABLE = _slice_at(IOR)


def layer_s(roughness, cos_v, eta=IOR):
    """``S(r, n.v)`` at ``eta``: the 3D table looked up as Cycles' ``lookup_table_read_3D`` (trilinear,
    texel i at i/15 on each axis; ``eta`` may vary per element)."""
    return lookup_3d(LAYER_S_TABLE_3D, roughness, cos_v, _table_z(eta))


def specular_layer_albedo(roughness, cos_v, eta=IOR, f0=None):
    """``E_s = F0 + (1 - F0) S(r, n.v, eta)``: the specular layer's albedo estimate that scales the diffuse.

    ``f0`` is the layer's (tinted) F0, with or without a channel axis; default ``F0(eta)``.
    """
    s = layer_s(roughness, cos_v, eta)
    if f0 is None:
        f0 = f0_from_ior(eta)
    else:  # a channel axis (..., 3): the tinted F0
        s = np.asarray(s)[..., None]
    f0 = np.asarray(f0, dtype=np.float64)
    return f0 + (1.0 - f0) * s


def _check_distribution(distribution: str) -> bool:
    """True for Multiscatter GGX; a clear error for anything but :data:`DISTRIBUTIONS`."""
    if distribution not in DISTRIBUTIONS:
        raise ValueError(f"distribution: expected one of {', '.join(DISTRIBUTIONS)}, got {distribution!r}")
    return distribution == "multi_ggx"


def f82_tint_b(f0, tint):
    """The F82-tint model's ``B`` for F0 and a tint (Cycles' ``fresnel_f82tint_B``): Schlick at
    cos = 1/7 (about 82 degrees) times the tint. ``tint`` is clamped to at most 1 first, as Cycles does."""
    f = 6.0 / 7.0
    f5 = f ** 5
    f0 = np.asarray(f0, dtype=np.float64)
    schlick = f0 + (1.0 - f0) * f5
    return schlick * (7.0 / (f5 * f)) * (1.0 - np.minimum(np.asarray(tint, dtype=np.float64), 1.0))


def fresnel_f82(cos_theta, f0, b):
    """F82-tint Fresnel of the metal layer (Cycles' ``fresnel_f82``): Schlick minus ``B cos (1 - cos)^6``."""
    c = np.clip(np.asarray(cos_theta, dtype=np.float64), 0.0, 1.0)[..., None]
    s = 1.0 - c
    return np.clip(f0 + (1.0 - f0) * s ** 5 - b * c * s ** 6, 0.0, 1.0)


def _layer(base_color, metallic, roughness, ior, level, tint, shape):
    """Per-point constants of the model: clamped base colour, m, r, eta, tinted F0, the metal's B."""
    base = np.broadcast_to(np.clip(np.asarray(base_color, dtype=np.float64), 0.0, 1.0), shape + (3,))
    tint = np.broadcast_to(np.maximum(np.asarray(tint, dtype=np.float64), 0.0), shape + (3,))
    eta, f0 = specular_ior(np.broadcast_to(ior, shape), np.broadcast_to(level, shape))
    f0t = np.clip(f0[..., None] * tint, 0.0, 1.0)
    return base, eta, f0t, f82_tint_b(base, tint)


def dielectric_fresnel(cos_theta, eta, f0t):
    """The specular layer's Fresnel (Cycles' generalized Schlick with the real Fresnel curve):
    ``f0t + (1 - f0t) s``, ``s`` the exact Fresnel at ``eta`` remapped from [F0(eta), 1] to [0, 1];
    ``(..., 3)``, zero where the layer does not exist (``eta == 1``)."""
    eta = np.asarray(eta, dtype=np.float64)
    on = eta != 1.0
    e = np.where(on, eta, 1.5)
    f0e = f0_from_ior(e)
    s = np.clip((fresnel_dielectric(cos_theta, e) - f0e) / (1.0 - f0e), 0.0, 1.0)
    return np.where(on[..., None], f0t + (1.0 - f0t) * s[..., None], 0.0)


def _compensation(base, b, eta, f0t, r, cos_v, multi: bool):
    """(K_m, K_d, L_d), each (..., 3): Multiscatter GGX's lobe scales and the layer factor, or ones for GGX."""
    if not multi:
        ones = np.ones(np.shape(cos_v) + (3,))
        return ones, ones, ones
    mu = np.clip(cos_v, 0.0, 1.0)
    k_m = lobe_scale(base + (1.0 - base) / 21.0 - b / 126.0, r, mu)  # Cycles' fresnel_f82_Fss
    e = np.where(eta != 1.0, eta, 1.5)
    f0e = f0_from_ior(e)
    s_avg = np.clip((fresnel_dielectric_fss(e) - f0e) / (1.0 - f0e), 0.0, 1.0)
    fss_d = np.where((eta != 1.0)[..., None], f0t + (1.0 - f0t) * s_avg[..., None], 0.0)
    return k_m, lobe_scale(fss_d, r, mu), layer_factor(fss_d, r, mu)


def _diffuse_weight(m, r, cos_v, eta, f0t, l_d):
    """``(1 - m)(1 - max_rgb(E_s L_d))``: Cycles' closure_layering_weight under the specular layer."""
    e_s = np.where((eta != 1.0)[..., None], specular_layer_albedo(r, np.clip(cos_v, 0.0, 1.0), eta, f0t), 0.0)
    return (1.0 - m) * np.clip(1.0 - np.max(e_s * l_d, axis=-1), 0.0, 1.0)


def eval_principled_lobes(n, v, l, base_color, metallic, roughness, distribution=DEFAULT_DISTRIBUTION, *,
                          ior=IOR, specular_ior_level=NEUTRAL_LEVEL, specular_tint=WHITE):
    """The specular and diffuse terms of :func:`eval_principled`, separately.

    Returns
    -------
    specular, diffuse : ndarray
        ``[m F_m K_m + (1 - m) F_d K_d] D V`` and ``(1 - m)(1 - max(E_s L_d)) c / pi``,
        each ``(..., 3)`` float64, both zero below the horizon.
    """
    multi = _check_distribution(distribution)
    g = _geometry(n, v, l, base_color, metallic, roughness, REFERENCE_ALPHA_MIN)  # the reference's model
    m, r, nv, vh, front = g.m, g.r, g.nv, g.vh, g.front
    shape = np.shape(nv)
    base, eta, f0t, b = _layer(g.base, m, r, ior, specular_ior_level, specular_tint, shape)
    r = np.broadcast_to(r, shape)
    k_m, k_d, l_d = _compensation(base, b, eta, f0t, r, nv, multi)
    dv = ggx_d(g.nh, g.alpha, g.sin2) * smith_v_height_correlated(nv, g.nl, g.alpha)
    f_metal = fresnel_f82(vh, base, b) * k_m
    f_diel = dielectric_fresnel(vh, eta, f0t) * k_d
    spec = (m[..., None] * f_metal + (1.0 - m[..., None]) * f_diel) * dv[..., None]
    diff = _diffuse_weight(m, r, nv, eta, f0t, l_d)[..., None] * np.asarray(g.base) / np.pi
    mask = front[..., None]
    return np.where(mask, spec, 0.0), np.where(mask, diff, 0.0)


def eval_principled(n, v, l, base_color, metallic, roughness, distribution=DEFAULT_DISTRIBUTION, **inputs):
    """Principled BSDF v2 f(n, v, l) (not multiplied by n.l); arguments as :func:`compare.brdf.eval_brdf`,
    ``distribution`` (:data:`DISTRIBUTIONS`, default Blender's ``multi_ggx``) and the keyword inputs
    ``ior``, ``specular_ior_level``, ``specular_tint`` (Blender's; defaults IOR 1.5, 0.5, white)."""
    spec, diff = eval_principled_lobes(n, v, l, base_color, metallic, roughness, distribution, **inputs)
    return spec + diff


def specular_sampling_probability(cos_theta_i, base_color, metallic, roughness,
                                  distribution=DEFAULT_DISTRIBUTION, *, ior=IOR,
                                  specular_ior_level=NEUTRAL_LEVEL, specular_tint=WHITE):
    """Probability with which the plugin's ``cycles`` flavour samples the specular lobe.

    As :func:`compare.brdf.specular_sampling_probability`, with this model's
    lobe weights at the incident cosine: ``w_s = m mean_rgb(F_m(cos) K_m) + (1 - m) mean_rgb(F_d(cos) K_d)``
    and ``w_d = (1 - m)(1 - max(E_s(r, cos) L_d)) mean_rgb(c)``.
    """
    multi = _check_distribution(distribution)
    c = np.clip(np.asarray(cos_theta_i, dtype=np.float64), 0.0, 1.0)
    base = np.asarray(base_color, dtype=np.float64)
    m = np.clip(np.asarray(metallic, dtype=np.float64), 0.0, 1.0)
    r = np.clip(np.asarray(roughness, dtype=np.float64), 0.0, 1.0)
    shape = np.broadcast_shapes(c.shape, m.shape, r.shape, base.shape[:-1])
    cc, eta, f0t, b = _layer(base, m, r, ior, specular_ior_level, specular_tint, shape)
    r, c = np.broadcast_to(r, shape), np.broadcast_to(c, shape)
    k_m, k_d, l_d = _compensation(cc, b, eta, f0t, r, c, multi)
    f_metal = np.mean(fresnel_f82(c, cc, b) * k_m, axis=-1)
    w_s = m * f_metal + (1.0 - m) * np.mean(dielectric_fresnel(c, eta, f0t) * k_d, axis=-1)
    w_d = _diffuse_weight(m, r, c, eta, f0t, l_d) * np.mean(base, axis=-1)
    total = w_s + w_d
    ratio = w_s / np.where(total > 0.0, total, 1.0)
    return np.where(w_d > 0.0, np.maximum(ratio, SPECULAR_PROB_MIN), 1.0)


def coat_lobe_cycles(n, v, l, weight, roughness):  # noqa: E741
    """Principled v2's coat as Cycles builds it: ``(keep, spec)``, what the layers below keep and the
    coat's lobe (not times n.l), with ``n`` the coat's normal.

    ``keep = 1 - w E_c(r, n.v) L_c`` (Cycles' closure_layering_weight: the coat's albedo estimate
    ``E_c = F0 + (1 - F0) S(r, n.v, 1.5)`` times the layer factor, at the view direction only) and
    ``spec = w F(v.h, 1.5) K_c D V``. Cycles always compensates the coat's lost energy (Multiscatter GGX's
    ``K_c``, ``L_c`` with ``fresnel_dielectric_Fss(1.5)``), whatever the base's distribution.
    """
    nv, vh, dv, _ = coat_geometry(n, v, l, roughness)
    r = np.clip(np.asarray(roughness, dtype=np.float64), 0.0, 1.0)
    w = np.clip(np.asarray(weight, dtype=np.float64), 0.0, 1.0)
    mu = np.clip(nv, 0.0, 1.0)
    fss = fresnel_dielectric_fss(COAT_IOR)
    keep = np.where(nv > 0, np.clip(1.0 - w * specular_layer_albedo(r, mu, COAT_IOR) * layer_factor(fss, r, mu),
                                    0.0, 1.0), 1.0)
    return keep, w * fresnel_dielectric(vh, COAT_IOR) * lobe_scale(fss, r, mu) * dv


def _load_sheen() -> np.ndarray:
    with np.load(SHEEN_LTC_PATH) as data:
        return data["sheen_ltc"].astype(np.float64)


#: [plane, j, i]: plane 0 the LTC's A, 1 its B, 2 the lobe's albedo; row j: roughness j/31, column i: n.v i/31.
SHEEN_LTC = _load_sheen()


def sheen_ltc(cos_v, roughness):
    """(A, B, albedo) of Cycles' sheen at the view cosine and roughness (``lookup_table_read_2D``, x = n.v)."""
    r = np.clip(np.asarray(roughness, dtype=np.float64), SHEEN_ROUGHNESS_MIN, 1.0)
    return tuple(lookup_2d(SHEEN_LTC[k], cos_v, r) for k in range(3))


def sheen_lobe_cycles(v, l, roughness):  # noqa: E741
    """Principled v2's sheen as Cycles builds it, in the local frame (normal +z): ``(albedo, f)``.

    Zeltner et al.'s linearly transformed cosine, ``f n.l = albedo D(l)`` with
    ``D = l_z (A / |(A l_x + B l_z, A l_y, l_z)|^2)^2 / pi`` in the frame whose x axis is the view's tangential
    direction, and the layers below scaled by ``1 - max(colour) albedo`` (the albedo at the view direction,
    Cycles' closure_layering_weight). Where the table's LTC is degenerate (A or the albedo under 1e-5) Cycles
    drops the closure: albedo and f are 0 there. Times the sheen colour (Sheen Weight × Sheen Tint).
    """
    v, l = np.asarray(v, dtype=np.float64), np.asarray(l, dtype=np.float64)
    a, b, albedo = sheen_ltc(np.clip(v[..., 2], 0.0, 1.0), roughness)
    on = (np.abs(a) >= 1e-5) & (albedo >= 1e-5) & (v[..., 2] > 0.0)
    t_len = np.hypot(v[..., 0], v[..., 1])
    tx = np.where(t_len > 1e-9, v[..., 0] / np.maximum(t_len, 1e-300), 1.0)
    ty = np.where(t_len > 1e-9, v[..., 1] / np.maximum(t_len, 1e-300), 0.0)
    lx, ly, lz = l[..., 0] * tx + l[..., 1] * ty, l[..., 1] * tx - l[..., 0] * ty, l[..., 2]
    len2 = (a * lx + b * lz) ** 2 + (a * ly) ** 2 + lz ** 2
    f = albedo * (a / np.maximum(len2, 1e-300)) ** 2 / np.pi
    return np.where(on, albedo, 0.0), np.where(on & (lz > 0.0), f, 0.0)
