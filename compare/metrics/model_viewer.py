"""model-viewer's render-fidelity number: the RMS of pixelmatch's YIQ colour distance, in dB.

google/model-viewer's fidelity page compares each renderer's 8-bit screenshot (after that engine's
own tone mapping) with a golden and publishes one number per renderer and scenario. This module
computes the same number from two 8-bit images; :func:`compare.metrics.images.mv_rms_db` and
:func:`compare.metrics.images.compare_images` feed it the suite's tone-mapped images.

What model-viewer computes (paths in google/model-viewer, commit 3e898294c7fe):

* ``packages/render-fidelity-tools/src/third_party/pixelmatch/color-delta.ts`` (commit a22919dc96ee),
  ``colorDelta``, lines 12–51: each pixel's RGB is first blended with white by its alpha,
  ``c' = 255 + (c − 255)·a/255`` (``blend``, lines 49–51), then converted to YIQ
  (``rgb2y``/``rgb2i``/``rgb2q``, lines 38–46)::

      Y = 0.29889531 R + 0.58662247 G + 0.11448223 B
      I = 0.59597799 R − 0.27417610 G − 0.32180189 B
      Q = 0.21147017 R − 0.52261711 G + 0.31114694 B

  and the distance is ``δ = 0.5053 ΔY² + 0.299 ΔI² + 0.1957 ΔQ²`` (line 35). It is a *squared*
  distance (Kotsarenko & Ramos' weights), the same as mapbox/pixelmatch ``index.js`` v5.3.0
  (commit 910cd5db90d1), ``colorDelta`` lines 172–212, weights on line 208, which only adds a sign.
  Its maximum over 8-bit pairs is 35215 (``MAX_COLOR_DISTANCE``, ``common.ts`` line 25; pixelmatch
  ``index.js`` lines 44–45), reached by red against cyan; black against white gives
  0.5053 · 255² ≈ 32857 (I and Q do not change along the grey axis).
* ``packages/render-fidelity-tools/src/common.ts``, ``ImageComparator.analyze``, lines 228–290:
  over the candidate's pixels with alpha ≠ 0 (lines 251, 269–271: "the model's pixels"),
  ``squareSum += δ²`` (line 276), then (lines 287–288)::

      rmsDistanceRatio = sqrt(squareSum / modelPixelCount) / 35215

  and the published figure is ``toDecibel(rmsDistanceRatio) = 10 · log10(rmsDistanceRatio)``
  (lines 293–295; printed by ``artifact-creator.ts`` ``analyze``). Lower is better: 0 dB is the
  largest possible error everywhere, and model-viewer's own regression test fails a scenario above
  ``FIDELITY_TEST_THRESHOLD`` = −22 dB (``common.ts`` line 31). ``analyze`` refuses a candidate
  whose every pixel is pure black or pure white ("colorless", lines 253–267 and 283–285).

In short, for the model's pixels P::

    mv_rms_db = 10 · log10( sqrt( mean_P δ² ) / 35215 )

Where the suite differs, and why:

* The model's pixels: the suite's images have no alpha, so every pixel counts, exactly what ``analyze``
  does for an opaque candidate (model-viewer's ``renderSkybox: true``). Under a hidden background
  (``renderSkybox: false``, the scene's ``background = false``) the background is black in both images
  and counts with δ = 0, where ``analyze`` leaves the candidate's transparent pixels out. A caller with
  coverage can pass ``mask``; an (H, W, 4) candidate's alpha ≠ 0 is used as in model-viewer otherwise.
* Identical images: ``log10(0)`` is −∞ in model-viewer (``null`` in its JSON); here the value is
  floored at :data:`MV_DB_FLOOR` (−100 dB), below every non-identical pair of up to 2.5·10⁸ pixels
  (the smallest nonzero δ, one 8-bit step of blue in one pixel, is 0.0565), so the order of scores
  is kept and the JSON stays finite.
* A colorless candidate is not refused here: against a ground truth that is not degenerate it is a
  real, large error and scores as one. A ground truth that tone-maps to a constant (black, saturated
  or flat) has no score at all (``None``, :data:`compare.metrics.images.LDR_DEGENERATE_RANGE`),
  as for the other LDR metrics: otherwise a black test image against a black ground truth would
  score as perfect.
"""

from __future__ import annotations

import math

import numpy as np

from compare.image.checks import check_finite
from compare.util.errors import ImageError

__all__ = [
    "FIDELITY_TEST_THRESHOLD_DB",
    "MAX_YIQ_DELTA",
    "MV_DB_FLOOR",
    "decibel",
    "quantize_8bit",
    "rms_distance_ratio",
    "rms_db_ldr",
    "yiq_delta",
]

#: The largest δ of :func:`yiq_delta` between two 8-bit colours (model-viewer's ``MAX_COLOR_DISTANCE``).
MAX_YIQ_DELTA = 35215.0
#: model-viewer's regression bound: a scenario above it fails (``FIDELITY_TEST_THRESHOLD``).
FIDELITY_TEST_THRESHOLD_DB = -22.0
#: The value of identical 8-bit images (model-viewer: −∞), below every non-identical pair of up to
#: 2.5·10⁸ pixels.
MV_DB_FLOOR = -100.0

# pixelmatch's RGB → YIQ rows and the weights of the squared distance (color-delta.ts lines 35–46).
_YIQ = np.array([[0.29889531, 0.58662247, 0.11448223],
                 [0.59597799, -0.27417610, -0.32180189],
                 [0.21147017, -0.52261711, 0.31114694]])
