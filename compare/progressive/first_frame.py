"""The cheap first frame: one forward-shaded pass instead of the G-buffer and its passes.

Frame 0 of a plan carries no light samples and no occlusion samples: it shows
emission, the unoccluded environment light (split sum) and the unshadowed
direct light of each area light from its centre. Shading that from the
G-buffer costs a full frame (four RGBA32F targets written, then full-screen
passes reading them), which made frame 1 as dear as an average frame. Here the
scene is rasterized once for depth and once with a forward shader
(``first_frame.glsl``) that writes what frame 0 adds to the every-frame running
mean (its first value: emission and background, and the unoccluded environment
light) straight into that mean's next target, and the unshadowed direct-light
preview (a cheaper form than the direct pass's, ``light_preview`` in
``area_light.glsl``) into its own target, shown until every light has a sample.
The displayed image is composed from them as after any other frame.

With ``scale`` < 1 (the renderer's default from 320×240 up, :func:`auto_scale`:
half of each axis) frame 0 is drawn at that fraction of each axis into a target of
its own and is a preview only: it adds nothing to the running means (their first
value comes from frame 1, so the final image averages one jitter position fewer).
The terms the display adds up are then summed by the shader into that one target,
the display upsamples it bilinearly, and frame 1 draws the full-resolution
unshadowed preview from its G-buffer, which then stays until every light has a
sample.

On a CPU rasterizer frame 0 is per-pixel work (clearing the targets, the depth
pre-pass, the preview's light evaluation, writing the targets) plus per-frame
overhead, so a half-size preview (a quarter of the pixels) is what keeps frame 0
cheap; the full-size preview's cost moves to frame 1. For the same reason frame 0
writes one target when reduced, draws its depth pre-pass into the framebuffer it
shades (one batch of llvmpipe work, not three) and culls single-sided back faces
with GL's face culling rather than a discard in its shaders. Measurements:
``docs/performance-notes.md``.

The blend and the glass passes draw their meshes over the deferred frames with the same shader, each a
:class:`MeshesForwardPass`.
"""

from __future__ import annotations

import numbers

import numpy as np

from compare.progressive.frame.accumulate import PingPong
from compare.progressive.frame.gpu_scene import mat_bytes
from compare.progressive.gl.passes import RenderPass
from compare.progressive.gl.shaders import load_program, set_uniform
from compare.progressive.gl.units import bind, units_of
from compare.progressive.lights.direct import area_model_defines

#: How frame 0 is drawn (Rasterizer's ``first_frame``).
FIRST_FRAME_MODES = ("forward", "gbuffer")
#: Fraction of each axis of a reduced forward frame 0 (Rasterizer's ``first_frame_scale``).
DEFAULT_FIRST_FRAME_SCALE = 0.5
#: The smallest reduced frame 0 that :func:`auto_scale` draws: below it the preview loses the
#: scene's structure and saves little, as a frame that small is mostly per-frame overhead
#: (docs/performance-notes.md).
MIN_REDUCED_SIZE = (160, 120)


def auto_scale(size: tuple[int, int]) -> float:
    """The default ``first_frame_scale`` for an image of ``size`` (width, height): half of
    each axis where that still gives at least :data:`MIN_REDUCED_SIZE`, else full size."""
    w, h = size
    k = DEFAULT_FIRST_FRAME_SCALE
    return k if w * k >= MIN_REDUCED_SIZE[0] and h * k >= MIN_REDUCED_SIZE[1] else 1.0


def check_scale(scale) -> float:
    """``scale`` as a float when it is a fraction of each axis in (0, 1]; else ValueError."""
    if not (isinstance(scale, numbers.Real) and not isinstance(scale, bool) and 0 < scale <= 1):
        raise ValueError(f"first_frame_scale: expected a fraction of each axis in (0, 1], got {scale!r}")
    return float(scale)


_UNITS = units_of("first_frame.glsl")


