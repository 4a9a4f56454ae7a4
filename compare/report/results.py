"""The result file of ``compare run``: a versioned JSON schema and its dataclasses.

``results.json`` is what every later step reads: the HTML report
(:mod:`compare.report.html`), the plots (:mod:`compare.report.plots`) and the CI gate
(:mod:`compare.report.check`). It is written by :mod:`compare.run.runner` and can be read back
with :meth:`Results.load`. Every image path in it is relative to the folder
that holds the file, in POSIX form, so the folder can be moved or zipped.

Schema 1
--------
The one definition is the JSON Schema published with the package,
``compare/schemas/results.schema.json``: :meth:`Results.from_json` (and so
:meth:`Results.load`) validates against it and refuses a file that does not conform
with one error naming the field (:func:`schema_problem`). The dataclasses below
mirror it, one per object.

Numbers are finite: :meth:`Results.to_json` raises :class:`ValueError` naming
the field if a NaN or infinity reaches it, because a report or a CI gate that
compares against NaN silently passes. The only non-numbers allowed for a
metric are the ``null`` values :func:`compare.metrics.images.compare_images`
documents (PSNR of identical images, HDR-FLIP of a black reference), and
``flip_hdr`` of intermediate checkpoints, which ``compare run`` leaves out
because HDR-FLIP costs more than every other metric together.

Error against time
------------------
:meth:`RendererRun.error_at` and :meth:`RendererRun.seconds_to` answer the
equal-time and equal-error questions by interpolating a run's checkpoints
linearly on log–log axes (error curves of Monte Carlo and progressive methods
are close to straight lines there), and never extrapolate: outside the
measured range they return ``None``.
"""

from __future__ import annotations

import functools
import json
import math
import os
from dataclasses import asdict, dataclass, field, fields
from importlib import resources
from pathlib import Path
from typing import Any

from compare.util.errors import CompareError
from compare.util.files import write_text_atomic
from compare.util.settings import DEFAULT_FRAMES, DEFAULT_SPP, DEFAULT_SPP_CAP, DEFAULT_SPP_TARGET, documented, option

__all__ = [
    "SCHEMA",
    "Machine",
    "NoiseFloor",
    "Point",
    "Reference",
    "RendererRun",
    "Results",
    "RunSettings",
    "ScenarioRecord",
    "ScenarioSet",
    "SceneResult",
    "SeedRun",
    "ResultsError",
    "check_json_finite",
    "metric_value",
    "schema_problem",
]

#: The schema version written into ``results.json``. Bump it when a field
#: changes meaning or disappears; readers refuse other versions.
SCHEMA = 1


class ResultsError(CompareError, ValueError):
    """``results.json`` is missing, malformed, or of another schema version."""


def check_json_finite(value: Any, where: str = "results") -> None:
    """Raise if any float inside ``value`` (dicts, lists, scalars) is NaN or infinite.

    Parameters
    ----------
    value
        A JSON-ready structure.
    where
        The name of ``value``, extended with keys and indices in the message.

    Raises
    ------
    ValueError
        Naming the first offending field, e.g.
        ``results.scenes[0].runs[1].points[3].metrics.flip is nan``.
    """
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError(f"{where} is {value!r}: NaN and infinities may not enter results.json "
                             "(fix the renderer or metric that produced it)")
    elif isinstance(value, dict):
        for k, v in value.items():
            check_json_finite(v, f"{where}.{k}" if where else str(k))
    elif isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            check_json_finite(v, f"{where}[{i}]")


#: The published JSON Schemas (package data in compare/schemas/): results.json, an external renderer's job.json
#: and a baseline's baseline.json. They refer to one another (baseline.json holds results.json's machine).
SCHEMAS = ("results", "job", "baseline")


@functools.cache
def _validator(name: str):
    # imported here: reading the schemas is the loaders' business, not that of every `import compare`
    import jsonschema
    from referencing import Registry, Resource

    folder = resources.files("compare") / "schemas"
    found = {n: json.loads((folder / f"{n}.schema.json").read_text(encoding="utf-8")) for n in SCHEMAS}
    registry = Registry().with_resources((s["$id"], Resource.from_contents(s)) for s in found.values())
    return jsonschema.Draft202012Validator(found[name], registry=registry)


