"""Procedural environments (``[environment] procedural = "sky" | "studio" | "axes"``): their parameters,
written once (defaults, ranges, units), and the maps they make."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from compare.scene.equirect import equirect_directions, uv_to_direction
from compare.util.files import sha256_bytes

__all__ = ["PROCEDURAL", "PROCEDURAL_VERSION", "procedural_key", "procedural_map", "validate_procedural"]


#: Bumped whenever a procedural generator changes its output (part of every cache key).
PROCEDURAL_VERSION = 1


@dataclass(frozen=True)
class Param:
    """One parameter of a procedural environment."""

    default: Any
    doc: str
    kind: str = "number"  # number | color | int
    lo: float | None = None
    hi: float | None = None


def _sky_params() -> dict[str, Param]:
    return {
        "sun_elevation": Param(35.0, "sun height above the horizon, degrees", lo=-90.0, hi=90.0),
        "sun_azimuth": Param(60.0, "degrees from −Z towards +X (u = azimuth / 360)"),
        "sun_size": Param(0.53, "angular diameter of the sun disk, degrees", lo=0.01, hi=30.0),
        "sun_radiance": Param(3.6e4, "radiance of the sun disk (times sun_color)", lo=0.0),
        "sun_color": Param((1.0, 0.96, 0.9), "tint of the sun disk", kind="color"),
        "zenith": Param((0.10, 0.22, 0.55), "sky radiance straight up", kind="color"),
        "horizon": Param((0.55, 0.65, 0.80), "sky radiance at the horizon", kind="color"),
        "ground": Param((0.10, 0.09, 0.08), "radiance of the ground below the horizon", kind="color"),
        "glow": Param(2.0, "radiance of the glow around the sun (falls off over ~10 degrees)", lo=0.0),
        "width": Param(1024, "map width in pixels (height = width / 2)", kind="int", lo=8, hi=16384),
    }


def _studio_params() -> dict[str, Param]:
    return {
        "key": Param(20.0, "radiance of the key soft box (azimuth 45°, elevation 35°, 40°×30°)", lo=0.0),
        "fill": Param(6.0, "radiance of the fill soft box (azimuth −60°, elevation 15°, 35°×25°)", lo=0.0),
        "rim": Param(12.0, "radiance of the rim soft box (azimuth 170°, elevation 40°, 20°×40°)", lo=0.0),
        "walls": Param(0.05, "radiance of the walls (the floor gets half)", lo=0.0),
        "softness": Param(3.0, "width of the soft boxes' edge falloff, degrees", lo=0.0, hi=20.0),
        "width": Param(1024, "map width in pixels (height = width / 2)", kind="int", lo=8, hi=16384),
    }


def _axes_params() -> dict[str, Param]:
    return {
        "width": Param(256, "map width in pixels (height = width / 2)", kind="int", lo=8, hi=16384),
        "spot_size": Param(12.0, "angular radius of the coloured spots, degrees", lo=1.0, hi=40.0),
    }


#: Procedural environments: name → (parameters with defaults, documentation).
PROCEDURAL: dict[str, tuple[dict[str, Param], str]] = {
    "sky": (_sky_params(), "a sky gradient over a dark ground with a sun disk (default 3.6e4) and its glow"),
    "studio": (_studio_params(), "a dim studio with three rectangular soft boxes (key, fill, rim)"),
    "axes": (_axes_params(), "an orientation test map: a coloured spot on each axis (+X red, −X cyan, "
                             "+Y green, −Y magenta, +Z blue, −Z yellow) and a white spot at azimuth 30°, "
                             "elevation 20°, over a dim latitude gradient"),
}


def validate_procedural(kind: str, params: dict[str, Any]) -> dict[str, Any]:
    """Check a procedural environment's parameters; returns them complete (defaults filled in).

    Raises ``ValueError("<field>: <message>")`` for an unknown kind or parameter
    or a bad value; the scene loader prefixes the file name.
    """
    if kind not in PROCEDURAL:
        raise ValueError(f"procedural: expected one of {', '.join(map(repr, PROCEDURAL))}, got {kind!r}")
    spec = PROCEDURAL[kind][0]
    unknown = sorted(set(params) - set(spec))
    if unknown:
        raise ValueError(f"{unknown[0]}: unknown parameter of procedural = {kind!r} (allowed: {', '.join(spec)})")
    out: dict[str, Any] = {}
    for name, p in spec.items():
        v = params.get(name, p.default)
        if p.kind == "color":
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                v = (v, v, v)
            ok = (isinstance(v, (list, tuple)) and len(v) == 3
                  and all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) and x >= 0
                          for x in v))
            if not ok:
                raise ValueError(f"{name}: expected three non-negative numbers, got {v!r}")
            out[name] = tuple(float(x) for x in v)
            continue
        if p.kind == "int":
            if isinstance(v, bool) or not isinstance(v, int):
                raise ValueError(f"{name}: expected an integer, got {v!r}")
        elif isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ValueError(f"{name}: expected a finite number, got {v!r}")
        if (p.lo is not None and v < p.lo) or (p.hi is not None and v > p.hi):
            lo = "-inf" if p.lo is None else f"{p.lo:g}"
            hi = "inf" if p.hi is None else f"{p.hi:g}"
            raise ValueError(f"{name}: expected a value in [{lo}, {hi}], got {v!r}")
        out[name] = int(v) if p.kind == "int" else float(v)
    return out


def _supersampled_directions(width: int, height: int, n: int, rows=None, cols=None) -> np.ndarray:
    """Directions spread n × n over each texel's footprint around Mitsuba's texel positions.

    Shape (H, W, n², 3) for the whole map, or (K, n², 3) for the texels (rows[k], cols[k]).
    """
    o = (np.arange(n) + 0.5) / n - 0.5
    if rows is None:
        rows, cols = np.meshgrid(np.arange(height), np.arange(width), indexing="ij")
    rows, cols = np.asarray(rows), np.asarray(cols)
    u = (cols[..., None, None] + 0.5 + o[None, :, None]) / width            # (..., n, 1): along u
    v = (rows[..., None, None] + o[None, None, :]) / max(height - 1, 1)    # (..., 1, n): along v
    u, v = np.broadcast_arrays(u, np.clip(v, 0.0, 1.0))
    return uv_to_direction(u, v).reshape(rows.shape + (n * n, 3))


def _az_el_direction(azimuth: float, elevation: float) -> np.ndarray:
    a, e = math.radians(azimuth), math.radians(elevation)
    return np.array([math.sin(a) * math.cos(e), math.sin(e), -math.cos(a) * math.cos(e)])


def _sky(p: dict[str, Any]) -> np.ndarray:
    w = p["width"]
    h = w // 2
    d = equirect_directions(w, h)
    y = d[..., 1:2]
    zenith, horizon, ground = (np.asarray(p[k]) for k in ("zenith", "horizon", "ground"))
    sky = horizon + (zenith - horizon) * np.sqrt(np.clip(y, 0.0, 1.0))
    blend = np.clip(-y / 0.05, 0.0, 1.0)  # 3 degrees of haze below the horizon
    img = np.where(y >= 0, sky, horizon + (ground - horizon) * (blend * blend * (3 - 2 * blend)))
    s = _az_el_direction(p["sun_azimuth"], p["sun_elevation"])
    angle = np.arccos(np.clip(d @ s, -1.0, 1.0))
    img = img + p["glow"] * np.exp(-angle / math.radians(10.0))[..., None] * np.asarray(p["sun_color"]) * (y >= 0)
    # The disk, antialiased: 8×8 sub-samples in the texels near it.
    radius = math.radians(p["sun_size"]) / 2
    texel = 2 * math.pi / w
    near = angle < radius + 3 * texel
    if near.any():
        rows, cols = np.nonzero(near)
        sub = _supersampled_directions(w, h, 8, rows, cols)
        cover = (np.arccos(np.clip(sub @ s, -1.0, 1.0)) < radius).mean(axis=-1)
        img[rows, cols] += (cover * p["sun_radiance"])[:, None] * np.asarray(p["sun_color"])
    return img


def _studio(p: dict[str, Any]) -> np.ndarray:
    w = p["width"]
    h = w // 2
    sub = _supersampled_directions(w, h, 2)
    y = sub[..., 1]
    img = np.where(y >= 0, p["walls"] * (0.6 + 0.4 * y), 0.5 * p["walls"])[..., None] * np.ones(3)
    soft = max(math.radians(p["softness"]), 1e-6)
    for name, az, el, sw, sh in (("key", 45.0, 35.0, 40.0, 30.0), ("fill", -60.0, 15.0, 35.0, 25.0),
                                 ("rim", 170.0, 40.0, 20.0, 40.0)):
        c = _az_el_direction(az, el)
        t = np.cross([0.0, 1.0, 0.0], c)
        t /= np.linalg.norm(t)
        b = np.cross(c, t)
        dc = sub @ c
        ax = np.arctan2(sub @ t, dc)
        ay = np.arctan2(sub @ b, dc)
        fx = np.clip((math.radians(sw / 2) - np.abs(ax)) / soft + 0.5, 0.0, 1.0)
        fy = np.clip((math.radians(sh / 2) - np.abs(ay)) / soft + 0.5, 0.0, 1.0)
        img = img + (p[name] * fx * fy * (dc > 0))[..., None]
    return img.mean(axis=2)


def _axes(p: dict[str, Any]) -> np.ndarray:
    w = p["width"]
    h = w // 2
    sub = _supersampled_directions(w, h, 2)
    y = sub[..., 1:2]
    img = (0.05 + 0.05 * (y + 1.0)) * np.ones(3)
    r = math.radians(p["spot_size"])
    spots = [((1, 0, 0), (4.0, 0.2, 0.2)), ((-1, 0, 0), (0.2, 3.0, 3.0)), ((0, 1, 0), (0.2, 4.0, 0.2)),
             ((0, -1, 0), (3.0, 0.2, 3.0)), ((0, 0, 1), (0.2, 0.2, 4.0)), ((0, 0, -1), (3.0, 3.0, 0.2)),
             (tuple(_az_el_direction(30.0, 20.0)), (6.0, 6.0, 6.0))]
    for axis, color in spots:
        angle = np.arccos(np.clip(sub @ np.asarray(axis, dtype=np.float64), -1.0, 1.0))
        # A ring-shaped spot (a dark annulus inside it), to see where its centre lands.
        inside = (angle < r) & ~((angle < 0.45 * r) & (angle > 0.25 * r))
        img = img + inside[..., None] * np.asarray(color)
    return img.mean(axis=2)


def procedural_map(kind: str, params: dict[str, Any] | None = None) -> np.ndarray:
    """Generate a procedural environment (float32, width × width/2 × 3); parameters as :data:`PROCEDURAL`."""
    p = validate_procedural(kind, dict(params or {}))
    return np.ascontiguousarray(_GENERATORS[kind](p), dtype=np.float32)


def procedural_key(kind: str, params: dict[str, Any]) -> str:
    """Content key of a procedural map (kind, every parameter, generator version)."""
    p = validate_procedural(kind, params)
    return sha256_bytes("procedural-environment", str(PROCEDURAL_VERSION), kind, repr(sorted(p.items())))


_GENERATORS: dict[str, Callable[[dict[str, Any]], np.ndarray]] = {"sky": _sky, "studio": _studio, "axes": _axes}
