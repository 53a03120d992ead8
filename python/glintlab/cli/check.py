"""``glintlab check``: the error bounds of a bounds file or a pipeline file; exit 1 on any violation.

A pipeline file (an object with "stages", docs/guide/ci_pipeline.md) bounds every stage of a renderer's
glint pipeline; ``--record`` measures it and writes its bounds (and shows what changed)."""
from __future__ import annotations

import math
import sys

from ..api import checks as V
from ..resources import data_path
from ..validation import bounds as B
from ..validation import pipeline as P
from ..studies import pipeline_metrics  # noqa: F401  (registers the built-in stages and metrics)
from .common import add_plugins, load_plugins


def add_parser(sub):
    p = sub.add_parser("check", help="check error bounds (a bounds or pipeline file); exit 1 on any violation",
                       description="Evaluates each bound of BOUNDS.json (law, regime, metric, maximum or minimum) or of "
                                   "PIPELINE.json (every stage of a glint pipeline: law, blend, grid, method, sampler), "
                                   "prints a table and exits 1 if any bound is violated (2 on a bad file).")
    p.add_argument("bounds", nargs="?", default=str(data_path("bounds", "default.json")),
                   help="bounds or pipeline file (default: the package's data/bounds/default.json)")
    p.add_argument("--junit", metavar="FILE.xml", help="also write JUnit XML (one testcase per bound)")
    p.add_argument("--record", action="store_true",
                   help="pipeline files: measure every bound and write it into the file (measured value, bound by the "
                        "file's margin rule, seed, glintlab version, machine); prints what changed")
    p.add_argument("--quiet", action="store_true", help="print only violations")
    add_plugins(p, help="load a C++ plugin's laws first")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    load_plugins(args.plugin)
    if P.is_pipeline(args.bounds):
        return _run_pipeline(args)
    if args.record:
        V.fail("--record", args.bounds, "a pipeline file (an object with \"stages\")")
    table = B.check(args.bounds, progress=None if not args.quiet else False)
    if args.junit:
        B.write_junit(table, args.junit)
    bad = table[~table.ok]
    if not args.quiet:
        print(B.format_table(table))
        print(f"\n{len(table) - len(bad)} of {len(table)} bounds hold ({args.bounds})")
    for r in bad.itertuples():
        rel = "<=" if r.limit == "max" else ">="
        print(f"glintlab check: VIOLATED {r.id}: {r.metric} = {r.worst:.6g} at n = {r.at_n:g}, p = {r.at_p:g} "
              f"(bound {rel} {r.bound:.6g})", file=sys.stderr)
    return 1 if len(bad) else 0


def _run_pipeline(args) -> int:
    if args.record:
        doc, table, diff = P.record(args.bounds)
        if args.junit:
            P.write_junit(table, args.junit)
        unmeasured = diff[~diff.measured.map(math.isfinite)]
        for r in unmeasured.itertuples():
            print(f"glintlab check: cannot record {r.id}: it measured {r.measured} ({r.note or 'no value'})",
                  file=sys.stderr)
        if len(unmeasured):
            print(f"nothing recorded into {args.bounds}", file=sys.stderr)
            return 1
        print(f"recorded {len(diff)} bounds into {args.bounds} (seed {doc['seed']}, glintlab "
              f"{doc['recorded']['glintlab_version']}):")
        print(P.format_diff(diff))
        # A p-value keeps its fixed level: one measured below it is a failing stage, recorded or not.
        for r in diff[~diff.holds].itertuples():
            print(f"glintlab check: VIOLATED {r.id}: {r.measured:.6g} against its level {r.bound:.6g}; {r.note}",
                  file=sys.stderr)
        return 1 if (~diff.holds).any() else 0
    table = P.check_pipeline(args.bounds)
    if args.junit:
        P.write_junit(table, args.junit)
    bad = table[~table.ok]
    if not args.quiet:
        print(P.format_table(table))
        print(f"\n{len(table) - len(bad)} of {len(table)} bounds hold ({args.bounds}, "
              f"{table.seconds.sum():.1f} s)")
    for r in bad.itertuples():
        print(f"glintlab check: VIOLATED {r.id}: {P.violation_line(r)}", file=sys.stderr)
    return 1 if len(bad) else 0
