"""Is the Mitsuba reference "Cycles-like"? FLIP against Cycles' own seed-to-seed FLIP, and region means.

A step of a run's measure stage (:func:`measure_likeness`): with ``--materials cycles`` (``cycles-ggx``), the
run of a renderer that draws the materials as that mode models them (:meth:`Renderer.models`, Cycles) is
compared with the reference. It orchestrates two engines, so it lives above both.

Two Cycles renders with different seeds (A, B) and two independent Mitsuba
renders (M1, M2), all of N samples per pixel, at the scene's resolution:

* ``flip_seed`` = FLIP(A, B): what noise alone costs at N spp.
* ``flip_cross`` = ½ (FLIP(M1, A) + FLIP(M2, B)): Mitsuba against Cycles.
* ``ratio`` = ``flip_cross`` / ``flip_seed``. Two renderers that converge to the
  same image with the same noise level give ≈ 1; a bias shows as > 1, and so
  does a reference noisier than Cycles at equal spp (``flip_mitsuba_seed`` =
  FLIP(M1, M2) tells which).
* Region means: the pixels of each mesh, and of its lit and shadowed parts,
  found by casting the camera's pixel rays and shadow rays towards each light
  (:func:`region_masks`). A region's mean agrees when, in every channel, the
  Cycles and Mitsuba means differ by at most :data:`Z_SCORE` combined standard
  errors or by :data:`REL_TOLERANCE` of the region's brightest channel (so a
  channel 20× dimmer than the others, e.g. green on the red wall, is not held
  to 2 % of its own tiny value). Standard errors come from the seed
  differences: per pixel, (A − B)² / 2 estimates the variance of one render, so
  the mean of (A + B)/2 over n pixels has variance mean((A − B)²) / (4n)
  (assuming pixels are independent, as they are for both samplers).

Noise levels differ: Mitsuba's ``independent`` sampler is noisier at equal spp
than Cycles' Sobol sequence. Two ways to account for it, both reported:

* **Matched by samples** (``match_noise=True``): Mitsuba renders
  ``k × spp`` samples, ``k`` = relMSE(M1, M2) / relMSE(A, B) measured at
  ``spp`` (MSE falls as 1/spp), so that both renderers carry the same noise and
  ``ratio`` and ``relmse_ratio`` are ≈ 1 without bias. ``mitsuba_spp`` says
  what was rendered.
* **Matched in the formula**: relMSE adds variances, E relMSE(M, A) ≈ bias² +
  (relMSE(A, B) + relMSE(M1, M2))/2, so ``relmse_ratio_noise_matched`` =
  ``relmse_cross`` / the mean of the two seed-to-seed relMSEs is ≈ 1 without
  bias; for FLIP, which grows like the noise's standard deviation,
  ``ratio_noise_matched`` = ``flip_cross`` / √((``flip_seed``² +
  ``flip_mitsuba_seed``²)/2).

relMSE here is symmetric in its two images (denominator: the square of their
mean, plus :data:`compare.metrics.images.RELMSE_EPS`), so that neither renderer's
noise sits in the denominator alone.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from compare.scene.geometry import ray_cast
from compare.scene.loader import Scene

#: Version of the measurement (part of its key in a run's folder): bump it when the numbers it gives change.
LIKENESS_VERSION = 1
#: Standard errors within which two region means count as agreeing (3: p ≈ 0.003 per test).
Z_SCORE = 3.0
#: Relative difference within which two region means count as agreeing regardless of noise.
REL_TOLERANCE = 0.02
#: Smallest region, in pixels, worth a mean.
MIN_REGION_PIXELS = 12
#: Shadow-ray samples per light (a stratified grid) for the lit/shadowed split.
SHADOW_GRID = 4


# ----------------------------------------------------------------------------- ray casting


def _triangles(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """All triangles (T, 3, 3) of meshes and lights, with labels (mesh index, or −1 − light index)."""
    tris, labels = [], []
    for k, mesh in enumerate(scene.meshes):
        t = mesh.triangles()
        tris.append(t.positions[t.indices].astype(np.float64))
        labels.append(np.full(len(t.indices), k))
    for k, light in enumerate(scene.lights):
        c = light.corners()
        tris.append(np.array([[c[0], c[1], c[2]], [c[0], c[2], c[3]]]))
        labels.append(np.full(2, -1 - k))
    return np.concatenate(tris), np.concatenate(labels)


class _NumpyCaster:
    """Rays against the scene's triangles in numpy (for Mitsuba's scalar variant; fine for small scenes)."""

    def __init__(self, scene: Scene):
        self.tris, self.labels = _triangles(scene)

    def closest(self, o: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t, idx = ray_cast(o, d, self.tris)
        label = np.where(idx >= 0, self.labels[np.maximum(idx, 0)], _MISS)
        tri = self.tris[np.maximum(idx, 0)]
        ng = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        return t, label, ng / np.maximum(np.linalg.norm(ng, axis=1, keepdims=True), 1e-300)

    def occluded(self, o: np.ndarray, d: np.ndarray, t_max: np.ndarray) -> np.ndarray:
        return np.isfinite(ray_cast(o, d, self.tris, t_max=t_max)[0])


class _MitsubaCaster:
    """Rays against the reference's own Mitsuba scene (its BVH; vectorised variants only).

    That scene is in the reference's world units (:func:`compare.mitsuba.scene_dict.world_scale`):
    rays go in and distances come out in the scene's own.
    """

    def __init__(self, scene: Scene, mi):
        import drjit as dr

        from compare.mitsuba.scene_dict import scene_dict, world_scale

        self.mi, self.dr = mi, dr
        self.scale = world_scale(scene)
        self.scene = mi.load_dict(scene_dict(scene, spp=1, materials="diffuse", scale=self.scale))
        # Shape pointers reinterpreted as integers identify the shape hit; names say which mesh.
        self.ids = {}
        for shape in self.scene.shapes():
            ptr = int(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(shape))[0])
            name = shape.id()
            self.ids[ptr] = int(name[4:]) if name.startswith("mesh") else -1 - int(name[5:])

    def _ray(self, o, d, t_max=None):
        mi = self.mi
        o = np.asarray(o, dtype=np.float64) * self.scale
        ray = mi.Ray3f(mi.Point3f(*(np.ascontiguousarray(o[:, k], dtype=np.float32) for k in range(3))),
                       mi.Vector3f(*(np.ascontiguousarray(d[:, k], dtype=np.float32) for k in range(3))))
        if t_max is not None:
            ray.maxt = mi.Float(np.ascontiguousarray(np.asarray(t_max, dtype=np.float64) * self.scale,
                                                     dtype=np.float32))
        return ray

    def closest(self, o: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        si = self.scene.ray_intersect(self._ray(o, d))
        ptr = np.asarray(self.dr.reinterpret_array(self.mi.UInt32, si.shape))
        label = np.array([self.ids.get(int(p), _MISS) for p in ptr])
        t = np.asarray(si.t, dtype=np.float64) / self.scale
        ng = np.stack([np.asarray(si.n[k], dtype=np.float64) for k in range(3)], axis=1)
        return np.where(label == _MISS, np.inf, t), label, ng

    def occluded(self, o: np.ndarray, d: np.ndarray, t_max: np.ndarray) -> np.ndarray:
        return np.asarray(self.scene.ray_test(self._ray(o, d, t_max)), dtype=bool)


_MISS = -10**6


def _caster(scene: Scene):
    from compare.mitsuba.backend import load_mitsuba

    mi = load_mitsuba(None)
    return _NumpyCaster(scene) if mi.variant().startswith("scalar") else _MitsubaCaster(scene, mi)


def region_masks(scene: Scene, *, min_pixels: int = MIN_REGION_PIXELS, caster=None) -> dict[str, np.ndarray]:
    """Boolean (H, W) masks of image regions: each mesh, and its lit and shadowed parts.

    A pixel belongs to a mesh when its centre and its four corners all hit that
    mesh (edge pixels, where pixel filters differ, are left out). ``lit``: every
    shadow ray from the centre's hit point to a :data:`SHADOW_GRID`² grid on
    every light arrives; ``shadowed``: none does (umbra). Penumbra pixels belong
    to neither. Regions smaller than ``min_pixels`` are dropped. Rays are cast
    in the reference's Mitsuba scene (lights are occluders there, as in the
    Blender export), or in numpy on Mitsuba's scalar variant (``caster="numpy"``
    forces that).
    """
    cam = scene.camera
    h, w = cam.height, cam.width
    caster = _NumpyCaster(scene) if caster == "numpy" else caster or _caster(scene)
    jj, ii = np.mgrid[0:h, 0:w]
    origin = np.broadcast_to(np.asarray(cam.position, dtype=np.float64), (h * w, 3))
    label = None
    same = np.ones(h * w, dtype=bool)
    for dx, dy in ((0.5, 0.5), (0.02, 0.02), (0.98, 0.02), (0.02, 0.98), (0.98, 0.98)):
        d = cam.ray_directions(ii + dx, jj + dy).reshape(-1, 3)
        t, lab, ng = caster.closest(origin, d)
        if label is None:
            label, centre_t, centre_d, centre_ng = lab, t, d, ng
        else:
            same &= lab == label
    hit = np.isfinite(centre_t) & (label >= 0) & same

    # Shadow rays from the centre hits, offset along the geometric normal towards the camera.
    points = origin + centre_d * np.where(np.isfinite(centre_t), centre_t, 0.0)[:, None]
    ng = centre_ng * -np.sign(np.sum(centre_ng * centre_d, axis=1, keepdims=True))
    points = points + ng * 1e-4 * max(1.0, float(np.abs(points[hit]).max(initial=1.0)))
    seen = np.zeros(h * w)
    total = 0
    for light in scene.lights:
        c = light.corners()
        g = (np.arange(SHADOW_GRID) + 0.5) / SHADOW_GRID
        for a in g:
            for b in g:
                target = c[0] + a * (c[1] - c[0]) + b * (c[3] - c[0])
                to = target - points
                dist = np.linalg.norm(to, axis=1)
                dirs = to / np.maximum(dist, 1e-300)[:, None]
                facing = (dirs @ np.asarray(light.normal)) < 0  # the point is in front of the light
                front = np.sum(dirs * ng, axis=1) > 0
                vis = np.zeros(h * w, dtype=bool)
                vis[hit] = ~caster.occluded(points[hit], dirs[hit], dist[hit] * (1 - 1e-4))
                seen += vis & facing & front
                total += 1
    frac = seen / max(total, 1)

    out: dict[str, np.ndarray] = {}
    for k, mesh in enumerate(scene.meshes):
        m = hit & (label == k)
        parts = [(mesh.name, m)]
        if scene.lights:
            parts += [(f"{mesh.name} lit", m & (frac >= 1.0)), (f"{mesh.name} shadowed", m & (frac <= 0.0))]
        for name, mask in parts:
            # A part equal to the whole mesh (a ceiling behind a one-sided light) says nothing new.
            if mask.sum() >= min_pixels and name not in out and (name == mesh.name or mask.sum() < m.sum()):
                out[name] = mask.reshape(h, w)
    return out


# ----------------------------------------------------------------------------- statistics


@dataclass
class RegionStat:
    """Mean radiance of one region in both renderers, with standard errors."""

    name: str
    pixels: int
    cycles: list[float]
    mitsuba: list[float]
    se_cycles: list[float]
    se_mitsuba: list[float]

    @property
    def scale(self) -> float:
        """The region's brightest Mitsuba channel: the unit of the relative tolerance."""
        return max(max(abs(m) for m in self.mitsuba), 1e-12)

    @property
    def rel_diff(self) -> float:
        """Largest difference over the channels, relative to the brightest channel (:attr:`scale`)."""
        return max(abs(c - m) for c, m in zip(self.cycles, self.mitsuba)) / self.scale

    @property
    def rel_diff_channel(self) -> float:
        """Largest difference over the channels, each relative to its own Mitsuba mean."""
        return max(abs(c - m) / max(abs(m), 1e-12) for c, m in zip(self.cycles, self.mitsuba))

    @property
    def z(self) -> float:
        """Largest difference in combined standard errors over the channels."""
        return max(abs(c - m) / max(math.hypot(sc, sm), 1e-300)
                   for c, m, sc, sm in zip(self.cycles, self.mitsuba, self.se_cycles, self.se_mitsuba))

    @property
    def agrees(self) -> bool:
        """Within :data:`Z_SCORE` standard errors or :data:`REL_TOLERANCE` relatively, in every channel."""
        return all(abs(c - m) <= max(Z_SCORE * math.hypot(sc, sm), REL_TOLERANCE * self.scale)
                   for c, m, sc, sm in zip(self.cycles, self.mitsuba, self.se_cycles, self.se_mitsuba))

    def as_dict(self) -> dict[str, Any]:
        return {"name": self.name, "pixels": self.pixels, "cycles": self.cycles, "mitsuba": self.mitsuba,
                "se_cycles": self.se_cycles, "se_mitsuba": self.se_mitsuba, "rel_diff": self.rel_diff,
                "rel_diff_channel": self.rel_diff_channel, "z": self.z, "agrees": self.agrees}


