"""Environment lighting in the rasterizer: the IBL textures, and the progressive occlusion pass.

:class:`EnvironmentLighting` preprocesses the scene's environment once
(:func:`compare.ibl.preprocess`, cached by content) and uploads:

* the equirectangular map itself (the background, interpolated as Mitsuba does);
* the prefiltered specular chain as a 2D atlas in the chosen ``env_format``
  (``"float"`` cube faces, ``"rgbm"`` cube faces in RGBM sqrt/range 7, or
  ``"octahedral"`` maps; :mod:`compare.ibl.atlas`);
* the diffuse irradiance as a convolved cube (``env_diffuse="cube"``) or 9 SH
  coefficients (``"sh9"``);
* the split-sum LUT.

Its GLSL is ``compare/ibl/ibl.glsl``. The every-frame pass (``accumulate.glsl``)
adds the unoccluded split-sum light; :class:`EnvOcclusionPass`
(``env_occlusion.glsl``) accumulates, in the frames the distributor gives
environment samples, the light that screen-space occlusion leaves visible: one
running mean per kind (diffuse, specular) over that kind's samples
(:class:`EnvOcclusionTargets`), which replaces the unoccluded light once both
kinds have samples.
"""

from __future__ import annotations

import time

import numpy as np

from compare.scene.environments import environment_image
from compare.scene.equirect import rotation_matrix
from compare.ibl import (DEFAULT_LEVELS, DEFAULT_SAMPLES, DEFAULT_SIZE, ENV_FORMATS, MAX_LEVELS, build_atlas, preprocess,
                         split_sum)
from compare.ibl.irradiance import SH_BAND_FACTORS
from compare.progressive.gl.passes import RenderPass
from compare.progressive.gl.shaders import load_program, set_uniform
from compare.progressive.gl.units import Units, bind, units_of

#: How the diffuse irradiance is stored.
ENV_DIFFUSE = ("cube", "sh9")
#: Largest number of environment samples one frame can evaluate (MAX_ENV_SAMPLES in env_occlusion.glsl).
MAX_SAMPLES_PER_FRAME = 16
_KINDS = {"diffuse": 0, "specular": 1}
_OCCLUSION = units_of("env_occlusion.glsl")


def _texture(ctx, data: np.ndarray, *, repeat_x: bool = False):
    data = np.ascontiguousarray(data)
    h, w, c = data.shape
    if data.dtype == np.uint8:
        tex = ctx.texture((w, h), c, data.tobytes(), dtype="f1")
    else:
        tex = ctx.texture((w, h), c, data.astype(np.float32).tobytes(), dtype="f4")
    tex.filter = (ctx.LINEAR, ctx.LINEAR)
    tex.repeat_x = repeat_x
    tex.repeat_y = False
    return tex


