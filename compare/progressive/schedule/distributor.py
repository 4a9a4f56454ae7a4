"""The sample distributor (Otto et al. 2020, Algorithm 1): which frame evaluates which sample.

A render of ``m`` frames (paper default 128) is planned before the first frame.

* **Pixel jitter**: every frame has its own sub-pixel offset (R2 sequence,
  :func:`compare.progressive.schedule.sampling.pixel_jitter`).
* **Direct-light samples** (area lights): light ``i`` gets ``n_i`` sample points
  on its rectangle, centre first and then outwards. They are evaluated only in
  frames ``f0 = round(f_d·m) … m−1`` (``f_d`` = ``direct_fraction``, default
  0.3, as in the paper's public code), spread evenly over that window, each
  sample in exactly one frame. Lights take turns in proportion to their sample
  counts (the samples of all lights are merged by the key ``(k + ½)/n_i``), so
  that at any frame every light has done about the same fraction of its samples.
  Frame 0 never carries light samples when ``m ≥ 2``: it needs no shadow map.
* **Environment samples** (scenes with an environment): ``N`` occlusion
  samples (default ``N = m``), as in the paper's public code ``n_d = round(N/2)``
  diffuse and ``n_s = N − n_d`` specular, alternating (even k diffuse, odd k
  specular). The paper puts sample ``k`` in frame ``⌊k·(m−1)/N⌋``, which would
  put two occlusion samples into frame 0; here the same spacing is shifted by
  one frame, ``1 + ⌊k·(m−1)/N⌋``, so that frame 0 stays environment-only
  (split sum without occlusion, no shadow maps: the cheap first frame of the
  paper's Algorithm 1). Each sample carries a point of the 3D R3 sequence of
  its kind (azimuth, polar angle, distance fraction).
* **Punctual lights** (point, spot, directional): their light is exact and
  unshadowed in every frame from the first; each needs one shadow map, which
  stays valid (the scene is static) and is rendered once, in frame ``1 + k``
  for light ``k`` (several per frame when there are more lights than frames
  after frame 0), as early as possible: once every map exists, every later
  frame adds the exact shadowed light at its own jitter
  (:mod:`compare.progressive.lights.punctual`).

Weights
-------
The paper accumulates one running mean over all ``m`` frames and weights a
sample of light ``i`` by ``w_i = m / n_i``, so that the mean over ``m`` frames is
``Σ_i (1/n_i) Σ_k est_ik``, the n_i-sample estimate of every light. Here the
direct light has its own running mean that is only updated in the ``F`` frames
that carry light samples, and a sample is weighted by ``F / n_i``
(:attr:`LightSample.weight`): the final value is the same,
``(1/F) Σ_frames Σ_samples (F/n_i) est = Σ_i (1/n_i) Σ_k est_ik``, but every
intermediate image is already a (nearly) unbiased estimate, because after ``j``
light frames each light has done about ``j·n_i/F`` of its samples. The
every-frame terms (emission, later the environment) have a second running mean
over all frames. Frame 0's cheap preview of the direct light (unshadowed, from
each light's centre) is only what is *displayed* until the first light frame;
it never enters either mean, so it cannot bias the result.
(:attr:`Plan.paper_weights` gives the ``m / n_i`` of the paper for reports.)

The environment light is split the same way: frame 0 shows the unoccluded
split sum (a running mean over all frames, display only, like the direct
preview), and the occluded light has one running mean per kind κ (diffuse,
specular) over that kind's samples, which replaces it once both kinds have
samples. The paper weights a sample by ``m / n_κ`` (:attr:`EnvSample.weight`,
:attr:`Plan.paper_env_weights`) in its single mean over all m frames; the
final value is the same, ``Σ_κ (1/n_κ) Σ_k term_κ V_k``, but every
intermediate image is an unbiased estimate too and never negative.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Iterator, Sequence

import numpy as np

from compare.progressive.schedule.sampling import env_sample_points, light_sample_points, pixel_jitter
from compare.util.settings import DEFAULT_FRAMES

#: Paper default: direct-light samples start at 30 % of the frames.
DEFAULT_DIRECT_FRACTION = 0.3


def round_half_up(x: float) -> int:
    """Round to nearest, halves up (JavaScript's ``Math.round``, used by the paper's code)."""
    return int(math.floor(x + 0.5))


@dataclass(frozen=True)
class LightSample:
    """One point on an area light, evaluated (one shadow map) in exactly one frame."""

    light: int
    """Index into ``scene.lights``."""
    index: int
    """Sample index k within the light, 0 = the centre, growing outwards."""
    point: tuple[float, float, float]
    """World-space point on the light's rectangle."""
    weight: float
    """Factor of this sample's single-sample estimate in the direct running mean (F / n_i)."""