_WEIGHTS = np.array([0.5053, 0.299, 0.1957])


def _pixels_8bit(a, what: str) -> np.ndarray:
    x = np.asarray(a)
    if x.ndim < 1 or x.shape[-1] not in (3, 4):
        raise ImageError(f"{what}: expected RGB or RGBA on the last axis, got shape {x.shape}")
    check_finite(x, what)
    x = x.astype(np.float64)
    if x.size and (x.min() < 0.0 or x.max() > 255.0):
        raise ImageError(f"{what}: expected 8-bit values in [0, 255], got [{x.min():g}, {x.max():g}]")
    return x


def _blend_white(x: np.ndarray) -> np.ndarray:
    if x.shape[-1] == 3:
        return x
    # pixelmatch composites a translucent pixel over white before comparing.
    return 255.0 + (x[..., :3] - 255.0) * (x[..., 3:] / 255.0)


def yiq_delta(a, b) -> np.ndarray:
    """pixelmatch's squared YIQ colour distance δ per pixel, as model-viewer's ``colorDelta`` computes it.

    Parameters
    ----------
    a, b : array_like, shape (..., 3) or (..., 4)
        8-bit colour values in [0, 255] (integers or floats), RGB or RGBA; an alpha channel blends
        the colour with white first, ``255 + (c − 255)·alpha/255``.

    Returns
    -------
    numpy.ndarray
        float64, shape ``(...)``: ``0.5053 ΔY² + 0.299 ΔI² + 0.1957 ΔQ²``, from 0 (same colour) to
        :data:`MAX_YIQ_DELTA` (red against cyan). Unsigned, like model-viewer's copy of it.

    Raises
    ------
    ImageError
        On NaN/Inf, values outside [0, 255], no RGB(A) last axis, or shapes that differ.
    """
    x, y = _pixels_8bit(a, "yiq_delta a"), _pixels_8bit(b, "yiq_delta b")
    if x.shape[:-1] != y.shape[:-1]:
        raise ImageError(f"yiq_delta: shapes differ, {x.shape} and {y.shape}")
    d = (_blend_white(x) - _blend_white(y)) @ _YIQ.T
    return (d * d) @ _WEIGHTS


def rms_distance_ratio(candidate, golden, *, mask=None) -> float:
    """model-viewer's ``rmsDistanceRatio``: ``sqrt(mean δ²) / 35215`` over the model's pixels.

    Parameters
    ----------
    candidate, golden : array_like, shape (H, W, 3) or (H, W, 4)
        8-bit images in [0, 255]; the candidate is the image under test.
    mask : array_like of bool, shape (H, W), optional
        The model's pixels. Default: the candidate's alpha ≠ 0 for an RGBA candidate (model-viewer's
        rule), every pixel for an RGB one (an opaque screenshot).

    Returns
    -------
    float
        In [0, 1]; 0 for identical images.

    Raises
    ------
    ImageError
        On bad pixel values or shapes, a mask of another shape, or no model pixel at all (model-viewer
        would divide by zero).
    """
    c = _pixels_8bit(candidate, "candidate")
    if c.ndim != 3:
        raise ImageError(f"candidate: expected an (H, W, 3|4) image, got shape {c.shape}")
    delta = yiq_delta(c, golden)
    if mask is None:
        keep = c[..., 3] != 0 if c.shape[-1] == 4 else np.ones(delta.shape, dtype=bool)
    else:
        keep = np.asarray(mask, dtype=bool)
        if keep.shape != delta.shape:
            raise ImageError(f"mask: shape {keep.shape}, expected {delta.shape}")
    n = int(np.count_nonzero(keep))
    if n == 0:
        raise ImageError("rms_distance_ratio: no model pixels (the mask or the candidate's alpha is empty)")
    d = delta[keep]
    return math.sqrt(float(np.sum(d * d)) / n) / MAX_YIQ_DELTA


def decibel(ratio: float) -> float:
    """``10 · log10(ratio)`` (model-viewer's ``toDecibel``), floored at :data:`MV_DB_FLOOR` (ratio 0: identical)."""
    r = float(ratio)
    if not (math.isfinite(r) and r >= 0.0):
        raise ValueError(f"decibel: expected a finite ratio >= 0, got {ratio!r}")
    return MV_DB_FLOOR if r == 0.0 else max(MV_DB_FLOOR, 10.0 * math.log10(r))


def quantize_8bit(ldr) -> np.ndarray:
    """Display values in [0, 1] as the 8-bit levels of the run's PNG previews (float64 integers 0–255).

    The same rounding as :func:`compare.image.tonemap.write_png`: the 8-bit image model-viewer would
    read from a screenshot is the one the suite writes.
    """
    a = np.asarray(ldr, dtype=np.float32)
    check_finite(a, "quantize_8bit input")
    return np.round(np.clip(a, 0.0, 1.0) * 255.0).astype(np.float64)


def rms_db_ldr(ref_ldr, test_ldr, *, mask=None) -> float:
    """model-viewer's number for two display-encoded images in [0, 1]: quantized to 8 bits, the test
    image as candidate and the reference as golden, ``decibel(rms_distance_ratio(...))``."""
    return decibel(rms_distance_ratio(quantize_8bit(test_ldr), quantize_8bit(ref_ldr), mask=mask))
