"""One scene at one size through ``compare run``'s stages: render, then measure.

**Render** (:meth:`SceneJob.render`, what workers of a distributed run do):
the ground truth (the ``ground_truth`` renderer at its full budget, seed
``s``) and every renderer of the run, each into its own unit folder
``runs/<scene id>/<renderer>/``: one EXR (and PNG preview) per checkpoint and
``render.json`` (the render's key, cumulative seconds per checkpoint, set-up
seconds, metadata), written last, so it marks a finished render.

**Measure** (:meth:`SceneJob.measure`): reads those files and the ground
truth, computes every checkpoint's metrics and the final image's error maps,
and writes ``partial.json`` (the unit's :class:`~compare.report.results.RendererRun`,
keyed by the render's and the ground truth's keys). ``results.json`` is the
scenes' measured units together.

The run of the ground-truth renderer itself uses seed ``s + 1``: an
independent render of the same budget, whose error against the ground truth
falls as a Monte Carlo estimate should until it meets the **noise floor**,
its last point (:class:`compare.report.results.NoiseFloor`).

A rerun reuses a measured unit whose key is unchanged, and measures again a
rendered one whose render key is unchanged; keys hold every setting that
changes pixels (the renderer's :meth:`~compare.renderers.base.Renderer.key`,
the scene's content hash and size, budget, checkpoints, seed), the tone
mapping of the previews and, because timings belong to a machine, the CPU and
its core count.
"""

from __future__ import annotations

import json
import os
import platform
import re
import dataclasses
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable

import numpy as np
from tqdm.auto import tqdm

from compare import __version__
from compare.brdf import PRINCIPLED_MODES
from compare.util.code import code_fingerprint
from compare.util.errors import CompareError, ImageError
from compare.image.exr import read_exr, write_exr
from compare.util.files import sha256_bytes, write_text_atomic
from compare.renderers import RenderContext, Renderer, RendererError, check_layers, check_rendering
from compare.renderers.base import NOTE_KINDS, is_display
from compare.renderers.registry import Registry
from compare.renderers.registry import TRUTH_FOLDER
from compare.report.results import (NoiseFloor, Point, Reference, RendererRun, RunSettings, SceneResult, SeedRun,
                                    check_json_finite)
from compare.scene.loader import Scene

__all__ = ["SceneJob", "cpu_model", "exr_metadata", "flat_metadata", "scene_id"]



def unit_name(spec: str, *, truth: bool = False, replica: int = 0) -> str:
    """The name of one render of a run: the ground truth's, a renderer's, or its ``replica``-th further
    independent run's."""
    return TRUTH_FOLDER if truth else spec if not replica else f"{spec}-seed{replica}"


def unit_folder(name: str) -> str:
    """The folder of a render named ``name`` (:func:`unit_name`): "progressive:paper" -> "progressive-paper"."""
    return re.sub(r"[^a-z0-9_-]+", "-", name.lower())


def check_unit_folders(specs, *, seeds: int = 1) -> None:
    """Refuse, before any work, two renders of a run that would share a folder (the ground truth's, each
    renderer's and each further seed's): ValueError naming both."""
    seen: dict[str, tuple] = {unit_folder(TRUTH_FOLDER): (None, 0, "the ground truth")}
    for spec in dict.fromkeys(specs):
        for replica in range(max(int(seeds), 1)):
            folder = unit_folder(unit_name(spec, replica=replica))
            what = f"renderer {spec!r}" + (f" (its seed {replica + 1})" if replica else "")
            other = seen.setdefault(folder, (spec, replica, what))
            if other[:2] != (spec, replica):
                raise ValueError(f"{what} and {other[2]} would share the folder runs/<scene>/{folder}/: rename one")

