"""glTF's alphaMode BLEND in the progressive rasterizer: a sorted forward pass after the deferred frame.

A deferred renderer keeps one surface per pixel, and a blended surface shows two. So blended meshes
stay out of the G-buffer (and out of frame 0's forward pass and depth pre-pass), and every G-buffer
frame draws them afterwards, back to front by the distance of their bounds' centres, forward-shaded
with the first frame's shading (``first_frame.glsl`` with ``BLEND``: emission, the unoccluded
environment light's split sum, each area light from its centre and each punctual light, all
unshadowed), hidden where the G-buffer's opaque surface is nearer. They composite with the *over*
operator into one target that starts at (0, 0, 0, 1)::

    rgb ← α c + (1 − α) rgb,    a ← (1 − α) a

so that after all of them ``rgb`` is the blended surfaces' premultiplied colour and ``a`` the
transmittance they leave to what is behind. Both fold into a running mean over frames (each at its
frame's jitter, ``blend_fold.glsl``) and the display is ``rgb + a × (the opaque image)``
(``compose.glsl``). Sorting by mesh is the usual real-time compromise: intersecting or interleaved
blended meshes composite in the wrong order.

What it leaves out: the blended surfaces' own shadows (they are lit unshadowed), and their partial
shadows on the rest (a blended mesh casts a shadow map's hard shadow where its coverage is at least
½, :meth:`~compare.progressive.frame.gpu_scene.GpuScene.draw_occluders`).
"""

from __future__ import annotations

import numpy as np

from compare.progressive.frame.accumulate import PingPong
from compare.progressive.first_frame import MeshesForwardPass, first_frame_defines
from compare.progressive.frame.gpu_scene import mat_bytes
from compare.progressive.gl.shaders import load_program, set_uniform
from compare.progressive.gl.units import bind, units_of

_FOLD = units_of("blend_fold.glsl")


class BlendPass(MeshesForwardPass):
    """The forward pass of the blended meshes and the running mean of what it composites."""

    def __init__(self, ctx, gpu_scene, size, lights, *, environment=None, punctual=None, area_model="radiometric",
                 materials="shared", lut_texture=None, ltc_table=None):
        super().__init__(ctx, gpu_scene, size, lights, [k for k, m in enumerate(gpu_scene.meshes) if m.blend >= 0.0],
                         first_frame_defines(gpu_scene, lights, punctual, environment, area_model, materials,
                                             blend=True),
                         environment=environment, punctual=punctual, lut_texture=lut_texture, ltc_table=ltc_table)

    def _make_targets(self, ctx, size) -> None:
        self.frame = self._keep(ctx.texture(size, 4, dtype="f4"))
        self.frame.filter = (ctx.NEAREST, ctx.NEAREST)
        self.fbo = self._keep(ctx.framebuffer([self.frame]))
        self.fold = self._keep(load_program(ctx, "blend_fold.glsl"))
        self.fold_vao = self._keep(ctx.vertex_array(self.fold, []))
        self.acc = self._keep(PingPong(ctx, size))

    def run(self, gbuffer, view_proj, camera_position) -> None:
        """Draw the blended meshes over the G-buffer's frame and fold the result into the mean."""
        ctx, p = self.ctx, self.program
        self.fbo.use()
        self.fbo.clear(0.0, 0.0, 0.0, 1.0)
        ctx.enable_only(ctx.BLEND)
        ctx.blend_equation = ctx.FUNC_ADD
        ctx.blend_func = ctx.ONE, ctx.ONE_MINUS_SRC_ALPHA, ctx.ZERO, ctx.ONE_MINUS_SRC_ALPHA
        cam = np.asarray(camera_position, dtype=np.float64)
        self.set_shading(gbuffer, mat_bytes(view_proj), tuple(float(x) for x in cam))
        far_first = sorted(self.indices, key=lambda k: -float(np.linalg.norm(
            np.asarray(self.scene.meshes[k].centre) - cam)))
        for k in far_first:
            self.scene.draw_mesh(p, k)
        self.acc.target.use()
        ctx.enable_only(ctx.NOTHING)
        bind(self.fold, "u_previous", self.acc.current, _FOLD["previous"])
        bind(self.fold, "u_frame", self.frame, _FOLD["frame"])
        set_uniform(self.fold, "u_count", float(self.acc.count + 1))
        self.fold_vao.render(vertices=3)
        self.acc.swap()

    @property
    def texture(self):
        """The running mean: premultiplied colour of the blended surfaces, and the transmittance (a)."""
        return self.acc.current

    def reset(self) -> None:
        """Start the mean again."""
        self.acc.reset()
