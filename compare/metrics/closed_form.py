"""Closed-form answers that renderers are checked against.

Irradiance from a uniformly emitting polygon at a point follows exactly from
Lambert's formula (Lambert 1760; in graphics: Arvo, "Applications of irradiance
tensors to the simulation of non-Lambertian phenomena", SIGGRAPH 1995, eq. 9):

    E(x) = L / 2 · Σ_k Θ_k · (n · γ_k)

with Θ_k the angle subtended at x by edge k, and γ_k the unit normal of the plane
through x and that edge. It holds as long as the whole polygon lies above the
surface's horizon, which callers must ensure.
"""

from __future__ import annotations

import numpy as np


def polygon_irradiance(points: np.ndarray, normals: np.ndarray, polygon: np.ndarray,
                       radiance: float | np.ndarray = 1.0) -> np.ndarray:
    """Irradiance at ``points`` (…, 3) with ``normals`` from a Lambertian polygon (K, 3) of ``radiance``.

    The polygon's emitting side does not matter here (the caller decides whether
    the point sees the front); the result is ≥ 0 for a polygon above the horizon.
    Returns shape (…) for scalar radiance, (…, C) for a radiance vector of C channels.
    """
    x = np.asarray(points, dtype=np.float64)[..., None, :]
    n = np.asarray(normals, dtype=np.float64)
    r = np.asarray(polygon, dtype=np.float64) - x  # (…, K, 3)
    r /= np.linalg.norm(r, axis=-1, keepdims=True)
    r_next = np.roll(r, -1, axis=-2)
    cross = np.cross(r, r_next)
    length = np.linalg.norm(cross, axis=-1)
    theta = np.arctan2(length, np.sum(r * r_next, axis=-1))
    gamma = cross / np.maximum(length, 1e-300)[..., None]
    e = 0.5 * np.abs(np.sum(theta * np.sum(gamma * n[..., None, :], axis=-1), axis=-1))
    rad = np.asarray(radiance, dtype=np.float64)
    return e * rad if rad.ndim == 0 else e[..., None] * rad

