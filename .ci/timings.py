#!/usr/bin/env python3
"""Per-step seconds of .ci/run, and the "no slower" check against a committed baseline.

    timings.py calibrate FILE                 time a fixed CPU workload, store it in FILE as "_calibration"
    timings.py run FILE STEP -- COMMAND...    run COMMAND, store its seconds, CPU seconds and the load
                                              beside it as STEP in FILE; exit with COMMAND's status
    timings.py compare FILE BASELINE          compare FILE with BASELINE; exit 1 only on a step 2x slower

A step's wall seconds are compared with its baseline scaled by two factors, so that neither a slower
nor a busier machine reads as a slower project:
  - the machine's speed: the calibration workload's CPU seconds now over its CPU seconds when the
    baseline was recorded, clamped to [0.5, 4] (CPU time, not wall time: the load is the next factor);
  - the load during the step: while it ran, other processes used a share s of the machine's CPU time
    (/proc/stat, less the step's own CPU time), so the step had 1 - s of it and takes 1 / (1 - s) times
    as long as on an idle machine (s capped at 0.95); the baseline's own share divides it out.
Measuring the load over each step, not once at the start in wall time, matters: on the shared 2-core
machine (load average 7-11) a wall-clock calibration said 6.5x, clamped to 4x, while `make docs` ran
19x its baseline with others using 91 % of the machine: that rule failed a correct run, this one
scales docs' baseline by 11x (tests/data/ci/loaded_run.json, issue 37).
A step more than WARN (1.5) times its scaled baseline prints a warning; more than FAIL (2) times, and
more than FLOOR (60) seconds over it, fails. The floor keeps a short step's noise (a few seconds either
way) from failing CI. Steps missing on either side are reported, never failed. A baseline recorded
before the load was measured (a number per step) counts as recorded on an idle machine. Standard
library only: CI's first python3 need not have numpy.
"""
from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

WARN, FAIL, FLOOR = 1.5, 2.0, 60.0
SCALE_RANGE = (0.5, 4.0)
MAX_OTHERS_SHARE = 0.95  # the load factor 1 / (1 - share) at most 20


def _load(path: Path) -> dict:
    return json.loads(path.read_text()) if path.exists() else {}


def _save(path: Path, data: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")


def workload(iterations: int = 2_000_000) -> float:
    """CPU seconds of a fixed integer loop (about 0.1-0.5 s on one core): the least of three runs, the
    machine's speed with as little of its load as CPU time still carries (caches, a busy sibling)."""
    times = []
    for _ in range(3):
        t0 = time.process_time()
        acc = 0
        for i in range(iterations):
            acc = (acc + i * i) % 1_000_003
        times.append(time.process_time() - t0)
    return min(times)


def cpu_ticks() -> tuple[int, int] | None:
    """(busy, total) clock ticks of all CPUs since boot (/proc/stat's first line), None where there is
    none. Busy counts steal time: a hypervisor's other guests are load too."""
    try:
        fields = [int(x) for x in Path("/proc/stat").read_text().splitlines()[0].split()[1:9]]
    except (OSError, ValueError, IndexError):
        return None
    idle = fields[3] + fields[4]  # idle, iowait
    total = sum(fields)  # user nice system idle iowait irq softirq steal (guest time is inside user)
    return total - idle, total


def others_share(before, after, own_cpu: float) -> float:
    """The share of the machine's CPU time that other processes used between two cpu_ticks() readings,
    the step's own CPU seconds taken out; in [0, MAX_OTHERS_SHARE]."""
    if before is None or after is None or after[1] <= before[1]:
        return 0.0
    hz = os.sysconf("SC_CLK_TCK")
    busy, total = (after[0] - before[0]) / hz, (after[1] - before[1]) / hz
    return min(max((busy - own_cpu) / total, 0.0), MAX_OTHERS_SHARE)


def run_step(command: list[str]) -> tuple[int, dict]:
    """(exit status, record) of COMMAND: its wall seconds, CPU seconds (it and the descendants it
    waited for) and the others' share of the machine while it ran."""
    ticks0, t0 = cpu_ticks(), time.time()
    try:
        pid = os.posix_spawnp(command[0], command, os.environ)
    except OSError as exc:
        print(f"ci: cannot run {command[0]}: {exc}", file=sys.stderr)
        return 127, {"seconds": 0.0, "cpu": 0.0, "others_share": 0.0}
    _, status, usage = os.wait4(pid, 0)
    wall = time.time() - t0
    cpu = usage.ru_utime + usage.ru_stime
    record = {"seconds": round(wall, 1), "cpu": round(cpu, 1),
              "others_share": round(others_share(ticks0, cpu_ticks(), cpu), 3)}
    return os.waitstatus_to_exitcode(status), record


def _entry(value) -> tuple[float, float | None, float]:
    """(seconds, CPU seconds or None, others' share) of a step's record; a bare number is a record of
    the seconds alone, on an idle machine."""
    if isinstance(value, dict):
        return float(value["seconds"]), value.get("cpu"), float(value.get("others_share", 0.0))
    return float(value), None, 0.0


def compare(now: dict, baseline: dict) -> tuple[int, list[str]]:
    """(exit code, report lines) for step seconds `now` against `baseline` (see the module docstring)."""
    lines = []
    speed = 1.0
    if now.get("_calibration") and baseline.get("_calibration"):
        raw = now["_calibration"] / baseline["_calibration"]
        speed = min(max(raw, SCALE_RANGE[0]), SCALE_RANGE[1])
        lines.append(f"ci: machine speed factor {raw:.2f} (calibration, CPU time), baseline scaled by {speed:.2f}")
    code = 0
    for step in sorted(set(now) | set(baseline)):
        if step.startswith("_"):
            continue
        if step not in baseline:
            lines.append(f"ci: {step}: {_entry(now[step])[0]:.0f} s (no baseline)")
            continue
        if step not in now:
            lines.append(f"ci: {step}: not run (baseline {_entry(baseline[step])[0]:.0f} s)")
            continue
        (seconds, cpu, share), (base_seconds, base_cpu, base_share) = _entry(now[step]), _entry(baseline[step])
        load = (1 - base_share) / (1 - share)
        expected = base_seconds * speed * load
        ratio = seconds / expected if expected > 0 else float("inf")
        line = (f"ci: {step}: {seconds:.0f} s, {ratio:.2f}x its baseline ({expected:.0f} s scaled: others used "
                f"{share:.0%} of the machine, the baseline's {base_share:.0%}")
        if cpu is not None and base_cpu:
            line += f"; CPU {cpu:.0f} s, {cpu / (base_cpu * speed):.2f}x the baseline's"
        line += ")"
        if ratio > FAIL and seconds - expected > FLOOR:
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
    if len(argv) >= 5 and argv[0] == "run" and argv[3] == "--":
        path, step = Path(argv[1]), argv[2]
        code, record = run_step(argv[4:])
        data = _load(path)
        data[step] = record
        _save(path, data)
        return code
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
