"""Image error metrics between a reference and a test rendering.

Two kinds of metric, on two kinds of image:

* On the **linear HDR** images, as rendered: :func:`mse`, :func:`relmse`, and
  HDR-FLIP (:func:`flip` with ``mode="HDR"``).
* On the **tone-mapped LDR** images (one :func:`compare.image.tonemap.to_ldr` call
  with the same exposure and operator for both images): :func:`psnr`,
  :func:`ssim`, LDR-FLIP (:func:`flip`, the default mode) and model-viewer's
  fidelity number (:func:`mv_rms_db`, on the 8-bit images; see
  :mod:`compare.metrics.model_viewer`).

Every public function checks its inputs first: both images must be (H, W, 3),
finite (:func:`check_finite` names the count and first location of any NaN/Inf)
and of the same shape (:func:`check_pair`). Reductions are done in float64 so
that a mean over millions of float32 pixels does not lose digits.

References
----------
.. [1] F. Rousselle, C. Knaus, M. Zwicker, "Adaptive Sampling and
   Reconstruction using Greedy Error Minimization", ACM TOG 30(6) (SIGGRAPH
   Asia 2011): relative MSE with ε = 0.01.
.. [2] Z. Wang, A. C. Bovik, H. R. Sheikh, E. P. Simoncelli, "Image Quality
   Assessment: From Error Visibility to Structural Similarity", IEEE TIP 13(4),
   2004.
.. [3] P. Andersson, J. Nilsson, T. Akenine-Möller, M. Oskarsson, K. Åström,
   M. D. Fairchild, "FLIP: A Difference Evaluator for Alternating Images",
   HPG 2020; P. Andersson et al., "Visualizing Errors in Rendered High Dynamic
   Range Images", Eurographics 2021 short papers (HDR-FLIP).
"""

from __future__ import annotations

import math
from typing import Any, Callable

import numpy as np

from compare.util.errors import ImageError
from compare.image.checks import check_finite, check_pair, check_rgb
from compare.image.tonemap import LUMINANCE_WEIGHTS, to_ldr
from compare.metrics.model_viewer import rms_db_ldr

__all__ = [
    "ERROR_MAP_RANGES",
    "RELMSE_EPS",
    "check_finite",
    "check_pair",
    "compare_images",
    "error_maps",
    "flip",
    "mse",
    "mv_rms_db",
    "psnr",
    "relmse",
    "ssim",
]

#: ε in relMSE's denominator, as in Rousselle et al. 2011 [1]_.
RELMSE_EPS = 1e-2

# SSIM as in Wang et al. [2]: 11x11 Gaussian window, sigma 1.5, population
# covariance. scikit-image recommends exactly these to match the paper.
_SSIM_SIGMA = 1.5
_SSIM_MIN_SIDE = 11

Operator = str | Callable[[np.ndarray], np.ndarray]


# --------------------------------------------------------------------------- input handling


def _checked_pair(ref, test) -> tuple[np.ndarray, np.ndarray]:
    r = check_rgb(ref, "reference")
    t = check_rgb(test, "test")
    check_finite(r, "reference")
    check_finite(t, "test")
    check_pair(r, t)
    return r, t


def _ldr_pair(r: np.ndarray, t: np.ndarray, exposure: float, operator: Operator,
              display: bool = False) -> tuple[np.ndarray, np.ndarray]:
    # One function, same arguments for both: the only way LDR metrics can
    # differ is through the images themselves. A display-encoded test image (an
    # engine that shows only its own tone-mapped 8-bit sRGB) is LDR already: it is
    # taken as it is, against the reference as the suite tone-maps it.
    return (
        to_ldr(r, exposure=exposure, operator=operator),
        to_ldr(t, operator="clamp", transfer="linear") if display else to_ldr(t, exposure=exposure, operator=operator),
    )


def _operator_name(operator: Operator) -> str:
    return operator if isinstance(operator, str) else getattr(operator, "__name__", repr(operator))


# --------------------------------------------------------------------------- HDR metrics


