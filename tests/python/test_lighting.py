"""Glints under extended lights (docs/math/lighting.md): the exact reflection probability against closed forms
and Monte Carlo, its approximations and the point-light limit, the facet truth against the exact laws, and
the environment map's multinomial; each statistical check also rejects its deliberately wrong variant.

Thresholds: a chi-square passes at p > 1e-3 (its false-failure rate; the seeds are fixed, so a run is
deterministic) and a wrong variant must be rejected at p < 1e-6."""
import itertools
import math
import time

import numpy as np
import pytest

import glintlab as gl
from glintlab.api import lighting as L
from glintlab.validation import lighting as VL

PASS, REJECT = 1e-3, 1e-6


def _unit(theta_deg, phi_deg=0.0):
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


@pytest.mark.parametrize("target", ["beckmann", "ggx"])
def test_exact_p_of_a_cap_about_the_normal_is_its_closed_form(target):
    # Seen from the normal, wi = reflect(n, m) lies at twice m's polar angle: p = P(theta_m <= a / 2).
    for alpha in (0.05, 0.3, 1.0):
        for a in (0.02, 0.3, math.pi / 2):
            t = math.tan(a / 2) ** 2
            ref = -math.expm1(-t / alpha**2) if target == "beckmann" else t / (t + alpha**2)
            p = gl.reflection_probability(target, alpha, (0, 0, 1), gl.lights.cap((0, 0, 1), a))
            assert p == pytest.approx(ref, rel=1e-6)


def test_exact_p_against_monte_carlo_facets():
    # 4e5 normals drawn from D(m)(m.n), mirrored: the share in the rectangle has standard error
    # sqrt(p q / N); |difference| < 5 SE fails by chance with probability 6e-7.
    light = gl.lights.rect((0.3, 0.1, 1.0), (0.5, 0.0, 0.1), (0.0, 0.4, 0.0))
    wo = np.array([-0.2, -0.1, 1.0]) / math.sqrt(1.05)
    rng = np.random.default_rng(7)
    u, v = rng.random(400_000), rng.random(400_000)
    tan2 = 0.3**2 * u / (1 - u)
    c = 1 / np.sqrt(1 + tan2)
    s = np.sqrt(1 - c * c)
    m = np.stack([s * np.cos(2 * np.pi * v), s * np.sin(2 * np.pi * v), c], axis=-1)
    d = m @ wo
    wi = 2 * d[:, None] * m - wo
    hit = (d > 0) & (wi[:, 2] > 0) & light.contains(wi)
    p_mc, p = hit.mean(), gl.reflection_probability("ggx", 0.3, wo, light)
    assert abs(p_mc - p) < 5 * math.sqrt(p * (1 - p) / len(u))


def test_point_light_limit_and_todays_point_p():
    table = VL.point_limit_table(half_angles=(0.03, 1e-3, 1e-4))
    # p_exact / (density at the centre x solid angle) -> 1 as the cap shrinks (error ~ a^2).
    assert abs(table.ratio.iloc[-1] - 1) < 1e-6
    assert abs(table.ratio.iloc[1] - 1) < 1e-4
    # The point p is DB23's p = R D(h) / D(n) at R = D(n) (h.n) solid_angle / (4 wo.h): today's law.
    assert np.allclose(table.p_point, table.p_db23, rtol=1e-12, atol=0)


def test_ltc_likelihood_fit_preserves_the_upper_hemisphere_and_approximations_are_close_for_small_lights():
    wo = _unit(40.0)
    whole = gl.lights.cap((0, 0, 1), math.pi / 2)
    exact = gl.reflection_probability("ggx", 0.3, wo, whole)
    assert gl.reflection_probability("ggx", 0.3, wo, whole, "ltc", ltc_fit="ml") == pytest.approx(exact, rel=0.02)
    # The value fits keep Heitz et al.'s norm: the LTC's mass below the horizon (a few %) is lost.
    for fit in ("values", "brdf"):
        assert gl.reflection_probability("ggx", 0.3, wo, whole, "ltc", ltc_fit=fit) == pytest.approx(exact, rel=0.1)
    small = gl.lights.cap(_unit(45.0, 180.0), 0.01)
    for method in ("cap", "point"):
        assert gl.reflection_probability("ggx", 0.3, wo, small, method) == pytest.approx(
            gl.reflection_probability("ggx", 0.3, wo, small), rel=1e-3)
    with pytest.raises(ValueError, match="fit"):
        gl.reflection_probability("ggx", 0.3, wo, small, "ltc", ltc_fit="heitz")


#: The value fit's median error over the configurations below measures 5.2 %, the likelihood fit's 15 % and
#: the BRDF-lobe reading's 9 %: the bound sits between, 1.5 times the value fit's, so a change of the
#: optimiser's convergence does not fail it while the likelihood fit does. The fits are deterministic (fixed
#: samples and start), so the test has no false-failure rate.
LTC_MEDIAN_TOLERANCE = 0.08


