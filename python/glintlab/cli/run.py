"""``glintlab run``: one experiment file (or a results.json, re-run exactly)."""
from __future__ import annotations

from pathlib import Path

from .common import add_outputs, run_experiment_cmd


def add_parser(sub):
    p = sub.add_parser("run", help="run one experiment (JSON) to CSV, JSON and plots",
                       description="Runs an experiment file (data/schema/experiment.schema.json), or re-runs a "
                                   "results.json exactly. Writes results.csv, results.json and one PNG per metric.")
    p.add_argument("experiment", help="experiment JSON, or a results.json written by an earlier run")
    add_outputs(p, None, store=True, out_help="out/experiments/EXPERIMENT, the file's stem")
    p.set_defaults(func=run, default_outputs=default_outputs)
    return p


def default_outputs(args):
    """The output folder defaults to the experiment file's stem."""
    if args.out is None:
        args.out = "out/experiments/" + Path(args.experiment).stem


def run(args) -> int:
    return run_experiment_cmd(args.experiment, args)
