"""Anisotropic grid schemes (docs/math/grids.md): weights, evaluation counts, exact laws and bad input.

Statistical checks use fixed seeds; each p-value threshold is 1e-4 (a false failure rate of 1e-4 per
check), and each check is shown to fail on a deliberately wrong law.
"""
import math
from collections import defaultdict

import numpy as np
import pytest

import glintlab as gl
from glintlab.api.grids import IMAGE_CONFIGS, configured_counter
from glintlab.studies import aniso as aniso_study

N = 1024.0**2
A0 = 1.0 / N
DEG = math.pi / 180


def counter(scheme, **kw):
    return gl.aniso_counter(scheme, inner=kw.pop("inner", "binomial"), base_area=A0, **kw)


def weights(c, P, r, phi):
    """Weight per grid (scale, ratio, orientation), zero weights dropped."""
    t = c.terms(N, P, r, phi)
    out = defaultdict(float)
    for row in t.itertuples():
        out[(row.scale_level, row.ratio_level, row.orientation)] += row.weight
    return {k: v for k, v in out.items() if v > 1e-15}


def l1(a, b):
    return sum(abs(a.get(k, 0.0) - b.get(k, 0.0)) for k in set(a) | set(b))


def area_for(minor_side_squared, r):
    """Footprint area whose equivalent rectangle has this minor side squared (P = r m^2)."""
    return minor_side_squared * r


RNG = np.random.default_rng(5)
SHAPES = [(10 ** RNG.uniform(0, 3) / N, 10 ** RNG.uniform(0, math.log10(200)), RNG.uniform(0, math.pi))
          for _ in range(300)]


@pytest.mark.parametrize("scheme", ["db23_trilinear", "db23_tetrahedral"])
def test_weights_are_a_non_negative_partition_of_unity(scheme):
    c = counter(scheme)
    for P, r, phi in SHAPES:
        t = c.terms(N, P, r, phi)
        assert (t.weight >= 0).all(), (P, r, phi)
        assert abs(t.weight.sum() - 1) < 1e-12, (P, r, phi)
        assert np.allclose(t.trials, t.weight * N * t.cell_area)


def test_trilinear_area_weights_conserve_the_expected_count_and_tetrahedra_do_not():
    tri, tet = counter("db23_trilinear"), counter("db23_tetrahedral")
    tri_bias = [tri.mean_bias(N, P, r, phi) for P, r, phi in SHAPES]
    tet_bias = [tet.mean_bias(N, P, r, phi) for P, r, phi in SHAPES]
    assert max(abs(b - 1) for b in tri_bias) < 1e-12
    # Barycentric weights interpolate the cell area (1 + y)(1 + 3z) linearly: on a prism face cut by the
    # diagonal from (y, z) = (0, 0) to (1, 1) the excess is 3y(1 - z) / ((1 + y)(1 + 3z)), largest at
    # y = z = y* = (sqrt(32) - 2) / 14: +25.74 %. Never below 1.
    y = (math.sqrt(32) - 2) / 14
    worst = 1 + 3 * y * (1 - y) / ((1 + y) * (1 + 3 * y))
    assert max(tet_bias) <= worst + 1e-12 and min(tet_bias) > 1 - 1e-12
    at_worst = tet.mean_bias(N, area_for(4.0**3 * (1 + 3 * y) * A0, 1 + y), 1 + y, 0.0)
    assert at_worst == pytest.approx(worst, rel=1e-12)
    # The public shader's log-LOD weight overshoots by up to (1 + 3t) / 4^t - 1 = 26.4 %.
    log = counter("db23_trilinear", scale_weights="log")
    worst = max(log.mean_bias(N, area_for(4.0**s * A0, 3.0), 3.0, 0.2) for s in np.linspace(2, 3, 201))
    t = (3 / math.log(4) - 1) / 3
    assert worst == pytest.approx((1 + 3 * t) / 4**t, rel=1e-3)


def test_tetrahedral_and_trilinear_agree_at_cell_vertices():
    tri, tet = counter("db23_trilinear"), counter("db23_tetrahedral")
    for level in (2, 3):
        for k in (0, 1, 2, 3):
            r = 2.0**k
            step = 22.5 / 2 ** (k - 1) if k else 22.5
            for j in (0, 1, 3):
                phi = j * step * DEG
                P = area_for(4.0**level * A0, r)
                wt, we = weights(tri, P, r, phi), weights(tet, P, r, phi)
                assert l1(wt, we) < 1e-9, (level, k, j, wt, we)
                assert len(wt) == 1 and abs(sum(wt.values()) - 1) < 1e-12


