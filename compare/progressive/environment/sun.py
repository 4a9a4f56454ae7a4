"""The environment's sun as a directional light (``progressive:sun``).

A sky with a sun, or a studio map with a soft box, holds most of its light in a small bright region.
Sampled as environment light, that region's shadows need many samples to converge (``envshadows``) or are
never drawn (screen-space occlusion). Here the brightest compact region of the map is taken out of it and
rendered as a directional light with its own shadow map (:mod:`compare.progressive.lights.punctual`); the rest
of the map stays environment light (Debevec 2005, "A median cut algorithm for light probe sampling", keeps
the brightest region as one light in the same way).

The region: the texels within :data:`MAX_RADIUS_DEG` of the brightest texel whose luminance is at least
:data:`PEAK_FRACTION` of it. Its light above the level of the texels just around it is the sun: the
irradiance ``E = Σ (L − L_ring) dω`` (RGB, on a surface facing it) along the luminance-weighted mean
direction of that excess; the region's texels are set to ``L_ring`` in the map that remains. A map
whose region holds less than :data:`MIN_SHARE` of the map's luminous power has no sun: nothing is taken
out, and the render says so. The sun's own size (about 0.5° for the real one) is given up: its shadows
are hard, its highlights those of a point at infinity.
"""

from __future__ import annotations

import dataclasses
import hashlib
from pathlib import Path

import numpy as np

__all__ = ["MAX_RADIUS_DEG", "MIN_SHARE", "PEAK_FRACTION", "extract_sun", "scene_with_sun"]

#: The region's largest angular radius around the brightest texel (a compact source, not a bright sky).
MAX_RADIUS_DEG = 6.0
#: The region's texels are at least this fraction of the brightest texel's luminance.
PEAK_FRACTION = 0.1
#: The smallest share of the map's luminous power (luminance × solid angle) the region must hold.
MIN_SHARE = 0.05

_LUM = np.array([0.2126, 0.7152, 0.0722])


def _texel_directions(h: int, w: int) -> tuple[np.ndarray, np.ndarray]:
    """Each texel's centre direction in the map's frame (H, W, 3) and its solid angle (H, 1)."""
    from compare.scene.equirect import uv_to_direction

    u, v = np.meshgrid((np.arange(w) + 0.5) / w, (np.arange(h) + 0.5) / h)
    dirs = np.asarray(uv_to_direction(u.ravel(), v.ravel()), dtype=np.float64).reshape(h, w, 3)
    cos_edges = np.cos(np.arange(h + 1) / h * np.pi)
    solid = ((cos_edges[:-1] - cos_edges[1:]) * (2.0 * np.pi / w))[:, None]
    return dirs, solid


def extract_sun(image: np.ndarray):
    """The map's sun: ``(direction, irradiance, rest, share)`` in the map's frame: the unit direction towards
    it, its RGB irradiance on a surface facing it, the map without it (float32) and its share of the map's
    luminous power; None when the map has no compact region holding :data:`MIN_SHARE` of its light."""
    img = np.asarray(image, dtype=np.float64)[..., :3]
    h, w = img.shape[:2]
    dirs, solid = _texel_directions(h, w)
    lum = np.maximum(img @ _LUM, 0.0)
    power = lum * solid
    total = power.sum()
    if not np.isfinite(total) or total <= 0.0:
        return None
    peak = np.unravel_index(np.argmax(lum), lum.shape)
    cos_to_peak = dirs @ dirs[peak]
    near = cos_to_peak >= np.cos(np.radians(MAX_RADIUS_DEG))
    region = near & (lum >= PEAK_FRACTION * lum[peak])
    ring = (cos_to_peak >= np.cos(np.radians(MAX_RADIUS_DEG + 3.0))) & ~near
    fill = np.median(img[ring], axis=0) if ring.any() else np.zeros(3)  # the level the sun sits on
    excess = np.maximum(img - fill, 0.0) * region[..., None]
    excess_power = (excess @ _LUM) * solid
    if excess_power.sum() < MIN_SHARE * total:
        return None
    irradiance = (excess * solid[..., None]).sum(axis=(0, 1))
    direction = (dirs * excess_power[..., None]).sum(axis=(0, 1))
    direction /= np.linalg.norm(direction)
    rest = np.where(region[..., None], np.minimum(img, fill), img).astype(np.float32)
    return direction, irradiance, rest, float(excess_power.sum() / total)


def scene_with_sun(scene, cache_dir=None):
    """``(scene, notes)``: ``scene`` with its environment's sun as a directional light (named "sun") and the
    remaining map as its environment (an EXR in the cache, keyed by the map's texels); the scene itself
    and a note when it has no environment or its map no sun."""
    from compare.image.exr import write_exr
    from compare.scene.environments import environment_image
    from compare.scene.equirect import rotation_matrix
    from compare.scene.model import Environment, PunctualLight
    from compare.util.cache import default_cache_dir

    env = scene.environment
    if env is None:
        return scene, ["sun: the scene has no environment; nothing taken out"]
    image = environment_image(env, None if cache_dir is False else cache_dir)
    found = extract_sun(image)
    if found is None:
        return scene, [f"sun: the environment has no compact bright region holding {MIN_SHARE:.0%} of its light; "
                       "it stays environment light"]
    direction, irradiance, rest, share = found
    key = hashlib.sha256(np.ascontiguousarray(image, dtype=np.float32).tobytes()).hexdigest()[:24]
    folder = (default_cache_dir() if cache_dir in (None, False) else Path(cache_dir)) / "sun"
    path = folder / f"{key}.exr"
    if not path.is_file():
        folder.mkdir(parents=True, exist_ok=True)
        part = path.with_suffix(f".part-{np.random.default_rng().integers(1 << 30)}.exr")
        write_exr(part, rest)
        part.replace(path)  # whole or not at all: another render may read it
    world = rotation_matrix(env.rotation) @ direction
    sun = PunctualLight("sun", "directional", (0.0, 0.0, 0.0), tuple(float(x) for x in -world),
                        tuple(float(x) * float(env.intensity) for x in irradiance))
    rest_env = Environment(file=path, intensity=env.intensity, rotation=env.rotation, background=env.background)
    note = (f"sun: a directional light of irradiance {float(irradiance @ _LUM) * env.intensity:.4g} W/m² "
            f"towards ({', '.join(f'{x:.3f}' for x in world)}) taken out of the environment "
            f"({share:.0%} of its light)")
    return dataclasses.replace(scene, environment=rest_env, punctual=tuple(scene.punctual) + (sun,)), [note]
