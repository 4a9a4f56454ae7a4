"""The renderer protocol: what every renderer declares and the one call that renders.

A renderer of the suite, built in or plugged in, is an object with

``name``
    the spec it is selected by (``--renderers``, ``--renderer``, ``results.json``);
``label``
    a human-readable name for tables and legends;
``unit``
    what a step counts: ``"spp"``, ``"frame"`` or ``"sample"``;
``variant_of`` and ``variant_note``
    the renderer this one is a variant of and what it changes (the report's
    ablation table compares variants with their baseline), or None and "";
:meth:`Renderer.available`
    ``(True, "")``, or ``(False, why)`` saying what is missing and how to install it;
:meth:`Renderer.steps` and :meth:`Renderer.checkpoints`
    the budget of a run with given :class:`~compare.report.results.RunSettings`, and
    the steps to keep an image at (1, 2, 4, …, budget unless it says otherwise);
:meth:`Renderer.key`
    every setting that changes the renderer's pixels (JSON data; with the scene's
    hash, size, seed and checkpoints it keys a finished render, so a rerun with
    the same key reuses it);
:meth:`Renderer.render`
    renders a scene (its camera's resolution) with a seed and returns a
    :class:`Rendering`: :class:`Checkpoint` s (step, cumulative seconds, linear
    float32 H×W×3 image), set-up seconds outside those and flat metadata, and
    optionally the final image split by kind of light (``layers``, the names of
    :mod:`compare.mitsuba.layers`), which the report measures layer by layer;
:meth:`Renderer.render_layers`
    optional: those layers as a render of their own, made when the renderer is the
    ground truth (the Mitsuba reference's per-effect ground truths).

Checkpoints are checked here (:func:`check_rendering`), once for every renderer:
the steps asked for, ascending times, the scene's size, finite pixels. A broken renderer gets one :class:`RendererError` naming it.
"""

from __future__ import annotations

import abc
import math
from dataclasses import dataclass, field
from typing import Any, Callable, ClassVar, NamedTuple

import numpy as np

from compare.util.errors import CompareError

__all__ = ["DISPLAY_OUTPUT", "OUTPUT_KEY", "is_display", "NOTE_KINDS", "UNITS", "UNIT_PLURALS", "unit_word", "Checkpoint", "RenderContext", "Renderer", "RendererError", "Rendering", "check_layers",
           "check_renderer", "check_rendering", "doubling_steps"]

#: What a step may count.
#: What a renderer's step counts (:attr:`Renderer.unit`) → its plural, the word of a budget flag and of
#: metadata (``--frames``, ``"samples": 64``).
UNIT_PLURALS = {"spp": "spp", "frame": "frames", "sample": "samples"}
UNITS = tuple(UNIT_PLURALS)


#: The metadata key of a rendering whose images are not linear radiance, and its one value: display-encoded
#: values in [0, 1] (an engine's own tone mapping and sRGB transfer, 8-bit), which the suite measures with its
#: LDR metrics only (:func:`compare.metrics.images.compare_images` ``display``) and shows as they are.
OUTPUT_KEY = "output"
DISPLAY_OUTPUT = "display"


def is_display(metadata) -> bool:
    """Whether a rendering's (or a run record's) metadata says its images are display-encoded, not linear."""
    return isinstance(metadata, dict) and metadata.get(OUTPUT_KEY) == DISPLAY_OUTPUT


#: The kinds of :meth:`Renderer.notes` a report shows, and where.
NOTE_KINDS = {"first_image": "how the first checkpoint was made (the report's first-frame table)"}


def unit_word(text: str) -> str | None:
    """The unit a word names, singular or plural (``"frames"`` → ``"frame"``); None for another word."""
    if not isinstance(text, str):
        return None
    if text in UNIT_PLURALS:
        return text
    return next((unit for unit, plural in UNIT_PLURALS.items() if plural == text), None)


class RendererError(CompareError, RuntimeError):
    """A renderer failed or produced something that is not a result (named in the message)."""


class Checkpoint(NamedTuple):
    """One checkpoint of any renderer: the image after ``step`` steps (frames, spp or samples) and the
    render seconds spent up to it."""

    step: int
    seconds: float
    image: np.ndarray


