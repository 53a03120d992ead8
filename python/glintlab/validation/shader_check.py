"""The verdict on a shader law (``glintlab shader``): the shader as it runs on a Vulkan device, measured
against the law it claims to approximate and, row by row, against a C++ twin.

Checks, in order (docs/guide/shaders.md):

- ``points``: at DB23's Figure 9 points, 10^6 samples of the shader (binned as the law says) against
  the exact pmf of ``against``: Pearson chi-square (pass at p > alpha / points, Sidak, with alpha =
  1e-3 the family-wise false-failure rate) and the TV distance of the histogram to the exact pmf.
- ``grid``: TV of a histogram of ``grid_samples`` draws to the exact pmf over the standard grid (a
  map), next to ``tv_floor``, the TV of the same number of draws of ``against`` itself (the sampling
  noise a histogram's TV carries: a shader with TV near its floor is indistinguishable there).
- ``rows``: with a ``twin`` (a C++ law in float32), the share of rows of the same uniforms where the
  two differ, and the largest |dK|, raw and binned.
- ``extremes``: the numerical-extremes suite (docs/math/extremes.md) on the shader in float32: NaN,
  inf, negative counts and errors fail the verdict; counts above ceil(n) are reported.
- ``speed``: ns per evaluation on the device, with the C++ twin (or ``against``) on the same rows as
  the named baseline, as a ratio.

A shader returning NaN, inf or a negative count where a check samples it fails that check (the row
carries the ``error``), as in the extremes suite: a faulty shader is a failed check, not bad input.
On lavapipe, a shader with loops whose trip count is not a constant <= 65535 gets a ``caveat``: the
device stops loops there, so the verdict is not what a GPU would compute (``gpu_faithful`` False).

Exit of the verdict: 0 every check passes, 1 one fails (bad input raises ValueError: exit 2).
"""
from __future__ import annotations

import time

import numpy as np
import pandas as pd

from ..api.laws import law as get_law, uniforms
from ..api.shaders import ShaderOutputError
from ..api.metrics import chi2_test, distance, sidak_alpha
from .._core import Distribution
from .extremes import extremes_table, failed_checks
from .grid import standard_grid

# DB23's Figure 9 points (n, p), where their paper compares the gated Gaussian with the binomial.
VERDICT_POINTS = [(8, 0.1), (8, 0.5), (1000, 0.002), (1000, 0.5)]
ALPHA = 1e-3
# Rows allowed to differ from the twin, by one count at most: a GPU's pow, exp and log are allowed
# errors of several ulps (pow inherits log2's absolute error near 1: on lavapipe DB23's P1 = 1 -
# pow(1 - p, n) moves 1.3e-4 of the binned rows at n = 1e4, p = 1e-6). A port's bug moves far more
# (K + 1: every row; a reversed gate: most rows).
ROW_SHARE = 1e-3
ROW_POINTS = VERDICT_POINTS + [(3.5, 0.3), (50, 0.02), (1e5, 0.9), (1e4, 1e-6)]


def _law(x):
    return get_law(x) if isinstance(x, str) else x


def point_table(law, against, points=VERDICT_POINTS, samples: int = 10**6, seed: int = 1,
                alpha: float = ALPHA) -> pd.DataFrame:
    """One row per (n, p): tv, chi2, dof, pvalue, threshold, ok (the sampled shader against the exact
    pmf of ``against``)."""
    law, against = _law(law), _law(against)
    per_test = sidak_alpha(alpha, len(points))
    rows = []
    for n, p in points:
        exact = against.pmf(n, p)
        try:
            x = law.bin(law.sample(n, p, size=samples, seed=seed))
        except ShaderOutputError as exc:  # NaN, inf or a negative count: this check fails
            rows.append(dict(n=n, p=p, samples=samples, tv=np.nan, chi2=np.nan, dof=0, pvalue=np.nan,
                             threshold=per_test, ok=False, error=str(exc)))
            continue
        r = chi2_test(x, exact)
        rows.append(dict(n=n, p=p, samples=samples, tv=distance(Distribution.empirical(x), exact, "tv"),
                         chi2=r.statistic, dof=r.dof, pvalue=r.pvalue, threshold=per_test,
                         ok=bool(r.pvalue > per_test), error=""))
    return pd.DataFrame(rows)


def grid_table(law, against, samples: int = 4096, seed: int = 1, stride: int = 2) -> pd.DataFrame:
    """TV of ``samples`` draws of the shader to the exact pmf of ``against`` over the standard grid
    (every ``stride``-th n and p), with ``tv_floor`` (the same for draws of ``against``)."""
    law, against = _law(law), _law(against)
    ns, ps = standard_grid()
    rows = []
    for n in ns[::stride]:
        for p in ps[::stride]:
            exact = against.pmf(n, p)
            y = against.bin(against.sample(n, p, size=samples, seed=seed + 1))
            try:
                x = law.bin(law.sample(n, p, size=samples, seed=seed))
                tv, error = distance(Distribution.empirical(x), exact, "tv"), ""
            except ShaderOutputError as exc:
                tv, error = np.nan, str(exc)
            rows.append(dict(n=float(n), p=float(p), tv=tv,
                             tv_floor=distance(Distribution.empirical(y), exact, "tv"), error=error))
    return pd.DataFrame(rows)


