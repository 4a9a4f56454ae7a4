"""Specular prefiltering: an equirectangular map → a cube chain of GGX-filtered radiance.

Source chain
------------
Level 0 of the source is the equirectangular map resampled onto cube faces
(``sub × sub`` supersampled bilinear lookups per texel with
:func:`compare.scene.equirect.sample_equirect`, so that the rasterizer sees the
map exactly as Mitsuba interpolates it); every further source level halves the
faces by solid-angle-weighted 2×2 means, down to 1×1.

Prefiltered chain and the roughness → level mapping
---------------------------------------------------
Level ``i`` of ``L`` (default 9, the paper's public code) holds the radiance
prefiltered for perceptual roughness ``r_i = i / (L − 1)``; a shader reads
roughness r at the fractional level ``lod = r · (L − 1)``, blending the two
neighbouring levels linearly (the paper's ``lod = clamp(roughness · 8, 0, 8)``).
The face size of level i is ``max(S >> i, MIN_LEVEL_SIZE)``: the lobes of
rough levels are wide, so small faces lose nothing, but below 8×8 the bilinear
reconstruction itself would blur. Level 0 (r = 0, α = ALPHA_MIN, a lobe much
narrower than a texel) is the source level 0 itself.

Each texel of level i > 0 is Karis' split-sum prefilter with the n = v = r
assumption::

    P(r_dir) = Σ_k L(l_k) (n·l_k) / Σ_k (n·l_k),   h_k ~ D(h)(n·h),  l_k = reflect(−n, h_k)

with ``n`` fixed Hammersley points (the same for every texel; GGX visible-normal
sampling of :func:`compare.brdf.sample_ggx_vndf` at normal incidence, which is
D(h)(n·h)). Every sample reads the source at the level where one source texel
covers its share of the lobe (Filament's pdf-based source-mip selection,
Křivánek & Colbert 2008)::

    lod_k = clamp(½ log2(K · Ω_s / Ω_p), 0, top),  Ω_s = 1 / (n · pdf(l_k)),  Ω_p = 4π / (6 S²),  K = 4

with pdf(l) = D(h) / 4 at n = v. That removes the aliasing of a bright sun
with a few hundred samples.
"""

from __future__ import annotations

import numpy as np

from compare.brdf import alpha_from_roughness, ggx_d, sample_ggx_vndf
from compare.ibl.cubemap import bilinear_faces, downsample, face_coordinates, pad_from_interior, padded_directions

__all__ = ["MIN_LEVEL_SIZE", "SOURCE_LOD_K", "hammersley", "level_roughness", "level_sizes", "prefilter",
           "sample_chain", "source_chain"]

#: Smallest face size of a prefiltered level.
MIN_LEVEL_SIZE = 8
#: Filament's bias K of the source-mip selection.
SOURCE_LOD_K = 4.0
#: Largest (texels × samples) handled at once (bounds memory).
_CHUNK = 1 << 19


def level_roughness(levels: int) -> np.ndarray:
    """Perceptual roughness of each prefiltered level, ``i / (levels − 1)``."""
    if levels < 2:
        raise ValueError(f"levels: expected at least 2 prefiltered levels, got {levels}")
    return np.arange(levels) / (levels - 1)


def level_sizes(size: int, levels: int) -> list[int]:
    """Face size of each prefiltered level: ``max(size >> i, MIN_LEVEL_SIZE)`` (level 0 = size)."""
    return [size] + [max(size >> i, min(MIN_LEVEL_SIZE, size)) for i in range(1, levels)]


def hammersley(n: int) -> np.ndarray:
    """The n-point Hammersley set in [0, 1)² (i/n, radical inverse base 2 of i)."""
    i = np.arange(n, dtype=np.uint64)
    bits = i.copy()
    bits = ((bits << np.uint64(16)) | (bits >> np.uint64(16))) & np.uint64(0xFFFFFFFF)
    bits = ((bits & np.uint64(0x55555555)) << np.uint64(1)) | ((bits & np.uint64(0xAAAAAAAA)) >> np.uint64(1))
    bits = ((bits & np.uint64(0x33333333)) << np.uint64(2)) | ((bits & np.uint64(0xCCCCCCCC)) >> np.uint64(2))
    bits = ((bits & np.uint64(0x0F0F0F0F)) << np.uint64(4)) | ((bits & np.uint64(0xF0F0F0F0)) >> np.uint64(4))
    bits = ((bits & np.uint64(0x00FF00FF)) << np.uint64(8)) | ((bits & np.uint64(0xFF00FF00)) >> np.uint64(8))
    return np.stack([(i.astype(np.float64) + 0.5) / n, bits.astype(np.float64) / 2.0**32], axis=-1)


