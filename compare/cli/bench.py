"""``compare bench``: its arguments and its command (the library: :mod:`compare.bench.suite`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import json

from compare.bench.suite import LADDER_SPP, all_items, format_table, run_bench
from compare.util.settings import DEFAULT_FRAMES
from compare.util.files import write_text_atomic


def add_bench_parser(subparsers) -> None:
    """Register ``compare bench``."""

    from compare.cli.argtypes import parse_size, positive_int

    p = subparsers.add_parser("bench", help="speed and memory ratios measured side by side (medians)",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scene", type=Path, default=Path("scenes/cornell.toml"), help="scene file")
    p.add_argument("--size", type=parse_size, default=(320, 240), help="WIDTHxHEIGHT")
    p.add_argument("--frames", type=positive_int, default=DEFAULT_FRAMES, help="progressive frames")
    p.add_argument("--spp", type=positive_int, default=LADDER_SPP, help="reference samples per pixel (equal-error ladder)")
    p.add_argument("--repeats", type=positive_int, default=5, help="repeated runs per side (medians)")
    p.add_argument("--setup-scene", type=Path, default=Path("scenes/car.toml"),
                   help="the scene of the setup-seconds and setup-rss items beside the generated ones")
    p.add_argument("--only", default="", help="comma-separated items (default: all; the renderers declare "
                                                "some, so an unknown name lists them)")
    p.add_argument("-o", "--output", type=Path, default=Path("reports/bench.json"), help="JSON output")
    p.set_defaults(func=_cmd_bench)


def _cmd_bench(args) -> int:
    known = all_items()
    items = tuple(x.strip() for x in args.only.split(",") if x.strip()) or known
    bad = [x for x in items if x not in known]
    if bad:
        print(f"compare: error: --only: unknown item(s) {', '.join(bad)}; known: {', '.join(known)}", file=sys.stderr)
        return 2
    from compare.util.files import check_outputs

    check_outputs({"-o": args.output}, inputs=(args.scene,), suffixes={"-o": ".json"})
    def keep(so_far: dict) -> None:  # every figure on disk as soon as it is measured
        write_text_atomic(args.output, json.dumps(so_far, indent=2))

    result = run_bench(args.scene, size=args.size, frames=args.frames, spp=args.spp, repeats=args.repeats,
                       items=items, setup_scene=args.setup_scene, on_item=keep)
    keep(result)
    print(format_table(result))
    for item, why in result.get("failed", {}).items():
        print(f"compare: bench item {item} failed: {why}", file=sys.stderr)
    print(f"written {args.output}")
    return 1 if result.get("failed") else 0
