"""The rasterizer's options: one validated dataclass (:class:`RasterizerOptions`) that
:class:`compare.progressive.rasterizer.Rasterizer` is built from; the spec words of
``progressive:<option>`` (:mod:`compare.progressive.options`) set some of them."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

from compare.ibl import DEFAULT_LEVELS, DEFAULT_SAMPLES, DEFAULT_SIZE
from compare.progressive.lights.direct import AREA_MODELS, SUPPORTED_MATERIALS
from compare.progressive.schedule.distributor import DEFAULT_FRAMES
from compare.progressive.environment.environment import ENV_DIFFUSE
from compare.progressive.first_frame import FIRST_FRAME_MODES, check_scale
from compare.progressive.lights.shadow import DEFAULT_BIAS, DEFAULT_SHADOW_SIZE, SHADOW_FILTERS

__all__ = ["DEFAULT_D_OCC_FRACTION", "DEFAULT_OCCLUSION_BIAS", "RasterizerOptions"]

#: Default occlusion distance d_occ as a fraction of the diagonal of the scene's bounds.
DEFAULT_D_OCC_FRACTION = 0.1
#: Default depth bias of the occlusion test, as a fraction of d_occ.
DEFAULT_OCCLUSION_BIAS = 0.01
#: How the environment light is shadowed (RasterizerOptions.env_occlusion).
ENV_OCCLUSION = ("screen", "shadows")


def _finite(x) -> bool:
    """A finite real number (numpy scalars included, booleans not)."""
    if isinstance(x, bool):
        return False
    try:
        return math.isfinite(float(x))
    except (TypeError, ValueError):
        return False


@dataclass(frozen=True)
class RasterizerOptions:
    """Every setting of one progressive render but the scene and the GL context; checked when made
    (ValueError naming the field).

    Attributes
    ----------
    frames : int
        Frames m to accumulate (paper default 128).
    seed : int
        Selects the jitter and light-sample offsets; a fixed seed gives the same image.
    area_model : {"radiometric", "paper", "ltc"}
        Light-sample contribution; see :mod:`compare.progressive.lights.direct`; ``"ltc"``:
        the closed-form unshadowed light times a shadow ratio (:mod:`compare.progressive.lights.ltc`).
    materials : {"shared", "diffuse"}
        The shared glTF BRDF, or Lambert only (for closed-form validation; same
        meaning as in :mod:`compare.mitsuba.scene_dict`).
    direct_fraction : float or None
        f_d: light samples start at frame round(f_d·m); None uses the paper's 0.3, or 0 with
        ``area_model="ltc"`` (:data:`compare.progressive.lights.ltc.LTC_DIRECT_FRACTION`: its light
        is exact from the first frame, and only its shadows wait for samples).
    samples_per_light : int or sequence of int
        n_i; None uses the paper's round(m / lights / 4).
    shadow_size : int
        Face resolution S of the shadow atlas (3S × S texels).
    shadow_bias : (float, float, float)
        (normal offset, constant, slope-scaled) in shadow texels; see :mod:`.shadow`.
    shadow_filter : {"hard", "vsm"}
        Visibility of a light sample: a hard depth test, or variance shadow maps
        filtered to about the penumbra of the sample's share of the light (the
        atlas then has at most ``shadow_size`` texels a side); see :mod:`.shadow`.
    d_occ : float
        Occlusion distance of the environment's screen-space occlusion, in
        world units; 0 turns occlusion off (no samples, no pass); None uses
        :data:`DEFAULT_D_OCC_FRACTION` × the diagonal of the scene's bounds.
    env_samples : int
        N environment occlusion samples (half diffuse, half specular); None
        uses the paper's N = frames.
    occlusion_bias : float
        Depth bias of the occlusion test as a fraction of d_occ.
    env_format : {"float", "rgbm", "octahedral"}
        Storage of the prefiltered environment (:mod:`compare.ibl.atlas`).
    env_diffuse : {"cube", "sh9"}
        Diffuse irradiance from the convolved cube or from 9 SH coefficients.
    ibl_size, ibl_levels, ibl_samples : int
        Cube face size, prefiltered levels and GGX samples per texel of the
        environment preprocessing (:func:`compare.ibl.preprocess`).
    cache_dir : path, None or False
        Cache root of the environment preprocessing (None: the default cache; False: none).
    warm_up : bool
        Draw frame 0 and the first light frame once before timing starts, so
        that lazy shader compilation is not counted in frame 1 (default True).
    indirect : {"none", "probes"} or None
        Indirect diffuse light: none (the paper's technique) or an irradiance
        volume (:mod:`compare.progressive.indirect.probes`); None uses the scene's
        ``[render] indirect``.
    probe_grid : (int, int, int) or None
        Probes along x, y, z; None uses the scene's ``probe_grid``.
    probe_bounces : int or None
        Diffuse bounces baked into the probes; None uses the scene's ``probe_bounces``.
    first_frame : {"forward", "gbuffer"}
        How frame 0 (display only) is drawn: one forward-shaded pass
        (:mod:`compare.progressive.first_frame`, the cheap first frame) or the
        G-buffer and full-screen passes of every other frame. The forward pass
        is used when frame 0 carries no samples (its preview then has no
        indirect light of probes: that needs the G-buffer).
    first_frame_scale : float or None
        Fraction of each axis at which the forward frame 0 is drawn; None (default)
        picks it (:func:`compare.progressive.first_frame.auto_scale`: 0.5, a quarter
        of the pixels, from 320×240 up, else 1). Below 1 frame 0 is a preview only,
        upsampled for display, and frame 1 draws the full-size unshadowed preview;
        1 draws it at full size as the first value of the every-frame mean.
    env_occlusion : {"screen", "shadows"}
        How the environment light is shadowed: screen-space occlusion samples (the paper's), or
        environment shadow maps of luminance-sampled directions (:mod:`compare.progressive.environment.env_shadows`).
    sun : bool
        Take the environment's brightest compact region out of the map as a directional light with its
        own shadow map (:mod:`compare.progressive.environment.sun`; ``progressive:sun``).
    frame_budget_ms : float or None
        A per-frame time budget: each frame evaluates as many of the plan's
        samples as a measured cost model says fit (:mod:`compare.progressive.schedule.budget`),
        at least one, so the render takes as many frames as it needs; None
        keeps the paper's fixed plan of ``frames`` frames.
    """

    frames: int = DEFAULT_FRAMES
    seed: int = 0
    area_model: str = "radiometric"
    materials: str = "shared"
    direct_fraction: float | None = None
    samples_per_light: int | Sequence[int] | None = None
    shadow_size: int = DEFAULT_SHADOW_SIZE
    shadow_bias: tuple[float, float, float] = DEFAULT_BIAS
    shadow_filter: str = "hard"
    d_occ: float | None = None
    env_samples: int | None = None
    occlusion_bias: float = DEFAULT_OCCLUSION_BIAS
    env_format: str = "float"
    env_diffuse: str = "cube"
    ibl_size: int = DEFAULT_SIZE
    ibl_levels: int = DEFAULT_LEVELS
    ibl_samples: int = DEFAULT_SAMPLES
    cache_dir: object = None
    warm_up: bool = True
    indirect: str | None = None
    probe_grid: Sequence[int] | None = None
    probe_bounces: int | None = None
    first_frame: str = "forward"
    first_frame_scale: float | None = None
    frame_budget_ms: float | None = None
    env_occlusion: str = "screen"
    sun: bool = False

    def __post_init__(self):
        if self.env_occlusion not in ENV_OCCLUSION:
            raise ValueError(f"env_occlusion: expected one of {', '.join(map(repr, ENV_OCCLUSION))}, "
                             f"got {self.env_occlusion!r}")
        if self.area_model not in AREA_MODELS:
            raise ValueError(f"area_model: expected one of {', '.join(map(repr, AREA_MODELS))}, got {self.area_model!r}")
        if self.materials not in SUPPORTED_MATERIALS:
            raise ValueError(f"materials: expected one of {', '.join(map(repr, SUPPORTED_MATERIALS))}, got {self.materials!r}")
        if len(tuple(self.shadow_bias)) != 3 or not all(_finite(b) and b >= 0 for b in self.shadow_bias):
            raise ValueError(f"shadow_bias: expected three non-negative numbers, got {self.shadow_bias!r}")
        if self.first_frame_scale is not None:
            check_scale(self.first_frame_scale)
        if self.first_frame not in FIRST_FRAME_MODES:
            raise ValueError(f"first_frame: expected one of {', '.join(map(repr, FIRST_FRAME_MODES))}, "
                             f"got {self.first_frame!r}")
        if self.shadow_filter not in SHADOW_FILTERS:
            raise ValueError(f"shadow_filter: expected one of {', '.join(map(repr, SHADOW_FILTERS))}, "
                             f"got {self.shadow_filter!r}")
        if self.env_diffuse not in ENV_DIFFUSE:
            raise ValueError(f"env_diffuse: expected one of {', '.join(map(repr, ENV_DIFFUSE))}, got {self.env_diffuse!r}")
        if self.d_occ is not None and not (_finite(self.d_occ) and self.d_occ >= 0):
            raise ValueError(f"d_occ: expected a non-negative distance (0 turns occlusion off), got {self.d_occ!r}")
        if not (_finite(self.occlusion_bias) and 0 <= self.occlusion_bias < 1):
            raise ValueError(f"occlusion_bias: expected a fraction of d_occ in [0, 1), got {self.occlusion_bias!r}")
        if self.frame_budget_ms is not None and not (_finite(self.frame_budget_ms) and self.frame_budget_ms > 0):
            raise ValueError(f"frame_budget_ms: expected a positive number of milliseconds, "
                             f"got {self.frame_budget_ms!r}")
