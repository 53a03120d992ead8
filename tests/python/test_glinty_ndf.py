"""Glinty NDFs (gl.glinty_ndf): KPT25's reference against an independent brute-force sum, Algorithm 1
against the reference, means against exact expectations and the smooth target, determinism, bad input.

Statistical checks use fixed seeds and |z| < 4.5 (two-sided false-failure rate 7e-6 per check under a
normal approximation of the mean of >= 2000 independent pixels); each is shown to fail on a wrong NDF.
"""
import math

import numpy as np
import pytest

import glintlab as gl

# ---------------------------------------------------------------------------------------------------
# An independent brute-force implementation of the documented point process (docs/math/glinty_ndf.md):
# its own Philox4x32-10, its own maps T, filter, levels and roulette, and a plain sum over every cell.
M0, M1, W0, W1 = 0xD2511F53, 0xCD9E8D57, 0x9E3779B9, 0xBB67AE85
MASK = np.uint64(0xFFFFFFFF)


def philox4x32(c, key):
    """Philox4x32-10 of counters c (4 uint64 arrays holding 32-bit words) under key (k0, k1)."""
    c = [np.asarray(x, dtype=np.uint64) & MASK for x in c]
    k0, k1 = np.uint64(key[0]), np.uint64(key[1])
    for rnd in range(10):
        if rnd:
            k0, k1 = (k0 + np.uint64(W0)) & MASK, (k1 + np.uint64(W1)) & MASK
        p0 = np.uint64(M0) * c[0]
        p1 = np.uint64(M1) * c[2]
        hi0, lo0 = p0 >> np.uint64(32), p0 & MASK
        hi1, lo1 = p1 >> np.uint64(32), p1 & MASK
        c = [hi1 ^ c[1] ^ k0, lo1, hi0 ^ c[3] ^ k1, lo0]
    return c


def test_philox_known_answer():
    # Random123's published known-answer vector for Philox4x32-10 (counter = key = 0).
    out = philox4x32([0, 0, 0, 0], (0, 0))
    assert [int(x) for x in out] == [0x6627E8D5, 0xE169C58D, 0xBC57AC4C, 0x9B00DBD8]


def brute_reference(uv, J, h, seed, density, target, alpha, alpha_star, epsilon, filt, blend="roulette"):
    h = np.asarray(h, float) / np.linalg.norm(h)
    if h[2] <= 0:
        return 0.0
    c = h[2]
    D = float(gl.ndf(target, alpha).D(c))
    theta = math.acos(min(1.0, c))
    phi = math.atan2(h[1], h[0])
    if target == "beckmann":
        rad = math.sqrt(1 - math.exp(-math.tan(theta) ** 2 / alpha**2))
    else:
        rad = math.sin(math.atan(math.tan(theta) / alpha))
    xa, ya = 0.5 + 0.5 * rad * math.cos(phi), 0.5 + 0.5 * rad * math.sin(phi)
    sig = alpha_star * math.sqrt(D)
    Jm = np.array([[J[0], J[2]], [J[1], J[3]]])
    S = filt**2 * Jm @ Jm.T
    Sinv = np.linalg.inv(S)
    lam = max(0.0, math.log2(math.sqrt(density) * 6 * math.sqrt(np.linalg.eigvalsh(S).max())))
    l0 = math.floor(lam)
    levels = [(l0, 1.0)] if lam == l0 else [(l0, 1 - (lam - l0)), (l0 + 1, lam - l0)]
    total = 0.0
    for lev, w in levels:
        cell = 2.0**lev / math.sqrt(density)
        na = 2**lev
        ru, rv = 3.5 * math.sqrt(S[0, 0]), 3.5 * math.sqrt(S[1, 1])
        I = np.arange(math.floor((uv[0] - ru) / cell), math.floor((uv[0] + ru) / cell) + 1)
        Jj = np.arange(math.floor((uv[1] - rv) / cell), math.floor((uv[1] + rv) / cell) + 1)
        A = np.arange(na)
        i, j, a, b = (x.ravel() for x in np.meshgrid(I, Jj, A, A, indexing="ij"))
        key = (seed & 0xFFFFFFFF, seed >> 32)
        word3 = (8 << 24) | (lev << 20) | b
        r0 = philox4x32([2 * a, i.astype(np.int64) & 0xFFFFFFFF, j.astype(np.int64) & 0xFFFFFFFF, word3], key)
        r1 = philox4x32([2 * a + 1, i.astype(np.int64) & 0xFFFFFFFF, j.astype(np.int64) & 0xFFFFFFFF, word3], key)
        u01 = [(x.astype(float) + 0.5) / 2.0**32 for x in r0]
        x = (i + u01[0]) * cell - uv[0]
        y = (j + u01[1]) * cell - uv[1]
        mx, my = (a + u01[2]) / na, (b + u01[3]) / na
        inside = (mx - 0.5) ** 2 + (my - 0.5) ** 2 < 0.25
        q = Sinv[0, 0] * x * x + 2 * Sinv[0, 1] * x * y + Sinv[1, 1] * y * y
        fw = np.where(q <= 9, np.exp(-q / 2), 0.0) / (2 * math.pi * math.sqrt(np.linalg.det(S)) * (1 - math.exp(-4.5)))
        g = np.exp(-((mx - xa) ** 2 + (my - ya) ** 2) / (2 * sig**2)) / (2 * math.pi * sig**2)
        if w == 1.0:
            keep = np.ones_like(g)
        elif blend == "linear":
            keep = np.full_like(g, w)
        else:
            r = (r1[0].astype(float) + 0.5) / 2.0**32
            lo, hi = np.maximum(0, r - epsilon), np.minimum(1, r + epsilon)
            if epsilon == 0:
                keep = (w >= r).astype(float)
            else:
                t = np.clip((w - lo) / (hi - lo), 0, 1)
                keep = t * t * (3 - 2 * t)
        total += float(np.sum(np.where(inside, keep * fw * g, 0.0)))
    return D * total / density


