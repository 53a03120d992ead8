"""Exact distribution functions: gl.binomial.* and gl.poisson.*, and law.pmf(n, p) Distributions.

References, chosen where each is itself accurate (measured while writing these tests):

* scipy.stats.binom (Boost's pdf / incomplete beta) and scipy.stats.poisson for n <= 1e6 and
  lam <= 1e4. Beyond that scipy loses digits: its binom.pmf is off by ~2% at n = 1e15, p = 0.5,
  its binom.cdf by ~2e-8 at n = 1e9, its poisson.sf by ~5e-6 at lam = 1e6, 5 sd out.
* mpmath log-gamma at 40 digits for log-pmfs at large n / lam, and exact mpmath sums at 400 digits
  for the cdf / sf at k = 0, 1, 2 (no cancellation down to 1e-300).
* Sums of the pmf over a +-15 sd window (math.fsum) for the cdf / sf when the variance is at most
  ~1e9. The pmfs summed are the library's own, validated against mpmath by the log-pmf tests; for
  p > 1/2 the window uses the mirrored law pmf(n - k; n, 1 - p), which is exact because 1 - p is
  exact in floating point for p >= 1/2.
* A second-order Edgeworth expansion with continuity and Sheppard corrections when the standard
  deviation is >= 1e6: its truncation error is O(sd^-3), far below the 1e-9 tolerance (checked
  against window sums at n = 1e9, p = 0.5 and n = 1e11, p = 0.3, sd 1.6e4 and 1.4e5, where it
  already agrees to 1e-12 out to 8 sd).

Tolerances: log-pmfs within 1e-9 * max(1, |log-pmf|); cdf / sf within 1e-9 relative wherever the
reference exceeds 1e-300.
"""
from __future__ import annotations

import math
from fractions import Fraction

import mpmath
import numpy as np
import pytest
import scipy.special
import scipy.stats as st

import glintlab as gl

BINOMIAL = gl.law("binomial")
POISSON = gl.law("poisson")

NS = [0, 1, 16, 1000, 1e6, 1e9, 1e15]
PS = [0.0, 1e-300, 1e-12, 1e-7, 0.01, 0.5, 1 - 1e-7, 1.0]
OPEN_PS = [p for p in PS if 0.0 < p < 1.0]
SCIPY_NS = [n for n in NS if n <= 1e6]          # where scipy.stats.binom is accurate
BIG_NS = [n for n in NS if n > 1e6]
LAMS = [0.0, 1e-300, 1e-12, 1e-7, 0.01, 0.5, 10.0, 100.0, 1e4, 1e6, 1e9, 1e12]
SCIPY_LAMS = [lam for lam in LAMS if lam <= 1e4]
NONINT_NS = [0.5, 10.5, 16.25, 1000.75, 1e6 + 0.5]
NONINT_PS = [1e-7, 0.01, 0.3, 0.9, 1.0]

LOG_RTOL = 1e-9
TAIL_RTOL = 1e-9
TINY = 1e-300
MAX_SUPPORT = 50_000_000  # law.pmf's default


def ctx(**kw) -> str:
    """'n=..., p=..., ...' with full precision, for assertion messages."""
    return ", ".join(f"{k}={v!r}" for k, v in kw.items())


def binomial_top(n, p):
    """Largest value K can take under the stratified rule (m + 1 when a fractional facet exists)."""
    m = math.floor(n)
    return m + 1 if (n > m and p > 0) else m


def probe_ks(n, p):
    """Integer k spread over the support: both ends and mean + z sd for z from -40 to 40."""
    m = math.floor(n)
    mean, sd = n * p, math.sqrt(n * p * (1 - p))
    pts = [0, 1, 2, 3, m - 3, m - 2, m - 1, m]
    pts += [mean + z * sd for z in (-40, -20, -10, -5, -2, -1, 0, 1, 2, 5, 10, 20, 40)]
    return np.unique(np.clip(np.floor(pts), 0, m)).astype(float)


def probe_poisson_ks(lam):
    sd = math.sqrt(lam)
    pts = [0, 1, 2, 3] + [lam + z * sd for z in (-40, -20, -10, -5, -2, -1, 0, 1, 2, 5, 10, 20, 40)]
    pts += [lam + 50 * sd + 50]
    return np.unique(np.clip(np.floor(pts), 0, None)).astype(float)


def assert_log_close(ks, got, ref, msg):
    """Log-pmfs within LOG_RTOL * max(1, |ref|); -inf references must be matched exactly."""
    for k, g, r in zip(ks, got, ref):
        if r == -np.inf:
            assert g == -np.inf, f"{msg}, k={k!r}: got {g!r}, expected -inf"
        else:
            tol = LOG_RTOL * max(1.0, abs(r))
            assert abs(g - r) <= tol, (
                f"{msg}, k={k!r}: logpmf {g!r} vs reference {r!r} (diff {g - r:.3e}, tol {tol:.1e})")


def assert_tail_close(got, ref, msg):
    if ref > TINY:
        assert abs(got - ref) <= TAIL_RTOL * ref, (
            f"{msg}: {got!r} vs reference {ref!r} (rel err {abs(got - ref) / ref:.2e})")
    else:
        assert 0.0 <= got <= 1e-290, f"{msg}: {got!r}, reference {ref!r} (below 1e-300)"


