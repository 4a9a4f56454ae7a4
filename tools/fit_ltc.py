"""Fit the linearly transformed cosine table of the shared BRDF's specular lobe (``compare/brdf/ltc_table.npz``,
served by :mod:`compare.brdf.ltc`): ``python -m tools.fit_ltc`` (minutes; ``docs/performance-notes.md``).

The fit
-------
Heitz's (his ``fitLTC.cpp``): per cell ``M = [X Y Z] [[m11, 0, m13], [0, m22, 0],
[0, 0, 1]]`` with Z the lobe's mean direction; Nelder-Mead on
``sum |f - magnitude D_ltc|^3 / (pdf_ltc + pdf_brdf)`` over 32 x 32 stratified
samples of the LTC and as many of the BRDF (GGX visible normals here); isotropic
at normal incidence; each fit starts from the previous one, from roughness 1 to
0 along normal incidence and from there towards grazing per roughness.

Accuracy: ``fit_error = integral |f - magnitude D_ltc| / integral f`` (over the
sphere, so the LTC's mass below the horizon counts). The error grows towards
grazing, where a clamped cosine cannot follow a lobe cut by the horizon; it is
close to that of Heitz's published GGX table evaluated the same way (both in
``docs/performance-notes.md``).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import NamedTuple

import numpy as np
from scipy.optimize import minimize
from tqdm import tqdm

from compare.brdf import (ALPHA_MIN, COS_MIN, H_LEN2_MIN, alpha_from_roughness, ggx_d, sample_ggx_vndf, smith_g1,
                          smith_v_height_correlated)
from compare.brdf.ltc import TABLE_PATH, TABLE_SIZE, cell_view, unit_rows as _unit


#: Samples per axis of each of the two fixed stratified sets of the fitting objective (Heitz's Nsample).
FIT_SAMPLES = 32


#: (m11, m22, m13) the first cell's fit starts from (roughness 1, normal incidence): a clamped cosine.
START_PARAMS = (1.0, 1.0, 0.0)


_AVERAGE_SAMPLES = 128  # per axis: the lobe's magnitude and mean direction (VNDF midpoints)


_ERROR_SAMPLES = 256  # per axis and technique: the reported relative L1 error (jittered)


_ERROR_SEED = 20160724  # seed of that jitter: any fixed value, independent of the fit's midpoints


_SIMPLEX_STEP = 0.05  # Heitz's initial simplex size, here in relative units (see _fit_params)


_XATOL = 1e-4  # Nelder-Mead stops when the simplex is this small (relative, see _fit_params) ...


_FATOL = 1e-7  # ... and the objective, scaled to 1 at the start, varies by less than this over it


_MAXITER = 600


def _midpoints(m: int) -> np.ndarray:
    """The m*m cell centres of the unit square, (m*m, 2): Heitz's fixed sample set."""
    c = (np.arange(m) + 0.5) / m
    a, b = np.meshgrid(c, c, indexing="ij")
    return np.stack([a.ravel(), b.ravel()], axis=-1)


def _jittered(m: int, rng: np.random.Generator) -> np.ndarray:
    """m*m jittered-stratified points of the unit square, (m*m, 2)."""
    return _midpoints(m) + (rng.random((m * m, 2)) - 0.5) / m


def _cosine_dirs(u: np.ndarray) -> np.ndarray:
    """Cosine-distributed unit directions (pdf ``w.z / pi``) from uniform points u (..., 2)."""
    s = np.sqrt(1.0 - u[..., 0])
    phi = 2.0 * np.pi * u[..., 1]
    return np.stack([s * np.cos(phi), s * np.sin(phi), np.sqrt(u[..., 0])], axis=-1)