class EnvironmentLighting(RenderPass):
    """The environment's textures and uniforms, for every program that includes ``ibl.glsl``.

    Parameters
    ----------
    ctx : moderngl.Context
    scene : compare.scene.loader.Scene
        Must have an environment.
    env_format : {"float", "rgbm", "octahedral"}
    env_diffuse : {"cube", "sh9"}
    ibl_size, ibl_levels, ibl_samples : int
        Cube face size, prefiltered levels, GGX samples per texel (:func:`compare.ibl.preprocess`).
    cache_dir : path, None or False
        Cache root for the procedural map and the preprocessing (None: the default cache).
    """

    def __init__(self, ctx, scene, *, env_format: str = "float", env_diffuse: str = "cube",
                 ibl_size: int = DEFAULT_SIZE, ibl_levels: int = DEFAULT_LEVELS, ibl_samples: int = DEFAULT_SAMPLES,
                 cache_dir=None):
        if env_format not in ENV_FORMATS:
            raise ValueError(f"env_format: expected one of {', '.join(map(repr, ENV_FORMATS))}, got {env_format!r}")
        if env_diffuse not in ENV_DIFFUSE:
            raise ValueError(f"env_diffuse: expected one of {', '.join(map(repr, ENV_DIFFUSE))}, got {env_diffuse!r}")
        if not 2 <= ibl_levels <= MAX_LEVELS:
            raise ValueError(f"ibl_levels: expected 2 … {MAX_LEVELS}, got {ibl_levels}")
        env = scene.environment
        if env is None:
            raise ValueError("EnvironmentLighting: the scene has no environment")
        self.ctx = ctx
        self.env_format = env_format
        self.env_diffuse = env_diffuse
        t0 = time.perf_counter()
        image = environment_image(env, None if cache_dir is False else cache_dir)
        self.map_seconds = time.perf_counter() - t0
        self.ibl = preprocess(image, size=ibl_size, levels=ibl_levels, samples=ibl_samples,
                              octahedral=env_format == "octahedral", cache_dir=cache_dir)
        self.lut, self.lut_seconds, self.lut_cached = split_sum(cache_dir=cache_dir)
        atlas = self.ibl.atlas(env_format)
        irradiance = build_atlas([self.ibl.irradiance], env_format="float")
        self.levels = len(self.ibl.radiance)
        self.intensity = float(env.intensity)
        self.to_map = rotation_matrix(env.rotation).T  # world -> map
        self._levels_bytes = np.zeros((MAX_LEVELS, 3), np.float32)
        self._levels_bytes[:self.levels] = atlas.levels
        self._sh9 = (self.ibl.sh9.astype(np.float64) * SH_BAND_FACTORS[:, None]).astype(np.float32)
        self.textures = []
        try:
            self.map = self._keep(_texture(ctx, image, repeat_x=True))
            self.atlas = self._keep(_texture(ctx, atlas.data))
            self.irradiance = self._keep(_texture(ctx, irradiance.data))
            self.lut_texture = self._keep(_texture(ctx, self.lut))
        except BaseException:
            self.release()
            raise
        self.image = image
        """The equirectangular map (without intensity), for samplers of its directions."""
        self.rotation = float(env.rotation)
        self.map_size = (image.shape[1], image.shape[0])
        self.atlas_size = (atlas.data.shape[1], atlas.data.shape[0])
        self.irradiance_size = (irradiance.data.shape[1], irradiance.data.shape[0])
        self.irradiance_face = float(self.ibl.irradiance.shape[1] - 2)

    def _keep(self, tex):
        self.textures.append(tex)
        return tex

    def defines(self, materials: str = "shared") -> dict[str, int]:
        """Preprocessor defines for programs that include ``ibl.glsl``."""
        return {"ENV_OCTAHEDRAL": int(self.env_format == "octahedral"), "ENV_RGBM": int(self.env_format == "rgbm"),
                "ENV_DIFFUSE_SH9": int(self.env_diffuse == "sh9"), "MATERIALS_DIFFUSE": int(materials == "diffuse")}

    def bind(self, program, units: Units) -> None:
        """Bind the four textures to ``units`` (the program's ``environment`` row) and set every ``u_env_*``
        uniform."""
        textures = ((self.map, "u_env_map"), (self.atlas, "u_env_atlas"), (self.irradiance, "u_env_irradiance"),
                    (self.lut_texture, "u_env_lut"))
        if len(units) != len(textures):
            raise ValueError(f"the environment takes {len(textures)} texture units, got {len(units)}")
        for k, (tex, name) in enumerate(textures):
            bind(program, name, tex, units, k)
        set_uniform(program, "u_env_map_size", tuple(float(x) for x in self.map_size))
        set_uniform(program, "u_env_atlas_size", tuple(float(x) for x in self.atlas_size))
        set_uniform(program, "u_env_levels", self._levels_bytes.tobytes())
        set_uniform(program, "u_env_max_lod", float(self.levels - 1))
        set_uniform(program, "u_env_irradiance_size", tuple(float(x) for x in self.irradiance_size))
        set_uniform(program, "u_env_irradiance_face", self.irradiance_face)
        set_uniform(program, "u_env_sh9", self._sh9.tobytes())
        # GLSL mat3 is column-major: the bytes of the transpose of a row-major matrix.
        set_uniform(program, "u_env_to_map", np.ascontiguousarray(self.to_map.T, dtype=np.float32).tobytes())
        set_uniform(program, "u_env_intensity", self.intensity)

    def describe(self) -> dict:
        """str/int/float metadata of the environment lighting."""
        t = self.ibl.timings
        return {
            "environment": "split sum",
            "env_format": self.env_format,
            "env_diffuse": self.env_diffuse,
            "ibl_size": int(self.ibl.settings["size"]),
            "ibl_levels": int(self.levels),
            "ibl_samples": int(self.ibl.settings["samples"]),
            "ibl_roughness_to_level": f"lod = roughness * {self.levels - 1}",
            "ibl_cached": int(self.ibl.cached),
            "ibl_seconds": float(t.get("total", 0.0)),
            "ibl_lut_seconds": float(self.lut_seconds),
        }

    def release(self) -> None:
        for tex in self.textures:
            tex.release()
        self.textures = []


