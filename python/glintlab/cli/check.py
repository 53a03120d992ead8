"""``glintlab check``: the error bounds of a bounds file; exit 1 on any violation."""
from __future__ import annotations

import sys

from ..resources import data_path
from ..validation.bounds import check, format_table, write_junit
from .common import add_plugins, load_plugins


def add_parser(sub):
    p = sub.add_parser("check", help="check error bounds; exit 1 on any violation",
                       description="Evaluates each bound of BOUNDS.json (law, regime, metric, maximum or minimum), "
                                   "prints a table and exits 1 if any bound is violated.")
    p.add_argument("bounds", nargs="?", default=str(data_path("bounds", "default.json")),
                   help="bounds file (default: the package's data/bounds/default.json)")
    p.add_argument("--junit", metavar="FILE.xml", help="also write JUnit XML (one testcase per bound)")
    p.add_argument("--quiet", action="store_true", help="print only violations")
    add_plugins(p, help="load a C++ plugin's laws first")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    load_plugins(args.plugin)
    table = check(args.bounds, progress=None if not args.quiet else False)
    if args.junit:
        write_junit(table, args.junit)
    bad = table[~table.ok]
    if not args.quiet:
        print(format_table(table))
        print(f"\n{len(table) - len(bad)} of {len(table)} bounds hold ({args.bounds})")
    for r in bad.itertuples():
        rel = "<=" if r.limit == "max" else ">="
        print(f"glintlab check: VIOLATED {r.id}: {r.metric} = {r.worst:.6g} at n = {r.at_n:g}, p = {r.at_p:g} "
              f"(bound {rel} {r.bound:.6g})", file=sys.stderr)
    return 1 if len(bad) else 0