@dataclass(frozen=True)
class EnvSample:
    """One screen-space occlusion sample of the environment light, evaluated in exactly one frame."""

    kind: str
    """``"diffuse"`` (cosine-weighted) or ``"specular"`` (GGX visible normal, reflected)."""
    index: int
    """Index k among all N environment samples (even: diffuse, odd: specular)."""
    weight: float
    """The paper's weight ``m / n_kind`` (for reports; see the module notes on weights)."""
    u: tuple[float, float] = (0.0, 0.0)
    """(ξ₁, ξ₂): azimuth and polar-angle numbers of the direction."""
    t: float = 1.0
    """ξ₃: the sample's distance along the direction as a fraction of d_occ."""


@dataclass(frozen=True)
class FramePlan:
    """What frame ``frame`` (0-based; the paper's frame ``frame + 1``) evaluates."""

    frame: int
    jitter: tuple[float, float]
    """Sub-pixel jitter in pixels (x right, y up) in [−½, ½), passed to ``Camera.projection_matrix``.

    That shifts the image by the jitter, so the pixel centred at i + ½ sees the
    scene at i + ½ − jitter: uniform over the pixel either way."""
    light_samples: tuple[LightSample, ...] = ()
    env_samples: tuple[EnvSample, ...] = ()
    preview: bool = False
    """Frame 0 renders an unshadowed direct-light preview (display only)."""
    punctual: tuple[int, ...] = ()
    """Indices into ``scene.punctual`` whose shadow map this frame renders (once per light)."""

    @property
    def shadow_passes(self) -> int:
        """Shadow maps this frame renders (one per area-light sample, one per punctual light's map)."""
        return len(self.light_samples) + len(self.punctual)


@dataclass(frozen=True)
class Plan:
    """The whole distribution of samples over the frames of one render."""

    frames: tuple[FramePlan, ...]
    direct_start: int
    """First frame that may carry light samples, ``round(f_d·m)`` (at least 1 when m ≥ 2)."""
    direct_fraction: float
    samples_per_light: tuple[int, ...]
    light_frames: int
    """Number of frames that carry light samples (F, the direct running mean's length)."""
    seed: int = 0
    notes: tuple[str, ...] = field(default=())
    env_counts: tuple[int, int] = (0, 0)
    """(n_d, n_s): diffuse and specular environment samples."""
    env_frames: int = 0
    """Number of frames that carry environment samples (E)."""

    def __len__(self) -> int:
        return len(self.frames)

    def __iter__(self) -> Iterator[FramePlan]:
        return iter(self.frames)

    def __getitem__(self, frame: int) -> FramePlan:
        return self.frames[frame]

    @property
    def paper_weights(self) -> tuple[float, ...]:
        """The paper's per-light weights ``w_i = m / n_i``."""
        m = len(self.frames)
        return tuple(m / n for n in self.samples_per_light)

    @property
    def paper_env_weights(self) -> tuple[float, float]:
        """The paper's environment-sample weights ``m / n_d`` and ``m / n_s`` (0 where a kind has no samples)."""
        m = len(self.frames)
        return tuple(m / n if n else 0.0 for n in self.env_counts)  # type: ignore[return-value]

    def samples_of(self, light: int) -> list[tuple[int, LightSample]]:
        """(frame, sample) for every sample of ``light``, in frame order."""
        return [(fp.frame, s) for fp in self.frames for s in fp.light_samples if s.light == light]


def default_samples_per_light(frames: int, lights: int) -> int:
    """The paper's default ``n_i = round(m / lights / 4)``, at least 1."""
    return max(1, round_half_up(frames / max(lights, 1) / 4))