def mse(ref, test) -> float:
    """Mean squared error of the linear HDR images, over all pixels and channels.

    Parameters
    ----------
    ref, test : array_like, shape (H, W, 3)
        Linear RGB, finite, same shape.

    Returns
    -------
    float
        ``mean((test - ref)²)``, computed in float64.

    Raises
    ------
    ImageError
        On NaN/Inf, a wrong shape, or a shape mismatch.
    """
    r, t = _checked_pair(ref, test)
    d = t.astype(np.float64) - r.astype(np.float64)
    return float(np.mean(d * d))


def _relmse_terms(r: np.ndarray, t: np.ndarray, eps: float) -> np.ndarray:
    r64 = r.astype(np.float64)
    d = t.astype(np.float64) - r64
    return d * d / (r64 * r64 + eps)


def relmse(ref, test, *, eps: float = RELMSE_EPS) -> float:
    """Relative mean squared error of the linear HDR images.

    ``mean((test - ref)² / (ref² + eps))`` per channel, averaged over pixels
    and channels [1]_.

    Parameters
    ----------
    ref, test : array_like, shape (H, W, 3)
        Linear RGB, finite, same shape.
    eps : float, optional
        Keeps dark reference pixels from dominating (and from dividing by
        zero). Default 1e-2, the value of Rousselle et al. 2011 and most
        Monte-Carlo denoising papers since; only relMSEs with the same ε are
        comparable.

    Returns
    -------
    float
        The relative MSE, computed in float64; 0 for identical images.

    Raises
    ------
    ImageError
        On NaN/Inf, a wrong shape, or a shape mismatch.
    ValueError
        If ``eps`` is not a finite positive number.
    """
    if not (math.isfinite(eps) and eps > 0):
        raise ValueError(f"eps must be a finite number > 0, got {eps!r}")
    r, t = _checked_pair(ref, test)
    return float(np.mean(_relmse_terms(r, t, eps)))


# --------------------------------------------------------------------------- LDR metrics


def _psnr_ldr(rl: np.ndarray, tl: np.ndarray) -> float:
    d = tl.astype(np.float64) - rl.astype(np.float64)
    m = float(np.mean(d * d))
    # Explicit: log10(1/0) would warn and give inf; identical images have no
    # error to measure, and +inf is the mathematically honest PSNR.
    return math.inf if m == 0.0 else 10.0 * math.log10(1.0 / m)


def psnr(ref, test, *, exposure: float = 1.0, operator: Operator = "aces") -> float:
    """Peak signal-to-noise ratio of the tone-mapped LDR images, in dB.

    ``10 · log10(1 / MSE_ldr)`` with data range 1, on ``to_ldr(image,
    exposure=exposure, operator=operator)`` of both images (sRGB-encoded,
    [0, 1]). PSNR on linear HDR values would be dominated by the brightest
    pixels and has no natural peak; on display values it is the familiar
    number.

    Parameters
    ----------
    ref, test : array_like, shape (H, W, 3)
        Linear RGB, finite, same shape.
    exposure, operator
        Passed to :func:`compare.image.tonemap.to_ldr`.

    Returns
    -------
    float
        PSNR in dB; ``math.inf`` when the two LDR images are identical (no
        divide-by-zero warning). :func:`compare_images` reports that case as
        ``None`` to stay valid JSON.

    Raises
    ------
    ImageError
        On NaN/Inf, a wrong shape, or a shape mismatch.
    """
    r, t = _checked_pair(ref, test)
    return _psnr_ldr(*_ldr_pair(r, t, exposure, operator))


def _ssim_ldr(rl: np.ndarray, tl: np.ndarray) -> tuple[float, np.ndarray]:
    from skimage.metrics import structural_similarity  # deferred: heavy import

    if min(rl.shape[:2]) < _SSIM_MIN_SIDE:
        raise ImageError(
            f"SSIM needs images of at least {_SSIM_MIN_SIDE}x{_SSIM_MIN_SIDE} pixels "
            f"(its Gaussian window), got {rl.shape[0]}x{rl.shape[1]}"
        )
    mean, smap = structural_similarity(
        rl.astype(np.float64),
        tl.astype(np.float64),
        data_range=1.0,
        channel_axis=2,
        gaussian_weights=True,
        sigma=_SSIM_SIGMA,
        use_sample_covariance=False,
        full=True,
    )
    return float(mean), smap


