"""HDR accumulation: running means in RGBA32F ping-pong targets, and the display composite.

``A_n = A_{n−1} + (C_n − A_{n−1}) / n``: after n frames A_n is the plain mean of
C_1 … C_n, in float32, without the growing sum that a ``Σ C / n`` buffer would
carry. Two targets alternate as source and destination, because a pass cannot
read the texture it writes.
"""

from __future__ import annotations

from compare.progressive.gl.passes import RenderPass
from compare.progressive.gl.shaders import load_program, set_uniform
from compare.progressive.gl.units import bind, units_of

#: Effective samples (Kish: (Σ g)² / Σ g²) from which the display takes the environment's specular shadow
#: ratio alone; below, it is blended towards the diffuse ratio in proportion (``ENV_SPECULAR_SAMPLES`` in
#: compose.glsl, :mod:`compare.progressive.environment.env_shadows` says why).
ENV_SPECULAR_SAMPLES = 16.0

_ACCUMULATE = units_of("accumulate.glsl")
_COMPOSE = units_of("compose.glsl")


class PingPong(RenderPass):
    """Two sets of RGBA32F targets (``dtype`` "f2": RGBA16F); :attr:`current` holds the latest running mean.

    ``attachments`` > 1 gives every set that many textures, written together by
    one pass (multiple render targets); :meth:`current_of` returns attachment k.
    """

    def __init__(self, ctx, size: tuple[int, int], attachments: int = 1, dtype: str = "f4"):
        self.textures = []  # [set][attachment]
        self.fbos = []
        for _ in range(2):
            texs = []
            for _ in range(attachments):
                tex = ctx.texture(size, 4, dtype=dtype)
                tex.filter = (ctx.NEAREST, ctx.NEAREST)
                texs.append(tex)
            self.textures.append(texs)
            self.fbos.append(ctx.framebuffer(texs))
        self.index = 0
        self.count = 0
        """Number of means accumulated so far."""
        self.units = 0
        """Units (frames, or samples with a frame budget) the current mean covers."""

    @property
    def current(self):
        return self.textures[self.index][0]

    def current_of(self, attachment: int):
        """Attachment ``attachment`` of the latest means."""
        return self.textures[self.index][attachment]

    @property
    def target(self):
        """Framebuffer of the next mean (the textures that are not :attr:`current`)."""
        return self.fbos[1 - self.index]

    def swap(self, units: int = 1) -> None:
        self.index = 1 - self.index
        self.count += 1
        self.units += units

    def reset(self) -> None:
        """Start the mean again: the next pass's value is its first."""
        self.index = 0
        self.count = 0
        self.units = 0

    def release(self) -> None:
        for obj in self.fbos + [t for texs in self.textures for t in texs]:
            obj.release()


class Target(RenderPass):
    """One RGBA32F render target (a frame's partial sums, the preview, the composite)."""

    def __init__(self, ctx, size: tuple[int, int]):
        self.texture = ctx.texture(size, 4, dtype="f4")
        self.texture.filter = (ctx.NEAREST, ctx.NEAREST)
        self.fbo = ctx.framebuffer([self.texture])

    def release(self) -> None:
        self.fbo.release()
        self.texture.release()


class AccumulatePass(RenderPass):
    """Running mean of the every-frame terms: emission where a surface was hit, background elsewhere.

    With an ``environment`` (:class:`compare.progressive.environment.environment.EnvironmentLighting`)
    the background is the environment map (unless ``background`` is False: a hidden one), and a second attachment of the
    ping-pong (``PingPong(..., attachments=2)``) holds the running mean of the
    unoccluded environment light of shaded surfaces (``accumulate.glsl``).
    """

    def __init__(self, ctx, environment=None, materials: str = "shared", occlusion: bool = False,
                 layers: bool = False, background: bool = True):
        self.ctx = ctx
        self.environment = environment
        #: With the material extensions (layers.glsl): the G-buffer's layer targets are read.
        self.layers = bool(layers and environment is not None)
        # background False: the environment lights but is not drawn where no surface is (the scene's
        # background = false); the background is then the uniform's colour, black
        defines = {"ENVIRONMENT": int(environment is not None), "OCCLUSION": int(bool(occlusion)),
                   "LAYERS": int(self.layers), "BACKGROUND": int(bool(background))}
        if environment is not None:
            defines.update(environment.defines(materials))
        self.program = load_program(ctx, "accumulate.glsl", defines)
        self.vao = ctx.vertex_array(self.program, [])

    @property
    def attachments(self) -> int:
        """Targets the pass writes (2 with an environment)."""
        return 1 if self.environment is None else 2

    def run(self, acc: PingPong, gbuffer, background, *, inv_view_proj: bytes | None = None,
            camera_position=None) -> None:
        ctx = self.ctx
        acc.target.use()
        ctx.enable_only(ctx.NOTHING)
        p = self.program
        bind(p, "u_previous", acc.current, _ACCUMULATE["previous"])
        gbuffer.bind(p, ("position", "emission"))
        set_uniform(p, "u_background", tuple(float(c) for c in background))
        set_uniform(p, "u_count", float(acc.count + 1))
        if self.environment is not None:
            gbuffer.bind(p, ("normal", "material"))
            bind(p, "u_previous_env", acc.current_of(1), _ACCUMULATE["previous_env"])
            if self.layers:
                gbuffer.bind_layers(p)
            set_uniform(p, "u_inv_view_proj", inv_view_proj)
            set_uniform(p, "u_camera_position", tuple(float(x) for x in camera_position))
            set_uniform(p, "u_viewport", tuple(float(x) for x in gbuffer.size))
            self.environment.bind(p, _ACCUMULATE["environment"])
        self.vao.render(vertices=3)
        acc.swap()

    def release(self) -> None:
        self.vao.release()
        self.program.release()


