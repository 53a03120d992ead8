"""Numerical extremes (docs/math/extremes.md) as a study: the failure counts per law and check (numbers:
:mod:`glintlab.validation.extremes`; the suite's own page, ``extremes.html``, is
:func:`glintlab.report.html.write_extremes_report`).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from ..validation.extremes import CHECKS, extremes_summary, extremes_table, invalid_inputs_table
from .base import Context, Tables

NAME = "extremes"
TITLE = "Numerical extremes (docs/math/extremes.md)"
MEANING = ("Every law gives a finite K in [0, n] at extreme n, p and uniforms in both precisions, except the "
           "shader's gated law, which returns n + 1 as the shader does; every invalid input is refused by name.")
DEFAULTS = {"samples": 4096}
QUICK = {"samples": 1024}
NOTEBOOK = "speed_accuracy.ipynb"
TABLE = {"extremes_summary": ["law", "precision", "points", "failures", "failed_checks"]}


def compute(params: dict, ctx: Context) -> Tables:
    table = extremes_table(samples=params["samples"], seed=ctx.seed)
    invalid = invalid_inputs_table()
    summary = extremes_summary(table)
    failing = summary[summary.failures > 0]
    return Tables({"extremes_summary": summary},
                  {"laws x precisions": len(summary), "with failing rows": ", ".join(
                      f"{r.law} ({r.precision})" for r in failing.itertuples()) or "none",
                   "invalid inputs refused by name": f"{int(invalid.ok.sum())} of {len(invalid)}",
                   "details": "extremes/extremes.html"},
                  data={"table": table, "invalid": invalid})


def figures(tables: Tables, ctx: Context) -> list:
    return [failure_matrix_figure(tables["extremes_summary"], Path(ctx.out) / "extremes.png")]


def failure_matrix_figure(summary: pd.DataFrame, path) -> Path:
    """Failure counts per law and check, float64 and float32 side by side, written as the PNG ``path``."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    laws_ = list(dict.fromkeys(summary.law))
    precs = ["float64", "float32"]
    mats = {}
    for prec in precs:
        mat = np.full((len(laws_), len(CHECKS)), np.nan)
        s = summary[summary.precision == prec].set_index("law")
        for i, name in enumerate(laws_):
            if name in s.index:
                mat[i] = [s.loc[name, c] for c in CHECKS]
                if prec != "float64":  # the pmf is checked once, on the float64 rows
                    mat[i, [CHECKS.index("pmf_mass"), CHECKS.index("pmf_support")]] = np.nan
        mats[prec] = mat
    top = max([1.0] + [float(np.nanmax(np.log10(1 + m))) for m in mats.values() if np.isfinite(m).any()])
    cmap = matplotlib.colormaps["Reds"].copy()
    cmap.set_bad("#dddddd")
    fig, axes = plt.subplots(1, 2, figsize=(13, 0.3 * len(laws_) + 2.4), sharey=True)
    for ax, prec in zip(axes, precs):
        mat = mats[prec]
        ax.imshow(np.ma.masked_invalid(np.log10(1 + mat)), cmap=cmap, vmin=0, vmax=top, aspect="auto")
        for i in range(len(laws_)):
            for j in range(len(CHECKS)):
                v = mat[i, j]
                dark = not np.isnan(v) and np.log10(1 + v) > 0.6 * top
                ax.text(j, i, "n/a" if np.isnan(v) else str(int(v)), ha="center", va="center", fontsize=7,
                        color="#777" if np.isnan(v) else ("white" if dark else "black"),
                        fontweight="bold" if not np.isnan(v) and v > 0 else "normal")
        ax.set_xticks(range(len(CHECKS)), CHECKS, rotation=30, ha="right", fontsize=8)
        ax.set_yticks(range(len(laws_)), laws_, fontsize=7)
        ax.set_title(f"{prec}: failing (n, p, uniform set) rows per check", fontsize=9)
    fig.suptitle("Numerical extremes (docs/math/extremes.md): failure counts (colour: log scale; grey: not run)",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)
