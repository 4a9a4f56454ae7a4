"""The regression gate's settings (a leaf, so that the command line reads its defaults without the gate)."""

from __future__ import annotations

from dataclasses import dataclass

from compare.util.errors import CompareError
from compare.util.settings import documented, option

__all__ = ["ERROR_TESTS", "GateError", "GateSettings"]

#: How the final checkpoint's error may be judged.
ERROR_TESTS = ("seeds", "ztest")


class GateError(CompareError, ValueError):
    """The gate cannot run (e.g. a candidate image named in results.json is missing)."""


@documented
@dataclass(frozen=True)
class GateSettings:
    """The gate's knobs; ``compare check --baseline`` has an option of each name, with this default and text."""

    alpha: float = option(0.01, "family-wise significance level of the whole gate (Holm over every test)")
    metrics: tuple[str, ...] = option(("relmse",), "error metric(s) tested at every checkpoint, comma-separated")
    block: int = option(1, "the image z-test on the means of BLOCK x BLOCK tiles (their variance from the seeds)")
    time_ratio: float = option(1.15, "a slowdown fails only when the mean time grew by at least this ratio "
                                     "(and significantly)")
    max_cv: float = option(0.15, "timings with a larger coefficient of variation (either side) are inconclusive")
    error_test: str = option("seeds", "how the final checkpoint's error is judged: Welch's t-test of the seeds' "
                                      "errors, or the z-test of the final images (they differ and the error grew)")
    fail_on_change: bool = option(False, "a changed final image fails the gate too")
    min_seconds: float = option(0.01, "checkpoints faster than this on both sides (mean seconds) are not timed")

    def __post_init__(self):
        if not 0 < self.alpha < 1:
            raise GateError(f"alpha: expected a level in (0, 1), got {self.alpha!r}")
        if not self.time_ratio >= 1:
            raise GateError(f"time ratio: expected a number >= 1, got {self.time_ratio!r}")
        if not self.min_seconds >= 0:
            raise GateError(f"min seconds: expected a number >= 0, got {self.min_seconds!r}")
        if not self.max_cv > 0:
            raise GateError(f"max cv: expected a number > 0, got {self.max_cv!r}")
        if self.error_test not in ERROR_TESTS:
            raise GateError(f"error test: expected one of {', '.join(map(repr, ERROR_TESTS))}, got {self.error_test!r}")
        if isinstance(self.block, bool) or not isinstance(self.block, int) or self.block < 1:
            raise GateError(f"block: expected a positive integer, got {self.block!r}")
        if not self.metrics:
            raise GateError("metrics: name at least one error metric")
