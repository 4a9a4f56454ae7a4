"""Environment maps: the one direction ↔ equirectangular mapping, loaders, procedural maps, Blender's HDRIs.

Orientation (the convention of Mitsuba 3's ``envmap`` emitter)
---------------------------------------------------------------
A unit direction ``d = (x, y, z)`` in the environment's own frame (world space
when ``rotation = 0``; +Y up, right-handed) maps to equirectangular texture
coordinates ``(u, v)`` in [0, 1)² by::

    u = atan2(x, -z) / (2π)   (wrapped to [0, 1))
    v = acos(y) / π

and back by ``d = (sin 2πu · sin πv, cos πv, −cos 2πu · sin πv)``. So the top
row of the image is straight up (+Y), the bottom row straight down; the left
edge (u = 0) and the right edge look along −Z, the image centre (u = ½, v = ½)
along +Z, u = ¼ along +X and u = ¾ along −X. Seen from inside, the image is
not mirrored: turning from −Z towards +X moves right in the image. This is
``direction_to_uv`` / ``uv_to_direction`` of ``mitsuba3/src/emitters/envmap.cpp``
(``dr::atan2(d.x(), -d.z())``, ``dr::safe_acos(d.y())``), verified by
``tests/test_environment.py`` against Mitsuba renders of a marked map.

Texel positions, as Mitsuba interpolates them (:func:`sample_equirect`):
column ``i`` of a W-wide map sits at ``u = (i + ½)/W`` (columns wrap around),
row ``j`` of an H-high map at ``v = j/(H − 1)``: the first and last rows lie
*on* the poles (not half a texel inside them). Bilinear interpolation between
those positions. The GLSL form (``compare/ibl/mapping.glsl``,
``env_equirect_uv``) reproduces this exactly with a GL_REPEAT × CLAMP_TO_EDGE
linear texture; the IBL preprocessing reads maps with :func:`sample_equirect`.

``rotation`` (degrees about +Y, the scene's ``environment.rotation``) turns the
map with Mitsuba's ``to_world = rotate(axis=[0, 1, 0], angle)``: a world
direction ``d`` looks up the map at ``R⁻¹ d`` (:func:`world_to_env`).

Sources of a map
----------------
* ``file = "x.exr"`` or ``"x.hdr"``: OpenEXR (:func:`compare.image.exr.read_exr`) or
  Radiance RGBE (:func:`read_hdr`), linear radiance.
* ``procedural = "sky" | "studio" | "axes"``: generated here, deterministic, with
  the parameters of :data:`PROCEDURAL` (defaults, ranges, units), written once
  to an EXR in ``<cache>/environments/`` keyed by the parameters and
  :data:`PROCEDURAL_VERSION` (:func:`environment_path`).
* ``blender = "interior"`` etc.: the CC0 studio-light HDRIs that ship inside the
  ``bpy`` wheel (``datafiles/studiolights/world/*.exr``), found without
  importing bpy (:func:`blender_studio_lights`). They are used in *this*
  convention; Blender's own world mapping (Z up) differs, which the Blender
  renderer has to account for.
* ``constant = [r, g, b]``: :func:`environment_image` returns a small uniform map
  so that the rasterizer's IBL code path is the same for every environment.
"""

from __future__ import annotations

import importlib.util
import math
import os
import re
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from compare.util.errors import ImageError, MissingComponentError
from compare.util.files import atomic_path, sha256_bytes

__all__ = [
    "PROCEDURAL",
    "PROCEDURAL_VERSION",
    "blender_studio_lights",
    "direction_to_uv",
    "environment_image",
    "environment_path",
    "equirect_directions",
    "load_equirect",
    "procedural_map",
    "read_hdr",
    "rotation_matrix",
    "sample_equirect",
    "uv_to_direction",
    "validate_procedural",
    "world_to_env",
    "write_hdr",
]