def cpu_model() -> str:
    """The CPU's model name (timings belong to a machine)."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            for line in f:
                key, _, value = line.partition(":")
                # x86 says "model name"; some ARM kernels only "Hardware" or "Processor".
                if key.strip() in ("model name", "Hardware", "Processor", "cpu model") and value.strip():
                    return value.strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def scene_id(scene: Scene) -> str:
    """A file-name-safe, unique id for a scene at its resolution.

    The scene's name is user text (it may hold anything, even markup); only
    ``[a-z0-9-]`` of it survives, followed by 8 hex digits of the scene file's
    content hash (two files with the same name stay apart) and the size.
    """
    slug = re.sub(r"[^a-z0-9]+", "-", scene.name.lower()).strip("-")[:40] or "scene"
    w, h = scene.camera.resolution
    return f"{slug}-{scene.file_hash[:8]}-{w}x{h}"


#: Part of every measurement's key: bumped when what is measured changes (2: FLIP's weighted median
#: and 95th percentile; HDR-FLIP with the ground truth's exposure range; 3: errors per layer; 4: each
#: seed's timings and errors, for regression gates).
MEASURE_VERSION = 4


#: Seed offset between a renderer's independent runs (settings.seeds).
REPLICA_SEED_STRIDE = 7919


def _key(*parts: Any) -> str:
    return sha256_bytes(json.dumps(parts, sort_keys=True, default=str))


def notes(r: Renderer, meta: dict) -> dict[str, str]:
    """The renderer's notes on a run (:meth:`Renderer.notes`), checked against the kinds a report shows."""
    out = r.notes(meta)
    bad = [k for k in out if k not in NOTE_KINDS or not isinstance(out[k], str)]
    if bad:
        raise RendererError(f"{r.name}: notes {bad} are not text of a kind of {', '.join(NOTE_KINDS)}")
    return dict(out)


def flat_metadata(meta: dict) -> dict:
    """Keep JSON scalars, stringify the rest (results.json metadata is flat)."""
    out = {}
    for k, v in (meta or {}).items():
        if isinstance(v, np.generic):
            v = v.item()
        if v is None or isinstance(v, (str, bool, int, float)):
            out[str(k)] = v
        else:
            out[str(k)] = json.dumps(v, default=str) if isinstance(v, (list, tuple, dict)) else str(v)
    return out


def exr_metadata(meta: dict) -> dict:
    """EXR metadata takes str/int/float only (see compare.image.exr)."""
    out = {}
    for k, v in flat_metadata(meta).items():
        if isinstance(v, bool):
            out[k] = int(v)
        elif isinstance(v, (str, int, float)):
            out[k] = v
        elif v is not None:
            out[k] = str(v)
    return out


def _write_image(path: Path, image: np.ndarray, metadata: dict, *, exposure: float, tonemap: str) -> None:
    # a display-encoded image (is_display) is its own preview: the engine tone-mapped it
    """EXR + tone-mapped PNG preview. The EXR is float32: the measure stage reads it back, and
    measures exactly what the renderer returned (half floats would round it to ~3 digits)."""
    from compare.image.tonemap import write_png

    write_exr(path, image, metadata=exr_metadata(metadata), half=False)
    write_png(path.with_suffix(".png"), image, exposure=exposure, operator=tonemap, display=is_display(metadata))


def _paths_in(d: Any) -> Iterable[str]:
    """Every relative file path a stored record points at (image, preview, maps)."""
    if isinstance(d, dict):
        for k, v in d.items():
            if k == "metadata":
                continue  # renderer-reported facts, not files
            if k in ("image", "preview", "variance") and isinstance(v, str):
                yield v
            elif k in ("maps", "layers") and isinstance(v, dict):
                yield from (p for p in v.values() if isinstance(p, str))
            else:
                yield from _paths_in(v)
    elif isinstance(d, list):
        for v in d:
            yield from _paths_in(v)


