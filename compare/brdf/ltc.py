"""Linearly transformed cosine (LTC) table of the suite's specular lobe.

Heitz, Dupuy, Hill & Neubelt, "Real-Time Polygonal-Light Shading with Linearly
Transformed Cosines", SIGGRAPH 2016. In the local frame (normal z, view
``v = (sin, 0, cos)``, x along the view's projection) the lobe
``f(l) = D V max(l.z, 0)`` of :mod:`compare.brdf` (Fresnel 1; its magnitude
``integral f`` is the split sum's A + B, and the consumer applies Fresnel as
``F0 A + B``) is approximated by ``magnitude * D_ltc``, the clamped cosine
transformed by a 3 x 3 matrix M::

    D_ltc(l) = D_o(M^-1 l / |M^-1 l|) |det M^-1| / |M^-1 l|^3,   D_o(w) = max(w.z, 0) / pi

The table
---------
``minv`` (64, 64, 4) float32, ``[j, i] = (a, b, c, d)``: column i is the
perceptual roughness ``i / 63``, row j is ``sqrt(1 - cos(theta_v)) = j / 63``
(``cos = 1 - (j / 63)**2``, raised to ``COS_MIN = 1e-4`` in the last row:
theta 89.994 deg). The entries are M^-1 divided by its middle element (which
leaves the normalised distribution unchanged)::

    M^-1 = [[a, 0, c],        GLSL: mat3(vec3(a, 0, b), vec3(0, 1, 0), vec3(c, 0, d))
            [0, 1, 0],        (three.js' ltc_1 layout)
            [b, 0, d]]

read with a linear texture fetch at ``uv = (r, sqrt(1 - cos)) 63/64 + 0.5/64``
(:func:`ltc_matrix`); :func:`polygon_integral` is the GLSL's polygon integral.
The file ``ltc_table.npz`` also holds ``fit_error`` and ``magnitude`` (64, 64)
float32 and the fit's settings; ``python -m tools.fit_ltc`` fits and rewrites it
(minutes; ``docs/performance-notes.md``).

"""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np

from compare.util.errors import MissingComponentError
from compare.brdf import (COS_MIN)

__all__ = [
    "TABLE_PATH",
    "TABLE_SIZE",
    "cell_view",
    "load_table",
    "ltc_matrix",
    "polygon_integral",
    "polygon_vector_form_factor",
    "unit_rows",
]

#: Grid size of the committed table (both axes).
TABLE_SIZE = 64
#: The committed table, written by ``python -m tools.fit_ltc``.
TABLE_PATH = Path(__file__).with_name("ltc_table.npz")


def cell_view(n: int, j: int, i: int) -> tuple[float, float]:
    """Perceptual roughness and cos(theta_v) of cell ``[j, i]`` of an ``n x n`` table.

    ``roughness = i / (n - 1)``; ``cos = 1 - (j / (n - 1))**2``, raised to
    :data:`compare.brdf.COS_MIN` (the BRDF's own cosine floor, 1e-4) so that the
    last row, at the horizon, keeps a view direction above it.
    """
    x = j / (n - 1)
    return i / (n - 1), max(1.0 - x * x, COS_MIN)


def load_table(path=None, size: int = TABLE_SIZE) -> np.ndarray:
    """The LTC table ``minv`` (size, size, 4) float32, ``[j, i] = (a, b, c, d)``.

    ``M^-1 = [[a, 0, c], [0, 1, 0], [b, 0, d]]`` (row-major; GLSL:
    ``mat3(vec3(a, 0, b), vec3(0, 1, 0), vec3(c, 0, d))``); see the module notes.

    Parameters
    ----------
    path : path-like, optional
        Default: the committed :data:`TABLE_PATH`.
    size : int
        The expected table size.

    Raises
    ------
    MissingComponentError
        The file is missing, unreadable, of the wrong shape or not finite; the
        message names it and the command that rewrites it.
    """
    path = Path(TABLE_PATH if path is None else path)
    command = ("python -m tools.fit_ltc" + ("" if path == TABLE_PATH else f" --out {path}")
               + ("" if size == TABLE_SIZE else f" --n {size}"))

    def fail(problem):
        return MissingComponentError(f"{path}: {problem}; rewrite the LTC table with `{command}`")

    try:
        with np.load(path, allow_pickle=False) as data:
            minv = np.asarray(data["minv"])
    except FileNotFoundError:
        raise fail("no such file") from None
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
        raise fail(f"not a readable LTC table ({type(exc).__name__}: {exc})") from exc
    if minv.shape != (size, size, 4):
        raise fail(f"minv has shape {minv.shape}, expected {(size, size, 4)}")
    if not np.all(np.isfinite(minv)):
        raise fail("minv holds NaN or Inf")
    return minv.astype(np.float32)


