"""``compare run``: render every scene with every renderer, measure error against time.

For each scene and resolution (:mod:`compare.run.scene_job`, which both this
module and :mod:`compare.run.executor` use):

1. **render**: the ground truth (``--ground-truth``, Mitsuba by default, at its
   full budget, seed ``s``); the ground-truth renderer's own convergence run
   with the independent seed ``s + 1`` (its last point is the noise floor: the
   error between two independent full-budget renders); every other renderer of
   ``--renderers`` with checkpoints at steps 1, 2, 4, … (or the renderer's own
   ladder). Renderers come from the registry (:mod:`compare.renderers`):
   built-ins, installed plug-ins and ``--renderer-config`` TOML files;
2. **measure** every checkpoint against the ground truth;
3. write ``results.json`` (:mod:`compare.report.results`) and the HTML report
   (:mod:`compare.report.html`).

Each stage leaves files behind (checkpoint EXRs with ``render.json``, then
``partial.json`` per unit), written atomically, so an interrupted run resumes
where it stopped, and a changed setting redoes only what it changes.

Timings
-------
``seconds`` are the renderers' own cumulative render times at each checkpoint
(for Mitsuba, its per-pass times, recorded when a pass was first rendered, so
cached passes keep their cost). One-time set-up (scene load, GL resource
creation, shader compilation, process start) is reported separately as
``setup_seconds``. Metric computation and image writing happen outside the
timed regions.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime
import os
import platform
import sys
import time
from pathlib import Path
from typing import Iterable, Mapping

from tqdm.auto import tqdm

from compare import __version__
from compare.util.errors import CompareError, MissingComponentError
from compare.util.files import check_output_folder, folder_lock, remove_stale_parts
from compare.renderers import RenderContext
from compare.renderers.options import split_spec
from compare.renderers.registry import Registry
from compare.report.results import Machine, Results, RunSettings, ScenarioSet, SceneResult
from compare.scene.loader import Scene, load_scene
from compare.run.scene_job import SceneJob, cpu_model, scene_id

__all__ = ["collect_machine", "registry_for", "run", "scene_id"]


def registry_for(settings: RunSettings, renderers: Iterable = ()) -> Registry:
    """The registry of a run: built-ins, plug-ins, the run's renderer TOML file and ``renderers``."""
    return Registry(settings.renderer_config, renderers)


def _version(dist: str) -> str | None:
    from importlib import metadata

    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return None


def collect_machine(facts: dict[str, str] | None = None) -> Machine:
    """Describe this machine and the software versions, with what the renderers revealed of it (``facts``),
    for the report's machine table."""
    return Machine(
        cpu=cpu_model(),
        cores=os.cpu_count() or 1,
        platform=platform.platform(),
        facts=dict(facts or {}),
        versions={
            "python": platform.python_version(),
            "compare": __version__,
            "mitsuba": _version("mitsuba"),
            "drjit": _version("drjit"),
            "moderngl": _version("moderngl"),
            "numpy": _version("numpy"),
            "flip-evaluator": _version("flip-evaluator"),
        },
    )


def _check_settings(settings: RunSettings, registry: Registry) -> None:
    """Refuse a bad budget, an unknown or unavailable renderer before any work."""
    settings.renderers = registry.parse(settings.renderers)
    if settings.frames < 1 or settings.spp < 1:
        raise ValueError(f"frames and spp must be positive, got frames={settings.frames}, spp={settings.spp}")
    bad = {k: v for k, v in settings.budgets.items() if isinstance(v, bool) or not isinstance(v, int) or v < 1}
    if bad:
        raise ValueError(f"budgets must be positive integers, got {bad}")
    registry.get(settings.ground_truth)
    from compare.run.scene_job import check_unit_folders

    check_unit_folders([s for s in dict.fromkeys(settings.renderers) if s != settings.ground_truth],
                       seeds=settings.seeds)
    missing = []
    for spec in dict.fromkeys([settings.ground_truth, *settings.renderers]):
        ok, why = registry.get(spec).available()
        if not ok:
            missing.append(f"{spec} ({why})")
    if missing:  # before hours of reference rendering
        raise MissingComponentError(f"renderer{'s' if len(missing) > 1 else ''} not available here: "
                                    + "; ".join(missing))


# --------------------------------------------------------------------------- public API


