"""The progressive renderer: frames, accumulation, timing, checkpoints.

One frame f of the :class:`~compare.progressive.schedule.distributor.Plan`:

1. G-buffer pass with frame f's sub-pixel jitter (``gbuffer.glsl``);
2. the every-frame running mean over all frames (``accumulate.glsl``):
   emission and the background, and — with an environment, in a second
   target — the unoccluded environment light (split-sum specular + diffuse
   irradiance, ``compare/ibl/ibl.glsl``; :mod:`compare.progressive.environment.environment`);
   with ``indirect="probes"``, in the first frames only, the running mean of the
   indirect diffuse light of an irradiance volume, baked just before the first frame
   that reads it (frame 1 after the forward frame 0; in that frame's seconds, not the set-up's)
   (:mod:`compare.progressive.indirect.probes`, ``probe_bake_seconds``;
   :mod:`compare.progressive.indirect.indirect` says why only the first frames);
3. frame 0 only (frame 1 after a reduced frame 0, see below): the unshadowed
   preview of the direct light from each light's centre (``direct.glsl``
   without shadows), shown until every light has a sample;
4. for each light sample of the frame: its shadow atlas (``shadow.glsl``, five
   faces) and its direct-light pass (``direct.glsl``); the last one folds the
   frame's sum into the direct-light running mean over light frames;
5. with point, spot or directional lights (:mod:`compare.progressive.lights.punctual`): the shadow
   maps the frame's plan names (each light's once, kept), then every punctual light's exact
   light, shadowed where its map exists, folded into its own running mean;
6. frames with environment samples (1 … m−1, never frame 0): the screen-space
   occlusion of the environment light (``env_occlusion.glsl``): the visible
   light, folded into one running mean per kind (diffuse, specular) over that
   kind's samples;
7. blended meshes (:mod:`compare.progressive.blend`) and, last, glass (:mod:`compare.progressive.glass`:
   the frame's opaque image composed, the glass drawn over it refracting it, summed over frames).

With ``area_model="ltc"`` (:mod:`compare.progressive.lights.ltc`) step 3 goes: the
lights' unshadowed light in closed form is added to per-light sums in the first
G-buffer frame and about 32 more, and each light sample of step 4 adds to its
light's shadow-ratio sums instead of a running mean.

Frame 0 carries no samples and is drawn differently (``first_frame="forward"``,
:mod:`compare.progressive.first_frame`): a depth pre-pass and one forward-shaded
pass write its every-frame terms straight into the running mean and the
unshadowed preview into its own target, without the G-buffer and its
full-screen passes: the cheap first frame of the paper. From 320×240 up it is drawn
at half size by default (``first_frame_scale``) as a preview outside the running means;
frame 1 then draws the full-size unshadowed preview from its G-buffer.

The displayed image (``compose.glsl``) is the every-frame mean plus the
direct-light mean (or the preview until every light has a sample) plus the
punctual lights' mean plus the environment light: the unoccluded mean until both kinds of occlusion samples
have run, then the two means of visible light. After the last frame it is the full estimate; see
``distributor.py`` for why the weights make intermediate images nearly
unbiased too and keep the preview out of the result. Frame 0 is the
environment-only split-sum image: no occlusion, no shadow maps.

A scene without an environment gets none of this: no preprocessing, no
environment textures or programs, no environment samples.

Timing: each frame's wall time runs from its first GL call to ``ctx.finish()``
(as a real-time renderer presents each frame), and a GL timer query measures its
GPU time. Scene upload, shader compilation and one warm-up of frame 0 (and of frame
1 after a reduced frame 0) and of a light frame (drivers compile shaders at their
first draw) are counted separately
(``setup_seconds``), and so is readback: it happens only when an image is asked
for (:meth:`Rasterizer.image`).
"""

from __future__ import annotations

import dataclasses
import math
import textwrap
import time
import warnings
from dataclasses import dataclass, field
from typing import Iterator, Sequence

import numpy as np

from compare import __version__
from compare.renderers.base import Checkpoint
from compare.progressive.frame.accumulate import AccumulatePass, ComposePass, PingPong, Target
from compare.progressive.config import DEFAULT_D_OCC_FRACTION, RasterizerOptions
from compare.progressive.gl.context import check_image_size, create_context, gl_renderer_name
from compare.progressive.gl.passes import RenderPass
from compare.progressive.gl.srgb_probe import srgb_decode_error
from compare.progressive.lights.direct import DirectPass
from compare.progressive.environment.environment import (MAX_SAMPLES_PER_FRAME, EnvironmentLighting, EnvOcclusionPass,
                          EnvOcclusionTargets)
