"""Statistics of a regression gate: is a candidate worse than its baseline beyond noise?

Three tests, each giving a p-value that :func:`holm` then corrects for the number of
tests made, so that a gate of many scenes, renderers and checkpoints raises a false
alarm with probability ``alpha`` over the whole family, not per test:

* :func:`welch` — Welch's t-test of two samples (each side's independent runs: the
  errors of K seeds, or K repeated timings), one-sided "candidate larger", with the
  interval of the difference of the means (Welch–Satterthwaite degrees of freedom).
  Two samples without spread are compared exactly (a deterministic renderer must
  repeat itself exactly).
* :func:`paired` — the paired t-test of the same, where both sides ran the same seeds:
  the noise a seed puts into both sides cancels in their difference, so a deterministic
  renderer's unchanged code differs by exactly nothing and a small change stands out.
  Seeds are independent of one another, so the differences are too (valid whether or
  not the renderer repeats itself).
* :func:`image_test` — the per-pixel z-test of :mod:`compare.metrics.ztest` on two
  stacks of independent final images; its smallest per-value p, Šidák-adjusted over
  the values tested, is the image's p. With ``block`` > 1 the test is on tile means,
  whose variance is estimated from the seeds' tile means (not from the pixels'
  variances divided by the tile's area): a renderer's noise is correlated between
  pixels (one light sample lights the whole frame), which the tile's own spread sees.
* :func:`holm` — Holm's step-down correction (uniformly more powerful than
  Bonferroni, valid under any dependence between the tests).

The t-tests are scipy's (:func:`scipy.stats.ttest_ind` without equal variances, and
:func:`scipy.stats.ttest_rel`); this module adds what a gate needs around them: samples
without spread compared exactly, and the interval of the difference at a given level.
"""

from __future__ import annotations

import contextlib
import math
import warnings
from dataclasses import dataclass

import numpy as np

__all__ = ["ImageTest", "SeedOutlier", "Welch", "coefficient_of_variation", "holm", "image_test", "paired",
           "seed_outlier", "welch"]


@dataclass(frozen=True)
class Welch:
    """The outcome of :func:`welch` (``candidate - baseline``)."""

    baseline_mean: float
    candidate_mean: float
    diff: float
    low: float
    high: float
    p: float
    dof: float
    n_baseline: int
    n_candidate: int

    @property
    def ratio(self) -> float | None:
        """candidate mean / baseline mean, None for a baseline mean of 0."""
        return None if self.baseline_mean == 0 else self.candidate_mean / self.baseline_mean


def _sample(values, what: str) -> np.ndarray:
    x = np.asarray(values, dtype=np.float64).ravel()
    if x.size < 2:
        raise ValueError(f"welch: {what} needs at least 2 values, got {x.size}")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"welch: {what} holds NaN or infinite values")
    return x


@contextlib.contextmanager
def _rounding_is_no_news():
    """Silence scipy's "precision loss" warning. It fires for a side whose values are equal to within rounding;
    the t-test of those values is still the one asked for, and the gate reports, it does not warn."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Precision loss occurred", category=RuntimeWarning)
        yield


def welch(baseline, candidate, *, level: float = 0.95) -> Welch:
    """Welch's t-test that the candidate's mean is larger than the baseline's (one-sided).

    Parameters
    ----------
    baseline, candidate : sequence of float
        Independent measurements of each side (at least 2 each).
    level : float
        Confidence of the two-sided interval ``[low, high]`` of ``candidate - baseline``.

    Returns
    -------
    Welch
        ``p`` is the one-sided p-value of "candidate > baseline" (:func:`scipy.stats.ttest_ind`,
        ``equal_var=False``), ``dof`` its Welch–Satterthwaite degrees of freedom. Where neither side
        varies, the difference is known exactly: ``p`` is 0 when the candidate is larger, else 1, and
        the interval is the difference itself.
    """
    from scipy.stats import ttest_ind

    a, b = _sample(baseline, "baseline"), _sample(candidate, "candidate")
    ma, mb = float(a.mean()), float(b.mean())
    diff = mb - ma
    if np.ptp(a) == 0 and np.ptp(b) == 0:
        # scipy gives NaN here (0 / 0); without spread the difference is exact. Equal values, not a zero
        # variance: three 0.1s have a variance of 1e-34 in floating point.
        return Welch(ma, mb, diff, diff, diff, 0.0 if diff > 0 else 1.0, math.inf, a.size, b.size)
    with _rounding_is_no_news():
        one_sided = ttest_ind(b, a, equal_var=False, alternative="greater")
        # the interval is two-sided: that of the one-sided test is open above
        ci = ttest_ind(b, a, equal_var=False).confidence_interval(level)
    return Welch(ma, mb, diff, float(ci.low), float(ci.high), float(one_sided.pvalue), float(one_sided.df),
                 a.size, b.size)


@dataclass(frozen=True)
class SeedOutlier:
    """The candidate seed farthest above the baseline's seeds (:func:`seed_outlier`)."""

    p: float
    """Šidák-corrected one-sided p-value of the worst candidate seed against the baseline's distribution."""
    worst: int
    """Index (among the candidate's seeds) of that seed."""
    t: float
    """Its distance above the baseline's mean in prediction-interval units (s·sqrt(1 + 1/n))."""