CASES = [  # (target, alpha, alpha_star, epsilon, J, h, blend)
    ("beckmann", 0.5, 0.05, 0.1, (0.05, 0.0, 0.0, 0.05), (0.2, -0.1, 1.0), "roulette"),
    ("ggx", 0.3, 0.1, 0.1, (0.04, 0.01, -0.02, 0.03), (0.1, 0.25, 1.0), "roulette"),
    ("beckmann", 0.8, 0.2, 0.0, (0.09, 0.0, 0.0, 0.01), (1.5, 0.3, 1.0), "roulette"),  # grazing, anisotropic
    ("ggx", 0.5, 0.05, 0.1, (0.03, 0.03, -0.01, 0.01), (0.0, 0.0, 1.0), "linear"),
]


@pytest.mark.parametrize("case", CASES)
def test_reference_equals_brute_force(case):
    target, alpha, astar, eps, J, h, blend = case
    ndf = gl.glinty_ndf("kpt25", density=1e4, target=target, alpha=alpha, alpha_star=astar, k=4, epsilon=eps,
                        blend=blend)
    rng = np.random.default_rng(3)
    for uv in rng.uniform(-2, 2, size=(3, 2)):
        seed = int(rng.integers(0, 2**63))
        ref, pts = ndf.reference(uv, J, h, seed=seed, return_points=True)
        brute = brute_reference(uv, J, h, seed, 1e4, target, alpha, astar, eps, 0.5 / math.sqrt(math.pi), blend)
        assert pts > 10
        assert ref == pytest.approx(brute, rel=1e-11, abs=1e-300)
        assert ref > 0 or brute == 0


def _pixels(n, spacing=1.0, seed=0):
    """n well separated positions: pixels whose filters share no cell are independent."""
    rng = np.random.default_rng(seed)
    side = int(math.ceil(math.sqrt(n)))
    g = np.stack(np.meshgrid(np.arange(side), np.arange(side), indexing="ij"), -1).reshape(-1, 2)[:n] * spacing
    return g + rng.uniform(0, spacing / 2, size=(n, 2))


