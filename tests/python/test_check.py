"""Error bounds: data/bounds/default.json holds, each of its bounds fails for a perturbed law, and the
`glintlab check` command's exit codes and JUnit XML."""
import json
import xml.etree.ElementTree as ET

import pytest

import glintlab as gl
from glintlab.validation.bounds import DEFAULT_BOUNDS, check, perturbed_law, write_junit
from glintlab.cli.main import main
from glintlab.validation.references import resolve_law

DOC = json.loads(DEFAULT_BOUNDS.read_text())


def test_default_bounds_cover_every_built_in_law_and_hold():
    table = check()
    assert table.ok.all(), table[~table.ok].to_string()
    built_in = {name for name, _ in gl._core.law_infos()}
    covered = {lw.split("[")[0] for lw in table.law}
    assert built_in <= covered
    # Each limit sits above the value measured when it was set (stated margin: 25% + 1e-12).
    for b, r in zip(DOC["bounds"], table.itertuples()):
        if "maximum" in b:
            assert b["maximum"] >= b["measured"] * 1.25
            assert r.worst <= b["maximum"]


@pytest.mark.parametrize("index", range(len(DOC["bounds"])), ids=[b["id"] for b in DOC["bounds"]])
def test_every_default_bound_fails_for_a_perturbed_law(index):
    bound = DOC["bounds"][index]
    law = resolve_law(bound["law"])
    table = check(dict(DOC, bounds=[bound]), substitute={law.label: perturbed_law(law, p_scale=1.5)})
    assert not table.ok.iloc[0], f"{bound['id']} held for a law evaluated at 1.5 p: worst {table.worst.iloc[0]}"


def test_a_shifted_sampler_fails_its_chi_square_bound():
    bound = next(b for b in DOC["bounds"] if b["id"] == "head_cf/sampler/chi2")
    table = check(dict(DOC, bounds=[bound]),
                  substitute={"head_cf": perturbed_law("head_cf", p_scale=1.0, shift=1.0)})
    assert not table.ok.iloc[0] and table.worst.iloc[0] < 1e-6


def test_check_command_exit_codes_and_junit(tmp_path, capsys):
    bounds = {"bounds": [
        {"id": "gated-ok", "law": "gated", "regime": {"n": [16, 1000], "p": [0.1]}, "metric": "tv", "maximum": 0.5},
        {"id": "gated-tight", "law": "gated", "regime": {"n": [16, 1000], "p": [0.1]}, "metric": "tv",
         "maximum": 1e-3},
    ]}
    path = tmp_path / "b.json"
    path.write_text(json.dumps(bounds))
    junit = tmp_path / "junit.xml"
    assert main(["check", str(path), "--junit", str(junit)]) == 1
    out, err = capsys.readouterr()
    assert "VIOLATED gated-tight" in err and "gated-ok" in out
    suite = ET.parse(junit).getroot()
    assert suite.get("tests") == "2" and suite.get("failures") == "1"
    failing = [c for c in suite.iter("testcase") if c.find("failure") is not None]
    assert [c.get("name") for c in failing] == ["gated-tight"]
    bounds["bounds"].pop()
    path.write_text(json.dumps(bounds))
    assert main(["check", str(path), "--quiet"]) == 0


def test_check_command_bad_file_exit_2(tmp_path, capsys):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps({"bounds": [{"id": "x", "law": "gated", "metric": "tv", "maximum": -1}]}))
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and "/bounds/0/maximum" in err
    path.write_text(json.dumps({"bounds": [{"id": "x", "law": "gatd", "metric": "tv", "maximum": 1}]}))
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert "/bounds/0/law" in err and "gatd" in err
    assert main(["check", str(tmp_path / "missing.json")]) == 2


def test_a_chi_square_bound_on_eight_samples_still_rejects_an_all_or_nothing_law():
    # Issue: with 8 samples every bin merged into one, dof = 0 and p = 1.0, so a law whose TV to the
    # binomial is ~1 passed its chi2_pvalue bound. The exact small-sample test rejects it; the binomial
    # itself still passes the same bound.
    bound = {"id": "tiny", "law": "binomial", "metric": "chi2_pvalue", "minimum": 1e-3, "samples": 8, "seed": 2,
             "regime": {"n": [16], "p": [0.1]}, "reference": {"law": "binomial"}}
    aon = gl.custom_law(lambda n, p, u: (u[:, 0] < p) * n, n_uniforms=1, name="all_or_nothing_check_test")
    bad = check(dict(DOC, bounds=[bound]), substitute={"binomial": aon})
    assert not bad.ok.iloc[0], bad.to_string()
    assert check(dict(DOC, bounds=[bound])).ok.iloc[0]


def test_the_chi_square_note_reaches_sweeps_tables_and_junit(tmp_path):
    # A law shifted by one count puts samples where the binomial has no mass at p = 1 ... the test's
    # note (the most useful line glintlab prints) must survive into every table that shows the p-value.
    shifted = perturbed_law("binomial", p_scale=1.0, shift=1.0)
    df = gl.sweep([shifted], n=[16], p=[1.0], metrics=["chi2_pvalue"], samples=1000, seed=1)
    assert df.chi2_pvalue.iloc[0] == 0.0 and "probability 0" in df.chi2_note.iloc[0]
    bound = {"id": "shifted", "law": "binomial", "metric": "chi2_pvalue", "minimum": 1e-6, "samples": 1000, "seed": 1,
             "regime": {"n": [16], "p": [1.0]}, "reference": {"law": "binomial"}}
    table = check(dict(DOC, bounds=[bound]), substitute={"binomial": shifted})
    assert not table.ok.iloc[0] and "probability 0 (first: 17)" in table.note.iloc[0], table.note.iloc[0]
    from glintlab.validation.bounds import format_table
    assert "probability 0 (first: 17)" in format_table(table)
    xml = write_junit(table, tmp_path / "j.xml").read_text()
    assert "probability 0 (first: 17)" in xml