def seed_outlier(baseline, candidate) -> SeedOutlier:
    """Whether any one candidate seed lies far above the baseline's spread (one-sided).

    A paired or Welch test of the means misses a candidate whose broken seeds widen its own spread as
    much as they move its mean (two seeds of 5 at 125x the error). Here each candidate seed is a new
    observation against the baseline's seeds: t_i = (x_i - mean) / (s sqrt(1 + 1/n)) has Student's t
    distribution with n - 1 degrees of freedom when it comes from the baseline's (normal) distribution;
    the smallest of the m one-sided p-values, Šidák-corrected, is the test's p. Where the baseline's seeds
    agree exactly, a larger candidate seed is a certain change (p 0) and none is p 1.
    """
    from scipy.stats import t as student_t

    a, b = _sample(baseline, "baseline"), _sample(candidate, "candidate")
    mean, sd, n = float(a.mean()), float(a.std(ddof=1)), a.size
    if sd == 0:
        worst = int(np.argmax(b))
        return SeedOutlier(0.0 if b[worst] > mean else 1.0, worst, math.inf if b[worst] > mean else 0.0)
    t = (b - mean) / (sd * math.sqrt(1.0 + 1.0 / n))
    worst = int(np.argmax(t))
    p_one = float(student_t.sf(t[worst], n - 1))
    return SeedOutlier(float(-math.expm1(b.size * math.log1p(-min(p_one, 1.0 - 1e-16)))), worst, float(t[worst]))


def paired(baseline, candidate, *, level: float = 0.95) -> Welch:
    """The paired t-test that the candidate is larger than the baseline (one-sided), value k of each side from
    the same seed (:func:`scipy.stats.ttest_rel`); the interval is that of the mean difference (K - 1 degrees
    of freedom). Differences without spread are known exactly (``p`` 0 when positive, else 1)."""
    from scipy.stats import ttest_rel

    a, b = _sample(baseline, "baseline"), _sample(candidate, "candidate")
    if a.size != b.size:
        raise ValueError(f"paired: {a.size} baseline values but {b.size} candidate values")
    d = b - a
    diff = float(d.mean())
    if np.ptp(d) == 0:
        # scipy gives NaN here (0 / 0); equal differences are exact
        return Welch(float(a.mean()), float(b.mean()), diff, diff, diff, 0.0 if diff > 0 else 1.0, math.inf,
                     a.size, b.size)
    with _rounding_is_no_news():
        one_sided = ttest_rel(b, a, alternative="greater")
        ci = ttest_rel(b, a).confidence_interval(level)  # two-sided, as welch's
    return Welch(float(a.mean()), float(b.mean()), diff, float(ci.low), float(ci.high), float(one_sided.pvalue),
                 float(one_sided.df), a.size, b.size)


def coefficient_of_variation(values) -> float:
    """Sample standard deviation over the mean (inf for a mean of 0 with spread, 0 without)."""
    x = np.asarray(values, dtype=np.float64).ravel()
    if x.size < 2:
        return math.inf
    sd, mean = float(x.std(ddof=1)), float(abs(x.mean()))
    if sd == 0:
        return 0.0
    return sd / mean if mean > 0 else math.inf


