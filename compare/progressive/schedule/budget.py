"""The adaptive frame budget: as many samples per frame as fit in a time budget.

The paper's distributor (:mod:`compare.progressive.schedule.distributor`) fixes before
the first frame which frame evaluates which sample, so every frame after the
direct-light start costs about the same on any device: a fast GPU idles, a
slow one misses its frame rate. The paper leaves an automatic adaptation to the
device as future work. Here a :class:`BudgetScheduler` takes the same samples
(the same points on the lights, the same environment directions, in the same
order) and decides frame by frame how many of them the next frame evaluates,
from a cost model of this device:

``t(frame) ≈ s · (c_0 + k_l·c_l + k_e·c_e)``

``c_0`` is a frame without samples (G-buffer, every-frame pass), ``c_l`` one
light sample (its shadow atlas and direct pass), ``c_e`` one environment
occlusion sample, ``c_p`` one punctual light's shadow map (``t`` adds ``k_p·c_p``),
all measured once after the shaders are compiled
(:meth:`Rasterizer._calibrate`); ``s`` follows the observed frame
times (an exponential moving average of observed ÷ predicted), so the model
keeps up with a device that speeds up or slows down. Each frame gets samples
one at a time, always of the kind (light or environment) that is furthest
behind as a fraction of its total, while the predicted time stays within the
budget; every frame gets at least one sample, so the render always ends. Frame
0 stays the cheap preview (no samples), and light samples start at frame 1,
not at ``f_d·m``: with a budget the point is to reach the final image soonest.
The punctual lights' shadow maps go first, as in the fixed plan (each is needed
once and makes its light exact from then on).

Weights: a frame may now fold any number k of light samples into the direct
running mean, so the mean runs over *samples*, not frames: each sample's
estimate is weighted ``T/n_i`` (T = all light samples) and the mean after s
samples is ``(1/s) Σ (T/n_i) est``. At the end (s = T) that is
``Σ_i (1/n_i) Σ_k est_ik``, exactly the fixed plan's result; before it, because
the lights' samples are merged in proportion (the distributor's order), each
light has done about ``s·n_i/T`` of its samples and the image is nearly
unbiased, as with the fixed plan. The environment's means already run over
samples per kind.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from compare.progressive.schedule.distributor import FramePlan, Plan
from compare.progressive.schedule.sampling import pixel_jitter

#: Weight of the newest observation in the moving average of observed ÷ predicted frame time.
SMOOTHING = 0.3


@dataclass
class FrameCosts:
    """Measured seconds of a frame without samples and of one more light / environment sample."""

    base: float
    light: float
    env: float
    punctual: float = 0.0
    """One punctual light's shadow map."""

    def predict(self, lights: int, envs: int, punctual: int = 0) -> float:
        return self.base + lights * self.light + envs * self.env + punctual * self.punctual


class BudgetScheduler:
    """Frame plans for a per-frame time budget, built one frame at a time from a fixed :class:`Plan`.

    Parameters
    ----------
    plan : Plan
        The fixed plan whose samples (and frame 0) are used.
    budget : float
        Seconds one frame may take (e.g. 1/60).
    max_env_per_frame : int
        Most environment samples one frame may carry (the occlusion pass's limit).
    """

    def __init__(self, plan: Plan, budget: float, *, max_env_per_frame: int = 16):
        if not (isinstance(budget, (int, float)) and math.isfinite(budget) and budget > 0):
            raise ValueError(f"frame budget: expected a positive number of seconds, got {budget!r}")
        self.budget = float(budget)
        self.max_env = int(max_env_per_frame)
        lights = [s for fp in plan for s in fp.light_samples]
        total = len(lights)
        counts = plan.samples_per_light
        self.lights = [replace(s, weight=total / counts[s.light]) for s in lights]
        self.envs = [s for fp in plan for s in fp.env_samples]
        self.punctual = [k for fp in plan for k in fp.punctual]
        self.first = plan[0]
        self.jitter = pixel_jitter(1 + len(self.lights) + len(self.envs) + len(self.punctual), plan.seed)
        self.costs: FrameCosts | None = None
        self.scale = 1.0
        self.frame = 0
        self._next_light = 0
        self._next_env = 0
        self._next_punctual = 0

    @property
    def done(self) -> bool:
        """All samples handed out (and frame 0 drawn)."""
        return (self.frame > 0 and self._next_light == len(self.lights) and self._next_env == len(self.envs)
                and self._next_punctual == len(self.punctual))

    def reset(self) -> None:
        """Start again from frame 0 (the cost model and its scale are kept)."""
        self.frame = 0
        self._next_light = self._next_env = self._next_punctual = 0

    def next(self) -> FramePlan:
        """The plan of the next frame."""
        if self.done:
            raise RuntimeError("every sample has been handed out")
        f = self.frame
        self.frame += 1
        if f == 0:
            return self.first
        costs = self.costs or FrameCosts(0.0, 1.0, 1.0)  # uncalibrated: one sample per frame
        nl, ne = len(self.lights), len(self.envs)
        kl = ke = kp = 0
        while self._next_punctual + kp < len(self.punctual):
            if kp > 0 and self.scale * costs.predict(0, 0, kp + 1) > self.budget:
                break
            kp += 1
        while True:
            left_l = self._next_light + kl < nl
            left_e = self._next_env + ke < ne and ke < self.max_env
            if not (left_l or left_e):
                break
            # The kind furthest behind as a fraction of its total goes next.
            frac_l = (self._next_light + kl) / nl if nl else math.inf
            frac_e = (self._next_env + ke) / ne if ne else math.inf
            take_light = left_l and (not left_e or frac_l <= frac_e)
            trial = (kl + 1, ke) if take_light else (kl, ke + 1)
            if kl + ke + kp > 0 and self.scale * costs.predict(*trial, kp) > self.budget:
                break
            kl, ke = trial
        lights = tuple(self.lights[self._next_light:self._next_light + kl])
        envs = tuple(self.envs[self._next_env:self._next_env + ke])
        punctual = tuple(self.punctual[self._next_punctual:self._next_punctual + kp])
        self._next_light += kl
        self._next_env += ke
        self._next_punctual += kp
        jx, jy = self.jitter[f]
        return FramePlan(frame=f, jitter=(float(jx), float(jy)), light_samples=lights, env_samples=envs,
                         punctual=punctual)

    def observe(self, fp: FramePlan, seconds: float) -> None:
        """Fold the measured wall ``seconds`` of frame plan ``fp`` into the model's scale."""
        if self.costs is None or fp.frame == 0 or not math.isfinite(seconds) or seconds <= 0:
            return
        raw = self.costs.predict(len(fp.light_samples), len(fp.env_samples), len(fp.punctual))
        if raw > 0:
            self.scale += SMOOTHING * (seconds / raw - self.scale)