def ssim(
    ref,
    test,
    *,
    exposure: float = 1.0,
    operator: Operator = "aces",
    full: bool = False,
) -> float | tuple[float, np.ndarray]:
    """Structural similarity of the tone-mapped LDR images.

    scikit-image's ``structural_similarity`` on ``to_ldr`` of both images, with
    ``data_range=1.0`` and ``channel_axis=2`` given explicitly (the LDR images
    are float in [0, 1]; a guessed range would be wrong), and the settings of
    Wang et al. [2]_: Gaussian window σ = 1.5 (11×11), population covariance.

    Parameters
    ----------
    ref, test : array_like, shape (H, W, 3)
        Linear RGB, finite, same shape, at least 11×11 pixels.
    exposure, operator
        Passed to :func:`compare.image.tonemap.to_ldr`.
    full : bool, optional
        Also return the per-pixel map.

    Returns
    -------
    mean : float
        Mean SSIM (1 for identical images). As in scikit-image, the mean
        excludes a border of 5 pixels where the window does not fit.
    map : numpy.ndarray, optional
        float64 (H, W) SSIM map averaged over the three channels, when
        ``full=True``.

    Raises
    ------
    ImageError
        On NaN/Inf, a wrong shape, a shape mismatch, or an image smaller than
        the window.
    """
    r, t = _checked_pair(ref, test)
    mean, smap = _ssim_ldr(*_ldr_pair(r, t, exposure, operator))
    if full:
        return mean, smap.mean(axis=2)
    return mean


# --------------------------------------------------------------------------- FLIP

_FLIP_KEYS = {"ppd", "vc", "startExposure", "stopExposure", "numExposures", "tonemapper"}
_FLIP_EXPOSURE_KEYS = {"startExposure", "stopExposure", "numExposures"}
_FLT_EPSILON = float(np.finfo(np.float32).eps)


def _check_flip_parameters(parameters: dict[str, Any], mode: str) -> dict[str, Any]:
    """Validate FLIP parameters ourselves: flip_evaluator prints and calls sys.exit()."""
    p = dict(parameters)
    unknown = set(p) - _FLIP_KEYS
    if unknown:
        raise ValueError(f"flip: unknown parameters {sorted(unknown)}; allowed: {sorted(_FLIP_KEYS)}")
    if "ppd" in p and "vc" in p:
        raise ValueError("flip: parameters 'ppd' and 'vc' are mutually exclusive")
    if "ppd" in p:
        ppd = float(p["ppd"])
        if not (math.isfinite(ppd) and ppd > 0):
            raise ValueError(f"flip: parameters['ppd'] must be a finite number > 0, got {p['ppd']!r}")
        p["ppd"] = ppd
    if "vc" in p:
        vc = [float(v) for v in p["vc"]]
        if len(vc) != 3 or not all(math.isfinite(v) and v > 0 for v in vc):
            raise ValueError(
                "flip: parameters['vc'] must be three positive numbers "
                f"(distance to display m, display width px, display width m), got {p['vc']!r}"
            )
        p["vc"] = vc
    if "tonemapper" in p and str(p["tonemapper"]).lower() not in {"aces", "hable", "reinhard"}:
        raise ValueError(f"flip: parameters['tonemapper'] must be 'ACES', 'Hable' or 'Reinhard', got {p['tonemapper']!r}")
    given = _FLIP_EXPOSURE_KEYS & set(p)
    if mode == "LDR" and (given or "tonemapper" in p):
        raise ValueError(f"flip: {sorted(given | ({'tonemapper'} & set(p)))} only apply to mode='HDR'")
    if ("startExposure" in p) != ("stopExposure" in p):
        raise ValueError("flip: give both 'startExposure' and 'stopExposure', or neither")
    if "startExposure" in p:
        start, stop = float(p["startExposure"]), float(p["stopExposure"])
        if not (math.isfinite(start) and math.isfinite(stop) and start <= stop):
            raise ValueError(f"flip: need finite startExposure <= stopExposure, got {start!r}, {stop!r}")
        p["startExposure"], p["stopExposure"] = start, stop
    if "numExposures" in p:
        n = p["numExposures"]
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
            # FLIP divides the range by (n - 1): one exposure gives NaN.
            raise ValueError(f"flip: parameters['numExposures'] must be an int >= 2, got {n!r}")
        p["numExposures"] = int(n)
    return p


