"""``compare measure``: its arguments and its command (the library: :mod:`compare.run.measure`)."""

from __future__ import annotations

import argparse
import functools
import sys
from pathlib import Path

from compare.cli.argtypes import positive_float, positive_int, setting
from compare.report.results import RunSettings
from compare.run.measure import UNITS, measure


def add_measure_parser(subparsers) -> None:
    """Register ``compare measure``."""
    p = subparsers.add_parser("measure", help="measure checkpoint EXRs made anywhere against a scene's ground truth",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("images", type=Path, help="folder with step-<N>.exr and timings.json")
    p.add_argument("--scene", required=True, type=Path, help="the scene the images show (TOML)")
    p.add_argument("--name", default=None, help="the renderer's name in results.json (default: the folder's name)")
    p.add_argument("--label", default=None, help="the renderer's label in the report")
    p.add_argument("--unit", choices=sorted(UNITS), default="frames", help="what a step counts")
    opt = functools.partial(setting, RunSettings)
    p.add_argument("--spp", type=positive_int, **opt("spp"))
    p.add_argument("--seed", type=int, **opt("seed"))
    p.add_argument("--ground-truth", metavar="RENDERER", **opt("ground_truth"))
    p.add_argument("--exposure", type=positive_float, **opt("exposure"))
    p.add_argument("--fresh", action="store_true", help="redo finished units")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.add_argument("-o", "--output", type=Path, required=True, help="output folder (results.json and the report)")
    p.set_defaults(func=_cmd_measure)


def _cmd_measure(args) -> int:
    settings = RunSettings(spp=args.spp, seed=args.seed, exposure=args.exposure, ground_truth=args.ground_truth)
    res = measure(args.images, args.scene, args.output, name=args.name, label=args.label, unit=UNITS[args.unit],
                  settings=settings, progress=not args.quiet, fresh=args.fresh)
    run = res.scenes[0].runs[0]
    flip = run.final.metrics.get("flip")
    # None where FLIP is undefined (a ground truth that tone-maps to a constant, e.g. black): said, not scored
    said = f"{flip:.4f}" if flip is not None else "undefined (the ground truth tone-maps to a constant)"
    print(f"{args.output / 'results.json'}: {run.label}, {len(run.points)} checkpoints, final FLIP "
          f"{said}; open {args.output / 'index.html'}", file=sys.stdout)
    return 0
