"""Compute Cycles' Multiscatter GGX energy tables (``compare/brdf/energy_table.npz``, served by
:mod:`compare.brdf.multiscatter`): ``python -m tools.fit_multiscatter``."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from compare.brdf.multiscatter import ENERGY_TABLE_SIZE, TABLE_PATH


def _lambda(cos_theta, alpha):
    """GGX Smith Lambda (Heitz 2014, eq. 72) as Cycles' ``bsdf_lambda``."""
    c2 = np.maximum(np.asarray(cos_theta, dtype=np.float64) ** 2, 1e-300)
    return 0.5 * (np.sqrt(1.0 + alpha * alpha * np.maximum(1.0 / c2 - 1.0, 0.0)) - 1.0)


def _albedo(rough: float, mu, u: np.ndarray) -> np.ndarray:
    """E(rough, mu) for each mu, averaged over the visible-normal samples ``u`` (S, 2)."""
    from compare.brdf import sample_ggx_vndf

    mu = np.atleast_1d(np.asarray(mu, dtype=np.float64))
    alpha = rough * rough
    wi = np.stack([np.sqrt(1.0 - mu * mu), np.zeros_like(mu), mu], axis=-1)[:, None, :]
    wi = np.broadcast_to(wi, (len(mu), len(u), 3))
    h = sample_ggx_vndf(wi, np.full(wi.shape[:2], alpha), np.broadcast_to(u, wi.shape[:2] + (2,)))
    wo_z = 2.0 * np.sum(h * wi, axis=-1) * h[..., 2] - wi[..., 2]
    lam_i = _lambda(wi[..., 2], alpha)
    lam_o = _lambda(np.maximum(wo_z, 1e-12), alpha)
    weight = np.where(wo_z > 0.0, (1.0 + lam_i) / (1.0 + lam_i + lam_o), 0.0)
    return weight.mean(axis=-1)


def _hammersley(samples: int) -> np.ndarray:
    """``samples**2`` Hammersley points: a product grid would give only ``samples`` distinct
    heights, and E at low roughness is decided in the last 0.1 % of the GGX tail."""
    count = samples * samples
    i = np.arange(count, dtype=np.uint64)
    bits = np.zeros(count)
    scale = 0.5
    while np.any(i):
        bits += (i & np.uint64(1)).astype(np.float64) * scale
        i >>= np.uint64(1)
        scale *= 0.5
    return np.stack([(np.arange(count) + 0.5) / count, bits + 0.5 / count], axis=-1)


def energy_tables(samples: int = 256, avg_nodes: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """Cycles' ``ggx_E`` and ``ggx_Eavg`` recomputed (see the module notes).

    Parameters
    ----------
    samples : int
        Visible-normal samples: ``samples**2`` Hammersley points per cell.
    avg_nodes : int
        Gauss-Legendre nodes in mu for E_avg (each node's E from ``samples // 2``
        squared Hammersley points).

    Returns
    -------
    e : ndarray, shape (32, 32)
        Row j: mu = j/31; column i: roughness = i/31.
    e_avg : ndarray, shape (32,)
        Entry i: roughness i/31.
    """
    n = ENERGY_TABLE_SIZE
    u = _hammersley(samples)
    u_avg = _hammersley(max(samples // 2, 8))
    x, w = np.polynomial.legendre.leggauss(avg_nodes)
    mu_avg, w_avg = 0.5 * (x + 1.0), 0.5 * w
    grid = np.clip(np.arange(n) / (n - 1), 1e-4, 1.0)
    e = np.empty((n, n))
    e_avg = np.empty(n)
    for i, rough in enumerate(grid):
        if rough ** 4 <= 2e-10:  # alpha^2 at or below BSDF_ROUGHNESS_SQ_THRESH: Cycles' perfect mirror
            e[:, i], e_avg[i] = 1.0, 1.0
            continue
        e[:, i] = np.concatenate([_albedo(rough, grid[j:j + 4], u) for j in range(0, n, 4)])
        e_avg[i] = np.sum(w_avg * 2.0 * mu_avg * _albedo(rough, mu_avg, u_avg))
    return np.clip(e, 0.0, 1.0), np.clip(e_avg, 0.0, 1.0)


def main(argv=None) -> int:
    """Regenerate ``energy_table.npz``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=256, help="square root of the Hammersley points per cell")
    parser.add_argument("--out", type=Path, default=TABLE_PATH, help=f"output .npz (default: {TABLE_PATH})")
    args = parser.parse_args(argv)
    e, e_avg = energy_tables(args.samples)
    np.savez_compressed(args.out, ggx_E=e.astype(np.float32), ggx_Eavg=e_avg.astype(np.float32),
                        samples=np.int64(args.samples))
    print(f"wrote {args.out}: ggx_E {e.shape}, ggx_Eavg {e_avg.shape}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