def plan(scene, frames: int = DEFAULT_FRAMES, *, seed: int = 0, direct_fraction: float = DEFAULT_DIRECT_FRACTION,
         samples_per_light: int | Sequence[int] | None = None, env_samples: int | None = None) -> Plan:
    """Distribute pixel jitter, light samples and environment samples over ``frames`` frames.

    Parameters
    ----------
    scene : compare.scene.loader.Scene
    frames : int
        Number of frames m (≥ 1).
    seed : int, keyword-only
        Selects the R2 offsets of the jitter and of the light samples.
    direct_fraction : float, keyword-only
        f_d in [0, 1): light samples go into frames round(f_d·m) … m−1.
    samples_per_light : int or sequence of int, keyword-only
        n_i for every light (one int) or per light; None uses the paper's
        ``round(m / lights / 4)``.
    env_samples : int, keyword-only
        N, the environment's occlusion samples (scenes with an environment
        only); None uses the paper's N = m; 0 plans none.

    Returns
    -------
    Plan
    """
    if isinstance(frames, bool) or not isinstance(frames, (int, np.integer)) or frames < 1:
        raise ValueError(f"frames: expected a positive integer, got {frames!r}")
    frames = int(frames)
    if not (0.0 <= direct_fraction < 1.0):
        raise ValueError(f"direct_fraction: expected a number in [0, 1), got {direct_fraction!r}")
    lights = scene.lights
    if samples_per_light is None:
        counts = [default_samples_per_light(frames, len(lights))] * len(lights)
    elif isinstance(samples_per_light, (int, np.integer)) and not isinstance(samples_per_light, bool):
        counts = [int(samples_per_light)] * len(lights)
    else:
        counts = [int(c) for c in samples_per_light]
        if len(counts) != len(lights):
            raise ValueError(f"samples_per_light: expected {len(lights)} counts (one per light), got {len(counts)}")
    if any(c < 1 for c in counts):
        raise ValueError(f"samples_per_light: expected positive counts, got {counts}")

    start = round_half_up(direct_fraction * frames)
    start = min(max(start, 1), frames - 1) if frames >= 2 else 0
    window = frames - start

    # Merge the lights' samples so each light's samples are spread evenly over the sequence.
    order = sorted(((k + 0.5) / n, i, k) for i, n in enumerate(counts) for k in range(n))
    total = len(order)
    points = [light_sample_points(light, counts[i], seed, i)[0] for i, light in enumerate(lights)]
    per_frame: list[list[tuple[int, int]]] = [[] for _ in range(frames)]
    for g, (_, i, k) in enumerate(order):
        per_frame[start + (g * window) // total].append((i, k))
    light_frames = sum(1 for f in per_frame if f)

    env_per_frame, env_counts, env_frames, env_notes = _env_plan(scene, frames, seed, env_samples)
    punctual_per_frame = punctual_frames(len(getattr(scene, "punctual", ())), frames)

    jitter = pixel_jitter(frames, seed)
    plans = []
    for f in range(frames):
        samples = tuple(
            LightSample(i, k, tuple(float(x) for x in points[i][k]), light_frames / counts[i]) for i, k in per_frame[f]
        )
        plans.append(FramePlan(
            frame=f,
            jitter=(float(jitter[f, 0]), float(jitter[f, 1])),
            light_samples=samples,
            env_samples=tuple(env_per_frame[f]),
            preview=bool(f == 0 and lights and not samples),
            punctual=tuple(punctual_per_frame[f]),
        ))
    notes: tuple[str, ...] = ()
    if frames == 1 and lights:
        notes = ("with a single frame, frame 0 evaluates the light samples itself (no cheap first frame)",)
    return Plan(tuple(plans), start, float(direct_fraction), tuple(counts), light_frames, int(seed),
                notes + env_notes, env_counts, env_frames)


def punctual_frames(count: int, frames: int) -> list[list[int]]:
    """Which frame renders each of ``count`` punctual lights' shadow maps: light k in frame
    ``1 + k``, or ``1 + ⌊k·(m−1)/count⌋`` when there are more lights than frames after frame 0
    (frame 0 stays the cheap preview; a single frame renders them itself)."""
    per_frame: list[list[int]] = [[] for _ in range(frames)]
    for k in range(count):
        if frames == 1:
            per_frame[0].append(k)
        elif count <= frames - 1:
            per_frame[1 + k].append(k)
        else:
            per_frame[1 + (k * (frames - 1)) // count].append(k)
    return per_frame


def _env_plan(scene, frames: int, seed: int, env_samples: int | None):
    """Environment samples per frame, (n_d, n_s), the number of frames carrying them, notes."""
    per_frame: list[list[EnvSample]] = [[] for _ in range(frames)]
    if getattr(scene, "environment", None) is None:
        return per_frame, (0, 0), 0, ()
    count = frames if env_samples is None else env_samples
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 0:
        raise ValueError(f"env_samples: expected a non-negative integer, got {env_samples!r}")
    count = int(count)
    if count == 0:
        return per_frame, (0, 0), 0, ()
    if frames < 2:
        return per_frame, (0, 0), 0, ("with a single frame there is no frame for environment occlusion samples "
                                      "(frame 0 is environment-only)",)
    n_d = round_half_up(count / 2)
    n_s = count - n_d
    window = frames - 1
    points = {"diffuse": env_sample_points(n_d, seed, 0), "specular": env_sample_points(n_s, seed, 1)}
    frames_with = sorted({1 + (k * window) // count for k in range(count)})
    e = len(frames_with)
    for k in range(count):
        kind = "diffuse" if k % 2 == 0 else "specular"
        j = k // 2
        n = n_d if kind == "diffuse" else n_s
        x = points[kind][j]
        per_frame[1 + (k * window) // count].append(
            EnvSample(kind, k, frames / n, (float(x[0]), float(x[1])), float(x[2])))
    return per_frame, (n_d, n_s), e, ()