def holm(pvalues) -> list[float]:
    """Holm's step-down adjusted p-values, in the order given.

    A test is significant at family-wise level ``alpha`` when its adjusted p is at most
    ``alpha``: the smallest p is multiplied by m, the next by m - 1, …, kept monotone.
    """
    p = [float(x) for x in pvalues]
    m = len(p)
    order = sorted(range(m), key=lambda i: p[i])
    out = [0.0] * m
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (m - rank) * p[i]))
        out[i] = running
    return out


@dataclass(frozen=True)
class ImageTest:
    """The outcome of :func:`image_test`."""

    p: float
    values: int
    min_p: float
    max_abs_z: float
    worst: tuple[int, int, int]
    block: int
    z: np.ndarray

    def significant(self, alpha: float) -> bool:
        """Whether the images differ at level ``alpha`` (by this test alone, before a family's correction)."""
        return self.p <= alpha


def _tiles(stack: np.ndarray, block: int) -> np.ndarray:
    k, h, w, c = stack.shape
    hh, ww = (h // block) * block, (w // block) * block
    return stack[:, :hh, :ww].reshape(k, hh // block, block, ww // block, block, c).mean(axis=(2, 4))


def image_test(baseline, candidate, *, block: int = 1, pair: bool = False) -> ImageTest:
    """Per-value z-test (Welch's t with each value's degrees of freedom) of two stacks of independent
    final images, (K, H, W, 3) each with K >= 2; p is the smallest per-value p, Šidák-adjusted over the
    values tested (the probability that two renders of one image show a value this far apart).

    ``pair``: image k of both sides comes from the same seed; the test is then on the per-seed
    differences (Student's t, K - 1 degrees of freedom), and a value whose difference is the same
    for every seed is tested exactly. ``z`` is the map of |z| (tiles with ``block`` > 1), for the report.
    """
    from scipy.stats import t as student_t

    from compare.metrics.ztest import pass_statistics

    a, b = np.asarray(baseline, dtype=np.float64), np.asarray(candidate, dtype=np.float64)
    if a.ndim != 4 or b.ndim != 4 or a.shape[1:] != b.shape[1:] or a.shape[-1] != 3:
        raise ValueError(f"image_test: expected two stacks (K, H, W, 3) of one image size, got {a.shape} and {b.shape}")
    if isinstance(block, bool) or not isinstance(block, (int, np.integer)) or not 1 <= block <= min(a.shape[1:3]):
        raise ValueError(f"image_test: block must be an integer from 1 to the image's smaller side, got {block!r}")
    if pair and a.shape != b.shape:
        raise ValueError(f"image_test: paired stacks need as many images on each side, got {a.shape} and {b.shape}")
    if block > 1:
        a, b = _tiles(a, block), _tiles(b, block)
    if pair:
        d = b - a
        mean, var = d.mean(axis=0), d.var(axis=0, ddof=1) / d.shape[0]
        exact = var == 0
        diff = np.abs(mean)
        z = np.where(exact, np.where(diff == 0, 0.0, np.inf), diff / np.sqrt(np.where(exact, 1.0, var)))
        p = np.where(exact, np.where(diff == 0, 1.0, 0.0),
                     2.0 * student_t.sf(np.where(exact, 0.0, z), d.shape[0] - 1))
        return _image_result(p, z, block)
    ma, va, da = pass_statistics(a)
    mb, vb, db = pass_statistics(b)
    var = va + vb
    diff = np.abs(mb - ma)
    exact = var == 0
    z = np.where(exact, np.where(diff == 0, 0.0, np.inf), diff / np.sqrt(np.where(exact, 1.0, var)))
    den = va * va / da + vb * vb / db
    dof = np.where(den > 0, var * var / np.where(den > 0, den, 1.0), 1e12)
    p = np.where(exact, np.where(diff == 0, 1.0, 0.0), 2.0 * student_t.sf(np.where(exact, 0.0, z), dof))
    return _image_result(p, z, block)


def _image_result(p: np.ndarray, z: np.ndarray, block: int) -> ImageTest:
    n = int(p.size)
    min_p = float(p.min())
    family = -math.expm1(n * math.log1p(-min_p)) if min_p < 1 else 1.0  # Šidák: 1 - (1 - p)^n
    worst = np.unravel_index(int(np.argmax(z)), z.shape)
    return ImageTest(p=float(family), values=n, min_p=min_p, max_abs_z=float(z.max()),
                     worst=tuple(int(i) for i in worst), block=int(block), z=z)
