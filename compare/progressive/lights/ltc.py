"""The ``ltc`` area model: closed-form unshadowed area light times a stochastic shadow ratio.

Heitz, Dupuy, Hill & Neubelt (2016) give the unshadowed light of a polygon in
closed form: Lambert's form factor for the diffuse lobe, and for the GGX lobe
the form factor of the polygon transformed by the inverse of a fitted linear
transform of the clamped cosine (``ltc.glsl``; the table is fitted to the
shared BRDF by :mod:`compare.brdf.ltc`, its magnitude and Fresnel are the
split-sum table's F0·A + B). Heitz, Hill & McGuire (2018) add shadows without
losing that exactness: the analytic value times the ratio of the shadowed to
the unshadowed point-sample estimate over the same samples,

    L_i ≈ LTC_i · Σ_k V_k g_k / Σ_k g_k,

for the diffuse lobe, g_k being its point-sample estimate through sample k (its
BRDF times A cos cos / d²). For the specular lobe the denominator is the fitted
lobe's own estimate through the same samples, h_k (the closed form's scale, Fresnel
× (A + B), times the transformed cosine's density, times A cos / d²), and the
numerator's BRDF term is bounded by b h_k (b = :data:`~compare.progressive.lights.direct.LTC_SHAPE_MAX`, 1.5):

    L_s ≈ LTC_s · Σ_k V_k min(g_k, b h_k) / Σ_k h_k,

which converges to the exact shadowed specular light as samples grow (to within
the bound), correcting the fitted lobe's shape and its Fresnel where the fit is
poor: at grazing views the clamped cosine, sheared, keeps mass near the horizon
where BRDF × cos vanishes (``stress/grazing.toml``'s plane;
``docs/performance-notes.md``). The bound keeps a sample where the fitted lobe
has almost no density from making a firefly. Where light i is entirely visible
the diffuse ratio is exactly 1, whatever the number of samples, so the diffuse
light is the closed form's, exact. In penumbrae the ratio converges as samples grow, as the radiometric model's point-on-area estimate does, but
without that model's discretisation error in the unshadowed part, which grows
as the light comes close to the surface (``tests/test_area_models.py``;
``docs/performance-notes.md``).

The closed form's scale is a constant of the pixel, so the sample pass leaves it out of h_k
and the bound reads it from the specular sum's alpha (below), where the unshadowed pass has
summed it; the compose pass divides by it. So the sample pass does not evaluate the polygon
integral again just to get it, which would make it much dearer (``docs/performance-notes.md``).

Per light this keeps three RGBA32F sums over the whole image, added to with
blending, never ping-ponged: the unshadowed diffuse and specular light of the
G-buffer frames that evaluate it (the first and then about
:data:`LTC_EVALUATIONS` spread over the render, whose jitter anti-aliases them as
the other means; the specular sum's alpha sums the scale), and the ratio's four sums, added to by each light sample
(``direct.glsl``). The display (``ltc_compose.glsl``) is
Σ_i (diffuse_i·R_d,i + specular_i·R_s,i) / frames_i, the specular ratio's denominator
being Σ_k h_k times the sum's mean scale.
Before a light has its first sample its ratio is 1: the light shows unshadowed
and exact from the first frame on, which replaces the other models' centre-point
preview.

The distributor
---------------
The paper holds light samples back to the last 70 % of the frames (f_d = 0.3)
and shows a crude unshadowed preview until then. With this model the light is
exact from the first frame and only its shadows wait for samples, so they start
at frame 1 (:data:`LTC_DIRECT_FRACTION` = 0; the samples, their order and
count are the paper's): the early images come closer to the reference and the
final image is as good (``docs/performance-notes.md``).
"""

from __future__ import annotations

import numpy as np

from compare.progressive.frame.accumulate import Target
from compare.progressive.gl.passes import RenderPass
from compare.progressive.gl.shaders import load_program, set_uniform
from compare.progressive.gl.units import bind, units_of
from compare.progressive.lights.direct import area_model_defines, set_light

#: f_d of the ``ltc`` model: shadow samples from frame 1 on (see the module notes).
LTC_DIRECT_FRACTION = 0.0
#: G-buffer frames in which each light's unshadowed light is evaluated (its jitter average).
LTC_EVALUATIONS = 32

_LIGHT = units_of("ltc_light.glsl")
_COMPOSE = units_of("ltc_compose.glsl")


def ltc_texture(ctx):
    """The fitted LTC table (:func:`compare.brdf.ltc.load_table`, TABLE_SIZE² texels) as an RGBA32F texture,
    bilinear."""
    from compare.brdf.ltc import load_table

    table = np.ascontiguousarray(load_table(), dtype=np.float32)
    tex = ctx.texture((table.shape[1], table.shape[0]), 4, table.tobytes(), dtype="f4")
    tex.filter = (ctx.LINEAR, ctx.LINEAR)
    tex.repeat_x = tex.repeat_y = False
    return tex


