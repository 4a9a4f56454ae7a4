"""glTF's transmission in the progressive rasterizer: a forward pass of the glass over the opaque frame.

Glass shows what is behind it, bent, so like the blended meshes (:mod:`compare.progressive.blend`) the glass
meshes stay out of the G-buffer (:meth:`GpuScene.draw_shaded <compare.progressive.frame.gpu_scene.GpuScene.draw_shaded>`
with ``glass=False``). After every G-buffer frame's opaque passes the display's opaque image is composed into
a texture of its own (``compose.glsl``: the one full-screen pass glass adds to a frame), and the glass meshes
are drawn over it, forward-shaded by ``first_frame.glsl`` with ``GLASS`` (``transmission.glsl`` says what they
let through: refraction by the file's ior through microfacet normals sampled anew every frame, the exit at the
nearest back face or the thickness, the tint at each interface, Beer–Lambert absorption, the opaque image or
the environment map behind; a dispersive volume refracts one colour channel's ior per pixel and frame, that
channel's light three times, which the mean over the frames turns into each channel's refraction). Two cheap geometry passes of the glass alone go first: its nearest back faces
(``glass_back.glsl``: the exit's plane and normal) and its depth, so that the shading pass shades each pixel's
nearest glass surface once.

The shading pass adds (radiance, 1) into a sum over the frames (additive blending, no fold pass): after
n glass frames the display is ``rgb / n + (1 − a / n) × (the opaque image)`` (``compose.glsl``), the glass's
mean radiance where it covered the pixel every frame, the opaque image blended in at its jittered edges.

Frame 0 drawn forward (:mod:`compare.progressive.first_frame`) leaves the glass out, and this pass draws it
over that frame's image as a preview, without a G-buffer (the frame's depth buffer hides it, a solid's
refracted ray sees the environment map alone), which the next frame's glass replaces; a reduced frame 0 draws
the glass in its forward pass (its rays see the environment map alone), a preview too.

A thin wall (thickness 0) whose glass's back face lies behind it is a closed thin-walled mesh: that back
face is its second wall, taken to be of its material (its tint and Fresnel, its own glass share from its maps).

What it leaves out: glass seen through glass beyond that (the refracted ray sees the opaque scene), the inner
side of a back face's opaque parts (dark), light reflected inside the glass, the glass's own shadows (it is lit unshadowed) and its coloured shadows on the rest (a glass mesh
casts an opaque shadow-map shadow, :meth:`GpuScene.draw_occluders
<compare.progressive.frame.gpu_scene.GpuScene.draw_occluders>`), caustics; the screen-space environment
occlusion does not see the glass. Blended meshes composite over the glass.
"""

from __future__ import annotations

import numpy as np

from compare.progressive.first_frame import MeshesForwardPass, first_frame_defines
from compare.progressive.frame.accumulate import Target
from compare.progressive.frame.gpu_scene import mat_bytes
from compare.progressive.gl.shaders import load_program, set_uniform
from compare.progressive.gl.units import bind, units_of

_UNITS = units_of("first_frame.glsl")


