"""When a Monte Carlo ground truth has enough samples: the relative standard error its own passes measure.

A reference render is the mean of independent passes (:mod:`compare.mitsuba.reference`), each an unbiased
estimate of the converged image. Their spread estimates each pixel's per-sample variance without a second
render: for passes of ``n_i`` samples with means ``x_i`` and overall mean ``x̄`` (``N = Σ n_i`` samples,
``C`` passes), ``s² = Σ n_i (x_i − x̄)² / (C − 1)`` is unbiased, and ``s² / N`` is the variance of ``x̄``.

The rule (:class:`StopRule`) judges luminance (what FLIP and the tone-mapped metrics see most) relative to
itself, the way relMSE does: a pixel's relative standard error is ``SE / sqrt(x̄² + ε)`` with relMSE's ``ε``
(:data:`EPS`), so a dark pixel's standard error is measured against 0.1 rather than against its own
near-zero value, which would let black pixels dominate. Its statistic is a high percentile over pixels, not the mean: a caustic
or a small glossy highlight covers few pixels, and a mean over the whole image would let them stay noisy.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from compare.image.tonemap import luminance
from compare.util.settings import DEFAULT_SPP_CAP, DEFAULT_SPP_TARGET

__all__ = ["EPS", "MIN_SPP", "PERCENTILE", "PassSpread", "StopRule", "Stopping"]

#: relMSE's ε (:data:`compare.metrics.images.RELMSE_EPS`, a test holds them equal), written here rather
#: than imported: the stopping rule is part of the ground truth's render key, and the metrics' code is not.
EPS = 1e-2

#: The share of pixels (in percent) whose relative standard error must be at or under the target.
PERCENTILE = 95.0
#: The fewest samples per pixel the rule judges. Before that a rare light path (a caustic seen through
#: glass, a small light in a mirror) may not have shown up in any pass of a pixel yet, and a pixel whose
#: passes all missed it looks converged; 32 spp are six passes of the doubling ladder (five degrees of freedom).
MIN_SPP = 32

@dataclass(frozen=True)
class StopRule:
    """Render passes until the ``percentile``-th percentile over pixels of the relative standard error of
    luminance is at most ``target``, judged from ``min_spp`` samples per pixel on, at most ``cap``."""

    target: float = DEFAULT_SPP_TARGET  # compare.util.settings says why 5 %
    cap: int = DEFAULT_SPP_CAP
    min_spp: int = MIN_SPP
    percentile: float = PERCENTILE

    def __post_init__(self):
        if not (isinstance(self.target, (int, float)) and math.isfinite(self.target) and self.target > 0):
            raise ValueError(f"target: expected a relative standard error > 0, got {self.target!r}")
        for name in ("cap", "min_spp"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise ValueError(f"{name}: expected a positive number of samples per pixel, got {v!r}")
        if not 0 < self.percentile <= 100:
            raise ValueError(f"percentile: expected a number in (0, 100], got {self.percentile!r}")

    def criterion(self) -> str:
        """The rule in words (results.json and the report state it)."""
        return (f"{_ordinal(self.percentile)} percentile over pixels of luminance's relative standard error "
                f"SE / sqrt(mean² + {EPS:g}), SE from the spread of the independent passes, "
                f"at most {self.target:g}; judged from {self.min_spp} spp on, at most {self.cap} spp")

    def to_json(self) -> dict:
        """JSON-ready dict (also part of a render's key: a changed rule is another ground truth)."""
        return asdict(self)


def _ordinal(p: float) -> str:
    n = f"{p:g}"
    last = n[-1]
    suffix = "th" if n.endswith(("11", "12", "13")) or last not in "123" else {"1": "st", "2": "nd", "3": "rd"}[last]
    return n + suffix


class PassSpread:
    """Running sums of the luminance of a render's independent passes, for :meth:`estimate`."""

    def __init__(self):
        self.sum = self.sum2 = None
        self.spp = 0
        self.passes = 0

    def add(self, image: np.ndarray, spp: int) -> None:
        """One more independent pass: ``image`` is the mean of its ``spp`` samples (H×W×3, linear)."""
        y = luminance(np.asarray(image, dtype=np.float64)[..., :3])
        if self.sum is None:
            self.sum, self.sum2 = np.zeros_like(y), np.zeros_like(y)
        self.sum += spp * y
        self.sum2 += spp * y * y
        self.spp += int(spp)
        self.passes += 1

    def relative_standard_error(self) -> np.ndarray | None:
        """Each pixel's standard error of the mean luminance over ``sqrt(mean² + ε)``; None before two passes."""
        if self.passes < 2:
            return None
        mean = self.sum / self.spp
        per_sample = np.maximum(self.sum2 - self.spp * mean * mean, 0.0) / (self.passes - 1)
        return np.sqrt(per_sample / self.spp / (mean * mean + EPS))

    def estimate(self, rule: StopRule) -> float | None:
        """The rule's statistic for the passes so far (None before two passes)."""
        rel = self.relative_standard_error()
        return None if rel is None else float(np.percentile(rel, rule.percentile))


class Stopping:
    """A render's stopping rule with the spread of its passes so far: the ``until`` of
    :meth:`compare.mitsuba.reference.ReferenceRenderer.iter_checkpoints`."""

    def __init__(self, rule: StopRule):
        self.rule = rule
        self.spread = PassSpread()
        #: [spp, estimate] at each pass sum the rule judged.
        self.history: list[list] = []

    def add(self, image: np.ndarray, spp: int) -> None:
        """One more independent pass (every chunk of the render, in order)."""
        self.spread.add(image, spp)

    def met(self, spp: int) -> bool:
        """Whether the render may stop at ``spp`` samples per pixel (the running sum of its passes): the
        rule's statistic is at most its target (from ``min_spp`` on), or the cap is reached."""
        if spp < self.rule.min_spp and spp < self.rule.cap:
            return False
        estimate = self.spread.estimate(self.rule)
        if estimate is not None:
            self.history.append([int(spp), estimate])
        return spp >= self.rule.cap or (estimate is not None and estimate <= self.rule.target)

    def record(self) -> dict:
        """What results.json keeps of it: the criterion, its target, the estimate and spp reached, whether
        the target was met (else the cap stopped it), and the estimate at each pass sum judged."""
        spp, estimate = self.history[-1] if self.history else (self.spread.spp, None)
        return {"criterion": self.rule.criterion(), "statistic": "relative_standard_error",
                "percentile": self.rule.percentile, "target": self.rule.target, "estimate": estimate,
                "spp": int(spp), "min_spp": self.rule.min_spp, "cap": self.rule.cap,
                "met": estimate is not None and estimate <= self.rule.target, "history": self.history}