@pytest.mark.parametrize("scheme", ["db23_trilinear", "db23_tetrahedral"])
def test_ratio_one_makes_the_orientation_irrelevant(scheme):
    c = counter(scheme)
    for P in (3 * A0, 40 * A0, 700 * A0):
        ref = weights(c, P, 1.0, 0.0)
        assert all(key[1] == 0 for key in ref)
        for phi in np.linspace(0, math.pi, 13):
            assert l1(weights(c, P, 1.0, phi), ref) < 1e-12


@pytest.mark.parametrize("scheme", ["db23_trilinear", "db23_tetrahedral"])
def test_weights_are_continuous_across_every_bin_edge(scheme):
    c = counter(scheme)
    eps = 1e-9
    for level in (2, 3):
        for r in (1.5, 3.0, 6.0, 12.0):
            # Orientation bin edges of the cell's lower face and of its upper (half-width) face.
            k = int(math.floor(math.log2(r)))
            step = (22.5 / 2 ** (max(k, 1) - 1)) * DEG
            for edge in (step, 2 * step, 2.5 * step, math.pi - 1e-7):
                P = area_for(4.0 ** (level + 0.4) * A0, r)
                assert l1(weights(c, P, r, edge - eps), weights(c, P, r, edge + eps)) < 1e-6, (r, edge)
        for r_edge in (2.0, 4.0, 8.0, 32.0):  # ratio level boundaries
            P = area_for(4.0 ** (level + 0.3) * A0, r_edge)
            a = weights(c, P * (1 - eps), r_edge * (1 - eps), 0.3)
            b = weights(c, P * (1 + eps), r_edge * (1 + eps), 0.3)
            assert l1(a, b) < 1e-6, (r_edge, a, b)
        for r in (1.0, 1.7, 5.0):  # scale level boundaries
            P = area_for(4.0**level * A0, r)
            assert l1(weights(c, P * (1 - eps), r, 0.7), weights(c, P * (1 + eps), r, 0.7)) < 1e-6


def test_evaluation_counts_are_as_stated():
    P = 50 * A0
    assert counter("db23_tetrahedral").evaluations(N, P, 3, 0.2) == 4
    assert counter("db23_trilinear").evaluations(N, P, 3, 0.2) == 8
    assert counter("db23_trilinear").evaluations(N, P, 1.5, 0.2) == 6  # isotropic cell: a triangle
    full = dict(spatial="square", angular="bilinear", realization="blend")
    assert counter("db23_tetrahedral", **full).evaluations(N, P, 3, 0.2) == 64          # DB23 §6.1
    assert counter("db23_tetrahedral", spatial="simplex", angular="bilinear",
                   realization="blend").evaluations(N, P, 3, 0.2) == 48                  # DB23 §6.2
    # DB23 counts 160 = 10 grids x 16 for the whole pentagonal prism; 8 of its 10 grids can have weight.
    assert counter("db23_trilinear", **full).evaluations(N, P, 3, 0.2) == 128
    z = counter("zk16_aniso")
    assert [z.evaluations(N, P, r, 0.2) for r in (1, 1.5, 2, 7.5, 16, 17, 64)] == [2, 4, 4, 16, 32, 32, 32]
    assert counter("db23_tetrahedral", **{**full, "realization": "select"}).evaluations(N, P, 3, 0.2) == 4


def test_zk16_widens_beyond_max_aniso():
    z = counter("zk16_aniso")
    assert z.mean_bias(N, 50 * A0, 8, 0.3) == pytest.approx(1, abs=1e-12)
    assert z.mean_bias(N, 50 * A0, 64, 0.3) == pytest.approx(64 / 16, rel=1e-12)
    assert z.terms(N, 50 * A0, 64, 0.3).attrs["clamped"]
    assert not z.terms(N, 50 * A0, 16, 0.3).attrs["clamped"]


