"""Blended laws from Python: the public blend surface, exact laws, custom inner laws, errors."""
import numpy as np
import pytest

import glintlab as gl

N, A_LO = 4096, 16 / 4096  # DB23 Fig. 4's setting: levels of 16 and 64 cells


def test_blends_are_listed():
    assert gl.blends() == ["distributed", "nearest", "roulette", "zk16_linear"]
    assert set(gl.blend_summaries()) == set(gl.blends())


def test_distributed_is_the_binomial_for_integer_trial_counts():
    bl = gl.blended_law("distributed", inner="binomial", level_ratio=4, base_area=A_LO)
    for cells in (19, 40, 61):
        d = bl.pmf(N, cells / N, 0.2)
        ref = gl.law("binomial").pmf(cells, 0.2)
        assert gl.distance(d, ref, "tv") < 1e-13
    assert bl.binning == "none" and bl.has_pmf


def test_levels_and_zk16_ratio():
    bl = gl.blended_law("zk16_linear", base_area=A_LO)
    lv = bl.levels(32 / N)
    assert lv["level"] == 0 and lv["area_lo"] == A_LO and lv["area_hi"] == 4 * A_LO
    assert lv["w_lod"] == pytest.approx(0.5) and lv["w_area"] == pytest.approx(1 / 3)
    r = gl.zk16_variance_ratio([16 / N, 32 / N, 64 / N], base_area=A_LO)
    assert r[0] == pytest.approx(1) and r[2] == pytest.approx(1) and r[1] == pytest.approx(2 * (0.25 + 0.25 / 4))
    x = bl.sample(N, 32 / N, 0.3, size=200_000, seed=2)
    expected = r[1] * 32 * 0.3 * 0.7
    assert abs(x.var() - expected) < 5 * expected * np.sqrt(3 / 200_000)
    assert bl.binning == "round"


def test_sampling_is_reproducible_and_broadcasts():
    bl = gl.blended_law("roulette", inner="gated", base_area=A_LO, epsilon=0.1)
    a = bl.sample(N, [20 / N, 50 / N], 0.1, size=(3, 2), seed=5)
    b = bl.sample(N, [20 / N, 50 / N], 0.1, size=(3, 2), seed=5)
    assert a.shape == (3, 2) and np.array_equal(a, b)
    k = bl.sample_at(N, 30 / N, 0.1, x=np.linspace(0, 0.5, 7)[:, None], y=[0.1, 0.2], seed=3)
    assert k.shape == (7, 2)
    assert repr(bl).startswith("glintlab.blended_law('roulette', inner='gated'")


def test_a_custom_inner_law_reproduces_the_builtin_seed_for_seed():
    mine = gl.custom_law(lambda n, p, u: gl.binomial.ppf(u[:, 0], n, p), n_uniforms=1, name="my_binomial")
    for name in ("distributed", "zk16_linear"):
        ours = gl.blended_law(name, inner=mine, base_area=A_LO)
        builtin = gl.blended_law(name, inner="binomial", base_area=A_LO)
        P = np.array([17, 30, 45, 80]) / N
        assert np.array_equal(ours.sample(N, P, 0.3, size=4, seed=8), builtin.sample(N, P, 0.3, size=4, seed=8))
        assert np.array_equal(ours.sample_at(N, 30 / N, 0.3, x=[0.1, 0.7], y=0.2, seed=1),
                              builtin.sample_at(N, 30 / N, 0.3, x=[0.1, 0.7], y=0.2, seed=1))
        with pytest.raises(NotImplementedError):
            ours.pmf(N, 30 / N, 0.3)


def test_a_failing_custom_inner_law_is_reported():
    bad = gl.custom_law(lambda n, p, u: np.full(len(n), np.nan), n_uniforms=1, name="nan_law")
    with pytest.raises(ValueError, match="nan_law"):
        gl.blended_law("distributed", inner=bad, base_area=A_LO).sample(N, 30 / N, 0.3, size=10, seed=1)


@pytest.mark.parametrize("call, match", [
    (lambda: gl.blended_law("linear"), "known: distributed"),
    (lambda: gl.blended_law("distributed", level_ratio=1), "level_ratio = 1"),
    (lambda: gl.blended_law("distributed", base_area=-2), "base_area = -2"),
    (lambda: gl.blended_law("distributed", inner=3), "inner = 3"),
    (lambda: gl.blended_law("distributed", inner="nope"), "nope"),
    (lambda: gl.blended_law("roulette", epsilon=0.9), "epsilon = 0.9"),
    (lambda: gl.blended_law("nearest", epsilon=0.1), "epsilon"),
    (lambda: gl.blended_law("distributed").sample(-5, 0.1, 0.5, size=3, seed=1), "N = -5"),
    (lambda: gl.blended_law("distributed").sample(100, -0.1, 0.5, size=3, seed=1), "P = -0.1"),
    (lambda: gl.blended_law("distributed").sample(100, [0.1, np.nan], 0.5, size=2, seed=1), r"P\[1\] = nan"),
    (lambda: gl.blended_law("distributed").sample(100, 0.1, 1.5, size=3, seed=1), "p = 1.5"),
    (lambda: gl.blended_law("distributed").sample_at(100, 0.1, 0.5, x=np.inf, y=0, seed=1), "x = inf"),
    (lambda: gl.blended_law("distributed").pmf(np.nan, 0.1, 0.5), "N = nan"),
    (lambda: gl.blended_law("distributed").levels(0), "P = 0"),
])
def test_bad_input_names_the_parameter(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_mollified_roulette_has_no_exact_law_but_an_exact_mean():
    bl = gl.blended_law("roulette", base_area=A_LO)  # epsilon = 0.1 (KPT25)
    assert bl.params == {"epsilon": 0.1} and not bl.has_pmf
    with pytest.raises(NotImplementedError, match="continuous"):
        bl.pmf(N, 20 / N, 0.3)
    for w in (0.0, 0.05, 0.3):
        assert gl.roulette_keep_moments(w)[0] + gl.roulette_keep_moments(1 - w)[0] == pytest.approx(1, abs=1e-14)
