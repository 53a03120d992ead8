"""KPT25's lobes and WWH18's cones integrated over an extended light (docs/math/lighting.md#lighting-lobes):
the point-light limit (the lobes' count over the light's solid angle tends to the method's own point-light
value), the large-light limit (lobes well inside the light count as their centres), the product rules'
error against finer rules, the expected counts with lobes and the unnormalised lobe rejected.

Statistics: the z-tests pool disjoint footprints of one realization (fixed seeds); a lobe's share is in
[0, 1], so a pooled count's variance is at most its mean and |z| < 4.5 fails falsely with probability
below 7e-6 per check (normal approximation). The limits are deterministic for a fixed realization."""
import math

import numpy as np
import pytest

import glintlab as gl
from glintlab.api import light_truths as lt
from glintlab.api.glinty_ndf import KPT25

Z_MAX = 4.5
UV16 = np.stack([(np.arange(16) % 4) * 0.06 + 0.03, (np.arange(16) // 4) * 0.06 + 0.03], -1)
UV64 = np.stack([(np.arange(64) % 8) * 0.06 + 0.03, (np.arange(64) // 8) * 0.06 + 0.03], -1)
J16 = np.broadcast_to([0.02, 0.0, 0.0, 0.02], (16, 4))  # 400 points per footprint at density 1e6
J64 = np.broadcast_to([0.02, 0.0, 0.0, 0.02], (64, 4))


def _method(name, alpha=0.1, **kw):
    if name == "kpt25":
        return KPT25(density=1e6, alpha=alpha, **kw), lt.kpt25_light_truth
    cone = "outgoing" if name == "wwh18_outgoing" else "half_vector"
    return gl.WWH18(density=1e6, alpha=alpha, dpf="exact", cone=cone, **kw), lt.wwh18_light_truth


def _cap_omega(a):
    return 4 * math.pi * math.sin(a / 2) ** 2  # no cancellation as a -> 0 (2 pi (1 - cos a) loses digits)


def test_kpt25_point_light_limit_is_the_glinty_ndf_at_a_rate_a_squared():
    """Count / Omega of a cap of half-angle a tends to K_P (pi/4) (h.n) / (4 wo.h) x the glinty D of the same
    points at the cap's centre: the lobe is smooth, so the error halves twice per halving of a."""
    nd, truth = _method("kpt25")
    wo, centre = (-0.2, 0.1, 1.0), (0.25, -0.05, 1.0)
    limit = lt.point_light_density(nd, UV16, J16, wo, centre, seed=3).sum()
    assert limit > 1e3
    errors = []
    for a in (0.04, 0.02, 0.01, 0.005):
        counts = truth(nd, UV16, J16, wo, gl.lights.cap(centre, a), seed=3).counts.sum()
        errors.append(abs(counts / _cap_omega(a) / limit - 1))
    rates = [e0 / e1 for e0, e1 in zip(errors, errors[1:])]
    assert all(3.5 < r < 4.5 for r in rates) and errors[-1] < 5e-4
    # The lobe without its normalisation (eq. 4's printed 1D factor) misses the limit by far.
    wrong = truth(nd, UV16, J16, wo, gl.lights.cap(centre, 0.005), seed=3, test="unnormalised").counts.sum()
    assert abs(wrong / _cap_omega(0.005) / limit - 1) > 0.5


@pytest.mark.parametrize("method", ["wwh18", "wwh18_outgoing"])
def test_wwh18_point_light_limit_is_the_cone_count(method):
    """Count / Omega tends to the truth's cone count at the cap's centre over sigma(gamma) (and 4 wo.h for the
    cone of half vectors), exactly once no cone's edge crosses the cap: the chance that one does is O(a). Tiny
    footprints (about 4 flakes each) make most pixels exact at a = 1e-4 (to the O(a^2) of the Jacobian and
    the cap's edge, which Light::exit finds to about 1e-16 / a^2), and their share grows as a shrinks."""
    nd, truth = _method(method)
    wo, centre = (-0.2, 0.1, 1.0), (0.25, -0.05, 1.0)
    uv = np.stack([(np.arange(256) % 16) * 0.06 + 0.03, (np.arange(256) // 16) * 0.06 + 0.03], -1)
    Js = np.broadcast_to([0.002, 0.0, 0.0, 0.002], (256, 4))
    limit = lt.point_light_density(nd, uv, Js, wo, centre, seed=3)
    assert np.sum(limit > 0) > 100

    def exact_share(a, test="mirror"):
        counts = truth(nd, uv, Js, wo, gl.lights.cap(centre, a), seed=3, test=test).counts[:, 0] / _cap_omega(a)
        return np.mean(np.abs(counts - limit) <= 1e-6 * limit.max())

    shares = [exact_share(a) for a in (1e-2, 1e-3, 1e-4)]
    assert shares[0] < shares[1] < shares[2] and shares[2] > 0.95
    assert exact_share(1e-4, "unnormalised") < 0.5  # its lit pixels all miss (only the dark ones agree)


@pytest.mark.parametrize("method, wide, narrow", [("kpt25", dict(alpha_star=0.02), dict(alpha_star=0.005)),
                                                  ("wwh18", dict(gamma=6.0), dict(gamma=1.5))])
def test_large_light_limit_is_the_single_normal_count(method, wide, narrow):
    """Under a cap much larger than the lobes, each lobe inside it counts 1, as its centre does: the lobe and
    normal counts differ by the lobes across the cap's edge, and the difference shrinks with the lobe."""
    cap, wo = gl.lights.cap((0.3, 0.0, 1.0), 0.4), (-0.3, 0.0, 1.0)
    diffs = []
    for kw in (wide, narrow):
        nd, truth = _method(method, alpha=0.3, **kw)
        normal = truth(nd, UV64, J64, wo, cap, seed=2, lit_as="normal").counts.sum()
        lobes = truth(nd, UV64, J64, wo, cap, seed=2).counts.sum()
        diffs.append(abs(lobes / normal - 1))
    assert diffs[1] < 5e-3 and (diffs[0] > 4 * diffs[1] or diffs[0] < 2e-3)


@pytest.mark.parametrize("method, light", [("kpt25", "cap"), ("kpt25", "rect"), ("kpt25", "sky"), ("wwh18", "cap"),
                                           ("wwh18", "rect"), ("wwh18", "sky")])
def test_rules_against_finer_rules(method, light):
    """The product rules' error: the default (8 rings x 12 sectors) against 32 x 48, pooled over footprints,
    below 2e-3 of the count (lobes straddling an edge carry it; a lobe inside is integrated to ~1e-4)."""
    nd, truth = _method(method, alpha=0.3)
    make = {"cap": lambda: gl.lights.cap((0.8, 0.0, 1.0), 0.1),
            "rect": lambda: gl.lights.rect((0.5, 0.2, 1.0), (0.3, 0.0, 0.0), (0.0, 0.2, 0.0)),
            "sky": lambda: gl.lights.envmap("sky", regions=3)}[light]
    wo = (-0.6, 0.0, 1.0)
    coarse = truth(nd, UV16, J16, wo, make(), seed=7).counts.sum(axis=0)
    fine = truth(nd, UV16, J16, wo, make(), seed=7, nodes=(32, 48)).counts.sum(axis=0)
    assert np.all(np.abs(coarse - fine) <= 2e-3 * fine.sum())


def test_outgoing_cone_counts_match_their_expectation():
    nd, truth = _method("wwh18_outgoing", alpha=0.3)
    uv = np.stack([(np.arange(256) % 16) * 0.06 + 0.03, (np.arange(256) // 16) * 0.06 + 0.03], -1)
    cap, wo = gl.lights.cap((0.8, 0.0, 1.0), 0.1), (-0.8, 0.0, 1.0)
    J256 = np.broadcast_to(J16[0], (256, 4))
    expected = lt.expected_light_counts(nd, J256, wo, cap).sum()
    assert abs(truth(nd, uv, J256, wo, cap, seed=4).counts.sum() - expected) < Z_MAX * math.sqrt(expected)
    wrong = truth(nd, uv, J256, wo, cap, seed=4, test="unnormalised").counts.sum()
    assert abs(wrong - expected) > Z_MAX * math.sqrt(expected)


def test_kpt25_rim_loss_is_in_the_expectation():
    """Beckmann's lobes near U's rim (sigma -> 0 there) lose mass outside U: E[count] under the sky is p less
    that loss (L8); the pooled counts match it, and not the loss-free p (the check that can fail)."""
    nd, truth = _method("kpt25", alpha=0.3, target="beckmann", alpha_star=0.04)
    env, wo = gl.lights.envmap("sky", regions=3), (0.5, 0.0, 1.0)
    uv = np.stack([(np.arange(128) % 12 + 0.5) / 12, (np.arange(128) // 12 + 0.5) / 12], -1)
    Jb = np.broadcast_to(J16[0], (128, 4))
    counts = truth(nd, uv, Jb, wo, env, seed=0).counts.sum()
    with_loss = lt.expected_light_counts(nd, Jb, wo, env).sum()
    without = lt.expected_light_counts(nd, Jb, wo, env, lit_as="normal").sum()
    assert abs(counts - with_loss) < Z_MAX * math.sqrt(with_loss)
    assert abs(counts - without) > Z_MAX * math.sqrt(without)


def test_bad_lobe_options_are_named():
    nd, truth = _method("kpt25")
    cap = gl.lights.cap((0.3, 0.0, 1.0), 0.1)
    with pytest.raises(ValueError, match="lit_as"):
        truth(nd, UV16[:1], J16[:1], (0, 0, 1), cap, lit_as="cone")
    with pytest.raises(ValueError, match="nodes"):
        truth(nd, UV16[:1], J16[:1], (0, 0, 1), cap, nodes=(0, 12))
    with pytest.raises(ValueError, match="test"):
        truth(nd, UV16[:1], J16[:1], (0, 0, 1), cap, lit_as="normal", test="unnormalised")
    with pytest.raises(ValueError, match="lit_as"):
        lt.expected_light_counts(nd, J16, (0, 0, 1), cap, lit_as="cone")
