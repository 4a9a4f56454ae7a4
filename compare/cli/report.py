"""``compare report``: its arguments and its command (the library: :mod:`compare.report.html`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from compare.report.html import build_report
from compare.report.results import Results
from compare.util.errors import CompareError, OutputError


def add_report_parser(subparsers) -> argparse.ArgumentParser:
    """Add ``compare report`` to an argparse subparsers object; returns the new parser."""
    p = subparsers.add_parser(
        "report", help="(re)build the HTML report of a results.json",
        description="Rebuild index.html, plots and viewer data from results.json and the images beside it.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("results", type=Path, help="results.json written by `compare run`")
    p.add_argument("-o", "--output", type=Path, default=None,
                   help="report folder; default: the folder of results.json (images are copied when different)")
    p.add_argument("--plot-format", choices=["png", "svg"], default="png", help="figure format")
    p.add_argument("--fresh", action="store_true",
                   help="replace the results of another run that the -o folder holds (refused otherwise)")
    p.set_defaults(func=cmd_report)
    return p


def _same_results(path: Path, results: Results) -> bool:
    """Whether ``path`` holds ``results`` (as a report copy writes them); unreadable counts as other."""
    try:
        return Results.load(path).to_json() == results.to_json()
    except (CompareError, ValueError, OSError):
        return False


def cmd_report(args: argparse.Namespace) -> int:
    """``compare report``; returns the exit status."""
    from compare.util.files import check_output_folder, folder_lock

    src = args.results.parent
    out = args.output or src
    check_output_folder("-o", out)
    results = Results.load(args.results)
    with folder_lock(out, "compare report"):
        held = Path(out) / "results.json"
        if (not args.fresh and held.is_file() and Path(out).resolve() != src.resolve()
                and not _same_results(held, results)):
            raise OutputError(f"-o {out}: holds the results of another run ({held}); choose another folder, or "
                              "--fresh to replace them")
        index = build_report(results, out, source_dir=src, plot_format=args.plot_format)
    print(f"{index}")
    return 0