@dataclass
class Rendering:
    """What :meth:`Renderer.render` returns."""

    checkpoints: list[Checkpoint]
    setup_seconds: float = 0.0
    metadata: dict[str, Any] = field(default_factory=dict)
    #: The last checkpoint's image split by kind of light: layer name (compare.image.layers.LAYERS)
    #: → H×W×3 image. A layer left out is light the renderer does not render (zero).
    layers: dict[str, np.ndarray] = field(default_factory=dict)
    #: Per-pixel variance of the last checkpoint's image (H×W×3) and its degrees of freedom, where
    #: the renderer can estimate it (the Mitsuba reference: from its independent passes); else None.
    variance: tuple[np.ndarray, int] | None = None
    #: How a render of :meth:`Renderer.render_until` decided it had enough steps (JSON data: the criterion,
    #: its target, the estimate and steps reached, whether the target was met); None for a fixed budget.
    convergence: dict[str, Any] | None = None


#: Seconds a renderer without a limit of its own may take for one render (set-up and every checkpoint).
DEFAULT_TIMEOUT_S = 1800.0


class RenderContext:
    """What the units rendered in one process share: the run's settings and lazily made resources.

    Parameters
    ----------
    settings : RunSettings
        The run's settings (renderers read their own budgets and modes from it).
    cache_dir : path, None or False
        The reference cache (None: the default; False: none).
    progress : bool
        Whether renderers may show progress bars.
    timeout : float or None
        Seconds a render may take before it is stopped with one error (``--timeout``); None: each
        renderer's own limit (an external command's ``timeout``, a web page's :data:`DEFAULT_TIMEOUT_S`).
    workers : distributed.Client or None
        A dask cluster over which a renderer may spread the independent parts of one render (the
        reference's passes, :mod:`compare.mitsuba.cluster`), with the same pixels; None: every render
        stays in this process.

    A renderer's own settings are not here: they are the options of its spec.
    """

    def __init__(self, settings, *, cache_dir=None, progress: bool = False, timeout: float | None = None,
                 workers=None):
        self.settings = settings
        self.cache_dir = cache_dir
        self.progress = progress
        self.workers = workers
        if timeout is not None and not (math.isfinite(timeout) and timeout > 0):
            raise ValueError(f"timeout: expected a positive number of seconds, got {timeout!r}")
        self.timeout = timeout
        self._resources: dict[str, tuple[Any, Callable[[Any], None] | None]] = {}

    def resource(self, name: str, make: Callable[[], Any], release: Callable[[Any], None] | None = None) -> Any:
        """The shared resource ``name`` (e.g. an OpenGL context), made on first use, released by :meth:`close`."""
        if name not in self._resources:
            self._resources[name] = (make(), release)
        return self._resources[name][0]

    def provide(self, name: str, value: Any) -> None:
        """Lend a resource made elsewhere (not released by :meth:`close`)."""
        self._resources[name] = (value, None)

    def close(self) -> None:
        """Release every resource this context made."""
        for value, release in reversed(list(self._resources.values())):
            if release is not None and value is not None:
                release(value)
        self._resources.clear()

    def __enter__(self) -> "RenderContext":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def doubling_steps(total: int) -> list[int]:
    """1, 2, 4, …, up to ``total``, always ending with ``total`` (e.g. 100 → …, 64, 100)."""
    if total < 1:
        raise ValueError(f"expected a positive budget, got {total}")
    steps, k = [], 1
    while k < total:
        steps.append(k)
        k *= 2
    steps.append(total)
    return steps