#: Bumped whenever a procedural generator changes its output (part of every cache key).
PROCEDURAL_VERSION = 1
#: Width × height of the uniform map that stands for a ``constant`` environment.
CONSTANT_MAP_SIZE = (16, 8)


# ----------------------------------------------------------------------------- the mapping


def direction_to_uv(d) -> np.ndarray:
    """Equirectangular (u, v) in [0, 1)×[0, 1] of unit directions ``d`` (..., 3) in the map's frame."""
    d = np.asarray(d, dtype=np.float64)
    u = np.arctan2(d[..., 0], -d[..., 2]) / (2.0 * np.pi)
    u = u - np.floor(u)
    v = np.arccos(np.clip(d[..., 1], -1.0, 1.0)) / np.pi
    return np.stack([u, v], axis=-1)


def uv_to_direction(u, v) -> np.ndarray:
    """Unit directions (..., 3) of equirectangular coordinates; the inverse of :func:`direction_to_uv`."""
    phi = 2.0 * np.pi * np.asarray(u, dtype=np.float64)
    theta = np.pi * np.asarray(v, dtype=np.float64)
    s = np.sin(theta)
    return np.stack([np.sin(phi) * s, np.cos(theta), -np.cos(phi) * s], axis=-1)


def rotation_matrix(degrees: float) -> np.ndarray:
    """3×3 map-to-world rotation about +Y by ``degrees`` (Mitsuba's ``rotate(axis=[0, 1, 0], angle)``)."""
    a = math.radians(float(degrees))
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def world_to_env(d, rotation: float = 0.0) -> np.ndarray:
    """World directions (..., 3) in the map's frame (``R⁻¹ d`` for the environment's rotation)."""
    d = np.asarray(d, dtype=np.float64)
    return d @ rotation_matrix(rotation)  # row vectors: d R = (R^T d^T)^T = R^-1 d


def equirect_directions(width: int, height: int) -> np.ndarray:
    """Directions (H, W, 3) of the texel positions (Mitsuba's: u = (i+½)/W, v = j/(H−1))."""
    u = (np.arange(width) + 0.5) / width
    v = np.arange(height) / max(height - 1, 1)
    uu, vv = np.meshgrid(u, v)
    return uv_to_direction(uu, vv)


def sample_equirect(image: np.ndarray, d, rotation: float = 0.0) -> np.ndarray:
    """Radiance of an equirectangular map towards world directions ``d`` (..., 3), bilinear, float64.

    The interpolation is Mitsuba's ``envmap.eval``: columns at (i + ½)/W wrapping
    around, rows at j/(H − 1) with the first and last row on the poles.
    """
    img = np.asarray(image)
    h, w = img.shape[:2]
    uv = direction_to_uv(world_to_env(d, rotation))
    x = uv[..., 0] * w - 0.5
    x = np.mod(x, w)
    y = uv[..., 1] * (h - 1)
    x0 = np.minimum(np.floor(x).astype(np.int64), w - 1)
    y0 = np.clip(np.floor(y).astype(np.int64), 0, h - 2)
    fx = (x - x0)[..., None]
    fy = (y - y0)[..., None]
    x1 = (x0 + 1) % w
    y1 = y0 + 1
    f = img.astype(np.float64, copy=False)
    top = f[y0, x0] * (1 - fx) + f[y0, x1] * fx
    bottom = f[y1, x0] * (1 - fx) + f[y1, x1] * fx
    return top * (1 - fy) + bottom * fy


# ----------------------------------------------------------------------------- Radiance .hdr


_HDR_RES = re.compile(rb"^-Y (\d+) \+X (\d+)$")


