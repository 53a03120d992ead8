"""Target NDFs: normalisation, the peak ratio max D(h)/D(n) (derived, checked on a dense grid), p clamping."""
import math

import numpy as np
import pytest
from scipy.integrate import quad

import glintlab as gl


@pytest.mark.parametrize("name", ["beckmann", "ggx"])
@pytest.mark.parametrize("alpha", [0.05, 0.3, 1.0, 1.7])
def test_projected_area_integrates_to_one(name, alpha):
    d = gl.ndf(name, alpha)
    value = quad(lambda t: d.D(math.cos(t)) * math.cos(t) * math.sin(t) * 2 * math.pi, 0, math.pi / 2,
                 points=[min(alpha, 1.0) * 0.5], limit=400)[0]
    assert value == pytest.approx(1.0, abs=1e-7)


@pytest.mark.parametrize("name", ["beckmann", "ggx"])
@pytest.mark.parametrize("alpha", [0.3, 0.7071, 1.0, 1.5])
def test_max_ratio_is_the_supremum(name, alpha):
    d = gl.ndf(name, alpha)
    th = np.linspace(0, math.pi / 2 - 1e-7, 400_001)
    dense = (d.D(np.cos(th)) / d.D_normal).max()
    assert dense == pytest.approx(d.max_ratio, rel=1e-6)


def test_db23_table1_setup_needs_clamping():
    # Beckmann, alpha = 1 (DB23 section 7.1): D(h)/D(n) peaks at 4/e at tan^2 = 1 (45 degrees).
    d = gl.ndf("beckmann", 1.0)
    assert d.max_ratio == pytest.approx(4 / math.e)
    p, clamped = d.success_probability(np.cos([0.0, math.pi / 4]), R=1.0)
    assert p[0] == pytest.approx(1.0) and not clamped[0]
    assert p[1] == 1.0 and clamped[1]
    p, clamped = d.success_probability(math.cos(math.pi / 4), R=0.5)
    assert p == pytest.approx(0.5 * 4 / math.e) and not clamped


def test_below_horizon_is_zero_and_bad_input_is_named():
    assert gl.ndf("ggx", 0.5).D(-0.2) == 0.0
    with pytest.raises(ValueError, match="ndf = 'phong'"):
        gl.ndf("phong", 0.5)
    with pytest.raises(ValueError, match="alpha = 0.0"):
        gl.ndf("ggx", 0.0)
    with pytest.raises(ValueError, match="R = 1.5"):
        gl.ndf("ggx", 0.5).success_probability(1.0, R=1.5)
