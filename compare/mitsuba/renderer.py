"""The Mitsuba 3 path tracer (:mod:`compare.mitsuba.reference`) as a renderer of the registry: ``mitsuba``.

Checkpoints may be any ascending spp ladder
(:meth:`compare.mitsuba.reference.ReferenceRenderer.iter_checkpoints`: a ground truth rendered
with one checkpoint reuses the passes of a convergence ladder and the reference cache).
"""

from __future__ import annotations

from compare.renderers.base import RenderContext, Renderer, Rendering
from compare.mitsuba.backend import MITSUBA_VARIANTS
from compare.renderers.options import parse_spec
from compare.scene.model import MAP_FEATURE_NAMES, MATERIAL_FEATURE_NAMES

__all__ = ["MitsubaRenderer"]


#: Bytes per pixel a Mitsuba render holds at once: its film (RGBA and weight, float32, and the
#: developed copy), the float64 accumulation of passes, and the float32 images handed on.
FILM_BYTES_PER_PIXEL = 96


def _available_memory() -> int:
    """Bytes this machine can still give (MemAvailable), or 0 if unknown."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return 0


def check_film_memory(scene) -> None:
    """Refuse a resolution whose film and accumulation do not fit in the memory available."""
    from compare.util.errors import SceneError

    w, h = scene.camera.resolution
    need, have = w * h * FILM_BYTES_PER_PIXEL, _available_memory()
    if have and need > 0.9 * have:
        raise SceneError(f"{scene.path}: camera.resolution: {w}x{h} needs about {need / 2**30:.1f} GiB for "
                         f"Mitsuba's film and the accumulation of its passes; {have / 2**30:.1f} GiB of memory "
                         "is available here")


class MitsubaRenderer(Renderer):
    """Mitsuba 3 (the best available variant), the suite's reference path tracer."""

    name = "mitsuba"
    unit = "spp"
    default_budget = "spp"
    # every material feature in both flavours (the cycles flavour: as Blender's Principled v2 inputs)
    # a hidden background: compare.mitsuba.background (the emitters seen directly stay seen)
    renders = (frozenset({"punctual_lights", "vertex_colors", "single_sided", "hidden_background"})
               | frozenset(MATERIAL_FEATURE_NAMES) | frozenset(MAP_FEATURE_NAMES))

    OPTIONS = {v: f"Mitsuba's {v} variant instead of the best available" for v in MITSUBA_VARIANTS}

    def __init__(self, spec: str | None = None):
        spec = spec or self.name  # a subclass may name itself
        options = parse_spec(spec, self.OPTIONS)
        if len(options) > 1:
            raise ValueError(f"renderer {spec!r}: one Mitsuba variant at a time")
        self.name = spec
        #: The Mitsuba variant asked for, or None for the best available (compare.mitsuba.backend).
        self.variant = options[0][0] if options else None
        if self.variant:
            self.variant_of, self.variant_note = "mitsuba", f"the {self.variant} variant"

    @property
    def label(self) -> str:
        from compare.mitsuba.backend import load_mitsuba
        from compare.util.errors import MissingComponentError

        try:
            return f"Mitsuba path tracer ({load_mitsuba(self.variant).variant()})"
        except MissingComponentError:
            return "Mitsuba path tracer"

    def available(self) -> tuple[bool, str]:
        from compare.mitsuba.backend import load_mitsuba
        from compare.util.errors import MissingComponentError

        try:
            load_mitsuba(self.variant)
        except MissingComponentError as exc:
            return False, str(exc)
        return True, ""

    def _reference(self, scene, context: RenderContext):
        from compare.mitsuba.reference import ReferenceRenderer

        workers = None
        if context.workers is not None:  # the run's dask cluster renders the passes (same pixels)
            from compare.mitsuba.cluster import DaskWorkers

            workers = DaskWorkers(context.workers)
        return ReferenceRenderer(scene, materials=context.settings.materials, variant=self.variant,
                                 cache_dir=context.cache_dir, progress=context.progress, workers=workers)

    def preflight(self, scene, context: RenderContext) -> None:
        check_film_memory(scene)

    def key(self, scene, settings) -> dict:
        from compare.mitsuba.reference import ReferenceRenderer

        # ReferenceRenderer.settings() is the reference cache's key: every setting that changes pixels.
        return ReferenceRenderer(scene, materials=settings.materials, variant=self.variant, cache_dir=False,
                                 progress=False).settings()

    def render(self, scene, *, steps: int, checkpoints: list[int], seed: int, context: RenderContext) -> Rendering:
        rr = self._reference(scene, context)
        out = list(rr.iter_checkpoints(checkpoints, seed))
        meta = {"variant": rr.variant, "seed": seed, **rr.settings()}
        return Rendering(out, float(rr.load_seconds), meta, variance=rr.variance)

    def render_until(self, scene, *, rule, seed: int, context: RenderContext) -> Rendering:
        """The doubling ladder's passes until the spread of their luminance meets ``rule``
        (:mod:`compare.image.convergence`); the passes, and so the pixels, are those of a fixed budget of
        the spp it stopped at."""
        from compare.image.convergence import Stopping

        rr = self._reference(scene, context)
        stopping = Stopping(rule)
        last = list(rr.iter_checkpoints([rule.cap], seed, until=stopping))[-1:]
        meta = {"variant": rr.variant, "seed": seed, **rr.settings()}
        return Rendering(last, float(rr.load_seconds), meta, variance=rr.variance, convergence=stopping.record())

    def render_layers(self, scene, *, steps: int, seed: int, context: RenderContext) -> dict:
        """The per-effect ground truths (compare.mitsuba.layers) at the ground truth's spp."""
        if scene.features().volume:
            return {}  # the layers integrator has no media: a scene with absorbing solids has no layers
        _, layers, _ = self._reference(scene, context).render_layers(steps, seed)
        return layers

    def material_coverage(self, scene) -> dict[str, float]:
        from compare.mitsuba.coverage import material_coverage

        return material_coverage(scene)  # Mitsuba's own ray tracer on the reference's scene

    def limit_threads(self, threads: int) -> None:
        from compare.mitsuba.backend import configure_llvm, set_thread_count

        configure_llvm()  # before Dr.Jit's first import
        set_thread_count(threads)

    def facts(self, metadata: dict) -> dict[str, str]:
        v = metadata.get("variant")
        return {"mitsuba_variant": v} if isinstance(v, str) else {}
