"""KPT25's Algorithm 2 (nd.sample / nd.pdf), the map T (nd.map), and the edge cases of issue 31 for the
KPT25 NDF (grazing and rescaled half vectors, fast exact expectations, error messages naming the element).

The sampler is checked against its own pdf (docs/math/glinty_ndf.md#glinty-sampling) with an exact
binning of its own: bins of the unit square of T-space aligned with every line where the pdf jumps (cell
edges of both levels and the half-cell lines where the x_a-regions of the blocks meet), expected counts
from the pdf integrated over each bin's part of the disk U by Gauss-Legendre rules (the chord of the disk
taken exactly), and the draws lost outside U as a bin of their own. Chi-square p-values are compared with
1e-6 (false-failure rate 1e-6 per check); each check is shown to reject a deliberately wrong pdf (one
missing the Jacobian of T^-1, one whose lobes are 10 % too wide) at the sample size it uses.
"""
import math
import time

import numpy as np
import pytest
from scipy import integrate, stats

import glintlab as gl
from glintlab import _core

ALPHA_P = 1e-6  # false-failure rate of each chi-square check


def inverse_map(nd, y):
    """T^-1 of docs/math/glinty_ndf.md#glinty-map written independently of the C++ (points y (n, 2) of U)."""
    d = 2.0 * np.asarray(y, float) - 1.0
    r2 = np.sum(d * d, axis=1)
    a, b = nd.alpha, getattr(nd, "alpha_y", nd.alpha)  # (alpha_x, alpha_y): the stretch of eq. 6
    if nd.target == "beckmann":
        ratio = np.sqrt(np.where(r2 > 0, -np.log1p(-r2) / np.where(r2 > 0, r2, 1.0), 1.0))
        v = np.column_stack([a * d[:, 0] * ratio, b * d[:, 1] * ratio, np.ones_like(r2)])
    elif getattr(nd, "ggx_map", "orthographic") == "lambert":  # eq. 7 inverted: z = 1 - |d|^2
        l = np.sqrt(2.0 - r2)
        v = np.column_stack([a * d[:, 0] * l, b * d[:, 1] * l, 1.0 - r2])
    else:
        v = np.column_stack([a * d[:, 0], b * d[:, 1], np.sqrt(np.maximum(0.0, 1.0 - r2))])
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def t_jacobian(nd, h):
    """dy / dOmega of T at unit h: (pi / 4) D(h)(h.n), or (pi / 8) D(h) abs(M^T h) for the Lambert map, M =
    diag(1 / alpha_x, 1 / alpha_y, 1) (docs/math/glinty_ndf.md#glinty-lambert). The T-space checks below
    divide the pdf by it and cannot see an error the core shares: test_kpt25_jacobian.py checks the
    Jacobian independently (a hemisphere quadrature of the pdf, finite differences of T)."""
    if getattr(nd, "ggx_map", "orthographic") == "lambert":
        a, b = nd.alpha, getattr(nd, "alpha_y", nd.alpha)
        return 0.125 * math.pi * nd.smooth(h) * np.sqrt((h[:, 0] / a) ** 2 + (h[:, 1] / b) ** 2 + h[:, 2] ** 2)
    return 0.25 * math.pi * nd.smooth(h) * h[:, 2]


def bin_edges(nd, J, h_probe=(0.0, 0.0, 1.0), sub=2):
    """Edges of T-space bins on which the pdf is smooth (but for the rim): 1 / (2 sub 2^l_max). The
    half cells matter: binned by whole cells (sub = 1/2), the correct pdf of the fourth pixel below is
    rejected (p = 6e-8 at 150000 draws), as the x_a-regions of 2 x 2 blocks meet at half cells."""
    levels = nd.pixel(J, h_probe)["levels"]
    n = 2 * sub * 2 ** max(levels)
    return np.linspace(0.0, 1.0, n + 1)


def gl_nodes(n):
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (x + 1.0), 0.5 * w