def _flip_eval(r: np.ndarray, t: np.ndarray, mode: str, parameters: dict[str, Any]) -> tuple[float, np.ndarray, dict[str, Any]]:
    import flip_evaluator  # deferred: loads an OpenMP library

    hdr = mode == "HDR"
    if hdr and "startExposure" not in parameters:
        # FLIP derives its exposure range from the reference's maximum and
        # median luminance (median clamped to float32 epsilon). For a black
        # or nearly black reference that range is reversed and the C++ code
        # calls std::exit(-1), killing the whole Python process. Refuse first.
        ymax = float(np.max(r.astype(np.float64) @ np.asarray(LUMINANCE_WEIGHTS)))
        if ymax <= 2.0 * _FLT_EPSILON:
            raise ImageError(
                f"HDR-FLIP: the reference is black (max luminance {ymax:g}), so FLIP cannot choose an "
                "exposure range (flip_evaluator would terminate the process); pass "
                "parameters={'startExposure': ..., 'stopExposure': ...} or use mode='LDR'"
            )
    fmap, _fmean, used = flip_evaluator.evaluate(
        np.ascontiguousarray(r, dtype=np.float32),
        np.ascontiguousarray(t, dtype=np.float32),
        mode,
        inputsRGB=not hdr,  # LDR input is sRGB-encoded; HDR input is linear
        applyMagma=False,
        computeMeanError=True,
        parameters=parameters,
    )
    fmap = np.asarray(fmap, dtype=np.float32).reshape(r.shape[:2])
    # FLIP's own mean is a float32 sum; recompute in float64 from the map.
    mean = float(np.mean(fmap, dtype=np.float64))
    out: dict[str, Any] = {"mode": mode, "ppd": float(used["ppd"])}
    if hdr:
        out.update(
            startExposure=float(used["startExposure"]),
            stopExposure=float(used["stopExposure"]),
            numExposures=int(used["numExposures"]),
            tonemapper=str(used["tonemapper"]),
        )
    return mean, fmap, out


