"""Blender Cycles and EEVEE (:mod:`compare.blender`, the ``blender`` extra) as renderers of the
registry: ``cycles`` (the paper's reference, CPU) and ``eevee`` (its rasterizer comparator)."""

from __future__ import annotations

from typing import Any

import numpy as np

from compare.blender.export import CYCLES_PAPER_SAMPLES, EEVEE_PAPER_SAMPLES
from compare.brdf import PRINCIPLED_MODES
from compare.renderers.base import Checkpoint, RenderContext, Renderer, Rendering
from compare.renderers.options import parse_spec
from compare.scene.model import MAP_FEATURE_NAMES, MATERIAL_FEATURE_NAMES

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
                         distribution: str | None = None,
                         gltf_import: bool = False) -> tuple[list[tuple[int, float, np.ndarray]], float, dict, Any]:
    """Render with Blender; returns (checkpoints, start-up seconds, metadata, result).

    Each checkpoint is a render of its own with the same seed (Blender's
    sample sequences are deterministic, so it is the first n samples).
    """
    from compare.blender import render_blender

    result = render_blender(scene, engine=engine, samples=samples, seed=seed, ladder=ladder,
                            distribution=distribution, gltf_import=gltf_import)
    cps = [(int(c.step), float(c.seconds), np.asarray(c.image, dtype=np.float32)) for c in result.checkpoints]
    if not cps or cps[-1][0] != samples:
        cps.append((samples, float(result.seconds), np.asarray(result.image, dtype=np.float32)))
    return cps, float(result.startup_seconds), dict(result.metadata), result


class BlenderRenderer(Renderer):
    """Cycles (CPU) or EEVEE through ``bpy`` in a separate process.

    ``cycles`` and ``eevee`` give each Principled BSDF the scene material's
    ``distribution`` (Blender's default, Multiscatter GGX, unless the scene
    says otherwise); ``cycles:ggx`` / ``eevee:ggx`` set GGX (single scattering)
    everywhere, ``:multi_ggx`` Multiscatter GGX everywhere. With
    ``--materials cycles`` (for ``cycles``) or ``--materials cycles-ggx`` (for
    ``cycles:ggx``) the reference models the same materials (:meth:`models`), and
    the measure stage says how Cycles-like it is (:mod:`compare.run.likeness`).
    """

    unit = "spp"
    # Principled BSDF v2 inputs; each map on its UV layer with its own transform, wraps and filter; glTF's
    # anisotropy through its Anisotropic inputs, iridescence as its Thin Film, dispersion (which no BSDF of
    # Blender 5.0 has) as three glasses of the channels' IORs (export.anisotropy_inputs, thin_film_inputs,
    # dispersion_inputs); a hidden background as a transparent film (export.py).
    renders = (frozenset({"punctual_lights", "vertex_colors", "single_sided", "hidden_background"})
               | frozenset(MATERIAL_FEATURE_NAMES) | frozenset(MAP_FEATURE_NAMES))
    #: What EEVEE draws less than Cycles: measured, its image does not change with the Anisotropic inputs or
    #: the Thin Film (Blender 5.0); its screen-space refraction has no use for three glasses (not given them).
    EEVEE_LEAVES_OUT = frozenset({"anisotropy", "iridescence", "dispersion"})
    DISTRIBUTION_OPTIONS = {"ggx": "GGX (single scattering) in every Principled BSDF",
                            "multi_ggx": "Multiscatter GGX in every Principled BSDF"}
    OPTIONS = {**DISTRIBUTION_OPTIONS,
               "gltf": "the scene's glTF files read by Blender's own glTF importer (its meshes, UVs, tangents and "
                       "materials), not the suite's export of them; camera, lights and environment the suite's"}

    def __init__(self, spec: str):
        engine = spec.partition(":")[0]
        if engine not in ("cycles", "eevee"):
            raise ValueError(f"unknown Blender engine {engine!r}")
        words = [word for word, _ in parse_spec(spec, self.OPTIONS)]
        distributions = [w for w in words if w in self.DISTRIBUTION_OPTIONS]
        if len(distributions) > 1:
            raise ValueError(f"renderer {spec!r}: one distribution at a time "
                             f"({' or '.join(self.DISTRIBUTION_OPTIONS)})")
        option = distributions[0] if distributions else ""
        self.engine = engine
        if engine == "eevee":
            self.renders = type(self).renders - self.EEVEE_LEAVES_OUT
        self.distribution = option or None
        self.gltf_import = "gltf" in words
        self.name = spec
        self.label = "Blender Cycles (CPU)" if engine == "cycles" else "Blender EEVEE"
        if words:
            self.variant_of = engine
            self.variant_note = "; ".join(self.OPTIONS[w] for w in words)
        if option:
            self.label += " GGX" if option == "ggx" else " Multiscatter GGX"
        if self.gltf_import:
            self.label += " (Blender's glTF import)"

    def available(self) -> tuple[bool, str]:
        from compare.blender import blender_available

        return blender_available()

    def checkpoints(self, steps: int) -> list[int]:
        return blender_ladder(steps)

    def models(self, materials: str) -> bool:
        # Cycles renders the Principled BSDFs that the reference's Principled modes model (with their distribution).
        return (self.engine == "cycles" and not self.gltf_import and materials in PRINCIPLED_MODES
                and PRINCIPLED_MODES[materials] == self.distribution)

    def key(self, scene, settings) -> list:
        return ["blender", self.name, "distribution", self.distribution or "per-material", "import", self.gltf_import]

    def render(self, scene, *, steps: int, checkpoints: list[int], seed: int, context: RenderContext) -> Rendering:
        cps, startup, meta, _ = _blender_checkpoints(scene, engine=self.engine, samples=steps, seed=seed,
                                                          ladder=[c for c in checkpoints if c < steps],
                                                          distribution=self.distribution,
                                                          gltf_import=self.gltf_import)
        return Rendering([Checkpoint(s, t, img) for s, t, img in cps], startup, meta)


class CyclesRenderer(BlenderRenderer):
    """Blender Cycles on the CPU: the paper's reference (1024 spp)."""

    default_budget = CYCLES_PAPER_SAMPLES
    budget_flag = "--cycles-spp"
    render_flag = "--spp"
    VARIANTS = ("cycles:ggx", "cycles:gltf")


class EeveeRenderer(BlenderRenderer):
    """Blender EEVEE: the paper's rasterizer comparator (64 samples)."""

    default_budget = EEVEE_PAPER_SAMPLES
    budget_flag = "--eevee-samples"
    render_flag = "--samples"
    VARIANTS = ("eevee:ggx",)