def schema_problem(data: Any, name: str) -> str | None:
    """What is most wrong with ``data`` against ``compare/schemas/<name>.schema.json``, or None if it conforms.

    Parameters
    ----------
    data
        Parsed JSON.
    name
        One of :data:`SCHEMAS`.

    Returns
    -------
    str or None
        One problem (jsonschema's ``best_match`` of all of them): ``"<field>: <what is wrong>"``, e.g.
        ``"scenes[0].runs[1].points[3].metrics.flip: expected number or null, got \"x\""`` or
        ``"scenes[0]: missing field 'runs'"``; no field for the top level.
    """
    from jsonschema.exceptions import best_match

    error = best_match(_validator(name).iter_errors(data))
    if error is None:
        return None
    where = "".join(_step(k) for k in error.absolute_path).lstrip(".")
    problem = _problem(error)
    return f"{where}: {problem}" if where else problem


def _step(key: int | str) -> str:
    """One step of a field's path: ``[3]``, ``.flip``, or ``["a key"]`` for a key that is not a plain name."""
    if isinstance(key, int):
        return f"[{key}]"
    return f".{key}" if key and all(c.isascii() and (c.isalnum() or c in "_-") for c in key) else f"[{_show(key)}]"


_JSON_TYPES = {"object", "array", "string", "number", "integer", "boolean", "null"}
_BOUNDS = {"minimum": ">=", "exclusiveMinimum": ">", "maximum": "<=", "exclusiveMaximum": "<"}


def _problem(error) -> str:
    """One schema error in words; a subschema's ``title`` names what is expected where it has one."""
    kind, rule, value = error.validator, error.validator_value, error.instance
    title = error.schema.get("title") if isinstance(error.schema, dict) else None
    got = _show(value)
    if kind == "required":
        return f"missing field {next(k for k in rule if k not in value)!r}"
    if title and kind in ("type", "pattern", *_BOUNDS):
        return f"expected {title}, got {got}"
    if kind == "type":
        types = [rule] if isinstance(rule, str) else list(rule)
        return f"expected {' or '.join(t for t in types if t in _JSON_TYPES)}, got {got}"
    if kind in _BOUNDS:
        return f"expected a number {_BOUNDS[kind]} {rule}, got {got}"
    if kind == "const":
        return f"expected {_show(rule)}, got {got}"
    if kind == "enum":
        return f"expected one of {', '.join(_show(v) for v in rule)}, got {got}"
    if kind == "minItems":
        return f"expected at least {rule} item(s), got {len(value)}"
    if kind == "maxItems":
        return f"expected at most {rule} item(s), got {len(value)}"
    if kind == "pattern":
        return f"expected a string matching {rule!r}, got {got}"
    return error.message


def _show(value: Any, limit: int = 60) -> str:
    """``value`` as JSON text, cut to ``limit`` characters (a message is one line)."""
    text = json.dumps(value, ensure_ascii=False, allow_nan=True, default=str)
    return text if len(text) <= limit else text[: limit - 1] + "…"


def metric_value(metrics: dict[str, float | None], name: str) -> float | None:
    """Read a metric as an *error* (lower is better), or None if absent.

    ``"one_minus_ssim"`` is ``1 − ssim``; every other name is looked up as is.
    Used by the plots and the equal-time / equal-error tables so that every
    curve goes down as a renderer converges.
    """
    if name == "one_minus_ssim":
        v = metrics.get("ssim")
        return None if v is None else 1.0 - float(v)
    v = metrics.get(name)
    return None if v is None else float(v)


# --------------------------------------------------------------------------- dataclasses


