"""Filament's image-based light made by the suite: what ``IndirectLight.Builder`` takes, without ``cmgen``.

Filament's own tool (``cmgen``, a native binary of its release archives, not on npm) prefilters an
environment into KTX files. The same two inputs are made here from the suite's map with the suite's own
preprocessing (:mod:`compare.ibl`):

* **reflections**: a cube texture with a full chain of mips from ``size`` down (``size >> l`` per level),
  level ``l`` GGX-prefiltered (:func:`compare.ibl.prefilter.prefilter`, n = v = r, pdf-based source levels)
  for the perceptual roughness Filament reads there. Filament's shader picks the level
  ``lod = (levels − 1) · r (2 − r)`` (``perceptualRoughnessToLod``, a fit to log2 roughness), so level
  ``l`` holds ``r = 1 − sqrt(1 − l / (levels − 1))`` (cmgen's ``lodToPerceptualRoughness``);
* **irradiance**: nine spherical-harmonic coefficients in Filament's convention: the radiance SH
  (:func:`compare.ibl.irradiance.sh9_project`) convolved with the clamped cosine (Â_l), times the basis'
  constants and the Lambertian 1/π, so that Filament's shader evaluates
  ``max(Σ_k sh_k · p_k(n), 0)`` with the bare polynomials ``p_k`` (1, y, z, x, xy, yz, 3z² − 1, xz, x² − y²)
  and multiplies the diffuse colour by it.

Directions are world directions: the map handed in is already turned by the scene's rotation
(:func:`compare.web.panorama.three_panorama`), so the light needs no rotation matrix. Faces are in the
OpenGL cube-map table of :mod:`compare.ibl.cubemap` (+X, −X, +Y, −Y, +Z, −Z; row 0 at t = −1).
"""

from __future__ import annotations

import numpy as np

from compare.ibl.cubemap import padded_directions
from compare.ibl.irradiance import SH_BAND_FACTORS, sh9_project
from compare.ibl.prefilter import prefilter, source_chain

__all__ = ["SH_POLYNOMIAL_CONSTANTS", "filament_ibl", "level_roughness", "sh_coefficients"]

#: The constants of the real SH basis in front of Filament's bare polynomials (compare.ibl.irradiance's
#: basis, in the same order).
SH_POLYNOMIAL_CONSTANTS = np.array([0.282095, 0.488603, 0.488603, 0.488603, 1.092548, 1.092548, 0.315392,
                                    1.092548, 0.546274])


def level_roughness(levels: int) -> np.ndarray:
    """The perceptual roughness each of ``levels`` mip levels holds for Filament's lookup (cmgen's)."""
    x = np.arange(levels) / max(levels - 1, 1)
    return 1.0 - np.sqrt(1.0 - x)


def sh_coefficients(radiance_sh: np.ndarray) -> np.ndarray:
    """Filament's nine irradiance coefficients (9, 3) of radiance SH coefficients (9, 3)."""
    return (SH_BAND_FACTORS * SH_POLYNOMIAL_CONSTANTS / np.pi)[:, None] * np.asarray(radiance_sh, np.float64)


def filament_ibl(equirect: np.ndarray, *, size: int = 128, samples: int = 256) -> tuple[list[np.ndarray], np.ndarray]:
    """The reflections chain (level l: (6, size >> l, size >> l, 3) float32, from ``size`` down to 8×8, the
    five levels of a 128 cube that Filament's lod fit was made for) and the SH (9, 3) float32 of a
    world-frame equirectangular map (the suite's mapping); ``samples`` GGX samples a texel."""
    if size < 8 or size & (size - 1):
        raise ValueError(f"size: expected a power of two of at least 8, got {size}")
    img = np.ascontiguousarray(equirect, dtype=np.float32)
    chain = source_chain(img, size)
    levels = int(np.log2(size)) - 2  # down to 8×8
    rough = level_roughness(levels)
    out = [chain[0][:, 1:-1, 1:-1].astype(np.float32)]
    for lvl in range(1, levels):
        s = size >> lvl
        out.append(prefilter(chain, padded_directions(s, padded=False), float(rough[lvl]), samples).astype(np.float32))
    sh = sh_coefficients(sh9_project(chain[0])).astype(np.float32)
    return out, sh
