"""KPT25's pdf per steradian, checked independently of its Jacobian formula (issue 37, items 3 and 4;
docs/math/glinty_ndf.md#glinty-lambert, #glinty-sampling).

With ``sample_smooth=1`` every draw is x_a, uniform on the disk U, so the pdf per steradian is
(4 / pi) |J_T(h)|: its integral over the hemisphere must be 1 for every map, target and roughness. The
integral here is this file's own quadrature over the hemisphere (Gauss-Legendre in theta on pieces
placed by the roughness, the midpoint rule in phi, exact for trigonometric polynomials of degree below
the point count); the Jacobian is also checked pointwise against finite differences of the map T
(``nd.map``), which uses nothing of the pdf. Neither check reads the Jacobian formula.

Tolerances: the quadrature's own error is below 1e-9 at these settings (checked on the orthographic
map, whose integral is known to be 1); the integral must be 1 within 1e-6. The finite differences'
truncation and rounding error is below 1e-6 relative at the step used; the pointwise check allows
1e-5. Deterministic: no sampled statistic.

Each check is shown to fail on the deliberately wrong reading ``lambert_jacobian="printed"`` (eq. 6's
printed exponent: (pi / 8) D(h), the formula glintlab used before; its integral is 0.588 at alpha 0.3).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

import glintlab as gl

UV, J = (0.3, 0.7), (0.01, 0.0, 0.0, 0.01)  # one point per hundred footprints: the smooth share only


def ndf(**kw):
    return gl.glinty_ndf("kpt25", density=1e2, alpha_star=0.05, sample_smooth=1.0, **kw)


def pdf_at(nd, h):
    h = np.asarray(h, float).reshape(-1, 3)
    n = len(h)
    return nd.pdf(np.tile(UV, (n, 1)), np.tile(J, (n, 1)), h, seed=1)


def hemisphere_integral(nd, alpha_min, anisotropic):
    """The integral of nd's pdf over the hemisphere, sin(theta) dtheta dphi: Gauss-Legendre (16 nodes)
    on theta pieces with breakpoints atan(alpha_min c), c from 1e-3 to 1e3 (the lobe's scale), and
    the midpoint rule in phi (8 points when the pdf does not depend on phi, 256 otherwise). One call
    of the pdf for every node (a call has a fixed cost of its own)."""
    x, w = np.polynomial.legendre.leggauss(16)
    cuts = np.concatenate([[0.0], np.arctan(alpha_min * np.geomspace(1e-3, 1e3, 31)), [0.5 * math.pi]])
    a, b = cuts[:-1, None], cuts[1:, None]
    theta = (0.5 * (b - a) * x + 0.5 * (b + a)).ravel()
    w_theta = (0.5 * (b - a) * w).ravel() * np.sin(theta)
    nph = 256 if anisotropic else 8
    phi = (np.arange(nph) + 0.5) * 2 * math.pi / nph
    T, P = np.meshgrid(theta, phi, indexing="ij")
    h = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], axis=-1)
    p = pdf_at(nd, h).reshape(T.shape)
    return float(np.sum(p * w_theta[:, None])) * 2 * math.pi / nph


CASES = [(target, m, a) for target, m in (("beckmann", "orthographic"), ("ggx", "orthographic"), ("ggx", "lambert"))
         for a in (0.05, 0.3, 1.0, 1.6, (0.6, 0.2), (0.1, 0.9))]


@pytest.mark.parametrize("target,ggx_map,alpha", CASES)
def test_pdf_integrates_to_one_over_the_hemisphere(target, ggx_map, alpha):
    nd = ndf(target=target, alpha=alpha, ggx_map=ggx_map)
    aniso = isinstance(alpha, tuple)
    total = hemisphere_integral(nd, min(alpha) if aniso else alpha, aniso)
    assert abs(total - 1.0) < 1e-6, (target, ggx_map, alpha, total)


@pytest.mark.parametrize("alpha,expected", [(0.3, 0.588), (1.6, 1.418), ((0.6, 0.2), None)])
def test_printed_exponent_fails_the_integral(alpha, expected):
    # Eq. 6 read with its printed exponent 4 gives the Jacobian (pi / 8) D(h): the pdf then integrates
    # to half the GGX mass of D(h) dOmega, 0.588 at alpha 0.3 and 1.418 at 1.6 (not 1).
    nd = ndf(target="ggx", alpha=alpha, ggx_map="lambert", lambert_jacobian="printed")
    aniso = isinstance(alpha, tuple)
    total = hemisphere_integral(nd, min(alpha) if aniso else alpha, aniso)
    assert abs(total - 1.0) > 0.05, total
    if expected is not None:
        assert total == pytest.approx(expected, abs=1e-3)


def map_jacobian(nd, h, step=1e-5):
    """|dT / dOmega| at unit half vectors h (n, 3) by central differences of nd.map in an orthonormal
    tangent frame (t1, t2) of h: h(s, t) = normalise(h + s t1 + t t2) has dOmega = ds dt at s = t = 0."""
    t1 = np.cross(h, [0.0, 1.0, 0.0])
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    t2 = np.cross(h, t1)
    d_s = (nd.map(h + step * t1) - nd.map(h - step * t1)) / (2 * step)
    d_t = (nd.map(h + step * t2) - nd.map(h - step * t2)) / (2 * step)
    return np.abs(d_s[:, 0] * d_t[:, 1] - d_s[:, 1] * d_t[:, 0])


@pytest.mark.parametrize("alpha", [0.3, 1.6, (0.6, 0.2)])
def test_pdf_is_the_map_jacobian_pointwise(alpha):
    rng = np.random.default_rng(5)
    theta = rng.uniform(0.05, 1.3, 200)
    phi = rng.uniform(0, 2 * math.pi, 200)
    h = np.column_stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])
    for ggx_map in ("orthographic", "lambert"):
        nd = ndf(target="ggx", alpha=alpha, ggx_map=ggx_map)
        jac = map_jacobian(nd, h)
        np.testing.assert_allclose(pdf_at(nd, h) * math.pi / 4, jac, rtol=1e-5)
    printed = ndf(target="ggx", alpha=alpha, ggx_map="lambert", lambert_jacobian="printed")
    ratio = pdf_at(printed, h) * math.pi / 4 / map_jacobian(printed, h)
    assert np.max(np.abs(ratio - 1)) > 0.05


def test_lambert_jacobian_option_is_checked():
    for bad in (dict(target="ggx", lambert_jacobian="exponent4"),
                dict(target="ggx", ggx_map="orthographic", lambert_jacobian="printed")):
        with pytest.raises(ValueError, match="lambert_jacobian"):
            gl.glinty_ndf("kpt25", **bad)
    nd = gl.glinty_ndf("kpt25", target="ggx", ggx_map="lambert", lambert_jacobian="printed")
    assert nd.params["lambert_jacobian"] == "printed"


# ---------------------------------------------------------------------------------------------------
# Item 4: the reflected directions of pixel_sampler(wo=...) and their pdf.

@pytest.mark.parametrize("wo", [(1.0, 0.0, 0.02), (0.3, -0.2, 1.0), (-0.6, 0.7, 1e-3)])
def test_reflected_draws_and_their_pdf_agree_at_grazing_wo(wo):
    nd = gl.glinty_ndf("kpt25", density=1e4, alpha=0.5, alpha_star=0.05)
    uv, Jp = (0.2, 0.3), (0.01, 0.0, 0.0, 0.01)
    s = nd.pixel_sampler(uv, Jp, seed=2, wo=wo)
    n = 20000
    wi, p = s.sample(n, seed=1)
    h, ph = nd.pixel_sampler(uv, Jp, seed=2).sample(n, seed=1)  # the same draws, as half vectors
    w = np.asarray(wo, float) / np.linalg.norm(wo)
    facing = np.isfinite(h[:, 0]) & (h @ w > 0)
    # Policy: a half vector facing away from wo reflects nothing (wi NaN, pdf 0); every other draw is
    # reflected, and its pdf is the one pdf(wi) gives, to the bit.
    np.testing.assert_array_equal(np.isfinite(wi).all(axis=1), facing)
    assert np.all(p[~facing] == 0) and np.all(p[facing] > 0)
    np.testing.assert_array_equal(p[facing], s.pdf(wi[facing]))
    # ... and pdf(h) / (4 wo.h) of the drawn half vector, to the conditioning of h given wi near grazing.
    cos_h = h[facing] @ w
    rel = np.abs(p[facing] * 4 * cos_h / ph[facing] - 1)
    assert np.all(rel <= 1e-12 / cos_h**2), float(np.max(rel * cos_h**2))
    if wo[2] < 0.1:  # at grazing wo a large share of the half vectors face away
        assert (~facing).mean() > 0.2
    # The pdf of wi integrates to the share of draws reflected: no density is put where nothing lands
    # (directions whose rebuilt half vector faces away cannot occur: wo.normalise(wi + wo) > 0 always).
    _, _, wi_core = nd.sample(np.tile(uv, (n, 1)), np.tile(Jp, (n, 1)), seed=2, draw_seed=1, wo=w)
    np.testing.assert_array_equal(np.isnan(wi_core[:, 0]), ~facing)


def test_harness_passes_the_reflected_sampler_at_grazing_wo():
    # The user's verdict (docs/math/sampling.md): at wo 3 degrees above the horizon a third of the half
    # vectors face away from wo; they are lost draws, their number is the mass the pdf of wi lacks, and no
    # draw's pdf disagrees with pdf(wi) (before issue 37: a third of the draws mismatched).
    nd = gl.glinty_ndf("kpt25", density=1e4, alpha=0.5, alpha_star=0.05)
    s = nd.pixel_sampler((0.2, 0.3), (0.01, 0.0, 0.0, 0.01), seed=2, wo=(1.0, 0.0, 0.05))
    r = gl.sampler_test(s, samples=50000, seed=1)
    assert r.mismatches == 0 and r.checked > 30000
    assert r.lost > 10000 and r.pvalue_lost > 1e-4
    assert r.passed, r