def run(scene_paths: Iterable[str | os.PathLike | Scene], out: str | os.PathLike, settings: RunSettings | None = None,
        *, progress: bool = True, cache_dir: str | os.PathLike | None | bool = None, fresh: bool = False,
        report: bool = True, gl_ctx=None, executor: str | object = "serial", renderers: Iterable = (),
        update: bool = False, keep_going: bool | None = None, timeout: float | None = None,
        exclude: Mapping[str, Iterable[str]] | None = None, scenarios: ScenarioSet | None = None) -> Results:
    """Render, measure and report every scene at every size with every renderer.

    Parameters
    ----------
    scene_paths : iterable of path or Scene
        Scene files (TOML, or glTF by themselves), or scenes already loaded (e.g. the scenarios of
        :mod:`compare.scene.scenarios`); a run with loaded scenes renders in this process (a worker
        loads its scene from a file).
    out : path
        Output folder; receives ``results.json``, ``runs/`` (checkpoints, partial
        results, EXR and PNG images) and the report (``index.html`` and its files).
    settings : RunSettings, optional
        Budgets, seeds, renderers and their roles, sizes, tone mapping; defaults as ``compare run``.
    progress : bool, optional
        Show tqdm progress bars.
    cache_dir : path or None or False, optional
        The reference cache (None: ``$COMPARE_CACHE`` or ``~/.cache/compare``;
        False: no cache).
    fresh : bool, optional
        Ignore finished units in ``out`` and redo them (also into a folder holding other settings).
    update : bool, optional
        Into a folder holding results of other settings: keep what still matches, redo the rest
        (without it, or ``fresh``, such a folder is refused).
    report : bool, optional
        Also write the HTML report and plots.
    gl_ctx : moderngl.Context, optional
        An OpenGL context for the progressive renderer (not released here);
        default: one is created on first need and released at the end.
        Used in this process only.
    executor : str or distributed.Client, optional
        ``"serial"`` (this process), ``"local"``, ``"local:N"`` or
        ``"dask://HOST:PORT"``, see :mod:`compare.run.executor`; or a connected
        ``distributed.Client``. Workers render; this process measures.
    keep_going : bool, optional
        A unit that fails (a renderer's error, a time-out, NaN pixels) is recorded in ``results.failures``
        with its message and the run goes on without it (a scene whose ground truth fails is left out);
        default: so for a run of more than one unit. False: the first failure ends the run.
    timeout : float, optional
        Seconds one render may take before it is stopped with one error (its browser tab or process group
        ended); default: each renderer's own limit.
    exclude : mapping, optional
        Scene name → renderer names that skip that scene (a scenario's ``exclude``): every spec of
        those names (``threejs`` also drops ``threejs:shadows``) but the ground truth, which every
        scene needs.
    scenarios : ScenarioSet, optional
        The render-fidelity file the scenes came from (every scenario, those left out with their reason),
        recorded in ``results.json`` for the report's scenario table.
    renderers : iterable of Renderer, optional
        Renderer objects of this process (:mod:`compare.renderers.base`), found by
        their names in ``settings.renderers`` and ``settings.ground_truth``; a run
        with any stays in this process.

    Returns
    -------
    Results
        What was written to ``out/results.json``.

    Raises
    ------
    SceneError, ImageError, MissingComponentError, RendererError
        A bad scene, a renderer that failed or produced NaN/Inf, a missing component.
    """
    settings = settings or RunSettings()
    registry = registry_for(settings, renderers)
    _check_settings(settings, registry)
    out = Path(out)
    check_output_folder("-o", out)
    if cache_dir is not False:
        from compare.util.cache import check_cache_dir

        check_cache_dir(cache_dir)
    given = list(scene_paths)
    if not given:
        raise ValueError("no scene given")
    # fail on a bad scene before rendering anything
    scenes = [p if isinstance(p, Scene) else load_scene(Path(p)) for p in given]
    if any(isinstance(p, Scene) for p in given):
        executor = "serial"  # a worker would load the scene from its path, which holds no such scene
    jobs: dict[str, Scene] = {}  # by id: a scene or size given twice is done once
    for sc in scenes:
        sizes = [tuple(sz) for sz in settings.sizes] or [sc.camera.resolution]
        for w, h in sizes:
            job = sc.with_resolution(w, h)
            jobs.setdefault(scene_id(job), job)

    with contextlib.ExitStack() as held:
        held.enter_context(folder_lock(out, "compare run"))
        _prepare_folder(out, settings, jobs, fresh=fresh, update=update, cache_dir=cache_dir)
        plans = {sid: _renderers_for(settings, sc, exclude) for sid, sc in jobs.items()}
        if keep_going is None:
            keep_going = sum(1 + len(p) for p in plans.values()) > 1
        return _run_held(jobs, out, settings, registry, progress=progress, cache_dir=cache_dir, fresh=fresh,
                         report=report, gl_ctx=gl_ctx, executor=executor, keep_going=keep_going, timeout=timeout,
                         plans=plans, scenarios=scenarios)


