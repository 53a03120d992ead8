"""Experiments as JSON: `glintlab run` / `glintlab sweep`, results that re-run exactly, bad files exit 2."""
import json
from pathlib import Path

import pandas as pd
import pytest

import glintlab as gl
from glintlab.cli.main import main
from glintlab.validation.experiment import parse_document, run_experiment

ROOT = Path(__file__).resolve().parents[2]
EXPERIMENTS = ROOT / "examples"


def test_defaults_are_filled_in():
    doc, source, _ = parse_document("experiment", {"laws": ["gated"], "grid": {"n": [16], "p": [0.1]}})
    assert doc["metrics"] == ["tv", "mean_rel_err", "var_rel_err"]
    assert doc["reference"] == "binomial" and doc["samples"] is None and doc["seed"] == 1
    assert doc["outputs"] == {"csv": True, "json": True, "plots": True}


@pytest.mark.parametrize("name", sorted(p.name for p in EXPERIMENTS.glob("*.json")
                                         if json.loads(p.read_text()).get("kind") != "report"))
def test_shipped_experiments_parse(name):
    doc, _, _ = parse_document("experiment", EXPERIMENTS / name)
    assert doc["laws"]


def test_run_writes_results_that_rerun_exactly(tmp_path, capsys):
    exp = {"name": "t", "laws": ["gated", {"name": "gaussian", "params": {"rounding": "round"}}],
           "grid": {"n": {"logspace": [1, 3, 3]}, "p": [0.05, 0.3]}, "metrics": ["tv", "chi2_pvalue"],
           "samples": 20000, "seed": 9}
    path = tmp_path / "exp.json"
    path.write_text(json.dumps(exp))
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out), "--quiet"]) == 0
    first = pd.read_csv(out / "results.csv")
    assert list(first.columns[:3]) == ["law", "n", "p"] and len(first) == 12
    assert (out / "tv.png").stat().st_size > 1000 and (out / "chi2_pvalue.png").exists()
    results = json.loads((out / "results.json").read_text())
    assert results["glintlab_version"] == gl.__version__
    assert results["config"]["seed"] == 9 and results["config"]["outputs"]["plots"] is True
    # Re-run from the results file alone: the same table.
    again = run_experiment(out / "results.json").table
    pd.testing.assert_frame_equal(pd.read_csv(out / "results.csv"), first)
    assert again.tv.tolist() == pytest.approx(first.tv.tolist(), rel=1e-15)
    assert again.chi2_pvalue.tolist() == pytest.approx(first.chi2_pvalue.tolist(), rel=1e-12)


def test_custom_python_law_experiment(tmp_path):
    result = run_experiment(EXPERIMENTS / "custom_python_law.json")
    t = result.table
    assert set(t.law) == {"shader_round_normal", "gated"}
    mine = t[t.law == "shader_round_normal"]
    # The rounded normal is fine in the bulk and wrong for rare glints (n p << 1).
    assert mine[(mine.n * mine.p) > 30].chi2_pvalue.min() > 1e-6 or mine.tv.min() < 0.05
    assert mine[(mine.n * mine.p) < 0.01].tv.max() > 0.001


def test_sweep_command(tmp_path, capsys):
    out = tmp_path / "sw"
    code = main(["sweep", "--laws", "gated", "gaussian:rounding=round", "--n", "logspace:0:4:5", "--p", "0.1", "0.5",
                 "--metrics", "tv", "kl", "--out", str(out), "--quiet"])
    assert code == 0
    df = pd.read_csv(out / "results.csv")
    assert len(df) == 20 and set(df.law) == {"gated", "gaussian[rounding=round]"}


@pytest.mark.parametrize("argv, pointer", [
    (["sweep", "--laws", "gated", "--n", "16", "--p", "1.5"], "/grid/p"),
    (["sweep", "--laws", "gated", "--n", "-3", "--p", "0.1"], "/grid/n"),
    (["sweep", "--laws", "gated", "--metrics", "tvv"], "/metrics/0"),
    (["sweep", "--laws", "gated", "--samples", "0"], "/samples"),
    (["sweep", "--laws", "gatd", "--n", "16", "--p", "0.1"], "/laws/0"),
])
def test_sweep_command_bad_input_exit_2(argv, pointer, capsys):
    assert main(argv) == 2
    assert pointer in capsys.readouterr().err


