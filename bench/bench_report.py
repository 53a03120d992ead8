#!/usr/bin/env python3
"""`make bench`: the report's per-section seconds (issue 32's `make run` row), read from report.json.

    ./.venv/bin/python bench/bench_report.py [--run] [--out out/bench/report] [--quick-out out/bench/report_quick]

With --run, first runs the full report and the quick one (`glintlab report` and `glintlab report --quick`)
into those folders with this build; without it, reads the report.json files already there (for example
`make run`'s: --out out/report). Prints, per section, the wall seconds and the process's CPU seconds
(every thread; less sensitive than wall time to other jobs on a shared machine, higher than it where C++
ran on several threads), largest first, with each report's total against its goal: the report under
150 s of the 3 minutes `make run` may take (the rest is the build check and the interpreter's start),
`--quick` under 45 s. A benchmark, not a test: exits 0 whatever the goals say.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

GOALS = {False: 150.0, True: 45.0}  # seconds of report: full, quick


def run_report(out: Path, quick: bool) -> float:
    """Runs `glintlab report` into ``out`` in a fresh process (as `make run` does); returns its wall seconds."""
    cmd = [sys.executable, "-m", "glintlab.cli.main", "report", "--out", str(out), "--quiet"] + (["--quick"] if quick else [])
    t0 = time.perf_counter()
    subprocess.run(cmd, check=False)
    return time.perf_counter() - t0


def table(summary: dict) -> str:
    """Per-section lines, largest wall time first."""
    rows = sorted(summary["sections"].items(), key=lambda kv: -kv[1]["seconds"])
    lines = [f"  {'section':22s} {'wall s':>8s} {'CPU s':>8s}"]
    for name, sec in rows:
        cpu = sec.get("cpu_seconds")
        lines.append(f"  {name:22s} {sec['seconds']:8.1f} {cpu if cpu is not None else float('nan'):8.1f}")
    return "\n".join(lines)


def report(path: Path, wall: float | None) -> None:
    summary = json.loads((path / "report.json").read_text())
    quick = bool(summary["quick"])
    total = summary["seconds"]
    goal = GOALS[quick]
    cpu = summary.get("cpu_seconds")
    print(f"\n{'make run QUICK=1' if quick else 'make run'}: report {total:.1f} s wall"
          + (f", {cpu:.1f} s CPU" if cpu is not None else "")
          + (f" ({wall:.1f} s with the interpreter's start)" if wall is not None else "")
          + f"; goal < {goal:g} s: {'PASS' if total < goal else 'FAIL'}"
          + f"; {len(summary['failures'])} failed checks; {path / 'report.json'}")
    print(table(summary))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--run", action="store_true", help="run both reports first")
    ap.add_argument("--out", default="out/bench/report")
    ap.add_argument("--quick-out", default="out/bench/report_quick")
    args = ap.parse_args(argv)
    print(f"report timing; machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} at the start")
    for folder, quick in ((Path(args.out), False), (Path(args.quick_out), True)):
        wall = run_report(folder, quick) if args.run else None
        if (folder / "report.json").is_file():
            report(folder, wall)
        else:
            print(f"\n{folder / 'report.json'}: not there (run with --run, or `make run` and --out out/report)")
    print(f"\nload average at the end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