def read_hdr(path: str | Path) -> np.ndarray:
    """Read a Radiance RGBE (``.hdr``) file as float32 (H, W, 3) linear RGB.

    Supports flat and run-length-encoded scanlines in the standard orientation
    ``-Y H +X W`` (row 0 at the top). Pixels decode as ``m · 2^(e − 136)``
    (no half-step offset), the convention of Bruce Walter's rgbe.c, which is
    what Mitsuba's ``Bitmap`` reads (tested), so that both renderers see the
    same radiance.

    Raises
    ------
    ImageError
        Naming the file, for a missing or malformed file or another orientation.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ImageError(f"{path}: cannot read: {exc}") from exc
    if not (data.startswith(b"#?RADIANCE") or data.startswith(b"#?RGBE")):
        raise ImageError(f"{path}: not a Radiance .hdr file (expected '#?RADIANCE' at the start)")
    pos = 0
    fmt = None
    while True:
        end = data.find(b"\n", pos)
        if end < 0:
            raise ImageError(f"{path}: truncated header")
        line = data[pos:end].strip()
        pos = end + 1
        if not line:
            break
        if line.startswith(b"FORMAT="):
            fmt = line[7:]
    if fmt not in (None, b"32-bit_rle_rgbe"):
        raise ImageError(f"{path}: unsupported pixel format {fmt!r} (only 32-bit_rle_rgbe)")
    end = data.find(b"\n", pos)
    m = _HDR_RES.match(data[pos:end].strip()) if end >= 0 else None
    if m is None:
        raise ImageError(f"{path}: unsupported resolution line {data[pos:end][:40]!r} (only '-Y H +X W')")
    h, w = int(m.group(1)), int(m.group(2))
    pos = end + 1
    # Each row is at least 4 bytes (an RLE header) and each channel's run covers at most 127 pixels in
    # 2 bytes, so a header claiming more pixels than that is corrupt: refuse it before allocating.
    room = len(data) - pos
    if h < 1 or w < 1 or 4 * h + h * 4 * 2 * math.ceil(w / 127) > room:
        raise ImageError(f"{path}: the header claims {w}×{h} pixels, more than the file's {room} bytes of pixel "
                         "data can hold (corrupt or truncated)")
    buf = np.frombuffer(data, dtype=np.uint8)
    out = np.empty((h, w, 4), dtype=np.uint8)
    try:
        for row in range(h):
            rle = (8 <= w < 32768 and pos + 4 <= len(buf) and buf[pos] == 2 and buf[pos + 1] == 2
                   and not (buf[pos + 2] & 0x80) and (int(buf[pos + 2]) << 8 | int(buf[pos + 3])) == w)
            if not rle:
                out[row] = buf[pos:pos + 4 * w].reshape(w, 4)
                pos += 4 * w
                continue
            pos += 4
            for c in range(4):
                x = 0
                line = out[row, :, c]
                while x < w:
                    count = int(buf[pos])
                    pos += 1
                    if count > 128:
                        count -= 128
                        line[x:x + count] = buf[pos]
                        pos += 1
                    else:
                        line[x:x + count] = buf[pos:pos + count]
                        pos += count
                    x += count
    except (ValueError, IndexError) as exc:
        raise ImageError(f"{path}: truncated or corrupt pixel data ({exc})") from exc
    from compare.image.encodings import rgbe_decode

    return rgbe_decode(out).astype(np.float32)


def write_hdr(path: str | Path, image: np.ndarray) -> Path:
    """Write float (H, W, 3) as a Radiance ``.hdr`` (flat scanlines, atomically); returns the path."""
    from compare.image.encodings import rgbe_encode

    path = Path(path)
    img = np.asarray(image, dtype=np.float64)
    if img.ndim != 3 or img.shape[2] != 3:
        raise ImageError(f"{path}: expected an (H, W, 3) image, got shape {img.shape}")
    h, w = img.shape[:2]
    head = f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n".encode()
    with atomic_path(path) as tmp:
        tmp.write_bytes(head + rgbe_encode(img).tobytes())
    return path


#: Negative values of an environment map down to this fraction of its mean are compression noise
#: and set to zero (Blender's HDRIs: -0.002 against a mean of ~0.5); larger ones are refused.
NEGATIVE_TOLERANCE = 0.01


def load_equirect(path: str | Path) -> np.ndarray:
    """An equirectangular map file (.exr or .hdr) as float32 (H, W, 3), compression noise below zero set to 0.

    Raises ImageError naming the file for a map that is too small, holds NaN or Inf, or holds
    negative radiance beyond :data:`NEGATIVE_TOLERANCE` of its mean (no renderer can emit that,
    and each would treat it differently)."""
    path = Path(path)
    return _checked_equirect(path, _read_equirect(path))


def _read_equirect(path: Path) -> np.ndarray:
    """The map file's pixels as stored."""
    if path.suffix.lower() == ".hdr":
        return read_hdr(path)
    from compare.image.exr import read_exr

    return read_exr(path)[0]