def flip(
    ref,
    test,
    *,
    mode: str = "LDR",
    exposure: float = 1.0,
    operator: Operator = "aces",
    parameters: dict[str, Any] | None = None,
) -> tuple[float, np.ndarray, dict[str, Any]]:
    """NVIDIA FLIP error between a reference and a test image [3]_.

    Parameters
    ----------
    ref, test : array_like, shape (H, W, 3)
        Linear RGB, finite, same shape.
    mode : {"LDR", "HDR"}, optional
        ``"LDR"`` (default): both images are tone-mapped by
        :func:`compare.image.tonemap.to_ldr` with ``exposure`` and ``operator`` and
        passed to LDR-FLIP as sRGB-encoded values in [0, 1].
        ``"HDR"``: the linear images are passed to HDR-FLIP, which sweeps its
        own exposure range (computed from the reference) through its own tone
        mapper; ``exposure`` and ``operator`` are not used, and negative values
        are clamped to 0 because HDR-FLIP expects non-negative radiance.
    exposure, operator
        Passed to :func:`compare.image.tonemap.to_ldr` in LDR mode.
    parameters : dict, optional
        FLIP settings: ``ppd`` (pixels per degree, default 67) or ``vc``
        (viewing conditions), and in HDR mode ``startExposure``/``stopExposure``
        (both or neither), ``numExposures`` (>= 2), ``tonemapper``. Checked
        here and a :class:`ValueError` raised, because flip_evaluator itself
        prints and calls ``sys.exit`` on bad values.

    Returns
    -------
    mean : float
        Mean FLIP error in [0, 1] (0 for identical images), averaged in
        float64 from the map.
    map : numpy.ndarray
        float32 (H, W) per-pixel FLIP error in [0, 1].
    parameters : dict
        The settings actually used, for the report: ``mode``, ``ppd``; in HDR
        mode the exposure range, count and tone mapper FLIP chose; in LDR mode
        the ``exposure`` and ``operator`` of the tone mapping applied first.

    Raises
    ------
    ImageError
        On NaN/Inf, a wrong shape, a shape mismatch, or (HDR mode without
        explicit exposures) a black reference, for which FLIP would terminate
        the process.
    ValueError
        For an unknown mode or invalid parameters.
    """
    m = str(mode).upper()
    if m not in {"LDR", "HDR"}:
        raise ValueError(f"flip: mode must be 'LDR' or 'HDR', got {mode!r}")
    r, t = _checked_pair(ref, test)
    params = _check_flip_parameters(parameters or {}, m)
    if m == "HDR":
        return _flip_eval(np.maximum(r, 0), np.maximum(t, 0), m, params)
    mean, fmap, used = _flip_eval(*_ldr_pair(r, t, exposure, operator), m, params)
    used.update(exposure=float(exposure), operator=_operator_name(operator))
    return mean, fmap, used


# --------------------------------------------------------------------------- all at once


#: A tone-mapped reference whose values spread less than one 8-bit step shows nothing to
#: compare against (black, saturated or flat): its LDR metrics are undefined (None).
LDR_DEGENERATE_RANGE = 1.0 / 255.0
#: The metrics of the tone-mapped images (None for such a reference), as results.json names them.
LDR_METRICS = ("psnr", "ssim", "flip", "flip_median", "flip_p95", "mv_rms_db")


def mv_rms_db(ref, test, *, exposure: float = 1.0, operator: Operator = "aces", mask=None) -> float | None:
    """model-viewer's fidelity number of the test image against the reference, in dB (lower is better).

    Both images go through :func:`compare.image.tonemap.to_ldr` with ``exposure`` and ``operator``
    and are rounded to 8 bits like the run's PNG previews; then
    ``10 · log10(sqrt(mean δ²) / 35215)`` over the model's pixels, with δ pixelmatch's squared YIQ
    colour distance (:mod:`compare.metrics.model_viewer` gives the formula with model-viewer's source
    files and lines).

    Parameters
    ----------
    ref, test : array_like, shape (H, W, 3)
        Linear RGB, finite, same shape.
    exposure, operator
        Passed to :func:`compare.image.tonemap.to_ldr`.
    mask : array_like of bool, shape (H, W), optional
        The model's pixels; default every pixel (the suite's images are opaque, as model-viewer's
        screenshots with the environment shown behind the model).

    Returns
    -------
    float or None
        In [:data:`compare.metrics.model_viewer.MV_DB_FLOOR`, 0]: −100 dB (the floor) for identical
        8-bit images, 0 dB for the largest error everywhere. ``None`` when the tone-mapped
        reference spreads less than one 8-bit step (:data:`LDR_DEGENERATE_RANGE`: black,
        saturated or flat), as for the other LDR metrics: a constant test image would otherwise
        score as perfect against it.

    Raises
    ------
    ImageError
        On NaN/Inf, a wrong shape, a shape mismatch, or an empty mask.
    """
    r, t = _checked_pair(ref, test)
    rl, tl = _ldr_pair(r, t, exposure, operator)
    if float(rl.max() - rl.min()) < LDR_DEGENERATE_RANGE:
        return None
    return rms_db_ldr(rl, tl, mask=mask)


