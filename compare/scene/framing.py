"""A camera for a model that brings none: an orbit about a target, and framing of bounds.

The convention is the one of the web's render-fidelity tools (model-viewer's
``camera-orbit``, three.js's ``Spherical``): ``theta`` turns about +Y from +Z towards +X,
``phi`` is measured down from +Y (0 looks straight down, 90 from the side), both in degrees;
the camera sits at ``target + radius · (sin φ sin θ, cos φ, sin φ cos θ)`` and looks at the
target with +Y up. ``radius = "auto"`` is the distance at which the bounding sphere of the
framed bounds, centred on the target, just fits the narrower of the two fields of view.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["DEFAULT_ORBIT", "bounds_center", "fit_radius", "orbit_position"]

#: theta, phi (degrees) of a camera without its own: model-viewer's default view, a little from above.
DEFAULT_ORBIT = (0.0, 75.0)


def orbit_position(target, theta: float, phi: float, radius: float) -> np.ndarray:
    """The camera position of an orbit (degrees, metres) about ``target``."""
    t, p = math.radians(theta), math.radians(phi)
    offset = np.array([math.sin(p) * math.sin(t), math.cos(p), math.sin(p) * math.cos(t)])
    return np.asarray(target, dtype=np.float64) + radius * offset


def bounds_center(lo, hi) -> np.ndarray:
    """The centre of the axis-aligned bounds (lo, hi)."""
    return (np.asarray(lo, dtype=np.float64) + np.asarray(hi, dtype=np.float64)) / 2.0


def fit_radius(lo, hi, target, fov: float, aspect: float) -> float:
    """The orbit radius at which the bounds (lo, hi), seen from any direction about ``target``, fill the
    view: their bounding sphere about the target touches the narrower field of view (``fov`` vertical, in
    degrees; ``aspect`` width / height)."""
    lo, hi, target = (np.asarray(v, dtype=np.float64) for v in (lo, hi, target))
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    sphere = float(np.linalg.norm(corners - target, axis=1).max())
    half_v = math.radians(fov) / 2.0
    half = min(half_v, math.atan(aspect * math.tan(half_v)))
    return max(sphere, 1e-9) / math.sin(half)
