"""The numerical-extremes suite (docs/math/extremes.md): every check is shown to fail on a law built to break
it and to pass on the exact binomial; the built-in findings (gated_shader's K = n + 1) are flagged."""
import math
import types

import numpy as np
import pandas as pd
import pytest

import glintlab as gl
from glintlab.validation import extremes as ex

SAMPLES = 256


@pytest.fixture(scope="module")
def default_table():
    """Every registered law and blend, the full extremes grid (docs/math/extremes.md#extremes-grid),
    256 ordinary draws per point."""
    return gl.extremes_table(samples=SAMPLES)


def _rows(table, law, **where):
    sel = table.law == law
    for k, v in where.items():
        sel &= table[k] == v
    return table[sel]


def _custom(fn, k=1, name="broken"):
    # Constructed directly (not gl.custom_law) so that the registry other tests see is unchanged.
    return gl.CustomLaw(fn, k, name)


def test_every_builtin_law_appears_in_each_precision_it_supports(default_table):
    t = default_table
    labels = set(t.law)
    builtin = [name for name in gl.laws() if not isinstance(gl.law(name), gl.CustomLaw)]
    assert {"binomial", "poisson", "gated", "gated_shader"} <= set(builtin)
    for name in builtin:
        law = gl.law(name)
        label = law.label
        assert label in labels, name
        g = t[t.law == label]
        assert set(g.precision) == set(law.precisions), name
        # every (n, p) of the grid, every uniform set, in every precision
        assert len(g) == len(law.precisions) * len(ex.GRID_N) * len(ex.GRID_P) * len(ex.UNIFORM_SETS)
        assert (g[g.uniforms != "corners"].evaluations == SAMPLES).all()
    assert "float32" in set(t[t.law == "gated"].precision) and set(t[t.law == "binomial"].precision) == {"float64"}
    # blends, on the level boundary (w = 0) and one ulp either side, float64 only
    for blend in gl.blends():
        tags = {lab.split("@")[1] for lab in labels if lab.startswith(blend) and "[binomial]@" in lab}
        assert tags == {"w=1-", "w=0", "w=0+"}, blend
    assert set(t[t.kind == "blend"].precision) == {"float64"}


def test_binomial_and_poisson_pass_everything(default_table):
    for name in ("binomial", "poisson"):
        g = default_table[default_table.law == name]
        assert len(g) and g.ok.all(), g[~g.ok]
        assert (g.error == "").all() and (g.nonfinite == 0).all() and (g.above_n == 0).all()
        pmf_rows = g[g.pmf_mass.notna()]
        assert len(pmf_rows) >= 55 and (pmf_rows.pmf_mass <= 1e-12).all()
        # n = 1e15 at p = 1/2: too large a support is noted, not a failure
        big = _rows(g, name, n=1e15, p=0.5, uniforms="ordinary").iloc[0]
        assert "support too large" in big.pmf_note and big.ok
    assert _rows(default_table, "poisson").bound.iloc[0].startswith("none")
    s = gl.extremes_summary(default_table).set_index(["law", "precision"])
    assert s.loc[("binomial", "float64"), "failures"] == 0 and s.loc[("binomial", "float64"), "failed_checks"] == ""


def test_gated_shader_above_n_break_is_flagged(default_table):
    g = default_table[(default_table.law == "gated_shader") & (default_table.above_n > 0)]
    assert len(g) >= 2 and not g.ok.any()
    # the break is real: the law itself returns K = n + 1 on these uniforms
    law = gl.law("gated_shader")
    row = g.iloc[0]
    if row.uniforms == "corners":
        u = ex.corner_uniforms(law.n_uniforms)
    else:
        u = gl.uniforms(SAMPLES, law.n_uniforms, seed=1)
        u = ex._to_half(u) if row.uniforms == "half" else u
    k = law.bin(law.evaluate(row.n, row.p, u, precision=row.precision))
    assert (k > math.ceil(row.n)).sum() == row.above_n and k.max() == math.ceil(row.n) + 1
    s = gl.extremes_summary(default_table)
    shader = s[s.law == "gated_shader"]
    assert (shader.above_n > 0).all() and shader.failed_checks.str.contains("above_n").all()
    assert shader["where_failed"].str.contains(r"above_n: \(n=").all()


