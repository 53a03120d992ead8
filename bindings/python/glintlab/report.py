"""The `make run` report: what glintlab knows of the exact laws and the metrics.

Three parts, each a table (CSV + JSON) and, where it helps, a figure (PNG), gathered in a small
self-contained ``index.html``:

1. exact laws: support size after trimming, mean/variance against the formulas, tail masses, at
   ordinary and extreme (n, p), including non-integer n (the stratified rule);
2. sampler checks: the binomial and Poisson samplers against their exact laws (chi-square p-value,
   exact TV of the sample histogram, ns/sample);
3. metrics: the distance between the uniform layout's law (binomial) and the Poisson layout's law
   for the same mean, over n and p: when the two ground truths differ visibly, and by how much;
4. LOD blending (glintlab.lod): DB23 Fig. 4 quantified against the stratified ground truth, the
   effect of non-integer trial counts, coherence along zoom and pan paths, the receding strip.
"""
from __future__ import annotations

import html
import json
import math
import platform
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from . import __version__
from .exact import binomial as binom_fn
from . import _validate as V
from .bench import grid_maps, pareto_figure, speed_accuracy
from .grid import error_table, standard_grid
from .laws import law
from .metrics import METRICS, chi2_test, distance

EXACT_POINTS = [(16, 0.1), (1e3, 1e-2), (1e6, 0.3), (1e9, 1e-6), (1e15, 1e-13), (1e12, 1 - 1e-7),
                (10.5, 0.3), (0.25, 0.8), (1e6, 1e-300)]
SAMPLER_POINTS = [(16, 0.1), (1e3, 1e-2), (1e6, 0.3), (1e9, 1e-6), (60, 0.9), (10.5, 0.3)]
# The speed/accuracy trade: every law with an exact pmf, over the standard grid.
TRADE_LAWS = [("binomial", {}), ("gaussian", {"rounding": "floor"}), ("gaussian", {"rounding": "round"}),
              ("zk16", {}), ("gated", {}), ("gated_shader", {}), ("gated_continuous", {}), ("dual_gated", {}),
              ("threshold", {}), ("head_cf", {})]


def _progress(total, quiet):
    """A rich progress bar on a terminal, nothing otherwise."""
    if quiet or not sys.stderr.isatty():
        class _Null:
            def __enter__(self): return self
            def __exit__(self, *a): return False
            def step(self, label): pass
        return _Null()
    from rich.progress import Progress

    class _Bar:
        def __enter__(self):
            self.p = Progress(transient=True)
            self.p.__enter__()
            self.task = self.p.add_task("report", total=total)
            return self

        def __exit__(self, *a):
            return self.p.__exit__(*a)

        def step(self, label):
            self.p.update(self.task, advance=1, description=label)
    return _Bar()


def exact_table() -> pd.DataFrame:
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
                       mean_rel_err=_rel(d.mean, n * p), var_rel_err=_rel(d.var, var))
        except ValueError:  # support too large to list: tails still exact
            row.update(support=float("nan"))
        row["P(K=0)"] = float(binom_fn.pmf(0, n, p))
        row["P(K>mean+5sd)"] = float(binom_fn.sf(math.floor(n * p + 5 * math.sqrt(var)), n, p))
        rows.append(row)
    return pd.DataFrame(rows)


def sampler_table(samples: int, seed: int, progress) -> pd.DataFrame:
    rows = []
    for name in ("binomial", "poisson"):
        lw = law(name)
        for n, p in SAMPLER_POINTS:
            progress.step(f"sampling {name} n={n:g} p={p:g}")
            t0 = time.perf_counter()
            x = lw.sample(n, p, size=samples, seed=seed)
            dt = time.perf_counter() - t0
            d = lw.pmf(n, p)
            r = chi2_test(x, d)
            rows.append(dict(law=name, n=n, p=p, samples=samples, seed=seed, chi2=r.statistic, dof=r.dof,
                             pvalue=r.pvalue, tv_hist=distance(x, d, "tv"),
                             mean_rel_err=_rel(x.mean(), d.mean), ns_per_sample=dt / samples * 1e9))
    return pd.DataFrame(rows)