# ----------------------------------------------------------------------------------------------
# References
# ----------------------------------------------------------------------------------------------

def mp_binom_logpmf(k, n, p):
    with mpmath.workdps(40):
        k, n, p = mpmath.mpf(int(k)), mpmath.mpf(n), mpmath.mpf(p)
        return float(mpmath.loggamma(n + 1) - mpmath.loggamma(k + 1) - mpmath.loggamma(n - k + 1)
                     + k * mpmath.log(p) + (n - k) * mpmath.log1p(-p))


def mp_poisson_logpmf(k, lam):
    with mpmath.workdps(40):
        k, lam = mpmath.mpf(int(k)), mpmath.mpf(lam)
        return float(k * mpmath.log(lam) - lam - mpmath.loggamma(k + 1))


def mp_binom_head(kmax, n, p):
    """Exact (cdf(k), sf(k)) for k = 0..kmax, 400 digits (sf as 1 - cdf without cancellation)."""
    out = []
    with mpmath.workdps(400):
        n_, p_ = mpmath.mpf(n), mpmath.mpf(p)
        acc = mpmath.mpf(0)
        for j in range(kmax + 1):
            acc += mpmath.binomial(n_, j) * p_**j * mpmath.exp((n_ - j) * mpmath.log1p(-p_))
            out.append((float(acc), float(1 - acc)))
    return out


def mp_poisson_head(kmax, lam):
    out = []
    with mpmath.workdps(400):
        lam_ = mpmath.mpf(lam)
        acc = mpmath.mpf(0)
        for j in range(kmax + 1):
            acc += mpmath.exp(j * mpmath.log(lam_) - lam_ - mpmath.loggamma(j + 1))
            out.append((float(acc), float(1 - acc)))
    return out


def window_tails(pmf_of, lo, hi, k):
    """(P(K <= k), P(K > k)) by fsum of pmf_of(j) over the integers of [lo, hi]."""
    js = np.arange(lo, hi + 1, dtype=float)
    probs = pmf_of(js)
    i = int(k - lo)
    return math.fsum(probs[: i + 1]), math.fsum(probs[i + 1:])


def edgeworth_tails(k, mean, var, kappa3, kappa4):
    """(P(K <= k), P(K > k)) of an integer law from its first four cumulants, sd >= 1e6.

    `mean` is exact (a Fraction): at n = 1e15 the rounding of n * p alone (0.01) would move an
    8-sd tail by 6e-9 relative.
    """
    sd = math.sqrt(var)
    g1, g2 = kappa3 / sd**3, kappa4 / var**2
    z = float(Fraction(k) + Fraction(1, 2) - mean) / sd   # continuity correction
    phi = math.exp(-0.5 * z * z) / math.sqrt(2 * math.pi)
    he2, he3, he5 = z * z - 1, z**3 - 3 * z, z**5 - 10 * z**3 + 15 * z
    corr = phi * (g1 * he2 / 6 + g2 * he3 / 24 + g1 * g1 * he5 / 72) - phi * z / (24 * var)
    return scipy.special.ndtr(z) - corr, scipy.special.ndtr(-z) + corr


# ----------------------------------------------------------------------------------------------
# Binomial log-pmf
# ----------------------------------------------------------------------------------------------

@pytest.mark.parametrize("p", PS)
@pytest.mark.parametrize("n", SCIPY_NS)
def test_binomial_logpmf_matches_scipy(n, p):
    ks = probe_ks(n, p)
    got = gl.binomial.logpmf(ks, n, p)
    with np.errstate(divide="ignore"):
        pmf = st.binom.pmf(ks, n, p)
        # Boost's pdf is accurate where it does not underflow; scipy's lgamma form beyond that.
        ref = np.where(pmf > 1e-290, np.log(np.maximum(pmf, 1e-320)), st.binom.logpmf(ks, n, p))
    assert_log_close(ks, got, ref, f"gl.binomial.logpmf vs scipy, {ctx(n=n, p=p)}")


@pytest.mark.parametrize("p", OPEN_PS)
@pytest.mark.parametrize("n", BIG_NS)
def test_binomial_logpmf_matches_mpmath_at_large_n(n, p):
    ks = probe_ks(n, p)
    got = gl.binomial.logpmf(ks, n, p)
    ref = [mp_binom_logpmf(k, n, p) for k in ks]
    assert_log_close(ks, got, ref, f"gl.binomial.logpmf vs mpmath, {ctx(n=n, p=p)}")


@pytest.mark.parametrize("n", BIG_NS)
@pytest.mark.parametrize("p", [0.0, 1.0])
def test_binomial_logpmf_degenerate_p(n, p):
    sure = 0.0 if p == 0.0 else n
    ks = np.array([0.0, 1.0, n - 1, n])
    got = gl.binomial.logpmf(ks, n, p)
    for k, g in zip(ks, got):
        expected = 0.0 if k == sure else -np.inf
        assert g == expected, f"logpmf(k={k!r}, {ctx(n=n, p=p)}) = {g!r}, expected {expected!r}"