def test_blends_exactly_on_a_level_boundary_pass(default_table):
    for blend in ("distributed", "nearest"):
        g = default_table[default_table.law == f"{blend}[binomial]@w=0"]
        assert len(g) == len(ex.GRID_N) * len(ex.GRID_P) * 3 and g.ok.all()


def test_mean_z_is_finite_when_every_draw_is_equal():
    t = gl.extremes_table(["binomial"], samples=SAMPLES, n=[1e-6, 16], p=[0, 1e-12, 1])
    ordinary = t[t.uniforms == "ordinary"]
    assert np.isfinite(ordinary.mean_z).all() and (ordinary.mean_z.abs() < 5).all()
    assert t[t.uniforms == "corners"]["mean"].isna().all()


# --------------------------------------------------------------------------------------------------
# Each check can fail (a law built to break it) and can pass (the binomial on the same inputs).

# The corner uniforms 0 and 1 reach a float32 law as 2^-24 and 1 - 2^-24 (the float32 uniform rule,
# docs/math/laws.md#float32-uniforms), a custom law as every other: the broken laws break at either.
BROKEN = {
    "nonfinite": lambda n, p, u: np.where(u[:, 0] <= 2.0**-24, np.nan, 0.0),         # NaN at the u = 0 corner
    "below_zero": lambda n, p, u: np.where(u[:, 0] >= 1 - 2.0**-24, -1.0, 0.0),      # K = -1 at the u = 1 corner
    "above_n": lambda n, p, u: np.where(p == 1, np.ceil(n) + 1, 0.0),        # n + 1 at p = 1
}


@pytest.mark.parametrize("check", sorted(BROKEN))
def test_a_broken_law_fails_the_check_and_the_binomial_passes_it(check):
    grid = dict(n=[0.5, 16], p=[0.5, 1.0], samples=SAMPLES)
    t = gl.extremes_table([_custom(BROKEN[check], name=f"broken_{check}"), "binomial"], **grid)
    fails = ex.failed_checks(t)
    broken = t.law == f"broken_{check}"
    assert fails.loc[broken, check].any() and not t.loc[broken & fails[check], "ok"].any()
    # only the check the law breaks
    others = [c for c in ex.CHECKS if c != check]
    assert not fails.loc[broken, others].any().any()
    assert not fails.loc[t.law == "binomial"].any().any() and t[t.law == "binomial"].ok.all()
    where = {"nonfinite": "corners", "below_zero": "corners", "above_n": "ordinary"}[check]
    assert fails.loc[broken & (t.uniforms == where), check].any()
    s = gl.extremes_summary(t).set_index(["law", "precision"])
    assert check in s.loc[(f"broken_{check}", "float32"), "failed_checks"]


def test_nan_at_u_zero_is_caught_in_float32_too_and_half_floats_reach_zero():
    law = _custom(BROKEN["nonfinite"], name="nan_at_zero")
    t = gl.extremes_table([law], samples=SAMPLES, n=[2], p=[0.5])
    assert set(t.precision) == {"float64", "float32"}
    corners = t[t.uniforms == "corners"]
    assert (corners.nonfinite == 1).all()  # {0, 1/2, 1}: one row has u = 0
    assert (t[t.uniforms == "ordinary"].nonfinite == 0).all()  # ordinary uniforms are never 0