def source_chain(equirect: np.ndarray, size: int, *, sub: int | None = None) -> list[np.ndarray]:
    """Padded cube levels (6, S+2, S+2, 3) float64 of an equirectangular map, from ``size`` down to 1.

    ``sub`` × ``sub`` lookups per texel of level 0; default ``clamp(ceil(W / (4 size)), 2, 8)``
    (about one lookup per map texel).
    """
    from compare.scene.equirect import sample_equirect

    if size < 1 or size & (size - 1):
        raise ValueError(f"size: expected a power of two, got {size}")
    w = equirect.shape[1]
    if sub is None:
        sub = int(np.clip(np.ceil(w / (4 * size)), 2, 8))
    d = padded_directions(size, sub=sub)
    level0 = sample_equirect(equirect, d).mean(axis=-2)
    interior = level0[:, 1:-1, 1:-1]
    chain = [level0]
    while interior.shape[1] > 1:
        interior = downsample(interior)
        chain.append(pad_from_interior(interior))
    return chain


def sample_chain(chain: list[np.ndarray], d, lod) -> np.ndarray:
    """Trilinear lookup in a padded cube chain: directions (..., 3), fractional levels ``lod`` (broadcast)."""
    d = np.asarray(d, dtype=np.float64)
    lod = np.broadcast_to(np.clip(np.asarray(lod, dtype=np.float64), 0.0, len(chain) - 1), d.shape[:-1])
    out = np.zeros(d.shape[:-1] + (chain[0].shape[-1],))
    lo = np.minimum(np.floor(lod).astype(np.int64), len(chain) - 1)
    frac = lod - lo
    for level in np.unique(lo):
        sel = lo == level
        coords = face_coordinates(d[sel])
        f = frac[sel][:, None]
        value = bilinear_faces(chain[level], *coords) * (1.0 - f)
        if level + 1 < len(chain):
            value += bilinear_faces(chain[level + 1], *coords) * f
        out[sel] = value
    return out


def _frames(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tangent and bitangent of unit normals (..., 3) (Duff et al. 2017, branchless ONB)."""
    x, y, z = n[..., 0], n[..., 1], n[..., 2]
    sign = np.where(z >= 0, 1.0, -1.0)
    a = -1.0 / (sign + z)
    b = x * y * a
    t = np.stack([1.0 + sign * x * x * a, sign * b, -sign * x], axis=-1)
    bt = np.stack([b, sign + y * y * a, -y], axis=-1)
    return t, bt


def ggx_lobe_samples(roughness: float, samples: int, source_size: int, source_levels: int):
    """Local sample directions (n, 3) with z = n = v, their n·l weights and source levels, for one roughness."""
    alpha = float(alpha_from_roughness(roughness))
    u = hammersley(samples)
    h = sample_ggx_vndf(np.broadcast_to([0.0, 0.0, 1.0], (samples, 3)), np.full(samples, alpha), u)
    l = 2.0 * h[:, 2:3] * h - np.array([0.0, 0.0, 1.0])  # noqa: E741
    nl = l[:, 2]
    keep = nl > 0
    l, nl, h = l[keep], nl[keep], h[keep]
    sin2 = h[:, 0] ** 2 + h[:, 1] ** 2
    pdf = ggx_d(h[:, 2], alpha, sin2) / 4.0
    omega_s = 1.0 / (samples * pdf)
    omega_p = 4.0 * np.pi / (6.0 * source_size * source_size)
    lod = np.clip(0.5 * np.log2(SOURCE_LOD_K * omega_s / omega_p), 0.0, source_levels - 1)
    return l, nl, lod


def prefilter(chain: list[np.ndarray], directions: np.ndarray, roughness: float, samples: int) -> np.ndarray:
    """GGX-prefiltered radiance (n = v = r) of a source chain towards ``directions`` (..., 3), float64."""
    d = np.asarray(directions, dtype=np.float64)
    flat = d.reshape(-1, 3)
    source_size = chain[0].shape[1] - 2
    l, nl, lod = ggx_lobe_samples(roughness, samples, source_size, len(chain))
    t, b = _frames(flat)
    # float32 inside the loop: half the memory traffic; the result is stored as float32 anyway.
    chain = [c.astype(np.float32, copy=False) for c in chain]
    flat, t, b, l32 = (a.astype(np.float32) for a in (flat, t, b, l))
    out = np.zeros((len(flat), chain[0].shape[-1]))
    wsum = nl.sum()
    # Every texel uses the same samples, so the samples are grouped by source level once.
    lo = np.minimum(np.floor(lod).astype(np.int64), len(chain) - 1)
    for level in np.unique(lo):
        k = np.nonzero(lo == level)[0]
        ls, ws, fs = l32[k], nl[k], (lod[k] - level).astype(np.float32)[None, :, None]
        step = max(1, _CHUNK // len(k))
        for start in range(0, len(flat), step):
            sl = slice(start, start + step)
            world = (ls[None, :, 0:1] * t[sl, None, :] + ls[None, :, 1:2] * b[sl, None, :]
                     + ls[None, :, 2:3] * flat[sl, None, :])
            coords = face_coordinates(world)
            value = bilinear_faces(chain[level], *coords)
            if level + 1 < len(chain):
                value = value * (1.0 - fs) + bilinear_faces(chain[level + 1], *coords) * fs
            out[sl] += np.einsum("tnc,n->tc", value, ws)
    out /= wsum
    return out.reshape(d.shape[:-1] + (out.shape[-1],))