@documented
@dataclass
class RunSettings:
    """What ``compare run`` was asked to do (everything but the output folder). The command line's options
    take their defaults and help texts from these fields."""

    frames: int = option(DEFAULT_FRAMES, "frames the progressive renderer accumulates (checkpoints at 1, 2, 4, ...)")
    spp: int = option(DEFAULT_SPP, "reference samples per pixel (ground truth and its convergence ladder)")
    seed: int = option(0, "seed of the ground truth (its convergence ladder uses seed+1)")
    renderers: list[str] = option(help="renderer specs, NAME[:OPTION[+OPTION]]", factory=lambda: ["mitsuba", "progressive"])
    sizes: list[list[int]] = option(help="resolutions; empty: each scene's own", factory=list)
    exposure: float = option(1.0, "linear exposure before ACES tone mapping (LDR metrics and previews)")
    tonemap: str = option("aces", "tone-mapping operator of the LDR metrics and previews (the report's "
                                  "interactive view implements aces only)")
    materials: str = option("shared", "reference material mode")
    budgets: dict[str, int] = option(help="budgets (steps) of single renderers by spec or name, e.g. "
                                          "{'cycles': 1024}; a renderer not named takes its own default",
                                     factory=dict)
    likeness: bool = option(True, "with --materials cycles (cycles-ggx), measure whether the ground truth is "
                                  "Cycles-like against the cycles (cycles:ggx) run; it renders Cycles once more and "
                                  "Mitsuba twice with as many samples as give it Cycles' noise, about three times "
                                  "the Cycles unit's cost")
    seeds: int = option(1, "independent runs of every renderer (different seeds); 2 or more split each "
                           "checkpoint's error into squared bias and variance (compare/metrics/bias.py), at that "
                           "many times the cost")
    spp_auto: bool = option(False, "--spp auto: the ground truth renders doubling passes until the 95th percentile "
                                   "over pixels of luminance's relative standard error, measured from the spread of "
                                   "its own passes, is at most the target (spp_target), or the cap (spp_cap) is "
                                   "reached; the run's other spp budgets (the noise floor's) are the spp it reached "
                                   "(compare/image/convergence.py)")
    spp_target: float = option(DEFAULT_SPP_TARGET, "with --spp auto: the relative standard error the 95th "
                                                   "percentile of the ground truth's pixels must reach")
    spp_cap: int = option(DEFAULT_SPP_CAP, "with --spp auto: the most samples per pixel the ground truth renders")
    ground_truth: str = option("mitsuba", "the renderer every run is measured against (at its full budget, seed "
                                          "--seed); its own run, if listed, uses seed+1 and gives the noise floor")
    baseline: str = option("progressive", "the run the report's ablation table compares the variants of its "
                                          "family with")
    renderer_config: str | None = option(None, "a renderer file: [renderer.<name>] tables of external commands "
                                               "(docs/renderers.md)")

    def to_json(self) -> dict:
        """JSON-ready dict."""
        return asdict(self)

    def stop_rule(self):
        """The ground truth's :class:`~compare.image.convergence.StopRule` under ``--spp auto``; else None."""
        if not self.spp_auto:
            return None
        from compare.image.convergence import StopRule

        return StopRule(target=float(self.spp_target), cap=int(self.spp_cap))

    def budget(self, renderer) -> int:
        """The steps of ``renderer`` in this run: :attr:`budgets` for its spec or name, else the renderer's
        ``default_budget``: a number, or ``"spp"`` / ``"frames"`` for this run's :attr:`spp` / :attr:`frames`."""
        name = renderer.name.partition(":")[0]
        for key in (renderer.name, name):
            if key in self.budgets:
                return int(self.budgets[key])
        default = renderer.default_budget
        if default == "spp":
            return int(self.spp)
        if default == "frames":
            return int(self.frames)
        return int(default)

    @classmethod
    def from_json(cls, d: dict) -> "RunSettings":
        """Inverse of :meth:`to_json`; unknown keys are ignored (forward compatibility)."""
        known = {f.name for f in fields(cls)}
        d = dict(d)
        legacy = {"cycles_spp": "cycles", "eevee_samples": "eevee"}  # schema 1 before per-renderer budgets
        if any(k in d for k in legacy):
            d["budgets"] = {**{legacy[k]: int(d[k]) for k in legacy if k in d}, **dict(d.get("budgets") or {})}
        return cls(**{k: v for k, v in d.items() if k in known})


@dataclass
class Machine:
    """The machine and software a run measured (timings mean nothing without it)."""

    cpu: str
    cores: int
    platform: str
    versions: dict[str, str | None] = field(default_factory=dict)
    facts: dict[str, str] = field(default_factory=dict)
    """What the renderers' metadata revealed about it (``Renderer.facts``: e.g. ``gl_renderer``,
    ``mitsuba_variant``, ``webgl_renderer``)."""

    def to_json(self) -> dict:
        """JSON-ready dict."""
        return asdict(self)

    @classmethod
    def from_json(cls, d: dict) -> "Machine":
        """Inverse of :meth:`to_json`; reads the fixed fact fields of files written before ``facts``."""
        facts = {k: str(d[k]) for k in ("gl_renderer", "mitsuba_variant", "webgl_renderer") if d.get(k)}
        facts.update({str(k): str(v) for k, v in dict(d.get("facts") or {}).items()})
        return cls(
            cpu=str(d["cpu"]),
            cores=int(d["cores"]),
            platform=str(d.get("platform", "")),
            versions=dict(d.get("versions") or {}),
            facts=facts,
        )


