"""The metrics the suite reports: name, heading, digits and direction, in one table.

The report's tables are made from it and ``compare check`` accepts the names in it
(a bound on any other name is refused, naming the known ones); a test checks that
every metric a run writes has its row. A new metric is one row.
"""

from __future__ import annotations

from typing import NamedTuple

__all__ = ["METRICS", "Metric", "higher_is_better", "known"]


class Metric(NamedTuple):
    """One reported metric of a checkpoint against the ground truth."""

    name: str
    heading: str
    digits: int
    higher_is_better: bool = False
    #: Whether the report's metric tables show it (the others are in results.json and ``check``).
    shown: bool = True


#: Every metric of a checkpoint, the report's tables' in their order first.
METRICS = (
    Metric("flip", "FLIP", 4),
    Metric("flip_median", "FLIP w. median", 4),
    Metric("flip_p95", "FLIP p95", 4),
    Metric("flip_hdr", "HDR-FLIP", 4),
    Metric("ssim", "SSIM", 4, higher_is_better=True),
    Metric("psnr", "PSNR (dB)", 2, higher_is_better=True),
    # model-viewer's fidelity figure (compare.metrics.model_viewer): 10·log10 of the RMS of pixelmatch's
    # YIQ distance over its maximum, on the 8-bit images; lower is better, 0 dB the worst, model-viewer
    # fails a scenario above −22 dB; −100 dB (the floor) for identical images, null for a ground truth
    # that tone-maps to a constant
    Metric("mv_rms_db", "model-viewer RMS (dB)", 4),
    Metric("relmse", "relMSE", 4),
    Metric("mse", "MSE", 4),
    # derived and diagnostic values (compare.report.results.metric_value, compare.metrics.images)
    Metric("one_minus_ssim", "1 − SSIM", 4, shown=False),
    Metric("ldr_range", "LDR range of the ground truth", 4, higher_is_better=True, shown=False),
    # the split into bias and noise of runs with --seeds K (compare.metrics.bias)
    Metric("mse_mean", "MSE, mean of the seeds", 4, shown=False),
    Metric("variance", "variance", 4, shown=False),
    Metric("bias2", "bias²", 4, shown=False),
    Metric("bias2_ci", "bias² 95 % half-width", 4, shown=False),
    Metric("relmse_mean", "relMSE, mean of the seeds", 4, shown=False),
    Metric("rel_variance", "relative variance", 4, shown=False),
    Metric("rel_bias2", "relative bias²", 4, shown=False),
    Metric("rel_bias2_ci", "relative bias² 95 % half-width", 4, shown=False),
    Metric("truth_variance", "the ground truth's own variance", 4, shown=False),
    Metric("rel_truth_variance", "the ground truth's own relative variance", 4, shown=False),
    Metric("seeds", "seeds", 0, higher_is_better=True, shown=False),
)
_BY_NAME = {m.name: m for m in METRICS}


def higher_is_better(name: str) -> bool:
    """Whether a larger value of metric ``name`` is better (SSIM, PSNR); False for errors and unknown names."""
    m = _BY_NAME.get(name)
    return bool(m and m.higher_is_better)


def known(name: str) -> bool:
    """Whether ``name`` is a metric of the table."""
    return name in _BY_NAME