class EnvOcclusionTargets(RenderPass):
    """Running means of the visible diffuse and specular environment light (RGBA32F, ping-pong, MRT).

    Both targets are written in every environment frame, so one index serves
    both; :attr:`counts` holds how many samples of each kind each mean covers.
    """

    def __init__(self, ctx, size: tuple[int, int]):
        self.textures = [[], []]  # [kind][index]
        for kind in range(2):
            for _ in range(2):
                tex = ctx.texture(size, 4, dtype="f4")
                tex.filter = (ctx.NEAREST, ctx.NEAREST)
                self.textures[kind].append(tex)
        self.fbos = [ctx.framebuffer([self.textures[0][i], self.textures[1][i]]) for i in range(2)]
        self.index = 0
        self.counts = [0, 0]

    def current(self, kind: int):
        """The latest mean of ``kind`` (0 diffuse, 1 specular)."""
        return self.textures[kind][self.index]

    @property
    def target(self):
        return self.fbos[1 - self.index]

    def swap(self, added: tuple[int, int]) -> None:
        self.index = 1 - self.index
        self.counts = [self.counts[0] + added[0], self.counts[1] + added[1]]

    @property
    def count(self) -> int:
        """Samples of both kinds accumulated so far."""
        return self.counts[0] + self.counts[1]

    def reset(self) -> None:
        """Start both means again."""
        self.index = 0
        self.counts = [0, 0]

    def release(self) -> None:
        for obj in self.fbos + self.textures[0] + self.textures[1]:
            obj.release()


class EnvOcclusionPass(RenderPass):
    """The environment's screen-space occlusion (``env_occlusion.glsl``), one pass per environment frame."""

    def __init__(self, ctx, environment: EnvironmentLighting, materials: str = "shared", occlusion: bool = False,
                 layers: bool = False):
        self.ctx = ctx
        self.environment = environment
        self.occlusion = bool(occlusion)
        #: With the material extensions (layers.glsl): the G-buffer's layer targets are read.
        self.layers = bool(layers)
        self.program = load_program(ctx, "env_occlusion.glsl",
                                    {**environment.defines(materials), "OCCLUSION": int(self.occlusion),
                                     "LAYERS": int(self.layers), "MAX_ENV_SAMPLES": MAX_SAMPLES_PER_FRAME})
        self.vao = ctx.vertex_array(self.program, [])

    def run(self, acc: EnvOcclusionTargets, gbuffer, view_proj: bytes, camera_position, camera_forward, samples,
            d_occ: float, bias: float) -> None:
        """Fold this frame's visible-light estimates of ``samples`` (EnvSample) into the per-kind means ``acc``."""
        if len(samples) > MAX_SAMPLES_PER_FRAME:
            raise ValueError(f"{len(samples)} environment samples in one frame; at most {MAX_SAMPLES_PER_FRAME}")
        ctx = self.ctx
        acc.target.use()
        ctx.enable_only(ctx.NOTHING)
        p = self.program
        gbuffer.bind(p)
        bind(p, "u_prev_diffuse", acc.current(0), _OCCLUSION["previous"], 0)
        bind(p, "u_prev_specular", acc.current(1), _OCCLUSION["previous"], 1)
        self.environment.bind(p, _OCCLUSION["environment"])
        if self.layers:
            gbuffer.bind_layers(p)
        if self.occlusion:  # the occlusion maps' factors (G-buffer emission.a)
            gbuffer.bind(p, ("emission",))
        kinds = np.zeros(MAX_SAMPLES_PER_FRAME, np.int32)
        us = np.zeros((MAX_SAMPLES_PER_FRAME, 3), np.float32)
        for i, s in enumerate(samples):
            kinds[i] = _KINDS[s.kind]
            us[i] = (s.u[0], s.u[1], s.t)
        added = (sum(1 for s in samples if s.kind == "diffuse"), sum(1 for s in samples if s.kind == "specular"))
        set_uniform(p, "u_sample_count", len(samples))
        set_uniform(p, "u_sample_kind", kinds.tobytes())
        set_uniform(p, "u_sample_u", us.tobytes())
        set_uniform(p, "u_counts", (float(acc.counts[0]), float(acc.counts[1])))
        set_uniform(p, "u_view_proj", view_proj)
        set_uniform(p, "u_camera_position", tuple(float(x) for x in camera_position))
        set_uniform(p, "u_camera_forward", tuple(float(x) for x in camera_forward))
        set_uniform(p, "u_viewport", tuple(float(x) for x in gbuffer.size))
        set_uniform(p, "u_d_occ", float(d_occ))
        set_uniform(p, "u_occ_bias", float(bias))
        self.vao.render(vertices=3)
        acc.swap(added)

    def describe(self) -> dict:
        """How the environment light is occluded."""
        return {"occlusion": "screen-space, progressive"}

    def release(self) -> None:
        self.vao.release()
        self.program.release()
