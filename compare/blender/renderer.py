"""Blender Cycles and EEVEE (:mod:`compare.blender`, the ``blender`` extra) as renderers of the
registry: ``cycles`` (the paper's reference, CPU) and ``eevee`` (its rasterizer comparator)."""

from __future__ import annotations

from typing import Any

import numpy as np

from compare.blender.export import CYCLES_PAPER_SAMPLES, EEVEE_PAPER_SAMPLES
from compare.renderers.base import Checkpoint, RenderContext, Renderer, Rendering
from compare.renderers.options import parse_spec
from compare.scene.model import MATERIAL_FEATURE_NAMES

__all__ = ["BlenderRenderer", "CyclesRenderer", "EeveeRenderer", "blender_ladder"]


def blender_ladder(samples: int) -> list[int]:
    """Checkpoints of a Blender run: 1, 4, 16, …, samples (each is a render of its own,
    so powers of 4 keep the ladder's cost to about a third of the full render's)."""
    out, k = [], 1
    while k < samples:
        out.append(k)
        k *= 4
    return out + [int(samples)]


def _blender_checkpoints(scene, *, engine: str, samples: int, seed: int, ladder: list[int],
                         distribution: str | None = None) -> tuple[list[tuple[int, float, np.ndarray]], float, dict,
                                                                   Any]:
    """Render with Blender; returns (checkpoints, start-up seconds, metadata, result).

    Each checkpoint is a render of its own with the same seed (Blender's
    sample sequences are deterministic, so it is the first n samples).
    """
    from compare.blender import render_blender

    result = render_blender(scene, engine=engine, samples=samples, seed=seed, ladder=ladder,
                            distribution=distribution)
    cps = [(int(c.step), float(c.seconds), np.asarray(c.image, dtype=np.float32)) for c in result.checkpoints]
    if not cps or cps[-1][0] != samples:
        cps.append((samples, float(result.seconds), np.asarray(result.image, dtype=np.float32)))
    return cps, float(result.startup_seconds), dict(result.metadata), result


def _cycles_likeness(scene, *, samples: int, seed: int, first, cache_dir, materials: str = "cycles",
                     distribution: str | None = None) -> dict:
    """Is the Mitsuba reference in material mode ``materials`` Cycles-like (compare.blender.likeness)?
    The run's Cycles render (with ``distribution``) is seed A; one more Cycles render (seed B)
    and two independent Mitsuba passes, with as many samples as give them Cycles' noise, are made here."""
    from compare.blender import render_blender
    from compare.blender.likeness import cycles_likeness

    second = render_blender(scene, engine="cycles", samples=samples, seed=seed + 1, distribution=distribution)
    res = cycles_likeness(scene, spp=samples, materials=materials, seeds=(seed, seed + 1), cache_dir=cache_dir,
                          cycles=(first, second), match_noise=True)
    agree = sum(1 for r in res.regions if r.agrees)
    return {"likeness_flip_cross": res.flip_cross, "likeness_flip_seed": res.flip_seed,
            "likeness_flip_mitsuba_seed": res.flip_mitsuba_seed, "likeness_ratio": res.ratio,
            "likeness_ratio_noise_matched": res.ratio_noise_matched,
            "likeness_relmse_ratio": res.relmse_ratio,
            "likeness_relmse_ratio_noise_matched": res.relmse_ratio_noise_matched,
            "likeness_spp": samples, "likeness_mitsuba_spp": res.mitsuba_spp, "likeness_materials": materials,
            "likeness_regions": f"{agree}/{len(res.regions)}"}