@pytest.mark.parametrize("n, p", [(16, 0.3), (1e9, 0.5), (10.5, 0.3)])
def test_binomial_logpmf_outside_support_is_minus_inf(n, p):
    for k in (-1.0, -1e300, 2.5, binomial_top(n, p) + 1.0, 1e300):
        got = gl.binomial.logpmf(k, n, p)
        assert got == -np.inf, f"logpmf(k={k!r}, {ctx(n=n, p=p)}) = {got!r}, expected -inf"


def test_binomial_logpmf_nan_k_raises():
    with pytest.raises(ValueError, match=r"\bk\b.*nan"):
        gl.binomial.logpmf(np.nan, 10, 0.5)


# ----------------------------------------------------------------------------------------------
# Binomial cdf / sf
# ----------------------------------------------------------------------------------------------

@pytest.mark.parametrize("p", PS)
@pytest.mark.parametrize("n", SCIPY_NS)
def test_binomial_cdf_sf_match_scipy(n, p):
    ks = np.concatenate([[-1.0], probe_ks(n, p), [n + 1.0]])
    cdf, sf = gl.binomial.cdf(ks, n, p), gl.binomial.sf(ks, n, p)
    ref_cdf, ref_sf = st.binom.cdf(ks, n, p), st.binom.sf(ks, n, p)
    for k, c, s, rc, rs in zip(ks, cdf, sf, ref_cdf, ref_sf):
        assert_tail_close(c, rc, f"gl.binomial.cdf(k={k!r}, {ctx(n=n, p=p)})")
        assert_tail_close(s, rs, f"gl.binomial.sf(k={k!r}, {ctx(n=n, p=p)})")


@pytest.mark.parametrize("p", OPEN_PS)
@pytest.mark.parametrize("n", BIG_NS)
def test_binomial_cdf_sf_small_k_exact(n, p):
    """k = 0, 1, 2 against exact 400-digit sums (the rare-glint corner: sf(0) = 1 - (1-p)^n)."""
    for k, (rc, rs) in enumerate(mp_binom_head(2, n, p)):
        assert_tail_close(gl.binomial.cdf(k, n, p), rc, f"gl.binomial.cdf(k={k}, {ctx(n=n, p=p)})")
        assert_tail_close(gl.binomial.sf(k, n, p), rs, f"gl.binomial.sf(k={k}, {ctx(n=n, p=p)})")


# (n, p) whose +-15 sd window has at most ~1e6 points; 4e7 / 6e7 at p = 1/4 straddle the library's
# switch from summation to the saddle-point formula (variance 1e7).
WINDOW_CASES = [(1e9, 1e-12), (1e9, 1e-7), (1e9, 0.01), (1e9, 0.5), (1e9, 1 - 1e-7),
                (4e7, 0.25), (6e7, 0.25), (1e15, 1e-12), (1e15, 1e-7), (1e15, 1 - 1e-7)]


@pytest.mark.parametrize("n, p", WINDOW_CASES)
def test_binomial_cdf_sf_match_pmf_sums(n, p):
    mean, sd = n * p, math.sqrt(n * p * (1 - p))
    lo, hi = max(0.0, math.floor(mean - 15 * sd - 30)), min(n, math.ceil(mean + 15 * sd + 30))
    if p > 0.5:
        pmf_of = lambda js: gl.binomial.pmf(n - js, n, 1.0 - p)  # noqa: E731  (1 - p is exact)
    else:
        pmf_of = lambda js: gl.binomial.pmf(js, n, p)  # noqa: E731
    for z in (-8, -5, -2, -1, 0, 1, 2, 5, 8):
        k = float(np.clip(math.floor(mean + z * sd), lo, hi))
        rc, rs = window_tails(pmf_of, lo, hi, k)
        assert_tail_close(gl.binomial.cdf(k, n, p), rc, f"gl.binomial.cdf(k={k!r}, {ctx(n=n, p=p)})")
        assert_tail_close(gl.binomial.sf(k, n, p), rs, f"gl.binomial.sf(k={k!r}, {ctx(n=n, p=p)})")


@pytest.mark.parametrize("n, p", [(1e13, 0.5), (1e15, 0.01), (1e15, 0.3), (1e15, 0.5), (1e15, 0.99)])
def test_binomial_cdf_sf_match_edgeworth_at_huge_variance(n, p):
    q = 1 - p
    var = n * p * q
    sd = math.sqrt(var)
    for z in (-8, -5, -2, -1, 0, 1, 2, 5, 8):
        k = float(math.floor(n * p + z * sd))
        rc, rs = edgeworth_tails(k, Fraction(n) * Fraction(p), var, var * (q - p), var * (1 - 6 * p * q))
        assert_tail_close(gl.binomial.cdf(k, n, p), rc, f"gl.binomial.cdf(k={k!r}, {ctx(n=n, p=p)})")
        assert_tail_close(gl.binomial.sf(k, n, p), rs, f"gl.binomial.sf(k={k!r}, {ctx(n=n, p=p)})")