@dataclass
class Point:
    """One checkpoint of a renderer: its image after ``step`` frames/spp, and its error.

    Attributes
    ----------
    step : int
        Frames (progressive) or samples per pixel (reference) accumulated.
    seconds : float
        Cumulative render time up to this checkpoint.
    metrics : dict
        :func:`compare.metrics.images.compare_images` against the ground truth.
    image, preview : str or None
        The checkpoint's EXR and tone-mapped PNG, relative to ``results.json``.
    """

    step: int
    seconds: float
    metrics: dict[str, float | None]
    image: str | None = None
    preview: str | None = None

    def to_json(self) -> dict:
        """JSON-ready dict."""
        return asdict(self)

    @classmethod
    def from_json(cls, d: dict) -> "Point":
        """Inverse of :meth:`to_json`."""
        return cls(
            step=int(d["step"]),
            seconds=float(d["seconds"]),
            metrics=dict(d["metrics"]),
            image=d.get("image"),
            preview=d.get("preview"),
        )


@dataclass
class SeedRun:
    """One of a renderer's independent runs (``--seeds K``): its seed, timings and error at every checkpoint.

    The repeated timings and errors of a regression gate (:mod:`compare.report.gate`) come from these.

    Attributes
    ----------
    seed : int
        The seed the run rendered with.
    setup_seconds : float
        Its one-time set-up.
    image : str or None
        Its final image (EXR), relative to ``results.json``.
    points : list of dict
        ``{"step", "seconds", "metrics"}`` per checkpoint (metrics of
        :func:`compare.metrics.images.compare_images` without HDR-FLIP).
    """

    seed: int
    setup_seconds: float
    image: str | None
    points: list[dict[str, Any]] = field(default_factory=list)

    def to_json(self) -> dict:
        """JSON-ready dict."""
        return asdict(self)

    def at(self, step: int) -> dict | None:
        """The checkpoint ``step``, or None."""
        return next((p for p in self.points if p["step"] == step), None)

    @classmethod
    def from_json(cls, d: dict) -> "SeedRun":
        """Inverse of :meth:`to_json`."""
        points = [{"step": int(p["step"]), "seconds": float(p["seconds"]), "metrics": dict(p["metrics"])}
                  for p in d["points"]]
        return cls(seed=int(d["seed"]), setup_seconds=float(d["setup_seconds"]), image=d.get("image"),
                   points=points)


def _log(x: float) -> float:
    # Errors can be exactly 0 (identical images); a floor keeps the log finite
    # without moving any real measurement (metrics are far above 1e-30).
    return math.log(max(x, 1e-30))