def test_algorithm1_equals_reference_when_B_covers_every_point():
    # Levels <= 2 have at most 4 x 4 angular cells: B(16) is all of them, the compensation of eq. 10 is
    # zero (square minus square) and Algorithm 1 must reproduce the reference to rounding.
    ndf = gl.glinty_ndf("kpt25", density=100.0, alpha=0.5, alpha_star=0.1, k=16)
    wrong = gl.glinty_ndf("kpt25", density=100.0, alpha=0.5, alpha_star=0.1, k=16, compensation="square_flipped")
    uv = _pixels(200, spacing=0.37)
    J = np.tile([0.05, 0.01, 0.0, 0.04], (200, 1))
    h = np.tile([0.3, 0.1, 1.0], (200, 1))
    assert all(lev <= 2 for lev in ndf.pixel(J[0], h[0])["levels"])
    ref = ndf.reference(uv, J, h, seed=11)
    assert np.count_nonzero(ref) > 40
    np.testing.assert_allclose(ndf.evaluate(uv, J, h, seed=11), ref, rtol=1e-12, atol=0)
    assert not np.allclose(wrong.evaluate(uv, J, h, seed=11), ref, rtol=1e-3)


def mean_z(values, expected):
    """z score of the mean of independent values against an expected mean."""
    v = np.asarray(values, float)
    se = v.std(ddof=1) / math.sqrt(v.size)
    return (v.mean() - expected) / se


# theta_h = 48.5 deg along the diagonal: T(h) at 0.88 of the disk's radius, towards a corner of the square.
GRAZING = (0.8 / math.sqrt(2), 0.8 / math.sqrt(2), 1.0)


def _setup(n=4000, h=(0.2, 0.1, 1.0), J=(0.004, 0.0, 0.0, 0.004)):
    return _pixels(n, spacing=0.05), np.tile(J, (n, 1)), np.tile(h, (n, 1))


def test_reference_mean_is_the_smooth_ndf_in_the_interior():
    ndf = gl.glinty_ndf("kpt25", density=1e6, target="ggx", alpha=0.5, alpha_star=0.05, k=4)
    uv, J, h = _setup(n=12000)
    e_ref, _ = ndf.expected(J[:1], h[:1])
    D = ndf.smooth(h[0])
    assert e_ref[0] == pytest.approx(D, rel=1e-6)  # the lobe lies inside the disk (5 sigma from its rim)
    assert abs(mean_z(ndf.reference(uv, J, h, seed=5), D)) < 4.5
    # The same check fails on a wrong NDF: a mean 10% low is detected (relative std 1.4, 12000 pixels).
    assert abs(mean_z(0.9 * ndf.reference(uv, J, h, seed=5), D)) > 4.5


def test_reference_loses_energy_at_grazing_half_vectors():
    # Near the rim of the disk part of each lobe falls outside U: E[reference] = D(h) x (its mass in U).
    ndf = gl.glinty_ndf("kpt25", density=1e6, target="beckmann", alpha=0.5, alpha_star=0.1, k=4)
    uv, J, h = _setup(h=GRAZING)
    e_ref, _ = ndf.expected(J[:1], h[:1])
    D = ndf.smooth(h[0])
    assert 0.5 < e_ref[0] / D < 0.9
    assert abs(mean_z(ndf.reference(uv, J, h, seed=6), e_ref[0])) < 4.5
    assert abs(mean_z(ndf.reference(uv, J, h, seed=6), D)) > 4.5


@pytest.mark.parametrize("k", [1, 4])
def test_algorithm1_mean_is_the_smooth_ndf_and_a_wrong_sign_fails(k):
    kw = dict(density=1e6, target="beckmann", alpha=0.5, alpha_star=0.05, k=k)
    uv, J, h = _setup()
    D = gl.ndf("beckmann", 0.5).D(1 / math.sqrt(1.05))
    ok = gl.glinty_ndf("kpt25", **kw)
    _, e_alg = ok.expected(J[:1], h[:1])
    assert e_alg[0] == pytest.approx(D, rel=1e-6)
    assert abs(mean_z(ok.evaluate(uv, J, h, seed=7), D)) < 4.5
    for bad in ("square_flipped", "none"):
        wrong = gl.glinty_ndf("kpt25", compensation=bad, **kw)
        assert abs(mean_z(wrong.evaluate(uv, J, h, seed=7), D)) > 4.5, bad


