"""Command-line interface: the ``compare`` command and its subcommands.

``compare render | diff | run | measure | renderers | report | check | baseline | history | inspect | bench``.

Every user error (bad scene, bad image, missing system component) ends in one
line on stderr, ``compare: error: …``, and exit status 2, with nothing
half-written left behind.
"""

from __future__ import annotations

import argparse
import functools
import json
import sys
from pathlib import Path

from compare.brdf import CLOSED_FORM_MODES, MATERIAL_MODES
from compare.cli.argtypes import choices_help, parse_size, positive_float, positive_int, setting
from compare.util.errors import CompareError

__all__ = ["main", "parse_size", "positive_float", "positive_int"]


def _renderer_arg(text: str) -> str:
    """``--renderer``: a built-in's spec (e.g. a variant's options) is checked here, before any work;
    other names against the registry (which may need ``--renderer-config``) in the command."""
    from compare.renderers.registry import Registry

    registry = Registry()
    if text.partition(":")[0] in registry.builtins():
        try:
            registry.get(text)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
    return text


class UsageError(CompareError, ValueError):
    """A bad combination of command-line options."""


def _build_parser() -> argparse.ArgumentParser:
    from compare.renderers.registry import Registry
    from compare.report.results import RunSettings

    p = argparse.ArgumentParser(prog="compare", description=__doc__.splitlines()[0],
                                formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    r = sub.add_parser("render", help="render one scene with one renderer to an EXR (+ PNG preview)",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    r.add_argument("--scene", required=True, type=Path, help="scene file (TOML), or a glTF file (.gltf, .glb) by itself")
    r.add_argument("--renderer", default="mitsuba", type=_renderer_arg,
                   help="any renderer of `compare renderers`, NAME[:OPTION[+OPTION]]: "
                        + Registry().describe() + "; or one of --renderer-config")
    r.add_argument("--renderer-config", type=Path, default=None, metavar="TOML",
                   help="a renderer file with [renderer.<name>] tables (docs/renderers.md)")
    r.add_argument("--steps", type=positive_int, default=None,
                   help="the budget in the renderer's unit; default: --spp, --frames or --samples by its kind")
    opt = functools.partial(setting, RunSettings)
    r.add_argument("--spp", type=positive_int, **opt("spp"))
    r.add_argument("--frames", type=positive_int, **opt("frames"))
    r.add_argument("--samples", type=positive_int, default=64, help="samples of a renderer whose own budget it sets (`compare renderers`)")
    r.add_argument("--size", type=parse_size, default=None, help="WIDTHxHEIGHT; default: the scene's resolution")
    r.add_argument("--seed", type=int, default=0, help="random seed")
    modes = [m for m in MATERIAL_MODES if m not in CLOSED_FORM_MODES]
    r.add_argument("--materials", choices=modes, default=opt("materials")["default"],
                   help=choices_help(opt("materials")["help"], MATERIAL_MODES, modes))
    r.add_argument("--max-depth", type=int, default=None, help="path depth override (2 = direct light only)")
    r.add_argument("--variant", default=None,
                   help="Mitsuba variant (default: best available); the same as --renderer mitsuba:VARIANT")
    r.add_argument("--no-cache", action="store_true", help="do not read or write the reference cache")
    r.add_argument("--timeout", type=positive_float, default=None, metavar="SECONDS",
                   help="stop the render if it takes longer, with one message; default: the renderer's own limit")
    r.add_argument("--png", type=Path, default=None, help="PNG preview path (default: beside the EXR)")
    r.add_argument("--exposure", type=positive_float, default=1.0, help="exposure multiplier for the PNG preview")
    r.add_argument("--tonemap", default="aces", help="tone-mapping operator for the PNG preview")
    r.add_argument("-o", "--output", required=True, type=Path, help="output EXR path")
    r.set_defaults(func=cmd_render)

    d = sub.add_parser("diff", help="print error metrics of TEST against REF, or z-test whether they converge "
                                    "to one image (--ztest)",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    d.add_argument("reference", type=Path, help="reference EXR (with --ztest: or a folder of independent renders)")
    d.add_argument("test", type=Path, help="test EXR (with --ztest: or a folder of independent renders)")
    d.add_argument("--ztest", action="store_true",
                   help="per-pixel z-test (compare/metrics/ztest.py): exit status 0 when the two are consistent with one "
                        "image, 1 when not; each side's variance comes from a folder of independent renders or "
                        "--reference-variance / --test-variance")
    d.add_argument("--reference-variance", type=Path, default=None, metavar="EXR",
                   help="per-pixel variance of the reference's mean (--ztest)")
    d.add_argument("--test-variance", type=Path, default=None, metavar="EXR",
                   help="per-pixel variance of the test's mean (--ztest)")
    d.add_argument("--alpha", type=float, default=0.01, help="family-wise significance level of --ztest")
    d.add_argument("--block", type=positive_int, default=1,
                   help="--ztest on the means of BLOCK x BLOCK tiles instead of pixels (sees changes that cover "
                        "many pixels below the noise of one)")
    d.add_argument("--maps", type=Path, default=None, help="write error maps (PNG) into this folder")
    d.add_argument("--exposure", type=positive_float, default=1.0,
                   help="exposure before tone mapping (SSIM, LDR-FLIP)")
    d.add_argument("--tonemap", default="aces", help="tone-mapping operator for LDR metrics")
    d.add_argument("--json", action="store_true", help="print JSON instead of a table")
    d.set_defaults(func=cmd_diff)

    n = sub.add_parser("renderers", help="list the renderers: built-ins, plug-ins, a renderer file; which are "
                                         "available here and why the rest are not")
    n.add_argument("--renderer-config", type=Path, default=None, metavar="TOML", help="a renderer file")
    n.add_argument("--json", action="store_true", help="print JSON instead of a table")
    n.set_defaults(func=cmd_renderers)

    from compare.cli.baseline import add_baseline_parser
    from compare.cli.bench import add_bench_parser
    from compare.cli.check import add_check_parser
    from compare.cli.history import add_history_parser
    from compare.cli.inspect import add_inspect_parser
    from compare.cli.measure import add_measure_parser
    from compare.cli.report import add_report_parser
    from compare.cli.run import add_run_parser

    add_run_parser(sub)
    add_measure_parser(sub)
    add_report_parser(sub)
    add_check_parser(sub)
    add_baseline_parser(sub)
    add_history_parser(sub)
    add_inspect_parser(sub)
    add_bench_parser(sub)
    return p


def cmd_render(args: argparse.Namespace) -> int:
    """``compare render``: one scene, one renderer, one EXR with metadata, one PNG preview."""
    from compare import __version__
    from compare.util.errors import MissingComponentError
    from compare.image.exr import write_exr
    from compare.util.files import check_outputs
    from compare.renderers import RenderContext, check_rendering
    from compare.renderers.base import UNIT_PLURALS
    from compare.renderers.registry import Registry
    from compare.report.results import RunSettings
    from compare.scene.loader import load_scene
    from compare.image.tonemap import write_png

    registry = Registry(args.renderer_config)
    spec = args.renderer
    if args.variant:  # one more option of the spec: the renderer's own grammar accepts or names it
        spec += ("+" if ":" in spec else ":") + args.variant
    try:
        renderer = registry.get(spec)
    except ValueError as exc:
        if isinstance(exc, CompareError):
            raise
        raise UsageError(f"--renderer: {exc}") from None
    ok, why = renderer.available()
    if not ok:
        raise MissingComponentError(f"renderer {renderer.name!r} is not available here: {why}")
    scene = load_scene(args.scene)
    png = args.png or args.output.with_suffix(".png")
    check_outputs({"-o": args.output, "--png": png}, inputs=(args.scene, *scene.referenced_files),
                  suffixes={"-o": ".exr", "--png": ".png"})
    if not args.no_cache:
        from compare.util.cache import check_cache_dir

        check_cache_dir()
    if args.size:
        scene = scene.with_resolution(*args.size)
    if args.max_depth is not None:
        scene = scene.with_max_depth(args.max_depth)
    settings = RunSettings(frames=args.frames, spp=args.spp, seed=args.seed, materials=args.materials,
                           budgets={renderer.name: getattr(args, renderer.render_flag[2:])} if renderer.render_flag
                           else {}, likeness=False)
    steps = args.steps or renderer.steps(settings)
    given, changed = renderer.prepare(scene)
    for note in changed:
        print(f"{renderer.name}: {note}", file=sys.stderr)
    with RenderContext(settings, cache_dir=False if args.no_cache else None, progress=True,
                       timeout=args.timeout) as context:
        rendering = check_rendering(renderer, renderer.render(given, steps=steps, checkpoints=[steps], seed=args.seed,
                                                              context=context), scene=scene, checkpoints=[steps])
    last = rendering.checkpoints[-1]
    unit = UNIT_PLURALS[renderer.unit]
    from compare.run.scene_job import exr_metadata

    meta = {**rendering.metadata, "renderer": renderer.name, unit: last.step, "seed": args.seed,
            "seconds": last.seconds, "setup_seconds": rendering.setup_seconds, "scene": str(args.scene),
            "scene_hash": scene.hash, "package": __version__,
            **({"scene_changed": "; ".join(changed)} if changed else {})}
    write_exr(args.output, last.image, metadata=exr_metadata(meta))
    write_png(png, last.image, exposure=args.exposure, operator=args.tonemap)
    print(f"{args.output}: {scene.camera.width}x{scene.camera.height}, {renderer.label}, {last.step} {unit} in "
          f"{last.seconds:.2f} s (set-up {rendering.setup_seconds:.2f} s); preview {png}")
    return 0


def cmd_renderers(args: argparse.Namespace) -> int:
    """``compare renderers``: every renderer known here, available or not, and why."""
    from compare.renderers.registry import Registry

    rows = Registry(args.renderer_config).listing()
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    width = max(len(r["name"]) for r in rows)
    for r in rows:
        state = "available" if r["available"] else f"not available: {r['why']}"
        print(f"{r['name']:<{width}}  {r['unit'] or '-':<6}  {r['label'] or '-'}  [{r['source']}]  {state}")
    return 0


def cmd_diff(args: argparse.Namespace) -> int:
    """``compare diff``: metrics of TEST against REF, optionally with error maps."""
    from compare.image.exr import read_exr
    from compare.image.maps import save_maps
    from compare.metrics.images import ERROR_MAP_RANGES, compare_images, error_maps

    if args.ztest:
        return _ztest(args)
    if args.reference_variance or args.test_variance:
        raise UsageError("--reference-variance and --test-variance belong to --ztest")
    if args.maps:
        from compare.util.files import check_output_folder

        check_output_folder("--maps", args.maps)
    ref, _ = read_exr(args.reference)
    test, _ = read_exr(args.test)
    metrics = compare_images(ref, test, exposure=args.exposure, operator=args.tonemap)
    if args.maps:
        save_maps(args.maps, error_maps(ref, test, exposure=args.exposure, operator=args.tonemap),
                  ranges=ERROR_MAP_RANGES)
    if args.json:
        print(json.dumps(metrics, indent=2, sort_keys=True))
    else:
        width = max(len(k) for k in metrics)
        for k, v in metrics.items():
            print(f"{k:<{width}}  {v:.6g}" if isinstance(v, float) else f"{k:<{width}}  {v}")
    return 0


def _ztest(args: argparse.Namespace) -> int:
    from compare.util.errors import ImageError
    from compare.metrics.ztest import load_side, z_test

    if not 0 < args.alpha < 1:
        raise UsageError(f"--alpha: expected a level in (0, 1), got {args.alpha}")
    ref, ref_var, ref_dof = load_side(args.reference, args.reference_variance, "reference")
    test, test_var, test_dof = load_side(args.test, args.test_variance, "test")
    if ref.shape != test.shape:
        raise ImageError(f"{args.test}: {test.shape[1]}x{test.shape[0]}, but {args.reference} is "
                         f"{ref.shape[1]}x{ref.shape[0]}")
    if ref_var is None and test_var is None:
        raise UsageError("--ztest needs the variance of at least one side: give a folder of independent renders "
                         "or --reference-variance / --test-variance")
    try:
        res = z_test(ref, 0.0 if ref_var is None else ref_var, test, 0.0 if test_var is None else test_var,
                     alpha=args.alpha, block=args.block, dof_a=ref_dof, dof_b=test_dof)
    except ValueError as exc:  # e.g. a --block larger than the image
        raise UsageError(f"--ztest: {exc}") from None
    print(json.dumps(res.as_dict(), indent=2) if args.json else str(res))
    return 0 if res.passed else 1


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP: unwound like Ctrl-C, so that every ``finally`` runs (an external renderer's process
    group is killed, its job folder removed, nothing half-written kept)."""


def _terminate(signum, frame) -> None:
    raise Terminated(signum)


#: Seconds a SIGTERM or SIGHUP waits for the unwinding above before the process ends without it.
TERMINATE_GRACE_S = 10.0


def _watch_signals() -> None:
    """End the process on SIGTERM/SIGHUP even while the main thread is inside native code.

    Python runs a signal handler only when the main thread is back in the interpreter; a render blocked in
    a library (a Dr.Jit kernel, an OpenEXR read) would never see it. The C-level handler writes the signal
    to a wake-up pipe; this thread reads it, gives the main thread :data:`TERMINATE_GRACE_S` to unwind
    (its ``finally`` blocks kill child process groups and remove temporary folders), and then exits hard."""
    import os
    import signal
    import threading
    import time

    r, w = os.pipe()
    os.set_blocking(w, False)
    signal.set_wakeup_fd(w, warn_on_full_buffer=False)
    ends = {int(signal.SIGTERM), int(signal.SIGHUP)}

    def watch() -> None:
        while True:
            got = os.read(r, 64)
            for signum in got:
                if signum in ends:
                    time.sleep(TERMINATE_GRACE_S)
                    print(f"compare: terminated by signal {signum} while inside native code", file=sys.stderr,
                          flush=True)
                    os._exit(128 + signum)

    threading.Thread(target=watch, name="compare-signal-watch", daemon=True).start()


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``compare`` console script."""
    import signal
    import threading

    parser = _build_parser()
    args = parser.parse_args(argv)
    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGTERM, signal.SIGHUP):
            signal.signal(sig, _terminate)
        if argv is None:  # the console script's own process, not a caller's
            _watch_signals()
    try:
        return args.func(args)
    except CompareError as exc:
        from compare.util.text import terminal_text

        print(f"compare: error: {terminal_text(exc)}", file=sys.stderr)  # it may quote a file's strings
        return 2
    except KeyboardInterrupt:
        print("compare: interrupted; finished work is cached and will be reused", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