def _renderers_for(settings: RunSettings, scene: Scene, exclude: Mapping[str, Iterable[str]] | None) -> list[str]:
    """The run's renderer specs for ``scene``, without those ``exclude`` names for it (never the ground truth:
    every scene is measured against it)."""
    names = set((exclude or {}).get(scene.name, ()))
    if not names:
        return list(settings.renderers)
    if split_spec(settings.ground_truth)[0] in names:
        import warnings

        warnings.warn(f"{scene.path}: {scene.name}: excludes {settings.ground_truth}, the ground truth of this run: "
                      "kept, every scene is measured against it", stacklevel=3)
    return [s for s in settings.renderers if s == settings.ground_truth or split_spec(s)[0] not in names]


def _settings_changes(old: Results, settings: RunSettings, ids: list[str]) -> list[str]:
    """What differs between the results a folder holds and a run's settings and scenes."""
    a, b = old.settings.to_json(), settings.to_json()
    changes = [f"{k} {a.get(k)!r} → {b.get(k)!r}" for k in b if a.get(k) != b.get(k)]
    old_ids = [s.id for s in old.scenes]
    if sorted(old_ids) != sorted(ids):
        changes.append(f"scenes {', '.join(old_ids) or 'none'} → {', '.join(ids)}")
    return changes


def _prepare_folder(out: Path, settings: RunSettings, jobs: dict, *, fresh: bool, update: bool, cache_dir) -> None:
    """In a held folder: remove what a killed run left half-written; refuse one that holds the
    results of other settings unless asked to replace (``fresh``) or update them."""
    import warnings

    from compare.util.errors import OutputError
    from compare.report.results import ResultsError

    gone = remove_stale_parts(out)
    if cache_dir is not False:
        from compare.util.cache import default_cache_dir

        # a shared cache: only what no write in progress can be (an hour old)
        gone += remove_stale_parts(Path(cache_dir) if cache_dir else default_cache_dir(), older_than=3600)
    if gone:
        warnings.warn(f"removed {len(gone)} half-written file(s) an interrupted run left behind "
                      f"(e.g. {gone[0]})", stacklevel=3)
    held = out / "results.json"
    if fresh or update or not held.is_file():
        return
    try:
        old = Results.load(held)
    except ResultsError as exc:  # another version's (a schema this one does not know) or damaged: keep it
        raise OutputError(f"{out}: holds a results.json this version cannot read ({exc}); use --fresh to replace "
                          "it, or another folder") from None
    changes = _settings_changes(old, settings, list(jobs))
    if changes:
        raise OutputError(f"{out}: holds the results of other settings ({'; '.join(changes)}); use --fresh to "
                          "redo it with these, --update to keep what still matches, or another folder")