@pytest.mark.parametrize("n", [1e6, 1e9, 1e13, 1e15])
def test_binomial_half_symmetry(n):
    """p = 1/2, even n: P(K <= n/2) = 1/2 + pmf(n/2)/2 and P(K <= n/2 - 1) = P(K > n/2)."""
    h = n / 2
    c, pm = gl.binomial.cdf(h, n, 0.5), gl.binomial.pmf(h, n, 0.5)
    assert abs(c - (0.5 + pm / 2)) <= 1e-14, f"cdf(n/2) = {c!r}, expected {0.5 + pm / 2!r}, {ctx(n=n, p=0.5)}"
    below, above = gl.binomial.cdf(h - 1, n, 0.5), gl.binomial.sf(h, n, 0.5)
    assert abs(below - above) <= 1e-14, f"cdf(n/2 - 1) = {below!r} != sf(n/2) = {above!r}, {ctx(n=n, p=0.5)}"


@pytest.mark.parametrize("p", OPEN_PS)
@pytest.mark.parametrize("n", [16, 1000, 1e9, 1e15])
def test_binomial_cdf_plus_sf_is_one(n, p):
    for k in probe_ks(n, p):
        c, s = gl.binomial.cdf(k, n, p), gl.binomial.sf(k, n, p)
        assert 0.0 <= c <= 1.0 and 0.0 <= s <= 1.0, f"k={k!r}, {ctx(n=n, p=p)}: cdf {c!r}, sf {s!r}"
        assert abs(c + s - 1.0) <= 2e-15, f"k={k!r}, {ctx(n=n, p=p)}: cdf + sf = {c + s!r}"


# ----------------------------------------------------------------------------------------------
# Binomial Distribution (law.pmf)
# ----------------------------------------------------------------------------------------------

def binomial_variance(n, p):
    m = math.floor(n)
    g = (n - m) * p
    return m * p * (1 - p) + g * (1 - g)


def too_wide(var):
    return 17 * math.sqrt(var) + 40 > MAX_SUPPORT  # the library's documented +-8.5 sd width


def check_distribution(d, mean, var, lowest, highest, below_mass, above_mass, msg):
    s, q = d.support, d.probs
    assert len(s) == len(q) >= 1, msg
    assert np.all(np.diff(s) == 1.0), f"{msg}: support is not consecutive integers"
    assert lowest <= s[0] and s[-1] <= highest, f"{msg}: support [{s[0]}, {s[-1]}] outside [{lowest}, {highest}]"
    total = math.fsum(q)
    assert abs(total - 1.0) <= 1e-12, f"{msg}: probs sum to 1 + {total - 1:.3e}"
    sd = math.sqrt(var)
    assert abs(d.mean - mean) <= 1e-11 * mean + 1e-12 * (1 + sd), f"{msg}: mean {d.mean!r}, expected {mean!r}"
    assert abs(d.var - var) <= 1e-9 * var + 1e-12 * (1 + sd), f"{msg}: var {d.var!r}, expected {var!r}"
    lo_mass, hi_mass = below_mass(s[0] - 1), above_mass(s[-1])
    assert lo_mass < 1e-14, f"{msg}: mass {lo_mass:.3e} below the support start {s[0]}"
    assert hi_mass < 1e-14, f"{msg}: mass {hi_mass:.3e} above the support end {s[-1]}"


@pytest.mark.parametrize("n, p", [(n, p) for n in NS for p in PS if not too_wide(binomial_variance(n, p))])
def test_binomial_distribution(n, p):
    var = binomial_variance(n, p)
    d = BINOMIAL.pmf(n, p)
    lowest = math.floor(n) if p == 1.0 else 0
    highest = 0 if p == 0.0 else binomial_top(n, p)
    check_distribution(d, n * p, var, lowest, highest,
                       lambda k: gl.binomial.cdf(k, n, p), lambda k: gl.binomial.sf(k, n, p),
                       f"binomial.pmf({ctx(n=n, p=p)})")


TRIM_CASES = [
    # (law, n, p, lowest value K can take, highest value K can take)
    ("binomial", 16, 0.5, 0, 16),          # nothing trimmed
    ("binomial", 1000, 0.5, 0, 1000),      # both tails trimmed
    ("binomial", 16, 1e-300, 0, 16),       # only k = 0, 1 kept; the rest has (tiny) positive mass
    ("binomial", 16, 0.0, 0, 0),           # K = 0 surely: nothing beyond the support
    ("binomial", 16, 1.0, 16, 16),         # K = 16 surely
    ("binomial", 1e15, 0.0, 0, 0),
    ("binomial", 10.5, 1.0, 10, 11),       # K = 10 + Bernoulli(1/2)
    ("poisson", 10, 1.0, 0, math.inf),
    ("poisson", 1e4, 1.0, 0, math.inf),
    ("poisson", 5, 0.0, 0, 0),             # lam = 0: K = 0 surely
]


@pytest.mark.parametrize("law, n, p, lowest, highest", TRIM_CASES)
def test_trimmed_flags(law, n, p, lowest, highest):
    """trimmed_below / trimmed_above promise a positive (< 1e-14) mass beyond that end of the support
    (chi2_test then counts samples there in the end bin): exactly when the law reaches further."""
    d = gl.law(law).pmf(n, p)
    s = d.support
    assert d.trimmed_below == (s[0] > lowest), (
        f"{law}.pmf({ctx(n=n, p=p)}): trimmed_below = {d.trimmed_below}, support starts at {s[0]}, "
        f"lowest possible value {lowest}")
    assert d.trimmed_above == (s[-1] < highest), (
        f"{law}.pmf({ctx(n=n, p=p)}): trimmed_above = {d.trimmed_above}, support ends at {s[-1]}, "
        f"highest possible value {highest}")


