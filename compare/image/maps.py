"""Scalar maps as colour-mapped PNG images (the report's and ``compare diff --maps``' error maps)."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from compare.image.checks import check_finite
from compare.util.errors import ImageError
from compare.util.files import atomic_path

__all__ = ["save_maps"]


def save_maps(
    directory: str | os.PathLike,
    maps: dict[str, np.ndarray],
    *,
    ranges: dict[str, tuple[float, float]] | None = None,
    prefix: str = "",
) -> dict[str, Path]:
    """Write scalar maps (e.g. error maps) as magma-coloured 8-bit PNGs, atomically.

    Parameters
    ----------
    directory : str or os.PathLike
        Output folder (created if needed). Each map goes to
        ``<directory>/<prefix><name>.png``.
    maps : dict of str to numpy.ndarray
        (H, W) finite maps, e.g. from :func:`compare.metrics.images.error_maps`.
    ranges : dict, optional
        ``name -> (low, high)`` mapped to the ends of the colour map; values
        outside are clipped (for error maps,
        :data:`compare.metrics.images.ERROR_MAP_RANGES`); for a name without one,
        ``(0, max)`` of that map.
    prefix : str, optional
        File name prefix, e.g. ``"rasterizer_"``.

    Returns
    -------
    dict of str to pathlib.Path
        The written file per map name.

    Raises
    ------
    ImageError
        If a map is not 2-D or holds NaN/Inf.
    ValueError
        For an empty range or a map name that is not a plain file name.
    """
    import imageio.v3 as iio  # deferred: only needed for writing
    import matplotlib  # colormaps only; pyplot (and a GUI backend) is not needed

    cmap = matplotlib.colormaps["magma"]
    rng = dict(ranges or {})
    directory = Path(directory)
    written: dict[str, Path] = {}
    for name, m in maps.items():
        fname = f"{prefix}{name}.png"
        if not name or Path(fname).name != fname or fname.startswith("."):
            raise ValueError(f"save_maps: map name {name!r} (with prefix {prefix!r}) is not a plain file name")
        a = np.asarray(m)
        if a.ndim != 2:
            raise ImageError(f"error map {name!r}: expected an (H, W) array, got shape {a.shape}")
        check_finite(a, f"error map {name!r}")
        a = a.astype(np.float64)
        lo, hi = rng.get(name, (0.0, float(a.max(initial=0.0)) or 1.0))
        if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
            raise ValueError(f"save_maps: range for {name!r} must be finite with high > low, got {(lo, hi)}")
        norm = np.clip((a - lo) / (hi - lo), 0.0, 1.0)
        rgb = np.round(cmap(norm)[..., :3] * 255.0).astype(np.uint8)
        path = directory / fname
        with atomic_path(path, suffix=".png") as tmp:
            iio.imwrite(tmp, rgb, extension=".png")
        written[name] = path
    return written
