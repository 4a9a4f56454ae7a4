"""``compare check``: gate CI on quality thresholds.

A thresholds file (TOML) is a list of rules; each rule selects checkpoints of
``results.json`` and bounds some of their metrics::

    schema = 1

    [[rule]]
    scene = "Cornell box"       # scene name as in results.json; "*" = every scene
    size = "64x48"              # "WIDTHxHEIGHT"; "*" or left out = every size
    renderer = "progressive"    # renderer spec as in --renderers; "*" = every run
    step = "final"              # "final" (default) or an integer frame/spp count
    max = { flip = 0.25, relmse = 0.6 }   # value must be <= limit
    min = { ssim = 0.80 }                 # value must be >= limit
    note = "why these numbers"  # optional, printed with a violation

Values that can be bounded: every metric of
:func:`compare.metrics.images.compare_images` (``flip``, ``flip_median``, ``flip_p95``, ``flip_hdr``, ``ssim``,
``psnr``, ``mse``, ``relmse``), ``one_minus_ssim``, and the run's timings
``seconds`` (cumulative at that checkpoint), ``first_frame_seconds`` and
``setup_seconds``.

Strictness, because a gate that silently passes is worse than none:

* a rule that matches no checkpoint is a violation (a renamed scene or a
  missing renderer must not turn the gate green);
* a bounded value that is missing or ``null`` is a violation;
* unknown keys in the file are errors (a typo such as ``maximum`` would
  otherwise disable a bound).
"""

from __future__ import annotations

import fnmatch
import math
import os
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from compare.util.errors import CompareError
from compare.metrics.table import METRICS, known
from compare.report.results import Point, RendererRun, Results, metric_value

__all__ = [
    "Rule",
    "ThresholdsError",
    "Violation",
    "assert_thresholds",
    "check",
    "load_thresholds",
]

_RULE_KEYS = {"scene", "size", "renderer", "step", "max", "min", "note"}
_TIMINGS = ("seconds", "first_frame_seconds", "setup_seconds")


class ThresholdsError(CompareError, ValueError):
    """The thresholds file is missing or malformed (the message names the rule and field)."""


@dataclass(frozen=True)
class Rule:
    """One ``[[rule]]`` of a thresholds file (see the module docstring)."""

    index: int
    scene: str = "*"
    size: str = "*"
    renderer: str = "*"
    step: int | str = "final"
    max: tuple[tuple[str, float], ...] = ()
    min: tuple[tuple[str, float], ...] = ()
    note: str = ""

    def describe(self) -> str:
        """Short human-readable selector, e.g. ``rule 2 (Cornell box, 64x48, progressive, final)``."""
        return f"rule {self.index} ({self.scene}, {self.size}, {self.renderer}, {self.step})"


@dataclass(frozen=True)
class Violation:
    """A bound crossed, a value missing, or a rule that matched nothing."""

    rule: Rule
    message: str

    def __str__(self) -> str:
        note = f" — {self.rule.note}" if self.rule.note else ""
        return f"{self.message}  [{self.rule.describe()}{note}]"


def _bounds(raw: Any, where: str) -> tuple[tuple[str, float], ...]:
    if raw is None:
        return ()
    if not isinstance(raw, dict):
        raise ThresholdsError(f"{where}: expected a table such as {{ flip = 0.2 }}, got {raw!r}")
    out = []
    for name, v in raw.items():
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
            raise ThresholdsError(f"{where}.{name}: expected a finite number, got {v!r}")
        if not (known(str(name)) or name in _TIMINGS):
            raise ThresholdsError(f"{where}.{name}: unknown metric; expected one of "
                                  f"{', '.join([m.name for m in METRICS] + list(_TIMINGS))}")
        out.append((str(name), float(v)))
    return tuple(out)


def _parse_rules(data: dict, origin: str) -> list[Rule]:
    schema = data.get("schema", 1)
    if schema != 1:
        raise ThresholdsError(f"{origin}: schema {schema!r} is not supported (expected 1)")
    unknown = set(data) - {"schema", "rule"}
    if unknown:
        raise ThresholdsError(f"{origin}: unknown top-level keys {sorted(unknown)}; rules go in [[rule]] tables")
    raw_rules = data.get("rule", [])
    if not isinstance(raw_rules, list) or not raw_rules:
        raise ThresholdsError(f"{origin}: no [[rule]] tables; a thresholds file needs at least one rule")
    rules = []
    for i, raw in enumerate(raw_rules, start=1):
        where = f"{origin}: rule {i}"
        if not isinstance(raw, dict):
            raise ThresholdsError(f"{where}: expected a table")
        bad = set(raw) - _RULE_KEYS
        if bad:
            raise ThresholdsError(f"{where}: unknown keys {sorted(bad)}; allowed: {sorted(_RULE_KEYS)}")
        step = raw.get("step", "final")
        if not (step == "final" or (isinstance(step, int) and not isinstance(step, bool) and step >= 1)):
            raise ThresholdsError(f"{where}.step: expected \"final\" or a positive integer, got {step!r}")
        for key in ("scene", "size", "renderer", "note"):
            if key in raw and not isinstance(raw[key], str):
                raise ThresholdsError(f"{where}.{key}: expected a string, got {raw[key]!r}")
        rule = Rule(index=i, scene=raw.get("scene", "*"), size=raw.get("size", "*"),
                    renderer=raw.get("renderer", "*"), step=step, max=_bounds(raw.get("max"), f"{where}.max"),
                    min=_bounds(raw.get("min"), f"{where}.min"), note=raw.get("note", ""))
        if not rule.max and not rule.min:
            raise ThresholdsError(f"{where}: no bounds; give max = {{...}} and/or min = {{...}}")
        rules.append(rule)
    return rules