def region_stats(masks: dict[str, np.ndarray], a: np.ndarray, b: np.ndarray, m1: np.ndarray,
                 m2: np.ndarray) -> list[RegionStat]:
    """Region means of (A+B)/2 and (M1+M2)/2 with standard errors from the pair differences."""
    out = []
    for name, mask in masks.items():
        n = int(mask.sum())

        def mean_se(x, y):
            x, y = x[mask].astype(np.float64), y[mask].astype(np.float64)
            mean = 0.5 * (x + y).mean(axis=0)
            se = np.sqrt(np.mean((x - y) ** 2, axis=0) / (4 * n))
            return mean.tolist(), se.tolist()

        c, sc = mean_se(a, b)
        m, sm = mean_se(m1, m2)
        out.append(RegionStat(name, n, c, m, sc, sm))
    return out


def relmse_symmetric(a: np.ndarray, b: np.ndarray) -> float:
    """``mean((a - b)² / (((a + b)/2)² + eps))``: relMSE with neither image as the reference."""
    from compare.metrics.images import RELMSE_EPS

    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if a.shape != b.shape or not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise ValueError("relmse_symmetric: expected two finite images of one shape")
    return float(np.mean((a - b) ** 2 / ((0.5 * (a + b)) ** 2 + RELMSE_EPS)))