from compare.progressive.schedule.budget import BudgetScheduler, FrameCosts
from compare.progressive.schedule.distributor import DEFAULT_DIRECT_FRACTION, DEFAULT_FRAMES, FramePlan, Plan, plan
from compare.progressive.first_frame import FirstFramePass, auto_scale
from compare.progressive.frame.gbuffer import GBuffer
from compare.progressive.indirect.indirect import IndirectPass
from compare.progressive.lights.ltc import LTC_DIRECT_FRACTION, LtcLights
from compare.progressive.frame.gpu_scene import CameraSetup, GpuScene, mat_bytes
from compare.progressive.indirect.probes import ProbeVolume, indirect_options
from compare.progressive.gl.readback import read_rgb
from compare.progressive.blend import BlendPass
from compare.progressive.glass import GlassPass
from compare.progressive.environment.env_shadows import EnvShadows, default_directions as default_env_directions
from compare.progressive.lights.punctual import PunctualLights
from compare.progressive.lights.shadow import ShadowAtlas




@dataclass
class ProgressiveResult:
    """A finished progressive render."""

    image: np.ndarray
    """Linear radiance (H, W, 3) float32 after all frames."""
    seconds: float
    """Wall seconds of all frames (without setup and readback)."""
    frame_seconds: list[float]
    """Wall seconds of each frame."""
    gpu_frame_seconds: list[float]
    """GL timer-query seconds of each frame (NaN where the driver gave no answer)."""
    metadata: dict
    """str/int/float only: renderer, frames, seed, seconds, gl_renderer, area_model, ..."""
    checkpoints: list[Checkpoint] = field(default_factory=list)
    plan: Plan | None = None
    layers: dict[str, np.ndarray] = field(default_factory=dict)
    """The final image split by kind of light (:meth:`Rasterizer.layers`)."""


