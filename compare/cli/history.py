"""``compare history``: a page of error and time per renderer over a series of runs
(the library: :mod:`compare.report.history`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def add_history_parser(subparsers) -> argparse.ArgumentParser:
    """Add ``compare history`` to an argparse subparsers object; returns the new parser."""
    p = subparsers.add_parser(
        "history", help="a page of error and time per renderer over a series of runs, with the noise band",
        description="Plot each renderer's final error and time over RESULTS (in the order given, e.g. one per CI "
                    "run), with the 95 %% interval of the mean over each run's seeds.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("results", type=Path, nargs="+", help="results.json files, oldest first")
    p.add_argument("-o", "--output", type=Path, required=True, help="the page's folder (index.html)")
    p.add_argument("--labels", default=None, help="comma-separated names of the runs (e.g. commits); default: "
                                                  "each results.json's folder name")
    p.add_argument("--metric", default="relmse", help="the error metric plotted")
    p.set_defaults(func=cmd_history)
    return p


def cmd_history(args: argparse.Namespace) -> int:
    """``compare history``; returns 0."""
    from compare.metrics.table import known
    from compare.report.history import build_history
    from compare.report.results import ResultsError

    if not known(args.metric):
        raise ResultsError(f"--metric {args.metric!r}: not a metric of results.json (e.g. relmse, mse, flip)")
    labels = [x.strip() for x in args.labels.split(",")] if args.labels else None
    index = build_history(args.results, args.output, labels=labels, metric=args.metric,
                          progress=sys.stderr.isatty())
    print(index)
    return 0