@pytest.mark.parametrize("shift", [1e6, 1e12, 1e15])
def test_distribution_moments_shift_invariant(shift):
    """Moments of a law moved far from 0 (support values up to 1e15, as at n = 1e15, p = 1 - 1e-7)."""
    base = BINOMIAL.pmf(1e8, 0.5)  # sd 5000, ~85000 points
    moved = gl.Distribution(base.support + shift, base.probs)
    assert abs(moved.mean - (base.mean + shift)) <= 1e-13 * (shift + base.mean), (
        f"shift={shift!r}: mean {moved.mean!r}, expected {base.mean + shift!r}")
    assert abs(moved.var - base.var) <= 1e-9 * base.var, (
        f"shift={shift!r}: var {moved.var!r}, expected {base.var!r} (n=1e8, p=0.5 moved by the shift)")


@pytest.mark.parametrize("n, p", [(1e15, 0.01), (1e15, 0.5), (1e14, 0.5)])
def test_binomial_distribution_too_wide(n, p):
    assert too_wide(binomial_variance(n, p))
    with pytest.raises(ValueError, match="max_support"):
        BINOMIAL.pmf(n, p)


def test_distribution_max_support_argument():
    d = BINOMIAL.pmf(1000, 0.5, max_support=400)  # needs ~245 points; the pre-check asks 17 sd + 40
    assert len(d) <= 400
    with pytest.raises(ValueError, match="max_support"):
        BINOMIAL.pmf(1000, 0.5, max_support=100)


# ----------------------------------------------------------------------------------------------
# Non-integer n: K = Binomial(m, p) + Bernoulli(f p), n = m + f
# ----------------------------------------------------------------------------------------------

def stratified_reference(fn, k, n, p):
    """Mixture (1 - fp) X(k) + fp X(k - 1) of a scipy binom(m, p) function X (pmf, cdf or sf)."""
    m = math.floor(n)
    g = (n - m) * p
    return (1 - g) * fn(k, m, p) + g * fn(k - 1, m, p)


def mp_stratified_logpmf(k, n, p):
    """log[(1 - g) b(k; m, p) + g b(k - 1; m, p)], g = (n - m) p, from 40-digit log-pmfs."""
    m = math.floor(n)
    g = (n - m) * p
    with mpmath.workdps(40):
        total = mpmath.mpf(0)
        for j, w in ((k, 1 - mpmath.mpf(g)), (k - 1, mpmath.mpf(g))):
            if 0 <= j <= m and w > 0 and not (p == 1.0 and j != m):
                total += w * (1 if p == 1.0 else mpmath.exp(mp_binom_logpmf(j, m, p)))
        return float(mpmath.log(total)) if total > 0 else -math.inf


@pytest.mark.parametrize("p", NONINT_PS)
@pytest.mark.parametrize("n", NONINT_NS)
def test_stratified_pmf_cdf_sf(n, p):
    m = math.floor(n)
    ks = np.unique(np.concatenate([[-1.0, m + 2.0], probe_ks(n, p), probe_ks(n, p) + 1]))
    got = gl.binomial.logpmf(ks, n, p)
    ref = [mp_stratified_logpmf(k, n, p) for k in ks]
    assert_log_close(ks, got, ref, f"stratified gl.binomial.logpmf vs mixture, {ctx(n=n, p=p)}")
    cdf, sf = gl.binomial.cdf(ks, n, p), gl.binomial.sf(ks, n, p)
    ref_cdf = stratified_reference(st.binom.cdf, ks, n, p)
    ref_sf = stratified_reference(st.binom.sf, ks, n, p)
    for k, c, s, rc, rs in zip(ks, cdf, sf, ref_cdf, ref_sf):
        assert_tail_close(c, rc, f"gl.binomial.cdf(k={k!r}, {ctx(n=n, p=p)})")
        assert_tail_close(s, rs, f"gl.binomial.sf(k={k!r}, {ctx(n=n, p=p)})")


@pytest.mark.parametrize("p", NONINT_PS)
@pytest.mark.parametrize("n", NONINT_NS)
def test_stratified_distribution(n, p):
    m = math.floor(n)
    d = BINOMIAL.pmf(n, p)
    ref = stratified_reference(st.binom.pmf, d.support, n, p)
    rel = np.abs(d.probs - ref) / ref  # scipy's pdf is good to ~1e-10 at m = 1e6
    assert rel.max() <= 1e-9, (
        f"binomial.pmf({ctx(n=n, p=p)}) vs mixture: worst rel err {rel.max():.2e} at k={d.support[rel.argmax()]}")
    # E[K] = n p exactly (what rounding n would break), Var[K] = m p q + f p (1 - f p).
    check_distribution(d, n * p, binomial_variance(n, p), m if p == 1.0 else 0, m + 1,
                       lambda k: gl.binomial.cdf(k, n, p), lambda k: gl.binomial.sf(k, n, p),
                       f"binomial.pmf({ctx(n=n, p=p)})")