def bin_quadrature(edges, order=10):
    """Nodes and weights (per bin) integrating over each bin's part of the disk U: Gauss-Legendre in x
    over the bin's part of the disk's x-range, and in y over the chord's part of the bin at each x."""
    t, w = gl_nodes(order)
    pts, wts, ids = [], [], []
    n = len(edges) - 1
    for bx in range(n):
        x0, x1 = edges[bx], edges[bx + 1]
        xs = x0 + (x1 - x0) * t
        s = np.sqrt(np.maximum(0.0, 0.25 - (xs - 0.5) ** 2))
        for by in range(n):
            y0, y1 = edges[by], edges[by + 1]
            lo, hi = np.maximum(y0, 0.5 - s), np.minimum(y1, 0.5 + s)
            if not np.any(hi > lo):
                continue
            for ix in range(order):
                if hi[ix] <= lo[ix]:
                    continue
                ys = lo[ix] + (hi[ix] - lo[ix]) * t
                pts.append(np.column_stack([np.full(order, xs[ix]), ys]))
                wts.append((x1 - x0) * w[ix] * (hi[ix] - lo[ix]) * w)
                ids.append(np.full(order, bx * n + by))
    return np.concatenate(pts), np.concatenate(wts), np.concatenate(ids), n * n


def expected_per_bin(nd, uv, J, seed, edges, pdf_fn=None, order=10):
    """The probability of each T-space bin under ``pdf_fn(h)`` (density per steradian of h): the integral
    of pdf(h(y)) |dOmega/dy| over the bin's part of U, with dy = (pi / 4) D(h) (h.n) dOmega."""
    y, w, ids, nb = bin_quadrature(edges, order)
    inside = np.sum((y - 0.5) ** 2, axis=1) < 0.25
    y, w, ids = y[inside], w[inside], ids[inside]
    h = inverse_map(nd, y)
    m = h.shape[0]
    if pdf_fn is None:
        pdf_fn = lambda hh: nd.pdf(np.tile(uv, (m, 1)), np.tile(J, (m, 1)), hh, seed=seed)  # noqa: E731
    jac = 1.0 / t_jacobian(nd, h)
    return np.bincount(ids, weights=w * pdf_fn(h) * jac, minlength=nb)


def observed_per_bin(nd, h, edges):
    lost = ~np.isfinite(h[:, 0])
    y = nd.map(h[~lost])
    n = len(edges) - 1
    bx = np.clip(np.searchsorted(edges, y[:, 0], side="right") - 1, 0, n - 1)
    by = np.clip(np.searchsorted(edges, y[:, 1], side="right") - 1, 0, n - 1)
    return np.bincount(bx * n + by, minlength=n * n).astype(float), int(lost.sum())


def chi2_pvalue(observed, lost, prob, N, min_expected=5.0):
    """Pearson chi-square of the bins and the lost draws against the probabilities ``prob``; bins
    expecting fewer than ``min_expected`` draws are pooled into one bin."""
    exp = prob * N
    exp_lost = max(0.0, 1.0 - prob.sum()) * N
    big = exp >= min_expected
    o = list(observed[big]) + [observed[~big].sum()]
    e = list(exp[big]) + [exp[~big].sum()]
    o.append(lost)
    e.append(exp_lost)
    o, e = np.array(o), np.array(e)
    if np.any((e == 0) & (o > 0)):
        return 0.0
    keep = e > 0
    stat = float(np.sum((o[keep] - e[keep]) ** 2 / e[keep]))
    return float(stats.chi2.sf(stat, keep.sum() - 1))


def draw(nd, uv, J, seed, N, draw_seed=1):
    return nd.sample(np.tile(uv, (N, 1)), np.tile(J, (N, 1)), seed=seed, draw_seed=draw_seed)


# (NDF parameters, uv, J): levels 1-2 with blocks of 2 x 2 cells; single cells and a defensive smooth
# share; blocks of 3 x 3 cells; levels 2-3 with about 10 points per footprint (most blocks empty: the
# fallback to x_a); 4 x 4 blocks with GGX; the printed reservoir weight.
PIXELS = [
    (dict(density=4e3, target="beckmann", alpha=0.5, alpha_star=0.05, k=4), (0.31, 0.57), (0.03, 0.004, -0.006, 0.025)),
    (dict(density=1e3, target="ggx", alpha=0.4, alpha_star=0.08, k=1, sample_smooth=0.2), (1.7, -0.4),
     (0.05, 0.0, 0.0, 0.05)),
    (dict(density=2e4, target="beckmann", alpha=0.3, alpha_star=0.04, k=9, epsilon=0.0), (0.05, 0.9),
     (0.012, 0.0, 0.003, 0.01)),
    (dict(density=1e6, target="beckmann", alpha=0.5, alpha_star=0.02, k=4), (0.123, 0.456), (0.003, 0, 0.0005, 0.0025)),
    (dict(density=1e6, target="ggx", alpha=0.2, alpha_star=0.03, k=16), (3.3, 0.1), (0.002, 0, 0, 0.002)),
    (dict(density=4e3, target="beckmann", alpha=0.5, alpha_star=0.05, k=4, sample_weight="printed"), (0.31, 0.57),
     (0.03, 0.004, -0.006, 0.025)),
    # The paper's Lambert map for GGX (eq. 7): the sampler and its pdf through the other Jacobian of T.
    (dict(density=4e3, target="ggx", alpha=0.4, alpha_star=0.05, k=4, ggx_map="lambert"), (0.31, 0.57),
     (0.03, 0.004, -0.006, 0.025)),
    # Anisotropic roughness (alpha_x, alpha_y): the stretched map and its Jacobian.
    (dict(density=4e3, target="beckmann", alpha=(0.6, 0.3), alpha_star=0.05, k=4), (0.31, 0.57),
     (0.03, 0.004, -0.006, 0.025)),
]


