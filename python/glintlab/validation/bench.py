"""Speed against accuracy, per law, in one run (``glintlab bench`` and the report's trade section).

Accuracy: the law's error against the exact binomial over the standard grid, exact when the law
has an exact pmf (``sweep`` with samples=None), otherwise sampled on a coarser grid with its Monte
Carlo noise floor (``tv_noise``) reported beside it. Speed: ns/sample of ``law.sample`` from Python
on glintlab's threads (both cores), best of ``repeats`` calls of ``samples`` draws at each timing
point, against numpy's binomial (``Generator(PCG64).binomial``, one thread: numpy has no other) at
the same points, timed in the same run.
"""
from __future__ import annotations

import math
import time

import numpy as np
import pandas as pd

from ..api import checks as v
from .grid import standard_grid
from ..api.laws import law as get_law, law_variants
from .references import resolve_law
from .sweep import error_table, sweep

TIMING_POINTS = [(16, 0.1), (1e3, 1e-2), (1e6, 0.3), (1e9, 1e-6)]
# The laws of the speed/accuracy trade study: the variants each law declares in its own file.
DEFAULT_LAWS = law_variants("study")


def best_time(fn, repeats: int) -> float:
    """Seconds of the fastest of `repeats` calls of fn, after one warm-up call."""
    fn()  # warm-up: page in code and tables
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def speed_accuracy(laws=None, samples: int = 10**6, seed: int = 1, repeats: int = 2, timing_points=TIMING_POINTS,
                   sampled_grid: int = 8, sampled_draws: int = 20000, progress=None):
    """(summary, errors): one summary row per law (law, accuracy, tv_max, tv_median, hellinger_max,
    w1_max, mean_rel_err_max, var_rel_err_median, tv_noise, ns_per_sample, ns_ratio_1e9_vs_16,
    numpy_ns, speedup_vs_numpy) and the per-point error table behind it.

    Laws without an exact pmf are measured on ``sampled_grid`` x ``sampled_grid`` points of the
    standard grid with ``sampled_draws`` draws each (accuracy "sampled"; tv_noise is the largest
    TV pure sampling noise would give there on average).
    """
    seed = v.seed(seed)
    for name, value in (("samples", samples), ("repeats", repeats)):
        v.integer(name, value, minimum=1)
    if laws is None:
        laws = [resolve_law({"name": name, "params": params}) for name, params in DEFAULT_LAWS]
    else:
        laws = [resolve_law(x) for x in laws]
    exact = [lw for lw in laws if lw.has_pmf]
    other = [lw for lw in laws if not lw.has_pmf]
    metrics = ["tv", "hellinger", "w1", "mean_rel_err", "var_rel_err"]
    tables = []
    if exact:
        tables.append(sweep(exact, metrics=metrics, progress=progress).assign(accuracy="exact"))
    if other:
        gn, gp = standard_grid()
        pick = lambda a: a[np.linspace(0, a.size - 1, sampled_grid).astype(int)]
        tables.append(sweep(other, n=pick(gn), p=pick(gp), metrics=metrics, samples=sampled_draws, seed=seed,
                            progress=progress).assign(accuracy="sampled"))
    errors = pd.concat(tables, ignore_index=True)
    agg = dict(tv_max=("tv", "max"), tv_median=("tv", "median"), hellinger_max=("hellinger", "max"),
               w1_max=("w1", "max"), mean_rel_err_max=("mean_rel_err", "max"),
               var_rel_err_median=("var_rel_err", "median"), accuracy=("accuracy", "first"))
    if "tv_noise" in errors:
        agg["tv_noise"] = ("tv_noise", "max")
    summary = errors.groupby("law", sort=False).agg(**agg).reset_index()
    rng = np.random.default_rng(seed)
    numpy_ns = [best_time(lambda: rng.binomial(int(n), p, size=samples), repeats) / samples * 1e9
                for n, p in timing_points]
    speed = {}
    for lw in laws:
        times = [best_time(lambda: lw.sample(n, p, size=samples, seed=seed), repeats) / samples * 1e9
                 for n, p in timing_points]
        speed[lw.label] = (float(np.mean(times)), times[-1] / times[0],
                             float(np.mean(np.array(numpy_ns) / np.array(times))))
    summary["ns_per_sample"] = summary.law.map(lambda k: speed[k][0])
    summary["ns_ratio_1e9_vs_16"] = summary.law.map(lambda k: speed[k][1])
    summary["numpy_ns"] = float(np.mean(numpy_ns))
    summary["speedup_vs_numpy"] = summary.law.map(lambda k: speed[k][2])
    summary["pareto"] = pareto_front(summary.ns_per_sample.to_numpy(), summary.tv_max.to_numpy())
    return summary, errors