def test_a_law_that_raises_on_valid_input_gets_error_text_and_fails():
    def fn(n, p, u):
        if np.any(n == 0):
            raise ZeroDivisionError("no facets")
        return np.zeros(len(n))

    t = gl.extremes_table([_custom(fn, name="raises_at_n0"), "binomial"], samples=SAMPLES, n=[0, 2], p=[0.5])
    bad = t[(t.law == "raises_at_n0") & (t.n == 0)]
    assert len(bad) == 6 and not bad.ok.any() and bad.error.str.contains("ZeroDivisionError: no facets").all()
    assert (bad.evaluations == 0).all()
    good = t[(t.law == "raises_at_n0") & (t.n == 2)]  # the failure is attributed to its grid point only
    assert good.ok.all() and (good.error == "").all()
    assert (t[t.law == "binomial"].error == "").all()


class _BadPmfLaw(gl.CustomLaw):
    """A custom law with a wrong "exact" pmf: extra mass, or a support point above ceil(n)."""

    def __init__(self, mode):
        super().__init__(lambda n, p, u: np.zeros(len(n)), 1, f"bad_pmf_{mode}")
        self.mode = mode

    has_pmf = property(lambda self: True)

    def pmf(self, n, p, max_support=50_000_000):
        if self.mode == "mass":
            return types.SimpleNamespace(support=np.array([0.0, 1.0]), probs=np.array([0.5, 0.5 + 1e-6]))
        if self.mode == "support":
            return types.SimpleNamespace(support=np.array([0.0, math.ceil(n) + 1.0]), probs=np.array([0.5, 0.5]))
        if self.mode == "too_large":
            raise ValueError(f"needs more than max_support = {max_support} support points")
        raise ValueError("pmf broke")


@pytest.mark.parametrize("mode, check", [("mass", "pmf_mass"), ("support", "pmf_support"), ("broken", "error")])
def test_pmf_checks_fail_on_a_wrong_pmf_and_pass_on_the_binomial(mode, check):
    t = gl.extremes_table([_BadPmfLaw(mode), "binomial"], samples=SAMPLES, n=[1, 16], p=[0.5])
    fails = ex.failed_checks(t)
    bad = t.law == f"bad_pmf_{mode}"
    once = (t.precision == "float64") & (t.uniforms == "ordinary")  # the pmf is checked once per point
    rows = bad & once
    assert fails.loc[rows, check].all() and not t.loc[rows, "ok"].any()
    assert not fails.loc[bad & ~once].any().any()
    binom = t.law == "binomial"
    assert not fails.loc[binom].any().any() and (t.loc[binom & once, "pmf_mass"] <= 1e-12).all()
    if mode == "support":
        assert (t.loc[rows, "pmf_above_n"] == 0.5).all()
    if mode == "broken":
        assert t.loc[rows, "error"].str.contains("pmf: ValueError: pmf broke").all()


def test_a_refused_large_support_is_not_a_failure():
    t = gl.extremes_table([_BadPmfLaw("too_large")], samples=SAMPLES, n=[1], p=[0.5])
    row = t[(t.precision == "float64") & (t.uniforms == "ordinary")].iloc[0]
    assert row.ok and row.error == "" and "support too large" in row.pmf_note and np.isnan(row.pmf_mass)


def test_corner_uniforms():
    c = ex.corner_uniforms(2)
    assert c.shape == (9, 2) and set(map(tuple, c)) == {(a, b) for a in (0, .5, 1) for b in (0, .5, 1)}
    c = ex.corner_uniforms(16)
    assert len(c) <= 4096 and set(np.unique(c)) == {0.0, 0.5, 1.0}
    for row in (np.zeros(16), np.ones(16), np.full(16, 0.5)):
        assert (c == row).all(axis=1).any()
    h = ex._to_half(np.array([1e-9, 0.3, 1 - 1e-5]))
    assert h[0] == 0 and h[2] == 1 and abs(h[1] - 0.3) < 1e-3


# --------------------------------------------------------------------------------------------------
# Invalid inputs.