def _checked_equirect(path: Path, img: np.ndarray) -> np.ndarray:
    """:func:`load_equirect`'s checks and clamping of the pixels ``img`` of ``path``."""
    if img.shape[0] < 3 or img.shape[1] < 2:
        raise ImageError(f"{path}: an environment map needs at least 2×3 pixels, got {img.shape[1]}×{img.shape[0]}")
    if not np.all(np.isfinite(img)):
        raise ImageError(f"{path}: an environment map must hold finite radiance (found NaN or Inf)")
    low = float(img.min())
    if low < 0.0:
        mean = float(np.mean(np.maximum(img, 0.0), dtype=np.float64))
        limit = NEGATIVE_TOLERANCE * mean
        if low < -limit:
            count = int(np.count_nonzero(img < -limit))
            raise ImageError(f"{path}: an environment map must hold non-negative radiance: {count} values below "
                             f"-{limit:.3g}, down to {low:.3g} (its mean is {mean:.3g}; only lossy-compression noise "
                             f"within {NEGATIVE_TOLERANCE:.0%} of the mean is set to zero)")
    return np.ascontiguousarray(np.maximum(img, 0.0), dtype=np.float32)


def environment_file(env, cache_dir: str | Path | None = None) -> Path | None:
    """The map file a path tracer should read for ``env``: :func:`environment_path`, or where that file
    holds compression noise below zero, a copy with it set to zero (as :func:`load_equirect` gives the
    rasterizer), written once to ``<cache>/environments/clamped-<content hash>.exr``. The map is
    checked as :func:`load_equirect` checks it."""
    path = environment_path(env, cache_dir)
    if path is None:
        return None
    raw = _read_equirect(path)
    image = _checked_equirect(path, raw)
    if float(np.min(raw)) >= 0.0:
        return path
    from compare.util.files import sha256_bytes

    clamped = _cache_root(cache_dir) / "environments" / f"clamped-{sha256_bytes(raw.tobytes())[:24]}.exr"
    if not clamped.is_file():
        from compare.image.exr import write_exr

        write_exr(clamped, image, metadata={"renderer": "clamped-environment", "source": str(path)})
    return clamped


# ----------------------------------------------------------------------------- procedural maps


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
        "background": Param(0.05, "radiance of the walls (the floor gets half)", lo=0.0),
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
    img = np.where(y >= 0, p["background"] * (0.6 + 0.4 * y), 0.5 * p["background"])[..., None] * np.ones(3)
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


_GENERATORS: dict[str, Callable[[dict[str, Any]], np.ndarray]] = {"sky": _sky, "studio": _studio, "axes": _axes}


def procedural_map(kind: str, params: dict[str, Any] | None = None) -> np.ndarray:
    """Generate a procedural environment (float32, width × width/2 × 3); parameters as :data:`PROCEDURAL`."""
    p = validate_procedural(kind, dict(params or {}))
    return np.ascontiguousarray(_GENERATORS[kind](p), dtype=np.float32)


# ----------------------------------------------------------------------------- Blender studio lights