def test_stratified_mean_beats_rounding():
    """The rule keeps E[K] = n p where rounding n would not (n = 10.5, p = 0.3: 3.15, not 3.0 or 3.3)."""
    d = BINOMIAL.pmf(10.5, 0.3)
    assert abs(d.mean - 3.15) < 1e-13, f"mean {d.mean!r}, expected 3.15 (n=10.5, p=0.3)"


# ----------------------------------------------------------------------------------------------
# Binomial quantile (ppf): smallest k with cdf(k) >= min(u, 1 - 2^-53)
# ----------------------------------------------------------------------------------------------

U_MODERATE = np.array([1e-12, 1e-6, 1e-3, 0.05, 0.1, 0.3, 0.5, 0.7, 0.9, 0.95, 1 - 1e-3])
U_EXTREME = np.array([2.0**-1074, 1e-300, 1e-17, 2.0**-54, 1e-16, 1e-12, 1e-3, 0.1, 0.5, 0.9,
                      1 - 1e-9, 1 - 1e-12, 1 - 2.0**-53])
U_MAX = 1 - 2.0**-53


@pytest.mark.parametrize("p", OPEN_PS)
@pytest.mark.parametrize("n", [n for n in SCIPY_NS if n > 0])
def test_binomial_ppf_matches_scipy(n, p):
    got = gl.binomial.ppf(U_MODERATE, n, p)
    ref = st.binom.ppf(U_MODERATE, n, p)
    for u, g, r in zip(U_MODERATE, got, ref):
        assert g == r, f"gl.binomial.ppf(u={u!r}, {ctx(n=n, p=p)}) = {g!r}, scipy {r!r}"


def ppf_definition_failures(ppf, cdf, sf, us, top, where):
    """Messages for every u where k = ppf(u) is not the smallest k with cdf(k) >= u', u' being u
    clamped to [2^-53, 1 - 2^-53] as documented (binomial.hpp)."""
    out = []
    for u_given in us:
        k = ppf(u_given)
        u = min(max(u_given, 2.0**-53), U_MAX)
        if not (0 <= k <= top) or k != math.floor(k):
            out.append(f"{where}: ppf(u={u!r}) = {k!r} outside the integers of [0, {top}]")
            continue
        if u > 0.5:  # complementary form keeps precision near 1
            ok_k, ok_prev = sf(k) <= 1 - u, k == 0 or sf(k - 1) > 1 - u
        else:
            ok_k, ok_prev = cdf(k) >= u, k == 0 or cdf(k - 1) < u
        if not (ok_k and ok_prev):
            out.append(f"{where}: ppf(u={u!r}) = {k!r} but cdf({k - 1}) = {cdf(k - 1)!r}, "
                       f"cdf({k}) = {cdf(k)!r}, sf({k - 1}) = {sf(k - 1)!r}, sf({k}) = {sf(k)!r}")
    return out


@pytest.mark.parametrize("p", OPEN_PS + [1.0])
@pytest.mark.parametrize("n", [1, 16, 1000, 1e6, 1e9, 1e15, 10.5, 1000.75])
def test_binomial_ppf_definition(n, p):
    failures = ppf_definition_failures(
        lambda u: float(gl.binomial.ppf(u, n, p)), lambda k: gl.binomial.cdf(k, n, p),
        lambda k: gl.binomial.sf(k, n, p), U_EXTREME, binomial_top(n, p), f"binomial {ctx(n=n, p=p)}")
    assert not failures, "\n".join(failures)


@pytest.mark.parametrize("n, p", [(16, 0.3), (1000, 0.01), (1e9, 0.5), (1e15, 1e-12), (10.5, 0.9)])
def test_binomial_ppf_monotone_in_u(n, p):
    us = np.sort(np.concatenate([np.linspace(0, 1, 2001), U_EXTREME]))
    ks = gl.binomial.ppf(us, n, p)
    bad = np.flatnonzero(np.diff(ks) < 0)
    assert bad.size == 0, (f"ppf not monotone, {ctx(n=n, p=p)}: u={us[bad[0]]!r} -> {ks[bad[0]]}, "
                           f"u={us[bad[0] + 1]!r} -> {ks[bad[0] + 1]}")


@pytest.mark.parametrize("n, p", [(16, 0.3), (1000, 1e-7), (1e15, 0.5), (10.5, 0.3), (16, 1.0),
                                  (10.5, 1.0), (16, 0.0), (0, 0.5)])
def test_binomial_ppf_edges(n, p):
    """u is clamped to [2^-53, 1 - 2^-53] (documented): u = 0 equals ppf(2^-53), a K the law can
    produce (0 when P(K = 0) >= 2^-53, n when p = 1); u = 1 is finite and continuous with u -> 1."""
    at0, above0 = float(gl.binomial.ppf(0.0, n, p)), float(gl.binomial.ppf(2.0**-53, n, p))
    assert at0 == above0, f"ppf(u=0, {ctx(n=n, p=p)}) = {at0!r} but ppf(2^-53) = {above0!r}"
    assert gl.binomial.pmf(at0, n, p) > 0, f"ppf(u=0, {ctx(n=n, p=p)}) = {at0!r} is impossible"
    if gl.binomial.pmf(0, n, p) >= 2.0**-53:
        assert at0 == 0.0, f"ppf(u=0, {ctx(n=n, p=p)}) = {at0!r}, expected 0"
    at1, below1 = float(gl.binomial.ppf(1.0, n, p)), float(gl.binomial.ppf(U_MAX, n, p))
    assert at1 == below1, f"ppf(u=1, {ctx(n=n, p=p)}) = {at1!r} but ppf(1 - 2^-53) = {below1!r}"
    lowest = math.floor(n) if p == 1.0 else 0
    assert lowest <= at1 <= binomial_top(n, p), f"ppf(u=1, {ctx(n=n, p=p)}) = {at1!r}"
    if p == 1.0:
        assert gl.binomial.ppf(2.0**-54, n, p) == lowest, f"ppf(u=2^-54, {ctx(n=n, p=p)}) != {lowest}"