@dataclass
class _Unit:
    """Where one (scene, size, renderer) unit keeps its files."""

    root: Path  # the output folder (results.json lives here)
    dir: Path

    def rel(self, path: Path) -> str:
        return path.relative_to(self.root).as_posix()

    def _load(self, name: str, key: str, field: str) -> dict | None:
        try:
            d = json.loads((self.dir / name).read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None
        if not isinstance(d, dict) or d.get("key") != key or not isinstance(d.get(field), dict):
            return None
        if any(not (self.root / rel).is_file() for rel in _paths_in(d[field])):
            return None
        return d[field]

    def _save(self, name: str, key: str, field: str, value: dict) -> None:
        check_json_finite(value, f"{self.dir.name} {field}")
        write_text_atomic(self.dir / name, json.dumps({"key": key, field: value}, indent=1, allow_nan=False))

    def rendered(self, key: str) -> dict | None:
        """The finished render with this key (``render.json``), if every file it names exists."""
        return self._load("render.json", key, "render")

    def save_render(self, key: str, record: dict) -> None:
        self._save("render.json", key, "render", record)

    def measured(self, key: str) -> dict | None:
        """The measured result with this key (``partial.json``), if every file it names exists."""
        return self._load("partial.json", key, "result")

    def save_result(self, key: str, result: dict) -> None:
        self._save("partial.json", key, "result", result)

    def likeness(self, key: str) -> dict | None:
        """The likeness measured with this key (``likeness.json``)."""
        return self._load("likeness.json", key, "likeness")

    def save_likeness(self, key: str, value: dict) -> None:
        self._save("likeness.json", key, "likeness", value)


class SceneJob:
    """The units of one scene at one size in one output folder.

    Parameters
    ----------
    settings : RunSettings
        The run's settings (renderers, roles, budgets, seeds, tone mapping).
    out : path
        The output folder.
    registry : Registry
        Where the renderers' names are looked up.
    context : RenderContext
        Shared by every unit this process renders (closed by its owner).
    fresh : bool
        Redo finished units instead of reusing them.
    """

    def __init__(self, settings: RunSettings, out: Path, *, registry: Registry, context: RenderContext,
                 fresh: bool = False, progress: bool = False, keep_going: bool = False):
        self.settings = settings
        #: Whether a unit that fails is recorded (:attr:`failures`) and the run goes on without it.
        self.keep_going = keep_going
        #: The failed units: {"scene": id, "renderer": spec, "message": the error}, in order.
        self.failures: list[dict] = []
        self.out = Path(out)
        self.registry = registry
        self.context = context
        self.fresh = fresh
        self.progress = progress
        self.machine = [cpu_model(), os.cpu_count()]
        self.facts: dict[str, str] = {}
        # (scene id, renderer, role) -> (key, record) of what this process rendered or found finished:
        # the measure stage does not compute the keys or read render.json again
        self._done: dict[tuple[str, str, bool, int], tuple[str, dict]] = {}

    def _unit(self, sid: str, name: str) -> _Unit:
        return _Unit(self.out, self.out / "runs" / sid / unit_folder(name))

    def settings_for(self, scene: Scene) -> RunSettings:
        """The run's settings for ``scene``: under ``spp_auto`` (``--spp auto``), ``spp`` is what its ground
        truth reached (rendered first if need be), so that the ground-truth renderer's own run, the noise
        floor, has the ground truth's budget."""
        s = self.settings
        if s.spp_auto:
            _, truth = self._render_unit(scene, scene_id(scene), s.ground_truth, truth=True)
            return dataclasses.replace(s, spp=int(truth["steps"]))
        return s

    def _plan(self, scene: Scene, spec: str, *, truth: bool, replica: int = 0) -> tuple[Renderer, int, list[int], int]:
        """(renderer, steps, checkpoints, seed) of the ground truth or of a run (``replica`` k >= 1:
        the k-th further independent run, for the bias/variance split). Under ``--spp auto`` the ground
        truth's steps are its cap (it stops where its noise is low enough)."""
        r = self.registry.get(spec)
        if truth:
            rule = self.settings.stop_rule()
            steps = rule.cap if rule is not None else int(r.steps(self.settings))
            return r, steps, [steps], self.settings.seed
        s = self.settings_for(scene)
        steps = int(r.steps(s))
        # the ground-truth renderer's own run is independent of the ground truth (noise floor)
        seed = s.seed + (1 if spec == s.ground_truth else 0) + REPLICA_SEED_STRIDE * replica
        return r, steps, list(r.checkpoints(steps)), seed

    def _replicas(self, spec: str) -> int:
        """Further independent runs of ``spec`` the settings ask for (none for an open-ended renderer,
        whose runs would not share their checkpoints)."""
        if self.settings.seeds < 2 or self.registry.get(spec).open_ended:
            return 0
        return int(self.settings.seeds) - 1

    def _coverage(self, scene) -> dict[str, float] | None:
        """Each material's share of the pixels, where the scene has material features a renderer may
        leave out (:meth:`Renderer.prepare` says how much of the image that is); once per scene."""
        if not scene.material_features():
            return None
        cache = self.__dict__.setdefault("_coverages", {})
        if scene.hash not in cache:  # offered by the ground truth through the protocol (None: it cannot say)
            try:
                cache[scene.hash] = self.registry.get(self.settings.ground_truth).material_coverage(scene)
            except (ImportError, RuntimeError, CompareError):  # its engine is not here: notes without pixels
                cache[scene.hash] = None
        return cache[scene.hash]

    def _render_key(self, scene: Scene, r: Renderer, steps: int, checkpoints: list[int], seed: int,
                    rule=None) -> str:
        s = self.settings
        # a stopping rule (--spp auto) is part of the ground truth's key; a fixed budget's key stays as it was
        stop = [rule.to_json()] if rule is not None else []
        return _key("render", r.name, r.key(scene, s), r.code_key(), scene.hash, steps, checkpoints, seed, s.exposure,
                    s.tonemap, self.machine, __version__, *stop)

    # -- stage 1: render ------------------------------------------------------------------------

    def _render_unit(self, scene: Scene, sid: str, spec: str, *, truth: bool, bar=None,
                     replica: int = 0) -> tuple[str, dict]:
        """Render one unit unless a finished render with the same key is there; returns (key, record)."""
        if (sid, spec, truth, replica) not in self._done:
            self._done[(sid, spec, truth, replica)] = self._find_or_render(scene, sid, spec, truth=truth, bar=bar,
                                                                           replica=replica)
        return self._done[(sid, spec, truth, replica)]

    def _find_or_render(self, scene: Scene, sid: str, spec: str, *, truth: bool, bar,
                        replica: int = 0) -> tuple[str, dict]:
        r, steps, cps, seed = self._plan(scene, spec, truth=truth, replica=replica)
        unit = self._unit(sid, unit_name(spec, truth=truth, replica=replica))
        rule = self.settings.stop_rule() if truth else None
        key = self._render_key(scene, r, steps, cps, seed, rule)
        if not self.fresh:
            stored = unit.rendered(key)
            if stored is not None:
                self._note_facts(r, stored.get("metadata") or {})
                if truth and "layers" not in stored:  # a ground truth from before per-effect layers
                    stored["layers"] = self._save_layers(unit, r.name, self._truth_layers(r, scene, int(stored["steps"]),
                                                                                          seed))
                    unit.save_render(key, stored)
                return key, stored
        if bar is not None:
            what = "ground truth" if truth else spec
            bar.set_postfix_str(f"{scene.name[:30]} {what} {steps} {r.unit}")
        given, changed = r.prepare(scene, self._coverage(scene))
        if rule is not None:  # --spp auto: the ground truth stops where its own noise is low enough
            raw = r.render_until(given, rule=rule, seed=seed, context=self.context)
            cps = [int(c.step) for c in raw.checkpoints[-1:]] or [steps]
            if cps[0] > rule.cap or raw.convergence is None:
                raise RendererError(f"renderer {r.name!r}: render_until() went past its cap of {rule.cap} or did "
                                    "not say how it stopped (Rendering.convergence)")
        else:
            raw = r.render(given, steps=steps, checkpoints=cps, seed=seed, context=self.context)
        rendering = check_rendering(r, raw, scene=scene, checkpoints=cps)
        meta = flat_metadata({**rendering.metadata, **({"scene_changed": "; ".join(changed)} if changed else {})})
        self._note_facts(r, meta)
        points = []
        for c in rendering.checkpoints:
            path = unit.dir / ("final.exr" if truth else f"step-{c.step:05d}.exr")
            _write_image(path, c.image, {**meta, "renderer": r.name, "role": "ground truth" if truth else "run",
                                         "step": c.step, "unit": r.unit, "seed": seed, "seconds": c.seconds,
                                         "scene_hash": scene.hash},
                         exposure=self.settings.exposure, tonemap=self.settings.tonemap)
            points.append({"step": c.step, "seconds": c.seconds, "image": unit.rel(path),
                           "preview": unit.rel(path.with_suffix(".png"))})
        layers = rendering.layers
        if truth and not layers:  # the per-effect ground truths, a render of their own, at the spp it reached
            layers = self._truth_layers(r, scene, int(points[-1]["step"]), seed)
        record = {"renderer": r.name, "label": r.label, "unit": r.unit, "steps": int(points[-1]["step"]),
                  "seed": seed, "setup_seconds": rendering.setup_seconds, "metadata": meta,
                  "variant_of": r.variant_of, "variant_note": r.variant_note, "notes": notes(r, meta), "points": points,
                  "layers": self._save_layers(unit, r.name, layers)}
        if truth and rendering.variance is not None:  # the ground truth's own noise, pixel by pixel
            var, dof = rendering.variance
            path = unit.dir / "final-variance.exr"
            write_exr(path, var, metadata={"renderer": r.name, "what": "per-pixel variance of final.exr's mean",
                                           "dof": int(dof)})
            record.update(variance=unit.rel(path), variance_dof=int(dof))
        if rendering.convergence is not None:
            record["convergence"] = rendering.convergence
        unit.save_render(key, record)
        return key, record

    def _truth_layers(self, r: Renderer, scene: Scene, steps: int, seed: int) -> dict[str, np.ndarray]:
        """The ground truth's per-effect layers, when its renderer makes them (``render_layers``)."""
        return check_layers(r.name, r.render_layers(scene, steps=steps, seed=seed, context=self.context), scene)

    def _save_layers(self, unit: _Unit, name: str, layers: dict[str, np.ndarray]) -> dict[str, str]:
        """Write a unit's layers (``layer-<name>.exr``); returns name → relative path."""
        out = {}
        for layer, image in layers.items():
            path = unit.dir / f"layer-{layer}.exr"
            write_exr(path, image, metadata={"renderer": name, "layer": layer})
            out[layer] = unit.rel(path)
        return out

    def _note_facts(self, r: Renderer, meta: dict) -> None:
        for k, v in r.facts(meta).items():
            self.facts.setdefault(k, v)

    def failed(self, sid: str, spec: str) -> bool:
        """Whether unit ``spec`` of scene ``sid`` failed in this run (and is left out)."""
        return any(f["scene"] == sid and f["renderer"] == spec for f in self.failures)

    def _attempt(self, sid: str, spec: str, work) -> bool:
        """Run ``work()``; with :attr:`keep_going`, a failure (any error of the suite's, or a renderer's own
        exception) is recorded for the unit instead of ending the run. True if it succeeded."""
        if self.failed(sid, spec):
            return False
        if not self.keep_going:
            work()
            return True
        try:
            work()
            return True
        except Exception as exc:  # noqa: BLE001 - a renderer's failure of any kind is the unit's, recorded
            message = str(exc) if isinstance(exc, CompareError) else f"{type(exc).__name__}: {exc}"
            self.failures.append({"scene": sid, "renderer": spec, "message": message})
            tqdm.write(f"compare: {sid}: {spec} failed, the run goes on without it: {message}", file=sys.stderr)
            return False

    def render(self, scene: Scene, bar=None) -> None:
        """Stage 1 for this scene: the ground truth and every renderer's checkpoints."""
        sid = scene_id(scene)
        truth_ok = self._attempt(sid, self.settings.ground_truth,
                                 lambda: self._render_unit(scene, sid, self.settings.ground_truth, truth=True, bar=bar))
        if bar is not None:
            bar.update(1)
        for spec in self.settings.renderers:
            if truth_ok:
                self._attempt(sid, spec, lambda spec=spec: [
                    self._render_unit(scene, sid, spec, truth=False, bar=bar, replica=k)
                    for k in range(self._replicas(spec) + 1)])
            if bar is not None:
                bar.update(1)

    # -- stage 2: measure -----------------------------------------------------------------------

    def measure(self, scene: Scene, bar=None) -> SceneResult | None:
        """Stage 2 for this scene (rendering first what stage 1 has not left behind); None when its ground
        truth failed in a run that keeps going (the failure is recorded)."""
        s = self.settings
        sid = scene_id(scene)
        found: list = []
        if not self._attempt(sid, s.ground_truth,
                             lambda: found.append(self._render_unit(scene, sid, s.ground_truth, truth=True))):
            return None
        gt_key, gt = found[0]
        final = gt["points"][-1]
        ref = Reference(spp=int(final["step"]), seed=int(gt["seed"]), seconds=float(final["seconds"]),
                        variant=str(gt["metadata"].get("variant", "")), load_seconds=float(gt["setup_seconds"]),
                        renderer=gt["renderer"], label=gt["label"], unit=gt["unit"], key=gt_key,
                        image=final["image"], preview=final["preview"], metadata=dict(gt["metadata"]),
                        variance=gt.get("variance"), variance_dof=gt.get("variance_dof"),
                        convergence=gt.get("convergence"))
        cached: dict[str, np.ndarray] = {}

        def truth() -> np.ndarray:  # read the ground truth at most once per scene
            if "gt" not in cached:
                from compare.metrics.images import hdr_exposure_range

                cached["gt"] = read_exr(self.out / ref.image)[0]
                # One HDR-FLIP exposure range per ground truth: every run's HDR-FLIP sweeps the same exposures.
                cached["hdr_range"] = hdr_exposure_range(cached["gt"])
                ref.flip_hdr_exposure = None if cached["hdr_range"] is None else list(cached["hdr_range"])
            return cached["gt"]

        def hdr_range():
            truth()
            return cached["hdr_range"]

        hdr_range()  # recorded with the reference even when every run's metrics are reused

        def truth_layers() -> dict[str, np.ndarray]:  # the per-effect ground truths, read once
            if "layers" not in cached:
                cached["layers"] = {k: read_exr(self.out / v)[0] for k, v in (gt.get("layers") or {}).items()}
            return cached["layers"]

        runs: list[RendererRun] = []
        noise_floor = None
        for spec in s.renderers:
            measured: list[RendererRun] = []

            def unit(spec=spec, measured=measured) -> None:
                key, record = self._render_unit(scene, sid, spec, truth=False)
                measured.append(self._measure_unit(scene, sid, spec, key, record, gt_key, truth, bar, hdr_range,
                                                   truth_layers))

            if not self._attempt(sid, spec, unit):
                continue
            run = measured[0]
            if spec == s.ground_truth:
                nf = run.final.metrics
                noise_floor = NoiseFloor(method="independent-full", spp=ref.spp, seeds=[ref.seed, ref.seed + 1],
                                         metrics=dict(nf), mse_reference_estimate=float(nf["mse"]) / 2.0)
            runs.append(run)
        if noise_floor is not None:  # the ground truth's own variance is no bias of the runs (compare.metrics.bias)
            for run in runs:
                for p in run.points:
                    if "bias2" in p.metrics:
                        rel_floor = noise_floor.metrics.get("relmse")
                        p.metrics["truth_variance"] = noise_floor.mse_reference_estimate
                        p.metrics["bias2"] -= noise_floor.mse_reference_estimate
                        if rel_floor is not None:
                            p.metrics["rel_truth_variance"] = rel_floor / 2.0
                            p.metrics["rel_bias2"] -= rel_floor / 2.0
        w, h = scene.camera.resolution
        feats = scene.features()
        likeness: list = []  # a measurement of its own: with --keep-going its failure is recorded, not fatal
        self._attempt(sid, "likeness", lambda: likeness.append(self._likeness(scene, sid, runs, bar)))
        return SceneResult(id=sid, name=scene.name, path=_display_path(scene.path), hash=scene.hash, width=w,
                           height=h, features=feats.names(), omitted=feats.omitted(), reference=ref,
                           noise_floor=noise_floor, runs=runs, likeness=likeness[0] if likeness else None)

    def _likeness(self, scene: Scene, sid: str, runs: list[RendererRun], bar) -> dict | None:
        """The reference's likeness to the first run whose renderer draws the materials as the reference's
        Principled mode models them (:mod:`compare.run.likeness`), measured once and kept in its unit."""
        s = self.settings_for(scene)
        if not s.likeness or s.materials not in PRINCIPLED_MODES:
            return None
        for run in runs:
            r = self.registry.get(run.renderer)
            if not r.models(s.materials):
                continue
            from compare.run.likeness import LIKENESS_VERSION, measure_likeness

            render_key, record = self._render_unit(scene, sid, run.renderer, truth=False)
            unit = self._unit(sid, run.renderer)
            # the likeness renders its own reference (compare.run.likeness): that code, not the run's
            # ground truth's, is what its figures depend on
            key = _key("likeness", render_key, code_fingerprint("compare.run.likeness"), s.materials,
                       s.exposure, s.tonemap, __version__, LIKENESS_VERSION)
            stored = None if self.fresh else unit.likeness(key)
            if stored is None:
                if bar is not None:
                    bar.set_postfix_str(f"{scene.name[:30]} likeness of the ground truth to {run.renderer}")
                first = read_exr(self.out / record["points"][-1]["image"])[0]
                stored = {"renderer": run.renderer, **measure_likeness(scene, r, record, first, materials=s.materials,
                                                                      context=self.context)}
                unit.save_likeness(key, stored)
            return stored
        return None

    def _measure_unit(self, scene: Scene, sid: str, spec: str, render_key: str, record: dict, gt_key: str,
                      truth, bar, hdr_range, truth_layers) -> RendererRun:
        s = self.settings
        unit = self._unit(sid, spec)
        replicas = [self._render_unit(scene, sid, spec, truth=False, replica=k)
                    for k in range(1, self._replicas(spec) + 1)]
        key = _key("measure", render_key, gt_key, s.exposure, s.tonemap, __version__, MEASURE_VERSION,
                   [k for k, _ in replicas])
        stored = None if self.fresh else unit.measured(key)
        if stored is not None:
            return RendererRun.from_json(stored)
        if bar is not None:
            bar.set_postfix_str(f"{scene.name[:30]} metrics of {spec}")
        gt = truth()
        points: list[Point] = []
        last = record["points"][-1]
        others = [{q["step"]: q["image"] for q in rec["points"]} for _, rec in replicas]
        # each independent run's timings and errors (the repeated measurements of a regression gate)
        seed_points: list[list[dict]] = [[] for _ in range(len(replicas) + 1)]
        for p in tqdm(record["points"], desc="metrics", unit="checkpoint", leave=False, disable=not self.progress):
            image = read_exr(self.out / p["image"])[0]
            what = f"{scene.name}: {spec} at {record['unit']} {p['step']}"
            display = is_display(record["metadata"])
            metrics = _measure(gt, image, s, what, final=p is last, hdr_range=hdr_range(), display=display)
            # the seeds' bias and variance are of radiance: a display-encoded run has none to give
            if others and not display and all(p["step"] in o for o in others):
                from compare.metrics.bias import bias_variance

                replica_images = [read_exr(self.out / o[p["step"]])[0] for o in others]
                seed_points[0].append({"step": int(p["step"]), "seconds": float(p["seconds"]),
                                       "metrics": {k: v for k, v in metrics.items() if k != "flip_hdr"}})
                for k, ((_, rec), img) in enumerate(zip(replicas, replica_images), start=1):
                    q = next(q for q in rec["points"] if q["step"] == p["step"])
                    m = _measure(gt, img, s, f"{what} (seed {rec['seed']})", final=False, hdr_range=hdr_range())
                    m.pop("flip_hdr", None)
                    seed_points[k].append({"step": int(p["step"]), "seconds": float(q["seconds"]), "metrics": m})
                stack = np.stack([image] + replica_images)
                b = bias_variance(stack, gt)
                rel = bias_variance(stack, gt, relative=True)
                metrics.update(mse_mean=b["mse"], variance=b["variance"], bias2=b["bias2"], bias2_ci=b["bias2_ci"],
                               relmse_mean=rel["mse"], rel_variance=rel["variance"], rel_bias2=rel["bias2"],
                               rel_bias2_ci=rel["bias2_ci"], seeds=b["seeds"])
            points.append(Point(int(p["step"]), float(p["seconds"]), metrics, p["image"], p["preview"]))
        run = RendererRun(
            renderer=spec, label=record["label"], unit=record["unit"], steps=int(record["steps"]), key=key,
            seconds=points[-1].seconds, first_frame_seconds=points[0].seconds,
            setup_seconds=float(record["setup_seconds"]), metadata=dict(record["metadata"]),
            image=points[-1].image, preview=points[-1].preview,
            maps=_maps(unit, gt, image, s, display=is_display(record["metadata"])), points=points,
            variant_of=record.get("variant_of"), variant_note=record.get("variant_note") or "",
            notes=dict(record.get("notes") or {}),
            layers=_layers(unit, truth_layers(), record, self.out, s, f"{scene.name}: {spec}"))
        if replicas:
            recs = [record] + [rec for _, rec in replicas]
            run.seed_runs = [SeedRun(seed=int(rec["seed"]), setup_seconds=float(rec["setup_seconds"]),
                                     image=rec["points"][-1]["image"], points=pts)
                             for rec, pts in zip(recs, seed_points)]
        unit.save_result(key, run.to_json())
        return run


def _measure(gt: np.ndarray, image: np.ndarray, settings: RunSettings, what: str, *, final: bool,
             hdr_range: tuple[float, float] | None = None, display: bool = False) -> dict:
    """Metrics of one checkpoint against the ground truth.

    HDR-FLIP runs several LDR-FLIP passes (one per exposure of its range) and
    costs more than all other metrics together, so it is computed for a
    run's final image only; intermediate checkpoints carry ``flip_hdr: null``.
    A display-encoded image (``display``) gets the LDR metrics only.
    """
    from compare.metrics.images import compare_images

    try:
        m = compare_images(gt, image, exposure=settings.exposure, operator=settings.tonemap, flip_hdr=final,
                           hdr_range=hdr_range, display=display)
    except ImageError as e:
        raise ImageError(f"{what}: {e}") from e
    m.setdefault("flip_hdr", None)
    check_json_finite(m, f"metrics of {what}")
    return m


def _maps(unit: _Unit, gt: np.ndarray, image: np.ndarray, settings: RunSettings, *,
          display: bool = False) -> dict[str, str]:
    from compare.image.maps import save_maps
    from compare.metrics.images import ERROR_MAP_RANGES, error_maps

    maps = error_maps(gt, image, exposure=settings.exposure, operator=settings.tonemap, display=display)
    written = save_maps(unit.dir / "maps", maps, ranges=ERROR_MAP_RANGES)
    return {name: unit.rel(path) for name, path in written.items()}


def _layers(unit: _Unit, truth: dict[str, np.ndarray], record: dict, out: Path, settings: RunSettings,
            what: str) -> dict[str, dict]:
    """Errors per kind of light of a run that gives layers, with a FLIP map per layer; {} otherwise."""
    from compare.metrics.layers import layer_metrics
    from compare.image.maps import save_maps
    from compare.metrics.images import ERROR_MAP_RANGES, flip

    paths = record.get("layers") or {}
    if not truth or not paths:
        return {}
    try:
        run = {k: read_exr(out / v)[0] for k, v in paths.items()}
        result = layer_metrics(truth, run, exposure=settings.exposure, operator=settings.tonemap)
        zero = np.zeros_like(next(iter(truth.values())))
        for name, entry in result.items():
            fmap = flip(truth[name], run.get(name, zero), exposure=settings.exposure, operator=settings.tonemap)[1]
            written = save_maps(unit.dir / "maps", {f"layer-{name}-flip": fmap}, ranges=ERROR_MAP_RANGES)
            entry["map"] = unit.rel(next(iter(written.values())))
    except ImageError as e:
        raise ImageError(f"{what} layers: {e}") from e
    check_json_finite(result, f"layer metrics of {what}")
    return result


def _display_path(path: Path) -> str:
    try:
        return Path(os.path.relpath(path)).as_posix()
    except ValueError:  # another drive on Windows
        return Path(path).as_posix()
