"""The standard grid and the exact error table over it."""
import numpy as np
import pytest

import glintlab as gl


def test_standard_grid_shape_and_range():
    n, p = gl.standard_grid()
    assert len(n) >= 40 and len(p) >= 40
    assert n.min() == 1 and n.max() == pytest.approx(1e6)
    assert np.any(n != np.floor(n)), "non-integer n must be on the grid"
    assert p.min() == pytest.approx(1e-6) and p.max() == pytest.approx(1 - 1e-6)
    assert np.all(np.diff(n) > 0) and np.all(np.diff(p) > 0)


def test_error_table_columns_and_values():
    df = gl.error_table(["binomial", "gated", "head_cf"], n=[16, 1000.5], p=[0.1, 0.999])
    assert list(df.columns[:3]) == ["law", "n", "p"]
    assert len(df) == 3 * 4
    exact = df[df.law == "binomial"]
    assert np.all(exact[["tv", "hellinger", "w1", "mean_rel_err", "var_rel_err"]].to_numpy() < 1e-12)
    # The table's TV is the exact distance, recomputed here for one row.
    row = df[(df.law == "gated") & (df.n == 16) & (df.p == 0.1)].iloc[0]
    want = gl.distance(gl.law("gated").pmf(16, 0.1), gl.law("binomial").pmf(16, 0.1), "tv")
    assert row.tv == pytest.approx(want, abs=1e-15)


def test_head_cf_dominates_gated_on_the_standard_grid():
    df = gl.error_table(["gated", "head_cf"])
    worst = df.groupby("law").tv.max()
    assert worst["head_cf"] < 0.01 < 0.5 < worst["gated"], worst.to_dict()


def test_error_table_refuses_laws_without_pmf():
    mine = gl.custom_law(lambda n, p, u: np.zeros(len(u)), n_uniforms=1, name="zeros_for_grid_test")
    with pytest.raises(ValueError, match="no exact pmf"):
        gl.error_table([mine], n=[1], p=[0.5])
