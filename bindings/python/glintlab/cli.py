"""The `glintlab` command line. Exit status: 0 success, 1 a check failed, 2 bad input."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from . import __version__


def _cmd_laws(args) -> int:
    from .laws import law_summaries
    for name, summary in law_summaries().items():
        print(f"{name:12s} {summary}")
    return 0


def _cmd_report(args) -> int:
    from . import report
    summary = report.run(Path(args.out), quick=args.quick, seed=args.seed, quiet=args.quiet)
    if not args.quiet:
        report.print_summary(summary)
        print(f"\nwrote {args.out}/index.html, report.json, *.csv, *.png in {summary['seconds']} s")
    failed = [r for r in summary["tables"]["sampler_checks"] if r["pvalue"] < 1e-4]
    if failed:
        print(f"glintlab report: {len(failed)} sampler check(s) below p = 1e-4", file=sys.stderr)
        return 1
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="glintlab",
        description="Exact laws, samplers and metrics for the counting laws of glint rendering.")
    parser.add_argument("--version", action="version", version=f"glintlab {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("laws", help="list the registered counting laws")
    p.set_defaults(func=_cmd_laws)

    p = sub.add_parser("report", help="the main job: a report of the exact laws, samplers and metrics",
                       description="Writes index.html, report.json, CSV tables and PNG figures. "
                                   "Exit 1 if a sampler check fails (p < 1e-4).")
    p.add_argument("--out", default="out/report", help="output directory (default: out/report)")
    p.add_argument("--quick", action="store_true", help="1e5 instead of 1e6 samples per check")
    p.add_argument("--seed", type=int, default=1, help="seed of every sampler check (default: 1)")
    p.add_argument("--quiet", action="store_true", help="no tables on stdout, no progress bar")
    p.set_defaults(func=_cmd_report)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse exits 2 on bad usage, 0 on --help
        return int(exc.code or 0)
    if args.command is None:
        parser.print_help()
        return 2
    try:
        return args.func(args)
    except ValueError as exc:
        print(f"glintlab {args.command}: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