def test_footprint_shapes_from_jacobians():
    J = np.array([[0.01, 0, 0, 0.01], [0.04, 0, 0, 0.01], [0, 0.04, 0.01, 0], [0, 0, 0, 0],
                  [np.nan, 0, 0, 1], [1e-3, 1e-3, 1e-3, 1e-3], [1.0, 0, 0, 1e-11], [1.0, 0, 0, 1e-13]])
    s = gl.footprint_shapes(J)
    assert s.P[0] == pytest.approx(1e-4) and s.r[0] == pytest.approx(1)
    assert s.r[1] == pytest.approx(4) and s.phi[1] == pytest.approx(0, abs=1e-12)
    assert s.r[2] == pytest.approx(4) and s.phi[2] == pytest.approx(math.pi / 2)
    assert list(s.status) == ["ok", "ok", "ok", "degenerate", "non_finite", "degenerate", "ok", "degenerate"]
    assert s.r[6] == pytest.approx(1e11, rel=1e-9) and s.P[6] == pytest.approx(1e-11, rel=1e-12)
    # The ellipse's area is |det J| (the image of a unit pixel) and matches gl.Ellipse's.
    e = gl.Ellipse.from_uv_derivatives(0.02, 0.01, -0.005, 0.03) if hasattr(gl.Ellipse, "from_uv_derivatives") else None
    sh = gl.footprint_shapes([0.02, 0.01, -0.005, 0.03])
    assert sh.P[0] == pytest.approx(abs(0.02 * 0.03 + 0.005 * 0.01))
    if e is not None:
        assert e.area == pytest.approx(sh.P[0])


def chi2(c, P, r, phi, p, law_counter=None, size=60_000, seed=3):
    x = (law_counter or c).sample(N, P, r, phi, p, size=size, seed=seed)
    return gl.chi2_test(x, c.pmf(N, P, r, phi, p)).pvalue


@pytest.mark.parametrize("scheme,opts", [("db23_trilinear", {}), ("db23_tetrahedral", {}),
                                         ("db23_tetrahedral", dict(spatial="simplex", angular="bilinear")),
                                         ("db23_trilinear", dict(spatial="square", angular="bilinear"))])
def test_sampler_matches_the_exact_law(scheme, opts):
    c = counter(scheme, realization="select", **opts)
    for P, r, phi, p in [(20 * A0, 3.0, 0.4, 0.3), (300 * A0, 10.0, 2.0, 0.05), (2 * A0, 1.3, 1.0, 0.5)]:
        assert chi2(c, P, r, phi, p) > 1e-4, (P, r, phi, p)


def test_sampler_check_fails_on_a_wrong_law():
    # The trilinear law is tested against tetrahedral samples where their trial totals differ (+9 %).
    tri, tet = counter("db23_trilinear"), counter("db23_tetrahedral")
    P, r, phi, p = 60 * A0, 3.0, 0.4, 0.3
    assert tet.mean_bias(N, P, r, phi) > 1.05
    assert chi2(tri, P, r, phi, p, law_counter=tet) < 1e-4
    # And a gated inner law against the binomial one's exact law.
    assert chi2(tri, P, r, phi, p, law_counter=counter("db23_trilinear", inner="gated")) < 1e-4


def test_blended_realizations_keep_the_mean_and_scale_the_variance():
    # One grid (r = 1 at a level: all weight on one isotropic grid): K = sum v_j K_j over the 4 square
    # corners, E[sum v_j^2] = (2/3)^2 for a uniform position.
    c = counter("db23_trilinear", spatial="square", realization="blend")
    P, p, size = 4.0**3 * A0, 0.3, 200_000
    x = c.sample(N, P, 1.0, 0.0, p, size=size, seed=11)
    n = N * P
    var = n * p * (1 - p)
    assert abs(x.mean() - n * p) < 5 * math.sqrt(var / size)
    assert x.var() / var == pytest.approx(4 / 9, rel=0.03)
    assert not c.has_pmf and c.binning == "round"
    with pytest.raises(NotImplementedError, match="realization='select'"):
        c.pmf(N, P, 1.0, 0.0, p)