@pytest.mark.parametrize("case", PIXELS)
def test_pdf_integrates_to_one_less_the_lost_mass(case):
    kw, uv, J = case
    nd = gl.glinty_ndf("kpt25", **kw)
    edges = bin_edges(nd, J)
    prob = expected_per_bin(nd, uv, J, 3, edges)
    total = prob.sum()
    # Lobes whose tails cross the rim lose that part (the draws land outside U): the mass is <= 1 and
    # close to 1 for these pixels; the draws lost must match the mass the pdf misses (|z| < 5, plus
    # the quadrature's error, below 1e-4 of the mass at these bins and order).
    assert 0.9 < total < 1.0 + 1e-4
    N = 50000
    h, pdf = draw(nd, uv, J, 3, N)
    lost = int(np.sum(~np.isfinite(h[:, 0])))
    p_lost = max(1.0 - total, 1e-12)
    assert abs(lost - N * p_lost) < 5.0 * math.sqrt(N * p_lost) + 1e-4 * N, (lost, N * p_lost)
    assert np.all(pdf[np.isfinite(h[:, 0])] > 0) and np.all(pdf[~np.isfinite(h[:, 0])] == 0)
    # A pdf missing the Jacobian of T^-1 (a density on the square read as one on the hemisphere) does
    # not integrate to 1.
    wrong = expected_per_bin(nd, uv, J, 3, edges,
                             pdf_fn=lambda hh: nd.pdf(np.tile(uv, (len(hh), 1)), np.tile(J, (len(hh), 1)), hh, seed=3)
                             / t_jacobian(nd, hh))
    assert abs(wrong.sum() - 1.0) > 0.05


@pytest.mark.parametrize("case", PIXELS)
def test_samples_follow_their_pdf_and_wrong_pdfs_are_rejected(case):
    kw, uv, J = case
    nd = gl.glinty_ndf("kpt25", **kw)
    edges = bin_edges(nd, J)
    N = 100000
    h, pdf = draw(nd, uv, J, 5, N, draw_seed=11)
    # The pdf returned with each draw is the one pdf() gives for it, to the bit.
    ok = np.isfinite(h[:, 0])
    np.testing.assert_array_equal(pdf[ok], nd.pdf(np.tile(uv, (ok.sum(), 1)), np.tile(J, (ok.sum(), 1)), h[ok], seed=5))
    obs, lost = observed_per_bin(nd, h, edges)
    p = chi2_pvalue(obs, lost, expected_per_bin(nd, uv, J, 5, edges), N)
    assert p > ALPHA_P, p
    # Wrong: the lobes 10 % wider (the same realization: the points do not depend on alpha_star).
    wide = gl.glinty_ndf("kpt25", **{**kw, "alpha_star": 1.1 * kw["alpha_star"]})
    assert chi2_pvalue(obs, lost, expected_per_bin(wide, uv, J, 5, edges), N) < ALPHA_P

    # Wrong: the pdf without the Jacobian (pi / 4) D(h) (h.n) of T^-1.
    def no_jacobian(hh):
        m = len(hh)
        return nd.pdf(np.tile(uv, (m, 1)), np.tile(J, (m, 1)), hh, seed=5) / t_jacobian(nd, hh)

    assert chi2_pvalue(obs, lost, expected_per_bin(nd, uv, J, 5, edges, pdf_fn=no_jacobian), N) < ALPHA_P
    # Wrong: another realization's pdf (seed 6) for the draws of seed 5.
    assert chi2_pvalue(obs, lost, expected_per_bin(nd, uv, J, 6, edges), N) < ALPHA_P


