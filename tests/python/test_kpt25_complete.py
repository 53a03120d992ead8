"""KPT25 as printed, completed (docs/math/glinty_ndf.md): the like-for-like density mapping with DB23
(#glinty-matched) and anisotropic roughness (#glinty-anisotropy). The map T's own tests (and the Lambert
option's) are in test_kpt25_sampling.py.

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


# ---------------------------------------------------------------------------------------------------
# Anisotropic roughness alpha = (alpha_x, alpha_y)

def aniso_D(target, ax, ay, h):
    """The anisotropic target written independently: Beckmann exp(-(s_x^2 / ax^2 + s_y^2 / ay^2)) /
    (pi ax ay cos^4), GGX 1 / (pi ax ay (x^2 / ax^2 + y^2 / ay^2 + z^2)^2), h normalised."""
    h = np.asarray(h, float) / np.linalg.norm(h, axis=-1, keepdims=True)
    x, y, z = h[..., 0], h[..., 1], h[..., 2]
    if target == "beckmann":
        return np.exp(-((x / z / ax) ** 2 + (y / z / ay) ** 2)) / (math.pi * ax * ay * z**4)
    return 1.0 / (math.pi * ax * ay * ((x / ax) ** 2 + (y / ay) ** 2 + z * z) ** 2)


def aniso_draws(target, ax, ay, n, seed):
    """Half vectors from the anisotropic D(h)(h.n) dOmega: Beckmann slopes are N(0, a^2 / 2) per axis;
    GGX by Walter et al.'s inversion (tan phi = (ay / ax) tan 2 pi u, tan^2 theta = v / (1 - v) /
    (cos^2 phi / ax^2 + sin^2 phi / ay^2))."""
    rng = np.random.default_rng(seed)
    if target == "beckmann":
        s = rng.normal(size=(n, 2)) * np.array([ax, ay]) / math.sqrt(2)
        v = np.column_stack([s, np.ones(n)])
    else:
        u, w = rng.uniform(size=n), rng.uniform(size=n)
        phi = np.arctan(ay / ax * np.tan(2 * math.pi * u)) + math.pi * np.round(2 * u)
        t2 = w / (1 - w) / (np.cos(phi) ** 2 / ax**2 + np.sin(phi) ** 2 / ay**2)
        v = np.column_stack([np.sqrt(t2) * np.cos(phi), np.sqrt(t2) * np.sin(phi), np.ones(n)])
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def ring_sector_p(y, rings=10, sectors=8):
    d = 2 * np.asarray(y) - 1
    ring = np.minimum((np.sum(d * d, axis=1) * rings).astype(int), rings - 1)
    sec = ((np.arctan2(d[:, 1], d[:, 0]) + math.pi) / (2 * math.pi) * sectors).astype(int) % sectors
    from scipy import stats
    return stats.chisquare(np.bincount(ring * sectors + sec, minlength=rings * sectors)).pvalue


@pytest.mark.parametrize("target", ["beckmann", "ggx"])
def test_anisotropic_roughness_map_and_D(target):
    ax, ay = 0.2, 0.6
    nd = gl.glinty_ndf("kpt25", target=target, alpha=(ax, ay))
    swapped = gl.glinty_ndf("kpt25", target=target, alpha=(ay, ax))
    # D(h) of the core (through nd.pixel) and of nd.smooth against the formula written here.
    rng = np.random.default_rng(4)
    h = np.column_stack([rng.normal(0, 0.4, (50, 2)), np.ones(50)])
    np.testing.assert_allclose(nd.smooth(h), aniso_D(target, ax, ay, h), rtol=1e-12)
    np.testing.assert_allclose([nd.pixel([0.01, 0, 0, 0.01], hh)["D"] for hh in h], aniso_D(target, ax, ay, h),
                               rtol=1e-12)
    # T on its own: the anisotropic D(h)(h.n) maps to the uniform disk; the swapped stretch is rejected.
    hs = aniso_draws(target, ax, ay, 40000, seed=9)
    assert ring_sector_p(nd.map(hs)) > 1e-6
    assert ring_sector_p(swapped.map(hs)) < 1e-6
    assert gl.glinty_ndf("kpt25", target=target, alpha=(0.3, 0.3)).params["alpha"] == 0.3
    with pytest.raises(ValueError, match="alpha"):
        gl.glinty_ndf("kpt25", target=target, alpha=(0.3, -1.0))
    with pytest.raises(ValueError, match="alpha"):
        gl.glinty_ndf("kpt25", target=target, alpha=(0.3, 0.2, 0.1))


@pytest.mark.parametrize("target", ["beckmann", "ggx"])
def test_anisotropic_means_are_the_anisotropic_D(target):
    # E[reference] and E[evaluate] against the anisotropic D(h) written independently: exact (expected)
    # and sampled (12000 pixels, |z| < 4.5); the isotropic D and the swapped axes are rejected.
    ax, ay = 0.25, 0.5
    nd = gl.glinty_ndf("kpt25", density=1e6, target=target, alpha=(ax, ay), alpha_star=0.02, k=4)
    n = 6000
    rng = np.random.default_rng(11)
    uv = rng.uniform(-5, 5, (n, 2))
    J = np.tile([0.002, 0.0003, -0.0002, 0.0018], (n, 1))
    h = np.tile([0.2, 0.05, 1.0], (n, 1))  # T(h) > 6 lobe stds from the rim of U: no energy lost
    D = aniso_D(target, ax, ay, h[0])
    e_ref, e_alg = nd.expected(J[:1], h[:1])
    assert e_ref[0] == pytest.approx(D, rel=1e-6) and e_alg[0] == pytest.approx(D, rel=1e-6)
    ref = np.concatenate([nd.reference(uv, J, h, seed=s) for s in (1, 2)])
    alg = np.concatenate([nd.evaluate(uv, J, h, seed=s) for s in (1, 2)])
    for x in (ref, alg):
        assert abs(z_score(x, D)) < Z
        assert abs(z_score(x, aniso_D(target, ay, ax, h[0]))) > Z
        assert abs(z_score(x, aniso_D(target, ax, ax, h[0]))) > Z


# ---------------------------------------------------------------------------------------------------
# Per-facet colour: colors = (m, 3) palette, RGB output

PALETTE = [[1.0, 0.2, 0.1], [0.9, 0.8, 0.1], [0.1, 0.3, 1.0]]


def test_colored_means_are_the_expected_color_and_an_uncolored_compensation_fails():
    # k = 1 and wide lobes: the compensation carries about 2/3 of the mean, so its colour matters.
    kw = dict(density=1e6, target="beckmann", alpha=0.5, alpha_star=0.1, k=1)
    nd = gl.glinty_ndf("kpt25", colors=PALETTE, **kw)
    np.testing.assert_allclose(nd.expected_color, np.mean(PALETTE, axis=0), rtol=1e-15)
    n = 6000
    rng = np.random.default_rng(13)
    uv = rng.uniform(-5, 5, (n, 2))
    J = np.tile([0.002, 0.0003, -0.0002, 0.0018], (n, 1))
    h = np.tile([0.2236, 0.0, 1.0], (n, 1))
    # The exact scalar expectations (the lobe loses a little mass outside U here) times E[GlintColor].
    e_ref, e_alg = (float(e[0]) for e in gl.glinty_ndf("kpt25", **kw).expected(J[:1], h[:1]))
    ref = np.concatenate([nd.reference(uv, J, h, seed=s) for s in (1, 2)])
    alg = np.concatenate([nd.evaluate(uv, J, h, seed=s) for s in (1, 2)])
    assert ref.shape == alg.shape == (2 * n, 3)
    for x, e in ((ref, e_ref), (alg, e_alg)):
        for c in range(3):
            assert abs(z_score(x[:, c], e * nd.expected_color[c])) < Z, (c, x[:, c].mean(), e)
        # Wrong: every glint the first palette entry's colour.
        assert max(abs(z_score(x[:, c], e * PALETTE[0][c])) for c in range(3)) > Z
    target = e_alg * nd.expected_color
    # Wrong: Algorithm 1 with an uncoloured (white) compensation, built from the same realization: the
    # explicit part (compensation "none") plus the scalar compensation in every channel.
    none = gl.glinty_ndf("kpt25", colors=PALETTE, **{**kw, "compensation": "none"})
    scalar, scalar_none = gl.glinty_ndf("kpt25", **kw), gl.glinty_ndf("kpt25", **{**kw, "compensation": "none"})
    explicit = np.concatenate([none.evaluate(uv, J, h, seed=s) for s in (1, 2)])
    comp = np.concatenate([scalar.evaluate(uv, J, h, seed=s) - scalar_none.evaluate(uv, J, h, seed=s) for s in (1, 2)])
    np.testing.assert_allclose(explicit + comp[:, None] * nd.expected_color, alg, rtol=1e-9, atol=1e-12)
    white = explicit + comp[:, None]
    assert max(abs(z_score(white[:, c], target[c])) for c in range(3)) > Z
    # A grey palette of ones reproduces the scalar NDF in each channel (same realization).
    grey = gl.glinty_ndf("kpt25", colors=np.ones((4, 3)), **kw)
    np.testing.assert_allclose(grey.evaluate(uv[:200], J[:200], h[:200], seed=1),
                               np.repeat(scalar.evaluate(uv[:200], J[:200], h[:200], seed=1)[:, None], 3, axis=1),
                               rtol=1e-12)
    np.testing.assert_allclose(grey.reference(uv[:200], J[:200], h[:200], seed=1),
                               np.repeat(scalar.reference(uv[:200], J[:200], h[:200], seed=1)[:, None], 3, axis=1),
                               rtol=1e-12)
    for bad in ([[1.0, 0.0]], [[1.0, -0.1, 0.0]], [[1.0, float("nan"), 0.0]], np.zeros((0, 3))):
        with pytest.raises(ValueError, match="colors"):
            gl.glinty_ndf("kpt25", colors=bad)


# ---------------------------------------------------------------------------------------------------
# Anisotropic glints: Algorithm 1's A_* = diag(a_x, a_y)

def test_anisotropic_glints_keep_the_mean_and_the_printed_density_does_not():
    kw = dict(density=1e6, target="beckmann", alpha=0.5, alpha_star=0.03, k=4)
    n = 6000
    rng = np.random.default_rng(17)
    uv = rng.uniform(-5, 5, (n, 2))
    J = np.tile([0.002, 0.0003, -0.0002, 0.0018], (n, 1))
    h = np.tile([0.2236, 0.0, 1.0], (n, 1))
    D = float(gl.glinty_ndf("kpt25", **kw).smooth(h[0]))
    nd = gl.glinty_ndf("kpt25", anisotropy=(4.0, 0.5), **kw)
    printed = gl.glinty_ndf("kpt25", anisotropy=(4.0, 0.5), anisotropy_density="printed", **kw)
    # The lobes (std alpha_star sqrt(D) / a per axis) lie well inside U here: E = D(h).
    ref = np.concatenate([nd.reference(uv, J, h, seed=s) for s in (1, 2)])
    alg = np.concatenate([nd.evaluate(uv, J, h, seed=s) for s in (1, 2)])
    for x in (ref, alg):
        assert abs(z_score(x, D)) < Z
    # As printed: grid resolution sqrt(N) det(A_*^-1) (N / det^2 points per unit x_s area) and line 19's
    # 1 / N: a mean of D / det(A_*)^2 = D / 4, rejected against D.
    p_ref = np.concatenate([printed.reference(uv, J, h, seed=s) for s in (1, 2)])
    assert abs(z_score(p_ref, D / 4.0)) < Z and abs(z_score(p_ref, D)) > Z
    # The glints are stretched: the angular lobe is narrower along x (a_x = 4) than along y.
    px = nd.pixel(J[0], h[0])
    assert px["sigma"] == pytest.approx(0.03 * math.sqrt(D) / 4.0, rel=1e-12)
    # The identity A_* is the isotropic NDF, to the bit.
    iso = gl.glinty_ndf("kpt25", anisotropy=(1.0, 1.0), **kw)
    np.testing.assert_array_equal(iso.evaluate(uv[:300], J[:300], h[:300], seed=1),
                                  gl.glinty_ndf("kpt25", **kw).evaluate(uv[:300], J[:300], h[:300], seed=1))
    with pytest.raises(ValueError, match="anisotropy"):
        nd.expected(J[:1], h[:1])
    with pytest.raises(ValueError, match="anisotropy"):
        gl.glinty_ndf("kpt25", anisotropy=(0.0, 1.0))
    with pytest.raises(ValueError, match="compensation"):
        gl.glinty_ndf("kpt25", anisotropy=(2.0, 1.0), compensation="disk")
