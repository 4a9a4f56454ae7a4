"""Bias against noise: the error of K independent runs split into squared bias and variance.

K runs of one renderer with different seeds (jitter, light and environment
samples) give, at each checkpoint, images ``t_1 … t_K``; with ``r`` the ground
truth, per pixel and channel::

    MSE      = mean_k (t_k - r)^2              the error of one run, averaged over the K
    variance = var_k(t_k)   (ddof = 1)        the noise of one run
    bias^2   = MSE - variance - var(r)        what more samples of the same method do not remove

since E (t - r)^2 = (E t - E r)^2 + var(t) + var(r) for independent t and r.
``var(r)``, the ground truth's own noise, is its noise floor's estimate
(``NoiseFloor.mse_reference_estimate``) when the run has one, else 0 (then
``bias2`` includes it). Its 95 % confidence interval is the jackknife's over
the K runs (leave one run out; K >= 3; Student's t quantile of K - 1 degrees of
freedom), which sees the noise of the estimate and not the bias's spatial
pattern; with K = 2 the spread of 8 x 8-pixel tile estimates stands in. A flat ``bias2`` curve above 0 while ``variance`` falls
says the renderer is biased, not just unconverged; ``bias2`` within its
interval of 0 says it converges to the ground truth.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["TILE", "bias_variance"]

#: Tile size (pixels) of the confidence interval.
TILE = 8


def bias_variance(images, truth, *, truth_variance: float = 0.0,
                  relative: bool = False) -> dict[str, float | int | None]:
    """Split the error of K >= 2 independent renders (K, H, W, 3) against ``truth`` (see the notes).

    Returns ``mse`` (of one run, averaged over the K), ``variance`` (of one run), ``bias2``
    (``mse - variance - truth_variance``), ``bias2_ci`` (half-width of its 95 % interval;
    None for two runs of a single pixel, where nothing estimates it) and ``seeds`` (K). ``relative``: every squared difference divided by ``truth² + eps``
    per pixel (relMSE's weights, :data:`compare.metrics.images.RELMSE_EPS`), so that the split is
    in relMSE units and bright pixels (a visible light's edges) do not decide it.
    """
    t = np.asarray(images, dtype=np.float64)
    r = np.asarray(truth, dtype=np.float64)
    if t.ndim != 4 or t.shape[0] < 2 or t.shape[1:] != r.shape or r.ndim != 3:
        raise ValueError(f"bias_variance: expected K >= 2 renders (K, H, W, 3) of the truth's shape {r.shape}, "
                         f"got {t.shape}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(r))):
        raise ValueError("bias_variance: the images hold NaN or infinite values")
    if not (math.isfinite(truth_variance) and truth_variance >= 0):
        raise ValueError(f"bias_variance: truth_variance must be a finite number >= 0, got {truth_variance!r}")
    k = t.shape[0]
    if relative:
        from compare.metrics.images import RELMSE_EPS

        scale = 1.0 / np.sqrt(r * r + RELMSE_EPS)  # (t - r)^2 / (r^2 + eps) = ((t - r) * scale)^2
        t, r = t * scale, r * scale
    sq = np.mean((t - r) ** 2, axis=0)           # per pixel and channel: mean over runs
    var = np.var(t, axis=0, ddof=1)
    mse = float(sq.mean())
    variance = float(var.mean())
    if k >= 3:
        # leave-one-out: bias^2 of the other K - 1 runs
        sq_sum, s1, s2 = ((t - r) ** 2).sum(axis=0), t.sum(axis=0), (t * t).sum(axis=0)
        loo = []
        for i in range(k):
            n = k - 1
            a, b = s1 - t[i], s2 - t[i] * t[i]
            v = (b - a * a / n) / (n - 1)
            loo.append(float(((sq_sum - (t[i] - r) ** 2) / n - v).mean()))
        loo = np.asarray(loo)
        # Student's t with K - 1 degrees of freedom: K is small, the jackknife's spread uncertain
        from scipy.stats import t as student_t

        ci = float(student_t.ppf(0.975, k - 1)) * math.sqrt((k - 1) / k * float(np.sum((loo - loo.mean()) ** 2)))
    else:
        d = (sq - var).mean(axis=2)
        h, w = d.shape
        th, tw = max(h // TILE, 1), max(w // TILE, 1)
        hh, ww = (h // th) * th, (w // tw) * tw
        tiles = d[:hh, :ww].reshape(th, hh // th, tw, ww // tw).mean(axis=(1, 3)).ravel()
        if tiles.size < 4:  # an image too small for tiles: its pixels stand in
            tiles = d.ravel()
        ci = 1.96 * float(np.std(tiles, ddof=1)) / math.sqrt(tiles.size) if tiles.size > 1 else None
    return {"mse": mse, "variance": variance, "bias2": mse - variance - float(truth_variance), "bias2_ci": ci,
            "seeds": int(t.shape[0])}