class LtcLights(RenderPass):
    """Per-light sums of the ``ltc`` model and the pass that composes them (see the module notes).

    ``lut_texture`` is the split-sum table (None with Lambert-only materials),
    ``table`` the LTC texture (:func:`ltc_texture`; None makes one, which :attr:`table` then holds
    and :meth:`release` frees), ``gbuffer_frames`` the number of
    G-buffer frames the render plans: each light's unshadowed light is evaluated in the
    first of them and then in every ``stride``-th, staggered over the lights, so that it
    averages about :data:`LTC_EVALUATIONS` jitter positions (see :meth:`run`).
    """

    def __init__(self, ctx, size: tuple[int, int], lights, *, materials: str, lut_texture, table=None,
                 gbuffer_frames: int, layers: bool = False):
        self.ctx = ctx
        self.lights = tuple(lights)
        self.lut_texture = lut_texture
        self._objects: list = []
        try:
            self.table = table if table is not None else self._keep(ltc_texture(ctx))
            defines = {**area_model_defines("ltc"), "MATERIALS_DIFFUSE": int(materials == "diffuse"),
                       "LAYERS": int(layers)}
            self.layers = bool(defines["LAYERS"])
            self.program = self._keep(load_program(ctx, "ltc_light.glsl", defines))
            self.vao = self._keep(ctx.vertex_array(self.program, []))
            self.compose_program = self._keep(load_program(ctx, "ltc_compose.glsl"))
            self.compose_vao = self._keep(ctx.vertex_array(self.compose_program, []))
            self.unshadowed = []
            """Per light: (diffuse sum, specular sum) textures and their framebuffer."""
            self.ratio: list[Target] = []
            """Per light: the shadow ratio's sums, a target the light samples add to."""
            for _ in self.lights:
                texs = [self._keep(ctx.texture(size, 4, dtype="f4")) for _ in range(2)]
                for tex in texs:
                    tex.filter = (ctx.NEAREST, ctx.NEAREST)
                self.unshadowed.append((texs, self._keep(ctx.framebuffer(texs))))
                self.ratio.append(self._keep(Target(ctx, size)))
            self.out = self._keep(Target(ctx, size))
        except BaseException:
            self.release()
            raise
        self.stride = max(1, round(gbuffer_frames / LTC_EVALUATIONS))
        """Each light's unshadowed light is evaluated in every ``stride``-th G-buffer frame."""
        self.gbuffer_frames = 0
        """G-buffer frames run so far."""
        self.frames = [0] * len(self.lights)
        """Per light: the G-buffer frames in its unshadowed sums."""

    def _keep(self, obj):
        self._objects.append(obj)
        return obj

    def reset(self) -> None:
        """Clear every sum (a new render)."""
        for _, fbo in self.unshadowed:
            fbo.clear(0.0, 0.0, 0.0, 0.0)
        for target in self.ratio:
            target.fbo.clear(0.0, 0.0, 0.0, 0.0)
        self.gbuffer_frames = 0
        self.frames = [0] * len(self.lights)

    def due(self, light: int) -> bool:
        """Whether the next G-buffer frame evaluates ``light``: the first frame evaluates every
        light (so that each shows from the start), later ones light i when (frame + i) % stride == 0."""
        g = self.gbuffer_frames
        return g == 0 or (g + light) % self.stride == 0

    def run(self, gbuffer, camera_position) -> None:
        """Add this frame's unshadowed light of the lights that are :meth:`due` (from its G-buffer).

        The unshadowed light is smooth but for the edges of what the G-buffer sees, which
        its jitter anti-aliases: a subset of the frames' jitter positions does that as well
        as all of them, and evaluating a light in every frame would cost as much as a
        shadowed sample pass each (docs/performance-notes.md).
        """
        due = [i for i in range(len(self.lights)) if self.due(i)]
        self.gbuffer_frames += 1
        if not due:
            return
        ctx = self.ctx
        p = self.program
        gbuffer.bind(p)
        if self.layers:
            gbuffer.bind_layers(p)
        if self.lut_texture is not None:
            bind(p, "u_spec_lut", self.lut_texture, _LIGHT["spec_lut"])
        bind(p, "u_ltc", self.table, _LIGHT["ltc"])
        set_uniform(p, "u_camera_position", tuple(float(x) for x in camera_position))
        ctx.enable_only(ctx.BLEND)
        ctx.blend_func = ctx.ONE, ctx.ONE
        ctx.blend_equation = ctx.FUNC_ADD
        for i in due:
            self.unshadowed[i][1].use()
            set_light(p, self.lights[i])
            self.vao.render(vertices=3)
            self.frames[i] += 1

    def specular_sum(self, light: int):
        """(texture, frames): ``light``'s unshadowed specular sum so far (alpha: the sum of its
        scale, Fresnel × (A + B)) and the frames in it; the sample pass bounds by it."""
        return self.unshadowed[light][0][1], self.frames[light]

    def compose(self):
        """The shadowed direct light of all lights so far (a texture); needs one :meth:`run` first."""
        if self.gbuffer_frames == 0:
            raise RuntimeError("no frame has added the lights' unshadowed light yet")
        ctx = self.ctx
        p = self.compose_program
        self.out.fbo.use()
        self.out.fbo.clear(0.0, 0.0, 0.0, 0.0)
        ctx.enable_only(ctx.BLEND)
        ctx.blend_func = ctx.ONE, ctx.ONE
        ctx.blend_equation = ctx.FUNC_ADD
        for (texs, _), ratio, frames in zip(self.unshadowed, self.ratio, self.frames):
            set_uniform(p, "u_frames", float(frames))
            bind(p, "u_diffuse", texs[0], _COMPOSE["diffuse"])
            bind(p, "u_specular", texs[1], _COMPOSE["specular"])
            bind(p, "u_ratio", ratio.texture, _COMPOSE["ratio"])
            self.compose_vao.render(vertices=3)
        return self.out.texture

    def describe(self) -> dict:
        """The table's size and file, the evaluations' stride, the shadow ratio's kind."""
        w, h = self.table.size
        return {"ltc_table": f"{w}x{h} (compare/brdf/ltc_table.npz)", "ltc_stride": int(self.stride),
                "shadow_ratio": "per light, diffuse and specular"}

    def release(self) -> None:
        for obj in reversed(self._objects):
            obj.release()
        self._objects = []