def metrics_table() -> pd.DataFrame:
    rows = []
    b, po = law("binomial"), law("poisson")
    for n in (10, 100, 1e4, 1e6):
        for p in (1e-3, 1e-2, 0.1, 0.3, 0.5, 0.9):
            if n * p < 0.05:
                continue
            db, dp = b.pmf(n, p), po.pmf(n, p)
            row = dict(n=n, p=p, mean=n * p)
            row.update({m: distance(db, dp, m) for m in METRICS})
            rows.append(row)
    return pd.DataFrame(rows)


def trade_table(samples: int, seed: int, progress):
    """Errors over the standard grid (worst and median) and ns/sample timed in this run (glintlab.bench)."""
    progress.step("speed / accuracy of every law")
    return speed_accuracy([law(name, **params) for name, params in TRADE_LAWS], samples=samples, seed=seed)


def _rel(a, b):
    return abs(a - b) / abs(b) if b else abs(a - b)


def _trade_figures(out: Path, trade: pd.DataFrame, errors: pd.DataFrame):
    import matplotlib.pyplot as plt

    fig = pareto_figure(trade)
    paths = [out / "trade_pareto.png"]
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)
    paths.append(grid_maps(out / "error_maps_tv.png", errors, list(trade.law), "tv", 1e-6, "magma",
                           "TV to the binomial", "Exact TV over the standard grid: n (log, x) by p (y)"))
    return paths


def _figure9(out: Path, samples: int, seed: int):
    import matplotlib.pyplot as plt

    from .blending import blended_law
    from .figures import figure9
    # DB23 Fig. 9a: the gated Gaussian inside the distributed binomial (N = 4^8: n = 8 sits mid-level).
    lod = blended_law("distributed", inner="gated").at_density(4.0**8)
    fig, rows = figure9(laws=("gated", "head_cf", lod), samples=samples, seed=seed)
    path = out / "db23_figure9.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return [path], pd.DataFrame(rows)


def _figures(out: Path, samples: int, seed: int):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = []
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.4))
    for ax, (n, p) in zip(axes, [(16, 0.1), (1e3, 1e-2), (10.5, 0.3)]):
        b = law("binomial")
        d = b.pmf(n, p)
        x = b.sample(n, p, size=samples, seed=seed)
        emp = pd.Series(x).value_counts(normalize=True).sort_index()
        ax.bar(d.support, d.probs, width=0.8, color="#9ecae1", label="exact pmf")
        ax.plot(emp.index, emp.values, "o", ms=3.5, color="#08519c", label=f"{samples:.0e} samples")
        r = chi2_test(x, d)
        ax.set_title(f"Binomial(n={n:g}, p={p:g})\nchi-square p = {r.pvalue:.3f}", fontsize=9)
        ax.set_xlabel("K")
    axes[0].set_ylabel("probability")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    paths.append(out / "sampler_vs_exact.png")
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(6, 3.6))
    ps = np.logspace(-4, math.log10(0.95), 40)
    b, po = law("binomial"), law("poisson")
    for n in (10, 100, 1e4, 1e6):
        tv = [distance(b.pmf(n, p), po.pmf(n, p), "tv") for p in ps]
        ax.loglog(ps, tv, label=f"n = {n:g}")
    ax.set_xlabel("p")
    ax.set_ylabel("TV(Binomial(n, p), Poisson(np))")
    ax.set_title("Uniform vs Poisson facet layouts: exact TV", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    paths.append(out / "binomial_vs_poisson_tv.png")
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)
    return paths


def _precision(out: Path, samples: int, seed: int):
    """float32 against float64 over the standard grid (coupled draws), and (1 - p)^n four ways."""
    import matplotlib.pyplot as plt

    from .precision import float32_summary, float32_table, one_minus_p_pow_n
    laws = [law(name, **params) for name, params in TRADE_LAWS if name != "binomial"]
    table = float32_table(laws, samples=samples, seed=seed)
    summary = float32_summary(table)
    paths = [grid_maps(out / "float32_mismatch_maps.png", table, list(summary.law), "mismatch",
                        1.0 / samples / 2, "viridis", "P(K_f32 != K_f64) >= TV",
                        f"float32 vs float64 on the same uniforms ({samples} draws per point): n (x) by p (y)")]

    pow_table = one_minus_p_pow_n()
    fig, ax = plt.subplots(figsize=(6.4, 3.8))
    styles = {("float32", "pow(1-p, n)"): "-", ("float32", "exp(n log1p(-p))"): "--",
              ("float64", "pow(1-p, n)"): ":", ("float64", "exp(n log1p(-p))"): "-."}
    for (prec, method), g in pow_table[pow_table.n == 1e3].groupby(["precision", "method"]):
        ax.loglog(g.p, np.maximum(g.p1_rel_err, 1e-17), styles[(prec, method)], label=f"{prec} {method}")
    ax.set_xlabel("p (n = 1000)")
    ax.set_ylabel("relative error of P1 = 1 - (1-p)^n")
    ax.set_title("The gate probability, four ways (reference: mpmath)", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    paths.append(out / "one_minus_p_pow_n.png")
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)
    table.to_csv(out / "float32_vs_float64_standard_grid.csv", index=False)
    return paths, summary, pow_table