def first_frame_defines(gpu_scene, lights, punctual, environment, area_model: str, materials: str, *,
                        blend: bool, transmission: bool = False) -> dict:
    """The defines of ``first_frame.glsl``: frame 0's forward pass (``transmission``: it draws glass), or
    (``blend``) the blend pass."""
    defines = {"LIGHTS": len(lights), "ENVIRONMENT": int(environment is not None), "BLEND": int(blend),
               "TRANSMISSION": int(transmission),
               "PUNCTUAL": len(punctual.lights) if punctual is not None else 0, **area_model_defines(area_model),
               "MATERIALS_DIFFUSE": int(materials == "diffuse"), **gpu_scene.defines(),
               **gpu_scene.layer_defines(materials)}
    if environment is not None:
        defines.update(environment.defines(materials))
    return defines


def bind_tables(program, gpu_scene, *, lut_texture=None, ltc_table=None, environment=None) -> None:
    """Bind what ``first_frame.glsl`` samples besides the meshes' maps (frame 0 and the blend pass): the
    split-sum table, the LTC table, the material layers' table and the environment."""
    if lut_texture is not None:
        bind(program, "u_spec_lut", lut_texture, _UNITS["spec_lut"])
    if ltc_table is not None:
        bind(program, "u_ltc", ltc_table, _UNITS["ltc"])
    gpu_scene.bind_layers(program)
    if environment is not None:
        environment.bind(program, _UNITS["environment"])


def bind_gbuffer_position(program, gbuffer) -> None:
    """Bind the G-buffer's positions to the blend pass's ``first_frame.glsl`` (``u_gbuffer_position``): its
    meshes are hidden where the opaque surface is nearer."""
    bind(program, "u_gbuffer_position", gbuffer["position"], _UNITS["gbuffer"], gbuffer.NAMES.index("position"))


def set_light_uniforms(program, lights, punctual=None) -> None:
    """The lights' uniform arrays of ``first_frame.glsl`` (frame 0, and the blend pass): the area
    ``lights`` and the :class:`~compare.progressive.lights.punctual.PunctualLights` ``punctual`` (or None)."""
    if punctual is not None:
        for name, values in punctual.uniform_arrays().items():
            set_uniform(program, name, values)
    if not lights:
        return

    def arr(values) -> bytes:
        return np.ascontiguousarray(values, dtype=np.float32).tobytes()

    set_uniform(program, "u_lights_center", arr([lt.center for lt in lights]))
    set_uniform(program, "u_lights_t", arr([lt.tangent for lt in lights]))
    set_uniform(program, "u_lights_b", arr([lt.bitangent for lt in lights]))
    set_uniform(program, "u_lights_n", arr([lt.normal for lt in lights]))
    set_uniform(program, "u_lights_half", arr([(lt.size[0] / 2, lt.size[1] / 2) for lt in lights]))
    set_uniform(program, "u_lights_radiance", arr([lt.radiance for lt in lights]))
    set_uniform(program, "u_lights_area", arr([lt.area for lt in lights]))


class MeshesForwardPass(RenderPass):
    """A forward pass of the scene's meshes ``indices`` over the deferred frames, shaded by
    ``first_frame.glsl`` with ``defines`` (the blend and the glass passes): its program with the lights set,
    the tables it samples, and the GL objects it makes (:meth:`_keep`), freed in reverse order. A subclass
    makes its own programs and targets in :meth:`_make_targets`."""

    def __init__(self, ctx, gpu_scene, size, lights, indices: list[int], defines: dict, *, environment=None,
                 punctual=None, lut_texture=None, ltc_table=None):
        self.ctx = ctx
        self.scene = gpu_scene
        self.environment = environment
        self.lut_texture = lut_texture
        self.ltc_table = ltc_table
        self.indices = indices
        self._objects: list = []
        try:
            self.program = self._keep(load_program(ctx, "first_frame.glsl", defines))
            self._make_targets(ctx, size)
        except BaseException:
            self.release()
            raise
        set_light_uniforms(self.program, lights, punctual)

    def _make_targets(self, ctx, size) -> None:
        """Make (and :meth:`_keep`) what the pass draws into besides its program."""
        raise NotImplementedError

    def _keep(self, obj):
        self._objects.append(obj)
        return obj

    def _programs(self) -> list:
        """The programs the scene keeps state for (its maps' bindings), forgotten on release."""
        return [getattr(self, "program", None)]

    def set_shading(self, gbuffer, view_proj: bytes, camera_position: tuple) -> None:
        """Bind the tables and, where there is a G-buffer, its positions (the meshes are hidden where the
        opaque surface is nearer); set the camera's uniforms."""
        p = self.program
        bind_tables(p, self.scene, lut_texture=self.lut_texture, ltc_table=self.ltc_table,
                    environment=self.environment)
        if gbuffer is not None:
            bind_gbuffer_position(p, gbuffer)
        set_uniform(p, "u_view_proj", view_proj)
        set_uniform(p, "u_camera_position", camera_position)
        set_uniform(p, "u_background_pass", 0.0)

    def release(self) -> None:
        for program in self._programs():
            if program is not None:
                self.scene.forget(program)
        for obj in reversed(self._objects):
            obj.release()
        self._objects = []