def _ltc_median_error(fit):
    errors = []
    for alpha, a, el, vw in itertools.product((0.2, 0.5), (0.05, 0.2), (20.0, 45.0), (10.0, 40.0, 70.0)):
        light, wo = gl.lights.cap(_unit(el, 180.0), a), _unit(vw)
        exact = gl.reflection_probability("ggx", alpha, wo, light)
        if exact > 1e-6:
            errors.append(abs(gl.reflection_probability("ggx", alpha, wo, light, "ltc", ltc_fit=fit) / exact - 1))
    return float(np.median(errors))


def test_ltc_value_fit_is_within_its_tolerance_and_the_likelihood_fit_is_not():
    assert _ltc_median_error("values") < LTC_MEDIAN_TOLERANCE
    assert _ltc_median_error("ml") > LTC_MEDIAN_TOLERANCE


def test_chebyshev_grid_refines_to_1e_6_for_beckmann_alpha_1():
    views = np.array([[np.sin(t) * np.cos(f), np.sin(t) * np.sin(f), np.cos(t)]
                      for t in np.linspace(0.2, 1.2, 40) for f in np.linspace(-0.8, 0.8, 40)])
    light = gl.lights.cap((-0.6, 0.0, 0.8), 0.2)
    grid = L.ProbabilityGrid("beckmann", 1.0, light, views, nodes=5, tolerance=1e-6)
    assert grid.converged and grid.refinement_error <= 1e-6
    assert grid.error(views, samples=256, seed=4)["max_rel_error_p_above_1e-3_max"] < 1e-6
    # The same nodes through uniform bicubic splines miss the target by the same measure (the check can fail).
    spline = L.ProbabilityGrid("beckmann", 1.0, light, views, nodes=grid.nodes, interpolation="spline")
    assert spline.error(views, samples=256, seed=4)["max_rel_error_p_above_1e-3_max"] > 1e-6


def test_exact_p_speed_per_view_and_light():
    light = gl.lights.rect((0.2, 0.1, 1.0), (0.5, 0.0, 0.0), (0.0, 0.3, 0.1))
    views = np.stack([_unit(t, 30.0 * t) for t in np.linspace(5, 70, 100)])
    t0 = time.process_time()
    gl.reflection_probability("beckmann", 0.2, views, light)
    assert (time.process_time() - t0) / len(views) < 2e-3  # the goal is 1 ms; twice that for a loaded machine


def _cap_counts(light_half_angle=0.1, seed=3):
    wo = _unit(30.0)
    light = gl.lights.cap(wo * [-1, -1, 1], light_half_angle)
    k, _, m = VL.facet_samples("ggx", 0.2, light, wo, side=128, cells=4, realizations=2, seed=seed)
    return wo, light, k[:, 0], m


def test_facet_truth_is_binomial_at_the_exact_p_and_rejects_p_without_the_solid_angle():
    wo, light, k, m = _cap_counts()
    p = gl.reflection_probability("ggx", 0.2, wo, light)
    assert gl.chi2_test(k, gl.law("binomial").pmf(m, p)).pvalue > PASS
    # The wrong variant: the point light's density at the centre, not multiplied by the solid angle.
    p_wrong = min(float(L.density("ggx", 0.2, wo, light.center)), 1.0)
    assert gl.chi2_test(k, gl.law("binomial").pmf(m, p_wrong)).pvalue < REJECT


def test_facet_truth_point_limit_is_todays_ground_truth():
    # A light of 0.02 rad: the facets' count has the law of today's stratified ground truth at the same p.
    wo, light, k, m = _cap_counts(0.02, seed=11)
    p = float(gl.reflection_probability("ggx", 0.2, wo, light))
    fp, centres, _ = VL.whole_cell_footprints(128, 4)
    truth = gl.ground_truth("stratified", 128**2, fp[0], p, center=centres[0]).pmf()
    assert gl.chi2_test(k, truth).pvalue > PASS
    assert gl.chi2_test(k, gl.law("binomial").pmf(m, 0.5 * p)).pvalue < REJECT


def test_region_probabilities_add_up_to_the_upper_hemisphere():
    env = gl.lights.envmap("sky", regions=3)
    wo = _unit(35.0, 20.0)
    p = gl.reflection_probability("ggx", 0.3, wo, env)
    whole = gl.reflection_probability("ggx", 0.3, wo, gl.lights.cap((0, 0, 1), math.pi / 2))
    assert p.sum() == pytest.approx(whole, rel=1e-6)
    assert np.all(p > 0)


