"""HDR encodings of the web-PBR seed documents, with their round-trip error.

Every encoder takes linear float RGB (..., 3) and returns what an 8-bit RGBA
texture would store (uint8); every decoder returns float64 radiance. The
rasterizer decodes the same way in GLSL (``compare/ibl/ibl.glsl``).

RGBM (Karis 2009)
    ``M = ceil(255 · clamp(max(rgb)/R, 1e-6, 1)) / 255``, stored
    ``(rgb / (R·M), M)``, decoded ``R · rgb · M``, with ``R = 6`` (linear, as in
    Karis' post). Channels above R are **clipped** to R (a 3.6e4 sun keeps
    6/3.6e4 of its radiance). Relative precision is about 1/255 of the pixel's
    brightest channel; darker channels of a saturated colour lose more.
RGBM, sqrt, range 7 (WebGL Insights, "HDR image formats for WebGL")
    The same on ``sqrt(rgb)`` with ``R = 7``: decoded ``(7 · rgb · M)²``, so the
    largest representable value is 49; precision is spent more evenly over
    the range (relative error ≈ 2/255 over most of it).
RGBE (Ward 1991, Radiance)
    A shared 8-bit exponent: ``e = frexp(max(rgb))``, mantissas
    ``floor(c · 256 / 2^e)``, decoded ``m · 2^(e − 136)``. Range
    ~1e-38 … 1.7e38, relative precision ~1/256 of the largest channel. Hardware
    cannot filter it (the exponent does not interpolate), so it is decoded
    before use. ``offset=0.5`` decodes Radiance-style at the mantissa's
    centre (unbiased); the default 0 matches Walter's rgbe.c and Mitsuba.
Octahedral (Engelhardt & Dachsbacher 2008)
    A direction maps to the unit square by projecting onto the octahedron
    ``|x|+|y|+|z| = 1`` and folding the lower half outwards
    (:func:`octahedral_encode` / :func:`octahedral_decode`). One square texture
    per prefiltered level, laid into an atlas where each level has a 1-pixel
    border copied from its mirror neighbours (:func:`octahedral_pad`), so that
    hardware bilinear filtering is seamless across the folds.

:func:`roundtrip_stats` measures an encoding's relative error on real HDR data.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "RGBM_KARIS",
    "RGBM_SQRT7",
    "decode",
    "encode",
    "octahedral_decode",
    "octahedral_directions",
    "octahedral_encode",
    "octahedral_pad",
    "rgbe_decode",
    "rgbe_encode",
    "rgbm_decode",
    "rgbm_encode",
    "rgbm_max",
    "roundtrip_stats",
]

#: Karis' RGBM: linear, range 6.
RGBM_KARIS = {"scale": 6.0, "sqrt": False}
#: The WebGL Insights variant: sqrt encoding, range 7, maximum 49.
RGBM_SQRT7 = {"scale": 7.0, "sqrt": True}

ENCODINGS = ("rgbm", "rgbm7sqrt", "rgbe")


def rgbm_max(scale: float = 6.0, sqrt: bool = False) -> float:
    """Largest value an RGBM variant represents (6 for Karis, 49 for sqrt with range 7)."""
    return scale * scale if sqrt else scale


def rgbm_encode(rgb, *, scale: float = 6.0, sqrt: bool = False) -> np.ndarray:
    """RGBM-encode linear RGB (..., 3) into uint8 (..., 4); see the module notes."""
    c = np.maximum(np.asarray(rgb, dtype=np.float64), 0.0)
    if sqrt:
        c = np.sqrt(c)
    c = c / scale
    m = np.clip(np.max(c, axis=-1), 1e-6, 1.0)
    m = np.ceil(m * 255.0) / 255.0
    rgb8 = np.clip(np.round(c / m[..., None] * 255.0), 0, 255)
    return np.concatenate([rgb8, np.round(m * 255.0)[..., None]], axis=-1).astype(np.uint8)


def rgbm_decode(rgbm, *, scale: float = 6.0, sqrt: bool = False) -> np.ndarray:
    """Decode RGBM uint8 (..., 4) (or floats in [0, 1]) to linear RGB float64."""
    x = np.asarray(rgbm)
    x = x.astype(np.float64) / 255.0 if x.dtype == np.uint8 else x.astype(np.float64)
    c = scale * x[..., :3] * x[..., 3:4]
    return c * c if sqrt else c


def rgbe_encode(rgb) -> np.ndarray:
    """Ward's RGBE: uint8 (..., 4), a shared exponent; zero (and below 1e-32) encodes as 0."""
    c = np.maximum(np.asarray(rgb, dtype=np.float64), 0.0)
    v = np.max(c, axis=-1)
    mant, exp = np.frexp(v)  # v = mant · 2^exp, mant in [0.5, 1)
    ok = v > 1e-32
    factor = np.where(ok, mant * 256.0 / np.where(ok, v, 1.0), 0.0)
    rgb8 = np.clip(np.floor(c * factor[..., None]), 0, 255)
    e8 = np.where(ok, np.clip(exp + 128, 0, 255), 0)
    return np.concatenate([rgb8, e8[..., None]], axis=-1).astype(np.uint8)


