"""Distances between distributions and the chi-square goodness-of-fit test (docs/math/metrics.md)."""
from __future__ import annotations

import numpy as np

from .. import _core
from . import checks as v
from .._core import Distribution

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


def chi2_test(samples, dist: Distribution, min_expected: float = 5.0, fitted_params: int = 0):
    """Pearson chi-square test of samples against an exact law.

    Support points are merged left to right until every bin expects >= ``min_expected`` samples;
    dof = bins - 1 - fitted_params; the p-value is P(chi2_dof >= statistic). Samples the law cannot
    produce make the test fail outright (statistic inf, p-value 0, see ``.note``). The result also
    carries the merged bins (``lower``, ``upper``, ``observed``, ``expected``) for plotting.
    """
    if not isinstance(dist, Distribution):
        v.fail("dist", dist, "a glintlab.Distribution (e.g. law.pmf(n, p))")
    arr = v.as_float_array("samples", samples).ravel()
    if arr.size == 0:
        v.fail("samples", samples, "a non-empty array")
    if isinstance(fitted_params, bool) or not isinstance(fitted_params, (int, np.integer)):
        v.fail("fitted_params", fitted_params, "an integer >= 0")
    # A number, not anything float() accepts ("5" is a mistake worth naming).
    min_expected = v.real("min_expected", min_expected)
    return _core.chi2_test(np.ascontiguousarray(arr), dist, min_expected, int(fitted_params))


def sidak_alpha(alpha: float, tests: int) -> float:
    """Per-test significance keeping the family-wise false-failure rate at alpha over `tests` tests."""
    if isinstance(tests, bool) or not isinstance(tests, (int, np.integer)):  # 2.7 tests is not 2 tests
        v.fail("tests", tests, "an integer >= 1")
    return _core.sidak_alpha(v.real("alpha", alpha), int(tests))
