"""``glintlab sweep``: an experiment given by flags instead of a file."""
from __future__ import annotations

import json

from .common import add_outputs, add_samples, add_seed, axis_arg, law_arg, run_experiment_cmd
from ..api import checks as V


def add_parser(sub):
    p = sub.add_parser("sweep", help="sweep laws over an (n, p) grid from flags",
                       description="An experiment given by flags. Axes: numbers, 'standard', 'logspace:LO:HI:COUNT' "
                                   "(exponents of 10) or 'linspace:LO:HI:COUNT'. Laws: NAME or NAME:KEY=VALUE,...")
    p.add_argument("--laws", nargs="+", required=True,
                   help="laws (e.g. gated head_cf gaussian:rounding=round, or a Python law "
                        "mine.py:count[:n_uniforms=2,binning=round])")
    p.add_argument("--n", nargs="+", help="values of n (default: standard)")
    p.add_argument("--p", nargs="+", help="values of p (default: standard)")
    p.add_argument("--metrics", nargs="+", default=["tv", "mean_rel_err", "var_rel_err"],
                   help="tv chi2_distance hellinger kl js w1 ks mean_rel_err var_rel_err chi2_pvalue")
    p.add_argument("--reference", help="reference law (default: binomial)")
    add_samples(p, "draws per grid point (default: exact distributions)")
    add_seed(p, help="seed (default: 1)")
    p.add_argument("--name", default="sweep", help="experiment name (default: sweep)")
    add_outputs(p, None, store=True, out_help="out/sweeps/NAME, NAME from --name")
    p.set_defaults(func=run, default_outputs=default_outputs)
    return p


def default_outputs(args):
    """The output folder defaults to out/sweeps/NAME; the name is checked first."""
    # The name becomes a folder under out/sweeps: a path (../../x) would write elsewhere.
    if not args.name or args.name in (".", "..") or any(c in args.name for c in "/\\\0"):
        V.fail("--name", args.name, "a plain name without '/' (it names the output folder out/sweeps/NAME)")
    if args.out is None:
        args.out = "out/sweeps/" + args.name


def run(args) -> int:
    doc = {"name": args.name, "laws": [law_arg(x) for x in args.laws],
           "grid": {"n": axis_arg(args.n, "--n"), "p": axis_arg(args.p, "--p")},
           "metrics": args.metrics, "reference": law_arg(args.reference) if args.reference else "binomial",
           "samples": args.samples, "seed": args.seed}
    if isinstance(doc["reference"], dict):
        doc["reference"] = {"law": doc["reference"]}
    return run_experiment_cmd(json.dumps(doc), args)
