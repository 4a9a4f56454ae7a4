"""Error per kind of light: a renderer's layers against the per-effect ground truths.

For every layer (:data:`compare.image.layers.LAYERS`, written by the reference's integrator :mod:`compare.mitsuba.layers`) that the ground truth has,
:func:`layer_metrics` gives FLIP and relMSE of the renderer's layer against the
ground truth's, the ratio of their mean luminances, and the layer's **share** of
the full image's relMSE::

    share_l = sum_p w (t_l - r_l) . (t - r)  /  sum_p w (t - r)^2,   w = 1 / (r^2 + eps)

with ``t`` and ``r`` the sums of the renderer's and the ground truth's layers.
The shares of :data:`SUM_LAYERS` add up to exactly 1:
the full image's squared error splits into each approximation's part (a share
can be negative when a layer's error cancels part of another's). A layer the
renderer does not give is light it does not render: it counts as zero, and its
whole ground truth is that layer's error.
"""

from __future__ import annotations

import numpy as np

from compare.image.layers import EXTRA_LAYERS, LAYERS, SUM_LAYERS
from compare.metrics.images import LUMINANCE_WEIGHTS, RELMSE_EPS, compare_images

__all__ = ["EXTRA_LAYERS", "LAYERS", "SUM_LAYERS", "layer_metrics"]

#: A layer whose mean luminance is below this (of the full image's) carries no light worth a ratio.
DARK_FRACTION = 1e-6


def _mean_luminance(image: np.ndarray) -> float:
    return float(np.mean(image.astype(np.float64) @ np.asarray(LUMINANCE_WEIGHTS)))


def layer_metrics(truth: dict[str, np.ndarray], run: dict[str, np.ndarray], *, exposure: float = 1.0,
                  operator: str = "aces") -> dict[str, dict]:
    """Per-layer errors of ``run``'s layers against ``truth``'s (see the module notes).

    Returns layer → ``{"flip", "flip_median", "flip_p95", "relmse", "mean_ratio", "share",
    "rendered"}`` (``share`` only for the summing layers; ``None`` where undefined: LDR
    metrics of a layer that tone-maps to a constant, the ratio of a dark layer).
    """
    shape = next(iter(truth.values())).shape if truth else None
    zero = None if shape is None else np.zeros(shape, dtype=np.float32)
    summing = [n for n in SUM_LAYERS if n in truth]
    r_full = sum((truth[n].astype(np.float64) for n in summing), np.zeros(shape or (1, 1, 3)))
    t_full = sum((run.get(n, zero).astype(np.float64) for n in summing), np.zeros(shape or (1, 1, 3)))
    w = 1.0 / (r_full * r_full + RELMSE_EPS)
    err = t_full - r_full
    total = float(np.sum(w * err * err))
    bright = _mean_luminance(r_full) if summing else 0.0
    out: dict[str, dict] = {}
    for name in summing + [n for n in EXTRA_LAYERS if n in truth and n in run]:
        r = truth[name]
        t = run.get(name, zero)
        m = compare_images(r, t, exposure=exposure, operator=operator, flip_hdr=False)
        mean_r = _mean_luminance(r)
        entry = {"flip": m["flip"], "flip_median": m["flip_median"], "flip_p95": m["flip_p95"],
                 "relmse": m["relmse"],
                 "mean_ratio": (_mean_luminance(t) / mean_r if mean_r > DARK_FRACTION * max(bright, 1e-30)
                                else None),
                 "rendered": name in run}
        if name in SUM_LAYERS:
            part = float(np.sum(w * (t.astype(np.float64) - r) * err))
            entry["share"] = part / total if total > 0 else None
        out[name] = entry
    return out
