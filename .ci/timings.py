#!/usr/bin/env python3
"""Per-step seconds of .ci/run, and the "no slower" check against a committed baseline.

    timings.py calibrate FILE          time a fixed CPU workload, store it in FILE as "_calibration"
    timings.py record FILE STEP T0     store the seconds since T0 (date +%s.%N) as STEP in FILE
    timings.py compare FILE BASELINE   compare FILE with BASELINE; exit 1 only on a step 2x slower

The comparison scales the baseline by the machine's speed at the time (the calibration workload's seconds
now over its seconds when the baseline was recorded, clamped to [0.5, 4]), so that a loaded or slower
machine does not read as a slower project. A step more than WARN (1.5) times its scaled baseline prints
a warning; more than FAIL (2) times, and more than FLOOR (60) seconds over it, fails. The floor keeps a
short step's noise (a few seconds either way) from failing CI. Steps missing on either side are reported,
never failed. Standard library only: CI's first python3 need not have numpy.
"""
from __future__ import annotations

import json
import statistics
import sys
import time
from pathlib import Path

WARN, FAIL, FLOOR = 1.5, 2.0, 60.0
SCALE_RANGE = (0.5, 4.0)


def _load(path: Path) -> dict:
    return json.loads(path.read_text()) if path.exists() else {}


def _save(path: Path, data: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")


def workload() -> float:
    """Seconds of a fixed integer loop (about 0.5 s on an idle core): the median of three runs, so that
    it reflects the load the steps see rather than the best moment."""
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        acc = 0
        for i in range(2_000_000):
            acc = (acc + i * i) % 1_000_003
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def compare(now: dict, baseline: dict) -> tuple[int, list[str]]:
    """(exit code, report lines) for step seconds `now` against `baseline` (see the module docstring)."""
    lines = []
    scale = 1.0
    if now.get("_calibration") and baseline.get("_calibration"):
        raw = now["_calibration"] / baseline["_calibration"]
        scale = min(max(raw, SCALE_RANGE[0]), SCALE_RANGE[1])
        lines.append(f"ci: machine speed factor {raw:.2f} (calibration), baseline scaled by {scale:.2f}")
    code = 0
    for step in sorted(set(now) | set(baseline)):
        if step.startswith("_"):
            continue
        if step not in baseline:
            lines.append(f"ci: {step}: {now[step]:.0f} s (no baseline)")
            continue
        if step not in now:
            lines.append(f"ci: {step}: not run (baseline {baseline[step]:.0f} s)")
            continue
        expected = baseline[step] * scale
        ratio = now[step] / expected if expected > 0 else float("inf")
        line = f"ci: {step}: {now[step]:.0f} s, {ratio:.2f}x its baseline ({expected:.0f} s scaled)"
        if ratio > FAIL and now[step] - expected > FLOOR:
            lines.append(line + f": FAILED (more than {FAIL:g}x and {FLOOR:g} s slower)")
            code = 1
        elif ratio > WARN:
            lines.append(line + f": warning (more than {WARN:g}x)")
        else:
            lines.append(line)
    return code, lines


def main(argv: list[str]) -> int:
    if len(argv) == 2 and argv[0] == "calibrate":
        path = Path(argv[1])
        data = _load(path)
        data["_calibration"] = workload()
        _save(path, data)
        return 0
    if len(argv) == 4 and argv[0] == "record":
        path = Path(argv[1])
        data = _load(path)
        data[argv[2]] = round(time.time() - float(argv[3]), 1)
        _save(path, data)
        return 0
    if len(argv) == 3 and argv[0] == "compare":
        now, baseline_path = _load(Path(argv[1])), Path(argv[2])
        if not baseline_path.exists():
            print(f"ci: no baseline {baseline_path}: nothing to compare (record one with CI_RECORD_BASELINE=1)")
            return 0
        code, lines = compare(now, _load(baseline_path))
        print("\n".join(lines))
        return code
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