def row_table(law, twin, points=None, rows: int = 10**6, seed: int = 5) -> pd.DataFrame:
    """The shader against its C++ twin (float32) on the same uniforms: per (n, p) the share of rows
    that differ (raw output and binned count) and the largest |dK| of each; ok when at most
    ``ROW_SHARE`` of the binned rows differ, by one count at most."""
    law, twin = _law(law), _law(twin)
    if twin.n_uniforms != law.n_uniforms:
        raise ValueError(f"twin = {twin.name!r} reads {twin.n_uniforms} uniforms and the shader {law.n_uniforms}; "
                         "expected a twin reading the same uniforms (row-by-row comparison)")
    points = points or ROW_POINTS
    u = uniforms(rows, law.n_uniforms, seed=seed)
    out = []
    for n, p in points:
        c = twin.evaluate(n, p, u, precision="float32")
        try:
            k = law.evaluate(n, p, u)
        except ShaderOutputError as exc:
            out.append(dict(n=n, p=p, rows=rows, raw_differ=np.nan, raw_max_dk=np.nan, binned_differ=np.nan,
                            binned_max_dk=np.nan, ok=False, error=str(exc)))
            continue
        kb, cb = law.bin(k), twin.bin(c)
        share = float(np.mean(kb != cb))
        big = float(np.abs(kb - cb).max())
        out.append(dict(n=n, p=p, rows=rows, raw_differ=float(np.mean(k != c)), raw_max_dk=float(np.abs(k - c).max()),
                        binned_differ=share, binned_max_dk=big, ok=bool(share <= ROW_SHARE and big <= 1), error=""))
    return pd.DataFrame(out)


def extremes_checks(law, samples: int = 256, seed: int = 1) -> pd.DataFrame:
    """The extremes suite on the shader (float32): its rows with the failed checks marked."""
    table = extremes_table([_law(law)], precisions=("float32",), samples=samples, seed=seed)
    failed = failed_checks(table)
    table = table.assign(breaks=(failed.nonfinite | failed.below_zero | failed.error))
    return table


def speed_table(law, baseline, n=1000.0, p=0.002, evaluations: int = 10**6, repeats: int = 3) -> pd.DataFrame:
    """ns per evaluation of the shader on its device (transfers and the float32 conversion of the
    uniforms included) and of ``baseline`` (C++, float32, all threads) on the same rows, best of
    ``repeats``; ``ratio`` = shader / baseline. A baseline without float32 arithmetic (the binomial,
    poisson, zk16) runs in float64 (``baseline_precision``). The shader is timed by ``evaluate_raw``
    (what it returns, unchecked), so a faulty shader is still timed."""
    law, baseline = _law(law), _law(baseline)
    precision = "float32" if "float32" in baseline.precisions else "float64"
    u = uniforms(evaluations, law.n_uniforms, seed=9)
    ub = u if baseline.n_uniforms == law.n_uniforms else uniforms(evaluations, baseline.n_uniforms, seed=9)
    shader = getattr(law, "evaluate_raw", law.evaluate)
    shader(n, p, u[:1024])  # the first call pays for the device's start

    def best(fn):
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t0)
        return min(times) / evaluations * 1e9

    shader_ns = best(lambda: shader(n, p, u))
    base_ns = best(lambda: baseline.evaluate(n, p, ub, precision=precision))
    return pd.DataFrame([dict(device=getattr(law, "device", ""), n=n, p=p, evaluations=evaluations,
                              shader_ns=shader_ns, baseline=baseline.name, baseline_precision=precision,
                              baseline_ns=base_ns, ratio=shader_ns / base_ns)])


def shader_verdict(law, against="binomial", twin=None, samples: int = 10**6, grid_samples: int = 4096,
                   grid_stride: int = 2, seed: int = 1, extremes_samples: int = 256,
                   speed_evaluations: int = 10**6, rows: int = 10**6) -> dict:
    """Every check above as tables, and ``failures`` (a list of one-line reasons; empty: the shader
    passes)."""
    law = _law(law)
    tables = {"points": point_table(law, against, samples=samples, seed=seed)}
    tables["grid"] = grid_table(law, against, samples=grid_samples, seed=seed, stride=grid_stride)
    if twin is not None:
        tables["rows"] = row_table(law, twin, rows=rows)
    tables["extremes"] = extremes_checks(law, samples=extremes_samples, seed=seed)
    tables["speed"] = speed_table(law, twin if twin is not None else against, evaluations=speed_evaluations)
    failures = []
    for r in tables["points"].itertuples():
        if r.error:
            failures.append(f"chi-square against {_law(against).name} at n = {r.n:g}, p = {r.p:g}: {r.error}")
        elif not r.ok:
            failures.append(f"chi-square against {_law(against).name} at n = {r.n:g}, p = {r.p:g}: "
                            f"p-value {r.pvalue:.3g} <= {r.threshold:.3g} (TV {r.tv:.4f})")
    grid_errors = tables["grid"][tables["grid"].error != ""]
    if len(grid_errors):
        r = grid_errors.iloc[0]
        failures.append(f"grid: {len(grid_errors)} points where the shader returned invalid counts (first: "
                        f"n = {r.n:g}, p = {r.p:g}: {r.error})")
    if "rows" in tables:
        for r in tables["rows"].itertuples():
            if r.error:
                failures.append(f"row by row against {_law(twin).name} at n = {r.n:g}, p = {r.p:g}: {r.error}")
            elif not r.ok:
                failures.append(f"row by row against {_law(twin).name} at n = {r.n:g}, p = {r.p:g}: "
                                f"{r.binned_differ:.3g} of the rows differ, largest |dK| {r.binned_max_dk:g}")
    breaks = tables["extremes"][tables["extremes"].breaks]
    if len(breaks):
        r = breaks.iloc[0]
        failures.append(f"extremes: {len(breaks)} rows with NaN, inf, negative counts or errors "
                        f"(first: n = {r.n:g}, p = {r.p:g}, uniforms {r.uniforms})")
    caveat = getattr(law, "loop_caveat", None)
    return {"tables": tables, "failures": failures, "caveat": caveat, "gpu_faithful": caveat is None}
