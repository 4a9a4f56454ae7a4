"""The suite's environment map laid out for the web engines that look up an equirectangular panorama the
way three.js does (``u = atan2(z, x) / 2π + ½``, ``v`` from −Y at the bottom to +Y at the top): the
``<model-viewer>`` element and the Khronos glTF Sample Viewer read it as a Radiance HDR file and have no
rotation or intensity of the suite's kind, so both are baked into the pixels here."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["three_panorama"]


def three_panorama(image: np.ndarray, rotation_deg: float, intensity: float, min_width: int = 0) -> np.ndarray:
    """The suite's equirectangular map (Mitsuba's u, :mod:`compare.scene.equirect`) as three.js looks it up
    (its u is the suite's u + ¼) with the scene's rotation about +Y and intensity baked in: column i of the
    result is the map at u + rotation/360 − ¼, a whole-pixel roll where that shift is whole, else linear
    between the two nearest rolls. A map narrower than ``min_width`` is repeated pixel by pixel first (which
    leaves the radiance of every direction as it was)."""
    img = np.asarray(image, dtype=np.float64) * float(intensity)
    if img.shape[1] < min_width:
        k = -(-min_width // img.shape[1])
        img = np.repeat(np.repeat(img, k, axis=0), k, axis=1)
    w = img.shape[1]
    shift = (w * (float(rotation_deg) / 360.0 - 0.25)) % w
    lo = math.floor(shift)
    t = shift - lo
    out = np.roll(img, -lo, axis=1)
    if t > 1e-9:
        out = (1.0 - t) * out + t * np.roll(img, -(lo + 1), axis=1)
    return out.astype(np.float32)