class ComposePass(RenderPass):
    """The displayed image: every-frame mean + (direct-light mean or frame 0's preview) + the environment light."""

    #: The samplers of compose.glsl, at the units of its ``sources`` in this order.
    SOURCES = ("u_base", "u_direct", "u_env", "u_env_diffuse", "u_env_specular", "u_indirect", "u_punctual",
               "u_env_ratio", "u_env_weights", "u_blend", "u_glass")

    def __init__(self, ctx, size: tuple[int, int]):
        self.ctx = ctx
        self.program = load_program(ctx, "compose.glsl", {"ENV_SPECULAR_SAMPLES": ENV_SPECULAR_SAMPLES})
        self.vao = ctx.vertex_array(self.program, [])
        self.out = Target(ctx, size)

    def run(self, base: PingPong, direct_texture=None, env_visible=None, indirect_texture=None, *,
            punctual_texture=None, env_ratio=None, blend_texture=None, glass=None, upsample: bool = False,
            target=None):
        """Compose the display image.

        ``base`` is the every-frame ping-pong (a second attachment holds the
        unoccluded environment light); ``env_visible`` the per-kind running means
        of the occluded environment light
        (:class:`~compare.progressive.environment.environment.EnvOcclusionTargets`) or None.
        The environment term is the unoccluded mean until both kinds have
        samples, then the two means of visible light. ``indirect_texture`` is
        the irradiance volume's indirect light (:mod:`.indirect`), or None;
        ``punctual_texture`` the punctual lights' running mean (:mod:`.punctual`), or None;
        ``env_ratio`` the environment shadow ratios' sums and the lobes' weights, two textures
        (:mod:`.env_shadows`), which then scale the unoccluded environment light, or None;
        ``blend_texture`` the blended surfaces' running mean (:mod:`.blend`), composited over the
        rest, or None; ``glass`` the glass's sums and their frame count, (texture, n), composited before the
        blended surfaces, or None; ``target``: a :class:`Target` to write instead of the display's own.
        ``upsample``: the sources are smaller than the output (a reduced first
        frame) and are sampled bilinearly.
        """
        ctx = self.ctx
        out = target or self.out
        out.fbo.use()
        ctx.enable_only(ctx.NOTHING)
        has_env = len(base.textures[0]) > 1
        occluded = env_visible is not None and min(env_visible.counts) > 0
        env_mode = 0 if not has_env else 3 if env_ratio is not None else 2 if occluded else 1
        sums, weights = env_ratio if env_ratio is not None else (base.current, base.current)
        # An absent source reads the every-frame mean, with its scale 0 (or unused by its u_env_mode).
        sources = (base.current, direct_texture or base.current, base.current_of(1) if has_env else base.current,
                   env_visible.current(0) if occluded else base.current,
                   env_visible.current(1) if occluded else base.current, indirect_texture or base.current,
                   punctual_texture or base.current, sums, weights, blend_texture or base.current,
                   glass[0] if glass is not None else base.current)
        for k, (name, texture) in enumerate(zip(self.SOURCES, sources, strict=True)):
            bind(self.program, name, texture, _COMPOSE["sources"], k)
        set_uniform(self.program, "u_indirect_scale", 1.0 if indirect_texture is not None else 0.0)
        set_uniform(self.program, "u_punctual_scale", 1.0 if punctual_texture is not None else 0.0)
        set_uniform(self.program, "u_blend_scale", 1.0 if blend_texture is not None else 0.0)
        set_uniform(self.program, "u_glass_scale", 1.0 / glass[1] if glass is not None and glass[1] > 0 else 0.0)
        set_uniform(self.program, "u_direct_scale", 1.0 if direct_texture is not None else 0.0)
        set_uniform(self.program, "u_env_mode", env_mode)
        w, h = out.texture.size
        set_uniform(self.program, "u_upsample", (1.0 / w, 1.0 / h) if upsample else (0.0, 0.0))
        self.vao.render(vertices=3)
        return out.fbo

    def release(self) -> None:
        self.out.release()
        self.vao.release()
        self.program.release()