def flip_statistics(fmap) -> dict[str, float]:
    """Pooled values of a FLIP map beside its mean, as NVIDIA's FLIP tool reports them.

    ``flip_median``: the *weighted* median, the error below which half of the
    total error lies (each pixel weighted by its own error, FLIP's
    "weighted median"; 0 for an error-free map); ``flip_p95``: the plain 95th
    percentile of the per-pixel errors (the worst 5 % of the image start there).
    """
    v = np.sort(np.asarray(fmap, dtype=np.float64).ravel())
    if v.size == 0 or not np.all(np.isfinite(v)):
        raise ImageError("flip_statistics: expected a non-empty, finite FLIP map")
    total = float(v.sum())
    median = 0.0
    if total > 0.0:
        median = float(v[min(int(np.searchsorted(np.cumsum(v), 0.5 * total)), v.size - 1)])
    return {"flip_median": median, "flip_p95": float(np.percentile(v, 95.0))}


def hdr_exposure_range(ref) -> tuple[float, float] | None:
    """HDR-FLIP's exposure range (start, stop) for ``ref``, or None for a black reference.

    FLIP chooses it from the reference's maximum and median luminance; computed
    once per ground truth and passed to every HDR-FLIP against it
    (:func:`compare_images` ``hdr_range``), every renderer's HDR-FLIP sweeps the
    same exposures, and the range is recorded in ``results.json``.
    """
    r = np.maximum(_checked_pair(ref, ref)[0], 0)
    try:
        _, _, used = _flip_eval(r, r, "HDR", {})
    except ImageError:
        return None
    return float(used["startExposure"]), float(used["stopExposure"])


def compare_images(
    ref,
    test,
    *,
    exposure: float = 1.0,
    operator: Operator = "aces",
    flip_hdr: bool = True,
    hdr_range: tuple[float, float] | None = None,
    display: bool = False,
) -> dict[str, float | None]:
    """Every metric for one reference/test pair, as a JSON-ready dict.

    The images are checked once and tone-mapped once.

    Parameters
    ----------
    ref, test : array_like, shape (H, W, 3)
        Linear RGB, finite, same shape, at least 11×11 pixels (SSIM window).
    exposure, operator
        The tone mapping for the LDR metrics (PSNR, SSIM, LDR-FLIP, ``mv_rms_db``).
    flip_hdr : bool, optional
        Also compute HDR-FLIP (several LDR-FLIP passes, the slowest metric).
    hdr_range : (float, float), optional
        HDR-FLIP's exposure range (:func:`hdr_exposure_range` of the ground
        truth); None lets FLIP choose it from ``ref``.
    display : bool, optional
        ``test`` holds display-encoded values in [0, 1] (an engine's own tone
        mapping, 8-bit sRGB; :data:`compare.renderers.base.DISPLAY_OUTPUT`), not
        linear radiance: it enters the LDR metrics as it is, and the HDR metrics
        (``mse``, ``relmse``, ``flip_hdr``) are ``None``.

    Returns
    -------
    dict
        ``mse``, ``relmse`` (linear HDR), ``psnr``, ``ssim``, ``flip``,
        ``flip_median``, ``flip_p95`` (tone-mapped LDR; :func:`flip_statistics`),
        ``mv_rms_db`` (model-viewer's number on the 8-bit images, every pixel; :func:`mv_rms_db`),
        ``flip_hdr`` (when requested), and ``ldr_range``, the
        spread (max − min) of the tone-mapped reference. All values are Python
        floats, except three documented ``None`` cases so the dict stays valid
        JSON: ``psnr`` is ``None`` when the LDR images are identical (PSNR is
        +inf); ``flip_hdr`` is ``None`` when the reference is black (HDR-FLIP
        has no exposure range); and ``psnr``, ``ssim``, ``flip`` (with its
        pooled values) and ``mv_rms_db`` are all
        ``None`` when the reference tone-maps to a constant (``ldr_range`` below
        one 8-bit step, :data:`LDR_DEGENERATE_RANGE`: black, saturated, or
        flat): there is nothing to compare, and a constant test image would
        otherwise score as perfect (SSIM 1, FLIP 0) against it. Identical 8-bit
        images give ``mv_rms_db`` its floor, −100 dB, not −inf.

    Raises
    ------
    ImageError
        On NaN/Inf, a wrong shape, or a shape mismatch.
    """
    r, t = _checked_pair(ref, test)
    rl, tl = _ldr_pair(r, t, exposure, operator, display)
    ldr_range = float(rl.max() - rl.min())
    out: dict[str, float | None] = {
        "mse": None if display else float(np.mean(np.square(t.astype(np.float64) - r.astype(np.float64)))),
        "relmse": None if display else float(np.mean(_relmse_terms(r, t, RELMSE_EPS))),
        **dict.fromkeys(LDR_METRICS),
        "ldr_range": ldr_range,
    }
    if ldr_range >= LDR_DEGENERATE_RANGE:
        p = _psnr_ldr(rl, tl)
        mean, fmap, _ = _flip_eval(rl, tl, "LDR", {})
        out.update(psnr=None if math.isinf(p) else p, ssim=_ssim_ldr(rl, tl)[0], flip=mean, **flip_statistics(fmap),
                   mv_rms_db=rms_db_ldr(rl, tl))
    if flip_hdr and display:
        out["flip_hdr"] = None  # no radiance to sweep exposures over
    elif flip_hdr:
        params = {} if hdr_range is None else {"startExposure": float(hdr_range[0]),
                                               "stopExposure": float(hdr_range[1])}
        try:
            out["flip_hdr"] = _flip_eval(np.maximum(r, 0), np.maximum(t, 0), "HDR",
                                         _check_flip_parameters(params, "HDR"))[0]
        except ImageError:
            out["flip_hdr"] = None  # black reference, see flip()
    return out


