"""Validated fields of a scene file: every error names the file and the field.

Shared by the scene loader (:mod:`compare.scene.loader`) and the glTF include
(:mod:`compare.scene.include`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from compare.util.errors import SceneError

__all__ = ["Ctx", "boolean", "color", "file_field", "fmt", "number", "require", "table", "unit_vector", "vector"]

class Ctx:
    """Carries the file name for error messages and the scene folder for paths."""

    def __init__(self, path: Path):
        self.path = path
        self.root = path.parent.resolve()
        self.files: list[Path] = []

    def err(self, where: str, msg: str) -> SceneError:
        return SceneError(f"{self.path}: {where}: {msg}")


def fmt(value: Any) -> str:
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, list):
        return "[" + ", ".join(fmt(v) for v in value) + "]"
    if isinstance(value, dict):
        return "a table"
    return str(value)


#: Smallest normal and largest float32 numbers: every renderer computes in float32, where a scene
#: number outside this range (other than 0) turns into 0 or infinity.
_FLOAT32_TINY = 1.1754944e-38
_FLOAT32_MAX = 3.4028235e38


def float32_problem(v: float) -> str | None:
    """Why ``v`` cannot be carried by float32 (None if it can)."""
    if v != 0 and abs(v) < _FLOAT32_TINY:
        return f"{v:g} is below float32's smallest normal number (1.2e-38): every renderer would compute 0"
    if abs(v) > _FLOAT32_MAX:
        return f"{v:g} is beyond float32's range (3.4e38): every renderer would compute infinity"
    return None


def boolean(ctx: Ctx, where: str, v: Any) -> bool:
    if not isinstance(v, bool):
        raise ctx.err(where, f"expected true or false, got {fmt(v)}")
    return v


def number(ctx: Ctx, where: str, v: Any, *, lo: float | None = None, hi: float | None = None,
            positive: bool = False) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ctx.err(where, f"expected a finite number, got {fmt(v)}")
    problem = float32_problem(float(v))
    if problem:
        raise ctx.err(where, problem)
    if positive and v <= 0:
        raise ctx.err(where, f"expected a positive number, got {fmt(v)}")
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        rng = (f"in [{lo:g}, {hi:g}]" if lo is not None and hi is not None
               else f"at most {hi:g}" if hi is not None else f"at least {lo:g}")
        raise ctx.err(where, f"expected a number {rng}, got {fmt(v)}")
    return float(v)


def vector(ctx: Ctx, where: str, v: Any, n: int, *, positive: bool = False, nonnegative: bool = False,
            lo: float | None = None, hi: float | None = None) -> tuple[float, ...]:
    words = {2: "two", 3: "three", 4: "four"}[n]
    kind = "positive " if positive else "non-negative " if nonnegative else ""
    ok = (isinstance(v, list) and len(v) == n
          and all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in v))
    if ok and positive:
        ok = all(x > 0 for x in v)
    if ok and nonnegative:
        ok = all(x >= 0 for x in v)
    if ok and (lo is not None or hi is not None):
        ok = all((lo is None or x >= lo) and (hi is None or x <= hi) for x in v)
    if not ok:
        rng = (f" in [{lo:g}, {hi:g}]" if lo is not None and hi is not None
               else f" at most {hi:g}" if hi is not None else f" at least {lo:g}" if lo is not None else "")
        raise ctx.err(where, f"expected {words} {kind}numbers{rng}, got {fmt(v)}")
    for x in v:
        problem = float32_problem(float(x))
        if problem:
            raise ctx.err(where, problem)
    return tuple(float(x) for x in v)


def color(ctx: Ctx, where: str, v: Any, *, hi: float | None = None) -> tuple[float, float, float]:
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        v = [v, v, v]
    return vector(ctx, where, v, 3, nonnegative=True, hi=hi)  # type: ignore[return-value]


def unit_vector(ctx: Ctx, where: str, v: Any) -> np.ndarray:
    vec = np.asarray(vector(ctx, where, v, 3))
    length = np.linalg.norm(vec)
    if length < 1e-12:
        raise ctx.err(where, f"expected a non-zero direction, got {fmt(v)}")
    return vec / length


def table(ctx: Ctx, where: str, v: Any, allowed: set[str]) -> dict[str, Any]:
    if not isinstance(v, dict):
        raise ctx.err(where, f"expected a table, got {fmt(v)}")
    unknown = sorted(set(v) - allowed)
    if unknown:
        raise ctx.err(f"{where}.{unknown[0]}" if where else unknown[0],
                      f"unknown field (allowed: {', '.join(sorted(allowed))})")
    return v


def require(ctx: Ctx, where: str, table: dict, key: str) -> Any:
    if key not in table:
        raise ctx.err(f"{where}.{key}" if where else key, "missing required field")
    return table[key]


def file_field(ctx: Ctx, where: str, v: Any, suffixes: tuple[str, ...]) -> Path:
    """A file the scene file names, relative to its folder. It may lie outside that folder (``../assets/…``):
    the user wrote the path; the URIs inside a glTF file stay confined to the glTF's own folder
    (:mod:`compare.scene.include`)."""
    if not isinstance(v, str) or not v:
        raise ctx.err(where, f"expected a file path (string), got {fmt(v)}")
    p = Path(v)
    if p.is_absolute():
        raise ctx.err(where, f"path {v!r} is absolute; give it relative to the scene file's folder")
    full = (ctx.root / p).resolve()
    if full.suffix.lower() not in suffixes:
        raise ctx.err(where, f"{v!r}: unsupported file type (expected one of {', '.join(suffixes)})")
    if not full.is_file():
        raise ctx.err(where, f"file {v!r} not found (looked for {full})")
    ctx.files.append(full)
    return full
