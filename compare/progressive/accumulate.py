"""HDR accumulation: running means in RGBA32F ping-pong targets, and the display composite.

``A_n = A_{n−1} + (C_n − A_{n−1}) / n``: after n frames A_n is the plain mean of
C_1 … C_n, in float32, without the growing sum that a ``Σ C / n`` buffer would
carry. Two targets alternate as source and destination, because a pass cannot
read the texture it writes.
"""

from __future__ import annotations

from .shaders import load_program, set_uniform


class PingPong:
    """Two RGBA32F targets; :attr:`current` holds the latest running mean."""

    def __init__(self, ctx, size: tuple[int, int]):
        self.textures = []
        self.fbos = []
        for _ in range(2):
            tex = ctx.texture(size, 4, dtype="f4")
            tex.filter = (ctx.NEAREST, ctx.NEAREST)
            self.textures.append(tex)
            self.fbos.append(ctx.framebuffer([tex]))
        self.index = 0
        self.count = 0
        """Number of means accumulated so far."""

    @property
    def current(self):
        return self.textures[self.index]

    @property
    def target(self):
        """Framebuffer of the next mean (the texture that is not :attr:`current`)."""
        return self.fbos[1 - self.index]

    def swap(self) -> None:
        self.index = 1 - self.index
        self.count += 1

    def reset(self) -> None:
        self.index = 0
        self.count = 0

    def release(self) -> None:
        for obj in self.fbos + self.textures:
            obj.release()


class Target:
    """One RGBA32F render target (a frame's partial sums, the preview, the composite)."""

    def __init__(self, ctx, size: tuple[int, int]):
        self.texture = ctx.texture(size, 4, dtype="f4")
        self.texture.filter = (ctx.NEAREST, ctx.NEAREST)
        self.fbo = ctx.framebuffer([self.texture])

    def release(self) -> None:
        self.fbo.release()
        self.texture.release()


class AccumulatePass:
    """Running mean of the every-frame terms: emission where a surface was hit, background elsewhere."""

    def __init__(self, ctx):
        self.ctx = ctx
        self.program = load_program(ctx, "accumulate.glsl")
        self.vao = ctx.vertex_array(self.program, [])

    def run(self, acc: PingPong, gbuffer, background) -> None:
        ctx = self.ctx
        acc.target.use()
        ctx.enable_only(ctx.NOTHING)
        acc.current.use(location=0)
        gbuffer["position"].use(location=1)
        gbuffer["emission"].use(location=2)
        p = self.program
        set_uniform(p, "u_previous", 0)
        set_uniform(p, "u_position", 1)
        set_uniform(p, "u_emission", 2)
        set_uniform(p, "u_background", tuple(float(c) for c in background))
        set_uniform(p, "u_count", float(acc.count + 1))
        self.vao.render(vertices=3)
        acc.swap()

    def release(self) -> None:
        self.vao.release()
        self.program.release()


class ComposePass:
    """The displayed image: every-frame mean + (direct-light mean or frame 0's preview)."""

    def __init__(self, ctx, size: tuple[int, int]):
        self.ctx = ctx
        self.program = load_program(ctx, "compose.glsl")
        self.vao = ctx.vertex_array(self.program, [])
        self.out = Target(ctx, size)

    def run(self, base_texture, direct_texture=None):
        ctx = self.ctx
        self.out.fbo.use()
        ctx.enable_only(ctx.NOTHING)
        base_texture.use(location=0)
        (direct_texture or base_texture).use(location=1)
        set_uniform(self.program, "u_base", 0)
        set_uniform(self.program, "u_direct", 1)
        set_uniform(self.program, "u_direct_scale", 1.0 if direct_texture is not None else 0.0)
        self.vao.render(vertices=3)
        return self.out.fbo

    def release(self) -> None:
        self.out.release()
        self.vao.release()
        self.program.release()
