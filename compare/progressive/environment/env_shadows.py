"""Environment light that converges to its shadows: progressive environment shadow maps
(``progressive:envshadows``).

Screen-space occlusion (``env_occlusion.glsl``) sees only occluders on screen and within ``d_occ``.
Here each environment sample of the distributor's plan (:class:`~compare.progressive.schedule.distributor.EnvSample`;
its index picks a point of one Sobol sequence) is instead a direction drawn from the environment map in proportion to its
luminance, with an orthographic shadow map fitted to the scene (the directional light's map of
:mod:`compare.progressive.lights.punctual`), so every occluder of the scene casts its environment shadow,
on screen or not.

Estimator
---------
The unshadowed direct environment light stays the split sum (``accumulate.glsl``, converged from the
first frame); the shadows are a ratio, as the ``ltc`` area model's (Heitz, Hill & McGuire 2018)::

    shadowed ≈ Σ_lobe unshadowed_lobe · Σ_k V(ω_k) g(ω_k) / Σ_k g(ω_k),   g = luminance(f_lobe(v, ω) cos θ)

with ω_k drawn with density ∝ L(ω) (the map's luminance, ``env_shadows.glsl``): luminance / pdf is
then one constant and cancels, and each ratio converges to ∫ V L f cos / ∫ L f cos, the shadowed share
of that lobe's direct environment light (in luminance). The display weights the diffuse and the
specular ratio by the lobes' unshadowed split-sum luminance (kept beside the sums): one ratio for both
lobes let a glossy lobe's few samples (a peak of g where a sample falls near the mirror direction)
darken the diffuse light too, in streaks behind occluders. A specular ratio resting on few samples
(Kish's effective count (Σ g)² / Σ g² below :data:`SPECULAR_SAMPLES`) is blended towards the diffuse
one: the specular occlusion of a narrow lobe is the diffuse visibility until enough samples have
fallen inside it (the blend is a bias that the samples remove). The sums are kept over all frames
(each at its own jitter) and never reset: the ratio is consistent, the image unbiased in the limit up to
the split sum's own approximation. Why a ratio rather than a direct MIS estimate of the integral: the
unshadowed part stays exact and noise-free from the first frame, and only the visibility is estimated
(the estimate of ∫ L f cos by a few luminance samples would be noisy on glossy surfaces). Its weakness
is the same as ``ltc``'s: on a narrow specular lobe few samples fall inside it, and the ratio is that
of the samples nearby.

Directions
----------
Each ratio's error is that of a quadrature of the visibility over a few directions: an occluder that hides
a cap of the sky is counted by the directions that fall inside it, and one direction more or less is a
step of g_k / Σ g in the ratio. The error is the point set's discrepancy over caps (every pixel reads the
same directions, so it shows as a smooth per-pixel bias at a finite count, not as noise), and three things
keep it small:

* the directions are Sobol's low-discrepancy sequence through the map's luminance CDF
  (:func:`~compare.progressive.schedule.sampling.sobol2`; any 2^k consecutive directions from index 0
  share the map's light out evenly, one per elementary box of the square the CDF maps), not independent
  draws, and every prefix (the image after each frame) is as even as the whole;
* a frame takes :data:`DIRECTIONS_PER_FRAME` of them by default (N = that × (m − 1) for m frames, where
  the screen-space samples have N = m): a cap's count error shrinks about as N^(-3/4), and the
  paper's 128 frames then hold the closed form of tests/test_env_shadows.py within 3 % per pixel for
  every seed (docs/performance-notes.md gives the measurements behind the choice);
* each map is a tile of :data:`TILE_FRACTION` of the shadow size a side: the mean over many directions
  smooths a coarser map's steps as percentage-closer filtering would, while contact shadows (a car on
  its floor) still need the texels (docs/performance-notes.md). A map's cost on a CPU rasterizer is its
  occluders' vertices, not its texels.

One pass shades a frame's directions together (up to :data:`BATCH` tiles of one shadow atlas): the split
sum and the G-buffer reads are shared, and a direction more costs its shadow map and a BRDF evaluation.

The distributor places these samples as it places the screen-space ones (frames 1 … m−1, frame 0 stays
the cheap preview), so the frame budget schedules them alike; screen-space occlusion is off with them.
"""

