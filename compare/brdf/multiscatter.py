"""Cycles' Multiscatter GGX: the energy compensation of Blender's default Principled BSDF.

Blender's Principled BSDF (4.0 to 5.x) defaults to ``distribution =
'MULTI_GGX'``. Since Blender 4.0 Cycles does not random-walk between
microfacets for it; it scales the single-scattering GGX lobe by an
albedo-based factor (``microfacet_ggx_preserve_energy`` in
``kernel/closure/bsdf_microfacet.h``, Kulla & Conty, "Revisiting Physically
Based Shading at Imageworks", 2017, with one ``F_ss`` cancelled). For a lobe of
perceptual roughness ``r`` seen from ``v`` (``mu = n.v``)::

    E     = ggx_E(r, mu)       albedo of the GGX lobe with F = 1 (height-correlated Smith)
    E_avg = ggx_Eavg(r)        its cosine-weighted mean over mu, 2 * int E(mu) mu dmu
    F_ms  = F_ss E_avg / (1 - F_ss (1 - E_avg))
    lobe  = f_ss(v, l) * (1 + F_ms (1 - E) / E)          (lobe_scale)

where ``F_ss`` is the lobe's average Fresnel: for the dielectric specular layer
``fresnel_dielectric_Fss(ior)`` (Cycles' rational fit; 0.0895 at IOR 1.5),
for the metallic F82-tint lobe with a white tint ``mix(F0, 1, 1/21)`` per
channel (``fresnel_f82_Fss`` with B = 0). The factor depends on ``v`` only,
as in Cycles, where ``mu`` is the direction towards the previous path vertex.

The layer under the specular (the diffuse) is weighted by
``1 - E_s * (E + F_ms (1 - E))`` (:func:`layer_factor`): Cycles' compensation
multiplies the closure's weight by ``E + F_ms (1 - E)`` and its energy scale by
``1/E``, and ``closure_layering_weight`` reads the albedo estimate ``E_s``
(:mod:`compare.mitsuba.principled`) times that weight. With GGX (single
scattering) both factors are 1. Because ``E < 1`` at any roughness above ~0.2,
the multiscatter diffuse is *brighter* than the single-scattering one (at
roughness 1 and normal incidence, weight 1 - 0.045 against 1 - 0.090 for
IOR 1.5), and glossy lobes gain up to (1 - E)/E F_ms.

The tables are computed the way ``cycles_precompute.cpp`` computes its
``ggx_E`` (32 x 32, roughness and mu on the grid ``i/31``, each clamped to at
least 1e-4) and ``ggx_Eavg`` (32): the mean of ``G2(v, l) / G1(v)`` (zero when
``l`` falls below the horizon) over GGX visible normals drawn for ``v``
(:func:`energy_tables`, Hammersley points here, Sobol in Cycles), and looked up
as ``lookup_table_read_2D`` / ``lookup_table_read`` do (linear, texel ``i`` at
coordinate ``i/31``). ``energy_table.npz`` holds the result at 256²
Hammersley points per cell (E) and 64 Gauss-Legendre nodes in mu of 128² points
each (E_avg). It agrees with Cycles' own tables (``scene/shader.tables`` of
Blender 5.0; the differences are in ``docs/performance-notes.md``);
``tests/test_multiscatter.py`` recomputes part of it and checks values read
from Cycles' tables.
Regenerate with ``python -m tools.fit_multiscatter``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = [
    "DEFAULT_DISTRIBUTION",
    "DISTRIBUTIONS",
    "ENERGY_TABLE_SIZE",
    "GGX_E_TABLE",
    "GGX_EAVG_TABLE",
    "fresnel_dielectric_fss",
    "fresnel_f82_fss",
    "ggx_e",
    "ggx_eavg",
    "layer_factor",
    "lobe_scale",
    "lookup_1d",
    "lookup_2d",
    "multiscatter_fresnel",
]

#: The Principled BSDF's microfacet distributions this suite models (Blender's enum names, lower case).
DISTRIBUTIONS = ("multi_ggx", "ggx")
#: Blender's default (what a Principled BSDF node and Blender's glTF importer create).
DEFAULT_DISTRIBUTION = "multi_ggx"
#: Points per axis of Cycles' ``ggx_E`` and ``ggx_Eavg`` tables.
ENERGY_TABLE_SIZE = 32
TABLE_PATH = Path(__file__).with_name("energy_table.npz")


def _load() -> tuple[np.ndarray, np.ndarray]:
    with np.load(TABLE_PATH) as data:
        return data["ggx_E"].astype(np.float64), data["ggx_Eavg"].astype(np.float64)


#: ``ggx_E``: row j: mu = j/31, column i: roughness = i/31.
#: ``ggx_Eavg``: entry i: roughness i/31.
GGX_E_TABLE, GGX_EAVG_TABLE = _load()


def _axis(x, n):
    x = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0) * (n - 1)
    i = np.minimum(x.astype(np.int64), n - 1)
    return i, np.minimum(i + 1, n - 1), x - i


def lookup_1d(table, x):
    """Cycles' ``lookup_table_read``: linear in a table whose entry i sits at coordinate i / (n - 1)."""
    t = np.asarray(table, dtype=np.float64)
    i0, i1, f = _axis(x, len(t))
    return t[i0] * (1.0 - f) + t[i1] * f


