"""A benchmark figure: two medians of runs measured side by side and their ratio (``compare bench``)."""

from __future__ import annotations

import math
import statistics
from dataclasses import asdict, dataclass, field

__all__ = ["Figure", "median", "time_to_error"]


@dataclass
class Figure:
    """One benchmark figure: two medians and their ratio (A ÷ B)."""

    name: str
    a: str
    b: str
    a_median: float
    b_median: float
    unit: str
    repeats: int
    note: str = ""
    a_samples: list[float] = field(default_factory=list)
    b_samples: list[float] = field(default_factory=list)

    @property
    def ratio(self) -> float:
        return self.a_median / self.b_median if self.b_median > 0 else math.inf

    def to_json(self) -> dict:
        d = asdict(self)
        d["ratio"] = self.ratio if math.isfinite(self.ratio) else None
        return d


def median(xs) -> float:
    return float(statistics.median(xs))


def time_to_error(seconds: list[float], errors: list[float], target: float) -> float:
    """Seconds at which a log–log interpolated error curve first reaches ``target`` (inf if never).

    Before the first checkpoint nothing is known: if the first checkpoint is
    already below the target, its time is returned (an upper bound).
    """
    for k, (t, e) in enumerate(zip(seconds, errors)):
        if e <= target:
            if k == 0:
                return float(t)
            t0, e0 = seconds[k - 1], errors[k - 1]
            if e0 <= 0 or e <= 0 or e0 == e:
                return float(t)
            f = (math.log(target) - math.log(e0)) / (math.log(e) - math.log(e0))
            return float(math.exp(math.log(t0) + f * (math.log(t) - math.log(t0))))
    return math.inf


