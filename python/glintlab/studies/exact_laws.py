"""Exact laws and their samplers: the exact binomial's moments and tails at extreme (n, p), chi-square
tests of the binomial and Poisson samplers against their exact laws, and how far the uniform
(binomial) and Poisson facet layouts are apart (exact TV)."""
from __future__ import annotations

import math
import time

import numpy as np
import pandas as pd

from ..api.exact import binomial as binom_fn
from ..api.laws import law
from ..api.metrics import METRICS, chi2_test, distance
from ..validation.rows import relative_error
from .base import Context, Tables

NAME = "exact_laws"
TITLE = "Exact laws and their samplers"
MEANING = ("The binomial and Poisson samplers reproduce their exact laws (chi-square p-values), and the uniform "
           "and Poisson facet layouts differ visibly only when p is not small.")
DEFAULTS = {"samples": 1_000_000}
QUICK = {"samples": 100_000}
NOTEBOOK = "exact_laws.ipynb"
TABLE = {"sampler_checks": ["law", "n", "p", "pvalue", "tv_hist", "ns_per_sample", "note"]}

EXACT_POINTS = [(16, 0.1), (1e3, 1e-2), (1e6, 0.3), (1e9, 1e-6), (1e15, 1e-13), (1e12, 1 - 1e-7),
                (10.5, 0.3), (0.25, 0.8), (1e6, 1e-300)]
SAMPLER_POINTS = [(16, 0.1), (1e3, 1e-2), (1e6, 0.3), (1e9, 1e-6), (60, 0.9), (10.5, 0.3)]
# The binomial's samples drawn at these points are shown against the exact pmf.
FIGURE_POINTS = [(16, 0.1), (1e3, 1e-2), (10.5, 0.3)]
# A sampler check fails below this p-value (Sidak-style: about 1e-3 false alarms per report run).
SAMPLER_ALPHA = 1e-4
TV_NS = (10, 100, 1e4, 1e6)


def compute(params: dict, ctx: Context) -> Tables:
    samples, seed = params["samples"], ctx.seed
    rows = []
    b = law("binomial")
    for n, p in EXACT_POINTS:
        m = math.floor(n)
        g = (n - m) * p
        var = m * p * (1 - p) + g * (1 - g)
        row = dict(n=n, p=p, mean_formula=n * p, var_formula=var)
        try:
            d = b.pmf(n, p)
            row.update(support=len(d), k_min=d.support[0], k_max=d.support[-1], mass=d.probs.sum(),
                       mean_rel_err=relative_error(d.mean, n * p), var_rel_err=relative_error(d.var, var))
        except ValueError:  # support too large to list: tails still exact
            row.update(support=float("nan"))
        row["P(K=0)"] = float(binom_fn.pmf(0, n, p))
        row["P(K>mean+5sd)"] = float(binom_fn.sf(math.floor(n * p + 5 * math.sqrt(var)), n, p))
        rows.append(row)
    exact = pd.DataFrame(rows)
    rows, histograms = [], {}
    for name in ("binomial", "poisson"):
        lw = law(name)
        for n, p in SAMPLER_POINTS:
            ctx.progress(f"sampling {name} n={n:g} p={p:g}")
            t0 = time.perf_counter()
            x = lw.sample(n, p, size=samples, seed=seed)
            dt = time.perf_counter() - t0
            d = lw.pmf(n, p)
            r = chi2_test(x, d)
            rows.append(dict(law=name, n=n, p=p, samples=samples, seed=seed, chi2=r.statistic, dof=r.dof,
                             pvalue=r.pvalue, tv_hist=distance(x, d, "tv"),
                             mean_rel_err=relative_error(x.mean(), d.mean), ns_per_sample=dt / samples * 1e9,
                             note=r.note))
            if name == "binomial" and (n, p) in FIGURE_POINTS:
                histograms[n, p] = (d, pd.Series(x).value_counts(normalize=True).sort_index(), r.pvalue)
    checks = pd.DataFrame(rows)
    rows = []
    po = law("poisson")
    for n in TV_NS:
        for p in (1e-3, 1e-2, 0.1, 0.3, 0.5, 0.9):
            if n * p < 0.05:
                continue
            db, dp = b.pmf(n, p), po.pmf(n, p)
            row = dict(n=n, p=p, mean=n * p)
            row.update({m: distance(db, dp, m) for m in METRICS})
            rows.append(row)
    layouts = pd.DataFrame(rows)
    ps = np.logspace(-4, math.log10(0.95), 40)
    tv_curves = {n: [distance(b.pmf(n, p), po.pmf(n, p), "tv") for p in ps] for n in TV_NS}
    return Tables(
        tables={"exact_laws": exact, "sampler_checks": checks, "binomial_vs_poisson": layouts},
        stats={"sampler checks": len(checks), "smallest p-value": float(checks.pvalue.min()),
               "largest support relative mean error": float(exact.mean_rel_err.max())},
        failures=[f"{r.law} at n = {r.n:g}, p = {r.p:g}: chi-square p = {r.pvalue:.2g} < {SAMPLER_ALPHA:g}"
                  + (f" ({r.note})" if r.note else "")
                  for r in checks.itertuples() if r.pvalue < SAMPLER_ALPHA],
        data={"histograms": [(n, p, *histograms[n, p]) for n, p in FIGURE_POINTS], "samples": samples,
              "tv_p": ps, "tv_curves": tv_curves})


def figures(tables: Tables, ctx: Context) -> list:
    import matplotlib.pyplot as plt
    samples = tables["samples"]
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.4))
    for ax, (n, p, d, emp, pvalue) in zip(axes, tables["histograms"]):
        ax.bar(d.support, d.probs, width=0.8, color="#9ecae1", label="exact pmf")
        ax.plot(emp.index, emp.values, "o", ms=3.5, color="#08519c", label=f"{samples:.0e} samples")
        ax.set_title(f"Binomial(n={n:g}, p={p:g})\nchi-square p = {pvalue:.3f}", fontsize=9)
        ax.set_xlabel("K")
    axes[0].set_ylabel("probability")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    paths = [ctx.save(fig, "sampler_vs_exact.png", 110)]
    fig, ax = plt.subplots(figsize=(6, 3.6))
    for n, tv in tables["tv_curves"].items():
        ax.loglog(tables["tv_p"], tv, label=f"n = {n:g}")
    ax.set_xlabel("p")
    ax.set_ylabel("TV(Binomial(n, p), Poisson(np))")
    ax.set_title("Uniform vs Poisson facet layouts: exact TV", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    paths.append(ctx.save(fig, "binomial_vs_poisson_tv.png", 110))
    return paths
