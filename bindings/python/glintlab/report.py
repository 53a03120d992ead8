"""The `make run` report: what glintlab knows of the exact laws and the metrics.

Three parts, each a table (CSV + JSON) and, where it helps, a figure (PNG), gathered in a small
self-contained ``index.html``:

1. exact laws: support size after trimming, mean/variance against the formulas, tail masses, at
   ordinary and extreme (n, p), including non-integer n (the stratified rule);
2. sampler checks: the binomial and Poisson samplers against their exact laws (chi-square p-value,
   exact TV of the sample histogram, ns/sample);
3. metrics: the distance between the uniform layout's law (binomial) and the Poisson layout's law
   for the same mean, over n and p: when the two ground truths differ visibly, and by how much.
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
from .laws import law
from .metrics import METRICS, chi2_test, distance

EXACT_POINTS = [(16, 0.1), (1e3, 1e-2), (1e6, 0.3), (1e9, 1e-6), (1e15, 1e-13), (1e12, 1 - 1e-7),
                (10.5, 0.3), (0.25, 0.8), (1e6, 1e-300)]
SAMPLER_POINTS = [(16, 0.1), (1e3, 1e-2), (1e6, 0.3), (1e9, 1e-6), (60, 0.9), (10.5, 0.3)]


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


def _rel(a, b):
    return abs(a - b) / abs(b) if b else abs(a - b)


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


def run(out: Path, quick: bool = False, seed: int = 1, quiet: bool = False) -> dict:
    out.mkdir(parents=True, exist_ok=True)
    samples = 10**5 if quick else 10**6
    t0 = time.perf_counter()
    with _progress(len(SAMPLER_POINTS) * 2, quiet) as progress:
        tables = {
            "exact_laws": exact_table(),
            "sampler_checks": sampler_table(samples, seed, progress),
            "binomial_vs_poisson": metrics_table(),
        }
    figures = _figures(out, samples, seed)
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