@dataclass
class Likeness:
    """The outcome of :func:`cycles_likeness` for one scene."""

    scene: str
    spp: int
    resolution: tuple[int, int]
    materials: str
    flip_seed: float
    flip_cross: float
    flip_mitsuba_seed: float
    relmse_seed: float = math.nan
    relmse_cross: float = math.nan
    relmse_mitsuba_seed: float = math.nan
    mitsuba_spp: int = 0
    distribution: str = ""
    regions: list[RegionStat] = field(default_factory=list)
    images: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    seconds: dict[str, float] = field(default_factory=dict)

    @property
    def ratio(self) -> float:
        """FLIP(Mitsuba, Cycles) / FLIP(Cycles seed A, seed B)."""
        return self.flip_cross / max(self.flip_seed, 1e-12)

    @property
    def ratio_noise_matched(self) -> float:
        """FLIP(Mitsuba, Cycles) / √((FLIP(A, B)² + FLIP(M1, M2)²)/2): ≈ 1 for unbiased renderers."""
        return self.flip_cross / max(math.sqrt(0.5 * (self.flip_seed ** 2 + self.flip_mitsuba_seed ** 2)), 1e-12)

    @property
    def relmse_ratio(self) -> float:
        """relMSE(Mitsuba, Cycles) / relMSE(Cycles seed A, seed B)."""
        return self.relmse_cross / max(self.relmse_seed, 1e-300)

    @property
    def relmse_ratio_noise_matched(self) -> float:
        """relMSE(Mitsuba, Cycles) / mean(relMSE(A, B), relMSE(M1, M2)): ≈ 1 for unbiased renderers."""
        return self.relmse_cross / max(0.5 * (self.relmse_seed + self.relmse_mitsuba_seed), 1e-300)

    @property
    def regions_agree(self) -> bool:
        return all(r.agrees for r in self.regions)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready summary (no images)."""
        return {"scene": self.scene, "spp": self.spp, "mitsuba_spp": self.mitsuba_spp,
                "resolution": list(self.resolution), "materials": self.materials,
                "distribution": self.distribution, "flip_seed": self.flip_seed, "flip_cross": self.flip_cross,
                "flip_mitsuba_seed": self.flip_mitsuba_seed, "ratio": self.ratio,
                "ratio_noise_matched": self.ratio_noise_matched, "relmse_seed": self.relmse_seed,
                "relmse_cross": self.relmse_cross, "relmse_mitsuba_seed": self.relmse_mitsuba_seed,
                "relmse_ratio": self.relmse_ratio, "relmse_ratio_noise_matched": self.relmse_ratio_noise_matched,
                "regions_agree": self.regions_agree, "regions": [r.as_dict() for r in self.regions],
                "seconds": self.seconds}


def cycles_likeness(scene: Scene, *, spp: int, materials: str = "cycles", seeds: tuple[int, int] = (0, 1),
                    exposure: float = 1.0, operator: str = "aces", cache_dir=None, progress: bool = False,
                    cycles=None, match_noise: bool = False, max_noise_factor: float = 16.0) -> Likeness:
    """Compare Cycles with the Mitsuba reference at ``spp`` samples per pixel (see the module notes).

    ``materials`` is the reference's material mode (``"cycles"``: the plugin's
    model of Blender's Principled BSDF v2 with each material's distribution;
    ``"cycles-ggx"``: the same with GGX everywhere; ``"shared"``: the suite's
    glTF BSDF; ``"diffuse"``: Lambert; see :mod:`compare.mitsuba.scene_dict`).
    Cycles uses the Principled mapping of :mod:`compare.blender.export` with the
    distribution the mode models (``cycles-ggx``: GGX; otherwise each
    material's), or Lambert for ``"diffuse"`` (which isolates geometry, camera,
    lights and bounces from the BSDF models). FLIP is LDR-FLIP after
    ``exposure`` and ``operator`` (:func:`compare.metrics.images.flip`). ``cycles``:
    two finished Cycles renders (:class:`~compare.blender.render.BlenderResult`)
    of ``spp`` samples, seeds A and B, with that distribution, to reuse instead
    of rendering them again. ``match_noise``: render Mitsuba with as many more
    samples as its noise needs to equal Cycles' (at most ``max_noise_factor`` ×).
    """
    from compare.metrics.images import flip
    from compare.mitsuba.scene_dict import PRINCIPLED_MODES
    from compare.mitsuba.reference import ReferenceRenderer
    from compare.blender.render import render_blender

    bm = "diffuse" if materials == "diffuse" else "cycles"
    forced = PRINCIPLED_MODES.get(materials)
    if cycles is None:
        cycles = tuple(render_blender(scene, engine="cycles", samples=spp, seed=sd, materials=bm, distribution=forced)
                       for sd in seeds)
    ra, rb = cycles
    if ra.samples != spp or rb.samples != spp or ra.metadata.get("materials") != bm:
        raise ValueError(f"cycles: expected two {bm} renders of {spp} spp, got {ra.samples} and {rb.samples}")
    dist = {ra.metadata.get("distribution"), rb.metadata.get("distribution")}
    if bm == "cycles" and forced and dist != {forced.upper()}:
        raise ValueError(f"cycles: materials {materials!r} models {forced.upper()}, the renders have {sorted(dist)}")
    ref = ReferenceRenderer(scene, materials=materials, cache_dir=cache_dir, progress=progress)
    t0 = time.perf_counter()
    m1, m2 = ref.independent_passes(2, spp, seed=seeds[0])
    m_spp = int(spp)
    relmse_seed = relmse_symmetric(ra.image, rb.image)
    if match_noise:
        k = relmse_symmetric(m1, m2) / max(relmse_seed, 1e-300)
        if k > 1.05:
            m_spp = int(math.ceil(min(k, max_noise_factor) * spp))
            m1, m2 = ref.independent_passes(2, m_spp, seed=seeds[0])
    t_ref = time.perf_counter() - t0

    def f(r, t):
        return flip(r, t, exposure=exposure, operator=operator)[0]

    cross = 0.5 * (f(m1, ra.image) + f(m2, rb.image))
    masks = region_masks(scene)
    cam = scene.camera
    return Likeness(
        scene=scene.name, spp=int(spp), resolution=(cam.width, cam.height), materials=materials,
        flip_seed=f(ra.image, rb.image), flip_cross=cross, flip_mitsuba_seed=f(m1, m2),
        relmse_seed=relmse_seed,
        relmse_cross=0.5 * (relmse_symmetric(m1, ra.image) + relmse_symmetric(m2, rb.image)),
        relmse_mitsuba_seed=relmse_symmetric(m1, m2), mitsuba_spp=m_spp,
        distribution="/".join(sorted(d for d in dist if d)),
        regions=region_stats(masks, ra.image, rb.image, m1, m2),
        images={"cycles_a": ra.image, "cycles_b": rb.image, "mitsuba_1": m1, "mitsuba_2": m2},
        seconds={"cycles_each": 0.5 * (ra.seconds + rb.seconds), "mitsuba_both": t_ref},
    )


@dataclass
class FinishedRender:
    """One finished Cycles render as :func:`cycles_likeness` reads it (a BlenderResult has the same fields)."""

    image: np.ndarray
    samples: int
    metadata: dict
    seconds: float


def summary(res: Likeness) -> dict[str, Any]:
    """What a run records of a likeness (results.json's ``likeness`` of a scene)."""
    agree = sum(1 for r in res.regions if r.agrees)
    return {"flip_cross": res.flip_cross, "flip_seed": res.flip_seed, "flip_mitsuba_seed": res.flip_mitsuba_seed,
            "ratio": res.ratio, "ratio_noise_matched": res.ratio_noise_matched, "relmse_ratio": res.relmse_ratio,
            "relmse_ratio_noise_matched": res.relmse_ratio_noise_matched, "spp": res.spp,
            "mitsuba_spp": res.mitsuba_spp, "materials": res.materials, "distribution": res.distribution,
            "regions": f"{agree}/{len(res.regions)}"}


def measure_likeness(scene: Scene, renderer, record: dict, first: np.ndarray, *, materials: str, context) -> dict:
    """The likeness of the reference in mode ``materials`` to ``renderer``'s finished run (``record``, its final
    image ``first``, seed A): one more render of it through the renderer protocol (seed A + 1) and two
    independent reference passes with as many samples as give them its noise (:func:`cycles_likeness`)."""
    steps, seed = int(record["steps"]), int(record["seed"])
    given, _ = renderer.prepare(scene)
    again = renderer.render(given, steps=steps, checkpoints=[steps], seed=seed + 1, context=context)
    a = FinishedRender(first, steps, dict(record["metadata"]), float(record["points"][-1]["seconds"]))
    last = again.checkpoints[-1]
    b = FinishedRender(np.asarray(last.image, dtype=np.float32), steps, dict(again.metadata), float(last.seconds))
    res = cycles_likeness(scene, spp=steps, materials=materials, seeds=(seed, seed + 1), cache_dir=context.cache_dir,
                          cycles=(a, b), match_noise=True, exposure=context.settings.exposure,
                          operator=context.settings.tonemap)
    return summary(res)
