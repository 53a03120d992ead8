"""``glintlab extremes``: the numerical-extremes suite for every law, as extremes.html."""
from __future__ import annotations

from ..report.html import write_extremes_report
from ..validation.extremes import extremes_summary, extremes_table, invalid_inputs_table
from ..validation.references import resolve_law
from .common import add_laws, add_outputs, add_samples, add_seed, law_arg, load_plugins, print_table


def add_parser(sub):
    p = sub.add_parser("extremes", help="the numerical-extremes suite (docs/math/extremes.md) for every law",
                       description="Evaluates every law in float32 and float64 at extreme n, p and uniforms: finite, "
                                   "in [0, n], mean error, pmf mass; invalid inputs must raise clear errors. Writes "
                                   "extremes.html with failures highlighted.")
    add_laws(p, "laws as in sweep, Python laws FILE.py:FUNCTION included (default: every registered law and blend)")
    add_samples(p, "ordinary draws per point (default: 4096)", 4096)
    add_seed(p)
    p.add_argument("--strict", action="store_true", help="exit 1 if any check fails")
    add_outputs(p, "out/extremes")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    load_plugins(args.plugin)
    laws = [law_arg(x) for x in args.laws] if args.laws else None
    if laws is not None:
        laws = [resolve_law(x) for x in laws]
    table = extremes_table(laws, samples=args.samples, seed=args.seed)
    invalid = invalid_inputs_table(laws)
    summary = extremes_summary(table)
    path = write_extremes_report(args.out, table, invalid, summary)
    failures = int((~table.ok).sum()) + int((~invalid.ok).sum())
    if not args.quiet:
        print_table(summary, args.quiet)
        print(f"\n{failures} failing rows; wrote {path}")
    return 1 if (failures and args.strict) else 0
