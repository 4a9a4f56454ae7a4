"""Input checks shared by image I/O, tone mapping and metrics.

One NaN in a rendered image silently poisons every mean computed from it (MSE,
SSIM, FLIP all return NaN or, worse, a plausible number after clipping), and a
shape mismatch that broadcasts can give a metric without an error. These checks
run first in every public function that consumes an image, so the failure names
the image and the first bad pixel instead of surfacing later as a strange
number in a report. They live here, not in :mod:`compare.metrics.images`, because
:mod:`compare.image.tonemap` and :mod:`compare.image.exr` need them too and metrics imports
tonemap.
"""

from __future__ import annotations

import numpy as np

from compare.util.errors import ImageError

__all__ = ["check_finite", "check_pair", "check_rgb"]


def _location(index: tuple[int, ...]) -> str:
    # Name the axes the way a person looking at an image thinks of them.
    names = ("row", "col", "channel")
    if len(index) == len(names):
        return "(" + ", ".join(f"{n} {i}" for n, i in zip(names, index)) + ")"
    return "index " + str(tuple(int(i) for i in index))


def check_finite(image: np.ndarray, name: str = "image") -> None:
    """Raise if ``image`` holds NaN or Inf.

    Parameters
    ----------
    image : array_like
        A real-valued array, usually (H, W, 3).
    name : str, optional
        What to call the image in the message (``"reference"``, a file name).

    Raises
    ------
    ImageError
        If the array is not real-valued, or if any value is NaN or ±Inf. The
        message gives the count of non-finite values (split into NaN and Inf)
        and the location of the first one in C order, as
        ``(row r, col c, channel k)`` for an (H, W, 3) image.
    """
    a = np.asarray(image)
    if a.dtype == np.bool_ or not np.issubdtype(a.dtype, np.number) or np.iscomplexobj(a):
        raise ImageError(f"{name}: expected a real-valued numeric array, got dtype {a.dtype}")
    if not np.issubdtype(a.dtype, np.floating):
        return  # integers cannot hold NaN/Inf
    bad = ~np.isfinite(a)
    count = int(np.count_nonzero(bad))
    if count == 0:
        return
    n_nan = int(np.count_nonzero(np.isnan(a)))
    # argmax of a boolean array is the first True in C order: the first bad
    # value a person scanning rows would meet.
    first = tuple(int(i) for i in np.unravel_index(int(np.argmax(bad)), a.shape))
    raise ImageError(
        f"{name}: {count} non-finite value(s) ({n_nan} NaN, {count - n_nan} Inf) "
        f"out of {a.size}; first at {_location(first)} = {float(a[first])}. "
        "Fix the renderer output (or clamp it explicitly) before comparing or saving."
    )


def check_rgb(image: np.ndarray, name: str = "image") -> np.ndarray:
    """Check that ``image`` is a non-empty (H, W, 3) real array and return it as ndarray.

    Parameters
    ----------
    image : array_like
        The candidate image.
    name : str, optional
        What to call the image in the message.

    Returns
    -------
    numpy.ndarray
        ``np.asarray(image)`` (no copy when already an array).

    Raises
    ------
    ImageError
        If the shape is not (H, W, 3) with H, W >= 1, or the dtype is not real numeric.
    """
    a = np.asarray(image)
    if a.ndim != 3 or a.shape[2] != 3 or a.shape[0] < 1 or a.shape[1] < 1:
        raise ImageError(
            f"{name}: expected an (H, W, 3) linear RGB image, got shape {a.shape}; "
            "add a channel axis with np.repeat(img[..., None], 3, axis=2) for grey images"
        )
    if a.dtype == np.bool_ or not np.issubdtype(a.dtype, np.number) or np.iscomplexobj(a):
        raise ImageError(f"{name}: expected a real-valued numeric array, got dtype {a.dtype}")
    return a


def check_pair(
    ref: np.ndarray,
    test: np.ndarray,
    *,
    names: tuple[str, str] = ("reference", "test"),
) -> None:
    """Raise if two images do not have the same shape.

    Parameters
    ----------
    ref, test : array_like
        The two images to be compared.
    names : tuple of str, optional
        What to call them in the message.

    Raises
    ------
    ImageError
        If the shapes differ; the message gives both shapes, because NumPy
        broadcasting would otherwise turn e.g. (H, W, 1) vs (H, W, 3) into a
        silently wrong metric.
    """
    rs, ts = np.shape(ref), np.shape(test)
    if rs != ts:
        raise ImageError(
            f"shape mismatch: {names[0]} has shape {rs} but {names[1]} has shape {ts}; "
            "render both at the same resolution"
        )
