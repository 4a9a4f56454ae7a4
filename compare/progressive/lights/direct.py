"""Direct light from area lights: one full-screen pass per light sample (``direct.glsl``).

Area models
-----------
``"radiometric"`` (default)
    A sample point y on light i stands for the area A/n_i around it: its
    diffuse contribution is ``f_d · L · (A/n_i) · cos θ_light · cos θ_surf / d²``,
    so the sum over the n_i uniformly spread samples is the point-on-area
    estimate of ``∫_A f L cos cos / d² dA``; for a Lambert surface it converges
    to the exact polygon-light irradiance (tested against the closed form). The
    specular term through the representative point uses the light's exact solid
    angle Ω (two spherical triangles).
``"ltc"``
    The unshadowed light in closed form (linearly transformed cosines) times a
    shadow ratio estimated from the samples: :mod:`compare.progressive.lights.ltc`. This
    pass then writes the ratio's sums instead of an estimate.
``"paper"``
    Otto et al.'s point-light form: each sample is an isotropic point light
    carrying the emitter's whole power Φ = π·A·L, ``E = Φ / (4π d²) · cos θ_surf``
    (here ``Φ/(4πd²) = L·A/(4d²)``), and the specular term uses the same
    ``Φ/(4πd²)`` instead of L·Ω. Compared with the radiometric form it lacks
    the emitter's cos θ_light and is a quarter of it straight below the light
    (an isotropic source spreads Φ over 4π sr; a Lambertian emitter's intensity
    on its axis is Φ/π). Both keep the emitter one-sided (nothing behind its plane).
    Only the contribution formula changes: the samples (on the rectangle,
    sorted from the light's centre), the shadows and the BRDF stay the same, so
    the difference of the two images is the cost of the point-light form alone.
    The public code's other deviations (samples sorted from the world origin or
    placed on a sphere, N·L applied twice, shading from the centre) are not
    reproduced.

Representative point and normalisation
--------------------------------------
The specular direction is Karis' most representative point: the point of the
rectangle closest to the reflection ray (the ray's hit on the light's plane
clamped to the rectangle). Evaluating the GGX lobe there puts its peak on the
light however small α is, so the energy is normalised as for Karis' sphere
lights, with the light's half-angle mapped to half vectors: ``ρ = r/(2d)``,
r = √(A/π) the radius of the disc of equal area and d the distance to the
light's centre. Karis' ``(α/α')²``, ``α' = α + ρ``, holds at normal incidence;
in general the map from l to h has the Jacobian ``dω_h/dω_l = 1/(4 v·h)``:
within the plane of incidence h turns by half of l's angle, across it by
``1/(2 v·h)`` of it, so the factor is ``α² / ((α + ρ)(α + ρ/(v·h)))`` (each
bracket capped at 1). Without the ``v·h`` a glossy plane seen at grazing
angles (``scenes/stress/grazing.toml``) reflects more than the light's radiance
(``docs/performance-notes.md``). Last, the term is bounded by ``L · (F0·A + B)``,
the lobe's directional albedo from the split-sum table (:mod:`compare.ibl.lut`):
no light reflects more than that, whatever part of the hemisphere it covers. The term is the same for all
samples of a light and is multiplied by each sample's visibility, so its mean
is the MRP specular × mean visibility.
"""

from __future__ import annotations

import numpy as np

from compare.brdf.ltc import TABLE_SIZE
from compare.progressive.frame.accumulate import PingPong, Target
from compare.progressive.gl.passes import RenderPass
from compare.progressive.gl.shaders import load_program, set_uniform
from compare.progressive.gl.units import bind, units_of
from compare.progressive.lights.shadow import SHADOW_FILTERS

AREA_MODELS = ("radiometric", "paper", "ltc")
#: The material modes (compare.brdf.SUPPORTED_MATERIALS) the rasterizer has: the shared BRDF, and Lambert only.
SUPPORTED_MATERIALS = ("shared", "diffuse")
#: The ``ltc`` model's bound on a sample's specular term in the shadow ratio's numerator, in units of the
#: fitted lobe's own density (:mod:`compare.progressive.lights.ltc`; ``LTC_SHAPE_MAX`` in direct.glsl).
LTC_SHAPE_MAX = 1.5

_UNITS = units_of("direct.glsl")