from __future__ import annotations

import copy
import math

import numpy as np

from compare.progressive.frame.accumulate import ENV_SPECULAR_SAMPLES
from compare.progressive.frame.gpu_scene import mat_bytes
from compare.progressive.gl.passes import RenderPass
from compare.progressive.gl.shaders import load_program, set_uniform
from compare.progressive.gl.units import bind, units_of
from compare.progressive.lights.punctual import ShadowMap, set_shadow_maps, visible_points
from compare.progressive.schedule.sampling import sobol2
from compare.scene.equirect import rotation_matrix, uv_to_direction

#: Effective samples (Kish: (Σ g)² / Σ g²) from which the specular ratio is taken alone; below, it is
#: blended towards the diffuse ratio in proportion. The display blends (compose.glsl), so the constant is
#: the compose pass's; :meth:`EnvShadows.ratio` does as the display does.
SPECULAR_SAMPLES = ENV_SPECULAR_SAMPLES

#: Directions (shadow maps) a frame evaluates by default: :func:`default_directions`.
DIRECTIONS_PER_FRAME = 8
#: Side of a direction's shadow map as a fraction of ``shadow_size`` (module notes).
TILE_FRACTION = 0.5
#: Most shadow maps one pass shades (tiles of one atlas, ``env_shadows.glsl``'s BATCH).
BATCH = 8
#: Most texels of the atlas: fewer tiles per pass for large maps.
ATLAS_TEXELS = 4096 * 4096

_UNITS = units_of("env_shadows.glsl")


def default_directions(frames: int) -> int:
    """The environment shadow maps of a render of ``frames`` frames: :data:`DIRECTIONS_PER_FRAME` in each
    frame after frame 0 (which stays the cheap preview); one frame's worth for a single frame (which then
    has none: the distributor's note says so)."""
    return DIRECTIONS_PER_FRAME * max(int(frames) - 1, 1)


def atlas_layout(batch: int, size: int) -> tuple[int, int]:
    """(columns, rows) of an atlas of ``batch`` tiles of ``size``² texels, as square as it goes."""
    cols = math.ceil(math.sqrt(batch))
    return cols, math.ceil(batch / cols)


def luminance_sampler(image: np.ndarray):
    """A function ``u (N, 2) → (directions (N, 3) in the map's frame)`` drawing directions with density
    ∝ the map's luminance, piecewise constant on the texels' cells (rows j of v ∈ [j/H, (j+1)/H)):
    a cell by its luminance times its solid angle, then a direction uniform in solid angle within it."""
    img = np.asarray(image, dtype=np.float64)
    h, w = img.shape[:2]
    lum = img[..., 0] * 0.2126 + img[..., 1] * 0.7152 + img[..., 2] * 0.0722
    # Each cell's solid angle is ∝ cos θ_top − cos θ_bottom; within a cell, cos θ is drawn uniformly, so
    # the density is ∝ the cell's luminance over the whole cell (uniform v would crowd the poles).
    cos_edges = np.cos(np.arange(h + 1) / h * np.pi)
    solid = (cos_edges[:-1] - cos_edges[1:])[:, None]
    weight = np.maximum(lum, 0.0) * solid
    if not np.isfinite(weight).all() or weight.sum() <= 0:
        weight = np.broadcast_to(solid, (h, w)).copy()  # black map: uniform on the sphere
    rows = weight.sum(axis=1)
    row_cdf = np.concatenate([[0.0], np.cumsum(rows)]) / rows.sum()
    col_cdf = np.concatenate([np.zeros((h, 1)), np.cumsum(weight, axis=1)], axis=1)
    col_cdf /= np.where(col_cdf[:, -1:] > 0, col_cdf[:, -1:], 1.0)

    def sample(u) -> np.ndarray:
        u = np.asarray(u, dtype=np.float64).reshape(-1, 2)
        j = np.clip(np.searchsorted(row_cdf, u[:, 1], side="right") - 1, 0, h - 1)
        fv = (u[:, 1] - row_cdf[j]) / np.maximum(row_cdf[j + 1] - row_cdf[j], 1e-300)
        i = np.array([np.clip(np.searchsorted(col_cdf[jj], uu, side="right") - 1, 0, w - 1)
                      for jj, uu in zip(j, u[:, 0])], dtype=int)
        fu = (u[:, 0] - col_cdf[j, i]) / np.maximum(col_cdf[j, i + 1] - col_cdf[j, i], 1e-300)
        cos_t = cos_edges[j] + np.clip(fv, 0, 1) * (cos_edges[j + 1] - cos_edges[j])
        return uv_to_direction((i + np.clip(fu, 0, 1)) / w, np.arccos(np.clip(cos_t, -1.0, 1.0)) / np.pi)

    return sample