def _lod(out: Path, quick: bool, seed: int):
    """DB23 Fig. 4 quantified, the non-integer trial rule, coherence along zoom/pan paths, the strip."""
    import matplotlib.pyplot as plt

    from . import lod
    from .figures import coherence_figure, figure4, strip_figure
    paths = []
    table, panels = lod.figure4_table(samples=20_000 if quick else 200_000, seed=seed)
    fig = figure4(table, panels)
    paths.append(out / "db23_figure4.png")
    fig.savefig(paths[-1], dpi=100)
    plt.close(fig)
    trials = lod.non_integer_trials_table()
    n_paths = 200 if quick else 1000
    zoom, zoom_K = lod.zoom_study(paths=n_paths, seed=seed)
    pan, pan_K = lod.pan_study(paths=n_paths, seed=seed)
    fig = coherence_figure(zoom_K, pan_K, zoom, pan)
    paths.append(out / "lod_coherence.png")
    fig.savefig(paths[-1], dpi=100)
    plt.close(fig)
    # Quick: a coarser level at a quarter of the density keeps n = N P (and the look) unchanged.
    images, exponents = lod.strip_images(N=2.5e7 if quick else 1e8, width=128 if quick else 256,
                                         height=32 if quick else 64, level=-9 if quick else -10, seed=seed)
    fig = strip_figure(images, exponents)
    paths.append(out / "lod_strip.png")
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)
    tables = {"db23_figure4": table, "lod_non_integer_trials": trials,
              "lod_coherence": pd.concat([zoom, pan], ignore_index=True)}
    return paths, tables


def run(out: Path, quick: bool = False, seed: int = 1, quiet: bool = False) -> dict:
    seed = V.seed(seed)  # before any work: a bad seed is refused by name, not deep inside numpy
    out.mkdir(parents=True, exist_ok=True)
    samples = 10**5 if quick else 10**6
    t0 = time.perf_counter()
    with _progress(len(SAMPLER_POINTS) * 2 + 1, quiet) as progress:
        trade, errors = trade_table(samples, seed, progress)
        tables = {
            "exact_laws": exact_table(),
            "sampler_checks": sampler_table(samples, seed, progress),
            "binomial_vs_poisson": metrics_table(),
            "speed_accuracy": trade,
        }
    fig9_paths, fig9 = _figure9(out, samples, seed)
    tables["db23_figure9"] = fig9
    precision_paths, tables["float32_vs_float64"], tables["one_minus_p_pow_n"] = _precision(
        out, 256 if quick else 1024, seed)
    lod_paths, lod_tables = _lod(out, quick, seed)
    tables.update(lod_tables)
    # Anisotropic grids (LAWS.md §6): the study's summary, its maps and the image timing.
    from .aniso_study import write_report as aniso_report
    aniso_paths, aniso_tables = aniso_report(out, full=False, samples=4_000 if quick else 10_000, seed=seed,
                                             image=not quick)
    tables["aniso_summary"] = aniso_tables["aniso_summary"]
    if "aniso_image" in aniso_tables:
        tables["aniso_image"] = aniso_tables["aniso_image"]
    figures = (_figures(out, samples, seed) + _trade_figures(out, trade, errors) + fig9_paths + lod_paths
               + precision_paths + aniso_paths)
    errors.to_csv(out / "error_table_standard_grid.csv", index=False)
    for name, df in tables.items():
        df.to_csv(out / f"{name}.csv", index=False)
    summary = {
        "glintlab_version": __version__,
        "command": f"glintlab report --out {out}" + (" --quick" if quick else "") + f" --seed {seed}",
        "seed": seed,
        "samples": samples,
        "python": platform.python_version(),
        "seconds": round(time.perf_counter() - t0, 2),
        "tables": {k: json.loads(v.to_json(orient="records")) for k, v in tables.items()},
        "figures": [p.name for p in figures],
    }
    (out / "report.json").write_text(json.dumps(summary, indent=1))
    _write_html(out, summary, tables, figures)
    return summary


