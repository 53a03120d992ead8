"""LOD studies: coherence metrics on hand-built paths, Figure 4's verdicts at a small size."""
import numpy as np
import pytest

from glintlab.studies import lod


def test_coherence_metrics_on_hand_built_paths():
    # Two paths of 5 steps: steps of 0, 3, 0, 1 and 2, 2, 0, 0.
    K = np.array([[0, 0, 3, 3, 4], [1, 3, 5, 5, 5]], dtype=float)
    m = lod.coherence_metrics(K)
    assert m["mean_abs_step"] == pytest.approx((0 + 3 + 0 + 1 + 2 + 2 + 0 + 0) / 8)
    assert m["pop_rate"] == pytest.approx(3 / 8)
    # Identical columns (after centering) correlate perfectly; independent ones do not.
    rng = np.random.default_rng(0)
    base = rng.normal(size=(5000, 1))
    assert lod.coherence_metrics(np.repeat(base, 4, axis=1) + np.arange(4))["lag_corr"] == pytest.approx(1)
    assert abs(lod.coherence_metrics(rng.normal(size=(5000, 4)))["lag_corr"]) < 0.05
    alt = np.concatenate([base, -base], axis=1)
    assert lod.coherence_metrics(alt)["lag_corr"] == pytest.approx(-1)
    assert np.isnan(lod.coherence_metrics(np.ones((3, 3)))["lag_corr"])
    with pytest.raises(ValueError, match="steps"):
        lod.coherence_metrics(np.ones(4))
    with pytest.raises(ValueError, match="lag = 3"):
        lod.coherence_metrics(np.ones((2, 3)), lag=3)


def test_figure4_accepts_distributed_and_rejects_zk16():
    table, panels = lod.figure4_table(samples=20_000, seed=3, cases=[(64, 16, 0.3)], weights=(0.5,))
    t = table.set_index("source")
    assert t.loc["distributed", "tv"] < 1e-13            # exactly the truth (integer trial counts)
    assert t.loc["distributed", "pvalue"] > 1e-3
    assert t.loc["ground truth (realizations)", "pvalue"] > 1e-3
    assert t.loc["zk16_linear", "pvalue"] < 1e-6
    # ZK16's variance deficit matches the analytic ratio within 5 standard errors.
    z = t.loc["zk16_linear"]
    assert abs(z.var_ratio - z.var_ratio_analytic) < 5 * z.var_ratio_se
    assert len(panels) == 1 and set(panels[0]["sources"]) == {"ground truth (realizations)", "zk16_linear",
                                                               "distributed"}


def test_zoom_ground_truth_is_nested_and_laws_are_coherent():
    table, K = lod.zoom_study(N=1e4, p=0.2, cells_lo=16, steps=16, paths=60, seed=2, inners=("binomial",))
    gt = K[("ground truth", "-")]
    assert np.all(np.diff(gt, axis=1) >= 0)              # nested footprints on one realization
    assert set(table.law) == {"ground truth", "nearest", "zk16_linear", "distributed", "roulette", "roulette_eps0.1"}
    near = table.set_index("law").loc["nearest"]
    assert near.pop_rate > 0                             # the level switch at w = 1/2 pops
    # Every law sits exactly on level lo at the first step and on level hi at the last: same values.
    ends = {k: v[:, [0, -1]] for k, v in K.items() if k[0] != "ground truth"}
    first = next(iter(ends.values()))
    assert all(np.array_equal(v, first) for v in ends.values())


def test_strip_refuses_what_does_not_fit():
    with pytest.raises(ValueError, match="does not fit"):
        lod.strip_images(level=-3, width=64, height=16)