class FirstFramePass(RenderPass):
    """Program and targets of the forward-shaded frame 0.

    ``lut_texture`` is the direct pass's split-sum table (None with Lambert-only
    materials), ``ltc_table`` the LTC table of the ``ltc`` area model (its preview is the
    closed-form unshadowed light, :mod:`compare.progressive.lights.ltc`); ``environment`` an
    :class:`~compare.progressive.environment.environment.EnvironmentLighting` or None.
    ``scale`` in (0, 1]: 1 draws frame 0 at full size into the every-frame mean's
    next target and the unshadowed direct light into :attr:`direct`; below 1 at that
    fraction of each axis into :attr:`targets`, a preview only (:attr:`reduced`): one
    target, all that the display adds up. ``punctual`` (a
    :class:`~compare.progressive.lights.punctual.PunctualLights` or None): their exact
    unshadowed light goes into their running mean's next target (reduced: into that
    one target too). ``background`` False: the environment is not drawn behind the scene.
    """

    def __init__(self, ctx, gpu_scene, base, lights, *, environment=None, area_model: str = "radiometric",
                 materials: str = "shared", lut_texture=None, ltc_table=None, scale: float = 1.0,
                 punctual=None, background: bool = True):
        self.scale = check_scale(scale)
        #: Whether the environment is drawn where no surface is (False: the clear colour, black).
        self.background = bool(background)
        self.ctx = ctx
        self.scene = gpu_scene
        full = base.textures[0][0].size
        self.reduced = self.scale < 1.0
        size = (max(1, round(full[0] * self.scale)), max(1, round(full[1] * self.scale))) if self.reduced else full
        self.size = size
        self.base = base
        self.targets = None
        """With :attr:`reduced`: frame 0's preview, the sum of what the display shows (a PingPong of one
        target, which the display composes as it would the every-frame mean alone)."""
        self.direct = None
        """At full size: the unshadowed direct light, shown until every light has a sample."""
        self.lights = tuple(lights)
        self.environment = environment
        self.lut_texture = lut_texture
        self.punctual = punctual
        # A reduced frame 0 draws the glass itself (a preview, outside the means); a full-size one leaves it
        # to the glass pass (glass.py), whose sum it starts.
        defines = first_frame_defines(gpu_scene, self.lights, punctual, environment, area_model, materials,
                                      blend=False, transmission=gpu_scene.glassy and self.reduced)
        # A reduced frame 0 is a preview only: the terms the display adds up are added here, into one
        # target, which is what a CPU rasterizer clears and writes per pixel (docs/performance-notes.md).
        defines["PREVIEW"] = int(self.reduced)
        # GL culls the single-sided back faces: without a discard in them both programs cost less per fragment.
        defines["FACE_CULLING"] = 1
        if area_model == "ltc" and ltc_table is None and self.lights:
            raise ValueError("area_model 'ltc' needs the LTC table (ltc_table)")
        self.ltc_table = ltc_table
        self._objects: list = []
        try:
            self.program = self._keep(load_program(ctx, "first_frame.glsl", defines))
            self.background_vao = self._keep(ctx.vertex_array(self.program, []))
            self.depth = self._keep(ctx.depth_renderbuffer(size))
            if self.reduced:
                # half floats: the preview is replaced by frame 1 and averaged into nothing, and a software
                # rasterizer writes half the bytes (first-frame ratio 0.160 -> 0.149, docs/performance-notes.md)
                self.targets = self._keep(PingPong(ctx, size, dtype="f2"))
                colour = list(self.targets.textures[1])
                # Upsampled bilinearly for display (compose.glsl), clamped at the borders: the
                # default wrap would blend in the opposite edge.
                for tex in colour:
                    tex.filter = (ctx.LINEAR, ctx.LINEAR)
                    tex.repeat_x = tex.repeat_y = False
            else:
                self.direct = self._keep(ctx.texture(size, 4, dtype="f4"))
                self.direct.filter = (ctx.NEAREST, ctx.NEAREST)
                # Frame 0 is the every-frame mean's first value: after reset() its next target is set 1.
                colour = list(base.textures[1]) + [self.direct]
                if punctual is not None:
                    colour.append(punctual.acc.textures[1][0])  # likewise the punctual mean's first value
            self.fbo = self._keep(ctx.framebuffer(colour, self.depth))
            # moderngl's colour masks: one (r, g, b, a) for a single target, one per target for several
            self._writes, self._no_writes = (((m,) * 4 if len(colour) == 1 else ((m,) * 4,) * len(colour))
                                             for m in (True, False))
            # Depth pre-pass: with the nearest depth known, each pixel is shaded once, however
            # much the scene overdraws (docs/performance-notes.md). It draws into the same framebuffer,
            # its colours masked: on llvmpipe each change of framebuffer ends a batch of work (a "scene",
            # rasterized on its own), and frame 0 is then one batch instead of three.
            self.depth_programs = gpu_scene.occluder_programs(ctx, "depth_only.glsl", {"FACE_CULLING": 1})
            for program in self.depth_programs.values():
                self._keep(program)
        except BaseException:
            self.release()
            raise
        self._set_lights()

    def _keep(self, obj):
        self._objects.append(obj)
        return obj

    def _set_lights(self) -> None:
        set_light_uniforms(self.program, self.lights, self.punctual)

    def render(self, view_proj, inv_view_proj: bytes, camera_position) -> None:
        """Draw frame 0: the every-frame mean's first value (then swapped in) and :attr:`direct`, the
        preview; with :attr:`reduced` the preview's sum into :attr:`targets` instead."""
        if self.reduced:
            self.targets.reset()
        elif (self.base.count != 0 or self.base.index != 0
              or (self.punctual is not None and (self.punctual.acc.count != 0 or self.punctual.acc.index != 0))):
            raise RuntimeError("the first frame must be drawn right after reset()")
        ctx = self.ctx
        p = self.program
        fbo = self.fbo
        fbo.color_mask = self._writes  # a clear leaves a masked target alone
        fbo.use()
        ctx.enable_only(ctx.DEPTH_TEST)
        ctx.depth_func = "<="
        # Without an environment the background is black (the clear colour).
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        fbo.color_mask = self._no_writes
        view_proj = mat_bytes(view_proj)
        try:
            for program in self.depth_programs.values():
                set_uniform(program, "u_view_proj", view_proj)
            self.scene.draw_occluders(self.depth_programs, casters=False, glass=self.reduced, cull=True)
        finally:
            fbo.color_mask = self._writes
        bind_tables(p, self.scene, lut_texture=self.lut_texture, ltc_table=self.ltc_table,
                    environment=self.environment)
        set_uniform(p, "u_view_proj", view_proj)
        set_uniform(p, "u_camera_position", tuple(float(x) for x in camera_position))
        set_uniform(p, "u_background_pass", 0.0)
        self.scene.draw_shaded(p, glass=self.reduced, cull=True)
        if self.environment is not None and self.background:
            set_uniform(p, "u_background_pass", 1.0)
            set_uniform(p, "u_inv_view_proj", inv_view_proj)
            set_uniform(p, "u_viewport", tuple(float(x) for x in self.size))
            self.background_vao.render(vertices=3)
        (self.targets if self.reduced else self.base).swap()
        if self.punctual is not None and not self.reduced:
            self.punctual.acc.swap()

    def describe(self) -> dict:
        """That frame 0 is forward-shaded, and at which fraction of each axis."""
        return {"first_frame": "forward", "first_frame_scale": self.scale}

    def release(self) -> None:
        for program in [getattr(self, "program", None), *getattr(self, "depth_programs", {}).values()]:
            if program is not None:
                self.scene.forget(program)
        for obj in reversed(self._objects):
            obj.release()
        self._objects = []
