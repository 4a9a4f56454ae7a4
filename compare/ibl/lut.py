"""The split-sum lookup table over (n·v, roughness), computed with the shared BRDF.

Karis' split sum approximates the environment's specular reflection as
``prefiltered(r, roughness) · (F0 · A + B)`` with (Schlick, ``F_c = (1 − v·h)^5``)::

    A(n·v, r) = ∫ (1 − F_c) D V (n·l) dl        B(n·v, r) = ∫ F_c D V (n·l) dl

for the shared BRDF's D (GGX) and V (height-correlated Smith); here both come
from :func:`compare.brdf.eval_brdf_lobes` itself (the specular lobe of a metal
with F0 = 1 is ``D V``, with F0 = 0 it is ``F_c D V``), integrated by GGX
visible-normal sampling. The shared BRDF's diffuse lobe ``(1 − m)(1 − F_d) c / π``
depends on v·h too; the third channel is its directional factor for c = 1::

    C(n·v) = ∫ (1 − F_d(v·h)) (n·l) / π dl        (F_d = Schlick with F0 = 0.04)

(independent of roughness), so that the diffuse environment term is
``(1 − m) c · E(n)/π · C(n·v)`` with the irradiance E — the same split of a
product integral into a product of integrals as the specular term.

Texel (i, j) of the (size × size × 3) table holds n·v = (i + ½)/size (column)
and roughness = (j + ½)/size (row), so ``texture(lut, vec2(n·v, roughness))``
with linear filtering reads it.
"""

from __future__ import annotations

import numpy as np

from compare.brdf import alpha_from_roughness, eval_brdf_lobes, pdf_ggx_vndf_reflection, sample_ggx_vndf
from compare.ibl.prefilter import hammersley

__all__ = ["split_sum_lut"]


def split_sum_lut(size: int = 32, samples: int = 1024) -> np.ndarray:
    """(size, size, 3) float32: A, B, C at (row = roughness, column = n·v); see the module notes."""
    if size < 2 or samples < 1:
        raise ValueError(f"size >= 2 and samples >= 1 expected, got {size}, {samples}")
    c = (np.arange(size) + 0.5) / size
    table = np.empty((size, size, 3))
    for row, rough in enumerate(c):  # one roughness per row keeps the temporaries small
        table[row] = _row(c, float(rough), samples)
    return table.astype(np.float32)


def _row(nv: np.ndarray, rough: float, samples: int) -> np.ndarray:
    """A, B, C (len(nv), 3) for one roughness."""
    v = np.stack([np.sqrt(1.0 - nv * nv), np.zeros_like(nv), nv], axis=-1)
    n = np.array([0.0, 0.0, 1.0])
    u = hammersley(samples)
    alpha = float(alpha_from_roughness(rough))
    vv = np.broadcast_to(v[:, None, :], (len(nv), samples, 3))
    h = sample_ggx_vndf(vv, np.full((len(nv), samples), alpha), np.broadcast_to(u, (len(nv), samples, 2)))
    l = 2.0 * np.sum(vv * h, axis=-1, keepdims=True) * h - vv  # noqa: E741
    pdf = pdf_ggx_vndf_reflection(vv, l, alpha)
    ok = pdf > 0
    weight = np.where(ok, np.maximum(l[..., 2], 0.0) / np.where(ok, pdf, 1.0), 0.0)
    one, _ = eval_brdf_lobes(n, vv, l, np.ones(3), 1.0, rough)      # D V     (F0 = 1)
    fc, _ = eval_brdf_lobes(n, vv, l, np.zeros(3), 1.0, rough)      # F_c D V (F0 = 0)
    a_plus_b = np.mean(one[..., 0] * weight, axis=1)
    b = np.mean(fc[..., 0] * weight, axis=1)
    # Diffuse factor: cosine-weighted directions, weight f cos / pdf = pi f.
    rad = np.sqrt(u[:, 0])
    phi = 2.0 * np.pi * u[:, 1]
    ld = np.stack([rad * np.cos(phi), rad * np.sin(phi), np.sqrt(np.maximum(1.0 - u[:, 0], 0.0))], axis=-1)
    _, diff = eval_brdf_lobes(n, vv, np.broadcast_to(ld, vv.shape), np.ones(3), 0.0, rough)
    c_diff = np.mean(diff[..., 0] * np.pi, axis=1)
    return np.stack([a_plus_b - b, b, c_diff], axis=-1)