def area_model_defines(area_model: str) -> dict[str, object]:
    """The defines of a program that evaluates area lights with ``area_model`` (area_light.glsl, ltc.glsl,
    direct.glsl): which model, and with ``ltc`` the constants its GLSL shares with Python."""
    defines: dict[str, object] = {"AREA_MODEL_PAPER": int(area_model == "paper"),
                                  "AREA_MODEL_LTC": int(area_model == "ltc")}
    if area_model == "ltc":
        defines.update({"LTC_SIZE": float(TABLE_SIZE), "LTC_SHAPE_MAX": LTC_SHAPE_MAX})
    return defines


def set_light(program, light) -> None:
    """The ``u_light_*`` uniforms of one rectangular light (area_light.glsl, ltc.glsl)."""
    set_uniform(program, "u_light_center", tuple(float(x) for x in light.center))
    set_uniform(program, "u_light_t", tuple(float(x) for x in light.tangent))
    set_uniform(program, "u_light_b", tuple(float(x) for x in light.bitangent))
    set_uniform(program, "u_light_n", tuple(float(x) for x in light.normal))
    set_uniform(program, "u_light_half", (light.size[0] / 2, light.size[1] / 2))
    set_uniform(program, "u_light_radiance", tuple(float(x) for x in light.radiance))
    set_uniform(program, "u_light_area", float(light.area))