def test_square_compensation_bias_at_grazing_matches_its_exact_expectation():
    # eq. 10 integrates over the square, not the disk: at grazing h the corners outside U add energy
    # that no point carries. The sampled mean matches the exact E[evaluate], which exceeds E[reference];
    # the disk compensation (eq. 9) removes the difference.
    kw = dict(density=1e6, target="beckmann", alpha=0.5, alpha_star=0.1, k=1)
    uv, J, h = _setup(h=GRAZING)
    sq = gl.glinty_ndf("kpt25", **kw)
    e_ref, e_alg = sq.expected(J[:1], h[:1])
    assert e_alg[0] > 1.2 * e_ref[0]
    assert abs(mean_z(sq.evaluate(uv, J, h, seed=8), e_alg[0])) < 4.5
    assert abs(mean_z(sq.evaluate(uv, J, h, seed=8), e_ref[0])) > 4.5
    disk = gl.glinty_ndf("kpt25", compensation="disk", **kw)
    d_ref, d_alg = disk.expected(J[:1], h[:1])
    assert d_alg[0] == pytest.approx(d_ref[0], rel=1e-7)
    assert abs(mean_z(disk.evaluate(uv[:400], J[:400], h[:400], seed=8), d_ref[0])) < 4.5


def test_deterministic_whatever_the_threads_and_order():
    ndf = gl.glinty_ndf("kpt25", density=1e5, target="ggx", alpha=0.4, alpha_star=0.03, k=9)
    rng = np.random.default_rng(1)
    n = 3000
    uv = rng.uniform(0, 1, (n, 2))
    J = np.column_stack([rng.uniform(1e-3, 5e-3, n), rng.uniform(-1e-3, 1e-3, n),
                         rng.uniform(-1e-3, 1e-3, n), rng.uniform(1e-3, 5e-3, n)])
    h = np.column_stack([rng.normal(0, 0.4, (n, 2)), np.ones(n)])
    threads = gl.get_num_threads()
    try:
        gl.set_num_threads(1)
        one = ndf.evaluate(uv, J, h, seed=3)
        ref_one = ndf.reference(uv[:300], J[:300], h[:300], seed=3)
        gl.set_num_threads(2)
        two = ndf.evaluate(uv, J, h, seed=3)
        ref_two = ndf.reference(uv[:300], J[:300], h[:300], seed=3)
    finally:
        gl.set_num_threads(threads)
    np.testing.assert_array_equal(one, two)
    np.testing.assert_array_equal(ref_one, ref_two)
    perm = rng.permutation(n)
    np.testing.assert_array_equal(ndf.evaluate(uv[perm], J[perm], h[perm], seed=3), one[perm])
    assert not np.array_equal(ndf.evaluate(uv, J, h, seed=4), one)
    img = ndf.evaluate(uv.reshape(30, 100, 2), J.reshape(30, 100, 4), h.reshape(30, 100, 3), seed=3)
    assert img.shape == (30, 100)
    np.testing.assert_array_equal(img.reshape(-1), one)


def test_below_the_horizon_is_zero():
    ndf = gl.glinty_ndf("kpt25")
    out = ndf.evaluate([[0.1, 0.2]], [[1e-3, 0, 0, 1e-3]], [[0.3, 0.0, -0.1]])
    assert out[0] == 0.0


@pytest.mark.parametrize("kw, name", [
    (dict(density=0), "density"), (dict(density=float("nan")), "density"), (dict(alpha=-1), "alpha"),
    (dict(alpha_star=0), "alpha_star"), (dict(k=3), "k"), (dict(k=True), "k"), (dict(epsilon=0.7), "epsilon"),
    (dict(filter=0), "filter"), (dict(target="phong"), "target"), (dict(compensation="circle"), "compensation"),
    (dict(blend="cubic"), "blend"), (dict(alpha_star="x"), "alpha_star"), (dict(bogus=1), "bogus"),
])
def test_bad_parameters_are_refused_by_name(kw, name):
    with pytest.raises(ValueError, match=name):
        gl.glinty_ndf("kpt25", **kw)