class _Lobe:
    """The fitted lobe ``f(l) = D V max(l.z, 0)`` (Fresnel 1) of one view, and its sampling.

    Local frame: normal z, view ``v = (sin, 0, cos)``.
    """

    def __init__(self, roughness: float, cos_theta: float):
        self.alpha = float(alpha_from_roughness(roughness))
        self.v = np.array([np.sqrt(1.0 - cos_theta * cos_theta), 0.0, cos_theta])
        # Visible-normal density of the reflected direction, D(h) G1(v) / (4 v.z), without D.
        self._pdf_scale = float(smith_g1(cos_theta, self.alpha)) / (4.0 * cos_theta)

    def eval(self, l: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # noqa: E741
        """f(l) and the density with which :meth:`sample` draws l, for unit l (..., 3).

        The density is that of every direction the sampler produces, those below
        the horizon included (where f is 0; :func:`compare.brdf.pdf_ggx_vndf_reflection`
        is 0 there): both enter the fitting error.
        """
        hu = self.v + l
        len2 = np.sum(hu * hu, axis=-1)
        h = hu / np.sqrt(np.maximum(len2, H_LEN2_MIN))[..., None]
        d = ggx_d(np.clip(h[..., 2], 0.0, 1.0), self.alpha, h[..., 0] ** 2 + h[..., 1] ** 2)
        pdf = np.where(h[..., 2] > 0.0, d * self._pdf_scale, 0.0)  # visible normals have h.z > 0
        lz = l[..., 2]
        front = (lz > 0.0) & (len2 > H_LEN2_MIN)  # the BRDF's own one-sidedness and h guard
        f = np.where(front, d * smith_v_height_correlated(self.v[2], lz, self.alpha) * lz, 0.0)
        return f, pdf

    def sample(self, u: np.ndarray) -> np.ndarray:
        """Directions l = reflect(v, h), h a GGX visible normal, from uniform points u (..., 2)."""
        shape = u.shape[:-1]
        v = np.broadcast_to(self.v, shape + (3,))
        h = sample_ggx_vndf(v, np.full(shape, self.alpha), u)
        return 2.0 * np.sum(v * h, axis=-1, keepdims=True) * h - v

    def average(self) -> tuple[float, np.ndarray]:
        """The magnitude ``integral f`` and the unit mean direction of f (in the xz-plane)."""
        l = self.sample(_midpoints(_AVERAGE_SAMPLES))  # noqa: E741
        f, pdf = self.eval(l)
        weight = f / pdf  # pdf > 0 for every sampled direction
        mean = np.mean(weight[:, None] * l, axis=0)
        mean[1] = 0.0  # zero for an isotropic lobe; removes the sampling noise
        return float(np.mean(weight)), mean / np.linalg.norm(mean)


def _ltc_m(frame: np.ndarray, params) -> np.ndarray:
    """``M = [X Y Z] [[m11, 0, m13], [0, m22, 0], [0, 0, 1]]`` (Heitz's parametrisation)."""
    m11, m22, m13 = params
    return frame @ np.array([[m11, 0.0, m13], [0.0, m22, 0.0], [0.0, 0.0, 1.0]])


def _ltc_density(minv: np.ndarray, l: np.ndarray) -> np.ndarray:  # noqa: E741
    """The normalised LTC ``D_o(M^-1 l / |M^-1 l|) |det M^-1| / |M^-1 l|^3`` at unit l (..., 3)."""
    q = l @ minv.T
    q2 = np.sum(q * q, axis=-1)
    return np.maximum(q[..., 2], 0.0) * abs(np.linalg.det(minv)) / (np.pi * q2 * q2)


class _Objective:
    """Heitz's fitting error of one cell, vectorised over his two fixed sample sets.

    ``sum |f - f_ltc|^3 / (pdf_ltc + pdf_brdf)`` over 32 x 32 stratified samples
    drawn from the LTC and as many from the BRDF, ``f_ltc = magnitude D_ltc``.
    """

    def __init__(self, lobe: _Lobe, magnitude: float, frame: np.ndarray):
        u = _midpoints(FIT_SAMPLES)
        self.lobe, self.magnitude, self.frame = lobe, magnitude, frame
        self.w = _cosine_dirs(u)  # LTC samples before the transform, density w.z / pi
        self.l_brdf = lobe.sample(u)
        self.f_brdf, self.pdf_brdf = lobe.eval(self.l_brdf)  # fixed: only the LTC moves

    def __call__(self, params) -> float:
        m = _ltc_m(self.frame, params)
        det_m = abs(np.linalg.det(m))
        # LTC samples l = M w / |M w|: their density is (w.z / pi) |M w|^3 / |det M|.
        l, length = _unit(self.w @ m.T)  # noqa: E741
        pdf_ltc = self.w[:, 2] / np.pi * length ** 3 / det_m
        f, pdf_brdf = self.lobe.eval(l)
        err = np.sum(np.abs(f - self.magnitude * pdf_ltc) ** 3 / (pdf_ltc + pdf_brdf))
        pdf_ltc = _ltc_density(np.linalg.inv(m), self.l_brdf)
        err += np.sum(np.abs(self.f_brdf - self.magnitude * pdf_ltc) ** 3 / (pdf_ltc + self.pdf_brdf))
        return float(err) / len(self.w)


def _fit_params(objective: _Objective, start, isotropic: bool) -> tuple[float, float, float]:
    """Nelder-Mead from ``start = (m11, m22, m13)``; isotropic: m11 = m22, m13 = 0, one parameter.

    Heitz's simplex has an absolute size of 0.05, which is 25 lobe widths at the
    smallest alpha; here the coordinates are relative instead: ``log m11``,
    ``log m22`` (which also keeps them positive) and ``m13 / m11_start``. The
    objective is divided by its value at the start so that one tolerance serves
    lobes whose peak values differ by eight orders of magnitude.
    """
    m11, m22, m13 = (float(p) for p in start)
    if isotropic:
        x0 = np.array([np.log(m11)])

        def unpack(x):
            return np.exp(x[0]), np.exp(x[0]), 0.0
    else:
        scale = m11
        x0 = np.array([np.log(m11), np.log(m22), m13 / scale])

        def unpack(x):
            return np.exp(x[0]), np.exp(x[1]), x[2] * scale
    e0 = objective(unpack(x0))
    simplex = x0 + np.vstack([np.zeros(len(x0)), _SIMPLEX_STEP * np.eye(len(x0))])
    res = minimize(lambda x: objective(unpack(x)) / e0, x0, method="Nelder-Mead",
                   options={"initial_simplex": simplex, "xatol": _XATOL, "fatol": _FATOL,
                            "maxiter": _MAXITER})
    return tuple(float(p) for p in unpack(res.x))


def _relative_l1(lobe: _Lobe, magnitude: float, m: np.ndarray) -> float:
    """``integral |f - magnitude D_ltc| / integral f`` over the sphere.

    Multiple importance sampling (balance heuristic) of both lobes with jittered
    stratified points independent of the fit's: every sample's weight is bounded
    (``f / pdf_brdf = G2 / G1 <= 1``, ``magnitude D_ltc / pdf_ltc = magnitude``), so the estimate is
    accurate to a fraction of a percent of its value. The LTC's mass below the
    horizon, where f is 0, counts as error.
    """
    rng = np.random.default_rng(_ERROR_SEED)
    minv = np.linalg.inv(m)
    l_brdf = lobe.sample(_jittered(_ERROR_SAMPLES, rng))
    l_ltc, _ = _unit(_cosine_dirs(_jittered(_ERROR_SAMPLES, rng)) @ m.T)
    total = 0.0
    for l in (l_brdf, l_ltc):  # noqa: E741
        f, pdf_brdf = lobe.eval(l)
        pdf_ltc = _ltc_density(minv, l)
        total += np.sum(np.abs(f - magnitude * pdf_ltc) / (pdf_brdf + pdf_ltc))
    return float(total / len(l_brdf) / magnitude)


class CellFit(NamedTuple):
    """The fit of one table cell.

    Attributes
    ----------
    params : tuple of float
        (m11, m22, m13) of M in the frame of the lobe's mean direction; the next
        cell's fit starts from them.
    entries : ndarray, shape (4,)
        The table's (a, b, c, d): M^-1 / M^-1[1][1] at [row][column] [0][0], [2][0], [0][2], [2][2].
    magnitude : float
        ``integral f``, the lobe's directional albedo (split-sum A + B).
    fit_error : float
        Relative L1 error of the LTC, ``integral |f - magnitude D_ltc| / integral f``.
    """

    params: tuple[float, float, float]
    entries: np.ndarray
    magnitude: float
    fit_error: float


def fit_cell(n: int, j: int, i: int, start=START_PARAMS) -> CellFit:
    """Fit the LTC of cell ``[j, i]`` of an ``n x n`` table, Nelder-Mead from ``start``.

    Row ``j = 0`` (normal incidence) is fitted isotropic, in the frame of the
    normal (``m11 = m22``, ``m13 = 0``); other rows in the frame whose Z is the
    lobe's mean direction, X orthogonal to it in the xz-plane, Y = (0, 1, 0).
    :func:`fit_table` chains the starts as Heitz does.

    Parameters
    ----------
    n, j, i : int
        Table size, row (view angle) and column (roughness); see :func:`cell_view`.
    start : (m11, m22, m13)
        The starting point, the neighbouring cell's :attr:`CellFit.params`.
    """
    roughness, cos_theta = cell_view(n, j, i)
    lobe = _Lobe(roughness, cos_theta)
    magnitude, mean_dir = lobe.average()
    if j == 0:
        frame, isotropic = np.eye(3), True
    else:
        x_axis = np.array([mean_dir[2], 0.0, -mean_dir[0]])
        frame, isotropic = np.stack([x_axis, [0.0, 1.0, 0.0], mean_dir], axis=-1), False
    params = _fit_params(_Objective(lobe, magnitude, frame), start, isotropic)
    m = _ltc_m(frame, params)
    minv = np.linalg.inv(m)
    minv /= minv[1, 1]  # the LTC is invariant to the scale of M; the table drops it
    entries = np.array([minv[0, 0], minv[2, 0], minv[0, 2], minv[2, 2]])
    return CellFit(params, entries, magnitude, _relative_l1(lobe, magnitude, m))


def _fit_column(n: int, i: int, start) -> list[CellFit]:
    """Rows 1 .. n-1 of column i, towards grazing, each started from the previous row's fit."""
    fits = []
    for j in range(1, n):
        fit = fit_cell(n, j, i, start)
        fits.append(fit)
        start = fit.params
    return fits


def fit_table(n: int = TABLE_SIZE, jobs: int | None = 1, progress: bool = False) -> dict[str, np.ndarray]:
    """Fit all ``n x n`` cells in Heitz's order; deterministic whatever ``jobs``.

    Heitz proceeds from high roughness to low and, per roughness, from normal
    incidence to grazing, each fit started from the previous one; only row 0
    links the columns (each row-0 cell starts from the rougher one). So row 0 is
    fitted first, in order, and the columns after it in parallel.

    Parameters
    ----------
    n : int
        Table size (>= 2).
    jobs : int or None
        Worker processes for the columns; None: one per CPU; 1: none.
    progress : bool
        Show a tqdm bar.

    Returns
    -------
    dict
        ``minv`` (n, n, 4) float32 (the (a, b, c, d) of :class:`CellFit`),
        ``fit_error`` (n, n) float32 and ``magnitude`` (n, n) float32, indexed
        ``[j, i]`` (row = view angle, column = roughness).
    """
    if n < 2:
        raise ValueError(f"n >= 2 expected, got {n}")
    fits: dict[tuple[int, int], CellFit] = {}
    bar = tqdm(total=n * n, unit="cell", desc="LTC fit", disable=not progress)
    start = START_PARAMS
    for i in reversed(range(n)):
        fits[0, i] = fit_cell(n, 0, i, start)
        start = fits[0, i].params
        bar.update(1)

    def store(i, column):
        for j, fit in enumerate(column, start=1):
            fits[j, i] = fit
        bar.update(n - 1)

    columns = reversed(range(n))
    if jobs == 1:
        for i in columns:
            store(i, _fit_column(n, i, fits[0, i].params))
    else:
        with ProcessPoolExecutor(max_workers=jobs) as pool:
            futures = {pool.submit(_fit_column, n, i, fits[0, i].params): i for i in columns}
            for fut in as_completed(futures):
                store(futures[fut], fut.result())
    bar.close()
    out = {
        "minv": np.empty((n, n, 4), np.float32),
        "fit_error": np.empty((n, n), np.float32),
        "magnitude": np.empty((n, n), np.float32),
    }
    for (j, i), fit in fits.items():
        out["minv"][j, i] = fit.entries
        out["fit_error"][j, i] = fit.fit_error
        out["magnitude"][j, i] = fit.magnitude
    return out


def write_table(path, table: dict[str, np.ndarray]) -> None:
    """Write :func:`fit_table`'s result with its metadata (``.npz``, compressed)."""
    n = table["minv"].shape[0]
    np.savez_compressed(path, **table, n=n, alpha_min=ALPHA_MIN, cos_theta_min=COS_MIN,
                        fit_samples=FIT_SAMPLES, average_samples=_AVERAGE_SAMPLES,
                        error_samples=_ERROR_SAMPLES)


def _summary(fit_error: np.ndarray) -> str:
    """Median, 95th percentile and maximum of the fitting error, and where the maximum is."""
    n = fit_error.shape[0]
    j, i = np.unravel_index(np.argmax(fit_error), fit_error.shape)
    roughness, cos_theta = cell_view(n, j, i)
    return (f"relative L1 error over {n}x{n} cells: median {np.median(fit_error):.4f}, "
            f"p95 {np.percentile(fit_error, 95):.4f}, max {fit_error.max():.4f} at roughness "
            f"{roughness:.3f}, theta {np.degrees(np.arccos(cos_theta)):.2f} deg (cell [{j}, {i}])")


def main(argv=None) -> int:
    """``python -m tools.fit_ltc [--out PATH] [--n N] [--jobs J]``: refit and write the table."""
    parser = argparse.ArgumentParser(prog="python -m tools.fit_ltc", description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=TABLE_PATH, help=f"output .npz (default: {TABLE_PATH})")
    parser.add_argument("--n", type=int, default=TABLE_SIZE, help="table size (default: %(default)s)")
    parser.add_argument("--jobs", type=int, default=os.cpu_count(),
                        help="worker processes (default: one per CPU); the result does not depend on it")
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    table = fit_table(args.n, jobs=args.jobs, progress=True)
    write_table(args.out, table)
    print(f"wrote {args.out} in {time.perf_counter() - t0:.0f} s")
    print(_summary(table["fit_error"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
