"""The one direction ↔ (u, v) mapping of equirectangular environment maps (Mitsuba's ``envmap``), its
rotation about +Y, and bilinear lookups. Every renderer's environment goes through it."""

from __future__ import annotations

import math
import numpy as np

__all__ = ["direction_to_uv", "equirect_directions", "rotation_matrix", "sample_equirect", "uv_to_direction",
           "world_to_env"]


def direction_to_uv(d) -> np.ndarray:
    """Equirectangular (u, v) in [0, 1)×[0, 1] of unit directions ``d`` (..., 3) in the map's frame."""
    d = np.asarray(d, dtype=np.float64)
    u = np.arctan2(d[..., 0], -d[..., 2]) / (2.0 * np.pi)
    u = u - np.floor(u)
    v = np.arccos(np.clip(d[..., 1], -1.0, 1.0)) / np.pi
    return np.stack([u, v], axis=-1)


def uv_to_direction(u, v) -> np.ndarray:
    """Unit directions (..., 3) of equirectangular coordinates; the inverse of :func:`direction_to_uv`."""
    phi = 2.0 * np.pi * np.asarray(u, dtype=np.float64)
    theta = np.pi * np.asarray(v, dtype=np.float64)
    s = np.sin(theta)
    return np.stack([np.sin(phi) * s, np.cos(theta), -np.cos(phi) * s], axis=-1)


def rotation_matrix(degrees: float) -> np.ndarray:
    """3×3 map-to-world rotation about +Y by ``degrees`` (Mitsuba's ``rotate(axis=[0, 1, 0], angle)``)."""
    a = math.radians(float(degrees))
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def world_to_env(d, rotation: float = 0.0) -> np.ndarray:
    """World directions (..., 3) in the map's frame (``R⁻¹ d`` for the environment's rotation)."""
    d = np.asarray(d, dtype=np.float64)
    return d @ rotation_matrix(rotation)  # row vectors: d R = (R^T d^T)^T = R^-1 d


def equirect_directions(width: int, height: int) -> np.ndarray:
    """Directions (H, W, 3) of the texel positions (Mitsuba's: u = (i+½)/W, v = j/(H−1))."""
    u = (np.arange(width) + 0.5) / width
    v = np.arange(height) / max(height - 1, 1)
    uu, vv = np.meshgrid(u, v)
    return uv_to_direction(uu, vv)


def sample_equirect(image: np.ndarray, d, rotation: float = 0.0) -> np.ndarray:
    """Radiance of an equirectangular map towards world directions ``d`` (..., 3), bilinear, float64.

    The interpolation is Mitsuba's ``envmap.eval``: columns at (i + ½)/W wrapping
    around, rows at j/(H − 1) with the first and last row on the poles.
    """
    img = np.asarray(image)
    h, w = img.shape[:2]
    uv = direction_to_uv(world_to_env(d, rotation))
    x = uv[..., 0] * w - 0.5
    x = np.mod(x, w)
    y = uv[..., 1] * (h - 1)
    x0 = np.minimum(np.floor(x).astype(np.int64), w - 1)
    y0 = np.clip(np.floor(y).astype(np.int64), 0, h - 2)
    fx = (x - x0)[..., None]
    fy = (y - y0)[..., None]
    x1 = (x0 + 1) % w
    y1 = y0 + 1
    f = img.astype(np.float64, copy=False)
    top = f[y0, x0] * (1 - fx) + f[y0, x1] * fx
    bottom = f[y1, x0] * (1 - fx) + f[y1, x1] * fx
    return top * (1 - fy) + bottom * fy
