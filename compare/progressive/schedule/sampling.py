"""Low-discrepancy points: pixel jitter, sample points on rectangular lights and the environment's
shadow directions.

Both use the R2 sequence (Roberts 2018), ``x_k = frac(s + k·(1/g, 1/g²))`` with
``g`` the plastic number: every prefix is well spread over the unit square, so a
render stopped at any frame has evenly placed samples. The seed picks the
offset ``s`` (a Cranley–Patterson rotation); seed 0 uses ``s = (½, ½)``, which
puts frame 0's jitter on the pixel centre and light sample 0 on the light's
centre.

The environment's shadow directions (:func:`sobol2`) use the first two dimensions of Sobol's
sequence instead: a (0, 2)-sequence in base 2, whose every 2^k points put exactly one point into each
of the 2^k elementary boxes of the square, is spread more evenly at a few hundred points than R2,
which is what a quadrature of the visibility over a few hundred directions needs.

References
----------
M. Roberts, "The unreasonable effectiveness of quasirandom sequences", 2018,
http://extremelearning.com.au/unreasonable-effectiveness-of-quasirandom-sequences/

I. M. Sobol', "On the distribution of points in a cube and the approximate evaluation of integrals",
USSR Computational Mathematics and Mathematical Physics 7(4), 1967. S. Joe and F. Y. Kuo, "Constructing
Sobol sequences with better two-dimensional projections", SIAM J. Sci. Comput. 30(5), 2008 (the second
dimension's direction numbers, of the polynomial x + 1).
"""

from __future__ import annotations

import numpy as np

#: The plastic number, the real root of x³ = x + 1.
PLASTIC = 1.324717957244746
R2_ALPHA = np.array([1.0 / PLASTIC, 1.0 / PLASTIC**2])
#: The real root > 1 of x⁴ = x + 1, generator of the 3D sequence (R3).
PHI3 = 1.2207440846057596
R3_ALPHA = np.array([1.0 / PHI3, 1.0 / PHI3**2, 1.0 / PHI3**3])


def seed_offset(seed: int, stream: int = 0) -> np.ndarray:
    """The R2 offset for ``seed`` and an independent ``stream`` ((½, ½) for seed 0)."""
    if seed == 0:
        return np.array([0.5, 0.5])
    return np.random.default_rng([int(seed), int(stream)]).random(2)


def r2(count: int, offset=(0.5, 0.5), start: int = 0) -> np.ndarray:
    """Points ``start … start+count−1`` of the R2 sequence in [0, 1)², shape (count, 2), float64."""
    k = np.arange(start, start + count, dtype=np.float64)[:, None]
    return np.mod(np.asarray(offset, dtype=np.float64) + k * R2_ALPHA, 1.0)


def pixel_jitter(frames: int, seed: int = 0) -> np.ndarray:
    """Sub-pixel offsets (frames, 2) in [−½, ½)², x right and y up, in pixels.

    Uniform over the pixel, so the mean over frames is Mitsuba's box pixel filter
    (pixel (i, j) covers [i, i+1) × [j, j+1), its centre at i + ½).
    """
    return r2(frames, seed_offset(seed, 0)) - 0.5


def light_sample_uv(count: int, seed: int = 0, light_index: int = 0) -> np.ndarray:
    """``count`` points (count, 2) in [0, 1)² for a light, in R2 order (not yet sorted).

    Point 0 is the centre (½, ½); points 1… are R2 points offset by the seed and
    light index. :func:`light_sample_points` sorts them from the centre outwards
    by metric distance on the rectangle.
    """
    if count < 1:
        raise ValueError(f"count: expected a positive number of light samples, got {count}")
    uv = r2(count, seed_offset(seed, 1 + light_index))
    uv[0] = 0.5
    return uv


def light_sample_points(light, count: int, seed: int = 0, light_index: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """World-space sample points on a rectangular light, centre first, then outwards.

    Parameters
    ----------
    light : compare.scene.loader.AreaLight
    count : int
        Number of samples n_i.
    seed, light_index : int
        Select the R2 offset (independent per light).

    Returns
    -------
    points : ndarray (count, 3) float64
        Points on the rectangle; ``points[0]`` is ``light.center``.
    uv : ndarray (count, 2)
        The same points in [0, 1)² along (tangent, bitangent).

    Notes
    -----
    Sorting by distance from the light's *centre* (not from the world origin, as
    the paper's public code does) makes every prefix of the samples a disc-like
    growing region around the centre: shadows start sharp and soften as frames
    accumulate, and sample 0 alone is the centre's hard shadow.
    """
    uv = light_sample_uv(count, seed, light_index)
    local = (uv - 0.5) * np.asarray(light.size, dtype=np.float64)
    order = np.argsort(np.hypot(local[:, 0], local[:, 1]), kind="stable")
    uv, local = uv[order], local[order]
    c = np.asarray(light.center, dtype=np.float64)
    t = np.asarray(light.tangent, dtype=np.float64)
    b = np.asarray(light.bitangent, dtype=np.float64)
    points = c + local[:, :1] * t + local[:, 1:] * b
    return points, uv


def env_sample_points(count: int, seed: int = 0, stream: int = 0) -> np.ndarray:
    """``count`` points (count, 3) in [0, 1)³ for environment samples (R3, Roberts' 3D sequence).

    Axis 0 drives the azimuth, axis 1 the polar angle (cosine or GGX), axis 2 the
    distance along the occlusion ray (fraction of d_occ). Seed 0 starts at
    (½, ½, ½); other seeds (and every ``stream``) get an independent offset.
    """
    if count < 0:
        raise ValueError(f"count: expected a non-negative number of samples, got {count}")
    offset = np.full(3, 0.5) if seed == 0 else np.random.default_rng([int(seed), 1000 + int(stream)]).random(3)
    k = np.arange(count, dtype=np.float64)[:, None]
    return np.mod(offset + k * R3_ALPHA, 1.0)


def _sobol_matrices(bits: int = 32) -> tuple[np.ndarray, np.ndarray]:
    """The direction numbers of Sobol's first two dimensions as ``bits``-bit integers: the van der
    Corput sequence (bit j of the index → bit ``bits − 1 − j``) and the polynomial x + 1's
    ``v_j = v_{j−1} xor (v_{j−1} >> 1)``."""
    first = np.array([1 << (bits - 1 - j) for j in range(bits)], dtype=np.uint64)
    second, v = [], 1 << (bits - 1)
    for _ in range(bits):
        second.append(v)
        v ^= v >> 1
    return first, np.array(second, dtype=np.uint64)


def sobol2(indices, seed: int = 0, stream: int = 0) -> np.ndarray:
    """Points ``indices`` (any integers ≥ 0) of Sobol's sequence in [0, 1)², shape (len, 2), float64.

    Seed 0 is the sequence itself (point 0 at the origin); other seeds (and every ``stream``) xor every
    point with one random 32-bit shift per dimension (a digital shift, which keeps each 2^k-point block an
    exact net: it permutes the elementary boxes).
    """
    k = np.asarray(indices, dtype=np.uint64).reshape(-1)
    shift = (np.zeros(2, dtype=np.uint64) if seed == 0
             else np.random.default_rng([int(seed), 2000 + int(stream)]).integers(0, 1 << 32, 2, dtype=np.uint64))
    out = np.tile(shift, (len(k), 1))
    for j, (a, b) in enumerate(zip(*_sobol_matrices())):
        bit = (k >> np.uint64(j)) & np.uint64(1)
        out[:, 0] ^= bit * a
        out[:, 1] ^= bit * b
    return out.astype(np.float64) / float(1 << 32)