class Rasterizer:
    """Otto et al.'s progressive rasterizer (environment and area lights) for one scene.

    Parameters
    ----------
    scene : compare.scene.loader.Scene
        The scene; its camera resolution is the image size.
    options : RasterizerOptions, optional
        Every other setting (:class:`compare.progressive.config.RasterizerOptions`); keywords
        replace single fields of it (``Rasterizer(scene, frames=16, area_model="ltc")``).
    ctx : moderngl.Context, keyword-only
        A context to use (not released here); None creates a headless one.
    """

    def __init__(self, scene, options: RasterizerOptions | None = None, *, ctx=None, **keywords):
        o = options or RasterizerOptions()
        if keywords:
            o = dataclasses.replace(o, **keywords)  # TypeError names an unknown keyword; ValueError a bad value
        self.options = o
        sun_notes: list[str] = []
        #: Whether the only punctual light is the environment's sun (its light is reported as environment's).
        self._sun_only_punctual = False
        if o.sun:  # before anything reads the scene: the map without its sun, and the sun as a light
            from compare.progressive.environment.sun import scene_with_sun

            self._sun_only_punctual = not scene.punctual
            scene, sun_notes = scene_with_sun(scene, o.cache_dir)
            self._sun_only_punctual &= bool(scene.punctual)
        frames, seed, area_model, materials = o.frames, o.seed, o.area_model, o.materials
        shadow_bias, shadow_filter, d_occ = o.shadow_bias, o.shadow_filter, o.d_occ
        direct_fraction, frame_budget_ms = o.direct_fraction, o.frame_budget_ms
        indirect, probe_grid, probe_bounces = o.indirect, o.probe_grid, o.probe_bounces
        self.indirect, self.probe_grid, self.probe_bounces = indirect_options(scene, indirect, probe_grid,
                                                                              probe_bounces)
        self.scene = scene
        self.area_model = area_model
        self.materials = materials
        self.seed = int(seed)
        self.shadow_bias = tuple(float(b) for b in shadow_bias)
        self.shadow_filter = shadow_filter
        has_env = scene.features().environment
        if d_occ is None:
            lo, hi = scene.extent()
            d_occ = DEFAULT_D_OCC_FRACTION * float(np.linalg.norm(hi - lo))
        self.d_occ = float(d_occ) if has_env else 0.0
        self.occlusion_bias = float(o.occlusion_bias)
        if direct_fraction is None:
            direct_fraction = LTC_DIRECT_FRACTION if area_model == "ltc" else DEFAULT_DIRECT_FRACTION
        env_samples = o.env_samples
        if has_env and o.env_occlusion == "shadows" and env_samples is None:
            env_samples = default_env_directions(frames)  # several shadow maps per frame (env_shadows.py)
        self.plan = plan(scene, frames, seed=seed, direct_fraction=direct_fraction,
                         samples_per_light=o.samples_per_light,
                         env_samples=env_samples if (self.d_occ > 0 or (has_env and o.env_occlusion == "shadows"))
                         else 0)
        self.notes: list[str] = sun_notes + list(self.plan.notes)
        self.scheduler = None
        if frame_budget_ms is not None:
            self.scheduler = BudgetScheduler(self.plan, frame_budget_ms / 1000.0,
                                             max_env_per_frame=MAX_SAMPLES_PER_FRAME)
        self._check_features()

        t0 = time.perf_counter()
        self._own_ctx = ctx is None
        self.ctx = create_context() if ctx is None else ctx
        ctx = self.ctx
        size = (scene.camera.width, scene.camera.height)
        self.size = size
        self.passes: list[RenderPass] = []
        """Every pass, target and table of the render, in the order made (:class:`RenderPass`)."""
        try:
            self._build_passes(has_env)
        except BaseException:
            self.release()
            raise
        self.background = self._background()
        self.frame = 0
        """Frames rendered so far."""
        self._warming = False
        self.frame_seconds: list[float] = []
        self.gpu_frame_seconds: list[float] = []
        self.shadow_passes: list[int] = []
        """Shadow atlases rendered in each frame."""
        self._preview_valid = False
        self._lights_sampled: set[int] = set()
        for fp in self.plan:
            self._matrices(fp.jitter)
        if self.scheduler is not None:
            for jitter in self.scheduler.jitter:
                self._matrices((float(jitter[0]), float(jitter[1])))
        if o.warm_up or self.scheduler is not None:
            try:
                self._warming = True  # the warm-up leaves the probes' bake to the first frame that needs it
                self._warm_up()
                self._warming = False
                if self.scheduler is not None:
                    self._calibrate()
            except BaseException:
                self.release()
                raise
        self.setup_seconds = time.perf_counter() - t0
        """Seconds for context, upload, shader compilation and warm-up (not in :attr:`seconds`)."""

    # ------------------------------------------------------------------ setup helpers


    def _build_passes(self, has_env: bool) -> None:
        """Make every pass and target the scene needs, and no other (the pass graph), in :attr:`passes`."""
        o, scene, ctx, size = self.options, self.scene, self.ctx, self.size
        check_image_size(ctx, size, str(scene.path))
        self.camera = CameraSetup(scene)
        # glass apart from the G-buffer unless materials are Lambert-only (the reference's diffuse glass)
        self.gpu_scene = self._keep(GpuScene(ctx, scene, glass=o.materials != "diffuse"))
        self.gbuffer = self._keep(GBuffer(ctx, self.gpu_scene, size))
        self._build_environment(has_env)
        # No probe work unless indirect = "probes"; the bake is part of setup (timed on its own too).
        self.probes = None
        if self.indirect == "probes":
            self.probes = self._keep(ProbeVolume(
                ctx, scene, self.gpu_scene, grid=self.probe_grid, bounces=self.probe_bounces,
                shadow_bias=self.shadow_bias, environment=self.environment, materials=o.materials, seed=o.seed,
                cache_dir=o.cache_dir, lazy=True))
        self.accumulate = self._keep(AccumulatePass(ctx, self.environment, o.materials,
                                                    occlusion=self.gpu_scene.occluded,
                                                    layers=self.gpu_scene.layers_for(o.materials),
                                                    background=not scene.hides_background))
        self.indirect_pass = None
        if self.probes is not None:
            self.indirect_pass = self._keep(IndirectPass(ctx, self.probes, size, o.materials,
                                                         occlusion=self.gpu_scene.occluded))
        self.base = self._keep(PingPong(ctx, size, attachments=self.accumulate.attachments))
        self.compose = self._keep(ComposePass(ctx, size))
        # Frame 0 is forward-shaded when it carries no samples (first_frame.py).
        fp0 = self.plan[0]
        forward_first = (o.first_frame == "forward" and not fp0.light_samples and not fp0.env_samples
                         and not fp0.punctual)
        # Point, spot and directional lights: exact light every frame, one kept shadow map each (punctual.py).
        self.punctual = None
        if scene.punctual:
            self.punctual = self._keep(PunctualLights(ctx, self.gpu_scene, scene, self.camera, size,
                                                      shadow_size=o.shadow_size, materials=o.materials))
            self.notes += self.punctual.notes
        self._build_area_lights(forward_first)
        self._build_first_frame(forward_first)
        # Blended meshes: a sorted forward pass after the deferred frame (blend.py).
        self.blend = None
        if self.gpu_scene.blended:
            self.blend = self._keep(BlendPass(
                ctx, self.gpu_scene, size, scene.lights, environment=self.environment, punctual=self.punctual,
                area_model=o.area_model, materials=o.materials,
                lut_texture=self.direct.lut_texture if self.direct is not None else None, ltc_table=self.ltc_table))
        # Glass: a forward pass over the opaque frame, reading its image (glass.py).
        self.glass = None
        if self.gpu_scene.glassy:
            self.glass = self._keep(GlassPass(
                ctx, self.gpu_scene, size, scene.lights, environment=self.environment, punctual=self.punctual,
                area_model=o.area_model, materials=o.materials,
                lut_texture=self.direct.lut_texture if self.direct is not None else None, ltc_table=self.ltc_table))
        self.query = ctx.query(time=True)  # moderngl queries have no release(); freed with the context

    def _build_environment(self, has_env: bool) -> None:
        """The environment's textures and its occlusion: screen-space samples or shadow maps."""
        o, ctx, size = self.options, self.ctx, self.size
        # Leave out what the scene does not need: no environment work without an environment.
        self.environment = self.env_occlusion = self.env_acc = self.env_shadows = None
        if not has_env:
            return
        self.environment = self._keep(EnvironmentLighting(
            ctx, self.scene, env_format=o.env_format, env_diffuse=o.env_diffuse, ibl_size=o.ibl_size,
            ibl_levels=o.ibl_levels, ibl_samples=o.ibl_samples, cache_dir=o.cache_dir))
        if self.plan.env_frames > 0 and o.env_occlusion == "shadows":
            self.env_shadows = self._keep(EnvShadows(
                ctx, self.gpu_scene, self.scene, self.camera, size, self.environment,
                [s for fp in self.plan for s in fp.env_samples], shadow_size=o.shadow_size, materials=o.materials,
                seed=o.seed))
        elif self.plan.env_frames > 0:
            self.env_occlusion = self._keep(EnvOcclusionPass(ctx, self.environment, o.materials,
                                                             occlusion=self.gpu_scene.occluded,
                                                             layers=self.gpu_scene.layers_for(o.materials)))
            self.env_acc = self._keep(EnvOcclusionTargets(ctx, size))

    def _build_area_lights(self, forward_first: bool) -> None:
        """The area lights' shadow atlas and direct-light pass, and their running mean or (``ltc``) sums."""
        o, scene, ctx, size = self.options, self.scene, self.ctx, self.size
        # Leave out what the scene does not need: no shadow or direct-light work without area lights.
        self.shadow = self.direct = self.direct_acc = self.partial = None
        self.ltc = self.ltc_table = None
        if not scene.lights:
            return
        lo, hi = scene.extent()
        self.shadow = self._keep(ShadowAtlas(ctx, self.gpu_scene, size=o.shadow_size,
                                             extent=float(np.linalg.norm(hi - lo)), filter=o.shadow_filter,
                                             lights=scene.lights, samples_per_light=self.plan.samples_per_light))
        self.direct = self._keep(DirectPass(ctx, area_model=o.area_model, materials=o.materials,
                                            shadows=self.plan.light_frames > 0, shadow_filter=o.shadow_filter,
                                            cache_dir=o.cache_dir, layers=self.gpu_scene.layers_for(o.materials)))
        if o.area_model == "ltc":
            # Per-light sums instead of one running mean (ltc.py); no partial sums.
            gbuffer_frames = len(self.plan) - int(forward_first)
            self.ltc = self._keep(LtcLights(ctx, size, scene.lights, materials=o.materials,
                                            lut_texture=self.direct.lut_texture,
                                            gbuffer_frames=max(gbuffer_frames, 1),
                                            layers=self.gpu_scene.layers_for(o.materials)))
            self.ltc_table = self.direct.ltc_table = self.ltc.table
        else:
            self.direct_acc = self._keep(PingPong(ctx, size))
            if self.scheduler is not None or any(len(fp.light_samples) > 1 for fp in self.plan):
                self.partial = self._keep(Target(ctx, size))

    def _build_first_frame(self, forward_first: bool) -> None:
        """The forward-shaded frame 0, and the target of the G-buffer frames' unshadowed preview."""
        o, scene, ctx, size = self.options, self.scene, self.ctx, self.size
        self.first = self.preview = None
        if forward_first:
            scale = o.first_frame_scale
            if scale is None:
                # A reduced frame 0 is only a preview: without a later frame it would be the result.
                later = (len(self.plan) > 1 if self.scheduler is None
                         else bool(self.scheduler.lights or self.scheduler.envs or self.scheduler.punctual))
                scale = auto_scale(size) if later else 1.0
            self.first = self._keep(FirstFramePass(
                ctx, self.gpu_scene, self.base, scene.lights, environment=self.environment,
                area_model=o.area_model, materials=o.materials,
                lut_texture=self.direct.lut_texture if self.direct is not None else None,
                ltc_table=self.ltc_table, scale=float(scale), punctual=self.punctual,
                background=not scene.hides_background))
        # A reduced frame 0 is a preview only: frame 1 draws the full-size one from its G-buffer
        # (with ltc every G-buffer frame has the closed-form unshadowed light: no preview).
        if (scene.lights and self.ltc is None and (self.first is None or self._reduced_first)
                and any(fp.preview for fp in self.plan)):
            self.preview = self._keep(Target(ctx, size))

    def _keep(self, obj: RenderPass):
        self.passes.append(obj)
        return obj

    @property
    def _reduced_first(self) -> bool:
        """Frame 0 is drawn at reduced size, as a preview outside the running means."""
        return self.first is not None and self.first.reduced

    def _check_features(self) -> None:
        feats = self.scene.features()
        if feats.emissive_meshes:
            msg = ("emissive meshes are shown with their emission but do not light other surfaces in "
                   "compare.progressive (only [[lights]] rectangles are sampled)")
            if self.indirect == "probes":
                msg = ("emissive meshes light other surfaces only through the irradiance volume in "
                       "compare.progressive (baked diffuse light; only [[lights]] rectangles are sampled)")
            warnings.warn(msg, stacklevel=3)
            self.notes.append(msg)

    def _background(self) -> tuple[float, float, float]:
        env = self.scene.environment
        if env is not None and env.constant is not None and env.background:
            return tuple(float(c) * env.intensity for c in env.constant)
        return (0.0, 0.0, 0.0)

    # ------------------------------------------------------------------ rendering

    @property
    def seconds(self) -> float:
        """Cumulative wall seconds of the frames rendered so far."""
        return float(sum(self.frame_seconds))

    def _matrices(self, jitter: tuple[float, float]) -> tuple[np.ndarray, bytes]:
        """The view-projection of a sub-pixel ``jitter`` and its inverse, computed once per jitter.

        The inverse is computed outside the timed frames: numpy's linear algebra
        can wake a BLAS thread pool, whose start-up is no part of a frame's cost.
        """
        cache = self.__dict__.setdefault("_matrix_cache", {})
        if jitter not in cache:
            view_proj = self.camera.view_proj(jitter)
            cache[jitter] = (view_proj, mat_bytes(np.linalg.inv(view_proj)))
        return cache[jitter]

    def _draw(self, fp, index: int) -> None:
        """Issue the GL work of one frame plan ``fp``, the ``index``-th frame drawn since reset()
        (-1: a frame outside the sequence, as the budget's calibration draws)."""
        cam_pos = self.camera.position
        view_proj, inv_view_proj = self._matrices(fp.jitter)
        if index == 0 and self.first is not None:
            self.first.render(view_proj, inv_view_proj, cam_pos)
            self._preview_valid = bool(self.scene.lights)
            if self.glass is not None and not self.first.reduced:  # a reduced frame 0 draws its own glass
                self._compose(opaque=True)
                self.glass.run(None, view_proj, cam_pos, index, first_depth=self.first.depth)
            return
        if self.indirect_pass is not None and not self.indirect_pass.done and not self._warming:
            # Baked here, not at set-up: the forward frame 0 does not read the volume, so the first image
            # waits for none of the bake; this frame and every later one read the same grid.
            self.probes.bake()
        self.gbuffer.render(view_proj, cam_pos)
        if self.punctual is not None:
            for k in fp.punctual:
                self.punctual.render_shadow(k)
            self.punctual.run(self.gbuffer, cam_pos, self.shadow_bias)
        self.accumulate.run(self.base, self.gbuffer, self.background,
                            inv_view_proj=inv_view_proj, camera_position=cam_pos)
        if self.indirect_pass is not None and self.probes.baked:
            self.indirect_pass.run(self.gbuffer, cam_pos)
        if self.ltc is not None:
            self.ltc.run(self.gbuffer, cam_pos)
        if fp.env_samples and self.env_shadows is not None:
            self.env_shadows.run(fp.env_samples, self.gbuffer, cam_pos, self.shadow_bias)
        if fp.env_samples and self.env_occlusion is not None:
            self.env_occlusion.run(self.env_acc, self.gbuffer, mat_bytes(view_proj), cam_pos,
                                   self.camera.camera.basis()[2], fp.env_samples, self.d_occ,
                                   self.occlusion_bias * self.d_occ)
        if self.preview is not None and (fp.preview or (index == 1 and self._reduced_first)):
            self.direct.preview(self.preview, self.gbuffer, self.scene.lights, cam_pos)
            self._preview_valid = True
        if self.blend is not None:
            self.blend.run(self.gbuffer, view_proj, cam_pos)
        last = len(fp.light_samples) - 1
        if last > 0 and self.partial is not None:
            self.partial.fbo.use()
            self.partial.fbo.clear(0.0, 0.0, 0.0, 0.0)
        for j, s in enumerate(fp.light_samples):
            light = self.scene.lights[s.light]
            self._lights_sampled.add(s.light)
            self.shadow.render(light, s.light, s.point)
            if self.ltc is not None:
                self.direct.add(self.ltc.ratio[s.light], self.gbuffer, self.shadow, self.shadow_bias, light, s.point,
                                1.0, cam_pos, ltc_specular=self.ltc.specular_sum(s.light))
            elif j < last:
                self.direct.add(self.partial, self.gbuffer, self.shadow, self.shadow_bias, light, s.point,
                                s.weight, cam_pos)
            else:
                # With a budget the direct mean runs over samples (budget.py), else over light frames.
                self.direct.accumulate(self.direct_acc, self.partial if last > 0 else None, self.gbuffer,
                                       self.shadow, self.shadow_bias, light, s.point, s.weight, cam_pos,
                                       units=len(fp.light_samples) if self.scheduler is not None else 1)
        if self.glass is not None:  # last: it refracts the frame's whole opaque image
            self._compose(opaque=True)
            self.glass.run(self.gbuffer, view_proj, cam_pos, index)

    def _warm_up(self) -> None:
        """Run frame 0 and the first light frame once, then forget them.

        Drivers compile shaders lazily at their first draw (llvmpipe JIT-compiles
        them; GPU drivers finish compiling and validate state), which would
        otherwise land in frame 1's time and the first checkpoints of an
        error-against-time curve.
        """
        self._draw(self.plan[0], 0)
        done = {0}
        if self._reduced_first and len(self.plan) > 1:
            self._draw(self.plan[1], 1)  # with the full-size preview's program
            done.add(1)
        light_frames = [fp for fp in self.plan if fp.light_samples]
        if light_frames and light_frames[0].frame not in done:
            self._draw(light_frames[0], -1)
            done.add(light_frames[0].frame)
        punctual_frames = [fp for fp in self.plan if fp.punctual]
        if punctual_frames and punctual_frames[0].frame not in done:
            self._draw(punctual_frames[0], -1)  # the shadow-map and shadowed programs
        env_frames = [fp for fp in self.plan if fp.env_samples]
        if env_frames and env_frames[0].frame not in done and not env_frames[0].light_samples:
            self._draw(env_frames[0], -1)
        self.ctx.finish()
        self.reset()

    def _calibrate(self, repeats: int = 3) -> None:
        """Measure the cost model of the frame budget (:mod:`.budget`): a frame without samples,
        with one light sample, with one environment sample (medians of ``repeats``, after warm-up)."""
        def timed(fp) -> float:
            xs = []
            for _ in range(repeats):
                self.ctx.finish()
                t0 = time.perf_counter()
                self._draw(fp, -1)
                self.ctx.finish()
                xs.append(time.perf_counter() - t0)
            return float(np.median(xs))

        jitter = self.plan[min(1, len(self.plan) - 1)].jitter
        base = timed(FramePlan(1, jitter))
        light = env = punctual = 0.0
        if self.scheduler.punctual:
            punctual = max(timed(FramePlan(1, jitter, punctual=self.scheduler.punctual[:1])) - base, 1e-6)
        if self.scheduler.lights:
            light = max(timed(FramePlan(1, jitter, light_samples=self.scheduler.lights[:1])) - base, 1e-6)
        if self.scheduler.envs:
            env = max(timed(FramePlan(1, jitter, env_samples=self.scheduler.envs[:1])) - base, 1e-6)
        self.scheduler.costs = FrameCosts(base, light, env, punctual)
        self.reset()

    def render_frame(self) -> float:
        """Render the next frame of the plan; returns its wall seconds."""
        if self.finished:
            raise RuntimeError(f"all {self.frame} frames of the plan are rendered; call reset() to start again")
        fp = self.scheduler.next() if self.scheduler is not None else self.plan[self.frame]
        t0 = time.perf_counter()
        with self.query:
            self._draw(fp, self.frame)
        self.ctx.finish()
        seconds = time.perf_counter() - t0
        self.frame_seconds.append(seconds)
        elapsed = self.query.elapsed
        # Some drivers answer the first query with an all-ones error value: record it as unknown.
        self.gpu_frame_seconds.append(elapsed * 1e-9 if 0 <= elapsed < 0xFFFFFFFF else float("nan"))
        self.shadow_passes.append(fp.shadow_passes)
        self.frame += 1
        # Frame 1 after a reduced frame 0 also draws the full-size preview, which the cost model
        # does not know: it would read as the model's error.
        if self.scheduler is not None and not (self.frame == 2 and self._reduced_first):
            self.scheduler.observe(fp, seconds)
        return seconds

    @property
    def finished(self) -> bool:
        """Every frame of the plan (every sample, with a frame budget) is rendered."""
        if self.scheduler is not None:
            return self.scheduler.done
        return self.frame >= len(self.plan)

    def frames(self) -> Iterator[tuple[int, float]]:
        """Render the remaining frames; after each yield (frames done, cumulative wall seconds).

        The accumulated image is read only when asked for, with :meth:`image`.
        """
        while not self.finished:
            self.render_frame()
            yield self.frame, self.seconds

    def image(self) -> np.ndarray:
        """The displayed image after the frames so far: linear (H, W, 3) float32."""
        if self.frame == 0:
            raise RuntimeError("no frame rendered yet; iterate frames() or call render_frame() first")
        what = f"progressive render of {self.scene.path} (frame {self.frame})"
        if self.frame == 1 and self._reduced_first:
            # the preview's one target holds the sum of what the display shows
            fbo = self.compose.run(self.first.targets, upsample=True)
            return read_rgb(self.ctx, fbo, what=what)
        return read_rgb(self.ctx, self._compose(), what=what)

    def _compose(self, *, opaque: bool = False):
        """Compose the display image after the frames so far (its framebuffer); ``opaque``: the opaque scene's
        alone, without the glass and the blended surfaces, into the glass pass's :attr:`GlassPass.opaque`."""
        blend = self.blend is not None and self.blend.acc.count and not opaque
        glass = self.glass is not None and self.glass.count and not opaque
        return self.compose.run(self.base, self._direct_texture(), self.env_acc,
                                self.indirect_pass.texture if self.indirect_pass is not None else None,
                                punctual_texture=self._punctual_texture(), env_ratio=self._env_ratio(),
                                blend_texture=self.blend.texture if blend else None,
                                glass=(self.glass.texture, self.glass.count) if glass else None,
                                target=self.glass.opaque if opaque else None)

    def _direct_texture(self):
        """The direct light the display shows now (a texture), or None."""
        # The preview (every light, unshadowed) stays until every light has a sample: before that
        # the direct mean would show a few lights scaled up to stand for all of them.
        if self.ltc is not None and self.ltc.gbuffer_frames > 0:
            return self.ltc.compose()
        if (self.direct_acc is not None and self.direct_acc.count > 0
                and (len(self._lights_sampled) == len(self.scene.lights) or not self._preview_valid)):
            return self.direct_acc.current
        if self._preview_valid:
            return self.preview.texture if self.preview is not None else self.first.direct
        return None

    def _env_ratio(self):
        """The environment shadow ratio's sums (numerator, denominator), or None before any sample."""
        if self.env_shadows is not None and self.env_shadows.count > 0:
            return self.env_shadows.sums, self.env_shadows.weights
        return None

    def _punctual_texture(self):
        """The punctual lights' running mean, or None (no punctual lights)."""
        if self.punctual is not None and self.punctual.acc.count > 0:
            return self.punctual.texture
        return None

    def layers(self) -> dict[str, np.ndarray]:
        """The displayed image split by kind of light (:mod:`compare.mitsuba.layers`), from the
        targets the renderer keeps: ``emission`` (the every-frame mean: emission and background),
        ``direct_area`` (the direct light shown), ``direct_punctual`` (the point, spot and
        directional lights' mean), ``direct_env`` (the environment light shown) and
        ``indirect_diffuse`` (the irradiance volume's, with probes). Light it does not render
        (indirect specular; indirect diffuse without probes) has no layer: it is zero. The
        layers sum to :meth:`image`. Empty after a reduced frame 0 alone (a preview, no means yet).
        """
        if self.frame == 0:
            raise RuntimeError("no frame rendered yet; iterate frames() or call render_frame() first")
        if (self.frame == 1 and self._reduced_first) or self.blend is not None or self.glass is not None:
            return {}  # blended surfaces and glass composite over every kind of light: the image has no such split
        from compare.progressive.gl.readback import read_texture_rgb

        what = f"progressive render of {self.scene.path} (frame {self.frame})"
        out = {"emission": read_texture_rgb(self.ctx, self.base.current, what=what)}
        direct = self._direct_texture()
        if direct is not None:
            out["direct_area"] = read_texture_rgb(self.ctx, direct, what=what)
        punctual = self._punctual_texture()
        if punctual is not None:
            out["direct_punctual"] = read_texture_rgb(self.ctx, punctual, what=what)
        if len(self.base.textures[0]) > 1:
            acc = self.env_acc
            if self._env_ratio() is not None:
                ratio = self.env_shadows.ratio(what)
                out["direct_env"] = (read_texture_rgb(self.ctx, self.base.current_of(1), what=what)
                                     * ratio[..., None].astype(np.float32))
            elif acc is not None and min(acc.counts) > 0:
                out["direct_env"] = (read_texture_rgb(self.ctx, acc.current(0), what=what)
                                     + read_texture_rgb(self.ctx, acc.current(1), what=what))
            else:
                out["direct_env"] = read_texture_rgb(self.ctx, self.base.current_of(1), what=what)
        if self.indirect_pass is not None:
            out["indirect_diffuse"] = read_texture_rgb(self.ctx, self.indirect_pass.texture, what=what)
        if self._sun_only_punctual and "direct_punctual" in out:
            # the sun taken out of the map (sun.py) is environment light: its layer is the reference's
            out["direct_env"] = out.get("direct_env", 0.0) + out.pop("direct_punctual")
        return out

    def reset(self) -> None:
        """Start the plan again (same seed, same image)."""
        for obj in self.passes:
            obj.reset()
        self._preview_valid = False
        self._lights_sampled: set[int] = set()
        self.frame = 0
        self.frame_seconds, self.gpu_frame_seconds, self.shadow_passes = [], [], []
        if self.scheduler is not None:
            self.scheduler.reset()

    def metadata(self) -> dict:
        """str/int/float description of the render so far (for EXR headers and reports)."""
        p = self.plan
        meta = {
            "renderer": "progressive",
            "package_version": __version__,
            "frames": int(self.frame),
            "frames_planned": len(p),
            "seed": self.seed,
            "seconds": self.seconds,
            "setup_seconds": float(self.setup_seconds),
            "gpu_seconds": float(np.nansum(self.gpu_frame_seconds)),
            "gl_renderer": gl_renderer_name(self.ctx),
            # how far this OpenGL's sampler is from the exact sRGB curve, on the 8-bit colour maps
            "gl_srgb_decode_error": srgb_decode_error(self.ctx),
            "area_model": self.area_model,
            "materials": self.materials,
            "jitter": "R2",
            "first_frame": "gbuffer",  # the passes' own entries below replace these defaults
            "first_frame_scale": 1.0,
            "distributor": "fixed plan" if self.scheduler is None else "frame budget",
            "direct_fraction": p.direct_fraction,
            "direct_start_frame": p.direct_start,
            "light_frames": p.light_frames,
            "samples_per_light": ",".join(str(n) for n in p.samples_per_light),
            "environment": "none",
        }
        if self.environment is not None:
            meta.update({"d_occ": self.d_occ, "occlusion_bias": self.occlusion_bias,
                         "env_samples": int(sum(p.env_counts)), "env_samples_diffuse": int(p.env_counts[0]),
                         "env_samples_specular": int(p.env_counts[1]), "env_frames": int(p.env_frames),
                         "occlusion": "off"})  # the occlusion's pass, if any, says which
        if self.shadow is not None or self.punctual is not None:
            meta["shadow_bias"] = ",".join(f"{b:g}" for b in self.shadow_bias)
        meta["indirect"] = self.indirect
        for obj in self.passes:
            meta.update(obj.describe())
        if self.scheduler is not None:
            c = self.scheduler.costs
            meta.update({"frame_budget_ms": self.scheduler.budget * 1e3, "cost_base_ms": c.base * 1e3,
                         "cost_light_sample_ms": c.light * 1e3, "cost_env_sample_ms": c.env * 1e3})
        if self.notes:
            meta["notes"] = "; ".join(self.notes)
        return meta

    def release(self) -> None:
        """Free every GL object (and the context when this renderer created it)."""
        for obj in reversed(self.passes):
            obj.release()
        self.passes = []
        if self._own_ctx and self.ctx is not None:
            self.ctx.release()
            self.ctx = None

    def __enter__(self) -> "Rasterizer":
        return self

    def __exit__(self, *exc) -> None:
        self.release()


