"""``glintlab report``: the main job, every configured section as out/report/index.html."""
from __future__ import annotations

import sys
from pathlib import Path

from ..report.config import load_config as load_report_config
from ..report.runner import print_summary as print_report_summary
from ..report.runner import run as run_report
from ..report.sections import SECTIONS
from .common import add_quick, add_quiet, add_seed


def add_parser(sub):
    p = sub.add_parser("report", help="the main job: every figure family, as out/report/index.html",
                       description="Runs the sections of a report configuration (default: "
                                   "glintlab/data/report/default.json) and writes index.html, report.json, CSV tables "
                                   "and PNG figures. --only re-runs some sections and rebuilds the page from the "
                                   "section records already in --out. Exit 1 if a check fails (a sampler's "
                                   "chi-square p < 1e-4, a violated error bound), 2 on bad input.")
    p.add_argument("--out", default="out/report", help="output directory (default: out/report)")
    p.add_argument("--config", help="report configuration JSON (default: glintlab/data/report/default.json)")
    p.add_argument("--only", nargs="+", metavar="SECTION", help="run only these sections (see --list)")
    p.add_argument("--list", action="store_true", help="list the configured sections and exit")
    add_quick(p, "the configuration's quick sizes (make run QUICK=1)")
    add_seed(p, None, "seed of every section (default: the configuration's, 1)")
    add_quiet(p)
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    if args.list:
        doc, source = load_report_config(args.config)
        for entry in doc["sections"]:
            sec = SECTIONS.get(entry["name"])
            print(f"{sec.name:20s} {sec.title}")
        return 0
    summary = run_report(Path(args.out), quick=args.quick, seed=args.seed, quiet=args.quiet, only=args.only,
                         config=args.config)
    if not args.quiet:
        print_report_summary(summary)
        print(f"\nwrote {args.out}/index.html, report.json, *.csv, *.png in {summary['seconds']} s")
    for failure in summary["failures"]:
        print(f"glintlab report: FAILED {failure}", file=sys.stderr)
    return 1 if summary["failures"] else 0