def _run_held(jobs: dict, out: Path, settings: RunSettings, registry: Registry, *, progress: bool, cache_dir,
              fresh: bool, report: bool, gl_ctx, executor, keep_going: bool = False,
              timeout: float | None = None, plans: dict[str, list[str]] | None = None,
              scenarios: ScenarioSet | None = None) -> Results:
    if isinstance(executor, str):
        from compare.run.executor import parse_executor

        kind, detail = parse_executor(executor)
        if kind == "serial" or (kind == "local" and (detail == 1 or len(jobs) == 1)) or not registry.portable:
            executor = "serial"  # one worker, or renderers only this process has: render here
    context = RenderContext(settings, cache_dir=cache_dir, progress=progress, timeout=timeout)
    if gl_ctx is not None:
        context.provide("gl", gl_ctx)
    facts: dict[str, str] = {}
    plans = plans or {sid: list(settings.renderers) for sid in jobs}
    # One SceneJob per renderer list: a scene that excludes renderers is rendered and measured with the
    # run's settings less those renderers.
    scene_jobs: dict[tuple[str, ...], SceneJob] = {}

    def job_of(sid: str) -> SceneJob:
        key = tuple(plans[sid])
        if key not in scene_jobs:
            s = settings if list(key) == list(settings.renderers) else dataclasses.replace(settings,
                                                                                          renderers=list(key))
            scene_jobs[key] = SceneJob(s, out, registry=registry, context=context, fresh=fresh, progress=progress,
                                       keep_going=keep_going)
        return scene_jobs[key]

    try:
        for sid, sc in jobs.items():  # a size no renderer can render here is refused before any work
            for spec in dict.fromkeys([settings.ground_truth, *plans[sid]]):
                registry.get(spec).preflight(sc, context)
        units = sum(1 + len(plans[sid]) for sid in jobs)
        phases: dict[str, float] = {}  # seconds of each stage, said at the end (where the time goes)
        started = time.perf_counter()
        if executor == "serial":
            with tqdm(total=units, desc="compare run", unit="unit", disable=not progress) as bar:
                for sid, sc in jobs.items():
                    job_of(sid).render(sc, bar)
        else:
            from compare.run.executor import Job, execute

            job_list = [Job(scene_path=str(sc.path), size=tuple(sc.camera.resolution), scene_hash=sc.hash,
                            scene_id=sid, settings=job_of(sid).settings.to_json(), out=str(out.resolve()),
                            cache_dir=str(cache_dir) if isinstance(cache_dir, os.PathLike) else cache_dir,
                            fresh=fresh)
                        for sid, sc in jobs.items()]
            with tqdm(total=len(job_list), desc="compare run", unit="job", disable=not progress) as bar:
                try:
                    for _, res_i in execute(job_list, executor):
                        for k, v in res_i.facts.items():
                            facts.setdefault(k, v)
                        bar.update(1)
                except CompareError as exc:
                    if not keep_going:
                        raise
                    # the measure stage renders here what the workers left undone, unit by unit, and records
                    # each unit that fails
                    tqdm.write(f"compare: a worker failed ({exc}); the rest renders here", file=sys.stderr)
            for scene_job in scene_jobs.values():
                scene_job.fresh = False  # the workers' fresh renders are this run's
        phases["render"] = time.perf_counter() - started
        started = time.perf_counter()
        results: list[SceneResult] = []
        with tqdm(total=len(jobs), desc="metrics", unit="scene", disable=not progress) as bar:
            for sid, sc in jobs.items():
                measured = job_of(sid).measure(sc, bar)
                if measured is not None:
                    results.append(measured)
                bar.update(1)
        for scene_job in scene_jobs.values():
            facts = {**scene_job.facts, **facts}
        phases["measure"] = time.perf_counter() - started  # with what the render stage left to it
    finally:
        context.close()

    if scenarios is not None:  # each scenario's scenes (one per size), by the scene's name, which is the scenario's
        scenarios = dataclasses.replace(scenarios, scenarios=[
            dataclasses.replace(s, scenes=[sid for sid, sc in jobs.items() if sc.name == s.name])
            for s in scenarios.scenarios])
    res = Results(
        settings=settings,
        machine=collect_machine(facts),
        scenes=results,
        created=datetime.datetime.now(datetime.timezone.utc).replace(microsecond=0).isoformat().replace("+00:00", "Z"),
        compare_version=__version__,
        failures=[f for scene_job in scene_jobs.values() for f in scene_job.failures],
        scenarios=scenarios,
    )
    started = time.perf_counter()
    _save_with_report(res, out, report)
    phases["report" if report else "results.json"] = time.perf_counter() - started
    if progress:
        tqdm.write("compare run: " + ", ".join(f"{k} {v:.1f} s" for k, v in phases.items()), file=sys.stderr)
    return res


def _save_with_report(res: Results, out: Path, report: bool) -> None:
    """Write results.json and the report's index.html so that they are replaced together or not at all:
    both are written beside the old ones first (hidden part files), then renamed, which cannot run out of
    space; a write that fails (a full disk) leaves the previous pair as it was and says so."""
    from compare.util.errors import OutputError
    from compare.util.files import PART_MARK

    staged = {out / "results.json": out / f".results.json{PART_MARK}staged",
              out / "index.html": out / f".index.html{PART_MARK}staged"}
    try:
        res.save(staged[out / "results.json"])
        if report:
            from compare.report.html import build_report

            build_report(res, out, index_name=staged[out / "index.html"].name)
    except OSError as exc:
        for part in staged.values():
            part.unlink(missing_ok=True)
        raise OutputError(f"{out}: could not write the new results and report ({exc.strerror or exc}); "
                          "the previous results.json and index.html are as they were") from None
    if report:
        os.replace(staged[out / "index.html"], out / "index.html")
    os.replace(staged[out / "results.json"], out / "results.json")