def test_images_are_deterministic_whatever_the_threads_and_report_degenerate_pixels():
    uv, J = aniso_study.plane_image(64, 36, tilt_deg=75)
    c = counter("db23_tetrahedral", spatial="simplex", angular="bilinear", realization="blend", inner="gated")
    before = gl.get_num_threads()
    try:
        gl.set_num_threads(1)
        one = c.count_image(uv, J, N, 0.2, seed=4)
        gl.set_num_threads(2)
        two = c.count_image(uv, J, N, 0.2, seed=4)
    finally:
        gl.set_num_threads(before)
    np.testing.assert_array_equal(one.K, two.K)
    assert set(np.unique(one.evaluations)) <= {0, 48}
    sky = (J == 0).all(axis=-1)
    assert sky.any() and (one.status[sky] == 1).all() and (one.K[sky] == 0).all() and (one.evaluations[sky] == 0).all()
    assert (one.status[~sky] == 0).all()
    hist = one.evaluation_histogram()
    assert hist.sum() == 64 * 36
    # Neighbouring pixels share cells: a different seed changes the image, the same seed does not.
    assert not np.array_equal(c.count_image(uv, J, N, 0.2, seed=5).K, one.K)


def test_custom_python_inner_law_runs_and_matches_the_builtin():
    binom = gl.law("binomial")

    def fn(n, p, u):
        return binom.evaluate(n, p, u) if False else np.floor(n * p + 0.0 * u[:, 0])

    mine = gl.custom_law(fn, n_uniforms=1, name="mean_floor")
    c = gl.aniso_counter("db23_trilinear", inner=mine, base_area=A0)
    x = c.sample(N, 50 * A0, 3.0, 0.2, 0.1, size=100, seed=1)
    t = c.terms(N, 50 * A0, 3.0, 0.2)
    assert np.all(x == np.floor(t.trials * 0.1).sum())


@pytest.mark.parametrize("law", ["binomial", "gated"])
@pytest.mark.parametrize("label", ["db23_trilinear", "db23_shader_48", "zk16_aniso"])
def test_sample_fast_path_gives_the_per_pixel_bits(label, law):
    """sample() hands each term's rows to the built-in law's fixed evaluator (a table); the same law
    wrapped as a Python law takes the per-pixel path on the same cell uniforms: the same bits. A wrong
    fast path (a row given another term's evaluator) is caught: it changes the trial count the rows see."""
    builtin = gl.law(law)
    wrapped = gl.custom_law(lambda n, p, u: builtin.evaluate(n, p, u), n_uniforms=builtin.n_uniforms,
                            name=f"wrapped_{law}")
    scheme, kw = IMAGE_CONFIGS[label]
    for n, r, ph in ((3.0, 1.5, 30.0), (300.0, 24.0, 60.0)):
        args = (N, n / N, r, ph * DEG, 0.1)
        fast = configured_counter(label, law, N).sample(*args, size=500, seed=3)
        slow = configured_counter((scheme, kw), wrapped, N).sample(*args, size=500, seed=3)
        assert np.array_equal(fast, slow)
        wrong = configured_counter(label, law, N).sample(N, n / N * 1.5, r, ph * DEG, 0.1, size=500, seed=3)
        assert not np.array_equal(wrong, slow)