def test_sampling_is_deterministic_whatever_the_threads():
    nd = gl.glinty_ndf("kpt25", density=1e5, target="ggx", alpha=0.4, alpha_star=0.03, k=4)
    rng = np.random.default_rng(1)
    n = 2000
    uv = rng.uniform(0, 1, (n, 2))
    J = np.column_stack([rng.uniform(1e-3, 5e-3, n), rng.uniform(-1e-3, 1e-3, n),
                         rng.uniform(-1e-3, 1e-3, n), rng.uniform(1e-3, 5e-3, n)])
    wo = np.column_stack([rng.normal(0, 0.3, (n, 2)), np.ones(n)])
    threads = gl.get_num_threads()
    try:
        gl.set_num_threads(1)
        h1, p1, w1 = nd.sample(uv, J, seed=3, draw_seed=4, wo=wo)
        q1 = nd.pdf(uv, J, np.where(np.isfinite(h1), h1, [0, 0, 1.0]), seed=3)
        gl.set_num_threads(2)
        h2, p2, w2 = nd.sample(uv, J, seed=3, draw_seed=4, wo=wo)
        q2 = nd.pdf(uv, J, np.where(np.isfinite(h2), h2, [0, 0, 1.0]), seed=3)
    finally:
        gl.set_num_threads(threads)
    for a, b in ((h1, h2), (p1, p2), (w1, w2), (q1, q2)):
        np.testing.assert_array_equal(a, b)
    ok = np.isfinite(h1[:, 0])
    assert ok.mean() > 0.99
    # wi is the mirror of wo about h, NaN where h faces away from wo (test_kpt25_jacobian.py); the draws
    # depend on draw_seed and on the realization.
    won = wo / np.linalg.norm(wo, axis=1, keepdims=True)
    facing = ok & (np.sum(won * np.where(ok[:, None], h1, 0.0), axis=1) > 0)
    np.testing.assert_array_equal(np.isfinite(w1[:, 0]), facing)
    np.testing.assert_allclose(w1[facing], 2 * np.sum(won[facing] * h1[facing], axis=1)[:, None] * h1[facing]
                               - won[facing], atol=1e-12)
    assert not np.array_equal(nd.sample(uv, J, seed=3, draw_seed=5)[0][ok], h1[ok])
    assert not np.array_equal(nd.sample(uv, J, seed=4, draw_seed=4)[0][ok], h1[ok])
    img_h, img_p = nd.sample(uv.reshape(20, 100, 2), J.reshape(20, 100, 4), seed=3, draw_seed=4)
    assert img_h.shape == (20, 100, 3) and img_p.shape == (20, 100)
    np.testing.assert_array_equal(img_p.reshape(-1), p1)


def test_pixel_sampler_is_a_direction_sampler():
    nd = gl.glinty_ndf("kpt25", density=1e4, alpha=0.5, alpha_star=0.05)
    s = nd.pixel_sampler((0.2, 0.3), (0.01, 0.0, 0.0, 0.01), seed=2)
    assert s.domain == "hemisphere"
    d, p = s.sample(500, seed=1)
    assert d.shape == (500, 3) and p.shape == (500,)
    ok = np.isfinite(d[:, 0])
    np.testing.assert_array_equal(s.pdf(d[ok]), p[ok])
    r = nd.pixel_sampler((0.2, 0.3), (0.01, 0.0, 0.0, 0.01), seed=2, wo=(0.3, 0.0, 1.0))
    assert r.domain == "sphere"
    wi, pw = r.sample(500, seed=1)
    ok = np.isfinite(wi[:, 0])
    np.testing.assert_allclose(r.pdf(wi[ok]), pw[ok], rtol=1e-9)
    # The reflected directions' density is the half vector's over 4 |wo.h|.
    h = d[ok]
    wo = np.array([0.3, 0.0, 1.0]) / np.linalg.norm([0.3, 0.0, 1.0])
    np.testing.assert_allclose(pw[ok], p[ok] / (4 * np.abs(h @ wo)), rtol=1e-12)