class BlenderRenderer(Renderer):
    """Cycles (CPU) or EEVEE through ``bpy`` in a separate process.

    ``cycles`` and ``eevee`` give each Principled BSDF the scene material's
    ``distribution`` (Blender's default, Multiscatter GGX, unless the scene
    says otherwise); ``cycles:ggx`` / ``eevee:ggx`` set GGX (single scattering)
    everywhere, ``:multi_ggx`` Multiscatter GGX everywhere. With
    ``--materials cycles`` (for ``cycles``) or ``--materials cycles-ggx`` (for
    ``cycles:ggx``) and the likeness measurement on (the default), a Cycles
    run also says how Cycles-like the Mitsuba reference is (metadata
    ``likeness_*``, shown in the report).
    """

    unit = "spp"
    renders = frozenset({"punctual_lights"}) | frozenset(MATERIAL_FEATURE_NAMES)  # Principled BSDF v2 inputs
    OPTIONS = {"ggx": "GGX (single scattering) in every Principled BSDF",
               "multi_ggx": "Multiscatter GGX in every Principled BSDF"}

    def __init__(self, spec: str):
        engine = spec.partition(":")[0]
        if engine not in ("cycles", "eevee"):
            raise ValueError(f"unknown Blender engine {engine!r}")
        options = parse_spec(spec, self.OPTIONS)
        if len(options) > 1:
            raise ValueError(f"renderer {spec!r}: one distribution at a time ({' or '.join(self.OPTIONS)})")
        option = options[0][0] if options else ""
        self.engine = engine
        self.distribution = option or None
        self.name = spec
        self.label = "Blender Cycles (CPU)" if engine == "cycles" else "Blender EEVEE"
        if option:
            self.variant_of = engine
            self.variant_note = ("GGX (single scattering) in every Principled BSDF" if option == "ggx" else
                                 "Multiscatter GGX in every Principled BSDF")
            self.label += " GGX" if option == "ggx" else " Multiscatter GGX"

    def available(self) -> tuple[bool, str]:
        from compare.blender import blender_available

        return blender_available()

    def checkpoints(self, steps: int) -> list[int]:
        return blender_ladder(steps)

    def _models_reference(self, settings) -> bool:
        """Whether the reference's material mode models this renderer's Principled BSDFs."""
        from compare.mitsuba.scene_dict import PRINCIPLED_MODES

        return (self.engine == "cycles" and settings.materials in PRINCIPLED_MODES
                and PRINCIPLED_MODES[settings.materials] == self.distribution)

    def _likeness(self, settings) -> bool:
        return self._models_reference(settings) and settings.likeness

    def key(self, scene, settings) -> list:
        # The likeness is metadata, not pixels, but a run that asks for it must not reuse one without.
        return ["blender", self.name, "distribution", self.distribution or "per-material",
                *(["likeness", settings.materials] if self._likeness(settings) else [])]

    def reusable_keys(self, scene, settings) -> list:
        # A finished Cycles render with the likeness has all that a run without it asks for.
        if self._models_reference(settings) and not settings.likeness:
            return [[*self.key(scene, settings), "likeness", settings.materials]]
        return []

    def render(self, scene, *, steps: int, checkpoints: list[int], seed: int, context: RenderContext) -> Rendering:
        cps, startup, meta, result = _blender_checkpoints(scene, engine=self.engine, samples=steps, seed=seed,
                                                          ladder=[c for c in checkpoints if c < steps],
                                                          distribution=self.distribution)
        if self._likeness(context.settings):
            meta.update(_cycles_likeness(scene, samples=steps, seed=seed, first=result, cache_dir=context.cache_dir,
                                         materials=context.settings.materials, distribution=self.distribution))
        return Rendering([Checkpoint(s, t, img) for s, t, img in cps], startup, meta)


class CyclesRenderer(BlenderRenderer):
    """Blender Cycles on the CPU: the paper's reference (1024 spp)."""

    default_budget = CYCLES_PAPER_SAMPLES
    budget_flag = "--cycles-spp"
    render_flag = "--spp"
    VARIANTS = ("cycles:ggx",)


class EeveeRenderer(BlenderRenderer):
    """Blender EEVEE: the paper's rasterizer comparator (64 samples)."""

    default_budget = EEVEE_PAPER_SAMPLES
    budget_flag = "--eevee-samples"
    render_flag = "--samples"
    VARIANTS = ("eevee:ggx",)