def test_binomial_ppf_rejects_bad_u():
    for u in (-1e-300, 1 + 1e-15, np.nan):
        with pytest.raises(ValueError, match=r"\bu\b"):
            gl.binomial.ppf(u, 10, 0.5)


# ----------------------------------------------------------------------------------------------
# Poisson
# ----------------------------------------------------------------------------------------------

@pytest.mark.parametrize("lam", SCIPY_LAMS)
def test_poisson_logpmf_matches_scipy(lam):
    ks = probe_poisson_ks(lam)
    got = gl.poisson.logpmf(ks, lam)
    ref = st.poisson.logpmf(ks, lam)
    assert_log_close(ks, got, ref, f"gl.poisson.logpmf vs scipy, {ctx(lam=lam)}")


@pytest.mark.parametrize("lam", [1e6, 1e9, 1e12])
def test_poisson_logpmf_matches_mpmath(lam):
    ks = probe_poisson_ks(lam)
    got = gl.poisson.logpmf(ks, lam)
    ref = [mp_poisson_logpmf(k, lam) for k in ks]
    assert_log_close(ks, got, ref, f"gl.poisson.logpmf vs mpmath, {ctx(lam=lam)}")


def test_poisson_logpmf_special_values():
    assert gl.poisson.logpmf(0, 0.0) == 0.0
    assert gl.poisson.logpmf(1, 0.0) == -np.inf
    for k in (-1.0, 0.5, 2.5):
        assert gl.poisson.logpmf(k, 3.0) == -np.inf, f"poisson logpmf(k={k}, lam=3)"
    with pytest.raises(ValueError, match="lam"):
        gl.poisson.logpmf(1, -1.0)


@pytest.mark.parametrize("lam", SCIPY_LAMS)
def test_poisson_cdf_sf_match_scipy(lam):
    ks = np.concatenate([[-1.0], probe_poisson_ks(lam)])
    cdf, sf = gl.poisson.cdf(ks, lam), gl.poisson.sf(ks, lam)
    for k, c, s, rc, rs in zip(ks, cdf, sf, st.poisson.cdf(ks, lam), st.poisson.sf(ks, lam)):
        assert_tail_close(c, rc, f"gl.poisson.cdf(k={k!r}, {ctx(lam=lam)})")
        assert_tail_close(s, rs, f"gl.poisson.sf(k={k!r}, {ctx(lam=lam)})")


@pytest.mark.parametrize("lam", [1e6, 9e6, 1.1e7, 1e9])
def test_poisson_cdf_sf_match_pmf_sums(lam):
    sd = math.sqrt(lam)
    lo, hi = max(0.0, math.floor(lam - 15 * sd - 30)), math.ceil(lam + 15 * sd + 30)
    for z in (-8, -5, -2, -1, 0, 1, 2, 5, 8):
        k = float(math.floor(lam + z * sd))
        rc, rs = window_tails(lambda js: gl.poisson.pmf(js, lam), lo, hi, k)
        assert_tail_close(gl.poisson.cdf(k, lam), rc, f"gl.poisson.cdf(k={k!r}, {ctx(lam=lam)})")
        assert_tail_close(gl.poisson.sf(k, lam), rs, f"gl.poisson.sf(k={k!r}, {ctx(lam=lam)})")


@pytest.mark.parametrize("lam", [1e12, 1e14])
def test_poisson_cdf_sf_match_edgeworth(lam):
    sd = math.sqrt(lam)
    for z in (-8, -5, -2, -1, 0, 1, 2, 5, 8):
        k = float(math.floor(lam + z * sd))
        rc, rs = edgeworth_tails(k, Fraction(lam), lam, lam, lam)
        assert_tail_close(gl.poisson.cdf(k, lam), rc, f"gl.poisson.cdf(k={k!r}, {ctx(lam=lam)})")
        assert_tail_close(gl.poisson.sf(k, lam), rs, f"gl.poisson.sf(k={k!r}, {ctx(lam=lam)})")


@pytest.mark.parametrize("lam", [1e-300, 1e-12, 0.5, 1e6, 1e12])
def test_poisson_cdf_sf_small_k_exact(lam):
    for k, (rc, rs) in enumerate(mp_poisson_head(2, lam)):
        assert_tail_close(gl.poisson.cdf(k, lam), rc, f"gl.poisson.cdf(k={k}, {ctx(lam=lam)})")
        assert_tail_close(gl.poisson.sf(k, lam), rs, f"gl.poisson.sf(k={k}, {ctx(lam=lam)})")