def render_progressive(scene, *, frames: int = DEFAULT_FRAMES, seed: int = 0, area_model: str = "radiometric",
                       ctx=None, checkpoints: Sequence[int] | str = (), **options) -> ProgressiveResult:
    """Render ``scene`` progressively for ``frames`` frames.

    Parameters
    ----------
    scene : compare.scene.loader.Scene
    frames, seed, area_model, ctx : keyword-only
        See :class:`Rasterizer`.
    checkpoints : sequence of int or "every", keyword-only
        Frame counts (1 … frames) after which the accumulated image is read
        back, e.g. ``(1, 2, 4, …, 128)``, or ``"every"`` frame; readback is not
        counted in the seconds. With ``frame_budget_ms`` the render may end
        before ``frames`` (or after: each frame then evaluates at least one
        sample); counts it does not reach are not taken.
    **options
        The other fields of :class:`~compare.progressive.config.RasterizerOptions`, by name:
{options}.

    Returns
    -------
    ProgressiveResult
        ``.image`` (H, W, 3) float32 linear radiance, ``.seconds``,
        ``.frame_seconds``, ``.metadata``, ``.checkpoints`` (frame, seconds, image).
    """
    every = isinstance(checkpoints, str)
    if every and checkpoints != "every":
        raise ValueError(f'checkpoints: expected frame counts or "every", got {checkpoints!r}')
    wanted = set() if every else {int(c) for c in checkpoints}
    limit = math.inf if options.get("frame_budget_ms") is not None else frames
    bad = sorted(c for c in wanted if not 1 <= c <= limit)
    if bad:
        raise ValueError(f"checkpoints: frame counts must lie in 1 … {frames} (frames), got {bad}")
    with Rasterizer(scene, frames=frames, seed=seed, area_model=area_model, ctx=ctx, **options) as r:
        taken = []
        for n, seconds in r.frames():
            if every or n in wanted:
                taken.append(Checkpoint(n, seconds, r.image()))
        image = taken[-1].image if taken and taken[-1].step == r.frame else r.image()
        return ProgressiveResult(
            image=image,
            seconds=r.seconds,
            frame_seconds=list(r.frame_seconds),
            gpu_frame_seconds=list(r.gpu_frame_seconds),
            metadata=r.metadata(),
            checkpoints=taken,
            plan=r.plan,
            layers=r.layers(),
        )


def _options_text(doc: str | None) -> str | None:
    """``doc`` with ``{options}`` replaced by RasterizerOptions' fields that are not parameters of their own."""
    if doc is None:  # python -OO
        return None
    own = {"frames", "seed", "area_model"}
    names = ", ".join(f.name for f in dataclasses.fields(RasterizerOptions) if f.name not in own)
    return doc.replace("{options}", textwrap.fill(names, width=96, initial_indent=" " * 8, subsequent_indent=" " * 8))


render_progressive.__doc__ = _options_text(render_progressive.__doc__)
