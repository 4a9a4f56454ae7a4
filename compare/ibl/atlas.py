"""2D texture atlases of the prefiltered chain, as the rasterizer uploads them.

GL 3.3 (and moderngl) cannot write the mip levels of a cube texture one by
one, and WebGL-style renderers often store environments in 2D textures anyway,
so every level of the chain goes into one 2D atlas with its 1-texel border:

``cube`` (formats ``float`` and ``rgbm``)
    level i: a row of six padded faces (+X, −X, +Y, −Y, +Z, −Z), each
    (S_i + 2)² texels; rows of levels stacked downwards (array row = GL t).
``octahedral``
    level i: one padded octahedral square of (O_i + 2)² texels, O_i = 2·S_i
    (4 S_i² texels against the cube's 6 S_i²), stacked downwards.

``levels`` holds, per level, the tile origin (x, y) and interior size in
texels: the GLSL reads face f of level i at atlas texel
``origin + (f·(size + 2), 0) + (s, t)·size + 1`` (s, t in [0, 1] face
coordinates), bilinear through the hardware, and blends two levels. The
numpy functions here do the same lookups, for tests and the accuracy table.

RGBM (the WebGL Insights variant: sqrt, range 7, maximum 49) stores the atlas
as RGBA8; the hardware filters the *encoded* texels, as a WebGL renderer does,
which is part of the error it costs (and values above 49, a sun, are clipped).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from compare.image.encodings import RGBM_SQRT7, octahedral_encode, rgbm_decode, rgbm_encode
from compare.ibl.cubemap import sample_faces

__all__ = ["ENV_FORMATS", "Atlas", "build_atlas", "sample_levels", "sample_octahedral"]

#: How the rasterizer stores the prefiltered environment.
ENV_FORMATS = ("float", "rgbm", "octahedral")


@dataclass
class Atlas:
    """One 2D texture holding every level."""

    data: np.ndarray
    """(H, W, 3) float32, or (H, W, 4) uint8 for RGBM."""
    levels: np.ndarray
    """(L, 3) float32: tile origin x, origin y, interior size of each level."""
    projection: str
    """``"cube"`` or ``"octahedral"``."""
    encoding: str
    """``"float"`` or ``"rgbm"``."""


def build_atlas(cube_levels: list[np.ndarray] | None, *, octahedral_levels: list[np.ndarray] | None = None,
                env_format: str = "float") -> Atlas:
    """Lay padded cube levels (6, S+2, S+2, 3) — or padded octahedral levels — into one atlas."""
    if env_format not in ENV_FORMATS:
        raise ValueError(f"env_format: expected one of {', '.join(map(repr, ENV_FORMATS))}, got {env_format!r}")
    if env_format == "octahedral":
        if octahedral_levels is None:
            raise ValueError("env_format='octahedral' needs the octahedral levels (preprocess(..., octahedral=True))")
        width = octahedral_levels[0].shape[1]
        height = sum(level.shape[0] for level in octahedral_levels)
        data = np.zeros((height, width, 3), dtype=np.float32)
        levels = []
        y = 0
        for level in octahedral_levels:
            p = level.shape[0]
            data[y:y + p, :p] = level
            levels.append((0.0, float(y), float(p - 2)))
            y += p
        return Atlas(data, np.asarray(levels, dtype=np.float32), "octahedral", "float")
    assert cube_levels is not None
    p0 = cube_levels[0].shape[1]
    width = 6 * p0
    height = sum(level.shape[1] for level in cube_levels)
    data = np.zeros((height, width, 3), dtype=np.float32)
    levels = []
    y = 0
    for level in cube_levels:
        p = level.shape[1]
        for f in range(6):
            data[y:y + p, f * p:(f + 1) * p] = level[f]
        levels.append((0.0, float(y), float(p - 2)))
        y += p
    if env_format == "rgbm":
        return Atlas(rgbm_encode(data, **RGBM_SQRT7), np.asarray(levels, dtype=np.float32), "cube", "rgbm")
    return Atlas(data, np.asarray(levels, dtype=np.float32), "cube", "float")


def sample_octahedral(level: np.ndarray, d) -> np.ndarray:
    """Bilinear lookup in one padded octahedral level (O+2, O+2, C) towards directions (..., 3)."""
    size = level.shape[0] - 2
    uv = octahedral_encode(d)
    x = np.clip(uv[..., 0] * size + 0.5, 0.0, size + 1.0)
    y = np.clip(uv[..., 1] * size + 0.5, 0.0, size + 1.0)
    x0 = np.minimum(np.floor(x).astype(np.int64), size)
    y0 = np.minimum(np.floor(y).astype(np.int64), size)
    fx = (x - x0)[..., None]
    fy = (y - y0)[..., None]
    top = level[y0, x0] * (1 - fx) + level[y0, x0 + 1] * fx
    bottom = level[y0 + 1, x0] * (1 - fx) + level[y0 + 1, x0 + 1] * fx
    return top * (1 - fy) + bottom * fy


def sample_levels(levels: list[np.ndarray], d, lod, *, projection: str = "cube", rgbm: bool = False) -> np.ndarray:
    """The shader's lookup in numpy: two levels around ``lod`` (scalar), blended linearly.

    ``rgbm`` filters RGBM-encoded texels and decodes after filtering, as the hardware path does.
    """
    lod = float(np.clip(lod, 0.0, len(levels) - 1))
    lo = int(np.floor(lod))
    hi = min(lo + 1, len(levels) - 1)
    f = lod - lo

    def one(level):
        if rgbm:
            enc = rgbm_encode(level, **RGBM_SQRT7).astype(np.float64) / 255.0
            filt = sample_faces(enc, d) if projection == "cube" else sample_octahedral(enc, d)
            return rgbm_decode(filt, **RGBM_SQRT7)
        return sample_faces(level, d) if projection == "cube" else sample_octahedral(level, d)

    out = one(levels[lo]) * (1.0 - f)
    if f > 0:
        out += one(levels[hi]) * f
    return out