class GlassPass(MeshesForwardPass):
    """The glass meshes' forward pass and the sum of its frames (:attr:`texture`, :attr:`count`)."""

    def __init__(self, ctx, gpu_scene, size, lights, *, environment=None, punctual=None, area_model="radiometric",
                 materials="shared", lut_texture=None, ltc_table=None):
        self.count = 0
        """Glass frames summed in :attr:`texture`."""
        self.preview = False
        """The sum holds frame 0's preview (:meth:`run` with ``first_depth``), which the next frame replaces."""
        self._first: dict = {}
        defines = {**first_frame_defines(gpu_scene, lights, punctual, environment, area_model, materials,
                                         blend=False, transmission=True), "GLASS": 1}
        super().__init__(ctx, gpu_scene, size, lights, [k for k, m in enumerate(gpu_scene.meshes) if m.glass], defines,
                         environment=environment, punctual=punctual, lut_texture=lut_texture, ltc_table=ltc_table)

    def _make_targets(self, ctx, size) -> None:
        self.back_program = self._keep(load_program(ctx, "glass_back.glsl", self.scene.defines()))
        self.depth_programs = self.scene.occluder_programs(ctx, "depth_only.glsl")
        for program in self.depth_programs.values():
            self._keep(program)
        #: The opaque scene's display image of the frame, read bilinearly where the glass refracts.
        self.opaque = self._keep(Target(ctx, size))
        self.opaque.texture.filter = (ctx.LINEAR, ctx.LINEAR)
        self.opaque.texture.repeat_x = self.opaque.texture.repeat_y = False
        self.sum = self._keep(ctx.texture(size, 4, dtype="f4"))
        self.sum.filter = (ctx.NEAREST, ctx.NEAREST)
        self.depth = self._keep(ctx.depth_renderbuffer(size))
        self.fbo = self._keep(ctx.framebuffer([self.sum], self.depth))
        self.depth_fbo = self._keep(ctx.framebuffer(depth_attachment=self.depth))
        self.back = self._keep(ctx.texture(size, 4, dtype="f4"))
        self.back.filter = (ctx.NEAREST, ctx.NEAREST)
        self.back_depth = self._keep(ctx.depth_renderbuffer(size))
        self.back_share = self._keep(ctx.texture(size, 1, dtype="f4"))
        self.back_share.filter = (ctx.NEAREST, ctx.NEAREST)
        self.back_fbo = self._keep(ctx.framebuffer([self.back, self.back_share], self.back_depth))

    def _programs(self) -> list:
        return [*super()._programs(), getattr(self, "back_program", None),
                *getattr(self, "depth_programs", {}).values()]

    def run(self, gbuffer, view_proj, camera_position, frame: int, *, first_depth=None) -> None:
        """Draw the glass over :attr:`opaque` (composed by the caller for this frame) and add it to the sum;
        ``frame`` seeds the frame's microfacet normals. ``first_depth``: frame 0 drawn forward, without a
        G-buffer: its depth buffer hides the glass, and a solid's refracted ray sees the environment map alone;
        a preview, which the next frame's glass replaces."""
        ctx, scene = self.ctx, self.scene
        if self.preview:  # frame 0's glass, seen without the G-buffer, stays out of the mean
            self.count, self.preview = 0, False
        vp = mat_bytes(view_proj)
        cam = tuple(float(x) for x in np.asarray(camera_position, dtype=np.float64))
        # the nearest back faces: the exits' planes
        self.back_fbo.use()
        self.back_fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        ctx.enable_only(ctx.DEPTH_TEST)
        ctx.depth_func = "<"
        set_uniform(self.back_program, "u_view_proj", vp)
        set_uniform(self.back_program, "u_camera_position", cam)
        for k in self.indices:
            scene.draw_mesh(self.back_program, k)
        fbo, depth_fbo = self.fbo, self.depth_fbo
        if first_depth is not None:  # frame 0's depth buffer, which holds the opaque scene's depth
            if id(first_depth) not in self._first:
                self._first[id(first_depth)] = (self._keep(ctx.framebuffer([self.sum], first_depth)),
                                                self._keep(ctx.framebuffer(depth_attachment=first_depth)))
            fbo, depth_fbo = self._first[id(first_depth)]
        if self.count == 0:  # the sum starts again
            self.fbo.use()
            self.fbo.clear(0.0, 0.0, 0.0, 0.0)
        # the nearest glass surface's depth, then its shading, once per pixel
        depth_fbo.use()
        if first_depth is None:
            depth_fbo.clear(depth=1.0)
        ctx.depth_func = "<"
        for program in self.depth_programs.values():
            set_uniform(program, "u_view_proj", vp)
        scene.draw_depth(self.depth_programs, self.indices)
        fbo.use()
        ctx.enable_only(ctx.DEPTH_TEST | ctx.BLEND)
        ctx.depth_func = "<="
        ctx.blend_equation = ctx.FUNC_ADD
        ctx.blend_func = ctx.ONE, ctx.ONE
        p = self.program
        self.set_shading(gbuffer, vp, cam)
        set_uniform(p, "u_glass_preview", float(first_depth is not None))
        bind(p, "u_opaque", self.opaque.texture, _UNITS["opaque"])
        bind(p, "u_glass_back", self.back, _UNITS["glass_back"])
        bind(p, "u_glass_share", self.back_share, _UNITS["glass_share"])
        set_uniform(p, "u_glass_seed", float(frame % (1 << 23)))
        for k in self.indices:
            scene.draw_mesh(p, k)
        ctx.enable_only(ctx.NOTHING)
        self.count += 1
        self.preview = first_depth is not None

    @property
    def texture(self):
        """The sum over the glass frames: radiance (rgb) and coverage (a)."""
        return self.sum

    def reset(self) -> None:
        """Start the sum again (cleared by the next frame)."""
        self.count, self.preview = 0, False

    def describe(self) -> dict:
        """The glass pass's frames."""
        return {"glass_frames": int(self.count)}