def test_envmap_facets_match_the_filtered_map_and_reject_the_unfiltered_one():
    env = gl.lights.envmap("sky", regions=3)
    table, partition = VL.envmap_counts(env, "ggx", 0.3, 30.0, side=128, cells=3, realizations=1, seed=0,
                                        schemes=())
    facets = table.set_index("method").chi2_pvalue
    assert facets["exact"] > PASS
    assert facets["filtered"] > PASS  # KK25's approximation, within what 1764 footprints can see
    assert facets["unfiltered"] < REJECT
    assert partition["rel_partition_error"] < 0.05


def test_multinomial_chain_is_exact_and_independent_binomials_are_rejected():
    p, m = np.array([0.3, 0.3, 0.2]), 10
    pmf = VL.multinomial_pmf(m, p)
    chain = gl.multinomial_counts(m, p, "binomial", "chain", size=5000, seed=1)
    tree = gl.multinomial_counts(m, p, "binomial", "tree", size=5000, seed=2)
    wrong = gl.multinomial_counts(m, p, "binomial", "independent", size=5000, seed=3)
    assert VL.joint_chi2(chain, pmf)[2] > PASS
    assert VL.joint_chi2(tree, pmf)[2] > PASS
    assert VL.joint_chi2(wrong, pmf)[2] < REJECT
    # Its marginals are right: only the joint test sees the wrong variant.
    assert gl.chi2_test(wrong[:, 0], gl.law("binomial").pmf(m, 0.3)).pvalue > PASS


def test_bad_inputs_are_refused_by_name():
    with pytest.raises(ValueError, match="half_angle"):
        gl.lights.cap((0, 0, 1), 0.0)
    with pytest.raises(ValueError, match="method"):
        gl.reflection_probability("ggx", 0.2, (0, 0, 1), gl.lights.cap((0, 0, 1), 0.1), "nope")
    with pytest.raises(ValueError, match="wo"):
        gl.reflection_probability("ggx", 0.2, (0, 0, -1), gl.lights.cap((0, 0, 1), 0.1))
    with pytest.raises(ValueError, match="density"):
        gl.facet_truth("ggx", 0.2, 1000, [gl.Rect(0.1, 0.1)], [(0.5, 0.5)], (0, 0, 1), gl.lights.cap((0, 0, 1), 0.1))
    with pytest.raises(ValueError, match="image"):
        gl.lights.envmap(np.full((8, 16), -1.0))
    with pytest.raises(ValueError, match="scheme"):
        gl.multinomial_counts(4, [0.2], scheme="nope")


def test_same_seed_same_facets_and_probabilities_whatever_the_threads():
    uv, J, wo = VL.plane_pixels(16, 10)
    fps = [gl.Ellipse.from_uv_derivatives(*j) for j in J.reshape(-1, 4)]
    light = gl.lights.rect((1.2, 0.0, 1.5), (0.4, 0.0, -0.3), (0.0, 0.6, 0.0))
    runs = []
    threads = gl.get_num_threads()
    try:
        for t in (1, 2):
            gl.set_num_threads(t)
            f = gl.facet_truth("beckmann", 0.3, 512**2, fps, uv.reshape(-1, 2), wo.reshape(-1, 3), light, seed=5)
            runs.append((f.counts, f.facets, gl.reflection_probability("beckmann", 0.3, wo, light)))
    finally:
        gl.set_num_threads(threads)
    for a, b in zip(*runs):
        assert np.array_equal(a, b)
    assert runs[0][1].min() > 0  # every footprint holds facets


def test_user_maps_load_from_npy_and_pfm(tmp_path):
    img = gl.lights.sky_image(16, 32)
    np.save(tmp_path / "sky.npy", img)
    rgb = np.repeat(img[..., None], 3, axis=-1).astype("<f4")
    with open(tmp_path / "sky.pfm", "wb") as f:  # PFM: bottom row first, little-endian when the scale is < 0
        f.write(b"PF\n32 16\n-1.0\n")
        f.write(np.ascontiguousarray(np.flipud(rgb)).tobytes())
    a = gl.lights.envmap(tmp_path / "sky.npy", regions=3)
    b = gl.lights.envmap(str(tmp_path / "sky.pfm"), regions=3)
    assert np.array_equal(a.labels, b.labels)
    assert np.allclose(a.region_radiance, b.region_radiance, rtol=1e-6)
    with pytest.raises(ValueError, match="path"):
        gl.lights.envmap(tmp_path / "missing.exr")


def test_a_small_caps_solid_angle_keeps_its_digits():
    # 2 pi (1 - cos a) loses about 1e-6 relative at a = 1e-5 to the cancellation of 1 - cos a; the light's
    # solid angle is written without it.
    for a in (1e-5, 1e-3, 0.3, 1.5):
        exact = 4 * math.pi * math.sin(a / 2) ** 2
        assert abs(gl.lights.cap((0.0, 0.0, 1.0), a).solid_angle / exact - 1) < 1e-14, a
