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

import argparse
import contextlib
import datetime
import os
import platform
import sys
from pathlib import Path
from typing import Iterable

from tqdm.auto import tqdm

from compare import __version__
from compare.cli.argtypes import parse_sizes, positive_float, positive_int
from compare.util.errors import CompareError, MissingComponentError
from compare.util.files import check_output_folder, folder_lock, remove_stale_parts
from compare.renderers import TABLE_1, RenderContext, Registry, doubling_steps
from compare.report.results import Environment, Results, RunSettings, SceneResult
from compare.scene.loader import Scene, load_scene
from compare.run.scene_job import SceneJob, cpu_model, scene_id
from compare.progressive.options import OPTIONS as VARIANT_OPTIONS

__all__ = [
    "add_run_parser",
    "checkpoint_steps",
    "collect_environment",
    "parse_renderers",
    "parse_sizes",
    "registry_for",
    "run",
    "scene_id",
]

#: What ``--renderers all`` means: the paper's Table 1 (and the three area models).
ALL_RENDERERS = TABLE_1
checkpoint_steps = doubling_steps


def registry_for(settings: RunSettings, renderers: Iterable = ()) -> Registry:
    """The registry of a run: built-ins, plug-ins, the run's renderer TOML file and ``renderers``."""
    return Registry(settings.renderer_config, renderers)


def parse_renderers(text: str | Iterable[str], registry: Registry | None = None) -> list[str]:
    """Validate a comma-separated renderer list against ``registry`` (default: built-ins and plug-ins)."""
    return (registry or Registry()).parse(text)


def _version(dist: str) -> str | None:
    from importlib import metadata

    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return None