class Renderer(abc.ABC):
    """Base class of every renderer: the core relies on what it declares, so subclassing is required
    (the registry refuses anything else, naming it).

    A subclass declares, as class attributes: ``unit``; :attr:`OPTIONS` (its ``:<option>`` words, parsed by
    :func:`compare.renderers.options.parse_spec`); :attr:`VARIANTS` (option sets ``compare renderers``
    lists); and :attr:`default_budget` with :attr:`budget_flag` where its budget is not the run's ``--frames`` /
    ``--spp``. It implements :meth:`render`; everything else has a default.
    """

    name: str = ""
    label: str = ""
    unit: str = "frame"
    variant_of: str | None = None
    variant_note: str = ""
    #: Whether the renderer decides its step count itself (e.g. a frame budget); its last
    #: checkpoint is then the steps it took, and checkpoints above it are not asked for.
    open_ended: bool = False
    #: Whether a worker process can rebuild this renderer from its name (an object made in a
    #: test or by ``compare measure`` cannot: such runs stay in this process).
    portable: bool = True
    #: ``:<option>`` words and what each changes (``word<unit>`` takes a number: ``budget<ms>``).
    OPTIONS: ClassVar[dict[str, str]] = {}
    #: Specs (this family's name with options) that ``compare renderers`` lists beside the plain name.
    VARIANTS: ClassVar[tuple[str, ...]] = ()
    #: The budget when the run names none for this renderer: a number of steps, or ``"frames"`` /
    #: ``"spp"`` for the run's ``--frames`` / ``--spp``; and a ``compare run`` flag of its own that sets it.
    default_budget: ClassVar[int | str] = "frames"
    budget_flag: ClassVar[str | None] = None
    #: The ``compare render`` flag (``--spp``, ``--frames`` or ``--samples``) that sets a budget of its own.
    render_flag: ClassVar[str | None] = None
    #: Scene features it draws as they are, beyond area lights and opaque metallic-roughness materials
    #: (names of :class:`compare.scene.model.Features`): :meth:`prepare` adapts a scene's others.
    renders: ClassVar[frozenset[str]] = frozenset()
    #: Whether it draws the scene's rectangular area lights; one that does not (an engine without area
    #: lights) gets the scene without them, and :meth:`prepare` says so.
    area_lights: ClassVar[bool] = True

    @classmethod
    def from_spec(cls, spec: str) -> "Renderer":
        """The renderer of ``spec`` (``<name>[:<option>[+<option>]]``): ``cls(spec)``, or ``cls()`` for a class
        whose constructor takes no argument (it then declares no options); ValueError for a bad option."""
        import inspect

        from compare.renderers.options import parse_spec

        if not inspect.signature(cls).parameters:
            parse_spec(spec, cls.OPTIONS)  # a ':' is refused where no options are declared
            return cls()
        return cls(spec)  # type: ignore[call-arg]

    def available(self) -> tuple[bool, str]:
        """``(True, "")`` or ``(False, what is missing and how to install it)``."""
        return True, ""

    def steps(self, settings) -> int:
        """The budget of a run with ``settings`` (frames, spp or samples): :meth:`RunSettings.budget`."""
        return int(settings.budget(self))

    def checkpoints(self, steps: int) -> list[int]:
        """The steps to keep an image at, ascending, ending with ``steps``: 1, 2, 4, …, steps by default."""
        return doubling_steps(steps)

    def key(self, scene, settings) -> Any:
        """Every setting that changes this renderer's pixels (JSON data) besides its code, which
        :meth:`code_key` adds to every render's key."""
        return []

    def code_key(self) -> str | None:
        """Hash of the code that renders: the import closure of this class's module and the data files
        beside it (:func:`compare.util.code.code_fingerprint`); None for a class without a source file."""
        from compare.util.code import code_fingerprint

        try:
            return code_fingerprint(type(self).__module__)
        except (ModuleNotFoundError, ValueError, OSError, SyntaxError):
            return None

    def prepare(self, scene, coverage: dict[str, float] | None = None) -> tuple[Any, list[str]]:
        """The scene as this renderer gets it, and what that changed or left out, one phrase each (the
        run records them): without ``punctual_lights`` in :attr:`renders`, point and spot lights become
        stand-in squares and directional lights are left out; each material feature
        (:meth:`~compare.scene.model.Scene.material_features`) not in :attr:`renders` is said to be left
        out, with the share of the pixels its materials cover where ``coverage`` (material name → fraction
        of the pixels, :func:`compare.mitsuba.coverage.material_coverage`) is given; without
        ``hidden_background``, a scene whose environment is hidden behind the model
        (:attr:`~compare.scene.model.Scene.hides_background`) comes with it shown, and says so."""
        given, changed = (scene, []) if "punctual_lights" in self.renders else scene.with_punctual_as_area()
        if not self.area_lights and given.lights:
            changed.append(f"{len(given.lights)} area light(s) not rendered (neither their light nor their face)")
            given = given.without_area_lights()
        for feature, names in scene.material_features().items():
            if feature in self.renders:
                continue
            share = (f", {100 * sum(coverage.get(n, 0.0) for n in names):.0f} % of the pixels"
                     if coverage is not None else "")
            changed.append(f"{feature.replace('_', ' ')} not rendered ({len(names)} material(s){share})")
        if given.hides_background and "hidden_background" not in self.renders:
            # it gets the environment as a background, which it shows, rather than a scene it half honours
            changed.append("hidden background not rendered (the environment is seen where camera rays hit "
                           "nothing)")
            given = given.with_background()
        return given, changed

    def preflight(self, scene, context: RenderContext) -> None:
        """Refuse, before any work of a run, a scene this renderer cannot render here (e.g. a size
        beyond its memory), with an error naming the limit; default: nothing to check."""

    @abc.abstractmethod
    def render(self, scene, *, steps: int, checkpoints: list[int], seed: int, context: RenderContext) -> Rendering:
        """Render ``scene`` with ``seed``; a checkpoint at every step of ``checkpoints`` (the last is ``steps``)."""

    def render_until(self, scene, *, rule, seed: int, context: RenderContext) -> Rendering:
        """Render ``scene`` with ``seed`` until its own noise meets ``rule`` (a
        :class:`compare.image.convergence.StopRule`: at most ``rule.cap`` steps), for a ground truth of
        ``compare run --spp auto``: one checkpoint, the steps it stopped at, and :attr:`Rendering.convergence`
        saying how. Default: a :class:`RendererError`, since only a renderer made of independent passes can
        measure its own noise."""
        raise RendererError(f"renderer {self.name!r} cannot measure its own noise: --spp auto needs a ground "
                            "truth that renders independent passes (mitsuba), or give --spp a number")

    def render_layers(self, scene, *, steps: int, seed: int, context: RenderContext) -> dict[str, np.ndarray]:
        """Per-effect layers of a ``steps`` render made for them alone (for a ground truth whose
        :meth:`render` gives none); default: none."""
        return {}

    def material_coverage(self, scene) -> dict[str, float] | None:
        """Each material's share of ``scene``'s pixels (material name → fraction of the pixel centres whose
        camera ray first hits it), which a ground truth may offer so that a run can say how much of the image
        a renderer's left-out features cover; default: None (unknown)."""
        return None

    def limit_threads(self, threads: int) -> None:
        """Render with about ``threads`` CPU threads in this process (a worker of a pool that shares the
        machine with others); called before the first render; default: nothing to do."""

    def notes(self, metadata: dict) -> dict[str, str]:
        """What the report should say about a run of this renderer, by kind of :data:`NOTE_KINDS` (e.g.
        ``{"first_image": "drawn at 0.5× size"}``), from the run's metadata; default: nothing."""
        return {}

    def models(self, materials: str) -> bool:
        """Whether this renderer draws the scene's materials as the ground truth's material mode ``materials``
        models them (a run's measure stage then compares the two for likeness, :mod:`compare.run.likeness`);
        default: False."""
        return False

    def facts(self, metadata: dict) -> dict[str, str]:
        """Facts about the machine this renderer's metadata reveals (e.g. ``gl_renderer``), for the report's
        machine table."""
        return {}


