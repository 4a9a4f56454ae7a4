"""Exposure, tone mapping and display transfer: the one place where HDR becomes LDR.

Every renderer returns linear-radiance float32 images; every LDR image the suite
shows or measures (PNG previews, LDR-FLIP, SSIM, PSNR) goes through
:func:`to_ldr` here, so that a reference and a test image are always mapped by
the same curve and the same exposure. A metric difference can then only come
from the images, not from two slightly different tone mappers.

Conventions
-----------
* Inputs are linear Rec.709/sRGB-primaries RGB, any float dtype, shape (..., 3)
  for the luminance-based operators and any shape for the per-channel ones.
* Every operator first **clamps negatives to 0** (path tracers and denoisers can
  produce tiny negative values, and every curve below is defined on x >= 0),
  and clamps values above the float32 maximum (including +inf) to that maximum
  so that the rational curves, evaluated in float64, never overflow. NaN is not
  repaired: it propagates, and :func:`to_ldr` / :func:`write_png` refuse it up
  front with :class:`~compare.util.errors.ImageError`.
* Operators return float32. Most return *linear* display values that still need
  a transfer function (:func:`srgb_encode`); :func:`hejl_burgess_dawson` is the
  exception (its fit has the display gamma built in). :func:`to_ldr` knows which.
* Exposure is a plain linear multiplier applied before the operator. Use
  :func:`exposure_scale` to derive it from EV100 or physical camera settings.

References
----------
.. [1] S. Lagarde, C. de Rousiers, "Moving Frostbite to Physically Based
   Rendering 3.0", SIGGRAPH 2014 course notes, sec. 4.2 (exposure).
.. [2] E. Reinhard, M. Stark, P. Shirley, J. Ferwerda, "Photographic Tone
   Reproduction for Digital Images", SIGGRAPH 2002.
.. [3] J. Hable, "Filmic Tonemapping Operators", filmicworlds.com, 2010 (Hejl &
   Burgess-Dawson curve and the Uncharted 2 curve), and "Uncharted 2: HDR
   Lighting", GDC 2010.
.. [4] K. Narkowicz, "ACES Filmic Tone Mapping Curve", knarkowicz.wordpress.com,
   2016-01-06.
.. [5] S. Hill, ACES RRT+ODT fit, in M. Pettineo's BakingLab, ``ACES.hlsl``
   (github.com/TheRealMJP/BakingLab), 2016.
.. [6] IEC 61966-2-1:1999, sRGB transfer function.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Callable

import numpy as np

from compare.util.errors import ImageError
from compare.util.files import atomic_path
from compare.image.checks import check_finite, check_rgb

__all__ = [
    "LUMINANCE_WEIGHTS",
    "OPERATORS",
    "TRANSFERS",
    "aces",
    "aces_narkowicz",
    "ev100_from_camera",
    "exposure_from_ev",
    "exposure_scale",
    "gamma_encode",
    "hable",
    "hejl_burgess_dawson",
    "luminance",
    "reinhard",
    "reinhard_extended",
    "reinhard_luminance",
    "srgb_decode",
    "srgb_encode",
    "to_ldr",
    "write_png",
]

#: Rec.709 / sRGB-primaries luminance weights (the images are linear sRGB).
LUMINANCE_WEIGHTS = (0.2126, 0.7152, 0.0722)

_F32_MAX = float(np.finfo(np.float32).max)


# --------------------------------------------------------------------------- helpers


def _prep(x) -> np.ndarray:
    """float64 copy of ``x`` clamped to [0, float32 max]; NaN propagates.

    float64 because the rational curves below square their input: 1e30² is
    out of float32 range but fine in float64, and capping at the float32
    maximum keeps even float64 inputs such as 1e300 (or +inf) from
    overflowing. ``+ 0.0`` turns -0.0 into +0.0 so outputs never carry a
    negative sign.
    """
    return np.clip(np.asarray(x, dtype=np.float64), 0.0, _F32_MAX) + 0.0


def _out(y: np.ndarray) -> np.ndarray:
    # Cap before the cast: a float64 above the float32 maximum would become
    # inf with an "overflow in cast" warning (possible for reinhard_extended
    # with a tiny white point).
    return np.minimum(y, _F32_MAX).astype(np.float32)


def _rgb_last_axis(a: np.ndarray, func: str) -> None:
    if a.ndim < 1 or a.shape[-1] != 3:
        raise ValueError(f"{func}: expected RGB values on the last axis (shape (..., 3)), got shape {a.shape}")


def _positive_finite(value: float, name: str) -> float:
    v = float(value)
    if not math.isfinite(v) or v <= 0.0:
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return v


def luminance(rgb) -> np.ndarray:
    """Rec.709 relative luminance of linear RGB values.

    Parameters
    ----------
    rgb : array_like, shape (..., 3)
        Linear RGB.

    Returns
    -------
    numpy.ndarray
        float64 array of shape ``rgb.shape[:-1]``.
    """
    a = np.asarray(rgb, dtype=np.float64)
    _rgb_last_axis(a, "luminance")
    return a @ np.asarray(LUMINANCE_WEIGHTS)


# --------------------------------------------------------------------------- exposure


def ev100_from_camera(aperture: float, shutter_s: float, iso: float) -> float:
    """Exposure value at ISO 100 from physical camera settings.

    ``EV100 = log2(N² / t · 100 / S)`` for f-number ``N``, shutter time ``t``
    in seconds and sensitivity ``S`` [1]_.

    Parameters
    ----------
    aperture : float
        f-number N (e.g. 16 for f/16), > 0.
    shutter_s : float
        Shutter time t in seconds, > 0.
    iso : float
        Sensor sensitivity S (ISO), > 0.

    Returns
    -------
    float
        EV100. ``ev100_from_camera(1, 1, 100) == 0``; the "sunny 16" setting
        (f/16, 1/100 s, ISO 100) gives about 14.6.

    Raises
    ------
    ValueError
        If any argument is not a finite positive number.
    """
    n = _positive_finite(aperture, "aperture")
    t = _positive_finite(shutter_s, "shutter_s")
    s = _positive_finite(iso, "iso")
    return math.log2(n * n / t * 100.0 / s)


def exposure_from_ev(ev100: float) -> float:
    """Linear exposure multiplier for an EV100, Frostbite convention.

    ``exposure = 1 / L_max`` with ``L_max = 1.2 · 2^EV100``: the luminance
    that just saturates the sensor for a saturation-based sensitivity with
    lens/vignetting factor q = 0.65, since ``78 / (q·S) · N²/t = 1.2 · 2^EV100``
    (Lagarde & de Rousiers 2014, sec. 4.2 [1]_). Multiplying scene luminance in
    cd/m² by this value maps the sensor's saturation point to 1.

    Parameters
    ----------
    ev100 : float
        Exposure value at ISO 100.

    Returns
    -------
    float
        The multiplier; ``exposure_from_ev(0) == 1/1.2``.

    Notes
    -----
    Mitsuba's RGB variants output radiometric radiance, not photometric
    luminance; the suite treats linear RGB values as relative luminance for
    exposure purposes. What matters for comparisons is that reference and
    test get the same multiplier, which :func:`to_ldr` guarantees.
    """
    ev = float(ev100)
    if not math.isfinite(ev):
        raise ValueError(f"ev100 must be finite, got {ev100!r}")
    return 1.0 / (1.2 * 2.0**ev)


def exposure_scale(
    *,
    ev100: float | None = None,
    aperture: float | None = None,
    shutter_s: float | None = None,
    iso: float | None = None,
    compensation_ev: float = 0.0,
) -> float:
    """Linear exposure multiplier from either an EV100 or camera settings.

    Give either ``ev100`` or all of ``aperture``, ``shutter_s`` and ``iso``.
    The result is :func:`exposure_from_ev` (Frostbite's ``1 / (1.2 · 2^EV100)``
    [1]_) times ``2^compensation_ev``, the usual photographic exposure
    compensation (+1 EV = twice as bright).

    Parameters
    ----------
    ev100 : float, optional
        Exposure value at ISO 100.
    aperture, shutter_s, iso : float, optional
        Camera settings, see :func:`ev100_from_camera`.
    compensation_ev : float, optional
        Exposure compensation in stops, default 0.

    Returns
    -------
    float
        The multiplier to pass as ``exposure=`` to :func:`to_ldr`.

    Raises
    ------
    ValueError
        If both or neither of the two ways are given, or only part of the
        camera settings.
    """
    camera = (aperture, shutter_s, iso)
    given = [v is not None for v in camera]
    if ev100 is not None and any(given):
        raise ValueError("exposure_scale: give either ev100 or aperture/shutter_s/iso, not both")
    if ev100 is None:
        if not all(given):
            missing = [n for n, g in zip(("aperture", "shutter_s", "iso"), given) if not g]
            raise ValueError(f"exposure_scale: give ev100, or all camera settings (missing: {', '.join(missing)})")
        ev100 = ev100_from_camera(aperture, shutter_s, iso)  # type: ignore[arg-type]
    comp = float(compensation_ev)
    if not math.isfinite(comp):
        raise ValueError(f"compensation_ev must be finite, got {compensation_ev!r}")
    return exposure_from_ev(ev100) * 2.0**comp


# --------------------------------------------------------------------------- operators


def reinhard(x) -> np.ndarray:
    """Simple Reinhard curve per channel, ``x / (1 + x)`` [2]_.

    Parameters
    ----------
    x : array_like
        Linear values (negatives are clamped to 0).

    Returns
    -------
    numpy.ndarray
        float32 in [0, 1), linear (apply a transfer afterwards).
    """
    a = _prep(x)
    return _out(a / (1.0 + a))


def reinhard_luminance(rgb) -> np.ndarray:
    """Hue-preserving Reinhard: scale RGB by ``L' / L`` with ``L' = L / (1 + L)``.

    Parameters
    ----------
    rgb : array_like, shape (..., 3)
        Linear RGB (negatives are clamped to 0 first).

    Returns
    -------
    numpy.ndarray
        float32, linear. Saturated bright colours can exceed 1 in one channel
        (that is how the operator keeps hue); :func:`to_ldr` clips.

    Notes
    -----
    ``L'/L = 1/(1+L)`` algebraically, and that form is what is computed: it
    needs no special case at L = 0 (black stays black) and, because negatives
    are clamped to 0 first, L can never be negative, so the scale is always in
    (0, 1].
    """
    a = _prep(rgb)
    _rgb_last_axis(a, "reinhard_luminance")
    lum = a @ np.asarray(LUMINANCE_WEIGHTS)
    return _out(a / (1.0 + lum)[..., None])


def reinhard_extended(x, *, white: float = 4.0) -> np.ndarray:
    """Reinhard with a white point, per channel: ``x (1 + x / w²) / (1 + x)`` [2]_ (eq. 4).

    Parameters
    ----------
    x : array_like
        Linear values (negatives are clamped to 0).
    white : float, optional
        The smallest input that maps to 1 (``L_white``), > 0; ``inf`` gives
        :func:`reinhard`. Default 4.0.

    Returns
    -------
    numpy.ndarray
        float32, linear; values above ``white`` map above 1 (burn out after
        :func:`to_ldr`'s clip).

    Notes
    -----
    Reinhard et al. suggest the scene's maximum luminance as white point. The
    default here is a fixed number on purpose: an image-dependent white point
    would tone-map a reference and a test image differently and turn an
    exposure difference into a metric difference. Applied per channel, as in
    most real-time implementations; use :func:`reinhard_luminance` for the
    hue-preserving variant.
    """
    w = float(white)
    if not (w > 0.0):  # also rejects NaN
        raise ValueError(f"white must be > 0 (use math.inf for plain Reinhard), got {white!r}")
    a = _prep(x)
    return _out(a * (1.0 + a / (w * w)) / (1.0 + a))


def hejl_burgess_dawson(x) -> np.ndarray:
    """Jim Hejl and Richard Burgess-Dawson's filmic curve (as published by Hable [3]_).

    ``y = (v (6.2 v + 0.5)) / (v (6.2 v + 1.7) + 0.06)`` with ``v = max(0, x - 0.004)``.

    Parameters
    ----------
    x : array_like
        Linear values (negatives are clamped to 0).

    Returns
    -------
    numpy.ndarray
        float32 in [0, 1), **display-encoded**: the fit includes the display
        gamma (roughly 1/2.2), so no sRGB or gamma transfer may follow.
        :func:`to_ldr` knows this and skips its transfer for this operator.
    """
    a = _prep(x)
    v = np.maximum(a - 0.004, 0.0)
    return _out(v * (6.2 * v + 0.5) / (v * (6.2 * v + 1.7) + 0.06))


# Uncharted 2 constants from Hable's post [3]: shoulder strength, linear
# strength, linear angle, toe strength, toe numerator, toe denominator, and
# the linear white point.
_HABLE = dict(A=0.15, B=0.50, C=0.10, D=0.20, E=0.02, F=0.30)
HABLE_WHITE = 11.2


def _hable_curve(x: np.ndarray) -> np.ndarray:
    A, B, C, D, E, F = (_HABLE[k] for k in "ABCDEF")
    return (x * (A * x + C * B) + D * E) / (x * (A * x + B) + D * F) - E / F


def hable(x, *, exposure_bias: float = 2.0, white: float = HABLE_WHITE) -> np.ndarray:
    """John Hable's Uncharted 2 filmic curve [3]_.

    ``f(x) = (x(Ax + CB) + DE) / (x(Ax + B) + DF) − E/F`` with A = 0.15,
    B = 0.50, C = 0.10, D = 0.20, E = 0.02, F = 0.30; the result is
    ``f(exposure_bias · x) / f(white)`` with W = 11.2.

    Parameters
    ----------
    x : array_like
        Linear values (negatives are clamped to 0).
    exposure_bias : float, optional
        Multiplier applied inside the curve, default 2.0 as in Hable's
        published shader (``ExposureBias = 2.0f``). The paper's webgl-operate
        implementation multiplies by its own exposure instead; pass 1.0 and
        use ``to_ldr(exposure=...)`` to reproduce it.
    white : float, optional
        Linear white point W, default 11.2.

    Returns
    -------
    numpy.ndarray
        float32, linear (Hable follows it with ``pow(1/2.2)``; use
        ``to_ldr(..., transfer="gamma2.2")`` for that, or the default sRGB).
        Inputs with ``exposure_bias · x > white`` map above 1 (asymptote about
        1.12 for the defaults); :func:`to_ldr` clips.
    """
    bias = _positive_finite(exposure_bias, "exposure_bias")
    w = _positive_finite(white, "white")
    a = _prep(x)
    # f(0) = DE/DF - E/F = 0 exactly in real arithmetic; float64 rounding can
    # leave about -1e-17, which the clamp removes so black stays black.
    y = _hable_curve(bias * a) / _hable_curve(np.float64(w))
    return _out(np.maximum(y, 0.0))


def aces_narkowicz(x) -> np.ndarray:
    """Krzysztof Narkowicz's 2015/2016 ACES filmic fit, per channel [4]_.

    ``y = saturate(x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14))``.

    Parameters
    ----------
    x : array_like
        Linear values (negatives are clamped to 0).

    Returns
    -------
    numpy.ndarray
        float32 in [0, 1], linear.

    Notes
    -----
    The fit is luminance-only and was made on data pre-exposed so that 1 maps
    to about 0.8; Narkowicz notes that the original ACES curve corresponds to
    multiplying the input by 0.6. It over-saturates bright colours, which is
    why :func:`aces` uses Hill's fit.
    """
    a = _prep(x)
    return _out(np.clip(a * (2.51 * a + 0.03) / (a * (2.43 * a + 0.59) + 0.14), 0.0, 1.0))


# Stephen Hill's fit [5]: sRGB -> XYZ -> D65->D60 -> AP1 -> RRT_SAT, the
# rational RRT+ODT curve, then ODT_SAT -> XYZ -> D60->D65 -> sRGB.
_ACES_IN = np.array(
    [[0.59719, 0.35458, 0.04823],
     [0.07600, 0.90834, 0.01566],
     [0.02840, 0.13383, 0.83777]]
)  # fmt: skip
_ACES_OUT = np.array(
    [[1.60475, -0.53108, -0.07367],
     [-0.10208, 1.10813, -0.00605],
     [-0.00327, -0.07276, 1.07602]]
)  # fmt: skip


def aces(rgb) -> np.ndarray:
    """ACES filmic tone mapping, Stephen Hill's RRT+ODT fit ("ACESFitted") [5]_.

    RGB is taken to AP1 with the RRT saturation, mapped by
    ``(v (v + 0.0245786) − 0.000090537) / (v (0.983729 v + 0.4329510) + 0.238081)``,
    taken back to linear sRGB and clamped to [0, 1].

    Parameters
    ----------
    rgb : array_like, shape (..., 3)
        Linear sRGB (negatives are clamped to 0).

    Returns
    -------
    numpy.ndarray
        float32 in [0, 1], linear (apply sRGB afterwards).

    Notes
    -----
    Chosen over :func:`aces_narkowicz` because it includes the ACES
    saturation/hue behaviour (bright saturated colours desaturate towards
    white). No pre-exposure is applied; three.js, for comparison, divides its
    input by 0.6 before this fit. Both matrices have rows summing to 1 (to the
    published 5 decimals: 0.99999 for the last output row), so grey stays
    grey to within 1e-5. The curve is slightly negative at 0 (−0.00038), which
    the final clamp turns into black.
    """
    a = _prep(rgb)
    _rgb_last_axis(a, "aces")
    v = a @ _ACES_IN.T
    v = (v * (v + 0.0245786) - 0.000090537) / (v * (0.983729 * v + 0.4329510) + 0.238081)
    return _out(np.clip(v @ _ACES_OUT.T, 0.0, 1.0))


# --------------------------------------------------------------------------- transfers


def srgb_encode(x) -> np.ndarray:
    """sRGB transfer function (linear → display-encoded), IEC 61966-2-1 [6]_.

    ``12.92 x`` for ``x <= 0.0031308``, else ``1.055 x^(1/2.4) − 0.055``.

    Parameters
    ----------
    x : array_like
        Linear values; negatives are clamped to 0, values above 1 follow the
        power segment (no clipping here).

    Returns
    -------
    numpy.ndarray
        float32.
    """
    a = _prep(x)
    # np.where evaluates both branches; a was clamped to >= 0 so the power
    # branch never sees a negative base (no invalid-value warning).
    return _out(np.where(a <= 0.0031308, 12.92 * a, 1.055 * np.power(a, 1.0 / 2.4) - 0.055))


def srgb_decode(x) -> np.ndarray:
    """Inverse sRGB transfer (display-encoded → linear), IEC 61966-2-1 [6]_.

    ``x / 12.92`` for ``x <= 0.04045``, else ``((x + 0.055) / 1.055)^2.4``.

    Parameters
    ----------
    x : array_like
        Encoded values; negatives are clamped to 0.

    Returns
    -------
    numpy.ndarray
        float32.
    """
    a = _prep(x)
    return _out(np.where(a <= 0.04045, a / 12.92, np.power((a + 0.055) / 1.055, 2.4)))


def gamma_encode(x, gamma: float = 2.2) -> np.ndarray:
    """Pure power-law display encoding, ``x^(1/gamma)``.

    Parameters
    ----------
    x : array_like
        Linear values; negatives are clamped to 0.
    gamma : float, optional
        Display gamma, default 2.2 (what Hable's and the paper's shaders use).

    Returns
    -------
    numpy.ndarray
        float32.
    """
    g = _positive_finite(gamma, "gamma")
    return _out(np.power(_prep(x), 1.0 / g))


# --------------------------------------------------------------------------- to_ldr

#: name -> (operator, output already display-encoded?)
OPERATORS: dict[str, tuple[Callable[[np.ndarray], np.ndarray], bool]] = {
    "aces": (aces, False),
    "aces_narkowicz": (aces_narkowicz, False),
    "hable": (hable, False),
    "hejl_burgess_dawson": (hejl_burgess_dawson, True),
    "reinhard": (reinhard, False),
    "reinhard_luminance": (reinhard_luminance, False),
    "reinhard_extended": (reinhard_extended, False),
    # No curve: clip only. For images that are already display-referred.
    "clamp": (lambda x: _out(_prep(x)), False),
}

#: name -> transfer function applied after a linear-output operator.
TRANSFERS: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "srgb": srgb_encode,
    "gamma2.2": gamma_encode,
    "linear": lambda x: _out(_prep(x)),
}


def to_ldr(
    image,
    *,
    exposure: float = 1.0,
    operator: str | Callable[[np.ndarray], np.ndarray] = "aces",
    transfer: str = "srgb",
) -> np.ndarray:
    """Map a linear HDR image to display-encoded LDR values in [0, 1].

    ``clip(transfer(operator(exposure · image)), 0, 1)``, except that for an
    operator whose output is already display-encoded (``hejl_burgess_dawson``)
    the transfer is skipped.

    Parameters
    ----------
    image : array_like, shape (..., 3)
        Linear RGB, finite.
    exposure : float, optional
        Linear multiplier applied first (see :func:`exposure_scale`), > 0.
    operator : str or callable, optional
        One of :data:`OPERATORS` (``"aces"`` (Hill's fit, default),
        ``"aces_narkowicz"``, ``"hable"``, ``"hejl_burgess_dawson"``,
        ``"reinhard"``, ``"reinhard_luminance"``, ``"reinhard_extended"``,
        ``"clamp"``), or a callable mapping linear RGB to linear display values
        (e.g. ``functools.partial(reinhard_extended, white=8)``).
    transfer : {"srgb", "gamma2.2", "linear"}, optional
        Display encoding after a linear-output operator. Default ``"srgb"``.

    Returns
    -------
    numpy.ndarray
        float32, same shape as ``image``, every value in [0, 1].

    Raises
    ------
    ImageError
        If the image holds NaN/Inf or has no RGB last axis.
    ValueError
        For an unknown operator or transfer, or a non-positive exposure.
    """
    a = np.asarray(image)
    if a.ndim < 1 or a.shape[-1] != 3:
        raise ImageError(f"to_ldr: expected RGB values on the last axis (shape (..., 3)), got shape {a.shape}")
    check_finite(a, "to_ldr input")
    exp = _positive_finite(exposure, "exposure")
    if transfer not in TRANSFERS:
        raise ValueError(f"unknown transfer {transfer!r}; choose one of {sorted(TRANSFERS)}")
    if callable(operator):
        op, encoded = operator, False
    elif operator in OPERATORS:
        op, encoded = OPERATORS[operator]
    else:
        raise ValueError(f"unknown operator {operator!r}; choose one of {sorted(OPERATORS)} or pass a callable")
    # Multiply in float64: a float32 image near its maximum times an exposure
    # > 1 would overflow to inf in float32.
    y = op(a.astype(np.float64) * exp)
    if not encoded:
        y = TRANSFERS[transfer](y)
    return np.clip(np.asarray(y, dtype=np.float32), 0.0, 1.0)


def write_png(
    path: str | os.PathLike,
    image_hdr,
    *,
    exposure: float = 1.0,
    operator: str | Callable[[np.ndarray], np.ndarray] = "aces",
    display: bool = False,
) -> Path:
    """Tone-map a linear HDR image and write it as an 8-bit sRGB PNG, atomically.

    With ``display`` the image is display-encoded already (an engine's own tone-mapped sRGB, values in
    [0, 1]) and is written as it is.

    Parameters
    ----------
    path : str or os.PathLike
        Destination; parent folders are created. Written via a temporary file
        in the same folder and renamed, so a crash never leaves half a PNG.
    image_hdr : array_like, shape (H, W, 3)
        Linear RGB, finite.
    exposure, operator
        As for :func:`to_ldr` (transfer is always sRGB: PNG has no other tag
        here, and viewers assume sRGB).

    Returns
    -------
    pathlib.Path
        The written path.

    Raises
    ------
    ImageError
        If the image holds NaN/Inf or is not (H, W, 3).
    """
    import imageio.v3 as iio  # deferred: imageio is only needed for writing previews

    a = check_rgb(image_hdr, f"{path}")
    ldr = (to_ldr(a, operator="clamp", transfer="linear") if display
           else to_ldr(a, exposure=exposure, operator=operator, transfer="srgb"))
    u8 = np.round(ldr * 255.0).astype(np.uint8)
    path = Path(path)
    with atomic_path(path, suffix=".png") as tmp:
        iio.imwrite(tmp, u8, extension=".png")
    return path