class EnvShadows(RenderPass):
    """Shadow maps of the environment samples and the running sums of their shadow ratio."""

    def __init__(self, ctx, gpu_scene, scene, camera, size: tuple[int, int], environment, samples, *,
                 shadow_size: int, materials: str = "shared", seed: int = 0):
        from compare.scene.model import PunctualLight

        size_s = self.shadow_size = max(16, round(int(shadow_size) * TILE_FRACTION))
        """Side of each direction's map (a tile of the atlas), :data:`TILE_FRACTION` of ``shadow_size``."""
        self.ctx = ctx
        self.scene = gpu_scene
        sample = luminance_sampler(environment.image)
        # One sequence over all samples by their index (the screen-space samples' points restart per
        # kind, which would draw each direction twice), shifted by the plan's seed.
        points = sobol2([s.index for s in samples], seed, stream=7)
        to_world = rotation_matrix(environment.rotation)
        directions = sample(points) @ to_world.T if len(points) else np.zeros((0, 3))
        self.directions = {s.index: d / np.linalg.norm(d) for s, d in zip(samples, directions)}
        bounds = scene.extent()
        corners = visible_points(camera, bounds)
        # Fitted once per direction at setup: a frame only renders its samples' maps.
        self.maps = {k: ShadowMap(PunctualLight("environment", "directional", (0.0, 0.0, 0.0), tuple(-d),
                                                (1.0, 1.0, 1.0)), bounds, corners, size_s)
                     for k, d in self.directions.items()}
        self._objects: list = []
        self.casters = {}
        self.batch = max(1, min(BATCH, ATLAS_TEXELS // (size_s * size_s), max(len(samples), 1)))
        """Shadow maps one pass shades (the atlas' tiles)."""
        cols, rows = atlas_layout(self.batch, size_s)
        self.tiles = [((k % cols) * size_s, (k // cols) * size_s) for k in range(self.batch)]
        try:
            self.depth = self._keep(ctx.depth_texture((cols * size_s, rows * size_s)))
            self.depth.compare_func = ""
            self.depth.filter = (ctx.NEAREST, ctx.NEAREST)
            self.depth_fbo = self._keep(ctx.framebuffer(depth_attachment=self.depth))
            self.casters = gpu_scene.occluder_programs(ctx, "shadow.glsl", {"ORTHO": 1})
            self.environment = environment
            self.program = self._keep(load_program(ctx, "env_shadows.glsl", {**environment.defines(materials),
                                                                               **gpu_scene.layer_defines(materials),
                                                                               "BATCH": self.batch}))
            self.vao = self._keep(ctx.vertex_array(self.program, []))
            self.sums = self._keep(ctx.texture(size, 4, dtype="f4"))
            self.weights = self._keep(ctx.texture(size, 4, dtype="f4"))
            for tex in (self.sums, self.weights):
                tex.filter = (ctx.NEAREST, ctx.NEAREST)
            self.sums_fbo = self._keep(ctx.framebuffer([self.sums, self.weights]))
        except BaseException:
            self.release()
            raise
        self.count = 0
        """Samples folded into the sums since :meth:`reset`."""
        self.reset()

    def _keep(self, obj):
        self._objects.append(obj)
        return obj

    def run(self, samples, gbuffer, camera_position, bias) -> None:
        """Render the samples' shadow maps and add their ratio terms at this frame's G-buffer, up to
        :attr:`batch` samples per pass."""
        samples = list(samples)
        for i in range(0, len(samples), self.batch):
            self._run_batch(samples[i:i + self.batch], gbuffer, camera_position, bias)

    def _run_batch(self, samples, gbuffer, camera_position, bias) -> None:
        ctx = self.ctx
        size = self.shadow_size
        self.depth_fbo.use()
        ctx.enable_only(ctx.DEPTH_TEST)
        ctx.depth_func = "<"
        maps = []
        for s, (x, y) in zip(samples, self.tiles):
            m = copy.copy(self.maps[s.index])
            m.rects = np.array([(x, y, size, size)], dtype=np.float32)  # its tile of the atlas
            maps.append(m)
            self.depth_fbo.clear(depth=1.0, viewport=(x, y, size, size))  # the tiles this batch uses only
            ctx.viewport = (x, y, size, size)
            for program in self.casters.values():
                set_uniform(program, "u_sample", tuple(float(c) for c in m.origin))
                set_uniform(program, "u_inv_far", 1.0 / m.far)
                set_uniform(program, "u_direction", tuple(float(c) for c in m.direction))
                set_uniform(program, "u_view_proj", mat_bytes(m.view_proj[0]))
            self.scene.draw_occluders(self.casters)
        self.sums_fbo.use()
        ctx.enable_only(ctx.BLEND)
        ctx.blend_func = ctx.ONE, ctx.ONE
        ctx.blend_equation = ctx.FUNC_ADD
        p = self.program
        gbuffer.bind(p)
        gbuffer.bind_layers(p)
        bind(p, "u_pshadow_map", self.depth, _UNITS["shadow"])
        set_uniform(p, "u_camera_position", tuple(float(c) for c in camera_position))
        directions = np.zeros((self.batch, 3), dtype=np.float32)
        directions[:len(samples)] = [self.directions[s.index] for s in samples]
        set_uniform(p, "u_directions", directions.tobytes())
        set_uniform(p, "u_count", len(samples))
        set_shadow_maps(p, maps + maps[:1] * (self.batch - len(maps)))  # unused slots: any valid map
        set_uniform(p, "u_bias", tuple(float(b) for b in bias))
        self.environment.bind(p, _UNITS["environment"])
        self.vao.render(vertices=3)
        self.count += len(samples)

    def ratio(self, what: str) -> np.ndarray:
        """The display's ratio per pixel, (H, W) float32, as ``compose.glsl`` computes it."""
        from compare.progressive.gl.readback import read_texture_rgba

        sums = read_texture_rgba(self.ctx, self.sums, what=what).astype(np.float64)
        e = read_texture_rgba(self.ctx, self.weights, what=what).astype(np.float64)

        def part(num, den):
            return np.where(den > 0, num / np.where(den > 0, den, 1.0), 1.0)

        r_d, r_s = part(sums[..., 0], sums[..., 1]), part(sums[..., 2], sums[..., 3])
        n_eff = np.where(e[..., 2] > 0, sums[..., 3] ** 2 / np.where(e[..., 2] > 0, e[..., 2], 1.0), 0.0)
        t = np.clip(n_eff / SPECULAR_SAMPLES, 0.0, 1.0)
        r_s = r_d + (r_s - r_d) * t
        total = e[..., 0] + e[..., 1]
        return np.where(total > 0, (r_d * e[..., 0] + r_s * e[..., 1]) / np.where(total > 0, total, 1.0),
                        r_d).astype(np.float32)

    def reset(self) -> None:
        """Clear the ratio's sums."""
        self.sums_fbo.use()
        self.sums_fbo.clear(0.0, 0.0, 0.0, 0.0)
        self.count = 0

    def describe(self) -> dict:
        """How the environment light is shadowed, the maps' size and count."""
        size = self.shadow_size
        return {"occlusion": "environment shadow maps",
                "env_occlusion": "environment shadow maps (luminance-sampled directions, shadow ratio)",
                "env_shadow_size": int(size), "env_shadow_samples": len(self.maps)}

    def release(self) -> None:
        if self.casters:
            self.scene.release_programs(self.casters)
            self.casters = {}
        for obj in reversed(self._objects):
            obj.release()
        self._objects = []
