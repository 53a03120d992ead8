"""The report's paper studies as library functions: DB23 Fig. 13 convergence, WWH18's threshold trade,
KPT25 Fig. 6's blend appearance. Each statistical check is shown to fail on a deliberately wrong law.

False failures: the z-tests use |z| < 5 (two-sided 5.7e-7 per test); over the ~150 tests below the
chance of a false failure per run is below 1e-4.
"""
import math

import numpy as np
import pytest

from glintlab.validation.bench import threshold_trade
from glintlab.studies.convergence import convergence_summary, convergence_table
from glintlab.studies.lod import blend_appearance

Z = 5.0
SMALL_N = (30.0, 300.0, 3000.0, 30000.0)


def test_exact_pipeline_converges_like_the_binomial():
    # n >= 30: below, eq. 10's non-integer trial counts per level (the stratified rule) change the variance
    # visibly at this sample size (lod.non_integer_trials_table measures that separately).
    t = convergence_table(n_values=SMALL_N, pixels=8000, seed=3, pipelines=(("distributed", "binomial"),))
    assert np.all(t.z_mean.abs() < Z) and np.all(t.z_spread.abs() < Z)
    s = convergence_summary(t, min_np=1.0)
    assert np.all((s.slope + 0.5).abs() < 0.05)
    assert np.allclose(t.mean_vs_target, t["mean"])  # R = 1/2, alpha = 1/2: p never clamped


def test_convergence_check_fails_on_output_blending():
    # zk16_linear keeps the mean but shrinks the variance mid-level: the same spread test must reject it.
    t = convergence_table(n_values=(30.0, 300.0), theta_deg=(25.0,), pixels=8000, seed=3,
                          pipelines=(("zk16_linear", "binomial"),))
    assert t.z_spread.abs().max() > Z


def test_gated_pipeline_bias_is_detected_and_fades():
    t = convergence_table(ndfs=(("ggx", 0.5),), theta_deg=(45.0,), n_values=(100.0, 1e5), pixels=20000, seed=5,
                          pipelines=(("distributed", "gated"),))
    assert abs(t.z_mean.iloc[0]) > Z            # n p = 8: DB23's gated law is biased (mean of floor + gate)
    assert abs(t["mean"].iloc[1] - 1) < 2e-3    # n p = 8000: the bias is gone


def test_clamped_p_loses_energy_against_the_target():
    t = convergence_table(ndfs=(("beckmann", 1.0),), theta_deg=(45.0,), n_values=(1e4,), R=1.0, pixels=2000, seed=1,
                          pipelines=(("distributed", "binomial"),))
    assert t.p.iloc[0] == 1.0 and t.p_raw.iloc[0] == pytest.approx(4 / math.e)
    assert t.mean_vs_target.iloc[0] == pytest.approx(math.e / 4, rel=1e-3)


def test_threshold_trade_errors_and_bound():
    t = threshold_trade(thresholds=(1.0, 4.0, 16.0, 64.0), n=[1.0, 10.0, 100.0, 1e3, 1e4], p=[1e-3, 0.01, 0.1, 0.5],
                        draws_per_point=2, repeats=1)
    explicit = t[t.explicit].iloc[0]
    assert explicit.rel_intensity_err_max == 0 and explicit.filtered_share == 0
    body = t[~t.explicit]
    assert np.all(np.diff(body.rel_intensity_err_max) <= 0) and np.all(np.diff(body.filtered_share) <= 0)
    # Just above T the filtered model loses E|K - n p| / (n p) ~ sqrt(2 (1 - p) / (pi n p)) <= sqrt(2 / (pi T)).
    assert np.all(body.rel_intensity_err_max <= 1.05 * np.sqrt(2 / (math.pi * body["T"])))
    with pytest.raises(ValueError, match="thresholds = -1"):
        threshold_trade(thresholds=(-1.0,))


def test_blend_appearance_distributed_matches_truth_and_linear_ghosts():
    t = blend_appearance(weights=(0.25, 0.5, 0.75), samples=40_000, seed=2)
    truth = t[t.blend.str.startswith("truth")].set_index("w")
    for label, g in t[~t.blend.str.startswith("truth")].groupby("blend"):
        z = ((g.set_index("w").lit_share - truth.lit_share) / g.set_index("w").lit_share_se).abs()
        if label == "distributed":
            assert np.all(z < Z), label
        else:  # the same test rejects output blending and the roulette between levels
            assert z.max() > Z, label
    mid = t[(t.w == 0.5)].set_index("blend")
    assert mid.loc["linear (zk16_linear)", "lit_share_vs_truth"] > 1.6
    assert mid.loc["linear (zk16_linear)", "lit_intensity_vs_truth"] < 0.65
