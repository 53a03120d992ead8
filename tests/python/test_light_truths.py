"""KPT25's points and WWH18's flakes lit by an extended light (docs/math/lighting.md#lighting-own-truths):
their exact counts per light or region against the methods' own expectations, the wrong variants
rejected, and the point-light limit.

Statistics: each check pools the counts of many disjoint footprints of one realization (fixed seeds).
WWH18's flakes are a Poisson process, so a light's pooled count is Poisson(E) and the regions' counts
independent Poisson; KPT25's are sums of independent per-cell terms in [0, 1] (roulette weights), whose
variance is at most their mean. The z-tests at |z| < 4.5 then fail falsely with probability below 7e-6
each (normal approximation, conservative for KPT25), the chi-square tests over regions at the 1 - 1e-5
quantile below 1e-5."""
import functools
import math

import numpy as np
import pytest
import scipy.stats

import glintlab as gl
from glintlab.api import light_truths as lt
from glintlab.api.glinty_ndf import KPT25
from glintlab.studies import lighting as LIGHTING_SECTION
from glintlab.validation import lighting as VL

Z_MAX = 4.5
N_PIXELS = 256
UV = np.stack([(np.arange(N_PIXELS) % 16) * 0.06 + 0.03, (np.arange(N_PIXELS) // 16) * 0.06 + 0.03], -1)
J = np.broadcast_to([0.02, 0.0, 0.0, 0.02], (N_PIXELS, 4))  # 400 facets per footprint at density 1e6

LIGHTS = {
    "cap": (lambda: gl.lights.cap((0.8, 0.0, 1.0), 0.1), (-0.8, 0.0, 1.0)),
    "rect": (lambda: gl.lights.rect((0.5, 0.2, 1.0), (0.3, 0.0, 0.0), (0.0, 0.2, 0.0)), (-0.4, -0.1, 1.0)),
    "disk": (lambda: gl.lights.disk((-0.3, 0.3, 1.0), (0.3, -0.3, -1.0), 0.1), (0.2, -0.3, 1.0)),
}


def _method(name, target="beckmann", alpha=0.3):
    if name == "kpt25":
        return KPT25(density=1e6, target=target, alpha=alpha), lt.kpt25_light_truth
    # dpf="exact": the truth's flakes never read the model's table, whose build costs a second.
    return gl.WWH18(density=1e6, target=target, alpha=alpha, dpf="exact"), lt.wwh18_light_truth


def _z(counts, expected):
    return (counts.sum() - expected.sum()) / math.sqrt(expected.sum())


@pytest.mark.parametrize("method", ["kpt25", "wwh18"])
@pytest.mark.parametrize("kind", sorted(LIGHTS))
def test_counts_match_the_methods_expectation(method, kind):
    make, wo = LIGHTS[kind]
    light = make()
    target = "ggx" if kind == "rect" else "beckmann"
    nd, truth = _method(method, target)
    expected = lt.expected_light_counts(nd, J, wo, light)
    assert abs(_z(truth(nd, UV, J, wo, light, seed=11).counts, expected)) < Z_MAX
    # The mirror direction replaced by the normal: the same check rejects it.
    assert abs(_z(truth(nd, UV, J, wo, light, seed=11, test="normal").counts, expected)) > Z_MAX
    # The light's solid angle left out (the point light's p density used as p): rejected.
    wrong = lt.expected_light_counts(nd, J, wo, light, method="point") / light.solid_angle
    assert abs(_z(truth(nd, UV, J, wo, light, seed=11).counts, wrong)) > Z_MAX


@pytest.mark.parametrize("method", ["kpt25", "wwh18"])
def test_region_counts_of_a_map(method):
    env = gl.lights.envmap("sky", regions=3)
    nd, truth = _method(method, "ggx", 0.5)
    wo = (0.5, 0.0, 1.0)
    expected = lt.expected_light_counts(nd, J, wo, env).sum(axis=0)
    assert expected.min() > 100  # each region's normal approximation holds
    limit = scipy.stats.chi2.ppf(1 - 1e-5, env.regions)

    def chi2(counts):
        return np.sum((counts.sum(axis=0) - expected) ** 2 / expected)

    assert chi2(truth(nd, UV, J, wo, env, seed=5).counts) < limit
    assert chi2(truth(nd, UV, J, wo, env, seed=5, test="normal").counts) > limit


@pytest.mark.parametrize("method", ["kpt25", "wwh18"])
def test_radiance_is_the_sum_of_the_lit_facets_radiance(method):
    nd, truth = _method(method)
    lights = [gl.lights.cap((0.3, 0.0, 1.0), 0.2, radiance=2.0),
              gl.lights.rect((-0.6, 0.0, 1.0), (0.3, 0.0, 0.0), (0.0, 0.3, 0.0), radiance=5.0)]
    t = truth(nd, UV[:16], J[:16], (-0.2, 0.0, 1.0), lights, seed=2)
    assert t.counts.shape == (16, 2) and np.all(t.counts.sum(axis=0) > 0)
    assert np.allclose(t.radiance, t.counts @ [2.0, 5.0], rtol=1e-12)
    env = gl.lights.envmap("sky", regions=3)
    t = truth(nd, UV[:16], J[:16], (0.5, 0.0, 1.0), env, seed=2, radiance="regions")
    assert np.allclose(t.radiance, t.counts @ env.region_radiance, rtol=1e-12)


@pytest.mark.parametrize("method", ["kpt25", "wwh18"])
def test_point_light_limit(method):
    """Glints as normals: as the cap shrinks, E[count] / solid angle tends to the point light's (L2) as a^2,
    and the pooled counts of a small cap divided by its solid angle match the point light's expectation.
    (The lobes' own limit: test_light_lobes.py.)"""
    nd, truth = _method(method, "beckmann", 0.1)
    truth = functools.partial(truth, lit_as="normal")
    wo, centre = (-0.2, 0.1, 1.0), (0.25, -0.05, 1.0)
    errors = []
    for a in (0.08, 0.04, 0.02, 0.01):
        cap = gl.lights.cap(centre, a)
        exact = lt.expected_light_counts(nd, J[:1], wo, cap, rel_tol=1e-9, lit_as="normal")[0, 0]
        point = lt.expected_light_counts(nd, J[:1], wo, cap, method="point")[0, 0]
        errors.append(abs(exact / point - 1))
    assert all(e1 < e0 / 3 for e0, e1 in zip(errors, errors[1:])) and errors[-1] < 2e-3
    cap = gl.lights.cap(centre, 0.03)
    point = lt.expected_light_counts(nd, J, wo, cap, method="point")
    exact = lt.expected_light_counts(nd, J, wo, cap, lit_as="normal")
    counts = truth(nd, UV, J, wo, cap, seed=9).counts
    assert point.sum() > 300
    bias = abs(exact.sum() - point.sum())
    assert abs(counts.sum() - point.sum()) < Z_MAX * math.sqrt(point.sum()) + bias
    # Without the solid angle the point light's expectation is off by 1 / Omega: rejected.
    assert abs(counts.sum() - point.sum() / cap.solid_angle) > Z_MAX * math.sqrt(point.sum()) + bias


@pytest.mark.parametrize("method", ["kpt25", "wwh18"])
def test_one_realization_per_seed_whatever_the_threads(method):
    nd, truth = _method(method)
    light, wo = LIGHTS["cap"][0](), LIGHTS["cap"][1]
    before = gl.get_num_threads()
    try:
        gl.set_num_threads(1)
        a = truth(nd, UV[:8], J[:8], wo, light, seed=4)
        gl.set_num_threads(2)
        b = truth(nd, UV[:8], J[:8], wo, light, seed=4)
    finally:
        gl.set_num_threads(before)
    c = truth(nd, UV[:8], J[:8], wo, light, seed=5)
    assert np.array_equal(a.counts, b.counts) and np.array_equal(a.radiance, b.radiance)
    assert not np.array_equal(a.counts, c.counts)
    share = math.pi / 4 if method == "kpt25" else 1.0  # KPT25: the points of the disk U only
    assert abs(a.facets.mean() / (1e6 * 0.02**2 * share) - 1) < 0.2


def test_bad_inputs_are_named():
    nd, truth = _method("wwh18")
    light = LIGHTS["cap"][0]()
    with pytest.raises(ValueError, match="test"):
        truth(nd, UV[:1], J[:1], (0, 0, 1), light, test="h")
    with pytest.raises(ValueError, match="wo"):
        truth(nd, UV[:1], J[:1], (0, 0, -1), light)
    with pytest.raises(ValueError, match="light"):
        truth(nd, UV[:1], J[:1], (0, 0, 1), "sun")
    with pytest.raises(ValueError, match="ndf"):
        lt.kpt25_light_truth(nd, UV[:1], J[:1], (0, 0, 1), light)
    with pytest.raises(ValueError, match="ndf"):
        lt.expected_light_counts(KPT25(density=1e6, alpha=(0.2, 0.4)), J[:1], (0, 0, 1), light)


def test_the_report_table_passes_and_names_its_columns():
    table = VL.own_truth_table(seed=0)
    assert list(table.columns) == LIGHTING_SECTION.TABLE["lighting_own_truths"]
    assert table["pass"].all() and len(table) == 8
    lights = table[table.light != "sky"]
    assert (lights.z_no_solid_angle.abs() > Z_MAX).all() and (table.z_normal_variant.abs() > Z_MAX).all()