def test_invalid_inputs_raise_value_errors_naming_parameter_and_value():
    t = gl.invalid_inputs_table()
    builtin = [name for name in gl.laws() if not isinstance(gl.law(name), gl.CustomLaw)]
    assert set(builtin) <= {x.split("[")[0] for x in t.law}
    assert t.ok.all(), t[~t.ok]
    assert {"n", "p", "u", "N", "P"} <= set(t.parameter)
    assert {"evaluate", "sample", "pmf"} <= set(t.method)
    nan_p = t[(t.law == "gated") & (t.parameter == "p") & t.value.isna()].iloc[0]
    assert "p = nan" in nan_p.message


class _Lax(gl.CustomLaw):
    """Accepts anything: no validation at all (a silent result), or a vague message."""

    def __init__(self, vague):
        super().__init__(lambda n, p, u: np.zeros(len(np.atleast_1d(n))), 1, "vague" if vague else "lax")
        self.vague = vague

    def evaluate(self, n, p, u, precision="float64"):
        if self.vague:
            raise ValueError("bad input")
        return np.zeros(len(u))

    def _sample_flat(self, nf, pf, count, seed, precision, out=None):
        if self.vague and not (np.all(pf >= 0) and np.all(pf <= 1) and np.all(np.isfinite(nf)) and np.all(nf >= 0)):
            raise ValueError(f"p = {pf[0]!r} is invalid")  # names p even when n is the bad one
        return np.zeros(count)


def test_silent_results_and_vague_messages_are_not_ok():
    t = gl.invalid_inputs_table([_Lax(False), _Lax(True), "binomial"])
    lax, vague = t[t.law == "lax"], t[t.law == "vague"]
    assert not lax.ok.any() and (lax.outcome == "returned").all()
    ev = vague[vague.method == "evaluate"]
    assert not ev.ok.any() and not ev.names_parameter.any()
    s = vague[vague.method == "sample"]
    assert not s[s.parameter == "n"].ok.any()  # names the wrong parameter
    assert s[(s.parameter == "p") & s.value.notna()].ok.all()  # p = -1e-300 and 1 + 1e-15 named exactly
    assert t[t.law == "binomial"].ok.all()


def test_value_naming_is_exact():
    assert ex._value_named("gated: p = 1.0000000000000011 is invalid", "p", 1 + 1e-15) == (True, True)
    assert ex._value_named("gated: p = 1 is invalid", "p", 1 + 1e-15) == (True, False)
    assert ex._value_named("u[0, 1] = nan is invalid", "u", float("nan")) == (True, True)
    assert ex._value_named("n = -1 is invalid", "p", -1.0) == (False, False)


# --------------------------------------------------------------------------------------------------
# Report.

def test_report_writes_every_file_and_highlights_failures(tmp_path):
    broken = _custom(BROKEN["above_n"], name="broken_above_n")
    t = gl.extremes_table([broken, "binomial"], samples=SAMPLES, n=[1, 16], p=[0.5, 1.0])
    inv = gl.invalid_inputs_table(["binomial", _Lax(False)])
    s = gl.extremes_summary(t)
    path = gl.write_extremes_report(tmp_path, t, inv, s)
    assert path == tmp_path / "extremes.html"
    for name in ("extremes.csv", "extremes_invalid.csv", "extremes_summary.csv", "extremes.png", "extremes.html"):
        assert (tmp_path / name).stat().st_size > 0, name
    assert (tmp_path / "extremes.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    back = pd.read_csv(tmp_path / "extremes.csv")
    assert len(back) == len(t) and (back.ok == t.ok).all()
    text = path.read_text()
    assert "<script" not in text and "http" not in text and "data:image/png;base64," in text
    assert 'class="fail"' in text and "broken_above_n" in text
    # the failing rows in full: one per failing (n, p, uniform set, precision)
    failing = text.split("Failing rows")[1].split("Invalid inputs")[0]
    assert failing.count("<tr>") == 1 + int((~t.ok).sum())
    assert "lax" in text.split("Invalid inputs")[1]  # the silent law's cases are listed
