"""Diffuse irradiance of an environment: 9 spherical-harmonic coefficients or a convolved cube map.

Both give the irradiance ``E(n) = ∫ L(ω) max(0, n·ω) dω`` (W·m⁻² for radiance
in W·sr⁻¹·m⁻²); a Lambert surface of albedo c reflects ``c · E / π``.

SH9 (Ramamoorthi & Hanrahan 2001)
    The radiance is projected onto the real spherical harmonics of bands 0–2,
    ``L_lm = Σ_texels L(ω) Y_lm(ω) Ω_texel`` over the cube's texels with their
    exact solid angles, and the clamped-cosine convolution multiplies band l
    by ``Â_0 = π``, ``Â_1 = 2π/3``, ``Â_2 = π/4``:
    ``E(n) = Σ_lm Â_l L_lm Y_lm(n)``. Exact for radiance that is a quadratic
    polynomial of the direction; for a small bright source (a sun) the
    truncation rings (the paper's "~3 % average error" holds only for smooth
    environments; see :mod:`compare.bench.ibl_accuracy`).
Convolved cube
    ``E(n)`` evaluated at every texel direction of a small padded cube
    (default 16×16 faces) by a sum over every texel of a source level of at
    most 32×32 faces: exact up to the source's resolution.

The basis, in world axes (x, y, z)::

    Y00 = 0.282095
    Y1-1 = 0.488603 y   Y10 = 0.488603 z   Y11 = 0.488603 x
    Y2-2 = 1.092548 xy  Y2-1 = 1.092548 yz Y20 = 0.315392 (3z² − 1)
    Y21 = 1.092548 xz   Y22 = 0.546274 (x² − y²)

The GLSL (``compare/ibl/ibl.glsl``, ``env_sh9_irradiance``) receives the
coefficients already multiplied by Â_l.
"""

from __future__ import annotations

import numpy as np

from compare.ibl.cubemap import padded_directions, texel_solid_angles

__all__ = ["SH_BAND_FACTORS", "convolve_irradiance", "sh9_basis", "sh9_irradiance", "sh9_project"]

#: Â_l of each of the 9 coefficients (clamped-cosine convolution).
SH_BAND_FACTORS = np.array([np.pi] + [2 * np.pi / 3] * 3 + [np.pi / 4] * 5)


def sh9_basis(d) -> np.ndarray:
    """The 9 real SH basis functions at unit directions (..., 3) → (..., 9)."""
    d = np.asarray(d, dtype=np.float64)
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return np.stack([
        np.full_like(x, 0.282095),
        0.488603 * y, 0.488603 * z, 0.488603 * x,
        1.092548 * x * y, 1.092548 * y * z, 0.315392 * (3 * z * z - 1), 1.092548 * x * z,
        0.546274 * (x * x - y * y),
    ], axis=-1)


def _interior(padded: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Interior radiance (N, C), directions (N, 3), solid angles (N,) of a padded cube level."""
    size = padded.shape[1] - 2
    radiance = padded[:, 1:-1, 1:-1].reshape(-1, padded.shape[-1])
    d = padded_directions(size, padded=False).reshape(-1, 3)
    omega = np.broadcast_to(texel_solid_angles(size), (6, size, size)).reshape(-1)
    return radiance, d, omega


def sh9_project(padded_level: np.ndarray) -> np.ndarray:
    """Radiance SH coefficients (9, C) of a padded cube level (6, S+2, S+2, C)."""
    radiance, d, omega = _interior(padded_level)
    return sh9_basis(d).T @ (radiance * omega[:, None])


def sh9_irradiance(coeffs: np.ndarray, n) -> np.ndarray:
    """Irradiance (..., C) at unit normals (..., 3) from radiance coefficients (9, C)."""
    return sh9_basis(n) @ (SH_BAND_FACTORS[:, None] * np.asarray(coeffs, dtype=np.float64))


def irradiance_at(padded_level: np.ndarray, n) -> np.ndarray:
    """Exact-up-to-resolution irradiance (..., C) at unit normals (..., 3) from a padded source level."""
    radiance, d, omega = _interior(padded_level)
    weighted = radiance * omega[:, None]
    n = np.asarray(n, dtype=np.float64)
    flat = n.reshape(-1, 3)
    out = np.empty((len(flat), radiance.shape[-1]))
    step = max(1, (1 << 22) // len(d))
    for start in range(0, len(flat), step):
        cos = np.maximum(flat[start:start + step] @ d.T, 0.0)
        out[start:start + step] = cos @ weighted
    return out.reshape(n.shape[:-1] + (radiance.shape[-1],))


def convolve_irradiance(chain: list[np.ndarray], size: int = 16, *, max_source: int = 32) -> np.ndarray:
    """Padded irradiance cube (6, size+2, size+2, C) from a padded source chain.

    The source is the largest level of ``chain`` with faces of at most ``max_source``.
    """
    source = next(level for level in chain if level.shape[1] - 2 <= max_source)
    return irradiance_at(source, padded_directions(size))