@dataclass
class RendererRun:
    """Everything one renderer produced for one scene at one size.

    Attributes
    ----------
    renderer : str
        The renderer spec (``"mitsuba"``, ``"progressive"``, ``"progressive:paper"``).
    label : str
        Human-readable name for tables and legends.
    unit : str
        ``"spp"`` or ``"frame"``: what :attr:`Point.step` counts.
    steps : int
        The budget asked for (last checkpoint's step).
    key : str
        Hash of every setting that changes the result; a rerun reuses this run
        only when its key is the same.
    seconds : float
        Cumulative render time at the last checkpoint.
    first_frame_seconds : float
        Time to the first checkpoint (1 frame or 1 spp), what an interactive
        user waits for the first image.
    setup_seconds : float
        One-time cost outside ``seconds`` (Mitsuba scene load, GL resource creation).
    metadata : dict
        Renderer-reported facts (e.g. ``gl_renderer``), flat JSON scalars.
    image, preview : str or None
        Final image (EXR) and its PNG, relative to ``results.json``.
    maps : dict
        Error-map PNGs of the final image against the ground truth (``flip``,
        ``one_minus_ssim``, ``relmse``).
    points : list of Point
        Every checkpoint in ascending ``step``.
    variant_of : str or None
        The renderer this one is a variant of (e.g. ``progressive`` for ``progressive:paper``).
    variant_note : str
        What the variant changes, for the ablation table.
    layers : dict
        Error per kind of light of the final image (:func:`compare.metrics.layers.layer_metrics`):
        layer name → ``{"flip", "flip_median", "flip_p95", "relmse", "mean_ratio", "share",
        "rendered", "map"}``; empty when the renderer gives no layers (measured on the full
        image only) or the ground truth has none.
    seed_runs : list of SeedRun
        Every independent run (``settings.seeds`` >= 2), the first one included; empty with one seed
        (:meth:`per_seed` then gives the one run from :attr:`points`).
    """

    renderer: str
    label: str
    unit: str
    steps: int
    key: str
    seconds: float
    first_frame_seconds: float
    setup_seconds: float = 0.0
    metadata: dict[str, Any] = field(default_factory=dict)
    image: str | None = None
    preview: str | None = None
    maps: dict[str, str] = field(default_factory=dict)
    points: list[Point] = field(default_factory=list)
    variant_of: str | None = None
    variant_note: str = ""
    layers: dict[str, dict[str, Any]] = field(default_factory=dict)
    seed_runs: list[SeedRun] = field(default_factory=list)
    #: What the renderer says about this run for the report, by kind (compare.renderers.base.NOTE_KINDS).
    notes: dict[str, str] = field(default_factory=dict)

    @property
    def family(self) -> str:
        """The renderer this run is a variant of, or its own name."""
        return self.variant_of or self.renderer

    @property
    def final(self) -> Point:
        """The last checkpoint (the full budget)."""
        if not self.points:
            raise ResultsError(f"run {self.renderer!r} has no checkpoints")
        return self.points[-1]

    def per_seed(self) -> list[SeedRun]:
        """The independent runs: :attr:`seed_runs`, or the one run of :attr:`points` when there is one seed."""
        if self.seed_runs:
            return list(self.seed_runs)
        seed = self.metadata.get("seed")
        return [SeedRun(seed=int(seed) if isinstance(seed, int) else 0, setup_seconds=self.setup_seconds,
                        image=self.image, points=[{"step": p.step, "seconds": p.seconds, "metrics": dict(p.metrics)}
                                                  for p in self.points])]

    def curve(self, metric: str) -> list[tuple[float, float]]:
        """(seconds, error) pairs of ``metric`` (see :func:`metric_value`), skipping nulls."""
        out = []
        for p in self.points:
            v = metric_value(p.metrics, metric)
            if v is not None and p.seconds > 0:
                out.append((p.seconds, v))
        return out

    def error_at(self, seconds: float, metric: str, *, hold: bool = False) -> float | None:
        """The error this run had reached after ``seconds`` (equal-time comparison).

        Linear interpolation of log(error) over log(seconds) between the two
        checkpoints around ``seconds``. Between checkpoints the renderer's
        *displayed* image is of course the earlier checkpoint's; the
        interpolation answers "what would a run with this budget reach",
        which is what an equal-time comparison asks.

        Parameters
        ----------
        seconds : float
            The time budget.
        metric : str
            A metric name for :func:`metric_value`.
        hold : bool, optional
            After the last checkpoint, return the final error instead of None:
            a run that finished its budget early keeps showing its final image
            (this is not an extrapolation of the curve).

        Returns
        -------
        float or None
            None before the first checkpoint (no image yet) and, unless
            ``hold``, after the last one (not measured; no extrapolation).
        """
        pts = self.curve(metric)
        if not pts or seconds <= 0:
            return None
        if seconds > pts[-1][0]:
            return pts[-1][1] if hold else None
        if seconds < pts[0][0]:
            return None
        for (t0, e0), (t1, e1) in zip(pts, pts[1:]):
            if t0 <= seconds <= t1:
                if t1 == t0:
                    return e1
                f = (math.log(seconds) - math.log(t0)) / (math.log(t1) - math.log(t0))
                return math.exp(_log(e0) + f * (_log(e1) - _log(e0)))
        return pts[-1][1]  # seconds == the only checkpoint's time

    def seconds_to(self, error: float, metric: str) -> float | None:
        """Seconds this run needs to first reach ``error`` or less (equal-error comparison).

        Finds the first checkpoint at or below ``error`` and interpolates
        log(seconds) over log(error) between it and the checkpoint before.

        Returns
        -------
        float or None
            None if no checkpoint reaches ``error`` (the renderer's bias or
            budget keeps it above). If the first checkpoint already reaches
            it, that checkpoint's time (the run cannot show an image sooner).
        """
        pts = self.curve(metric)
        for i, (t1, e1) in enumerate(pts):
            if e1 <= error:
                if i == 0:
                    return t1
                t0, e0 = pts[i - 1]
                if _log(e0) == _log(e1):
                    return t1
                f = (_log(error) - _log(e0)) / (_log(e1) - _log(e0))
                return math.exp(math.log(t0) + f * (math.log(t1) - math.log(t0)))
        return None

    def to_json(self) -> dict:
        """JSON-ready dict."""
        d = asdict(self)
        d["points"] = [p.to_json() for p in self.points]
        d["seed_runs"] = [r.to_json() for r in self.seed_runs]
        return d

    @classmethod
    def from_json(cls, d: dict) -> "RendererRun":
        """Inverse of :meth:`to_json`."""
        return cls(
            renderer=d["renderer"],
            label=str(d.get("label") or d["renderer"]),
            unit=d["unit"],
            steps=int(d["steps"]),
            key=str(d.get("key", "")),
            seconds=float(d["seconds"]),
            first_frame_seconds=float(d["first_frame_seconds"]),
            setup_seconds=float(d.get("setup_seconds", 0.0)),
            metadata=dict(d.get("metadata") or {}),
            image=d.get("image"),
            preview=d.get("preview"),
            maps=dict(d.get("maps") or {}),
            points=[Point.from_json(p) for p in d["points"]],
            variant_of=d.get("variant_of"),
            variant_note=str(d.get("variant_note") or ""),
            layers={str(k): dict(v) for k, v in (d.get("layers") or {}).items()},
            seed_runs=[SeedRun.from_json(r) for r in d.get("seed_runs") or []],
            notes={str(k): str(v) for k, v in (d.get("notes") or {}).items()},
        )


