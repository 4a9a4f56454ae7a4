"""The result file of ``compare run``: a versioned JSON schema and its dataclasses.

``results.json`` is what every later step reads: the HTML report
(:mod:`compare.report.html`), the plots (:mod:`compare.report.plots`) and the CI gate
(:mod:`compare.report.check`). It is written by :mod:`compare.run.runner` and can be read back
with :meth:`Results.load`. Every image path in it is relative to the folder
that holds the file, in POSIX form, so the folder can be moved or zipped.

Schema 1
--------
Published as a JSON Schema with the package (``compare/schemas/results.schema.json``)::

    {
      "schema": 1,
      "created": "2025-01-31T12:00:00Z",          # UTC, when the run finished
      "compare_version": "0.1.0",
      "settings": {                                 # RunSettings: what was asked for
        "frames": 128, "spp": 1024, "seed": 0,
        "renderers": ["mitsuba", "progressive"],
        "sizes": [[320, 240]],                      # [] = each scene's own resolution
        "exposure": 1.0, "tonemap": "aces", "materials": "shared",
        "budgets": {"cycles": 1024, "eevee": 64}, "likeness": true, "seeds": 1, "scene_spp": false,
        "ground_truth": "mitsuba",                  # the renderer every run is measured against
        "baseline": "progressive",                  # the ablation table's baseline
        "renderer_config": null                     # a renderer TOML file, or null
      },
      "machine": {                                  # where it ran (see Machine)
        "cpu": "AMD EPYC 7B13", "cores": 2, "platform": "Linux-6.1-x86_64",
        "gl_renderer": "llvmpipe (LLVM 15.0.6, 256 bits)" | null,
        "mitsuba_variant": "llvm_ad_rgb" | null,
        "versions": {"python": "3.11.2", "mitsuba": "3.9.1", "drjit": "1.5.0",
                     "moderngl": "5.13.0", "numpy": "2.4.6", "compare": "0.1.0"}
      },
      "scenes": [                                   # one entry per scene *and* size
        {
          "id": "cornell-box-1a2b3c4d-320x240",     # file-name-safe, unique
          "name": "Cornell box",                    # as written in the scene file
          "path": "scenes/cornell.toml", "hash": "<sha256>",
          "width": 320, "height": 240,
          "features": ["area_lights"],
          "omitted": {"<work left out>": "<why>"},  # Features.omitted()
          "reference": {                            # the ground truth
            "renderer": "mitsuba", "label": "Mitsuba path tracer (llvm_ad_rgb)",
            "unit": "spp", "spp": 1024, "seed": 0,   # spp: its budget, in its unit
            "seconds": 41.2, "load_seconds": 0.01, "variant": "llvm_ad_rgb",
            "image": "runs/<id>/reference/final.exr",
            "preview": "runs/<id>/reference/final.png",
            "flip_hdr_exposure": [-2.1, 4.3] | null, # HDR-FLIP's exposure range, fixed per ground truth
            "variance": "runs/<id>/reference/final-variance.exr" | null,  # per-pixel, from its passes
            "variance_dof": 21 | null
          },
          "noise_floor": {                          # or null (the ground-truth renderer not in the run)
            "method": "independent-full", "spp": 1024, "seeds": [0, 1],
            "metrics": {"flip": 0.02, "ssim": 0.99, ...},
            "mse_reference_estimate": 1.2e-05
          },
          "runs": [                                 # one per renderer (RendererRun)
            {
              "renderer": "progressive",            # the --renderers spec
              "label": "Progressive (radiometric)",
              "unit": "frame",                      # or "spp"
              "steps": 128,                         # frames or spp asked for
              "key": "<sha256 of every setting>",   # resume key
              "seconds": 3.1,                       # cumulative, last checkpoint
              "first_frame_seconds": 0.05,          # first checkpoint (1 frame / 1 spp)
              "setup_seconds": 0.4,                 # scene load / GPU upload, not in "seconds"
              "metadata": {"gl_renderer": "...", ...},   # str/int/float/bool/null only
              "image": "runs/<id>/progressive/final.exr",
              "preview": "runs/<id>/progressive/final.png",
              "maps": {"flip": "runs/<id>/progressive/maps/flip.png", ...},
              "layers": {"indirect_diffuse": {"flip": ..., "relmse": ..., "mean_ratio": ... | null,
                                              "share": ..., "rendered": false, "map": "runs/..png"}, ...},
                                                    # error per kind of light (compare/metrics/layers.py); {} if none
              "points": [                           # every checkpoint, ascending
                {"step": 1, "seconds": 0.05,
                 "metrics": {"mse": ..., "relmse": ..., "psnr": ... | null,
                             "ssim": ..., "flip": ...,
                             "flip_median": ..., "flip_p95": ...,  # FLIP's weighted median, 95th percentile
                             "flip_hdr": ... | null,   # last checkpoint only (cost); the reference's range
                             "mse_mean": ..., "variance": ..., "bias2": ..., "bias2_ci": ...,
                             "truth_variance": ..., "seeds": K,     # with settings.seeds >= 2 (compare/metrics/bias.py)
                             "relmse_mean": ..., "rel_variance": ..., "rel_bias2": ..., "rel_bias2_ci": ...,
                             "rel_truth_variance": ...},            # the same in relMSE units
                 "image": "runs/<id>/progressive/step-0001.exr",
                 "preview": "runs/<id>/progressive/step-0001.png"}
              ],
              "seed_runs": [                        # with settings.seeds >= 2: each independent run (SeedRun),
                {"seed": 0, "setup_seconds": 0.4,   # the first one's points repeated; [] otherwise
                 "image": "runs/<id>/progressive/step-0128.exr",     # its final image
                 "points": [{"step": 1, "seconds": 0.05, "metrics": {"relmse": ..., "flip": ..., ...}}]}
              ]
            }
          ]
        }
      ]
    }

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

import json
import math
import os
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

from compare.util.errors import CompareError
from compare.util.files import write_text_atomic
from compare.util.settings import DEFAULT_FRAMES, DEFAULT_SPP, documented, option

__all__ = [
    "SCHEMA",
    "Machine",
    "NoiseFloor",
    "Point",
    "Reference",
    "RendererRun",
    "Results",
    "RunSettings",
    "SceneResult",
    "SeedRun",
    "ResultsError",
    "check_json_finite",
    "metric_value",
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
            check_json_finite(v, f"{where}.{k}")
    elif isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            check_json_finite(v, f"{where}[{i}]")


def _require(d: Any, key: str, where: str, types: type | tuple[type, ...] | None = None) -> Any:
    if not isinstance(d, dict):
        raise ResultsError(f"{where}: expected an object, got {type(d).__name__}")
    if key not in d:
        raise ResultsError(f"{where}: missing field {key!r}")
    v = d[key]
    if types is not None and not isinstance(v, types):
        raise ResultsError(f"{where}.{key}: expected {types}, got {type(v).__name__} {v!r}")
    return v


def _seconds(d: Any, key: str, where: str, default: float | None = None) -> float:
    """A time of ``d``: a finite number of seconds >= 0 (a negative or infinite time would let an equal-time
    comparison or the gate's timing tests pass on nothing)."""
    if default is not None and isinstance(d, dict) and key not in d:
        return default
    v = _require(d, key, where)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
        raise ResultsError(f"{where}.{key}: expected a finite number of seconds >= 0, got {v!r}")
    return float(v)


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
    scene_spp: bool = option(False, "--spp auto: each scene's [render] reference_spp where it sets one, else spp")
    ground_truth: str = option("mitsuba", "the renderer every run is measured against (at its full budget, seed "
                                          "--seed); its own run, if listed, uses seed+1 and gives the noise floor")
    baseline: str = option("progressive", "the run the report's ablation table compares the variants of its "
                                          "family with")
    renderer_config: str | None = option(None, "a renderer file: [renderer.<name>] tables of external commands "
                                               "(docs/renderers.md)")

    def to_json(self) -> dict:
        """JSON-ready dict."""
        return asdict(self)

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
            cpu=str(_require(d, "cpu", "machine")),
            cores=int(_require(d, "cores", "machine")),
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
    def from_json(cls, d: dict, where: str = "point") -> "Point":
        """Inverse of :meth:`to_json`."""
        return cls(
            step=int(_require(d, "step", where, int)),
            seconds=_seconds(d, "seconds", where),
            metrics=dict(_require(d, "metrics", where, dict)),
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
    def from_json(cls, d: dict, where: str = "seed_run") -> "SeedRun":
        """Inverse of :meth:`to_json`."""
        points = []
        for i, p in enumerate(_require(d, "points", where, list)):
            w = f"{where}.points[{i}]"
            points.append({"step": int(_require(p, "step", w, int)),
                           "seconds": _seconds(p, "seconds", w),
                           "metrics": dict(_require(p, "metrics", w, dict))})
        return cls(seed=int(_require(d, "seed", where, int)),
                   setup_seconds=_seconds(d, "setup_seconds", where),
                   image=d.get("image"), points=points)


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
    def from_json(cls, d: dict, where: str = "run") -> "RendererRun":
        """Inverse of :meth:`to_json`."""
        points = _require(d, "points", where, list)
        return cls(
            renderer=str(_require(d, "renderer", where, str)),
            label=str(d.get("label") or d["renderer"]),
            unit=str(_require(d, "unit", where, str)),
            steps=int(_require(d, "steps", where, int)),
            key=str(d.get("key", "")),
            seconds=_seconds(d, "seconds", where),
            first_frame_seconds=_seconds(d, "first_frame_seconds", where),
            setup_seconds=_seconds(d, "setup_seconds", where, 0.0),
            metadata=dict(d.get("metadata") or {}),
            image=d.get("image"),
            preview=d.get("preview"),
            maps=dict(d.get("maps") or {}),
            points=[Point.from_json(p, f"{where}.points[{i}]") for i, p in enumerate(points)],
            variant_of=d.get("variant_of"),
            variant_note=str(d.get("variant_note") or ""),
            layers={str(k): dict(v) for k, v in (d.get("layers") or {}).items()},
            seed_runs=[SeedRun.from_json(r, f"{where}.seed_runs[{i}]")
                       for i, r in enumerate(d.get("seed_runs") or [])],
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

    def to_json(self) -> dict:
        """JSON-ready dict."""
        return asdict(self)

    @classmethod
    def from_json(cls, d: dict, where: str = "reference") -> "Reference":
        """Inverse of :meth:`to_json`."""
        return cls(
            spp=int(_require(d, "spp", where, int)),
            seed=int(_require(d, "seed", where, int)),
            seconds=_seconds(d, "seconds", where),
            variant=str(_require(d, "variant", where, str)),
            load_seconds=_seconds(d, "load_seconds", where, 0.0),
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
    def from_json(cls, d: dict, where: str = "noise_floor") -> "NoiseFloor":
        """Inverse of :meth:`to_json`."""
        return cls(
            method=str(_require(d, "method", where, str)),
            spp=int(_require(d, "spp", where, int)),
            seeds=[int(s) for s in _require(d, "seeds", where, list)],
            metrics=dict(_require(d, "metrics", where, dict)),
            mse_reference_estimate=float(_require(d, "mse_reference_estimate", where, (int, float))),
        )


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
    def from_json(cls, d: dict, where: str = "scene") -> "SceneResult":
        """Inverse of :meth:`to_json`."""
        nf = d.get("noise_floor")
        return cls(
            id=str(_require(d, "id", where, str)),
            name=str(_require(d, "name", where, str)),
            path=str(d.get("path", "")),
            hash=str(d.get("hash", "")),
            width=int(_require(d, "width", where, int)),
            height=int(_require(d, "height", where, int)),
            features=[str(f) for f in d.get("features") or []],
            omitted={str(k): str(v) for k, v in (d.get("omitted") or {}).items()},
            reference=Reference.from_json(_require(d, "reference", where, dict), f"{where}.reference"),
            noise_floor=None if nf is None else NoiseFloor.from_json(nf, f"{where}.noise_floor"),
            runs=[RendererRun.from_json(r, f"{where}.runs[{i}]")
                  for i, r in enumerate(_require(d, "runs", where, list))],
            likeness=None if d.get("likeness") is None else dict(d["likeness"]),
        )


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
        """Inverse of :meth:`to_json`.

        Raises
        ------
        ResultsError
            For another schema version or a malformed file (naming the field).
        """
        schema = _require(d, "schema", "results")
        if schema != SCHEMA:
            raise ResultsError(f"results: schema {schema!r} is not supported (this code reads schema {SCHEMA}); "
                               "rerun `compare run` with this version")
        check_json_finite(d)
        return cls(
            settings=RunSettings.from_json(_require(d, "settings", "results", dict)),
            machine=Machine.from_json(_require(d, "machine" if "machine" in d else "environment", "results", dict)),
            scenes=[SceneResult.from_json(s, f"results.scenes[{i}]")
                    for i, s in enumerate(_require(d, "scenes", "results", list))],
            created=str(d.get("created", "")),
            compare_version=str(d.get("compare_version", "")),
            schema=SCHEMA,
            failures=[{k: str(_require(f, k, f"results.failures[{i}]", str)) for k in ("scene", "renderer", "message")}
                      for i, f in enumerate(_require(d, "failures", "results", list) if "failures" in d else [])],
        )

    @classmethod
    def load(cls, path: str | os.PathLike) -> "Results":
        """Read ``results.json``.

        Raises
        ------
        ResultsError
            If the file is missing, not JSON (NaN tokens count as not JSON),
            or not schema 1.
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
            # a field of the wrong JSON type below the checked ones (e.g. a list for a number)
            raise ResultsError(f"{path}: malformed results ({type(e).__name__}: {e}); rerun `compare run`") from e


def _refuse_constant(name: str) -> float:
    raise ValueError(f"{name} is not allowed in results.json")