def blender_studio_lights() -> dict[str, Path]:
    """Blender's bundled world HDRIs, name → file (``{}`` when the ``bpy`` wheel is not installed).

    Found from the installed package's location without importing bpy (which
    is slow and starts Blender): in this interpreter, else in the environment of
    ``$COMPARE_BLENDER_PYTHON`` (bpy's own environment, as the test command sets up).
    """
    roots: list[str] = []
    try:
        spec = importlib.util.find_spec("bpy")
    except (ImportError, ValueError):
        spec = None
    if spec is not None:
        roots = list(spec.submodule_search_locations or [])
        if not roots and spec.origin:
            roots = [str(Path(spec.origin).parent)]
    other = os.environ.get("COMPARE_BLENDER_PYTHON")
    if not roots and other:
        # <env>/bin/python → <env>/lib/python3.X/{site,dist}-packages/bpy (not resolved: a venv's python
        # is a link to the base interpreter, whose own packages are elsewhere)
        exe = Path(shutil.which(other) or other)
        roots = [str(p) for p in sorted(exe.parent.parent.glob("lib/python3*/*-packages/bpy"))]
    if not roots:
        return {}
    found: dict[str, Path] = {}
    for root in roots:
        for f in sorted(Path(root).glob("*/datafiles/studiolights/world/*.exr")):
            found.setdefault(f.stem, f)
    return found


def blender_studio_light(name: str) -> Path:
    """The file of Blender's studio light ``name``; raises when bpy is missing or the name is unknown."""
    lights = blender_studio_lights()
    if not lights:
        raise MissingComponentError(
            f"blender = {name!r}: Blender's studio-light HDRIs come with the 'blender' extra "
            "(`pip install compare-pbr[blender]`, the bpy wheel), which is not installed")
    if name not in lights:
        raise ValueError(f"blender: unknown Blender studio light {name!r} (available: {', '.join(sorted(lights))})")
    return lights[name]


# ----------------------------------------------------------------------------- scene environments


def _cache_root(cache_dir: str | Path | None) -> Path:
    if cache_dir is not None:
        return Path(cache_dir)
    from compare.util.cache import default_cache_dir

    return default_cache_dir()


def procedural_key(kind: str, params: dict[str, Any]) -> str:
    """Content key of a procedural map (kind, every parameter, generator version)."""
    p = validate_procedural(kind, params)
    return sha256_bytes("procedural-environment", str(PROCEDURAL_VERSION), kind, repr(sorted(p.items())))


def environment_path(env, cache_dir: str | Path | None = None) -> Path | None:
    """The equirectangular file of a scene environment (None for a constant one).

    A procedural map is generated on first use and written atomically to
    ``<cache>/environments/<kind>-<key>.exr`` (cache: ``cache_dir`` or
    :func:`compare.mitsuba.reference.default_cache_dir`).
    """
    if env is None or getattr(env, "constant", None) is not None:
        return None
    if getattr(env, "file", None) is not None:
        return Path(env.file)
    if getattr(env, "blender", None):
        return blender_studio_light(env.blender)
    kind = getattr(env, "procedural", None)
    if kind:
        params = dict(env.parameters)
        key = procedural_key(kind, params)
        path = _cache_root(cache_dir) / "environments" / f"{kind}-{key[:24]}.exr"
        if not path.is_file():
            from compare.image.exr import write_exr

            write_exr(path, procedural_map(kind, params),
                      metadata={"renderer": "procedural-environment", "procedural": kind,
                                "procedural_version": PROCEDURAL_VERSION, "key": key})
        return path
    raise ValueError("environment: has neither constant, file, procedural nor blender")


def environment_image(env, cache_dir: str | Path | None = None) -> np.ndarray:
    """The environment's equirectangular radiance map (float32 H×W×3), *without* ``intensity``.

    A constant environment gives a uniform :data:`CONSTANT_MAP_SIZE` map of its colour.
    """
    if getattr(env, "constant", None) is not None:
        w, h = CONSTANT_MAP_SIZE
        return np.ascontiguousarray(np.broadcast_to(np.asarray(env.constant, dtype=np.float32), (h, w, 3)))
    return load_equirect(environment_path(env, cache_dir))