def ltc_matrix(table: np.ndarray, roughness: float, cos_theta: float) -> np.ndarray:
    """M^-1 (3, 3) at (roughness, cos_theta), read from ``table`` as the GLSL does.

    A bilinear (GL ``LINEAR``, clamp-to-edge) fetch at
    ``uv = (r, sqrt(1 - cos)) (N - 1) / N + 0.5 / N``, so that texel centres are
    the grid points of :func:`cell_view`; r and cos are clamped to [0, 1].
    """
    table = np.asarray(table, dtype=np.float64)
    n = table.shape[0]
    uv = np.array([np.clip(roughness, 0.0, 1.0), np.sqrt(1.0 - np.clip(cos_theta, 0.0, 1.0))])
    x = (uv * (n - 1) / n + 0.5 / n) * n - 0.5  # texel coordinates, centres at integers
    lo = np.floor(x).astype(int)
    t = x - lo
    i0, j0 = np.clip(lo, 0, n - 1)
    i1, j1 = np.clip(lo + 1, 0, n - 1)
    a, b, c, d = ((1 - t[1]) * ((1 - t[0]) * table[j0, i0] + t[0] * table[j0, i1])
                  + t[1] * ((1 - t[0]) * table[j1, i0] + t[0] * table[j1, i1]))
    return np.array([[a, 0.0, c], [0.0, 1.0, 0.0], [b, 0.0, d]])


def unit_rows(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows of x normalised, and their lengths."""
    length = np.sqrt(np.sum(x * x, axis=-1))
    return x / length[..., None], length


def _clip_below(q: np.ndarray) -> np.ndarray:
    """The part of the convex polygon q (K, 3) with z >= 0 (Sutherland-Hodgman, one plane)."""
    clipped = []
    for a, b in zip(q, np.roll(q, -1, axis=0)):
        if a[2] >= 0.0:
            clipped.append(a)
        if (a[2] >= 0.0) != (b[2] >= 0.0):
            clipped.append(a + (b - a) * (a[2] / (a[2] - b[2])))
    return np.array(clipped).reshape(-1, 3)


def polygon_integral(minv: np.ndarray, polygon_local) -> float:
    """Integral of the normalised LTC of ``minv`` over a polygon, as the GLSL evaluates it.

    The vertices (K, 3), relative to the shading point in the local frame (x along
    the view's projection, z the normal), are clipped to the surface's horizon
    z >= 0 (the lobe is zero below it, while the LTC of a grazing view has mass
    there), transformed by ``minv``, clipped again to z >= 0 (the clamped cosine's
    horizon; on the straight edges: the planes pass through the origin, so this is
    exact), projected on the unit sphere, and the clamped
    cosine ``max(z, 0) / pi`` is integrated over the spherical polygon by
    Lambert's edge formula ``sum acos(v_k . v_k+1) normalize(v_k x v_k+1).z / (2 pi)``.
    The result is taken in absolute value (any winding, as the GLSL's ``abs``):
    0 for a polygon below the horizon, 1 for one covering the upper hemisphere
    when ``minv`` keeps the horizon (identity, normal incidence).
    """
    return float(abs(polygon_vector_form_factor(minv, polygon_local)[2]))


def polygon_vector_form_factor(minv: np.ndarray, polygon_local) -> np.ndarray:
    """The vector form factor (3,) of the polygon clipped and transformed as in :func:`polygon_integral`:
    ``sum acos(v_k . v_k+1) normalize(v_k x v_k+1) / (2 pi)``, in the transformed space (sign by
    winding). Its z is the LTC's integral, its direction the mean direction of the lit part."""
    local = _clip_below(np.asarray(polygon_local, dtype=np.float64))
    if len(local) < 3:
        return np.zeros(3)
    p = _clip_below(local @ np.asarray(minv, dtype=np.float64).T)
    p = p[np.any(p != 0.0, axis=1)]  # the shading point has no direction
    if len(p) < 3:
        return np.zeros(3)
    p, _ = unit_rows(p)
    nxt = np.roll(p, -1, axis=0)
    cross = np.cross(p, nxt)
    sin = np.linalg.norm(cross, axis=-1)
    ok = sin > 0.0  # repeated vertices (clipping at a vertex on the horizon) add nothing
    angle = np.arccos(np.clip(np.sum(p * nxt, axis=-1)[ok], -1.0, 1.0))
    return np.sum((angle / sin[ok])[:, None] * cross[ok], axis=0) / (2.0 * np.pi)


