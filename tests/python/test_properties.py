"""Property-based tests (Debian's python3-hypothesis): random parameters, shapes and dtypes thrown at
the public functions. Every call either returns a result in its documented domain or raises a
ValueError that names the offending parameter - never another exception, a NaN, or a count outside
the law's declared support. `derandomize=True`: the examples are a fixed function of the test, so a
run is reproducible and its time bounded (max_examples per test)."""
import math
import re

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import glintlab as gl

BUDGET = settings(max_examples=60, deadline=None, derandomize=True,
                  suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

DTYPES = [np.float64, np.float32, np.float16, np.int8, np.int64, np.uint64, np.bool_, np.complex128]
NAMED = re.compile(r"(^|: |\()(n|p|k|q|size|seed|samples|a|b|min_expected|alpha|tests|max_support|precision)"
                   r"(\[\d+\])? (=|\(shape)")

# Small counts keep every law fast (zk16 loops over its trials); the domain's edges are covered by
# test_edges.py.
scalars = st.one_of(st.floats(min_value=-1e3, max_value=1e3),
                    st.sampled_from([0.0, 1.0, 0.5, -0.0, 1e-300, 1 - 1e-16, 2.0 ** 53 * 4, float("nan")]),
                    st.integers(-5, 500), st.booleans(), st.just("1"), st.none())


@st.composite
def arrays(draw, lo=-1.0, hi=300.0):
    shape = draw(st.sampled_from([(), (1,), (3,), (2, 3), (0,)]))
    dtype = draw(st.sampled_from(DTYPES))
    values = draw(st.lists(st.floats(lo, hi, allow_nan=False), min_size=int(np.prod(shape)),
                           max_size=int(np.prod(shape))))
    with np.errstate(all="ignore"):
        return np.asarray(values, dtype=np.float64).reshape(shape).astype(dtype)


params = st.one_of(scalars, arrays())
sizes = st.one_of(st.none(), st.integers(-2, 50), st.tuples(st.integers(0, 4), st.integers(0, 3)),
                  st.just((2, 3)), st.booleans(), st.just(2.5), st.just("3"))
seeds = st.one_of(st.integers(-1, 2**64), st.none(), st.just("x"), st.just(1.5), st.booleans())


def assert_named(exc):
    assert NAMED.search(str(exc)), f"ValueError does not name its parameter: {exc}"


def top_count(law_name, n):
    bound = gl.law_traits(law_name)["support"] if law_name in gl.laws() else "unbounded"
    with np.errstate(all="ignore"):
        c = np.ceil(np.asarray(n, dtype=np.float64))
    return {"bounded_by_n": c, "n_plus_one": c + 1}.get(bound, np.inf)


@pytest.mark.parametrize("name", gl.laws())
def test_sample_returns_counts_or_names_the_parameter(name):
    sample_property(gl.law(name), name)


def test_the_sample_property_fails_on_a_wrong_law():
    # The property can fail: a law that returns one facet too many, and one that lets a TypeError
    # escape for a string n, are both caught.
    def too_many(n, p, u):
        return np.floor(n * p + u[..., 0]) + np.ceil(n) + 1

    def type_error(n, p, u):
        raise TypeError("unsupported operand")

    for fn in (too_many, type_error):
        law = gl.custom_law(fn, 1, name="wrong_" + fn.__name__)
        with pytest.raises((AssertionError, TypeError)):
            sample_property(law, "binomial")  # held to the binomial's declared support


def sample_property(law, name):
    @BUDGET
    @given(n=params, p=st.one_of(scalars, arrays(-0.5, 1.5)), size=sizes, seed=seeds)
    def check(n, p, size, seed):
        sample_once(law, name, n, p, size, seed)
    check()


def sample_once(law, name, n, p, size, seed):
    try:
        x = law.sample(n, p, size=size, seed=seed)
    except ValueError as exc:
        assert_named(exc)
        return
    assert isinstance(x, np.ndarray) and x.dtype == np.float64
    assert np.isfinite(x).all() and (x >= 0).all()
    top = np.broadcast_to(top_count(name, n), x.shape) if np.ndim(n) else top_count(name, n)
    assert (x <= top).all()


@pytest.mark.parametrize("name", [n for n in gl.laws() if gl.law(n).has_pmf])
@BUDGET
@given(n=scalars, p=scalars)
def test_pmf_is_a_distribution_or_names_the_parameter(name, n, p):
    try:
        d = gl.law(name).pmf(n, p)
    except ValueError as exc:
        assert_named(exc)
        return
    probs = np.asarray(d.probs)
    assert np.isfinite(probs).all() and (probs >= 0).all() and math.isclose(probs.sum(), 1.0, abs_tol=1e-9)


@BUDGET
@given(k=params, n=st.one_of(st.integers(0, 40), st.floats(0, 40)), p=st.floats(0, 1), q=params)
def test_cdf_sf_ppf_stay_in_their_domain(k, n, p, q):
    law = gl.law("binomial")
    for what, arg in (("cdf", k), ("sf", k), ("ppf", q)):
        try:
            y = np.asarray(getattr(law, what)(arg, n, p))
        except ValueError as exc:
            assert_named(exc)
            continue
        assert np.isfinite(y).all()
        if what == "ppf":  # a support value: an integer in [0, ceil(n)]
            assert ((y >= 0) & (y <= math.ceil(n)) & (y == np.floor(y))).all()
        else:
            assert ((y >= 0) & (y <= 1)).all()


@BUDGET
@given(a=params, b=params, metric=st.sampled_from(gl.METRICS))
def test_distances_and_chi2_are_numbers_or_name_the_parameter(a, b, metric):
    try:
        dist = gl.distance(a, b, metric)
    except ValueError as exc:
        assert_named(exc)
    else:
        assert dist >= 0 and not np.isnan(dist)
    try:
        r = gl.chi2_test_two_sample(a, b)
    except ValueError as exc:
        assert_named(exc)
    else:
        assert np.isnan(r.pvalue) == bool(r.note) and (np.isnan(r.pvalue) or 0 <= r.pvalue <= 1)


@BUDGET
@given(alpha=scalars, tests=st.one_of(st.integers(-2, 100), st.floats(-1, 5), st.booleans(), st.none()))
def test_sidak_alpha(alpha, tests):
    try:
        a = gl.sidak_alpha(alpha, tests)
    except ValueError as exc:
        assert_named(exc)
    else:
        assert 0 <= a <= alpha