@pytest.mark.parametrize("doc, pointer, expected", [
    ({"laws": ["gated"], "grid": {"n": [16], "p": [0.1]}, "seeed": 1}, "/seeed", "one of the fields"),
    ({"laws": [], "grid": {"n": [16], "p": [0.1]}}, "/laws", "at least 1 item"),
    ({"laws": ["gated"], "grid": {"n": [16]}}, "/grid/p", "p"),
    ({"laws": [{"name": "zk16", "params": {"cap": True}}], "grid": {"n": [16], "p": [0.1]}}, "/laws/0/params/cap",
     "number or a string"),
    ({"laws": ["gated"], "grid": {"n": [16], "p": [0.1]}, "metrics": ["chi2_pvalue"]}, "/metrics/0", "samples"),
])
def test_run_command_bad_file_names_file_pointer_and_expectation(tmp_path, capsys, doc, pointer, expected):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(doc))
    assert main(["run", str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and pointer in err and expected in err
    assert not (tmp_path / "o").exists()


def test_run_command_unparsable_and_missing(tmp_path, capsys):
    path = tmp_path / "broken.json"
    path.write_text('{"laws": ["gated"], ')
    assert main(["run", str(path)]) == 2
    assert "broken.json" in capsys.readouterr().err
    assert main(["run", str(tmp_path / "nope.json")]) == 2


def test_help_of_every_subcommand(capsys):
    for cmd in ("run", "sweep", "check", "bench", "extremes", "report", "laws"):
        assert main([cmd, "--help"]) == 0
        assert "usage: glintlab " + cmd in capsys.readouterr().out


def test_a_cpp_plugin_law_gets_experiments_and_bounds(tmp_path):
    """The C++ custom-law route end to end, from the command line (a child process, so the plugin's
    laws stay out of this interpreter's registry)."""
    import subprocess
    plugin = ROOT / "build" / "validation" / "plugins" / "libglintlab_example_plugin.so"
    law = {"name": "example_binomial_inversion", "plugin": str(plugin)}
    exp = tmp_path / "exp.json"
    exp.write_text(json.dumps({"name": "plugin", "laws": [law, "gated"], "grid": {"n": [16, 100], "p": [0.1, 0.5]},
                               "metrics": ["tv", "mean_rel_err"]}))
    glintlab = str(ROOT / ".venv" / "bin" / "glintlab")
    run = subprocess.run([glintlab, "run", str(exp), "--out", str(tmp_path / "out"), "--quiet"],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    df = pd.read_csv(tmp_path / "out" / "results.csv")
    assert df[df.law == "example_binomial_inversion"].tv.max() < 1e-12  # exact inversion of the binomial
    bounds = tmp_path / "bounds.json"
    bounds.write_text(json.dumps({"bounds": [
        {"id": "exact", "law": law, "regime": {"n": [1, 16, 1000], "p": [0.01, 0.5]}, "metric": "tv", "maximum": 1e-9},
        {"id": "sampler", "law": law, "regime": {"n": [16, 1000], "p": [0.01, 0.5]}, "metric": "chi2_pvalue",
         "samples": 100000, "minimum": 1e-6},
        {"id": "rare-glints", "law": "example_round_normal", "regime": {"n": [16], "p": [0.01]},
         "metric": "tv", "samples": 20000, "maximum": 0.01}]}))
    check = subprocess.run([glintlab, "check", str(bounds)], capture_output=True, text=True)
    # The plugin is loaded by the first bound; the third names its other law alone: a rounded normal,
    # wrong for rare glints (n p = 0.16).
    assert check.returncode == 1, check.stderr
    assert "VIOLATED rare-glints" in check.stderr and "exact" in check.stdout and "2 of 3 bounds hold" in check.stdout
