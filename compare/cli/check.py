"""``compare check``: its arguments and its command (the library: :mod:`compare.report.check`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from compare.report.check import check, load_thresholds


def add_check_parser(subparsers) -> argparse.ArgumentParser:
    """Add ``compare check`` to an argparse subparsers object; returns the new parser."""
    p = subparsers.add_parser(
        "check", help="compare results.json against quality thresholds (exit 1 if any is crossed)",
        description="Check every metric bound of a thresholds file against results.json. Exit status 0 when "
                    "all hold, 1 with a list of every crossed bound, 2 for an unreadable file.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("results", type=Path, help="results.json written by `compare run`")
    p.add_argument("--thresholds", type=Path, default=Path("thresholds.toml"), help="thresholds file (TOML)")
    p.set_defaults(func=cmd_check)
    return p


def cmd_check(args: argparse.Namespace) -> int:
    """``compare check``; returns 0 (all bounds hold) or 1 (some crossed)."""
    rules = load_thresholds(args.thresholds)
    violations, checked = check(args.results, rules)
    if violations:
        print(f"{args.results}: {len(violations)} threshold violation(s) out of {checked} bound(s) "
              f"({args.thresholds}):")
        for v in violations:
            print(f"  - {v}")
        return 1
    print(f"{args.results}: all {checked} bound(s) of {len(rules)} rule(s) in {args.thresholds} hold")
    return 0
