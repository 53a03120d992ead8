"""KPT25's UV-free (triplanar) glints (docs/math/glinty_ndf.md#glinty-triplanar): three point processes
on the yz, xz and xy planes of the world position, blended by the roulette on weights from the normal.

Statistical checks: fixed seeds, |z| < 4.5 on means of >= 2500 pixels (two-sided false-failure rate
7e-6 per check under the normal approximation; 12 checks here, so about 1e-4 for the file); each is
shown to reject a deliberately wrong variant (the printed, unnormalised weights; a missing plane; a
glint density that ignores the planes' projected areas). Pixels lie 400 units apart at most on a plane
through the origin, far beyond a cell of side 1 / sqrt(K_P), so they share no points.
"""
import math

import numpy as np
import pytest

import glintlab as gl

Z = 4.5
KW = dict(density=1e4, alpha=0.5, alpha_star=0.05)


def frame(nv):
    n = np.asarray(nv, float)
    n = n / np.linalg.norm(n)
    a = np.array([0.3, 0.5, 1.0]) if abs(n[2]) < 0.9 else np.array([1.0, 0.2, 0.1])
    t = np.cross(n, a)
    t /= np.linalg.norm(t)
    return n, t, np.cross(n, t)


def surface(nv, m, side, seed):
    """m pixels on the plane through 0 with normal nv: positions, dP = (side t, side b), the frame."""
    n, t, b = frame(nv)
    P = np.random.default_rng(seed).uniform(-200, 200, (m, 3))
    P -= (P @ n)[:, None] * n
    return n, t, b, P, np.concatenate([side * t, side * b])


def half(n, t, b, theta, phi=0.7):
    return math.sin(theta) * (math.cos(phi) * t + math.sin(phi) * b) + math.cos(theta) * n


def z_score(x, target):
    return (x.mean() - target) / (x.std(ddof=1) / math.sqrt(x.size))


NORMALS = [(1, 0, 0), (0, 0, -1), (1, 0.01, 0.02), (1, 1, 0), (1, 1, 1), (0.3, -0.5, 0.8)]


def test_triplanar_mean_is_the_targets_at_every_normal_and_a_wrong_blend_is_rejected():
    # Exact roulette (epsilon = 0): E = D(h) x (the lobe's mass in U), the uv-mapped model's expectation,
    # computed here by the uv-mapped model (an independent path), whatever the normal.
    tri = gl.glinty_ndf("kpt25", mapping="triplanar", epsilon=0.0, **KW)
    uvm = gl.glinty_ndf("kpt25", epsilon=0.0, **KW)
    printed = gl.glinty_ndf("kpt25", mapping="triplanar", epsilon=0.0, triplanar_weights="printed", **KW)
    missing = gl.glinty_ndf("kpt25", mapping="triplanar", epsilon=0.0, triplanar_weights="missing_xy", **KW)
    m, theta = 2500, 0.4
    for i, nv in enumerate(NORMALS):
        n, t, b, P, dP = surface(nv, m, 0.05, i)
        h = half(n, t, b, theta)
        target = uvm.expected([0.05, 0, 0, 0.05], [math.sin(theta), 0, math.cos(theta)])[0]
        e_ref, e_alg = tri.expected(dP, h, n=n)
        assert e_ref == pytest.approx(target, rel=1e-12), nv
        r = tri.reference(P, dP, h, seed=i, n=n)
        e = tri.evaluate(P, dP, h, seed=i, n=n)
        assert abs(z_score(r, target)) < Z, (nv, r.mean(), target)
        assert abs(z_score(e, e_alg)) < Z, (nv, e.mean(), e_alg)
        if nv in ((1, 1, 1), (1, 1, 0)):  # where the weights cross, both wrong blends are rejected
            rp = printed.reference(P, dP, h, seed=i, n=n)
            assert z_score(rp, target) > Z, (nv, rp.mean() / target)
            assert printed.expected(dP, h, n=n)[0] == pytest.approx(target * np.abs(n).sum(), rel=1e-12)
        if nv == (1, 1, 1):
            rm = missing.reference(P, dP, h, seed=i, n=n)
            assert z_score(rm, target) < -Z, (nv, rm.mean() / target)


def test_mollified_roulette_bias_is_the_sum_of_the_keep_rates():
    # With epsilon > 0, E over r of R(r, w) differs from w within epsilon of 0 and 1, and three weights'
    # keep rates need not add up to 1 (two do: rho(w) + rho(1 - w) = 1). Keep rates checked against a
    # quadrature of eq. 8 written here; the blend's exact mean is their sum times the target.
    tri = gl.glinty_ndf("kpt25", mapping="triplanar", epsilon=0.1, **KW)
    r = (np.arange(200000) + 0.5) / 200000

    def rho(w):
        lo, hi = np.maximum(0, r - 0.1), np.minimum(1, r + 0.1)
        x = np.clip((w - lo) / (hi - lo), 0, 1)
        return float(np.mean(x * x * (3 - 2 * x)))

    for w in (0.0, 0.03, 0.08, 0.3, 0.5, 0.95, 1.0):
        assert tri.keep_rate(w) == pytest.approx(rho(w), abs=1e-6), w
    uvm = gl.glinty_ndf("kpt25", epsilon=0.1, **KW)
    n, t, b, _, dP = surface((1, 0.3, 0.1), 1, 0.05, 0)
    h = half(n, t, b, 0.4)
    w = tri.triplanar_weights(n)
    bias = sum(rho(x) for x in w) - 1
    assert abs(bias) > 0.01  # a weight below epsilon: the blend loses about 1.5 % of the mean
    target = uvm.expected([0.05, 0, 0, 0.05], [math.sin(0.4), 0, math.cos(0.4)])[0]
    assert tri.expected(dP, h, n=n)[0] == pytest.approx(target * (1 + bias), rel=1e-5)


