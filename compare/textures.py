"""Texture files a scene names, checked when it is loaded (not when a renderer first reads them).

A texture holds reflectances or roughness/metal factors: every value must be a finite number
at least 0. PNG and JPEG are read with Pillow (a matplotlib dependency), EXR with
:func:`compare.exr.read_exr`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["texture_problem"]


def texture_problem(path: Path) -> str | None:
    """What is wrong with the texture file ``path`` (one sentence), or None if it is usable."""
    from .errors import ImageError

    if path.suffix.lower() == ".exr":
        from .exr import read_exr

        try:
            image, _ = read_exr(path)
        except ImageError as exc:
            return str(exc).replace(f"{path}: ", "", 1)
        bad = ~np.isfinite(image)
        if bad.any():
            r, c, _ = np.argwhere(bad)[0]
            return f"{int(bad.sum())} NaN or infinite value(s) (first at row {r}, col {c})"
        if float(image.min(initial=0.0)) < 0.0:
            r, c, _ = np.argwhere(image < 0)[0]
            return (f"{int((image < 0).sum())} negative value(s) (first at row {r}, col {c}: "
                    f"{float(image[r, c].min()):g}); texture values are reflectances and factors >= 0")
        return None
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as im:
            im.verify()  # the file's structure and checksums
        with Image.open(path) as im:
            im.load()  # and its pixels
    except (OSError, UnidentifiedImageError, SyntaxError, ValueError) as exc:
        return f"unreadable image ({exc})"
    return None
