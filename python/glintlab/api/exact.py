"""Vectorized exact distribution functions (scipy.stats-style names; numpy broadcasting).

``binomial.cdf(k, n, p)`` etc. follow the stratified rule for non-integer n (see the README);
``poisson.*`` take the mean ``lam``. Tail masses come from ``sf`` directly, never as 1 - cdf.
"""
from types import SimpleNamespace

import numpy as np

from .. import _core

binomial = SimpleNamespace(
    logpmf=_core.binomial_log_pmf,
    pmf=lambda k, n, p: np.exp(_core.binomial_log_pmf(k, n, p)),
    cdf=_core.binomial_cdf,
    sf=_core.binomial_sf,
    ppf=_core.binomial_quantile,
)

poisson = SimpleNamespace(
    logpmf=_core.poisson_log_pmf,
    pmf=lambda k, lam: np.exp(_core.poisson_log_pmf(k, lam)),
    cdf=_core.poisson_cdf,
    sf=_core.poisson_sf,
    ppf=_core.poisson_quantile,
)