@pytest.mark.parametrize("call,match", [
    (lambda: counter("db23_trilinear").terms(N, 0.0, 2, 0), "P = 0"),
    (lambda: counter("db23_trilinear").terms(N, 1e-4, 0.5, 0), "r = 0.5"),
    (lambda: counter("db23_trilinear").terms(N, 1e-4, 1e13, 0), "r = 10000000000000"),
    (lambda: counter("db23_trilinear").terms(N, 1e-4, 2, float("nan")), "phi = nan"),
    (lambda: counter("db23_trilinear").sample(N, 1e-4, 2, 0, 1.5, size=3), "p = 1.5"),
    (lambda: counter("db23_trilinear").sample(-1, 1e-4, 2, 0, 0.5, size=3), "N = -1"),
    (lambda: gl.aniso_counter("db24"), "unknown grid scheme 'db24'"),
    (lambda: gl.aniso_counter("db23_trilinear", spatial="hex"), "unknown spatial 'hex'; known: none, square"),
    (lambda: gl.aniso_counter("db23_trilinear", realization="mix"), "unknown realization 'mix'"),
    (lambda: gl.aniso_counter("db23_trilinear", orientation_step=25), "orientation_step = 25"),
    (lambda: gl.aniso_counter("db23_trilinear", max_ratio=3), "max_ratio = 3"),
    (lambda: gl.aniso_counter("db23_trilinear", scale_weights="cubic"), "scale_weights"),
    (lambda: gl.aniso_counter("db23_trilinear", colour=1), "colour"),
    (lambda: gl.aniso_counter("zk16_aniso", max_aniso=0.5), "max_aniso = 0.5"),
    (lambda: gl.aniso_counter("zk16_aniso", inner="nope"), "nope"),
    (lambda: counter("zk16_aniso").count_image(np.zeros((2, 2, 2)), np.zeros((2, 2, 3)), N, 0.1), "J ="),
    (lambda: counter("zk16_aniso").count_image(np.full((1, 1, 2), np.nan), np.ones((1, 1, 4)), N, 0.1), "uv"),
    (lambda: counter("zk16_aniso").count_image(np.zeros((1, 2, 2)), np.ones((1, 2, 4)), N, [0.1, 2.0]), "p"),
])
def test_bad_input_is_refused_by_name(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_study_rows_and_summary():
    grid = {"n": (10.0,), "r": (1.0, 3.0, 40.0), "phi_deg": (20.0,), "p": (0.2,)}
    df = aniso_study.study(configs=["db23_trilinear", "db23_tetrahedral", "zk16_aniso"], laws=("binomial",),
                           grid=grid, samples=4000, seed=2)
    assert len(df) == 9
    tri = df[df.config == "db23_trilinear"]
    assert (tri.weight_bias - 1).abs().max() < 1e-12 and tri.exact.all()
    z = df[(df.config == "zk16_aniso") & (df.r == 40.0)].iloc[0]
    assert z.weight_bias == pytest.approx(40 / 16) and z.clamped and not z.exact
    # Widening shows in the sampled mean (2.5x the truth's) far beyond its standard error.
    assert abs(z.mean_bias - 2.5) < 6 * z.mean_bias_se + 0.02
    s = aniso_study.summary(df)
    assert set(s.config) == {"db23_trilinear", "db23_tetrahedral", "zk16_aniso"}


@pytest.mark.parametrize("label", list(IMAGE_CONFIGS))
def test_a_pixel_counts_the_same_alone_and_within_any_image(label):
    # The counter memoizes per-term values (angles' cosines, grid and texel keys) from pixel to pixel
    # and keeps its gathered buffers between chunks and calls: none of it may leak into a count. These
    # configurations draw no per-pixel picks (one lattice vertex, or blended realizations), so a
    # pixel's K depends on its footprint and position only, wherever it sits in the image.
    uv, J = aniso_study.plane_image(48, 27, tilt_deg=70)
    uv, J = uv.reshape(-1, 2), J.reshape(-1, 4)
    c = configured_counter(IMAGE_CONFIGS[label], "gated", N)
    whole = c.count_image(uv, J, N, 0.2, seed=9)
    order = np.random.default_rng(3).permutation(len(uv))
    shuffled = c.count_image(uv[order], J[order], N, 0.2, seed=9)
    np.testing.assert_array_equal(shuffled.K, whole.K[order])
    np.testing.assert_array_equal(shuffled.evaluations, whole.evaluations[order])
    for i in order[:25]:
        alone = c.count_image(uv[i:i + 1], J[i:i + 1], N, 0.2, seed=9)
        assert alone.K[0] == whole.K[i] and alone.evaluations[0] == whole.evaluations[i]


def test_an_inner_law_that_counts_an_image_itself_leaves_the_outer_count_intact():
    # A Python inner law runs on the counting thread, inside the outer count: its own count_image
    # must get buffers of its own rather than the thread's (which hold the outer chunk's requests).
    uv, J = aniso_study.plane_image(16, 9, tilt_deg=70)
    nested = counter("zk16_aniso", inner="gated")
    expected_nested = nested.count_image(uv, J, N, 0.3, seed=2).K
    seen = []

    def plain(n, p, u):
        return np.floor(n * p + 0.0 * u[:, 0])

    def reentrant(n, p, u):
        seen.append(np.array_equal(nested.count_image(uv, J, N, 0.3, seed=2).K, expected_nested))
        return plain(n, p, u)

    outer = {name: gl.aniso_counter("db23_trilinear", inner=gl.custom_law(fn, n_uniforms=1, name=name), base_area=A0)
             for name, fn in (("plain", plain), ("reentrant", reentrant))}
    k = {name: c.count_image(uv, J, N, 0.1, seed=5).K for name, c in outer.items()}
    np.testing.assert_array_equal(k["reentrant"], k["plain"])
    assert seen and all(seen)
