"""The blends' fast paths (one P, runs of equal P, P per sample) against a custom inner law driven
through Python: the built-in binomial (quantile tables, grouped levels) must give the same bits as
the same law written as a custom law, which takes the general path."""
import numpy as np
import pytest

import glintlab as gl

RULES = [("distributed", {}), ("zk16_linear", {}), ("nearest", {}), ("roulette", {}), ("roulette", {"epsilon": 0.0})]


@pytest.mark.parametrize("rule,params", RULES)
def test_fast_paths_match_a_custom_inner_law(rule, params):
    mine = gl.custom_law(lambda n, p, u: gl.binomial.ppf(u[:, 0], n, p), n_uniforms=1, name="my_binomial")
    ours = gl.blended_law(rule, inner=mine, **params)
    builtin = gl.blended_law(rule, inner="binomial", **params)
    rng = np.random.default_rng(4)
    m = 2500
    random_P = np.exp(rng.uniform(0, np.log(16), m))
    runs_P = np.repeat(np.exp(rng.uniform(0, np.log(64), 3)), 1000)[:m]
    for N, P, p in [(1e4, 4.0, 0.01), (2e3, 5.5, 0.3), (1e4, random_P, 0.01), (500.5, runs_P, 0.2),
                    (1e4, runs_P, rng.uniform(0.001, 0.5, m))]:
        size = m if np.isscalar(P) else None
        assert np.array_equal(ours.sample(N, P, p, size=size, seed=3), builtin.sample(N, P, p, size=size, seed=3))
    x, y = rng.uniform(0, 3, m), rng.uniform(0, 3, m)
    assert np.array_equal(ours.sample_at(1e4, 4.0, 0.01, x=x, y=y, seed=2),
                          builtin.sample_at(1e4, 4.0, 0.01, x=x, y=y, seed=2))
    assert np.array_equal(ours.sample_at(1e4, runs_P, 0.01, x=x, y=y, seed=2),
                          builtin.sample_at(1e4, runs_P, 0.01, x=x, y=y, seed=2))
