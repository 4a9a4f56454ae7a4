"""Command-line interface: ``compare render | diff | run | report | check | bench``.

Every user error (bad scene, bad image, missing system component) ends in one
line on stderr, ``compare: error: …``, and exit status 2, with nothing
half-written left behind.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .errors import CompareError
from .variants import OPTIONS as VARIANT_OPTIONS


def parse_size(text: str) -> tuple[int, int]:
    """Parse ``WIDTHxHEIGHT`` (e.g. ``320x240``)."""
    try:
        w, h = (int(x) for x in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT such as 320x240, got {text!r}") from None
    if w < 1 or h < 1 or w * h > 8192 * 8192:
        raise argparse.ArgumentTypeError(f"expected a positive size up to 8192x8192, got {text!r}")
    return w, h


def positive_float(text: str) -> float:
    """argparse type: a positive finite number (refused before any work, not after it)."""
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}") from None
    if not (v > 0 and v < float("inf")):
        raise argparse.ArgumentTypeError(f"expected a positive finite number, got {text!r}")
    return v


def positive_int(text: str) -> int:
    """argparse type: a positive integer."""
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return v


def _renderer_arg(text: str) -> str:
    """``--renderer``: mitsuba, or progressive with variant options (checked here, before any work)."""
    if text == "mitsuba":
        return text
    from .variants import renderer_options

    try:
        renderer_options(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def _build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="compare", description=__doc__.splitlines()[0],
                                formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    r = sub.add_parser("render", help="render one scene with one renderer to an EXR (+ PNG preview)",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    r.add_argument("--scene", required=True, type=Path, help="scene file (TOML)")
    r.add_argument("--renderer", default="mitsuba", type=_renderer_arg,
                   help="mitsuba, progressive or progressive:<option>[+<option>] (options: "
                        + ", ".join(VARIANT_OPTIONS) + "; see compare/variants.py)")
    r.add_argument("--spp", type=positive_int, default=256, help="samples per pixel (mitsuba)")
    r.add_argument("--frames", type=positive_int, default=128, help="frames to accumulate (progressive)")
    r.add_argument("--size", type=parse_size, default=None, help="WIDTHxHEIGHT; default: the scene's resolution")
    r.add_argument("--seed", type=int, default=0, help="random seed")
    r.add_argument("--materials", choices=["shared", "cycles"], default="shared",
                   help="reference material mode: the shared BRDF plugin or its Blender Principled v2 flavour "
                        "(Cycles-like)")
    r.add_argument("--max-depth", type=int, default=None, help="path depth override (2 = direct light only)")
    r.add_argument("--variant", default=None, help="Mitsuba variant (default: best available)")
    r.add_argument("--no-cache", action="store_true", help="do not read or write the reference cache")
    r.add_argument("--png", type=Path, default=None, help="PNG preview path (default: beside the EXR)")
    r.add_argument("--exposure", type=positive_float, default=1.0, help="exposure multiplier for the PNG preview")
    r.add_argument("--tonemap", default="aces", help="tone-mapping operator for the PNG preview")
    r.add_argument("-o", "--output", required=True, type=Path, help="output EXR path")
    r.set_defaults(func=cmd_render)

    d = sub.add_parser("diff", help="print error metrics of TEST against REF",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    d.add_argument("reference", type=Path, help="reference EXR")
    d.add_argument("test", type=Path, help="test EXR")
    d.add_argument("--maps", type=Path, default=None, help="write error maps (PNG) into this folder")
    d.add_argument("--exposure", type=positive_float, default=1.0,
                   help="exposure before tone mapping (SSIM, LDR-FLIP)")
    d.add_argument("--tonemap", default="aces", help="tone-mapping operator for LDR metrics")
    d.add_argument("--json", action="store_true", help="print JSON instead of a table")
    d.set_defaults(func=cmd_diff)

    from .bench import add_bench_parser
    from .check import add_check_parser
    from .report import add_report_parser
    from .run import add_run_parser

    add_run_parser(sub)
    add_report_parser(sub)
    add_check_parser(sub)
    add_bench_parser(sub)
    return p


def cmd_render(args: argparse.Namespace) -> int:
    """``compare render``: one scene, one renderer, one EXR with metadata, one PNG preview."""
    from .exr import write_exr
    from .fsutil import check_outputs
    from .scene import load_scene
    from .tonemap import write_png

    scene = load_scene(args.scene)
    png = args.png or args.output.with_suffix(".png")
    check_outputs({"-o": args.output, "--png": png}, inputs=(args.scene, *scene.referenced_files),
                  suffixes={"-o": ".exr", "--png": ".png"})
    if args.size:
        scene = scene.with_resolution(*args.size)
    if args.renderer == "mitsuba":
        from .reference import ReferenceRenderer

        renderer = ReferenceRenderer(scene, materials=args.materials, variant=args.variant,
                                     max_depth=args.max_depth, cache_dir=False if args.no_cache else None)
        result = renderer.render(args.spp, seed=args.seed)
        image, meta = result.image, result.metadata
        summary = f"{result.spp} spp in {result.seconds:.2f} s ({renderer.variant}, scene load {renderer.load_seconds:.2f} s)"
    else:
        from .progressive import render_progressive

        from .variants import renderer_options

        result = render_progressive(scene, frames=args.frames, seed=args.seed, **renderer_options(args.renderer))
        image, meta = result.image, result.metadata
        summary = f"{len(result.frame_seconds)} frames in {result.seconds:.2f} s"
    write_exr(args.output, image, metadata={**meta, "scene": str(args.scene)})
    write_png(png, image, exposure=args.exposure, operator=args.tonemap)
    print(f"{args.output}: {scene.camera.width}x{scene.camera.height}, {summary}; preview {png}")
    return 0


def cmd_diff(args: argparse.Namespace) -> int:
    """``compare diff``: metrics of TEST against REF, optionally with error maps."""
    from .exr import read_exr
    from .metrics import compare_images, error_maps, save_error_maps

    if args.maps:
        from .fsutil import check_output_folder

        check_output_folder("--maps", args.maps)
    ref, _ = read_exr(args.reference)
    test, _ = read_exr(args.test)
    metrics = compare_images(ref, test, exposure=args.exposure, operator=args.tonemap)
    if args.maps:
        save_error_maps(args.maps, error_maps(ref, test, exposure=args.exposure, operator=args.tonemap))
    if args.json:
        print(json.dumps(metrics, indent=2, sort_keys=True))
    else:
        width = max(len(k) for k in metrics)
        for k, v in metrics.items():
            print(f"{k:<{width}}  {v:.6g}" if isinstance(v, float) else f"{k:<{width}}  {v}")
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``compare`` console script."""
    parser = _build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except CompareError as exc:
        print(f"compare: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("compare: interrupted; finished work is cached and will be reused", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