def rgbe_decode(rgbe, *, offset: float = 0.0) -> np.ndarray:
    """Decode RGBE uint8 (..., 4): ``(m + offset) · 2^(e − 136)``, 0 where e = 0."""
    x = np.asarray(rgbe, dtype=np.uint8)
    e = x[..., 3].astype(np.int64)
    f = np.where(e > 0, np.ldexp(1.0, e - 136), 0.0)
    return (x[..., :3].astype(np.float64) + offset) * f[..., None]


def encode(name: str, rgb) -> np.ndarray:
    """Encode with ``"rgbm"`` (Karis), ``"rgbm7sqrt"`` or ``"rgbe"``."""
    if name == "rgbm":
        return rgbm_encode(rgb, **RGBM_KARIS)
    if name == "rgbm7sqrt":
        return rgbm_encode(rgb, **RGBM_SQRT7)
    if name == "rgbe":
        return rgbe_encode(rgb)
    raise ValueError(f"encoding: expected one of {', '.join(map(repr, ENCODINGS))}, got {name!r}")


def decode(name: str, data) -> np.ndarray:
    """Inverse of :func:`encode`."""
    if name == "rgbm":
        return rgbm_decode(data, **RGBM_KARIS)
    if name == "rgbm7sqrt":
        return rgbm_decode(data, **RGBM_SQRT7)
    if name == "rgbe":
        return rgbe_decode(data)
    raise ValueError(f"encoding: expected one of {', '.join(map(repr, ENCODINGS))}, got {name!r}")


def encoding_max(name: str) -> float:
    """Largest value an encoding can hold (per channel)."""
    if name == "rgbm":
        return rgbm_max(**RGBM_KARIS)
    if name == "rgbm7sqrt":
        return rgbm_max(**RGBM_SQRT7)
    if name == "rgbe":
        return float(np.ldexp(255.0, 127 - 8))
    raise ValueError(f"encoding: expected one of {', '.join(map(repr, ENCODINGS))}, got {name!r}")