def _write_html(out: Path, summary, tables, figures):
    parts = [f"<h1>glintlab {html.escape(summary['glintlab_version'])}: exact laws and metrics</h1>",
             f"<p>Regenerate: <code>{html.escape(summary['command'])}</code> "
             f"(seed {summary['seed']}, {summary['samples']} samples per check, {summary['seconds']} s).</p>"]
    for fig in figures:
        parts.append(f'<p><img src="{fig.name}" alt="{fig.stem}" style="max-width:100%"></p>')
    for name, df in tables.items():
        parts.append(f"<h2>{html.escape(name.replace('_', ' '))}</h2>")
        parts.append(df.to_html(index=False, float_format=lambda v: f"{v:.6g}", border=0))
    (out / "index.html").write_text(
        "<!doctype html><meta charset='utf-8'><title>glintlab report</title>"
        "<style>body{font-family:sans-serif;max-width:1100px;margin:auto}"
        "table{border-collapse:collapse;font-size:12px}td,th{padding:2px 6px;border-bottom:1px solid #ddd}</style>"
        + "\n".join(parts))


def print_summary(summary) -> None:
    def show(title, df, cols):
        print(f"\n== {title}")
        print(df[cols].to_string(index=False, float_format=lambda v: f"{v:.4g}"))

    t = {k: pd.DataFrame(v) for k, v in summary["tables"].items()}
    show("exact laws (trimmed to all but 1e-14 of the mass)", t["exact_laws"],
         ["n", "p", "support", "mass", "mean_rel_err", "var_rel_err", "P(K=0)", "P(K>mean+5sd)"])
    show(f"samplers against exact laws ({summary['samples']} samples, seed {summary['seed']})",
         t["sampler_checks"], ["law", "n", "p", "pvalue", "tv_hist", "mean_rel_err", "ns_per_sample"])
    show("uniform vs Poisson layout (exact distances)", t["binomial_vs_poisson"],
         ["n", "p", "tv", "hellinger", "js", "w1", "ks"])
    show("DB23 Figure 9 idea: exact TV to the binomial, chi-square p of the samples", t["db23_figure9"],
         ["law", "n", "p", "tv", "pvalue"])
    show("DB23 Figure 4: blending two LOD levels against the stratified ground truth (chi-square p, variance ratio)",
         t["db23_figure4"], ["N", "p", "n", "w_area", "source", "pvalue", "var_ratio", "var_ratio_se",
                             "var_ratio_analytic", "tv_vs_square"])
    show("distributed with non-integer trial counts vs Binomial(N P, p)", t["lod_non_integer_trials"],
         ["N", "cells_lo", "p", "max_tv", "mean_tv", "max_var_excess", "bound"])
    show("coherence along zoom and pan paths", t["lod_coherence"],
         ["path", "law", "inner", "mean_abs_step", "pop_rate", "corr_lag1", "corr_lag16", "corr_ends", "mean_K"])
    show("speed / accuracy over the standard grid (exact errors vs the binomial)", t["speed_accuracy"],
         ["law", "tv_max", "tv_median", "hellinger_max", "w1_max", "mean_rel_err_max", "ns_per_sample",
          "ns_ratio_1e9_vs_16"])
    show("anisotropic grids against stratified facets in the ellipse (glintlab aniso for maps and --full)",
         t["aniso_summary"], ["config", "law", "max_abs_mean_bias", "max_weight_bias", "var_ratio_min",
                              "var_ratio_max", "tv_max", "chi2_reject_1pct", "evaluations_min", "evaluations_max"])
    if "aniso_image" in t:
        show("1920 x 1080 image per grid scheme (both cores)", t["aniso_image"],
             ["config", "law", "seconds", "ns_per_pixel", "evaluations_mean", "evaluations_max", "degenerate",
              "clamped"])
    show("float32 vs float64 on the same uniforms (mismatch >= TV; breaks: non-finite, < 0, > n)",
         t["float32_vs_float64"], ["law", "mismatch_max", "at_n", "at_p", "max_abs_diff",
                                   "share_points_over_1pct", "points_broken_f32", "points_broken_f64"])