class DirectPass(RenderPass):
    """Programs of the direct-light pass: shadowed (light frames) and unshadowed (preview)."""

    def __init__(self, ctx, *, area_model: str = "radiometric", materials: str = "shared", shadows: bool = True,
                 shadow_filter: str = "hard", cache_dir=None, layers: bool = False):
        # shadow_filter: "hard" (depth test) or "vsm" (Chebyshev visibility of filtered moments; see .shadow).
        if shadow_filter not in SHADOW_FILTERS:
            raise ValueError(f"shadow_filter: expected one of {', '.join(map(repr, SHADOW_FILTERS))}, "
                             f"got {shadow_filter!r}")
        if area_model not in AREA_MODELS:
            raise ValueError(f"area_model: expected one of {', '.join(map(repr, AREA_MODELS))}, got {area_model!r}")
        if materials not in SUPPORTED_MATERIALS:
            raise ValueError(f"materials: expected one of {', '.join(map(repr, SUPPORTED_MATERIALS))}, got {materials!r}")
        self.ctx = ctx
        self.lut_texture = None
        #: The LTC table (area model "ltc"): the specular shadow ratio's denominator reads it.
        self.ltc_table = None
        if materials != "diffuse":
            # The split-sum table bounds the light a specular lobe can reflect (direct.glsl).
            from compare.ibl import split_sum

            lut = split_sum(cache_dir=cache_dir)[0]
            # RGBA (A, B, C and a zero): llvmpipe filters a four-float texel faster than a three-float one,
            # and frame 0 reads the table at every pixel (docs/performance-notes.md).
            lut = np.ascontiguousarray(np.pad(lut, ((0, 0), (0, 0), (0, 4 - lut.shape[2]))), dtype=np.float32)
            self.lut_texture = ctx.texture((lut.shape[1], lut.shape[0]), 4, lut.tobytes(), dtype="f4")
            self.lut_texture.filter = (ctx.LINEAR, ctx.LINEAR)
            self.lut_texture.repeat_x = self.lut_texture.repeat_y = False
        defines = {**area_model_defines(area_model), "MATERIALS_DIFFUSE": int(materials == "diffuse"),
                   "LAYERS": int(layers)}
        self._defines = defines
        # The G-buffer preview is compiled at its first use: with the forward-shaded first
        # frame (first_frame.py) it is never drawn.
        self.preview_program = self.preview_vao = None
        self.program = self.vao = None
        if shadows:
            vsm = int(shadow_filter == "vsm")
            self.program = load_program(ctx, "direct.glsl", {**defines, "SHADOWS": 1, "SHADOW_VSM": vsm})
            self.vao = ctx.vertex_array(self.program, [])

    @staticmethod
    def _set_light(program, light, point, weight, camera_position) -> None:
        set_uniform(program, "u_camera_position", tuple(float(x) for x in camera_position))
        set_light(program, light)
        set_uniform(program, "u_sample", tuple(float(x) for x in point))
        set_uniform(program, "u_weight", float(weight))

    def _bind_gbuffer(self, program, gbuffer) -> None:
        gbuffer.bind(program)
        if self._defines["LAYERS"]:
            gbuffer.bind_layers(program)
        if self.lut_texture is not None:
            bind(program, "u_spec_lut", self.lut_texture, _UNITS["spec_lut"])
        if self.ltc_table is not None:
            bind(program, "u_ltc", self.ltc_table, _UNITS["ltc"])

    def preview(self, target: Target, gbuffer, lights, camera_position) -> None:
        """Unshadowed direct light from every light's centre (one sample, full area), summed into ``target``."""
        ctx = self.ctx
        target.fbo.use()
        target.fbo.clear(0.0, 0.0, 0.0, 0.0)
        ctx.enable_only(ctx.BLEND)
        ctx.blend_func = ctx.ONE, ctx.ONE
        ctx.blend_equation = ctx.FUNC_ADD
        if self.preview_program is None:
            self.preview_program = load_program(ctx, "direct.glsl", {**self._defines, "SHADOWS": 0})
            self.preview_vao = ctx.vertex_array(self.preview_program, [])
        p = self.preview_program
        self._bind_gbuffer(p, gbuffer)
        set_uniform(p, "u_mode", 0)
        for light in lights:
            self._set_light(p, light, light.center, 1.0, camera_position)
            self.preview_vao.render(vertices=3)

    def add(self, partial: Target, gbuffer, shadow, bias, light, point, weight, camera_position, *,
            ltc_specular=None) -> None:
        """Add ``weight``·estimate of one sample to this frame's ``partial`` sum (not the last sample).

        With the ``ltc`` model: add the sample's shadow-ratio terms to the light's ratio
        target ``partial`` (:mod:`compare.progressive.lights.ltc`; ``weight`` is not used);
        ``ltc_specular`` is (the light's unshadowed specular sum, its frames), whose alpha
        bounds the specular term (:meth:`~compare.progressive.lights.ltc.LtcLights.specular_sum`)."""
        ctx = self.ctx
        partial.fbo.use()
        ctx.enable_only(ctx.BLEND)
        ctx.blend_func = ctx.ONE, ctx.ONE
        ctx.blend_equation = ctx.FUNC_ADD
        p = self.program
        self._bind_gbuffer(p, gbuffer)
        shadow.bind(p, _UNITS["shadow"], bias)
        if self._defines["AREA_MODEL_LTC"]:
            if ltc_specular is None:
                raise ValueError("the ltc model's sample pass needs the light's unshadowed specular sum (ltc_specular)")
            texture, frames = ltc_specular
            bind(p, "u_ltc_specular", texture, _UNITS["ltc_specular"])
            set_uniform(p, "u_ltc_inv_frames", 1.0 / max(frames, 1))
        set_uniform(p, "u_mode", 0)
        self._set_light(p, light, point, weight, camera_position)
        self.vao.render(vertices=3)

    def accumulate(self, acc: PingPong, partial: Target | None, gbuffer, shadow, bias, light, point, weight,
                   camera_position, *, units: int = 1) -> None:
        """Last sample of a frame: frame value = partial + weight·estimate, folded into the running mean.

        The mean counts ``units`` per frame: 1 when it runs over light frames (the fixed plan),
        the frame's number of samples when it runs over samples (the frame budget):
        ``A' = A + (c − units·A) / (n + units)`` with n the units folded in so far.
        """
        ctx = self.ctx
        acc.target.use()
        ctx.enable_only(ctx.NOTHING)
        p = self.program
        self._bind_gbuffer(p, gbuffer)
        shadow.bind(p, _UNITS["shadow"], bias)
        bind(p, "u_previous", acc.current, _UNITS["previous"])
        bind(p, "u_partial", partial.texture if partial is not None else acc.current, _UNITS["partial"])
        set_uniform(p, "u_use_partial", 1.0 if partial is not None else 0.0)
        set_uniform(p, "u_mode", 1)
        set_uniform(p, "u_count", float(acc.units + units))
        set_uniform(p, "u_units", float(units))
        self._set_light(p, light, point, weight, camera_position)
        self.vao.render(vertices=3)
        acc.swap(units)

    def release(self) -> None:
        """Free the programs and the split-sum table (the LTC table belongs to its maker)."""
        for obj in (self.vao, self.program, self.preview_vao, self.preview_program, self.lut_texture):
            if obj is not None:
                obj.release()

