"""A depth-only pass over the whole scene: the cost floor of any frame (for benchmarks)."""

from __future__ import annotations

from compare.progressive.frame.gpu_scene import mat_bytes
from compare.progressive.gl.passes import RenderPass
from compare.progressive.gl.shaders import set_uniform


class DepthOnlyPass(RenderPass):
    """Rasterizes every mesh of a :class:`~.gpu_scene.GpuScene` into a depth buffer only."""

    def __init__(self, ctx, gpu_scene, size: tuple[int, int]):
        self.ctx = ctx
        self.scene = gpu_scene
        self.size = size
        self.depth = ctx.depth_texture(size)
        self.fbo = ctx.framebuffer(depth_attachment=self.depth)
        self.programs = gpu_scene.occluder_programs(ctx, "depth_only.glsl")

    def render(self, view_proj) -> None:
        """Clear and draw the scene's depth with ``view_proj``."""
        self.fbo.use()
        self.ctx.viewport = (0, 0, *self.size)
        self.ctx.enable_only(self.ctx.DEPTH_TEST)
        self.fbo.clear(depth=1.0)
        for program in self.programs.values():
            set_uniform(program, "u_view_proj", mat_bytes(view_proj))
        self.scene.draw_occluders(self.programs, casters=False)

    def release(self) -> None:
        self.fbo.release()
        self.depth.release()
        self.scene.release_programs(self.programs)