def lookup_2d(table, x, y):
    """Cycles' ``lookup_table_read_2D``: bilinear, column i at x = i / (nx - 1), row j at y = j / (ny - 1)."""
    t = np.asarray(table, dtype=np.float64)
    i0, i1, tx = _axis(x, t.shape[1])
    j0, j1, ty = _axis(y, t.shape[0])
    a = t[j0, i0] * (1.0 - tx) + t[j0, i1] * tx
    b = t[j1, i0] * (1.0 - tx) + t[j1, i1] * tx
    return a * (1.0 - ty) + b * ty


def lookup_3d(table, x, y, z):
    """Cycles' ``lookup_table_read_3D``: trilinear in ``table[k, j, i]``, i at x = i / (nx - 1), j at
    y = j / (ny - 1), k at z = k / (nz - 1)."""
    t = np.asarray(table, dtype=np.float64)
    k0, k1, tz = _axis(z, t.shape[0])
    return _lookup_2d_at(t, k0, x, y) * (1.0 - tz) + _lookup_2d_at(t, k1, x, y) * tz


def _lookup_2d_at(table, k, x, y):
    """:func:`lookup_2d` in slice ``k`` (per element) of a 3D table."""
    i0, i1, tx = _axis(x, table.shape[2])
    j0, j1, ty = _axis(y, table.shape[1])
    a = table[k, j0, i0] * (1.0 - tx) + table[k, j0, i1] * tx
    b = table[k, j1, i0] * (1.0 - tx) + table[k, j1, i1] * tx
    return a * (1.0 - ty) + b * ty


def ggx_e(roughness, mu):
    """E(r, mu): :data:`GGX_E_TABLE` looked up as Cycles does."""
    return lookup_2d(GGX_E_TABLE, roughness, mu)


def ggx_eavg(roughness):
    """E_avg(r): :data:`GGX_EAVG_TABLE` looked up as Cycles does."""
    return lookup_1d(GGX_EAVG_TABLE, roughness)


def fresnel_dielectric_fss(eta):
    """Average dielectric Fresnel (Cycles' ``fresnel_dielectric_Fss``, its fit for IOR >= 1); arithmetic only,
    so a number, a numpy array or a Dr.Jit array (the plugins) all work."""
    return (eta - 1.0) / (4.08567 + 1.00071 * eta)


def fresnel_f82_fss(f0):
    """Average F82-tint Fresnel with a white tint: ``mix(F0, 1, 1/21)`` (Cycles' ``fresnel_f82_Fss``, B = 0)."""
    f0 = np.asarray(f0, dtype=np.float64)
    return f0 + (1.0 - f0) / 21.0


def multiscatter_fresnel(fss, roughness):
    """``F_ms = F_ss E_avg / (1 - F_ss (1 - E_avg))``; ``fss`` broadcasts against ``roughness``."""
    e_avg = ggx_eavg(roughness)
    fss = np.asarray(fss, dtype=np.float64)
    if fss.ndim > np.ndim(e_avg):  # per-channel F_ss (metals): roughness varies over the leading axes
        e_avg = np.asarray(e_avg)[..., None]
    return fss * e_avg / (1.0 - fss * (1.0 - e_avg))


def _e_and_fms(fss, roughness, mu):
    """E(r, mu) and F_ms, E with a channel axis when F_ss has one (metals)."""
    e = ggx_e(roughness, mu)
    f_ms = multiscatter_fresnel(fss, roughness)
    return (np.asarray(e)[..., None] if np.ndim(f_ms) > np.ndim(e) else e), f_ms


def lobe_scale(fss, roughness, mu):
    """``1 + F_ms (1 - E) / E``: what Multiscatter GGX multiplies the single-scattering lobe by."""
    e, f_ms = _e_and_fms(fss, roughness, mu)
    return 1.0 + f_ms * (1.0 - e) / e


def layer_factor(fss, roughness, mu):
    """``E + F_ms (1 - E)`` (= E × :func:`lobe_scale`): the factor on the specular layer's albedo
    estimate that the diffuse sees."""
    e, f_ms = _e_and_fms(fss, roughness, mu)
    return e + f_ms * (1.0 - e)