@dataclass
class Reference:
    """The ground truth of one scene/size: the ground-truth renderer at its full budget.

    ``spp`` is that budget in the renderer's ``unit``; ``variant`` is the renderer's
    own variant (Mitsuba's), or empty."""

    spp: int
    seed: int
    seconds: float
    variant: str
    load_seconds: float = 0.0
    renderer: str = "mitsuba"
    key: str = ""
    image: str | None = None
    preview: str | None = None
    metadata: dict[str, Any] = field(default_factory=dict)
    label: str = ""
    unit: str = "spp"
    #: HDR-FLIP's exposure range [start, stop] for this ground truth, used by every run's
    #: HDR-FLIP (compare.metrics.images.hdr_exposure_range); None for a black ground truth.
    flip_hdr_exposure: list[float] | None = None
    #: Per-pixel variance of ``image`` (an EXR; from the spread of the renderer's independent passes)
    #: and its degrees of freedom, for ``compare diff --ztest``; None where the renderer gives none.
    variance: str | None = None
    variance_dof: int | None = None
    #: Under ``--spp auto``, how it decided it had enough samples (:meth:`compare.image.convergence.Stopping.record`:
    #: the criterion, its target, the estimate and spp reached, whether the target was met); None for a fixed budget.
    convergence: dict[str, Any] | None = None

    def to_json(self) -> dict:
        """JSON-ready dict."""
        return asdict(self)

    @classmethod
    def from_json(cls, d: dict) -> "Reference":
        """Inverse of :meth:`to_json`."""
        return cls(
            spp=int(d["spp"]),
            seed=int(d["seed"]),
            seconds=float(d["seconds"]),
            variant=d["variant"],
            load_seconds=float(d.get("load_seconds", 0.0)),
            renderer=str(d.get("renderer", "mitsuba")),
            key=str(d.get("key", "")),
            image=d.get("image"),
            preview=d.get("preview"),
            metadata=dict(d.get("metadata") or {}),
            label=str(d.get("label") or ""),
            unit=str(d.get("unit") or "spp"),
            flip_hdr_exposure=(None if d.get("flip_hdr_exposure") is None
                               else [float(x) for x in d["flip_hdr_exposure"]]),
            variance=d.get("variance"),
            variance_dof=None if d.get("variance_dof") is None else int(d["variance_dof"]),
            convergence=None if d.get("convergence") is None else dict(d["convergence"]),
        )


@dataclass
class NoiseFloor:
    """The error the reference has against itself: below it, differences are noise.

    Attributes
    ----------
    method : str
        ``"independent-full"``: metrics between the ground truth (seed ``s``)
        and a second, independent render with the same budget (seed ``s + 1``),
        which is also the last point of the reference's convergence curve.
    spp : int
        Budget of each of the two renders.
    seeds : list of int
        Their seeds.
    metrics : dict
        :func:`compare.metrics.images.compare_images` between the two.
    mse_reference_estimate : float
        ``metrics["mse"] / 2``: the expected MSE of the ground truth against
        the converged image. Two independent renders differ by noise of twice
        one render's variance, so a perfect (noise-free, unbiased) renderer
        would measure about half the floor's MSE and relMSE against this
        ground truth; for FLIP and SSIM, which are not additive, the floor is
        an upper bound of what "indistinguishable from the reference" means.
    """

    method: str
    spp: int
    seeds: list[int]
    metrics: dict[str, float | None]
    mse_reference_estimate: float

    def to_json(self) -> dict:
        """JSON-ready dict."""
        return asdict(self)

    @classmethod
    def from_json(cls, d: dict) -> "NoiseFloor":
        """Inverse of :meth:`to_json`."""
        return cls(method=d["method"], spp=int(d["spp"]), seeds=[int(s) for s in d["seeds"]],
                   metrics=dict(d["metrics"]), mse_reference_estimate=float(d["mse_reference_estimate"]))