def load_thresholds(source: str | os.PathLike | dict) -> list[Rule]:
    """Read and validate a thresholds file (or an already parsed dict).

    Raises
    ------
    ThresholdsError
        For a missing file, invalid TOML, or a malformed rule.
    """
    if isinstance(source, dict):
        return _parse_rules(source, "thresholds")
    path = Path(source)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ThresholdsError(f"{path}: no such file") from None
    except (OSError, tomllib.TOMLDecodeError) as e:
        raise ThresholdsError(f"{path}: {e}") from e
    return _parse_rules(data, str(path))


def _matches(pattern: str, value: str) -> bool:
    # Exact match first: scene names may contain glob characters such as '['.
    return pattern == value or pattern == "*" or fnmatch.fnmatchcase(value, pattern)


def _select(rule: Rule, run: RendererRun) -> Point | None:
    if rule.step == "final":
        return run.final if run.points else None
    return next((p for p in run.points if p.step == rule.step), None)


def _value(name: str, run: RendererRun, point: Point) -> float | None:
    if name == "seconds":
        return point.seconds
    if name in _TIMINGS:
        return float(getattr(run, name))
    return metric_value(point.metrics, name)


def check(results: Results | str | os.PathLike, thresholds: str | os.PathLike | dict | list[Rule]) -> tuple[list[Violation], int]:
    """Apply every rule to every matching checkpoint.

    Parameters
    ----------
    results : Results or path
        The results (or the path of ``results.json``).
    thresholds : path, dict or list of Rule
        The thresholds file, its parsed TOML, or rules from :func:`load_thresholds`.

    Returns
    -------
    violations : list of Violation
        Empty when every bound holds.
    checked : int
        Number of bounds evaluated (for the "all N passed" line).
    """
    res = results if isinstance(results, Results) else Results.load(results)
    rules = thresholds if isinstance(thresholds, list) else load_thresholds(thresholds)
    violations: list[Violation] = []
    checked = 0
    for rule in rules:
        matched = 0
        for scene in res.scenes:
            if not (_matches(rule.scene, scene.name) and _matches(rule.size, scene.size)):
                continue
            for run in scene.runs:
                if not _matches(rule.renderer, run.renderer):
                    continue
                point = _select(rule, run)
                where = f"{scene.name} {scene.size} {run.renderer}"
                if point is None:
                    violations.append(Violation(rule, f"{where}: no checkpoint at {run.unit} {rule.step}"))
                    matched += 1
                    continue
                where += f" ({run.unit} {point.step})"
                matched += 1
                for bounds, op in ((rule.max, "max"), (rule.min, "min")):
                    for name, limit in bounds:
                        checked += 1
                        v = _value(name, run, point)
                        if v is None:
                            violations.append(Violation(rule, f"{where}: {name} {_why_missing(name, point)}"))
                        elif op == "max" and v > limit:
                            violations.append(Violation(rule, f"{where}: {name} = {v:.6g} > max {limit:g}"))
                        elif op == "min" and v < limit:
                            violations.append(Violation(rule, f"{where}: {name} = {v:.6g} < min {limit:g}"))
        if matched == 0:
            violations.append(Violation(rule, "matched no result: check the scene name, size and renderer "
                                              f"(results hold {_inventory(res)})"))
    return violations, checked


def _why_missing(name: str, point: Point) -> str:
    """Why a metric has no value: a degenerate ground truth (compare.metrics.images), or absent."""
    from compare.metrics.images import LDR_DEGENERATE_RANGE, LDR_METRICS

    spread = point.metrics.get("ldr_range")
    ldr = name in LDR_METRICS or name == "one_minus_ssim"
    if ldr and spread is not None and spread < LDR_DEGENERATE_RANGE:
        return (f"is undefined: the ground truth tone-maps to a constant (LDR range {spread:.3g} < 1/255: black, "
                "saturated or flat) at this exposure, so there is nothing to compare")
    return "is not available (missing or null in results.json)"


def _inventory(res: Results) -> str:
    items = sorted({f"{s.name!r} {s.size} [{', '.join(r.renderer for r in s.runs)}]" for s in res.scenes})
    return "; ".join(items) or "no scenes"


def assert_thresholds(results: Results | str | os.PathLike,
                      thresholds: str | os.PathLike | dict | list[Rule]) -> None:
    """pytest helper: fail with the readable list of every crossed threshold.

    Raises
    ------
    AssertionError
        Listing every violation, one per line.
    """
    violations, checked = check(results, thresholds)
    if violations:
        lines = "\n".join(f"  - {v}" for v in violations)
        raise AssertionError(f"{len(violations)} threshold violation(s) out of {checked} bound(s):\n{lines}")


# --------------------------------------------------------------------------- CLI




