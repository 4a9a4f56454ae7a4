"""Coverage-preserving alpha for the mip levels of an alpha-tested map (Castaño, "Computing Alpha
Mipmaps", 2010; what game engines call "mip maps preserve coverage").

Each level's alpha is the box average of level 0's (the average GL builds), scaled so that the
fraction of its texels at or above the cutoff is level 0's fraction. Written here because no
library this project depends on builds such mips; the scale is read from the level's distinct
alpha values (the one whose passing fraction is nearest level 0's), not found by bisection.
"""

from __future__ import annotations

import numpy as np

__all__ = ["box_levels", "coverage", "coverage_preserving_alpha"]


def box_levels(values: np.ndarray):
    """The mip levels 1, 2, ... of a (H, W) array as GL sizes them (each side halved, rounded down, at
    least 1): each texel the mean of the 2 x 2 (or 2 x 1) texels below it."""
    level = np.asarray(values, dtype=np.float64)
    while level.shape[0] > 1 or level.shape[1] > 1:
        h, w = max(level.shape[0] // 2, 1), max(level.shape[1] // 2, 1)
        fy, fx = level.shape[0] // h, level.shape[1] // w
        level = level[:h * fy, :w * fx].reshape(h, fy, w, fx).mean(axis=(1, 3))
        yield level


def coverage(alpha: np.ndarray, cutoff: float) -> float:
    """Fraction of texels whose alpha is at or above ``cutoff`` (glTF's test)."""
    return float(np.mean(np.asarray(alpha) >= cutoff))


def coverage_preserving_alpha(alpha: np.ndarray, cutoff: float) -> list[np.ndarray]:
    """Alpha of mip levels 1, 2, ... (float32, clipped to [0, 1]) whose coverage at ``cutoff`` is the
    closest a scale can bring it to level 0's (texels of equal alpha pass or fail together)."""
    target = coverage(alpha, cutoff)
    out = []
    for level in box_levels(alpha):
        values, counts = np.unique(level, return_counts=True)
        passing = np.cumsum(counts[::-1])[::-1] / level.size  # fraction at or above each value
        k = int(np.argmin(np.abs(passing - target)))
        if target == 0.0:
            scaled = np.minimum(level, cutoff * 0.5)  # nothing passes
        else:
            # the cutoff halfway between the last value that must pass and the first that must not, so that
            # rounding to the texture's half floats cannot move a texel across it
            below = values[k - 1] if k > 0 else 0.0
            edge = 0.5 * (values[k] + below)
            scaled = level * (cutoff / edge) if edge > 0 else np.where(level > 0, 1.0, 0.0)
        out.append(np.clip(scaled, 0.0, 1.0).astype(np.float32))
    return out
