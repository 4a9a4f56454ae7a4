"""Brute-force reflected environment radiance, for measuring the split-sum approximation.

``L_o(n, v) = ∫ L_env(l) f(n, v, l) (n·l) dl`` for the shared BRDF
(:func:`compare.brdf.eval_brdf`) and an equirectangular map read exactly as
Mitsuba reads it (:func:`compare.scene.equirect.sample_equirect`), by Monte Carlo
with multiple importance sampling (balance heuristic) of two techniques:

* environment sampling: a cell around a texel of the map chosen in proportion
  to its (dilated) luminance × solid angle, a uniform direction inside it (this
  finds a 3.6e4 sun);
* BRDF sampling: GGX visible normals (:func:`compare.brdf.sample_ggx_vndf`) with
  the plugin's lobe probability (:func:`compare.brdf.specular_sampling_probability`),
  cosine-weighted otherwise (this finds sharp reflections).

No visibility: the integral of one point of a convex object (a sphere) in the
environment, which is what the split sum approximates. Deterministic for a seed.
"""

from __future__ import annotations

import numpy as np

from compare.brdf import (alpha_from_roughness, eval_brdf, pdf_ggx_vndf_reflection, sample_ggx_vndf,
                    specular_sampling_probability)
from compare.scene.equirect import direction_to_uv, rotation_matrix, sample_equirect

__all__ = ["EnvSampler", "reflected_radiance"]


