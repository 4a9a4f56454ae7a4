"""The irradiance volume's indirect diffuse light as a pass of its own (``indirect.glsl``).

Looking the volume up costs far more than the rest of an every-frame pass on a
software rasterizer (8 probes × 9 coefficients and 8 distance maps per pixel;
``docs/performance-notes.md``), and its result is smooth and noise-free: the
running mean over jittered frames only anti-aliases it. So it has its own running mean, updated in the first :data:`PROBE_FRAMES` frames that
draw the G-buffer and then kept as it is; ``compose.glsl`` adds it. The
forward-shaded frame 0 has no G-buffer, so its preview shows no indirect light;
every later image does.
"""

from __future__ import annotations

from compare.progressive.frame.accumulate import PingPong
from compare.progressive.gl.passes import RenderPass
from compare.progressive.gl.shaders import load_program, set_uniform
from compare.progressive.gl.units import bind, units_of

#: Frames whose jitter anti-aliases the indirect light (then its mean is kept).
PROBE_FRAMES = 16

_UNITS = units_of("indirect.glsl")


class IndirectPass(RenderPass):
    """Program and running mean of the volume's indirect light."""

    def __init__(self, ctx, probes, size: tuple[int, int], materials: str = "shared", frames: int = PROBE_FRAMES,
                 occlusion: bool = False):
        if frames < 1:
            raise ValueError(f"probe frames: expected at least 1, got {frames}")
        self.ctx = ctx
        self.probes = probes
        self.frames = int(frames)
        self.occlusion = bool(occlusion)
        self.program = load_program(ctx, "indirect.glsl", {**probes.defines(materials), "OCCLUSION": int(self.occlusion)})
        self.vao = ctx.vertex_array(self.program, [])
        self.acc = PingPong(ctx, size)

    @property
    def done(self) -> bool:
        """The mean has all its frames: the pass need not run again until reset."""
        return self.acc.count >= self.frames

    def run(self, gbuffer, camera_position) -> None:
        """Fold this frame's indirect light into the running mean (nothing once :attr:`done`)."""
        if self.done:
            return
        ctx = self.ctx
        p = self.program
        self.acc.target.use()
        ctx.enable_only(ctx.NOTHING)
        bind(p, "u_previous", self.acc.current, _UNITS["previous"])
        gbuffer.bind(p)
        set_uniform(p, "u_camera_position", tuple(float(x) for x in camera_position))
        set_uniform(p, "u_count", float(self.acc.count + 1))
        self.probes.bind(p, _UNITS["probes"])
        if self.occlusion:  # the occlusion maps' factors (G-buffer emission.a)
            gbuffer.bind(p, ("emission",))
        self.vao.render(vertices=3)
        self.acc.swap()

    @property
    def texture(self):
        """The running mean, or None before the first update."""
        return self.acc.current if self.acc.count > 0 else None

    def reset(self) -> None:
        """Start the mean again."""
        self.acc.reset()

    def release(self) -> None:
        self.acc.release()
        self.vao.release()
        self.program.release()
