"""``glintlab bench``: ns/sample and accuracy of every law, table and Pareto plot."""
from __future__ import annotations

from pathlib import Path

from ..report.runner import write_section_files
from ..studies.base import Context
from ..studies.speed_accuracy import bench_figures, bench_tables
from ..validation.bench import speed_accuracy
from .common import add_laws, add_outputs, add_samples, add_seed, law_arg, load_plugins, print_table


def add_parser(sub):
    p = sub.add_parser("bench", help="ns/sample and accuracy per law: table and Pareto plot",
                       description="Times every law (or --laws) against numpy's binomial and measures its error "
                                   "against the exact binomial over the standard grid, in one run.")
    add_laws(p, "laws as in sweep, Python laws FILE.py:FUNCTION included (default: every built-in approximate "
                "law and the binomial)")
    add_samples(p, "draws per timed call (default: 1e6)", 10**6)
    p.add_argument("--repeats", type=int, default=2, help="timed calls per point, best kept (default: 2)")
    add_seed(p)
    add_outputs(p, "out/bench")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    load_plugins(args.plugin)
    laws = [law_arg(x) for x in args.laws] if args.laws else None
    summary, errors = speed_accuracy(laws, samples=args.samples, seed=args.seed, repeats=args.repeats,
                                     progress=None if not args.quiet else False)
    figures = write_section_files(bench_tables(summary, errors), bench_figures, Context(args.out, args.seed))
    files = [Path(args.out) / "bench.csv", Path(args.out) / "bench_errors.csv"] + figures
    if not args.quiet:
        print_table(summary[["law", "accuracy", "tv_max", "tv_median", "mean_rel_err_max", "ns_per_sample",
                             "speedup_vs_numpy", "ns_ratio_1e9_vs_16", "pareto"]], args.quiet)
        print(f"\nnumpy binomial: {summary.numpy_ns.iloc[0]:.1f} ns/sample (mean of the timing points); "
              f"wrote {', '.join(str(f) for f in files)}")
    return 0