class EnvSampler:
    """Importance sampling of an equirectangular map, cell by cell around Mitsuba's texel positions.

    Cell (j, i) covers u in [i/W, (i+1)/W] and v in [(j−½)/(H−1), (j+½)/(H−1)] (clipped to
    the poles), around texel (j, i)'s position, and is chosen with probability proportional
    to its solid angle times the largest luminance of the texel and its 8 neighbours (the
    bilinear lookup spreads a texel over its neighbours' cells); a direction is uniform in
    solid angle inside the cell.
    """

    def __init__(self, image: np.ndarray):
        img = np.asarray(image, dtype=np.float64)
        self.image = img
        h, w = img.shape[:2]
        self.h, self.w = h, w
        lum = img @ np.array([0.2126, 0.7152, 0.0722])
        padded = np.pad(lum, ((1, 1), (0, 0)), mode="edge")
        padded = np.concatenate([padded[:, -1:], padded, padded[:, :1]], axis=1)  # u wraps around
        dil = np.max([padded[1 + dj:1 + dj + h, 1 + di:1 + di + w] for dj in (-1, 0, 1) for di in (-1, 0, 1)],
                     axis=0)
        j = np.arange(h)
        self.v_lo = np.clip((j - 0.5) / (h - 1), 0.0, 1.0)
        self.v_hi = np.clip((j + 0.5) / (h - 1), 0.0, 1.0)
        self.z_hi = np.cos(np.pi * self.v_lo)  # cos(theta) at the cell's upper edge
        self.z_lo = np.cos(np.pi * self.v_hi)
        self.omega = (2.0 * np.pi / w) * (self.z_hi - self.z_lo)  # solid angle of a cell in row j
        weight = (dil + 1e-3 * max(float(lum.mean()), 1e-12)) * self.omega[:, None]
        self.pmf = (weight / weight.sum()).ravel()
        self.cdf = np.cumsum(self.pmf)
        self.cdf[-1] = 1.0

    def sample(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Directions (..., 3) in the map's frame and solid-angle pdfs for uniform numbers u (..., 3)."""
        cell = np.minimum(np.searchsorted(self.cdf, u[..., 0], side="right"), len(self.cdf) - 1)
        j, i = np.divmod(cell, self.w)
        phi = 2.0 * np.pi * (i + u[..., 1]) / self.w
        z = self.z_lo[j] + (self.z_hi[j] - self.z_lo[j]) * u[..., 2]
        s = np.sqrt(np.maximum(1.0 - z * z, 0.0))
        d = np.stack([np.sin(phi) * s, z, -np.cos(phi) * s], axis=-1)
        return d, self.pmf[cell] / self.omega[j]

    def pdf(self, d: np.ndarray) -> np.ndarray:
        """Solid-angle pdf of map-frame directions (..., 3)."""
        uv = direction_to_uv(d)
        i = np.minimum((uv[..., 0] * self.w).astype(np.int64), self.w - 1)
        j = np.clip(np.floor(uv[..., 1] * (self.h - 1) + 0.5).astype(np.int64), 0, self.h - 1)
        return self.pmf[j * self.w + i] / self.omega[j]


def _frame(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    x, y, z = n[..., 0], n[..., 1], n[..., 2]
    sign = np.where(z >= 0, 1.0, -1.0)
    a = -1.0 / (sign + z)
    b = x * y * a
    return (np.stack([1.0 + sign * x * x * a, sign * b, -sign * x], -1),
            np.stack([b, sign + y * y * a, -y], -1))


def reflected_radiance(image: np.ndarray, n, v, base_color, metallic, roughness, *, samples: int = 512,
                       rotation: float = 0.0, materials: str = "shared", seed: int = 0, chunk: int = 256
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Reflected radiance (P, 3) and its standard error towards ``v`` at points with normals ``n`` (P, 3).

    ``samples`` per technique and point. ``materials="diffuse"`` uses Lambert
    ``base / π`` only. ``rotation`` is the environment's (degrees about +Y).
    The map is *not* scaled by an intensity.
    """
    n = np.asarray(n, dtype=np.float64).reshape(-1, 3)
    v = np.asarray(v, dtype=np.float64).reshape(-1, 3)
    p = len(n)
    base = np.broadcast_to(np.asarray(base_color, dtype=np.float64), (p, 3))
    metal = np.broadcast_to(np.asarray(metallic, dtype=np.float64), (p,))
    rough = np.broadcast_to(np.asarray(roughness, dtype=np.float64), (p,))
    env = EnvSampler(image)
    rng = np.random.default_rng(seed)
    out = np.zeros((p, 3))
    err = np.zeros((p, 3))
    for start in range(0, p, chunk):
        sl = slice(start, min(start + chunk, p))
        m = sl.stop - sl.start
        nn, vv, bb, mm, rr = n[sl], v[sl], base[sl], metal[sl], rough[sl]
        t, b = _frame(nn)
        to_local = np.stack([t, b, nn], axis=-2)  # (m, 3, 3): rows t, b, n
        v_loc = np.einsum("pij,pj->pi", to_local, vv)
        alpha = alpha_from_roughness(rr)
        q = (np.zeros(m) if materials == "diffuse"
             else specular_sampling_probability(np.clip(v_loc[:, 2], 0, 1), bb, mm))

        def brdf_pdf(l_loc):
            """Solid-angle pdf of the BRDF technique for local directions (m, s, 3)."""
            cos = np.maximum(l_loc[..., 2], 0.0) / np.pi
            if materials == "diffuse":
                return cos
            vs = pdf_ggx_vndf_reflection(np.broadcast_to(v_loc[:, None, :], l_loc.shape), l_loc, alpha[:, None])
            return q[:, None] * vs + (1.0 - q[:, None]) * cos

        def contribution(l_world, l_loc):
            if materials == "diffuse":
                f = np.where(l_loc[..., 2:3] > 0, bb[:, None, :] / np.pi, 0.0)
            else:
                f = eval_brdf(nn[:, None, :], vv[:, None, :], l_world, bb[:, None, :], mm[:, None], rr[:, None])
            radiance = sample_equirect(env.image, l_world, rotation)
            return f * radiance * np.maximum(l_loc[..., 2:3], 0.0)

        # Technique 1: the environment.
        u = rng.random((m, samples, 3))
        d_env, p_env = env.sample(u)
        # The map is sampled in its own frame: rotate into the world (R d).
        rot = rotation_matrix(rotation)
        l1 = d_env @ rot.T
        l1_loc = np.einsum("pij,psj->psi", to_local, l1)
        c1 = contribution(l1, l1_loc)
        w1 = p_env + brdf_pdf(l1_loc)
        e1 = np.where(w1[..., None] > 0, c1 / np.where(w1 > 0, w1, 1.0)[..., None], 0.0)

        # Technique 2: the BRDF (specular lobe with probability q, else cosine).
        u = rng.random((m, samples, 3))
        rad = np.sqrt(u[..., 1])
        phi = 2.0 * np.pi * u[..., 2]
        cos_dir = np.stack([rad * np.cos(phi), rad * np.sin(phi), np.sqrt(np.maximum(1 - u[..., 1], 0))], -1)
        if materials == "diffuse":
            l2_loc = cos_dir
        else:
            h = sample_ggx_vndf(np.broadcast_to(v_loc[:, None, :], (m, samples, 3)),
                                np.broadcast_to(alpha[:, None], (m, samples)), u[..., 1:])
            spec_dir = 2.0 * np.sum(v_loc[:, None, :] * h, -1, keepdims=True) * h - v_loc[:, None, :]
            l2_loc = np.where((u[..., 0] < q[:, None])[..., None], spec_dir, cos_dir)
        l2 = np.einsum("pji,psj->psi", to_local, l2_loc)
        l2 /= np.linalg.norm(l2, axis=-1, keepdims=True)
        c2 = contribution(l2, l2_loc)
        w2 = env.pdf(l2 @ rot) + brdf_pdf(l2_loc)
        e2 = np.where(w2[..., None] > 0, c2 / np.where(w2 > 0, w2, 1.0)[..., None], 0.0)

        # Balance heuristic with equal counts: each sample contributes f L cos / (p_env + p_brdf).
        pair = e1 + e2
        out[sl] = pair.mean(axis=1)
        err[sl] = pair.std(axis=1, ddof=1) / np.sqrt(samples)
    return out, err
