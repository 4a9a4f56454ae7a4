"""Read a float framebuffer back as a linear (H, W, 3) float32 image, in one place."""

from __future__ import annotations

import numpy as np

from compare.util.errors import ImageError


def read_rgb(ctx, fbo, *, check_finite: bool = True, what: str = "progressive render") -> np.ndarray:
    """``fbo``'s first colour attachment as (H, W, 3) float32, row 0 at the top.

    Waits for the GPU (``ctx.finish()``), reads RGBA float32 and flips the rows
    once (OpenGL's row 0 is the bottom). Raises :class:`ImageError` when a pixel
    is NaN or infinite (``check_finite``), which is a renderer bug.
    """
    ctx.finish()
    width, height = fbo.size
    data = fbo.read(components=4, dtype="f4", attachment=0)
    image = np.frombuffer(data, dtype=np.float32).reshape(height, width, 4)[::-1, :, :3]
    image = np.ascontiguousarray(image)
    if check_finite:
        bad = ~np.isfinite(image)
        if bad.any():
            rows, cols = np.nonzero(bad.any(axis=2))
            raise ImageError(f"{what}: {int(bad.any(axis=2).sum())} pixels are NaN or infinite "
                             f"(first at row {int(rows[0])}, column {int(cols[0])})")
    return image


def read_texture_rgb(ctx, texture, *, what: str = "progressive render") -> np.ndarray:
    """An RGBA32F texture's RGB as (H, W, 3) float32, row 0 at the top (see :func:`read_rgb`)."""
    return read_texture_rgba(ctx, texture, what=what)[..., :3].copy()


def read_texture_rgba(ctx, texture, *, what: str = "progressive render") -> np.ndarray:
    """An RGBA32F texture as (H, W, 4) float32, row 0 at the top; NaN or infinity is an error."""
    ctx.finish()
    width, height = texture.size
    data = texture.read()
    image = np.frombuffer(data, dtype=np.float32).reshape(height, width, 4)[::-1]
    image = np.ascontiguousarray(image)
    if not np.all(np.isfinite(image)):
        raise ImageError(f"{what}: {int((~np.isfinite(image)).any(axis=2).sum())} pixels are NaN or infinite")
    return image