def test_sample_bad_input_is_refused_by_name():
    nd = gl.glinty_ndf("kpt25", density=1e4)
    uv, J = [[0.0, 0.0]], [[1e-3, 0, 0, 1e-3]]
    with pytest.raises(ValueError, match="draw_seed"):
        nd.sample(uv, J, draw_seed=-1)
    with pytest.raises(ValueError, match=r"wo\[0, 2\] = nan"):
        nd.sample(uv, J, wo=[0.0, 0.0, float("nan")])
    with pytest.raises(ValueError, match="wo"):
        nd.sample(uv, J, wo=[0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="sample_weight"):
        gl.glinty_ndf("kpt25", sample_weight="lobe")
    with pytest.raises(ValueError, match="sample_smooth"):
        gl.glinty_ndf("kpt25", sample_smooth=1.5)
    with pytest.raises(ValueError, match=r"J\[0\] = \[0\.001, 0\.001, 0\.001, 0\.001\]"):
        nd.sample(uv, [[1e-3, 1e-3, 1e-3, 1e-3]])


# ---------------------------------------------------------------------------------------------------
# nd.map

RINGS, SECTORS = 10, 8  # 80 bins of equal area on the disk U


def ring_sector_counts(y):
    """Counts of points y (n, 2) of U in RINGS equal-area rings (|d|^2 in [i / RINGS, (i + 1) / RINGS))
    x SECTORS equal sectors, d = 2 y - 1: bins of equal probability under the uniform distribution."""
    d = 2 * np.asarray(y) - 1
    ring = np.minimum((np.sum(d * d, axis=1) * RINGS).astype(int), RINGS - 1)
    sec = ((np.arctan2(d[:, 1], d[:, 0]) + math.pi) / (2 * math.pi) * SECTORS).astype(int) % SECTORS
    return np.bincount(ring * SECTORS + sec, minlength=RINGS * SECTORS)


def ring_sector_p(y):
    """Chi-square p-value of points y against the uniform distribution on U (79 degrees of freedom)."""
    return stats.chisquare(ring_sector_counts(y)).pvalue


def inversion_draws(target, alpha, n, seed, weight="projected"):
    """Half vectors drawn by inverting the CDF of theta (phi uniform): from D(h)(h.n) dOmega ("projected":
    tan^2 theta = -alpha^2 log u for Beckmann, alpha^2 u / (1 - u) for GGX, Walter et al. 2007) or, for
    GGX, from D(h) abs(M^T h) dOmega / 2 ("stretched": the uniform hemisphere of the stretched normal,
    cos theta' = u, unstretched: tan^2 theta = alpha^2 (1 - u^2) / u^2)."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(size=n)
    if target == "beckmann":
        t2 = -alpha * alpha * np.log(u)
    elif weight == "projected":
        t2 = alpha * alpha * u / (1.0 - u)
    else:
        t2 = alpha * alpha * (1.0 - u * u) / (u * u)
    phi = rng.uniform(0, 2 * math.pi, n)
    ct = 1 / np.sqrt(1 + t2)
    st = np.sqrt(t2) * ct
    return np.column_stack([st * np.cos(phi), st * np.sin(phi), ct])


@pytest.mark.parametrize("target,alpha", [("beckmann", 0.5), ("beckmann", 0.15), ("ggx", 0.3), ("ggx", 1.6)])
def test_map_sends_the_target_to_the_uniform_disk_and_wrong_maps_are_rejected(target, alpha):
    # T tested on its own (docs/math/glinty_ndf.md#glinty-map): directions from D(h)(h.n), drawn by
    # inversion (not through T^-1), map to the uniform distribution on U; a map with alpha 10 % off and
    # the other target's map are rejected at the same sample size (p < 1e-6 each).
    n = 40000
    h = inversion_draws(target, alpha, n, seed=21)
    assert ring_sector_p(gl.glinty_ndf("kpt25", target=target, alpha=alpha).map(h)) > ALPHA_P
    assert ring_sector_p(gl.glinty_ndf("kpt25", target=target, alpha=1.1 * alpha).map(h)) < ALPHA_P
    other = "ggx" if target == "beckmann" else "beckmann"
    assert ring_sector_p(gl.glinty_ndf("kpt25", target=other, alpha=alpha).map(h)) < ALPHA_P


def lambert_ring_probabilities():
    """Exact ring probabilities of the Lambert map applied to D(h)(h.n) dOmega: the stretched normal is
    cosine distributed, z = 1 - |d|^2 under eq. 7, so s = |d|^2 has density 2 (1 - s) on [0, 1)."""
    e = np.linspace(0.0, 1.0, RINGS + 1)
    return np.diff(2 * e - e * e)


def test_lambert_map_uniformises_the_stretched_hemisphere_not_d_cos_and_its_departure_is_exact():
    # The paper's T = L o M~ (eq. 6-7) for GGX makes D(h) abs(M^T h) dOmega / 2 (the uniform hemisphere of
    # the stretched normal) uniform on U, not D(h)(h.n) dOmega: glintlab's orthographic map is the exact
    # one for the latter.
    n = 40000
    for alpha in (0.3, 1.6):
        lam = gl.glinty_ndf("kpt25", target="ggx", alpha=alpha, ggx_map="lambert")
        ortho = gl.glinty_ndf("kpt25", target="ggx", alpha=alpha)
        area = inversion_draws("ggx", alpha, n, seed=22, weight="stretched")
        proj = inversion_draws("ggx", alpha, n, seed=23)
        assert ring_sector_p(lam.map(area)) > ALPHA_P
        assert ring_sector_p(ortho.map(area)) < ALPHA_P
        assert ring_sector_p(lam.map(proj)) < ALPHA_P
        # T^-1 o T is the identity on U for the Lambert map too.
        y = 0.5 + 0.5 * np.random.default_rng(3).uniform(-0.7, 0.7, (200, 2))
        np.testing.assert_allclose(lam.map(inverse_map(lam, y)), y, atol=1e-12)
        # The departure of the Lambert map's image of D(h)(h.n) from uniform: the per-sample Pearson
        # statistic chi2 / n of the rings converges to the exact divergence sum (p_i - 1/R)^2 R (0.33 for
        # 10 rings; total variation 1/4 exactly, whatever alpha); the sampled value is within 5 of its
        # standard errors, sqrt(4 div / n) at most (the delta method's leading term, bounded).
        rings = ring_sector_counts(lam.map(proj)).reshape(RINGS, SECTORS).sum(axis=1)
        stat = float(np.sum((rings - n / RINGS) ** 2 / (n / RINGS))) / n
        p = lambert_ring_probabilities()
        div = float(np.sum((p - 1 / RINGS) ** 2 * RINGS))
        assert abs(stat - div) < 5 * math.sqrt(4 * div / n) + (RINGS - 1) / n, (stat, div)
    with pytest.raises(ValueError, match="ggx_map"):
        gl.glinty_ndf("kpt25", target="beckmann", ggx_map="lambert")
    with pytest.raises(ValueError, match="ggx_map"):
        gl.glinty_ndf("kpt25", target="ggx", ggx_map="stereographic")


def test_map_is_vectorized_and_uniformises_the_target():
    for target, alpha in (("beckmann", 0.5), ("ggx", 0.3)):
        nd = gl.glinty_ndf("kpt25", target=target, alpha=alpha)
        assert nd.map([0.0, 0.0, 1.0]).tolist() == [0.5, 0.5]
        rng = np.random.default_rng(7)
        y = 0.5 + 0.5 * rng.uniform(-0.7, 0.7, (200, 2))
        h = inverse_map(nd, y)
        np.testing.assert_allclose(nd.map(h * 3.0), y, atol=1e-12)  # T(T^-1(y)) = y, any scale of h
        assert nd.map(h.reshape(10, 20, 3)).shape == (10, 20, 2)
        assert np.all(np.isnan(nd.map([[0.3, 0.0, -1.0]])))
    # Directions drawn from D(h)(h.n) by the textbook Beckmann sampler (tan^2 theta = -alpha^2 log u)
    # map to the uniform distribution on U: a chi-square on 10 rings x 8 sectors of equal area; the
    # GGX map applied to the same directions is rejected.
    rng = np.random.default_rng(8)
    n, a = 40000, 0.5
    t2 = -a * a * np.log(rng.uniform(size=n))
    phi = rng.uniform(0, 2 * math.pi, n)
    ct = 1 / np.sqrt(1 + t2)
    st = np.sqrt(t2) * ct
    h = np.column_stack([st * np.cos(phi), st * np.sin(phi), ct])

    assert ring_sector_p(gl.glinty_ndf("kpt25", alpha=a).map(h)) > ALPHA_P
    assert ring_sector_p(gl.glinty_ndf("kpt25", target="ggx", alpha=a).map(h)) < ALPHA_P


# ---------------------------------------------------------------------------------------------------
# Issue 31: grazing and rescaled half vectors, the cost of the disk integrals, the error messages.

def test_grazing_and_rescaled_half_vectors():
    for target in ("beckmann", "ggx"):
        nd = gl.glinty_ndf("kpt25", density=1e4, target=target, alpha=0.5, alpha_star=0.05)
        uv, J = [[0.1, 0.2]], [[0.01, 0.0, 0.0, 0.01]]
        for hz in (1e-150, 1e-300, 5e-324):
            h = [[1.0, 0.0, hz]]
            for out in (nd.evaluate(uv, J, h), nd.reference(uv, J, h), *nd.expected(J, h), nd.pdf(uv, J, h)):
                assert np.all(np.isfinite(out)), (target, hz)
            if target == "beckmann":  # D(h) -> 0 at grazing: the limit is 0
                assert nd.evaluate(uv, J, h)[0] == 0.0 and nd.expected(J, h)[0][0] == 0.0
        h = np.array([[0.3, -0.2, 0.9]])
        base = [nd.evaluate(uv, J, h, seed=2), nd.reference(uv, J, h, seed=2), nd.expected(J, h)[1], nd.pdf(uv, J, h)]
        for scale in (1e160, 1e-160, 1e300, 1e-300):
            got = [nd.evaluate(uv, J, h * scale, seed=2), nd.reference(uv, J, h * scale, seed=2),
                   nd.expected(J, h * scale)[1], nd.pdf(uv, J, h * scale)]
            for a, b in zip(base, got):
                np.testing.assert_allclose(b, a, rtol=1e-14)
        with pytest.raises(ValueError, match="nonzero"):
            nd.evaluate(uv, J, [[0.0, 0.0, 0.0]])
    # D(h) = 5e-323 (a denormal): its lobe's sigma^2 underflows; the value is 0, not NaN.
    nd = gl.glinty_ndf("kpt25", density=1e6, alpha=0.5, alpha_star=0.05, compensation="disk")
    h = [[1.82973211, 0.18888493, 0.13408654]]
    assert nd.evaluate([[0.0, 0.0]], [[0.01, 0, 0, 0.01]], h)[0] == 0.0
    assert np.all(np.isfinite(nd.expected([[0.01, 0, 0, 0.01]], h)))


def test_disk_integrals_are_fast_and_accurate():
    # Issue 31 item 3: grazing half vectors and extreme alpha_star / alpha took seconds per pixel.
    rng = np.random.default_rng(2)
    n = 1200
    v = rng.normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2])
    J = np.tile([0.01, 0.0, 0.0, 0.01], (n, 1))
    # 1200 pixels per call (random h: about a third beyond 60 degrees) in well under 5 s each; before the
    # fix one grazing pixel took 2-5 s and alpha_star = 1e-5 several seconds at any h.
    for kw in (dict(alpha=0.5, alpha_star=0.05), dict(alpha=0.5, alpha_star=1e-5), dict(alpha=150.0, alpha_star=0.02)):
        nd = gl.glinty_ndf("kpt25", density=1e6, compensation="disk", **kw)
        start = time.perf_counter()
        er, ea = nd.expected(J, v)
        assert time.perf_counter() - start < 5.0, kw
        assert np.all(np.isfinite(er)) and np.all(np.isfinite(ea))
        start = time.perf_counter()
        assert np.all(np.isfinite(nd.evaluate(np.zeros((n, 2)), J, v)))
        assert time.perf_counter() - start < 5.0, kw
    # Accuracy against an independent quadrature (scipy): the exact normal mass on the chord, integrated
    # over x by adaptive quadrature, at the rim, inside and at a tiny lobe.
    for cx, cy, s, rect in ((0.98, 0.6, 0.01, (0, 1, 0, 1)), (0.5, 0.999, 0.002, (0.4, 0.6, 0.9, 1.0)),
                            (0.2, 0.15, 0.05, (0, 0.25, 0, 0.25)), (0.5, 0.5, 1e-5, (0, 1, 0, 1)),
                            (0.85, 0.85, 0.01, (0.8, 0.9, 0.8, 0.86))):
        x0, x1, y0, y1 = rect

        def g(x):
            c = math.sqrt(max(0.0, 0.25 - (x - 0.5) ** 2))
            lo, hi = max(y0, 0.5 - c), min(y1, 0.5 + c)
            if hi <= lo:
                return 0.0
            return stats.norm.pdf(x, cx, s) * (stats.norm.cdf(hi, cy, s) - stats.norm.cdf(lo, cy, s))

        ref, _ = integrate.quad(g, max(x0, cx - 12 * s, 0), min(x1, cx + 12 * s, 1), epsabs=1e-15, epsrel=1e-13,
                                limit=500, points=[cx])
        assert _core.gaussian_in_disk_rect(cx, cy, s, x0, x1, y0, y1) == pytest.approx(ref, rel=1e-9, abs=1e-14)
    # The closed-form area of a rectangle's part of the disk (the x_a-region probabilities).
    assert _core.rect_disk_area(0, 1, 0, 1) == pytest.approx(math.pi / 4, rel=1e-14)
    assert _core.rect_disk_area(0.5, 1, 0.5, 1) == pytest.approx(math.pi / 16, rel=1e-14)
    a, _ = integrate.quad(lambda x: max(0.0, min(0.95, 0.5 + math.sqrt(0.25 - (x - .5) ** 2))
                                        - max(0.7, 0.5 - math.sqrt(0.25 - (x - .5) ** 2))), 0.1, 0.3, epsabs=1e-13)
    assert _core.rect_disk_area(0.1, 0.3, 0.7, 0.95) == pytest.approx(a, rel=1e-9)


def test_error_messages_name_the_element_and_its_value():
    nd = gl.glinty_ndf("kpt25", density=1e4)
    uv = np.full((5, 2), 0.3)
    J = np.tile([1e-3, 0.0, 0.0, 1e-3], (5, 1))
    h = np.tile([0.0, 0.0, 1.0], (5, 1))
    bad = uv.copy()
    bad[3, 0] = 1e12
    with pytest.raises(ValueError, match=r"uv\[3, 0\] = 1000000000000 "):
        nd.evaluate(bad, J, h)
    bad = uv.copy()
    bad[2, 1] = float("nan")
    with pytest.raises(ValueError, match=r"uv\[2, 1\] = nan"):
        nd.reference(bad, J, h)
    badJ = J.copy()
    badJ[2] = [1e-3, 1e-3, 1e-3, 1e-3]
    with pytest.raises(ValueError, match=r"J\[2\] = \(0\.001, 0\.001, 0\.001, 0\.001\).*det J"):
        nd.evaluate(uv, badJ, h)
    # An image-shaped input: the multi-index of the caller's array.
    with pytest.raises(ValueError, match=r"J\[0, 1\] = \[3\.16, 0, 0, 3\.16\].*MIP level"):
        gl.glinty_ndf("kpt25", density=1e12).evaluate(uv.reshape(1, 5, 2)[:, :2],
                                                      np.array([[[1e-3, 0, 0, 1e-3], [3.16, 0, 0, 3.16]]]),
                                                      h.reshape(1, 5, 3)[:, :2])
    badh = h.copy()
    badh[4, 1] = float("inf")
    with pytest.raises(ValueError, match=r"h\[4, 1\] = inf"):
        nd.pdf(uv, J, badh)
    Jr = np.tile([1e-8, 0.0, 0.0, 1e-8], (5, 1))
    Jr[3] = [5e-3, 0, 0, 5e-3]
    with pytest.raises(ValueError, match=r"J\[3\] = \[0\.005, 0, 0, 0\.005\].*reference sums at most"):
        gl.glinty_ndf("kpt25", density=1e12, alpha_star=0.5).reference(uv, Jr, h)


def test_cells_beyond_32_bits_have_their_own_points_and_far_uv_is_refused():
    # Issue 37: spatial cells 2^32 apart shared their points (the indices were hashed in 32 bits) while
    # |uv| <= 1e9 was accepted; every bit is hashed now (cells in [-2^31, 2^31) keep their numbers), and
    # positions beyond 2^38 cells of the origin are refused by name (docs/math/glinty_ndf.md#glinty-process).
    nd = gl.glinty_ndf("kpt25", density=1e4, alpha=0.5, alpha_star=0.05, k=1)  # 100 cells per unit uv
    rng = np.random.default_rng(6)
    n = 400
    uv = rng.uniform(0, 1, (n, 2))
    J = np.tile([0.02, 0.0, 0.0, 0.02], (n, 1))
    h = np.column_stack([rng.normal(0, 0.2, (n, 2)), np.ones(n)])
    base = nd.reference(uv, J, h, seed=2)
    assert base.std() > 0
    for shift in ([2.0**32 / 100, 0.0], [0.0, -(2.0**32) / 100]):  # 4.3e7 uv units: 2^32 cells
        far = nd.reference(uv + shift, J, h, seed=2)  # the same points would agree to rounding (corr 1)
        assert np.corrcoef(base, far)[0, 1] < 0.5
    dense = gl.glinty_ndf("kpt25", density=1e12)  # 1e6 cells per unit uv: the limit is 2^38 / 1e6 = 2.7e5
    with pytest.raises(ValueError, match=r"uv\[0, 0\] = 300000 .*2\^38 spatial cells"):
        dense.evaluate([[3e5, 0.0]], [[1e-6, 0, 0, 1e-6]], [[0.0, 0.0, 1.0]])
    assert np.isfinite(dense.evaluate([[2.5e5, -2.5e5]], [[1e-6, 0, 0, 1e-6]], [[0.0, 0.0, 1.0]])).all()
