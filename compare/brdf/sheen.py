"""glTF's sheen (``KHR_materials_sheen``): a Charlie lobe over the material, albedo-scaled.

The specification's model::

    D(h)   = (2 + 1/α) sin(θ_h)^(1/α) / (2π)                      Charlie (Estevez & Kulla 2017), α = r²
    V      = 1 / (4 (n·l + n·v − n·l n·v))                          Ashikhmin's visibility (Neubelt & Pettineo 2013)
    sheen  = color · D V
    scale  = min(1 − max(color) E(n·v, r), 1 − max(color) E(n·l, r))
    f      = base · scale + sheen

``E(μ, r)`` is the sheen lobe's directional albedo (colour 1), the integral of ``D V cos`` over the
hemisphere: tabulated here by quadrature (:func:`albedo_table`) on a grid of μ and r, and read with
bilinear interpolation (:func:`albedo`), as the reference's Mitsuba plugin (:mod:`compare.mitsuba.sheen`)
reads the same table. α is floored at :data:`SHEEN_ALPHA_MIN`: below it ``sin^(1/α)`` leaves a lobe at
grazing half vectors only that float32 cannot hold.
"""

from __future__ import annotations

import functools

import numpy as np

__all__ = ["SHEEN_ALPHA_MIN", "TABLE_SIZE", "albedo", "albedo_table", "charlie_d", "sheen_lobe", "sheened",
           "sheen_tables", "under_scale_table"]

#: Smallest Charlie α (roughness 0.1).
SHEEN_ALPHA_MIN = 0.01
#: Grid points of the albedo table on each axis (μ = n·v and roughness, both from 0 to 1).
TABLE_SIZE = 32


def sheen_alpha(roughness):
    r = np.clip(np.asarray(roughness, dtype=np.float64), 0.0, 1.0)
    return np.maximum(r * r, SHEEN_ALPHA_MIN)


def charlie_d(n_dot_h, alpha):
    """Charlie's distribution of half vectors."""
    nh = np.clip(np.asarray(n_dot_h, dtype=np.float64), 0.0, 1.0)
    inv = 1.0 / np.asarray(alpha, dtype=np.float64)
    sin2 = np.maximum(1.0 - nh * nh, 0.0)
    return (2.0 + inv) * sin2 ** (0.5 * inv) / (2.0 * np.pi)


def ashikhmin_v(n_dot_v, n_dot_l):
    nv, nl = np.asarray(n_dot_v, dtype=np.float64), np.asarray(n_dot_l, dtype=np.float64)
    return 1.0 / (4.0 * np.maximum(nl + nv - nl * nv, 1e-6))


def sheen_lobe(n_dot_v, n_dot_l, n_dot_h, roughness):
    """``D V`` of a sheen of colour 1 (not times n·l); zero below either horizon."""
    ok = (np.asarray(n_dot_v) > 0) & (np.asarray(n_dot_l) > 0)
    value = charlie_d(n_dot_h, sheen_alpha(roughness)) * ashikhmin_v(n_dot_v, n_dot_l)
    return np.where(ok, value, 0.0)


@functools.lru_cache(maxsize=1)
def albedo_table() -> np.ndarray:
    """E(μ, r) on a :data:`TABLE_SIZE`² grid (rows μ = i/(n−1), columns r = j/(n−1)), float32: the
    midpoint rule over θ_o (256, in cos θ_o) and φ_o (128) of ``D V cos θ_o``, at most 1."""
    n = TABLE_SIZE
    mu = np.linspace(0.0, 1.0, n)
    mu[0] = 1e-3  # the view at the horizon: its limit
    r = np.linspace(0.0, 1.0, n)
    ct = (np.arange(256) + 0.5) / 256  # cos θ_o, uniform: dω = d(cos θ) dφ
    phi = (np.arange(128) + 0.5) / 128 * 2.0 * np.pi
    st = np.sqrt(1.0 - ct * ct)
    lx = st[:, None] * np.cos(phi)[None, :]
    lz = np.broadcast_to(ct[:, None], lx.shape)
    out = np.zeros((n, n))
    for i, m in enumerate(mu):
        vx, vz = np.sqrt(1.0 - m * m), m
        hx, hz = lx + vx, lz + vz
        hy = st[:, None] * np.sin(phi)[None, :]
        nh = hz / np.sqrt(hx * hx + hy * hy + hz * hz)
        for j, rr in enumerate(r):
            value = sheen_lobe(m, lz, nh, rr) * lz
            out[i, j] = value.sum() * (1.0 / 256) * (2.0 * np.pi / 128)
    # At grazing views the model's albedo passes 1 (Ashikhmin's visibility is not energy-conserving
    # there); the albedo scaling of the layer below cannot go under 0, so the table stops at 1.
    return np.minimum(out, 1.0).astype(np.float32)


@functools.lru_cache(maxsize=1)
def under_scale_table() -> np.ndarray:
    """M(μ, r) on the grid of :func:`albedo_table`: the cosine-weighted mean over the light's directions of
    ``max(E(μ, r), E(n·l, r))``, so that a Lambertian layer under a sheen of colour c lit by uniform light
    keeps ``1 − max(c) M`` of it (the mean of :func:`sheened`'s scale), float32. The rasterizer's lobes
    that integrate whole hemispheres (environment, area lights) scale the layers below by it."""
    n = TABLE_SIZE
    table = albedo_table().astype(np.float64)
    mu = np.linspace(0.0, 1.0, n)
    mu_l = (np.arange(256) + 0.5) / 256
    weight = 2.0 * mu_l / 256  # cosine-weighted: ∫ 2 μ dμ = 1
    out = np.zeros((n, n))
    for j in range(n):
        e_l = np.interp(mu_l, mu, table[:, j])
        out[:, j] = (np.maximum(table[:, j][:, None], e_l[None, :]) * weight).sum(1)
    return out.astype(np.float32)


def sheen_tables() -> np.ndarray:
    """(E, M) per grid point, (n, n, 2) float32 C-contiguous: the rasterizer's two-channel table."""
    return np.ascontiguousarray(np.stack([albedo_table(), under_scale_table()], axis=-1), dtype=np.float32)


def albedo(n_dot_v, roughness):
    """E(μ, r), bilinear in :func:`albedo_table` (the plugin's texture lookup)."""
    n = TABLE_SIZE
    table = albedo_table().astype(np.float64)
    x = np.clip(np.asarray(n_dot_v, dtype=np.float64), 0.0, 1.0) * (n - 1)
    y = np.clip(np.asarray(roughness, dtype=np.float64), 0.0, 1.0) * (n - 1)
    i0 = np.minimum(np.floor(x).astype(int), n - 2)
    j0 = np.minimum(np.floor(y).astype(int), n - 2)
    fx, fy = x - i0, y - j0
    return ((1 - fx) * (1 - fy) * table[i0, j0] + fx * (1 - fy) * table[i0 + 1, j0]
            + (1 - fx) * fy * table[i0, j0 + 1] + fx * fy * table[i0 + 1, j0 + 1])


def sheened(base_value, n_dot_v, n_dot_l, n_dot_h, color, roughness):
    """The sheened material's value (N, 3) from the base's ``base_value`` at the same directions."""
    color = np.asarray(color, dtype=np.float64)
    peak = float(np.max(color))
    scale = np.minimum(1.0 - peak * albedo(n_dot_v, roughness), 1.0 - peak * albedo(n_dot_l, roughness))
    lobe = sheen_lobe(n_dot_v, n_dot_l, n_dot_h, roughness)
    return np.asarray(base_value, dtype=np.float64) * scale[..., None] + color * lobe[..., None]
