"""`glintlab report` (the job behind `make run`) runs end to end and writes what it announces."""
import json

from glintlab.cli import main


def test_quick_report_writes_tables_and_figures(tmp_path):
    out = tmp_path / "report"
    assert main(["report", "--quick", "--quiet", "--out", str(out)]) == 0
    summary = json.loads((out / "report.json").read_text())
    for table in ("exact_laws", "sampler_checks", "binomial_vs_poisson", "speed_accuracy"):
        assert summary["tables"][table], table
        assert (out / f"{table}.csv").stat().st_size > 0
    for fig in summary["figures"]:
        assert (out / fig).stat().st_size > 10_000, fig  # a real plot, not an empty canvas
    html = (out / "index.html").read_text()
    assert all(fig in html for fig in summary["figures"])
    trade = {row["law"]: row for row in summary["tables"]["speed_accuracy"]}
    assert trade["binomial"]["tv_max"] < 1e-12 and trade["head_cf"]["tv_max"] < 0.01


def test_bad_arguments_exit_2(capsys):
    assert main(["report", "--seed", "-1", "--quiet", "--out", "/tmp/never"]) == 2
    assert "seed = -1" in capsys.readouterr().err
    assert main(["no-such-command"]) == 2