def test_bad_inputs_are_refused_by_name():
    ndf = gl.glinty_ndf("kpt25", density=1e4)
    uv, J, h = [[0.0, 0.0]], [[1e-3, 0, 0, 1e-3]], [[0.0, 0.0, 1.0]]
    with pytest.raises(ValueError, match="unknown glinty NDF 'nope'"):
        gl.glinty_ndf("nope")
    with pytest.raises(ValueError, match="uv"):
        ndf.evaluate([[0.0, 0.0, 0.0]], J, h)
    with pytest.raises(ValueError, match="J"):
        ndf.evaluate(uv, [[1e-3, 0, 0]], h)
    with pytest.raises(ValueError, match=r"J\[0\]"):
        ndf.evaluate(uv, [[1e-3, 1e-3, 1e-3, 1e-3]], h)  # det J = 0
    with pytest.raises(ValueError, match=r"h\[0, 1\] = nan"):
        ndf.evaluate(uv, J, [[0.0, float("nan"), 1.0]])
    with pytest.raises(ValueError, match=r"uv\[0, 0\] = inf"):
        ndf.evaluate([[float("inf"), 0.0]], J, h)
    with pytest.raises(ValueError, match="J"):
        gl.glinty_ndf("kpt25", density=1e12).evaluate(uv, [[10.0, 0, 0, 10.0]], h)  # level > 15
    with pytest.raises(ValueError, match="seed"):
        ndf.evaluate(uv, J, h, seed=-1)


def test_glinty_ndfs_lists_the_registry():
    assert gl.glinty_ndfs()[:4] == ["kpt25", "db23", "smooth", "facets"]
    assert "wwh18" in gl.glinty_ndfs()
    assert "kpt25" in repr(gl.glinty_ndf("kpt25"))


def test_db23_d_p_mean_is_the_smooth_ndf():
    # D_P = (D(n) / R) K / (N P) over the exact binomial is unbiased (DB23 eq. 5-6) where p is not
    # clamped; pixels 1 apart read different grid cells, so they are independent.
    n = 3000
    uv = _pixels(n, spacing=1.0, seed=2)
    J = np.tile([0.01, 0.0, 0.0, 0.01], (n, 1))
    h = np.tile([0.2, 0.1, 1.0], (n, 1))
    db = gl.glinty_ndf("db23", density=2e5, target="beckmann", alpha=0.5, scheme="db23_trilinear", inner="binomial")
    d = db.evaluate(uv, J, h, seed=1)
    D = db.smooth(h[0])
    assert d.shape == (n,) and np.all(np.isfinite(d))
    assert abs(mean_z(d, D)) < 4.5
    assert abs(mean_z(0.95 * d, D)) > 4.5  # the check detects a 5% bias
    with pytest.raises(NotImplementedError):
        db.reference(uv, J, h)
    with pytest.raises(ValueError, match="R"):
        gl.glinty_ndf("db23", R=0)


@pytest.mark.parametrize("kw, message", [
    (dict(scheme="nope"), "scheme = 'nope' is invalid"), (dict(inner="nope"), "unknown law 'nope'"),
    (dict(angular_resolution=0), "angular_resolution"), (dict(target="x"), "target"), (dict(density=-1), "density"),
    (dict(alpha=0), "alpha"),
])
def test_db23_bad_parameters_are_refused_by_name(kw, message):
    with pytest.raises(ValueError, match=message):
        gl.glinty_ndf("db23", **kw)


def test_reference_refuses_footprints_it_cannot_sum_in_reasonable_time():
    # alpha_star = 0.5: every angular cell is within reach of the lobe; 4^15 cells at level 15.
    ndf = gl.glinty_ndf("kpt25", density=1e12, alpha_star=0.5)
    J = [[5e-3, 0.0, 0.0, 5e-3]]
    assert ndf.pixel(J[0], [0.0, 0.0, 1.0])["levels"][0] >= 12
    with pytest.raises(ValueError, match=r"J\[0\].*reference sums at most"):
        ndf.reference([[0.0, 0.0]], J, [[0.0, 0.0, 1.0]])
    assert np.isfinite(ndf.evaluate([[0.0, 0.0]], J, [[0.0, 0.0, 1.0]])[0])  # Algorithm 1 stays constant time
