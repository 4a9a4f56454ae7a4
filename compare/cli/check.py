"""``compare check``: its arguments and its command (the libraries: :mod:`compare.report.check` for
thresholds, :mod:`compare.report.gate` for a baseline)."""

from __future__ import annotations

import argparse
import dataclasses
import functools
import json
import sys
from pathlib import Path

from compare.cli.argtypes import positive_float, positive_int, setting
from compare.report.gate_settings import ERROR_TESTS, GateSettings
from compare.report.check import check, load_thresholds
from compare.util.errors import CompareError
from compare.util.text import terminal_text


class CheckUsageError(CompareError, ValueError):
    """A bad combination of ``compare check`` options."""


def _alpha(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a level in (0, 1), got {text!r}") from None
    if not 0 < v < 1:
        raise argparse.ArgumentTypeError(f"expected a level in (0, 1), got {text!r}")
    return v


def _ratio(text: str) -> float:
    v = positive_float(text)
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected a ratio >= 1, got {text!r}")
    return v


def _metrics(text: str) -> tuple[str, ...]:
    from compare.metrics.table import known

    names = tuple(m.strip() for m in text.split(",") if m.strip())
    bad = [m for m in names if not known(m)]
    if not names or bad:
        raise argparse.ArgumentTypeError(f"unknown metric(s) {bad or text!r}; e.g. relmse, mse, flip")
    return names


def add_check_parser(subparsers) -> argparse.ArgumentParser:
    """Add ``compare check`` to an argparse subparsers object; returns the new parser."""
    p = subparsers.add_parser(
        "check", help="gate CI: results.json against quality thresholds, or against a baseline (--baseline)",
        description="With --thresholds (the default): check every metric bound of a thresholds file against "
                    "results.json. With --baseline DIR: test the run against a baseline (`compare baseline save`) "
                    "for a worse error, changed images and a slowdown, with statistics over the seeds of "
                    "`compare run --seeds K` (docs/ci.md). Exit status 0 when everything holds, 1 with a table "
                    "of every crossed bound or significant regression, 2 for an unreadable file.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("results", type=Path, help="results.json written by `compare run`")
    p.add_argument("--thresholds", type=Path, default=None,
                   help="thresholds file (TOML); default thresholds.toml when no --baseline is given")
    g = p.add_argument_group("regression gate (--baseline)")
    g.add_argument("--baseline", type=Path, default=None, metavar="DIR",
                   help="a baseline folder (`compare baseline save`) to test the run against")
    knob = functools.partial(setting, GateSettings)
    g.add_argument("--alpha", type=_alpha, **knob("alpha"))
    g.add_argument("--metric", type=_metrics, dest="metrics", metavar="NAMES", **knob("metrics"))
    g.add_argument("--block", type=positive_int, **knob("block"))
    g.add_argument("--error-test", choices=ERROR_TESTS, **knob("error_test"))
    g.add_argument("--time-ratio", type=_ratio, **knob("time_ratio"))
    g.add_argument("--max-cv", type=positive_float, **knob("max_cv"))
    g.add_argument("--min-seconds", type=float, **knob("min_seconds"))
    g.add_argument("--fail-on-change", action="store_true", help=knob("fail_on_change")["help"])
    g.add_argument("--junit", type=Path, default=None, metavar="FILE", help="write JUnit XML, one test case per test")
    g.add_argument("--summary", type=Path, default=None, metavar="FILE",
                   help="append Markdown to FILE (e.g. $GITHUB_STEP_SUMMARY)")
    g.add_argument("--json", action="store_true", help="print the gate as JSON instead of a table")
    g.add_argument("--report", type=Path, default=None, metavar="DIR",
                   help="write the gate's HTML page (curves of both, images that changed) into DIR")
    g.add_argument("--all", action="store_true", help="list every test in the table, not only those that did not pass")
    p.set_defaults(func=cmd_check)
    return p


def _thresholds(args: argparse.Namespace, path: Path) -> int:
    rules = load_thresholds(path)
    violations, checked = check(args.results, rules)
    if violations:
        print(f"{args.results}: {len(violations)} threshold violation(s) out of {checked} bound(s) ({path}):")
        for v in violations:
            print(f"  - {terminal_text(v)}")
        return 1
    print(f"{args.results}: all {checked} bound(s) of {len(rules)} rule(s) in {path} hold")
    return 0


def _gate(args: argparse.Namespace) -> int:
    from compare.report.gate import run_gate
    from compare.util.files import check_outputs, write_text_atomic

    outputs = {k: v for k, v in (("--junit", args.junit), ("--summary", args.summary)) if v is not None}
    check_outputs(outputs, inputs=(args.results,))
    settings = GateSettings(**{f.name: getattr(args, f.name) for f in dataclasses.fields(GateSettings)})
    report = run_gate(args.results, args.baseline, settings, progress=sys.stderr.isatty())
    if args.junit:
        from compare.report.junit import write_junit

        write_junit(report, args.junit)
    if args.summary:  # CI step summaries are appended to (several steps share one file)
        old = args.summary.read_text(encoding="utf-8") if args.summary.is_file() else ""
        sep = "" if not old else "\n" if old.endswith("\n") else "\n\n"
        write_text_atomic(args.summary, old + sep + report.markdown())
    if args.report:
        from compare.report.gate_page import build_gate_page

        index = build_gate_page(report, args.report)
        print(f"gate page: {index}", file=sys.stderr)
    if args.json:
        print(json.dumps(report.to_json(), indent=1, allow_nan=False))
    else:
        print(terminal_text(report.table(everything=args.all)))
    return 1 if report.failed else 0


def cmd_check(args: argparse.Namespace) -> int:
    """``compare check``; returns 0 (everything holds) or 1 (a bound crossed, a significant regression)."""
    if args.baseline is None:
        extra = [o for o, v in (("--junit", args.junit), ("--summary", args.summary), ("--report", args.report),
                                ("--json", args.json)) if v]
        if extra:
            raise CheckUsageError(f"{', '.join(extra)} belong to the regression gate: give --baseline DIR")
        return _thresholds(args, args.thresholds or Path("thresholds.toml"))
    status = _gate(args)
    if args.thresholds is not None:
        status = max(status, _thresholds(args, args.thresholds))
    return status
