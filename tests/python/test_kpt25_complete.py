"""KPT25 as printed, completed (docs/math/glinty_ndf.md): the like-for-like density mapping with DB23
(#glinty-matched). The map T's own tests (and the Lambert option's) are in test_kpt25_sampling.py.

Statistical checks: fixed seeds, |z| < 4.5 on means of >= 8000 pixels (two-sided false-failure rate
7e-6 per check under the normal approximation); each is shown to reject a deliberately wrong variant.
"""
import math

import numpy as np
import pytest

import glintlab as gl
from glintlab.api.glinty_ndf import facet_counts

Z = 4.5


def z_score(samples, target):
    return (samples.mean() - target) / (samples.std(ddof=1) / math.sqrt(samples.size))


def two_sample_z(a, b):
    return (a.mean() - b.mean()) / math.sqrt(a.var(ddof=1) / a.size + b.var(ddof=1) / b.size)


@pytest.mark.parametrize("target,alpha", [("beckmann", 0.5), ("ggx", 0.3)])
def test_matched_density_gives_db23s_visible_glints_at_every_h(target, alpha):
    N, R, a_star = 1e6, 0.5, 0.02
    kp = gl.matched_density(N, a_star, target, alpha, R)
    nd = gl.glinty_ndf("kpt25", density=kp, target=target, alpha=alpha, alpha_star=a_star, epsilon=0.0)
    assert nd.db23_density(R) == pytest.approx(N, rel=1e-14)
    rng = np.random.default_rng(5)
    n = 4000
    J = np.tile([0.003, 0.0005, -0.0004, 0.0025], (n, 1))
    wrong = gl.glinty_ndf("kpt25", density=1.25 * kp, target=target, alpha=alpha, alpha_star=a_star, epsilon=0.0)
    for theta in (0.0, 0.3, 0.55):  # T(h) far enough from the rim of U for the lobe disk to lie inside
        h = np.tile([math.sin(theta) * 0.8, math.sin(theta) * 0.6, math.cos(theta)], (n, 1))
        uv = rng.uniform(-3, 3, (3 * n, 2))
        # KPT25: visible glints of three realizations against their exact mean; the formula with a
        # disk of radius 2.2 sigma (21 % more area) is rejected.
        c = np.concatenate([nd.visible_glints(uv[s * n:(s + 1) * n], J, h, seed=s) for s in range(3)])
        e = nd.expected_visible_glints(J[0], h[0])
        assert abs(z_score(c, e)) < Z, (theta, c.mean(), e)
        assert abs(z_score(c, nd.expected_visible_glints(J[0], h[0], radius=2.2))) > Z
        # DB23: the reflecting facets of the footprint (explicit stratified facets) against N P p.
        d = gl.db23_visible_glints(N, target, alpha, J[0], h[0], R)
        p, _ = gl.ndf(target, alpha).success_probability(np.array([h[0, 2]]), R)
        K = facet_counts(uv[:n], J, p[0], N, seed=7)[0]
        assert abs(z_score(K, d)) < Z, (theta, K.mean(), d)
        # Like for like: the formulas agree to rounding, the two methods' sampled counts agree, and a
        # KPT25 density 25 % off is rejected against the same facets.
        assert e == pytest.approx(d, rel=1e-12)
        assert abs(two_sample_z(c, K)) < Z
        cw = np.concatenate([wrong.visible_glints(uv[s * n:(s + 1) * n], J, h, seed=s) for s in range(3)])
        assert abs(two_sample_z(cw, K)) > Z, (theta, two_sample_z(cw, K))


def test_matched_density_fails_at_the_rim_as_documented():
    # Near the rim of U part of the lobe disk lies outside U: KPT25 sees fewer visible glints than DB23
    # (the energy lost at grazing half vectors); the exact formula still matches the sampled count.
    N, R, a_star = 1e6, 0.5, 0.02
    nd = gl.glinty_ndf("kpt25", density=gl.matched_density(N, a_star, "beckmann", 0.5, R), alpha=0.5,
                       alpha_star=a_star, epsilon=0.0)
    n = 8000
    J = np.tile([0.003, 0.0, 0.0, 0.003], (n, 1))
    h = np.tile([math.sin(0.8), 0.0, math.cos(0.8)], (n, 1))
    c = nd.visible_glints(np.random.default_rng(2).uniform(0, 1, (n, 2)), J, h, seed=4)
    e = nd.expected_visible_glints(J[0], h[0])
    assert abs(z_score(c, e)) < Z
    assert e / gl.db23_visible_glints(N, "beckmann", 0.5, J[0], h[0], R) < 0.9


def test_matched_density_bad_input():
    with pytest.raises(ValueError, match="alpha_star"):
        gl.matched_density(1e6, 0.0)
    with pytest.raises(ValueError, match="R"):
        gl.matched_density(1e6, 0.02, R=1.5)
    with pytest.raises(ValueError, match="density"):
        gl.matched_density(-1.0, 0.02)
    nd = gl.glinty_ndf("kpt25", density=1e6)
    with pytest.raises(ValueError, match="radius"):
        nd.visible_glints([0.0, 0.0], [1e-3, 0, 0, 1e-3], [0, 0, 1.0], radius=0.0)
    with pytest.raises(ValueError, match="filter"):
        gl.glinty_ndf("kpt25", density=1e6, filter=0.1).visible_glints([0.0, 0.0], [1e-3, 0, 0, 1e-3], [0, 0, 1.0])
