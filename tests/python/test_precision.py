"""float32 against float64 (coupled on the same uniforms) and the (1 - p)^n table."""
import numpy as np
import pytest

import glintlab as gl
from glintlab.studies.float32 import float32_summary, float32_table, one_minus_p_pow_n


def test_float32_changes_counts_only_where_float_cannot_resolve_them():
    t = float32_table(["gated", "gaussian"], n=[16, 1e6], p=[0.1, 0.9997], samples=4000, seed=2)
    at = lambda law, n, p: t[(t.law == law) & (t.n == n) & (t.p == p)].iloc[0]
    # n p = 1.6: every count is far from a float32 rounding boundary.
    assert at("gated", 16, 0.1).mismatch == 0
    # n p ~ 1e6: float spacing 0.06 moves floor boundaries; the bound holds at both ends.
    row = at("gated", 1e6, 0.9997)
    assert 0.01 < row.mismatch <= row.mismatch_upper95 < 0.2
    assert (t.nonfinite_f32 == 0).all() and (t.negative_f32 == 0).all() and (t.above_n_f32 == 0).all()


def test_mismatch_is_an_upper_bound_on_tv():
    # Coupling inequality, checked against the exact pmfs where float64 is the reference law:
    # TV(law_f32, law_f64) <= P(K_f32 != K_f64); the histogram TV of the same draws obeys it too.
    law = gl.law("gated")
    u = gl.uniforms(20000, 2, seed=3)
    k64, k32 = law.evaluate(1e6, 0.9997, u), law.evaluate(1e6, 0.9997, u, precision="float32")
    tv = gl.distance(k64, k32, "tv")
    assert tv <= np.mean(k64 != k32) + 1e-12


def test_summary_counts_the_shader_breaks():
    t = float32_table(["gated_shader"], n=[3, 16], p=[0.7, 0.1], samples=4000, seed=1)
    s = float32_summary(t).iloc[0]
    assert s.points_broken_f32 >= 1  # K = n + 1 (P = 0.0064 at n = 3, p = 0.7): above the facets
    with pytest.raises(ValueError, match="samples = 0"):
        float32_table(["gated"], samples=0)


def test_direct_pow_loses_small_p_in_float32():
    t = one_minus_p_pow_n(n_values=(1e3,), p_values=[1e-9, 1e-6, 1e-3])
    get = lambda prec, method, p: t[(t.precision == prec) & (t.method == method) & (t.p == p)].iloc[0]
    assert get("float32", "pow(1-p, n)", 1e-9).p1_rel_err == pytest.approx(1.0)  # 1 - p rounds to 1
    assert get("float32", "pow(1-p, n)", 1e-6).p1_rel_err > 1e-3
    assert get("float32", "exp(n log1p(-p))", 1e-9).p1_rel_err < 1e-6
    assert get("float64", "exp(n log1p(-p))", 1e-9).p1_rel_err < 1e-14
