"""``compare run``: its arguments and its command (the library: :mod:`compare.run.runner`)."""

from __future__ import annotations

import argparse
import functools
import sys
import warnings
from pathlib import Path

from compare.brdf import CLOSED_FORM_MODES, MATERIAL_MODES
from compare.cli.argtypes import choices_help, parse_sizes, positive_float, positive_int, setting
from compare.renderers.registry import Registry
from compare.report.results import RunSettings, ScenarioRecord, ScenarioSet
from compare.run.runner import run
from compare.util.settings import DEFAULT_SPP
from compare.util.errors import CompareError, SceneError


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
    which = p.add_mutually_exclusive_group()
    which.add_argument("--scenes", nargs="+", type=Path, default="scenes/cornell.toml", metavar="SCENE",
                       help="scene files (TOML), or glTF files (.gltf, .glb) by themselves")
    which.add_argument("--scenarios", type=Path, default=None, metavar="CONFIG",
                       help="a render-fidelity config.json (google/model-viewer's format): every scenario a scene "
                            "of this run, each skipping the renderers of its 'exclude' (docs/scenarios.md)")
    p.add_argument("--skip-unavailable", action="store_true",
                   help="with --scenarios: leave out the scenarios whose model or lighting file is not there or "
                        "whose lighting the suite does not read (an LDR image), naming them in one note, and "
                        "render the rest (default: such a scenario is an error before any rendering)")
    p.add_argument("--size", type=_sizes_arg, default=None, metavar="WxH[,WxH...]",
                   help="resolutions, comma-separated; default: each scene's own")
    opt = functools.partial(setting, RunSettings)
    p.add_argument("--frames", type=positive_int, **opt("frames"))
    p.add_argument("--spp", type=_spp_arg, default=DEFAULT_SPP,
                   help=opt("spp")["help"] + ", or auto: " + opt("spp_auto")["help"].removeprefix("--spp auto: "))
    p.add_argument("--spp-target", type=positive_float, metavar="RSE", **opt("spp_target"))
    p.add_argument("--spp-cap", type=positive_int, metavar="SPP", **opt("spp_cap"))
    registry = Registry()
    p.add_argument("--renderers", type=_renderer_list, default="mitsuba,progressive",
                   metavar="LIST", help="comma-separated renderer specs, NAME[:OPTION[+OPTION]]: "
                                        + registry.describe() + "; renderers of --renderer-config too; "
                                        "`compare renderers` lists them")
    p.add_argument("--renderer-config", type=Path, metavar="TOML", **opt("renderer_config"))
    p.add_argument("--ground-truth", metavar="RENDERER", **opt("ground_truth"))
    p.add_argument("--baseline", metavar="RENDERER", **opt("baseline"))
    for name in registry.builtins():  # each renderer's own budget flag, as it declares it
        cls = type(registry.get(name))
        if cls.budget_flag:
            p.add_argument(cls.budget_flag, type=positive_int, default=cls.default_budget, dest=f"budget_{name}", metavar="N",
                           help=f"{name}'s budget in {cls.unit} ({cls.__doc__.splitlines()[0].rstrip('.')})")
    p.add_argument("--seed", type=int, **opt("seed"))
    p.add_argument("--exposure", type=positive_float, **opt("exposure"))
    modes = [m for m in MATERIAL_MODES if m not in CLOSED_FORM_MODES]
    p.add_argument("--materials", choices=modes, default=opt("materials")["default"],
                   help=choices_help(opt("materials")["help"], MATERIAL_MODES, modes))
    p.add_argument("--no-likeness", dest="likeness", action="store_false",
                   help="skip this measurement: " + opt("likeness")["help"])
    p.add_argument("--seeds", type=positive_int, **opt("seeds"))
    p.add_argument("--timeout", type=positive_float, default=None, metavar="SECONDS",
                   help="stop a render that takes longer, with one message (its browser tab or process group "
                        "ended); default: each renderer's own limit (an external command's timeout, 1800 s for "
                        "the web engines)")
    p.add_argument("--keep-going", action=argparse.BooleanOptionalAction, default=None,
                   help="a unit that fails is recorded with its message in results.json and the report, and the "
                        "run goes on without it, exiting 1 at the end (default: so for a run of more than one "
                        "unit; --no-keep-going stops at the first failure)")
    p.add_argument("--fresh", action="store_true", help="redo finished units instead of reusing them (also into "
                                                         "a folder that holds the results of other settings)")
    p.add_argument("--update", action="store_true",
                   help="into a folder that holds the results of other settings: keep what still matches, redo "
                        "the rest, replace its results.json and report")
    p.add_argument("--no-report", action="store_true", help="write results.json only")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.add_argument("--features", action="store_true",
                   help="also measure which features each rasterizing renderer of the run draws (probe scenes, "
                        "python -m compare.bench.features) and show the table in the report's machine section")
    p.add_argument("--executor", default="local", metavar="WHERE",
                   help="local (a process pool sized to the machine), local:N, serial, or dask://HOST:PORT "
                        "(on a cluster of more workers than jobs, each job's reference spreads its passes over "
                        "all of them; see compare/run/executor.py for setting up workers)")
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
    settings = RunSettings(frames=args.frames, spp=DEFAULT_SPP if auto else args.spp, spp_auto=auto,
                           spp_target=args.spp_target, spp_cap=args.spp_cap,
                           seed=args.seed, renderers=renderers,
                           sizes=[list(s) for s in (args.size or [])], exposure=args.exposure, tonemap="aces",
                           materials=args.materials,
                           budgets={k[len("budget_"):]: v for k, v in vars(args).items() if k.startswith("budget_")},
                           likeness=args.likeness, seeds=args.seeds, ground_truth=args.ground_truth,
                           baseline=args.baseline,
                           renderer_config=config)
    exclude = scenario_set = None
    if args.skip_unavailable and args.scenarios is None:
        raise _UsageError("--skip-unavailable: applies to the scenarios of --scenarios only")
    if args.scenarios is not None:
        scenes, exclude, scenario_set = _scenario_scenes(args.scenarios, config,
                                                         skip_unavailable=args.skip_unavailable)
        out = args.output or Path("reports") / args.scenarios.stem
    else:
        scenes = args.scenes if isinstance(args.scenes, list) else [args.scenes]  # the default is one Path
        out = args.output or Path("reports") / scenes[0].stem
    try:
        res = run(scenes, out, settings, progress=not args.quiet, fresh=args.fresh, report=not args.no_report,
                  executor=args.executor, update=args.update, keep_going=args.keep_going, timeout=args.timeout,
                  exclude=exclude, scenarios=scenario_set)
    except ValueError as e:
        if isinstance(e, CompareError):
            raise
        raise _UsageError(str(e)) from e
    if args.features:
        _measure_features(res, renderers, out, report=not args.no_report, progress=not args.quiet)
    n = len(res.scenes)
    where = out / ("index.html" if not args.no_report else "results.json")
    print(f"{out / 'results.json'}: {n} scene/size combination{'s' if n != 1 else ''}; open {where}",
          file=sys.stdout)
    if res.failures:
        from compare.util.text import terminal_text

        print(f"compare: {len(res.failures)} unit(s) failed:", file=sys.stderr)
        for f in res.failures:
            print(f"  - {terminal_text(f['scene'])}: {terminal_text(f['renderer'])}: {terminal_text(f['message'])}",
                  file=sys.stderr)
        return 1
    return 0