@pytest.mark.parametrize("lam", LAMS)
def test_poisson_distribution(lam):
    d = POISSON.pmf(lam, 1.0)  # the law takes (n, p) with lam = n p
    check_distribution(d, lam, lam, 0, 0 if lam == 0 else math.inf,
                       lambda k: gl.poisson.cdf(k, lam), lambda k: gl.poisson.sf(k, lam),
                       f"poisson.pmf({ctx(lam=lam)})")


def test_poisson_distribution_uses_n_times_p():
    a, b = POISSON.pmf(1e4, 0.25), POISSON.pmf(2500.0, 1.0)
    assert np.array_equal(a.support, b.support) and np.allclose(a.probs, b.probs, rtol=1e-13, atol=0), \
        "poisson.pmf(n=1e4, p=0.25) differs from poisson.pmf(n=2500, p=1)"


def test_poisson_distribution_too_wide():
    with pytest.raises(ValueError, match="max_support"):
        POISSON.pmf(1e15, 0.5)


@pytest.mark.parametrize("lam", [0.5, 10.0, 100.0, 1e4])
def test_poisson_ppf_matches_scipy(lam):
    got = gl.poisson.ppf(U_MODERATE, lam)
    ref = st.poisson.ppf(U_MODERATE, lam)
    for u, g, r in zip(U_MODERATE, got, ref):
        assert g == r, f"gl.poisson.ppf(u={u!r}, {ctx(lam=lam)}) = {g!r}, scipy {r!r}"


@pytest.mark.parametrize("lam", [1e-300, 1e-12, 0.5, 10.0, 1e4, 1e9, 1e12])
def test_poisson_ppf_definition(lam):
    failures = ppf_definition_failures(
        lambda u: float(gl.poisson.ppf(u, lam)), lambda k: gl.poisson.cdf(k, lam),
        lambda k: gl.poisson.sf(k, lam), U_EXTREME, math.inf, f"poisson {ctx(lam=lam)}")
    assert not failures, "\n".join(failures)


@pytest.mark.parametrize("lam", [0.5, 10.0, 1e4, 1e12])
def test_poisson_ppf_monotone_and_edges(lam):
    us = np.sort(np.concatenate([np.linspace(0, 1, 2001), U_EXTREME]))
    ks = gl.poisson.ppf(us, lam)
    bad = np.flatnonzero(np.diff(ks) < 0)
    assert bad.size == 0, f"poisson ppf not monotone, {ctx(lam=lam)}: at u={us[bad[0]]!r}"
    at0 = gl.poisson.ppf(0.0, lam)
    assert at0 == gl.poisson.ppf(2.0**-53, lam), f"poisson ppf(u=0) != ppf(2^-53), {ctx(lam=lam)}"
    if np.exp(-lam) >= 2.0**-53:
        assert at0 == 0.0, f"poisson ppf(u=0, {ctx(lam=lam)}) = {at0!r}, expected 0"
    at1, below1 = gl.poisson.ppf(1.0, lam), gl.poisson.ppf(U_MAX, lam)
    assert at1 == below1 and np.isfinite(at1), (
        f"poisson ppf(u=1) = {at1!r}, ppf(1 - 2^-53) = {below1!r}, {ctx(lam=lam)}")


def test_poisson_ppf_zero_mean():
    assert np.all(gl.poisson.ppf(np.array([0.0, 0.5, 1.0]), 0.0) == 0.0)


# ----------------------------------------------------------------------------------------------
# law.evaluate at the numerical extremes of docs/math/extremes.md: a finite K in the support
# ----------------------------------------------------------------------------------------------

EXTREME_NS = [0, 1e-6, 0.5, 1, 2, 16, 17, 1e9, 1e15]
EXTREME_PS = [0.0, 1e-300, 1e-12, 1e-7, 0.5, 1 - 1e-7, 1.0]
EXTREME_US = np.array([0.0, 1e-300, 2.0**-54, 0.5, 1 - 2.0**-53, 1.0])  # increasing


@pytest.mark.parametrize("p", EXTREME_PS)
@pytest.mark.parametrize("n", EXTREME_NS)
def test_evaluate_at_extremes(n, p):
    u = EXTREME_US.reshape(-1, 1)
    k = BINOMIAL.evaluate(n, p, u)
    top = binomial_top(n, p)
    for ui, ki in zip(EXTREME_US, k):
        assert np.isfinite(ki) and 0 <= ki <= top and ki == math.floor(ki), (
            f"binomial.evaluate({ctx(n=n, p=p, u=ui)}) = {ki!r}, expected an integer in [0, {top}]")
    kp = POISSON.evaluate(n, p, u)
    assert np.all(np.isfinite(kp) & (kp >= 0) & (kp == np.floor(kp))), (
        f"poisson.evaluate({ctx(n=n, p=p)}) at u={EXTREME_US.tolist()} gave {kp.tolist()}")
    assert np.all(np.diff(k) >= 0) and np.all(np.diff(kp) >= 0), (
        f"evaluate not monotone in u, {ctx(n=n, p=p)}: binomial {k.tolist()}, poisson {kp.tolist()}")