@dataclass
class SceneResult:
    """One scene at one resolution: its ground truth, noise floor and renderer runs."""

    id: str
    name: str
    path: str
    hash: str
    width: int
    height: int
    features: list[str]
    omitted: dict[str, str]
    reference: Reference
    noise_floor: NoiseFloor | None = None
    runs: list[RendererRun] = field(default_factory=list)
    #: How like the ground truth is to the run of a renderer it models (compare.run.likeness), or None.
    likeness: dict[str, Any] | None = None

    @property
    def size(self) -> str:
        """``"WIDTHxHEIGHT"``."""
        return f"{self.width}x{self.height}"

    def run(self, renderer: str) -> RendererRun | None:
        """The run of ``renderer`` (spec as given to ``--renderers``), or None."""
        return next((r for r in self.runs if r.renderer == renderer), None)

    def to_json(self) -> dict:
        """JSON-ready dict."""
        return {
            "id": self.id, "name": self.name, "path": self.path, "hash": self.hash,
            "width": self.width, "height": self.height,
            "features": list(self.features), "omitted": dict(self.omitted),
            "reference": self.reference.to_json(),
            "noise_floor": None if self.noise_floor is None else self.noise_floor.to_json(),
            "runs": [r.to_json() for r in self.runs],
            **({"likeness": dict(self.likeness)} if self.likeness is not None else {}),
        }

    @classmethod
    def from_json(cls, d: dict) -> "SceneResult":
        """Inverse of :meth:`to_json`."""
        nf = d.get("noise_floor")
        return cls(
            id=d["id"],
            name=d["name"],
            path=str(d.get("path", "")),
            hash=str(d.get("hash", "")),
            width=int(d["width"]),
            height=int(d["height"]),
            features=list(d.get("features") or []),
            omitted=dict(d.get("omitted") or {}),
            reference=Reference.from_json(d["reference"]),
            noise_floor=None if nf is None else NoiseFloor.from_json(nf),
            runs=[RendererRun.from_json(r) for r in d["runs"]],
            likeness=None if d.get("likeness") is None else dict(d["likeness"]),
        )


@dataclass
class ScenarioRecord:
    """One scenario of the render-fidelity file a run came from (``compare run --scenarios``): the fields the
    report shows, and whether it was rendered.

    Attributes
    ----------
    name : str
        The scenario's name, which is the name of its scenes (one per size) in :attr:`Results.scenes`.
    model, lighting : str
        Its files, as the file writes them.
    exclude : list of str
        The renderer names of its ``exclude``, as the file gives them (model-viewer's names).
    excluded : list of str
        The suite's renderer names those are (:func:`compare.scene.scenarios.suite_renderers`): every spec of
        such a name skipped the scenario (the ground truth excepted).
    unavailable : str or None
        Why it was not rendered (``--skip-unavailable``: its model or lighting file not found, or its lighting
        a format the suite does not read), or None for a scenario of the run.
    scenes : list of str
        The ids of its scenes in the run (one per size; :attr:`SceneResult.id`, the key of
        :attr:`Results.failures` too); empty for a scenario not rendered.
    """

    name: str
    model: str = ""
    lighting: str = ""
    exclude: list[str] = field(default_factory=list)
    excluded: list[str] = field(default_factory=list)
    unavailable: str | None = None
    scenes: list[str] = field(default_factory=list)

    def to_json(self) -> dict:
        """JSON-ready dict."""
        return asdict(self)

    @classmethod
    def from_json(cls, d: dict) -> "ScenarioRecord":
        """Inverse of :meth:`to_json`."""
        return cls(name=str(d["name"]), model=str(d.get("model", "")), lighting=str(d.get("lighting", "")),
                   exclude=[str(n) for n in d.get("exclude") or []], excluded=[str(n) for n in d.get("excluded") or []],
                   unavailable=None if d.get("unavailable") is None else str(d["unavailable"]),
                   scenes=[str(s) for s in d.get("scenes") or []])


@dataclass
class ScenarioSet:
    """The render-fidelity file (model-viewer's ``config.json`` format) a run's scenes came from, with every
    scenario in the file's order, those left out too."""

    file: str
    """The file, as given to ``--scenarios``."""
    scenarios: list[ScenarioRecord] = field(default_factory=list)

    @property
    def left_out(self) -> list[ScenarioRecord]:
        """The scenarios not rendered, each with its reason."""
        return [s for s in self.scenarios if s.unavailable is not None]

    def to_json(self) -> dict:
        """JSON-ready dict."""
        return {"file": self.file, "scenarios": [s.to_json() for s in self.scenarios]}

    @classmethod
    def from_json(cls, d: dict) -> "ScenarioSet":
        """Inverse of :meth:`to_json`."""
        return cls(file=str(d["file"]), scenarios=[ScenarioRecord.from_json(s) for s in d["scenarios"]])