def _scenario_scenes(path: Path, renderer_config: str | None, *,
                     skip_unavailable: bool = False) -> tuple[list, dict[str, tuple[str, ...]], ScenarioSet]:
    """The scenes of a render-fidelity config's scenarios, scene name → the suite's renderer names each
    excludes (model-viewer's names mapped; names the suite lacks dropped), and the record of every scenario
    for results.json. A scenario that cannot be rendered here (``Scenario.unavailable``: a file not there,
    LDR lighting) is one error naming it and how many others share its fate, or, with ``skip_unavailable``,
    left out with one note naming each (and recorded with its reason)."""
    from compare.scene.scenarios import load_scenarios

    scenarios = load_scenarios(path)
    reasons = [sc.unavailable() for sc in scenarios]
    lacking = [(sc, why) for sc, why in zip(scenarios, reasons) if why is not None]
    usable = [sc for sc, why in zip(scenarios, reasons) if why is None]
    if lacking and (not skip_unavailable or not usable):
        first, why = lacking[0]
        message = f"{first.where}: {why}"
        try:
            first.check_files()
        except SceneError as exc:  # its one message, with the path it looked for
            message = str(exc)
        if len(lacking) > 1:
            message += (f"; {len(lacking) - 1} other scenario(s) cannot be rendered here either "
                        f"(`compare inspect {path}` lists them)")
        if usable:
            message += f"; --skip-unavailable renders the {len(usable)} that can"
        raise SceneError(message)
    if lacking:
        warnings.warn(f"{path}: {len(lacking)} of {len(scenarios)} scenario(s) left out (--skip-unavailable; "
                      f"paths relative to {path.parent.resolve()}):\n"
                      + "\n".join(f"  - {sc.name}: {why}" for sc, why in lacking), stacklevel=2)
    known = Registry(renderer_config).names()
    scenes = [sc.scene() for sc in usable]  # every model read before any rendering
    record = ScenarioSet(file=str(path), scenarios=[
        ScenarioRecord(name=sc.name, model=sc.given[0], lighting=sc.given[1], exclude=list(sc.exclude),
                       excluded=list(sc.suite_excluded(known)), unavailable=why)
        for sc, why in zip(scenarios, reasons)])
    return scenes, {sc.name: sc.suite_excluded(known) for sc in usable if sc.suite_excluded(known)}, record


def _measure_features(res, renderers: list[str], out: Path, *, report: bool, progress: bool) -> None:
    """Measure the engine x feature table of the run's rasterizers (unit frame, not the ground truth) and
    record it as facts of the run's machine, one per renderer, in results.json and the report."""
    from compare.bench.features import FEATURES, measure_features

    registry = Registry(res.settings.renderer_config)
    specs = [s for s in renderers if s != res.settings.ground_truth and registry.get(s).unit == "frame"]
    measured = measure_features(specs, progress=(lambda m: print(f"features: {m}", file=sys.stderr))
                                if progress else None)
    for spec, row in measured.items():
        res.machine.facts[f"features of {spec}"] = "; ".join(
            f"{FEATURES[n].title} " + ("error" if "error" in m else f"{'yes' if m['drawn'] else 'no'} ({m['value']:.2f})")
            for n, m in row.items())
    res.save(out / "results.json")
    if report:
        from compare.report.html import build_report

        build_report(res, out)


class _UsageError(CompareError, ValueError):
    """A bad combination of ``compare run`` options."""