def pareto_front(cost, error) -> np.ndarray:
    """Whether each (cost, error) point is on the Pareto front (no other point is at least as good in
    both and better in one)."""
    cost, error = np.asarray(cost, float), np.asarray(error, float)
    out = np.ones(cost.size, dtype=bool)
    for i in range(cost.size):
        better = (cost <= cost[i]) & (error <= error[i]) & ((cost < cost[i]) | (error < error[i]))
        out[i] = not better.any()
    return out


THRESHOLDS = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0, 256.0, 1024.0)
# Above every n p of the standard grid (at most 1e6 - 1e-6... times p < 1): the explicit count everywhere.
EXPLICIT_T = 1e7


def threshold_trade(thresholds=THRESHOLDS, n=None, p=None, draws_per_point: int = 8, repeats: int = 3,
                    seed: int = 1) -> pd.DataFrame:
    """WWH18's threshold trade (their Fig. 15 idea): the filtered model ``threshold`` (K = n p when
    n p > T, an explicit count below) as T varies, over the (n, p) points of a grid (default: standard).

    Error, exact per point against the binomial: TV, and ``rel_intensity_err`` = W1 / (n p), the mean
    absolute error of a pixel's D_P relative to D(h) when the filtered value replaces the count (W1 is
    the optimal coupling, so no renderer can do better with that law). Summaries over the points:
    median, 90th percentile and maximum. WWH18 measure PSNR of a whole rendering against the
    unfiltered one; this is the per-pixel version over a stated population of pixels.

    Cost, measured in this run: ns per draw of ``law.sample`` on the whole population (each point
    ``draws_per_point`` times, both cores, best of ``repeats``), and ``cost_ratio`` to the explicit
    count everywhere (T = EXPLICIT_T): the explicit count is an inversion whose loop grows with n p,
    which is why a threshold pays.
    """
    seed = v.seed(seed)
    if n is None or p is None:
        gn, gp = standard_grid()
        n = gn if n is None else np.atleast_1d(np.asarray(n, float))
        p = gp[gp <= 0.5] if p is None else np.atleast_1d(np.asarray(p, float))
    for T in thresholds:
        if not (isinstance(T, (int, float)) and math.isfinite(T) and T > 0):
            v.fail("thresholds", T, "finite numbers > 0")
    laws = [get_law("threshold", T=float(T)) for T in thresholds] + [get_law("threshold", T=EXPLICIT_T)]
    errors = error_table(laws, n=n, p=p, metrics=("tv", "w1"))
    errors["rel_intensity_err"] = errors.w1 / (errors.n * errors.p)
    errors["filtered"] = errors.n * errors.p > errors.law.map({lw.label: lw.params["T"] for lw in laws})
    nn, pp = np.meshgrid(np.asarray(n, float), np.asarray(p, float), indexing="ij")
    pop_n, pop_p = np.repeat(nn.ravel(), draws_per_point), np.repeat(pp.ravel(), draws_per_point)
    rows = []
    for lw in laws:
        g = errors[errors.law == lw.label]
        seconds = best_time(lambda: lw.sample(pop_n, pop_p, seed=seed), repeats)
        ri = g.rel_intensity_err
        rows.append({"T": lw.params["T"], "law": lw.label, "points": len(g), "filtered_share": g.filtered.mean(),
                     "tv_median": g.tv.median(), "tv_p90": g.tv.quantile(0.9), "tv_max": g.tv.max(),
                     "rel_intensity_err_median": ri.median(), "rel_intensity_err_p90": ri.quantile(0.9),
                     "rel_intensity_err_max": ri.max(), "ns_per_draw": seconds / pop_n.size * 1e9})
    table = pd.DataFrame(rows)
    table["cost_ratio"] = table.ns_per_draw / table.ns_per_draw.iloc[-1]
    table["explicit"] = table["T"] == EXPLICIT_T
    return table
