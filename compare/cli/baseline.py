"""``compare baseline save | update``: baselines as files for ``compare check --baseline``
(the library: :mod:`compare.report.baseline`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def add_baseline_parser(subparsers) -> argparse.ArgumentParser:
    """Add ``compare baseline`` to an argparse subparsers object; returns the new parser."""
    p = subparsers.add_parser(
        "baseline", help="save or update a baseline folder for `compare check --baseline`",
        description="A baseline is a folder with results.json, each seed's final EXR, their mean and per-pixel "
                    "variance, and the machine facts, all with relative paths: small enough to commit or to keep "
                    "in a CI cache (docs/ci.md).",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    sub = p.add_subparsers(dest="action", required=True, metavar="ACTION")
    for name, help_ in (("save", "write a new baseline folder DIR from a run"),
                        ("update", "replace the baseline in DIR with a run (after an accepted change)")):
        s = sub.add_parser(name, help=help_, description=help_ + "; written to a temporary folder and renamed "
                           "into place", formatter_class=argparse.ArgumentDefaultsHelpFormatter)
        s.add_argument("dir", type=Path, help="the baseline folder")
        s.add_argument("--results", type=Path, required=True, help="results.json of the run (`compare run --seeds K`)")
        s.set_defaults(func=cmd_baseline, replace=name == "update")
    return p


def cmd_baseline(args: argparse.Namespace) -> int:
    """``compare baseline save|update``; returns 0."""
    from compare.report.baseline import save_baseline

    base = save_baseline(args.results, args.dir, replace=args.replace, progress=sys.stderr.isatty())
    size = sum(f.stat().st_size for f in base.root.rglob("*") if f.is_file())
    seeds = sorted({len(r.seeds) for r in base.runs})
    print(f"{base.root}: baseline of {len(base.runs)} run(s), {size / 1e6:.2f} MB, seeds per run {seeds}")
    if seeds and seeds[0] < 2:
        print("compare: warning: runs with one seed give the gate no noise estimate: their error, image and time "
              "tests will be inconclusive; use `compare run --seeds 2` or more", file=sys.stderr)
    return 0