def test_glint_density_follows_the_planes_projected_areas():
    # The points kept in the truncated filters (Mahalanobis radius 3: area 9 pi f^2 |det J_i| = (9/4)
    # |det J_i|), K_P pi / 4 per unit area of each plane (those whose normal lies in U), kept at rate
    # w_i: E = K_P (pi / 4)(9 / 4) sum_i w_i |(dP/dx x dP/dy)_i|. Relative to an axis-aligned normal
    # the glints per unit surface area are sum_i w_i |n_i|: 1, 0.707 and 0.577 at the axis and the two
    # diagonals. A density that ignored the projection (1 everywhere) is rejected at the diagonal.
    tri = gl.glinty_ndf("kpt25", mapping="triplanar", epsilon=0.0, **KW)
    m = 2500
    for i, nv in enumerate([(0, 1, 0), (1, -1, 0), (1, 1, 1)]):
        n, t, b, P, dP = surface(nv, m, 0.05, 20 + i)
        h = half(n, t, b, 0.4)
        _, kept = tri.reference(P, dP, h, seed=i, n=n, return_points=True)
        w = tri.triplanar_weights(n)
        area = np.abs(np.cross(dP[:3], dP[3:]))
        expect = 1e4 * (math.pi / 4) * (9 / 4) * float(w @ area)
        assert abs(z_score(kept, expect)) < Z, (nv, kept.mean(), expect)
        rel = float(w @ np.abs(n))
        assert rel == pytest.approx({0: 1.0, 1: math.sqrt(0.5), 2: math.sqrt(1 / 3)}[i], rel=1e-12)
        if i == 2:
            flat = 1e4 * (math.pi / 4) * (9 / 4) * float(np.linalg.norm(np.cross(dP[:3], dP[3:])))
            assert z_score(kept, flat) < -Z


def test_shared_plane_seeds_correlate_the_planes_where_they_see_the_same_coordinates():
    # On the surface x = y the yz and xz planes see the same coordinates (y, z) = (x, z): with one shared
    # point process they keep the same points, doubling the variance at equal weights; one process per
    # plane (the default) does not. Elsewhere the two agree. Fixed seed; the ratios (about 2 and 1)
    # are far from the bounds (sampling spread of a variance ratio of 4000 heavy-tailed pixels: ~0.1).
    kw = dict(mapping="triplanar", epsilon=0.0, **KW)
    distinct = gl.glinty_ndf("kpt25", **kw)
    shared = gl.glinty_ndf("kpt25", plane_seeds="shared", **kw)
    m = 3000
    n, t, b, P, dP = surface((1, -1, 0), m, 0.05, 7)
    h = half(n, t, b, 0.4)
    ratio = shared.reference(P, dP, h, seed=3, n=n).var() / distinct.reference(P, dP, h, seed=3, n=n).var()
    assert ratio > 1.5, ratio
    n, t, b, P, dP = surface((1, -0.8, 0.3), m, 0.05, 8)
    h = half(n, t, b, 0.4)
    ratio = shared.reference(P, dP, h, seed=3, n=n).var() / distinct.reference(P, dP, h, seed=3, n=n).var()
    assert 0.7 < ratio < 1.4, ratio


def test_triplanar_is_deterministic_and_refuses_bad_input_by_name():
    tri = gl.glinty_ndf("kpt25", mapping="triplanar", **KW)
    n, t, b, P, dP = surface((0.2, 0.5, 0.9), 50, 0.05, 1)
    h = half(n, t, b, 0.3)
    a = tri.evaluate(P, dP, h, seed=4, n=n)
    assert np.array_equal(a, tri.evaluate(P, dP, h, seed=4, n=n))
    assert not np.array_equal(a, tri.evaluate(P, dP, h, seed=5, n=n))
    # (..., 2, 3) derivatives are the same as (..., 6)
    assert np.array_equal(a, tri.evaluate(P, dP.reshape(2, 3), h, seed=4, n=n))
    with pytest.raises(ValueError, match="n = None"):
        tri.evaluate(P, dP, h, seed=4)
    with pytest.raises(ValueError, match=r"n\[3\] = \[0, 0, 0\]"):
        nn = np.tile(n, (50, 1))
        nn[3] = 0
        tri.evaluate(P, dP, h, seed=4, n=nn)
    with pytest.raises(ValueError, match=r"dP\[0\] = "):
        tri.evaluate(P[:1], np.concatenate([dP[:3], 2 * dP[:3]]), h, n=n)
    with pytest.raises(ValueError, match=r"position\[0, 1\]"):
        tri.evaluate([[0.0, np.nan, 0.0]], dP, h, n=n)
    with pytest.raises(ValueError, match="mapping"):
        tri.sample(P[:, :2], np.tile([0.01, 0, 0, 0.01], (50, 1)))
    for bad, name in ((dict(triplanar_sharpness=0.0), "triplanar_sharpness"), (dict(triplanar_weights="x"), "triplanar_weights"),
                      (dict(plane_seeds="x"), "plane_seeds"), (dict(mapping="box"), "mapping"),
                      (dict(alpha=(0.3, 0.5)), "alpha"), (dict(anisotropy=(2.0, 1.0)), "anisotropy"),
                      (dict(colors=[[1, 0, 0]]), "colors")):
        with pytest.raises(ValueError, match=name):
            gl.glinty_ndf("kpt25", **{**KW, "mapping": "triplanar", **bad})