def roundtrip_stats(name: str, rgb, *, floor: float = 1e-3) -> dict[str, float]:
    """Relative round-trip error of an encoding on HDR data.

    Parameters
    ----------
    name : {"rgbm", "rgbm7sqrt", "rgbe"}
    rgb : array_like (..., 3)
        Linear radiance (e.g. an environment map).
    floor : float, keyword-only
        Channels below ``floor`` × the data's mean are left out of the relative
        statistics (their relative error is meaningless; they are in ``rmse_rel``).

    Returns
    -------
    dict
        ``mean_rel``, ``median_rel``, ``p99_rel``, ``max_rel`` over channels that
        are in range and above the floor; ``clipped`` (fraction of pixels whose
        largest channel exceeds the encoding's maximum), ``energy_lost`` (the
        fraction of the total radiance lost, mostly to clipping); ``rmse_rel``
        (RMS error over all channels / mean value); ``max_value`` (the
        encoding's maximum).
    """
    x = np.asarray(rgb, dtype=np.float64).reshape(-1, 3)
    y = decode(name, encode(name, x))
    top = encoding_max(name)
    in_range = np.max(x, axis=-1) <= top
    mean = float(x.mean())
    sel = in_range[:, None] & (x > floor * mean)
    rel = np.abs(y - x)[sel] / x[sel]
    return {
        "mean_rel": float(rel.mean()) if rel.size else 0.0,
        "median_rel": float(np.median(rel)) if rel.size else 0.0,
        "p99_rel": float(np.percentile(rel, 99)) if rel.size else 0.0,
        "max_rel": float(rel.max()) if rel.size else 0.0,
        "clipped": float(1.0 - in_range.mean()),
        "energy_lost": float(1.0 - y.sum() / x.sum()) if x.sum() > 0 else 0.0,
        "rmse_rel": float(np.sqrt(np.mean((y - x) ** 2)) / mean) if mean > 0 else 0.0,
        "max_value": top,
    }


# ----------------------------------------------------------------------------- octahedral


def octahedral_encode(d) -> np.ndarray:
    """Unit directions (..., 3) → octahedral coordinates in [0, 1]² (..., 2).

    Projected onto ``|x|+|y|+|z| = 1`` and looked at along Y: the upper half
    (y ≥ 0) fills the inner diamond, the lower half folds out into the corners.
    (+Y at the centre, −Y at the four corners.)
    """
    d = np.asarray(d, dtype=np.float64)
    p = d / np.sum(np.abs(d), axis=-1, keepdims=True)
    a, b, y = p[..., 0], p[..., 2], p[..., 1]
    sa = np.where(a >= 0, 1.0, -1.0)
    sb = np.where(b >= 0, 1.0, -1.0)
    fa = np.where(y < 0, (1.0 - np.abs(b)) * sa, a)
    fb = np.where(y < 0, (1.0 - np.abs(a)) * sb, b)
    return np.stack([fa, fb], axis=-1) * 0.5 + 0.5


def octahedral_decode(uv) -> np.ndarray:
    """Octahedral coordinates (..., 2) in [0, 1]² → unit directions (..., 3); inverse of the encoder."""
    f = np.asarray(uv, dtype=np.float64) * 2.0 - 1.0
    a, b = f[..., 0], f[..., 1]
    y = 1.0 - np.abs(a) - np.abs(b)
    t = np.maximum(-y, 0.0)
    a = a - np.where(a >= 0, t, -t)
    b = b - np.where(b >= 0, t, -t)
    d = np.stack([a, y, b], axis=-1)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def octahedral_directions(size: int) -> np.ndarray:
    """Directions (size, size, 3) of the texel centres of a size × size octahedral map (row = v)."""
    c = (np.arange(size) + 0.5) / size
    uu, vv = np.meshgrid(c, c)
    return octahedral_decode(np.stack([uu, vv], axis=-1))


def octahedral_pad(level: np.ndarray) -> np.ndarray:
    """Add the 1-pixel border of an octahedral map (S, S, C) → (S+2, S+2, C).

    Across each edge the map continues mirrored: the neighbour of texel (x, 0)
    above the top edge is (S−1−x, 0) (the same point of the sphere's fold), and
    likewise for the other edges; each corner takes the diagonally opposite
    corner texel (all four corners are −Y).
    """
    s = level.shape[0]
    out = np.empty((s + 2, s + 2) + level.shape[2:], dtype=level.dtype)
    out[1:-1, 1:-1] = level
    out[0, 1:-1] = level[0, ::-1]
    out[-1, 1:-1] = level[-1, ::-1]
    out[1:-1, 0] = level[::-1, 0]
    out[1:-1, -1] = level[::-1, -1]
    out[0, 0] = level[-1, -1]
    out[0, -1] = level[-1, 0]
    out[-1, 0] = level[0, -1]
    out[-1, -1] = level[0, 0]
    return out
