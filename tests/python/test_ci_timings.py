"""The "no slower" check of .ci/run (.ci/timings.py): warns above 1.5x a step's baseline scaled by the
machine's speed, fails only above 2x and 60 s more, and never on a step it cannot compare."""
import importlib.util
import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("ci_timings", ROOT / ".ci" / "timings.py")
timings = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(timings)

BASE = {"_calibration": 0.5, "test": 600.0, "docs": 4.0}


def test_same_speed_passes_quietly():
    code, lines = timings.compare(dict(BASE), BASE)
    assert code == 0 and not any("warning" in line or "FAILED" in line for line in lines)


def test_a_slower_step_warns_then_fails():
    code, lines = timings.compare({**BASE, "test": 1.6 * 600}, BASE)
    assert code == 0 and any("test" in line and "warning" in line for line in lines)
    code, lines = timings.compare({**BASE, "test": 2.1 * 600}, BASE)
    assert code == 1 and any("test" in line and "FAILED" in line for line in lines)


def test_a_short_step_never_fails_on_noise():
    # 3x slower but only 8 s more: under the 60 s floor, a warning.
    code, lines = timings.compare({**BASE, "docs": 12.0}, BASE)
    assert code == 0 and any("docs" in line and "warning" in line for line in lines)


def test_a_loaded_machine_scales_the_baseline():
    # The calibration workload took twice as long: a step twice as long is the machine, not the project.
    code, lines = timings.compare({"_calibration": 1.0, "test": 1200.0, "docs": 8.0}, BASE)
    assert code == 0 and not any("warning" in line or "FAILED" in line for line in lines)
    # The scale is clamped: a 10x slower calibration does not excuse a 10x slower step.
    code, _ = timings.compare({"_calibration": 5.0, "test": 6000.0, "docs": 4.0}, BASE)
    assert code == 1


def test_missing_steps_and_baseline_are_reported_not_failed(tmp_path):
    code, lines = timings.compare({"_calibration": 0.5, "fuzz": 30.0}, BASE)
    assert code == 0 and any("fuzz" in line and "no baseline" in line for line in lines)
    assert any("test" in line and "not run" in line for line in lines)
    now = tmp_path / "now.json"
    now.write_text(json.dumps({"test": 1.0}))
    assert timings.main(["compare", str(now), str(tmp_path / "absent.json")]) == 0


def test_ci_run_times_every_step_and_compares():
    run = (ROOT / ".ci" / "run").read_text()
    for step in ("test", "bounds", "docs", "clang-test", "sanitize", "fuzz"):
        assert f"\nstep {step} " in run
    assert "timings.py compare" in run and "timings.py calibrate" in run
