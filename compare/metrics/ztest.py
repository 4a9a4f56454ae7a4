"""Per-pixel z-test of two renders: do they converge to the same image?

The test of Mitsuba's own render suite, for any two renders whose per-pixel
variance is known: for every pixel and channel ::

    z = (mean_a - mean_b) / sqrt(var_a + var_b)          var_*: variance of each mean
    p = erfc(|z| / sqrt(2))                              two-sided

and the pixel is *rejected* when ``p`` is below the Šidák-corrected level
``1 - (1 - alpha)^(1/N)`` for the ``N`` values tested, so that two renders of one
image fail with probability ``alpha`` over the whole image, not per pixel. A
value whose two variances are both 0 is tested by equality (an exact pixel must
match exactly). Variances come from independent renders (:func:`pass_statistics`:
the spread of K passes) or from a variance image written beside a render.

A variance estimated from K passes is itself uncertain (K - 1 degrees of
freedom), and ``z`` then follows Student's t, whose tails are far heavier than
the normal's at the per-value levels a whole image needs (1e-6 for 10⁴ values):
with 8 passes per side two renders of one image would fail about one time in
two. Given the degrees of freedom, ``p`` comes from Student's t with the
Welch–Satterthwaite degrees of freedom (Welch's test); without them the variances
are taken as known (the normal distribution).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from compare.util.errors import ImageError

__all__ = ["ZTest", "load_side", "pass_statistics", "z_test"]

#: Default family-wise significance level.
ALPHA = 0.01


@dataclass(frozen=True)
class ZTest:
    """The outcome of :func:`z_test`."""

    values: int
    rejected: int
    alpha: float
    threshold: float
    min_p: float
    max_abs_z: float
    worst: tuple[int, int, int]

    @property
    def passed(self) -> bool:
        """No value is rejected: the renders are consistent with one image."""
        return self.rejected == 0

    def as_dict(self) -> dict:
        return {"values": self.values, "rejected": self.rejected, "alpha": self.alpha, "threshold": self.threshold,
                "min_p": self.min_p, "max_abs_z": self.max_abs_z, "worst": list(self.worst), "passed": self.passed}

    def __str__(self) -> str:
        verdict = "consistent" if self.passed else "NOT consistent"
        y, x, c = self.worst
        return (f"z-test: {verdict}: {self.rejected} of {self.values} values rejected at family-wise "
                f"alpha {self.alpha:g} (per-value p < {self.threshold:.3g}); smallest p {self.min_p:.3g}, "
                f"largest |z| {self.max_abs_z:.3g} at row {y}, column {x}, channel {'RGB'[c]}")


def pass_statistics(passes) -> tuple[np.ndarray, np.ndarray, int]:
    """Mean, variance of the mean and its degrees of freedom (K - 1) of K >= 2 independent renders
    (K, H, W, 3) of equal samples."""
    p = np.asarray(passes, dtype=np.float64)
    if p.ndim != 4 or p.shape[0] < 2 or p.shape[-1] != 3:
        raise ValueError(f"pass_statistics: expected (K >= 2, H, W, 3) independent renders, got shape {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ImageError("pass_statistics: the renders hold NaN or infinite values")
    return p.mean(axis=0), p.var(axis=0, ddof=1) / p.shape[0], int(p.shape[0] - 1)


def _blocks(x: np.ndarray, block: int) -> np.ndarray:
    """Means over ``block`` x ``block`` tiles (edge tiles that do not fit are left out)."""
    h, w = (x.shape[0] // block) * block, (x.shape[1] // block) * block
    return x[:h, :w].reshape(h // block, block, w // block, block, x.shape[2]).mean(axis=(1, 3))


def z_test(mean_a, var_a, mean_b, var_b, *, alpha: float = ALPHA, block: int = 1,
           dof_a: float = math.inf, dof_b: float = math.inf) -> ZTest:
    """Per-pixel two-sample z-test of two renders (see the module notes).

    ``var_a``, ``var_b``: per-pixel variances of the two means (0 for an exact image).
    ``dof_a``, ``dof_b``: degrees of freedom of the variance estimates (K - 1 for K
    passes; inf for a known variance).
    ``block`` > 1 tests the means of ``block`` x ``block`` tiles instead of pixels (the
    images box-filtered down: pixels of independent samples average their variances, so
    a tile's mean has ``block**2`` times less), which sees small changes that cover many
    pixels (a brightness change) at a noise per pixel that hides them; ``worst`` is then
    in tiles.
    """
    from scipy.special import erfc
    from scipy.stats import t as student_t

    a, b = np.asarray(mean_a, dtype=np.float64), np.asarray(mean_b, dtype=np.float64)
    va = np.broadcast_to(np.asarray(var_a, dtype=np.float64), a.shape)
    vb = np.broadcast_to(np.asarray(var_b, dtype=np.float64), b.shape)
    if isinstance(block, bool) or not isinstance(block, (int, np.integer)) or block < 1:
        raise ValueError(f"z_test: block must be a positive integer, got {block!r}")
    if a.ndim == 3 and a.shape == b.shape and block > min(a.shape[:2]):
        raise ValueError(f"z_test: block {block} is larger than the {a.shape[1]}x{a.shape[0]} image")
    if a.shape != b.shape or a.ndim != 3 or a.shape[-1] != 3:
        raise ValueError(f"z_test: expected two (H, W, 3) images of one shape, got {a.shape} and {b.shape}")
    for name, x in (("mean_a", a), ("var_a", va), ("mean_b", b), ("var_b", vb)):
        if not np.all(np.isfinite(x)):
            raise ImageError(f"z_test: {name} holds NaN or infinite values")
    if np.any(va < 0) or np.any(vb < 0):
        raise ValueError("z_test: variances must be >= 0")
    if not (0 < alpha < 1):
        raise ValueError(f"z_test: alpha must lie in (0, 1), got {alpha!r}")
    if block > 1:
        a, b = _blocks(a, block), _blocks(b, block)
        va, vb = _blocks(va, block) / block**2, _blocks(vb, block) / block**2
    var = va + vb
    diff = a - b
    exact = var == 0
    z = np.where(exact, np.where(diff == 0, 0.0, np.inf), np.abs(diff) / np.sqrt(np.where(exact, 1.0, var)))
    if math.isinf(dof_a) and math.isinf(dof_b):
        p = erfc(z / math.sqrt(2.0))
    else:  # Welch-Satterthwaite degrees of freedom per value
        if not (dof_a > 0 and dof_b > 0):
            raise ValueError(f"z_test: degrees of freedom must be > 0, got {dof_a!r} and {dof_b!r}")
        den = va * va / dof_a + vb * vb / dof_b
        dof = np.where(den > 0, var * var / np.where(den > 0, den, 1.0), np.inf)
        p = np.where(exact | np.isinf(dof), erfc(z / math.sqrt(2.0)), 2.0 * student_t.sf(z, np.minimum(dof, 1e12)))
    n = int(z.size)
    threshold = -math.expm1(math.log1p(-alpha) / n)  # 1 - (1 - alpha)^(1/n), exact for small alpha
    worst = np.unravel_index(int(np.argmax(z)), z.shape)
    return ZTest(values=n, rejected=int(np.sum(p < threshold)), alpha=float(alpha), threshold=threshold,
                 min_p=float(p.min()), max_abs_z=float(z.max()), worst=tuple(int(i) for i in worst))


def load_side(path: Path, variance: Path | None, what: str) -> tuple[np.ndarray, np.ndarray | None, float]:
    """(mean, variance of the mean or None, its degrees of freedom) of one side of ``compare diff --ztest``.

    ``path``: an EXR, or a folder of at least two EXRs that are independent renders of
    equal samples (their spread gives the variance). ``variance``: an EXR of the
    per-pixel variance of ``path``'s mean, for a single EXR (its ``dof`` metadata, as
    ``compare run`` writes beside a ground truth, gives the degrees of freedom; else
    the variance is taken as known).
    """
    from compare.image.exr import read_exr

    path = Path(path)
    if path.is_dir():
        files = sorted(path.glob("*.exr"))
        if len(files) < 2:
            raise ImageError(f"{what} {path}: a folder needs at least two EXRs of independent renders "
                             f"(found {len(files)})")
        if variance is not None:
            raise ImageError(f"{what} {path}: give a folder of renders or a variance image, not both")
        images = [read_exr(f)[0] for f in files]
        shapes = {im.shape for im in images}
        if len(shapes) != 1:
            raise ImageError(f"{what} {path}: the renders differ in size ({sorted(shapes)})")
        return pass_statistics(np.stack(images))
    image = read_exr(path)[0].astype(np.float64)
    if variance is None:
        return image, None, math.inf
    var, meta = read_exr(variance)
    var = var.astype(np.float64)
    if var.shape != image.shape:
        raise ImageError(f"{what} variance {variance}: {var.shape[1]}x{var.shape[0]}, but {path} is "
                         f"{image.shape[1]}x{image.shape[0]}")
    if np.any(var < 0):
        raise ImageError(f"{what} variance {variance}: negative values")
    dof = meta.get("dof")  # written beside a ground truth: estimated from its passes
    return image, var, float(dof) if isinstance(dof, (int, float)) and dof > 0 else math.inf
