"""Distances between distributions and the chi-square goodness-of-fit test (docs/math/metrics.md)."""
from __future__ import annotations

import numpy as np
import scipy.stats

from .. import _core
from . import checks as v
from .._core import Chi2Result, Distribution

METRICS = tuple(_core.metric_names())


def _as_distribution(name, x):
    if isinstance(x, Distribution):
        return x
    arr = v.as_float_array(name, x)
    if arr.ndim != 1 or arr.size == 0:
        v.fail(name, x, "a Distribution or a non-empty 1-D array of samples")
    return Distribution.empirical(np.ascontiguousarray(arr))


def distance(a, b, metric: str = "tv") -> float:
    """Distance between a and b, each a Distribution or a 1-D array of samples (its empirical law).

    Metrics: tv, chi2_distance, hellinger, kl (KL(a || b), nats), js (nats), w1, ks. Supports are
    aligned by exact value: bin real-valued outputs first. Sample-based estimates are biased upward
    (TV by about sqrt(#values / #samples)).
    """
    if not isinstance(metric, str):
        v.fail("metric", metric, "one of " + ", ".join(METRICS))
    return _core.distance(_as_distribution("a", a), _as_distribution("b", b), metric)


def chi2_test(samples, dist: Distribution, min_expected: float = 5.0, fitted_params: int = 0, alpha=None):
    """Pearson chi-square test of samples against an exact law.

    Support points are merged left to right until every bin expects >= ``min_expected`` samples;
    dof = bins - 1 - fitted_params; the p-value is P(chi2_dof >= statistic). Samples the law cannot
    produce make the test fail outright (statistic inf, p-value 0, see ``.note``). The result also
    carries the merged bins (``lower``, ``upper``, ``observed``, ``expected``) for plotting.

    Too few samples for two bins: an exact likelihood-ratio test (docs/math/metrics.md#metric-chi2-test),
    enumerated when the outcomes are few, else bounded or estimated by Monte Carlo; ``.resolution`` is
    the p-value's resolution (0 when computed, 1 / (1 + draws) for a Monte Carlo estimate). ``alpha``,
    the level the p-value will be compared with, makes the Monte Carlo estimate refine until the
    decision p <= alpha is clear (NaN, with a note, if it is still open at the cap).
    """
    if not isinstance(dist, Distribution):
        v.fail("dist", dist, "a glintlab.Distribution (e.g. law.pmf(n, p))")
    arr = v.as_float_array("samples", samples).ravel()
    if arr.size == 0:
        v.fail("samples", samples, "a non-empty array")
    v.integer("fitted_params", fitted_params, expected="an integer >= 0")
    # A number, not anything float() accepts ("5" is a mistake worth naming).
    min_expected = v.real("min_expected", min_expected)
    if alpha is None:
        alpha = 0.0
    else:
        alpha = v.real("alpha", alpha)
        if not 0 < alpha < 1:
            v.fail("alpha", alpha, "a number in (0, 1) or None")
    return _core.chi2_test(np.ascontiguousarray(arr), dist, min_expected, int(fitted_params), alpha)


def chi2_test_two_sample(a, b, min_expected: float = 5.0) -> Chi2Result:
    """Pearson chi-square test that two sets of samples come from one law (homogeneity test).

    The 2 x m table of counts per value is merged left to right until every cell expects
    >= ``min_expected`` samples under the pooled law; dof = bins - 1; p = P(chi2_dof >= statistic).
    When everything merges into one bin the test has no power: p-value NaN and a note, never 1.
    ``observed`` and ``expected`` of the result are those of ``a``.
    """
    xa = v.as_float_array("a", a).ravel()
    xb = v.as_float_array("b", b).ravel()
    for name, x in (("a", xa), ("b", xb)):
        if x.size == 0:
            v.fail(name, x, "a non-empty array of samples")
        if not np.isfinite(x).all():
            v.fail(name, x[~np.isfinite(x)][0], "finite samples")
    min_expected = v.real("min_expected", min_expected)
    if not min_expected > 0:
        v.fail("min_expected", min_expected, "a number > 0")
    values, inverse = np.unique(np.concatenate([xa, xb]), return_inverse=True)
    ca = np.bincount(inverse[:xa.size], minlength=values.size).astype(np.float64)
    cb = np.bincount(inverse[xa.size:], minlength=values.size).astype(np.float64)
    total, share_a = xa.size + xb.size, xa.size / (xa.size + xb.size)
    smaller = min(share_a, 1 - share_a)
    # Merge left to right until the smaller sample's expected count per bin reaches min_expected; a
    # last bin short of it joins the one before.
    edges, acc = [], 0.0
    for i, c in enumerate(ca + cb):
        acc += c
        if acc * smaller >= min_expected:
            edges.append(i + 1)
            acc = 0.0
    if not edges:
        edges = [values.size]
    elif edges[-1] != values.size:
        edges[-1] = values.size
    starts = [0] + edges[:-1]
    oa = np.array([ca[s:e].sum() for s, e in zip(starts, edges)])
    ob = np.array([cb[s:e].sum() for s, e in zip(starts, edges)])
    col = oa + ob
    ea, eb = col * share_a, col * (1 - share_a)
    statistic = float(((oa - ea) ** 2 / ea).sum() + ((ob - eb) ** 2 / eb).sum())
    dof = len(edges) - 1
    lower = values[starts].astype(np.float64)
    upper = values[np.array(edges) - 1].astype(np.float64)
    if dof < 1:
        return Chi2Result(statistic, 0, float("nan"), int(total),
                          f"no power: all {total} samples merge into one bin of expected count >= {min_expected:g}; "
                          "the test cannot reject (p-value NaN); draw more samples", lower, upper, oa, ea)
    return Chi2Result(statistic, dof, float(scipy.stats.chi2.sf(statistic, dof)), int(total), "", lower, upper, oa, ea)


def sidak_alpha(alpha: float, tests: int) -> float:
    """Per-test significance keeping the family-wise false-failure rate at alpha over `tests` tests."""
    v.integer("tests", tests, expected="an integer >= 1")  # 2.7 tests is not 2 tests
    return _core.sidak_alpha(v.real("alpha", alpha), int(tests))
