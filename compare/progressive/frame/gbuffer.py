"""G-buffer pass: the scene from the jittered camera into four RGBA32F targets.

Targets (``gbuffer.glsl``): world position + kind, shading normal + roughness,
base colour + metallic, emitted radiance towards the camera. Every other pass of
a frame is a full-screen pass over these, so the geometry is rasterized once per
frame however many light samples the frame evaluates.
"""

from __future__ import annotations

from compare.progressive.frame.gpu_scene import LAYER_TARGETS, mat_bytes
from compare.progressive.gl.passes import RenderPass
from compare.progressive.gl.shaders import load_program, set_uniform
from compare.progressive.gl.units import GBUFFER, bind


class GBuffer(RenderPass):
    """The targets and the program of the G-buffer pass."""

    #: The targets, in the order of their texture units (:data:`~compare.progressive.gl.units.GBUFFER`).
    NAMES = ("position", "normal", "material", "emission")

    def __init__(self, ctx, gpu_scene, size: tuple[int, int]):
        self.ctx = ctx
        self.scene = gpu_scene
        self.size = size
        self.textures = {}
        # With the material extensions, three more targets hold the pixel's layers (layers.glsl).
        self.names = self.NAMES + (LAYER_TARGETS if gpu_scene.layered else ())
        for name in self.names:
            tex = ctx.texture(size, 4, dtype="f4")
            tex.filter = (ctx.NEAREST, ctx.NEAREST)
            self.textures[name] = tex
        self.depth = ctx.depth_renderbuffer(size)
        self.fbo = ctx.framebuffer([self.textures[n] for n in self.names], self.depth)
        # One program per set of maps the meshes have (a scene without maps has one): each samples only
        # those maps: a software rasterizer runs both sides of a shared program's uniform branches and
        # would pay for every map's lookup on every mesh (docs/performance-notes.md).
        self.programs = {}
        try:
            for key in gpu_scene.map_sets():
                self.programs[key] = load_program(ctx, "gbuffer.glsl", gpu_scene.map_set_defines(key))
        except BaseException:
            self.release()
            raise

    def __getitem__(self, name: str):
        return self.textures[name]

    def bind(self, program, names: tuple[str, ...] = ("position", "normal", "material")) -> None:
        """Bind the targets ``names`` to a full-screen pass (``gbuffer_inputs.glsl``), each at its unit."""
        for name in names:
            bind(program, f"u_{name}", self.textures[name], GBUFFER, self.NAMES.index(name))

    def bind_layers(self, program) -> None:
        """Bind the layer targets and the sheen table to a full-screen pass built with LAYERS."""
        self.scene.bind_layers(program, self)

    def render(self, view_proj, camera_position) -> None:
        ctx = self.ctx
        self.fbo.use()
        ctx.enable_only(ctx.DEPTH_TEST)
        ctx.depth_func = "<"
        self.fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        for key, program in self.programs.items():
            set_uniform(program, "u_view_proj", mat_bytes(view_proj))
            set_uniform(program, "u_camera_position", tuple(float(x) for x in camera_position))
            self.scene.draw_shaded(program, map_set=key if len(self.programs) > 1 else None, glass=False)

    def release(self) -> None:
        self.fbo.release()
        self.depth.release()
        for tex in self.textures.values():
            tex.release()
        self.scene.release_programs(getattr(self, "programs", {}))
        self.programs = {}