def collect_environment(*, gl_renderer: str | None = None, mitsuba_variant: str | None = None,
                        webgl_renderer: str | None = None) -> Environment:
    """Describe this machine and the software versions (for the report's environment table)."""
    return Environment(
        cpu=cpu_model(),
        cores=os.cpu_count() or 1,
        platform=platform.platform(),
        gl_renderer=gl_renderer,
        mitsuba_variant=mitsuba_variant,
        webgl_renderer=webgl_renderer,
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
    if settings.cycles_spp < 1 or settings.eevee_samples < 1:
        raise ValueError(f"Blender samples must be positive, got cycles_spp={settings.cycles_spp}, "
                         f"eevee_samples={settings.eevee_samples}")
    registry.get(settings.ground_truth)
    missing = []
    for spec in dict.fromkeys([settings.ground_truth, *settings.renderers]):
        ok, why = registry.get(spec).available()
        if not ok:
            missing.append(f"{spec} ({why})")
    if missing:  # before hours of reference rendering
        raise MissingComponentError(f"renderer{'s' if len(missing) > 1 else ''} not available here: "
                                    + "; ".join(missing))


# --------------------------------------------------------------------------- public API


def run(scene_paths: Iterable[str | os.PathLike], out: str | os.PathLike, settings: RunSettings | None = None, *,
        progress: bool = True, cache_dir: str | os.PathLike | None | bool = None, fresh: bool = False,
        report: bool = True, gl_ctx=None, executor: str | object = "serial", renderers: Iterable = (),
        update: bool = False) -> Results:
    """Render, measure and report every scene at every size with every renderer.

    Parameters
    ----------
    scene_paths : iterable of path
        Scene files (TOML).
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
    paths = [Path(p) for p in scene_paths]
    if not paths:
        raise ValueError("no scene given")
    scenes = [load_scene(p) for p in paths]  # fail on a bad scene before rendering anything
    jobs: dict[str, Scene] = {}  # by id: a scene or size given twice is done once
    for sc in scenes:
        sizes = [tuple(sz) for sz in settings.sizes] or [sc.camera.resolution]
        for w, h in sizes:
            job = sc.with_resolution(w, h)
            jobs.setdefault(scene_id(job), job)

    with contextlib.ExitStack() as held:
        held.enter_context(folder_lock(out, "compare run"))
        _prepare_folder(out, settings, jobs, fresh=fresh, update=update, cache_dir=cache_dir)
        return _run_held(jobs, out, settings, registry, progress=progress, cache_dir=cache_dir, fresh=fresh,
                         report=report, gl_ctx=gl_ctx, executor=executor)


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
    except ResultsError:
        return  # unreadable: this run writes a good one
    changes = _settings_changes(old, settings, list(jobs))
    if changes:
        raise OutputError(f"{out}: holds the results of other settings ({'; '.join(changes)}); use --fresh to "
                          "redo it with these, --update to keep what still matches, or another folder")


def _run_held(jobs: dict, out: Path, settings: RunSettings, registry: Registry, *, progress: bool, cache_dir,
              fresh: bool, report: bool, gl_ctx, executor) -> Results:
    if isinstance(executor, str):
        from compare.run.executor import parse_executor

        kind, detail = parse_executor(executor)
        if kind == "serial" or (kind == "local" and (detail == 1 or len(jobs) == 1)) or not registry.portable:
            executor = "serial"  # one worker, or renderers only this process has: render here
    context = RenderContext(settings, cache_dir=cache_dir, progress=progress)
    if gl_ctx is not None:
        context.provide("gl", gl_ctx)
    facts: dict[str, str] = {}
    try:
        for sc in jobs.values():  # a size no renderer can render here is refused before any work
            for spec in dict.fromkeys([settings.ground_truth, *settings.renderers]):
                registry.get(spec).preflight(sc, context)
        scene_job = SceneJob(settings, out, registry=registry, context=context, fresh=fresh, progress=progress)
        units = len(jobs) * (1 + len(settings.renderers))
        if executor == "serial":
            with tqdm(total=units, desc="compare run", unit="unit", disable=not progress) as bar:
                for sc in jobs.values():
                    scene_job.render(sc, bar)
        else:
            from compare.run.executor import Job, execute

            job_list = [Job(scene_path=str(sc.path), size=tuple(sc.camera.resolution), scene_hash=sc.hash,
                            scene_id=sid, settings=settings.to_json(), out=str(out.resolve()),
                            cache_dir=str(cache_dir) if isinstance(cache_dir, os.PathLike) else cache_dir,
                            fresh=fresh)
                        for sid, sc in jobs.items()]
            with tqdm(total=len(job_list), desc="compare run", unit="job", disable=not progress) as bar:
                for _, res_i in execute(job_list, executor):
                    for k, v in res_i.facts.items():
                        facts.setdefault(k, v)
                    bar.update(1)
            scene_job.fresh = False  # the workers' fresh renders are this run's
        results: list[SceneResult] = []
        with tqdm(total=len(jobs), desc="metrics", unit="scene", disable=not progress) as bar:
            for sc in jobs.values():
                results.append(scene_job.measure(sc, bar))
                bar.update(1)
        facts = {**scene_job.facts, **facts}
    finally:
        context.close()

    res = Results(
        settings=settings,
        environment=collect_environment(gl_renderer=facts.get("gl_renderer"),
                                        mitsuba_variant=facts.get("mitsuba_variant"),
                                        webgl_renderer=facts.get("webgl_renderer")),
        scenes=results,
        created=datetime.datetime.now(datetime.timezone.utc).replace(microsecond=0).isoformat().replace("+00:00", "Z"),
        compare_version=__version__,
    )
    res.save(out / "results.json")
    if report:
        from compare.report.html import build_report

        build_report(res, out)
    return res


# --------------------------------------------------------------------------- CLI


def _sizes_arg(text: str) -> list[tuple[int, int]]:
    sizes = parse_sizes(text)
    if not sizes:
        raise argparse.ArgumentTypeError(f"expected sizes such as 320x240,1280x720, got {text!r}")
    return sizes


def _renderer_list(text: str) -> list[str]:
    """Split ``--renderers``; the names are checked against the registry (which may need
    ``--renderer-config``) in the command, before any work."""
    items = [s.strip() for s in text.split(",") if s.strip()]
    if not items:
        raise argparse.ArgumentTypeError("expected at least one renderer, e.g. mitsuba,progressive")
    return items


#: The ground truth's samples per pixel when neither --spp nor the scene says.
DEFAULT_SPP = 1024


def _spp_arg(text: str):
    """``--spp``: a positive integer, or ``auto``."""
    return "auto" if text == "auto" else positive_int(text)


def add_run_parser(subparsers) -> argparse.ArgumentParser:
    """Add ``compare run`` to an argparse subparsers object; returns the new parser."""
    p = subparsers.add_parser(
        "run", help="render scenes with every renderer, measure error against time, write results.json and a report",
        description="Render each scene at each size with the Mitsuba reference (ground truth, its convergence "
                    "ladder and noise floor) and the progressive rasterizer (checkpoints at frames 1, 2, 4, ...); "
                    "measure every checkpoint against the ground truth; write results.json and an HTML report. "
                    "Finished work in the output folder is reused when the settings match.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    # String defaults: argparse converts them with `type`, and --help prints them plainly.
    p.add_argument("--scenes", nargs="+", type=Path, default="scenes/cornell.toml", metavar="SCENE",
                   help="scene files (TOML)")
    p.add_argument("--size", type=_sizes_arg, default=None, metavar="WxH[,WxH...]",
                   help="resolutions, comma-separated; default: each scene's own")
    p.add_argument("--frames", type=positive_int, default=128, help="progressive frames (checkpoints at 1, 2, 4, ...)")
    p.add_argument("--spp", type=_spp_arg, default=1024,
                   help="reference samples per pixel (ground truth), or auto: each scene's [render] reference_spp "
                        "(what its ground truth needs to judge the built-in renderers), else 1024")
    p.add_argument("--renderers", type=_renderer_list, default="mitsuba,progressive",
                   metavar="LIST", help="comma-separated: mitsuba (reference convergence + noise floor), "
                                        "progressive, progressive:<option>[+<option>] with options " + ", ".join(VARIANT_OPTIONS)
                                        + " (e.g. progressive:paper,progressive:ltc,progressive:budget16), "
                                        "cycles and eevee (Blender, the blender extra; cycles:ggx, eevee:ggx set GGX in every Principled BSDF), renderers of installed plug-ins and of "
                                        "--renderer-config, or all (the paper's Table 1: " + ",".join(ALL_RENDERERS)
                                        + "); `compare renderers` lists them")
    p.add_argument("--renderer-config", type=Path, default=None, metavar="TOML",
                   help="a renderer file: [renderer.<name>] tables of external commands (docs/renderers.md)")
    p.add_argument("--ground-truth", default="mitsuba", metavar="RENDERER",
                   help="the renderer every run is measured against (at its full budget, seed --seed); its own "
                        "run, if listed, uses seed+1 and gives the noise floor")
    p.add_argument("--baseline", default="progressive", metavar="RENDERER",
                   help="the run the report's ablation table compares the variants of its family with")
    p.add_argument("--cycles-spp", type=positive_int, default=1024, help="Cycles samples per pixel (the paper: 1024)")
    p.add_argument("--eevee-samples", type=positive_int, default=64, help="EEVEE samples (the paper: 64)")
    p.add_argument("--seed", type=int, default=0, help="seed of the ground truth (its convergence ladder uses seed+1)")
    p.add_argument("--exposure", type=positive_float, default=1.0,
                   help="linear exposure before ACES tone mapping (LDR metrics and previews)")
    p.add_argument("--materials", choices=["shared", "cycles", "cycles-ggx"], default="shared",
                   help="reference material mode: shared (the rasterizer's BRDF), cycles (Blender's Principled "
                        "BSDF v2 with each material's distribution, Blender's default Multiscatter GGX; for "
                        "comparisons with cycles and eevee) or cycles-ggx (the same with GGX single scattering; "
                        "compare with cycles:ggx and eevee:ggx)")
    p.add_argument("--no-likeness", dest="likeness", action="store_false",
                   help="with --materials cycles (cycles-ggx), skip the Cycles-likeness measurement (it renders Cycles once more "
                        "and Mitsuba twice with as many samples as give it Cycles' noise: about three times the "
                        "Cycles unit's cost)")
    p.add_argument("--seeds", type=positive_int, default=1,
                   help="independent runs of every renderer (different seeds); 2 or more split each checkpoint's "
                        "error into squared bias and variance (compare/metrics/bias.py), at that many times the cost")
    p.add_argument("--fresh", action="store_true", help="redo finished units instead of reusing them (also into "
                                                         "a folder that holds the results of other settings)")
    p.add_argument("--update", action="store_true",
                   help="into a folder that holds the results of other settings: keep what still matches, redo "
                        "the rest, replace its results.json and report")
    p.add_argument("--no-report", action="store_true", help="write results.json only")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.add_argument("--executor", default="local", metavar="WHERE",
                   help="local (a process pool sized to the machine), local:N, serial, or dask://HOST:PORT "
                        "(see compare/run/executor.py for setting up workers)")
    p.add_argument("-o", "--output", type=Path, default=None,
                   help="output folder; default reports/<first scene's file name>")
    p.set_defaults(func=cmd_run)
    return p


def cmd_run(args: argparse.Namespace) -> int:
    """``compare run``; returns the exit status."""
    config = str(args.renderer_config) if args.renderer_config else None
    try:
        renderers = Registry(config).parse(args.renderers)
    except ValueError as e:
        if isinstance(e, CompareError):
            raise
        raise _UsageError(f"--renderers: {e}") from None
    auto = args.spp == "auto"
    settings = RunSettings(frames=args.frames, spp=DEFAULT_SPP if auto else args.spp, scene_spp=auto,
                           seed=args.seed, renderers=renderers,
                           sizes=[list(s) for s in (args.size or [])], exposure=args.exposure, tonemap="aces",
                           materials=args.materials, cycles_spp=args.cycles_spp, eevee_samples=args.eevee_samples,
                           likeness=args.likeness, seeds=args.seeds, ground_truth=args.ground_truth,
                           baseline=args.baseline,
                           renderer_config=config)
    scenes = args.scenes if isinstance(args.scenes, list) else [args.scenes]  # the default is one Path
    out = args.output or Path("reports") / scenes[0].stem
    try:
        res = run(scenes, out, settings, progress=not args.quiet, fresh=args.fresh, report=not args.no_report,
                  executor=args.executor, update=args.update)
    except ValueError as e:
        if isinstance(e, CompareError):
            raise
        raise _UsageError(str(e)) from e
    n = len(res.scenes)
    where = out / ("index.html" if not args.no_report else "results.json")
    print(f"{out / 'results.json'}: {n} scene/size combination{'s' if n != 1 else ''}; open {where}",
          file=sys.stdout)
    return 0


class _UsageError(CompareError, ValueError):
    """A bad combination of ``compare run`` options."""