@dataclass
class Results:
    """The whole ``results.json``."""

    settings: RunSettings
    machine: Machine
    scenes: list[SceneResult] = field(default_factory=list)
    created: str = ""
    compare_version: str = ""
    schema: int = SCHEMA
    #: Units that failed in a run that kept going: {"scene": id, "renderer": spec, "message": the error}.
    failures: list[dict] = field(default_factory=list)
    #: The render-fidelity file of a run of ``compare run --scenarios`` (its scenarios, those left out with
    #: their reason); None for a run of scene files.
    scenarios: ScenarioSet | None = None

    def to_json(self) -> dict:
        """JSON-ready dict, checked for NaN/Inf.

        Raises
        ------
        ValueError
            If any number is NaN or infinite (naming the field).
        """
        d = {
            "schema": self.schema,
            "created": self.created,
            "compare_version": self.compare_version,
            "settings": self.settings.to_json(),
            "machine": self.machine.to_json(),
            "scenes": [s.to_json() for s in self.scenes],
        }
        if self.failures:
            d["failures"] = [dict(f) for f in self.failures]
        if self.scenarios is not None:
            d["scenarios"] = self.scenarios.to_json()
        check_json_finite(d)
        return d

    def dumps(self) -> str:
        """The JSON text (indented, stable key order, strict: no NaN/Infinity tokens)."""
        return json.dumps(self.to_json(), indent=1, allow_nan=False, ensure_ascii=False) + "\n"

    def save(self, path: str | os.PathLike) -> Path:
        """Write atomically to ``path``."""
        text = self.dumps()  # validate fully before touching the disk
        write_text_atomic(path, text)
        return Path(path)

    @classmethod
    def from_json(cls, d: dict) -> "Results":
        """Inverse of :meth:`to_json`, validated against ``compare/schemas/results.schema.json``.

        Raises
        ------
        ResultsError
            For another schema version, a field the schema refuses, or a NaN or infinity (each naming the
            field, e.g. ``scenes[0].runs[1].seconds: expected a finite number of seconds >= 0, got -1``).
        """
        if isinstance(d, dict) and "schema" in d and d["schema"] != SCHEMA:
            # before the schema's `const`: the version says what to do about it
            raise ResultsError(f"schema {d['schema']!r} is not supported (this code reads schema {SCHEMA}); "
                               "rerun `compare run` with this version")
        if isinstance(d, dict) and "machine" not in d and "environment" in d:
            d = {**d, "machine": d["environment"]}  # its name in files written before the schema was published
        problem = schema_problem(d, "results")
        if problem is not None:
            raise ResultsError(problem)
        try:
            check_json_finite(d, "")  # 1e999 parses as infinity; the schema cannot tell
        except ValueError as e:
            raise ResultsError(str(e)) from None
        return cls(
            settings=RunSettings.from_json(d["settings"]),
            machine=Machine.from_json(d["machine"]),
            scenes=[SceneResult.from_json(s) for s in d["scenes"]],
            created=d["created"],
            compare_version=d["compare_version"],
            schema=SCHEMA,
            failures=[{k: f[k] for k in ("scene", "renderer", "message")} for f in d.get("failures", [])],
            scenarios=None if d.get("scenarios") is None else ScenarioSet.from_json(d["scenarios"]),
        )

    @classmethod
    def load(cls, path: str | os.PathLike) -> "Results":
        """Read ``results.json``.

        Raises
        ------
        ResultsError
            If the file is missing, not JSON (NaN tokens count as not JSON), or
            does not conform to schema 1 (:meth:`from_json`): one line naming the file and the field,
            e.g. ``runs/results.json: scenes[0].runs[1].steps: expected an integer >= 1, got "x"``.
        """
        path = Path(path)
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            raise ResultsError(f"{path}: no such file (run `compare run` first)") from None
        except OSError as e:
            raise ResultsError(f"{path}: cannot read: {e}") from e
        try:
            d = json.loads(text, parse_constant=_refuse_constant)
        except (json.JSONDecodeError, ValueError) as e:
            raise ResultsError(f"{path}: not valid JSON: {e}") from e
        try:
            return cls.from_json(d)
        except ResultsError as e:
            raise ResultsError(f"{path}: {e}") from e
        except ValueError as e:
            raise ResultsError(f"{path}: {e}") from e
        except (TypeError, AttributeError, KeyError, IndexError, OverflowError) as e:
            # the schema validated the file: this is a reader that expects more than the schema says
            raise ResultsError(f"{path}: malformed results ({type(e).__name__}: {e}); rerun `compare run`") from e


def _refuse_constant(name: str) -> float:
    raise ValueError(f"{name} is not allowed in results.json")
