#!/usr/bin/env python3
"""Writes python/glintlab/data/costs/laws.json: the law costs (ns per evaluation, ns per work unit) that
scene profiles and the advisor use by default (glintlab.validation.profile.recorded_costs).

The costs are timed once, here, by ``measure_costs`` (one core, best of REPEATS interleaved rounds: a
machine shared with other jobs slows whole stretches of time, and the best round is the least
disturbed), and shipped with the package, so that a profile, the advisor's pick and the report are
the same whatever the load of the machine that runs them. Rerun after adding a law to the trade study
(its traits' study_variants): only laws without a recorded cost are timed, so the others' costs stay
as they were; --all times every law again (after changing a law's cost, on an idle machine).
tests/python/test_advisor_costs.py fails while a study law has no recorded cost.

Run: .venv/bin/python scripts/record_law_costs.py  (then review the diff of python/glintlab/data/costs/laws.json)
"""
from __future__ import annotations

import argparse
import json
import os
import platform
from pathlib import Path

from glintlab.api.laws import law_label
from glintlab.validation.bench import DEFAULT_LAWS
from glintlab.validation.profile import RECORDED_COSTS, measure_costs

ROOT = Path(__file__).resolve().parents[1]
REPEATS = 9


def machine() -> str:
    """The CPU's model name and core count (what the numbers were timed on)."""
    model = platform.processor() or platform.machine()
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.exists():
        model = next((line.split(":", 1)[1].strip() for line in cpuinfo.read_text().splitlines()
                      if line.startswith("model name")), model)
    return f"{model}, {os.cpu_count()} cores"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--all", action="store_true",
                        help="time every study law again (default: only those without a recorded cost)")
    args = parser.parse_args(argv)
    path = ROOT / "python" / "glintlab" / "data" / Path(*RECORDED_COSTS)
    old = json.loads(path.read_text())["laws"] if path.exists() and not args.all else {}
    study = {law_label(name, params): (name, params) for name, params in DEFAULT_LAWS}
    todo = [study[label] for label in study if label not in old]
    table = measure_costs(todo, repeats=REPEATS) if todo else None
    new = {} if table is None else {row.law: {"ns_per_eval": round(float(row.ns_per_eval), 2),
                                              "ns_per_trial": round(float(row.ns_per_trial), 3)}
                                    for row in table.itertuples() if row.law not in old}  # (binomial comes along)
    laws = {label: new.get(label, old.get(label)) for label in study}  # laws no longer studied are dropped
    doc = {"note": "ns of one law evaluation (law.sample on one core, best of "
                   f"{REPEATS} rounds) and per work unit (law.work_units), written by scripts/record_law_costs.py; "
                   "modelled units for the scene profiles' SIMD cost, not GPU milliseconds",
           "machine": machine(), "laws": laws}
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(doc, indent=1) + "\n")
    print(f"wrote {path.relative_to(ROOT)}: {len(laws)} laws, {len(new)} timed now")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