def error_maps(
    ref,
    test,
    *,
    exposure: float = 1.0,
    operator: Operator = "aces",
    eps: float = RELMSE_EPS,
    display: bool = False,
) -> dict[str, np.ndarray]:
    """Per-pixel error maps for a reference/test pair.

    Parameters
    ----------
    ref, test : array_like, shape (H, W, 3)
        Linear RGB, finite, same shape, at least 11×11 pixels.
    exposure, operator
        The tone mapping for the LDR maps (FLIP, SSIM).
    eps : float, optional
        relMSE's ε, default 1e-2.
    display : bool, optional
        ``test`` is display-encoded (see :func:`compare_images`): its LDR maps
        only, no ``"relmse"``.

    Returns
    -------
    dict of str to numpy.ndarray
        Each (H, W): ``"flip"`` (LDR-FLIP, float32 in [0, 1]),
        ``"one_minus_ssim"`` (1 − SSIM averaged over channels, float64, 0 where
        identical, can reach 2 in theory), ``"relmse"`` (per-pixel relative
        squared error averaged over channels, float64, unbounded).

    Raises
    ------
    ImageError
        On NaN/Inf, a wrong shape, or a shape mismatch.
    """
    if not (math.isfinite(eps) and eps > 0):
        raise ValueError(f"eps must be a finite number > 0, got {eps!r}")
    r, t = _checked_pair(ref, test)
    rl, tl = _ldr_pair(r, t, exposure, operator, display)
    _, smap = _ssim_ldr(rl, tl)
    maps = {"flip": _flip_eval(rl, tl, "LDR", {})[1], "one_minus_ssim": 1.0 - smap.mean(axis=2)}
    if not display:
        maps["relmse"] = _relmse_terms(r, t, eps).mean(axis=2)
    return maps


#: Fixed colour-map ranges, so that maps of different renderers and runs share
#: one scale and can be compared by eye.
ERROR_MAP_RANGES: dict[str, tuple[float, float]] = {
    "flip": (0.0, 1.0),
    "one_minus_ssim": (0.0, 1.0),
    "relmse": (0.0, 1.0),
}


