"""The metrics the suite reports: name, heading, digits and direction, in one table.

``compare check`` (which bound is a ceiling and which a floor), the report's tables
and ``compare bench`` read their metrics from here, so a new metric is one row.
"""

from __future__ import annotations

from typing import NamedTuple

__all__ = ["METRICS", "Metric", "higher_is_better"]


class Metric(NamedTuple):
    """One reported metric of a checkpoint against the ground truth."""

    name: str
    heading: str
    digits: int
    higher_is_better: bool = False


#: Every metric of the report's tables, in their order.
METRICS = (
    Metric("flip", "FLIP", 4),
    Metric("flip_median", "FLIP w. median", 4),
    Metric("flip_p95", "FLIP p95", 4),
    Metric("flip_hdr", "HDR-FLIP", 4),
    Metric("ssim", "SSIM", 4, higher_is_better=True),
    Metric("psnr", "PSNR (dB)", 2, higher_is_better=True),
    Metric("relmse", "relMSE", 4),
    Metric("mse", "MSE", 4),
)
_BY_NAME = {m.name: m for m in METRICS}


def higher_is_better(name: str) -> bool:
    """Whether a larger value of metric ``name`` is better (SSIM, PSNR); False for errors and unknown names."""
    m = _BY_NAME.get(name)
    return bool(m and m.higher_is_better)