def check_renderer(r: object, where: str) -> Renderer:
    """``r`` as a renderer, or one :class:`RendererError` naming ``where`` and what is wrong."""
    if not isinstance(r, Renderer):
        what = r if isinstance(r, type) else type(r)
        raise RendererError(f"{where}: {what.__module__}.{what.__qualname__} is not a renderer: subclass "
                            "compare.renderers.base.Renderer (docs/renderers.md)")
    if not isinstance(r.name, str) or not r.name:
        raise RendererError(f"{where}: the renderer's name must be a non-empty string, got {r.name!r}")
    if r.unit not in UNITS:
        raise RendererError(f"{where}: unit {r.unit!r} is not one of {', '.join(UNITS)}")
    return r


def check_rendering(renderer: Renderer, rendering: Any, *, scene, checkpoints: list[int]) -> Rendering:
    """Check what a renderer returned against what was asked; return it with float32 images.

    Raises
    ------
    RendererError
        For a missing or extra checkpoint, times that are negative or go
        backwards, the wrong image size, NaN or infinite pixels.
    """
    name = renderer.name
    if not isinstance(rendering, Rendering):
        raise RendererError(f"renderer {name!r}: render() returned {type(rendering).__name__}, not a Rendering")
    w, h = scene.camera.resolution
    got = [int(c.step) for c in rendering.checkpoints]
    if renderer.open_ended and got:
        # It decides its step count itself (a frame budget): what was asked for below its end, and the end.
        checkpoints = [s for s in checkpoints if s < got[-1]] + [got[-1]]
    missing = [s for s in checkpoints if s not in got]
    if missing:
        raise RendererError(f"renderer {name!r}: no checkpoint at step {missing[0]} "
                            f"(asked for {checkpoints}, got {got})")
    if got != sorted(set(got)):
        raise RendererError(f"renderer {name!r}: checkpoints are not in ascending order: {got}")
    if not (isinstance(rendering.setup_seconds, (int, float)) and math.isfinite(rendering.setup_seconds)
            and rendering.setup_seconds >= 0):
        raise RendererError(f"renderer {name!r}: setup seconds {rendering.setup_seconds!r} is not a finite "
                            "non-negative number")
    out, last = [], 0.0
    for c in rendering.checkpoints:
        where = f"renderer {name!r} at step {c.step}"
        t = c.seconds
        if not (isinstance(t, (int, float)) and math.isfinite(t) and t >= 0):
            raise RendererError(f"{where}: seconds {t!r} is not a finite non-negative number")
        if t < last:
            raise RendererError(f"{where}: cumulative seconds go backwards ({t:g} after {last:g})")
        last = float(t)
        img = np.asarray(c.image)
        if img.ndim != 3 or img.shape[2] < 3:
            raise RendererError(f"{where}: expected an H×W×3 image, got shape {img.shape}")
        if img.shape[:2] != (h, w):
            raise RendererError(f"{where}: image is {img.shape[1]}x{img.shape[0]}, the scene is {w}x{h}")
        img = np.ascontiguousarray(img[..., :3], dtype=np.float32)
        bad = ~np.isfinite(img)
        if bad.any():
            y, x = np.argwhere(bad.any(axis=-1))[0]
            raise RendererError(f"{where}: {int(bad.any(axis=-1).sum())} pixel(s) are NaN or infinite "
                                f"(first at x={x}, y={y})")
        if is_display(rendering.metadata) and (img.min() < 0 or img.max() > 1):
            raise RendererError(f"{where}: display-encoded output must lie in [0, 1], got {img.min():g} … "
                                f"{img.max():g}")
        if int(c.step) in checkpoints:
            out.append(Checkpoint(int(c.step), float(t), img))
    variance = rendering.variance
    if variance is not None:
        var, dof = variance
        var = np.asarray(var)
        if var.shape[:2] != (h, w) or var.ndim != 3 or not np.all(np.isfinite(var)) or np.any(var < 0):
            raise RendererError(f"renderer {name!r}: the variance image must be finite, >= 0 and {w}x{h}")
        if isinstance(dof, bool) or not isinstance(dof, (int, np.integer)) or dof < 1:
            raise RendererError(f"renderer {name!r}: the variance's degrees of freedom must be >= 1, got {dof!r}")
        variance = (np.ascontiguousarray(var[..., :3], dtype=np.float32), int(dof))
    return Rendering(out, float(rendering.setup_seconds), dict(rendering.metadata or {}),
                     check_layers(name, rendering.layers, scene), variance,
                     None if rendering.convergence is None else dict(rendering.convergence))


def check_layers(name: str, layers: Any, scene) -> dict[str, np.ndarray]:
    """A renderer's layers as float32 images, each named, of the scene's size and finite."""
    from compare.image.layers import LAYERS

    if not layers:
        return {}
    if not isinstance(layers, dict):
        raise RendererError(f"renderer {name!r}: layers must be a dict of name → image, got {type(layers).__name__}")
    w, h = scene.camera.resolution
    out = {}
    for key, img in layers.items():
        if key not in LAYERS:
            raise RendererError(f"renderer {name!r}: unknown layer {key!r} (layers: {', '.join(LAYERS)})")
        img = np.asarray(img)
        if img.ndim != 3 or img.shape[:2] != (h, w) or img.shape[2] < 3:
            raise RendererError(f"renderer {name!r}: layer {key!r} has shape {img.shape}, expected ({h}, {w}, 3)")
        img = np.ascontiguousarray(img[..., :3], dtype=np.float32)
        if not np.all(np.isfinite(img)):
            raise RendererError(f"renderer {name!r}: layer {key!r} holds NaN or infinite values")
        out[key] = img
    return out
