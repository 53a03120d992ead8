"""Speed against accuracy (the report's trade section and ``glintlab bench``'s files): each law's cost
against its worst TV to the binomial over the standard grid, as a Pareto plot and per-law error maps
(numbers: ``validation.bench.speed_accuracy``)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from ..api.laws import law
from ..validation.bench import DEFAULT_LAWS, speed_accuracy
from ..validation.grid import standard_grid
from .base import Context, Tables

NAME = "speed_accuracy"
TITLE = "Speed against accuracy: Pareto plot, table and error maps"
MEANING = ("Each law's cost (ns per sample, this run) against its worst TV to the binomial over the standard grid: "
           "the Pareto front shows which laws are worth their cost, the maps show where each law errs.")
DEFAULTS = {"samples": 1_000_000}
QUICK = {"samples": 100_000}
NOTEBOOK = "speed_accuracy.ipynb"
TABLE = {"speed_accuracy": ["law", "tv_max", "tv_median", "mean_rel_err_max", "ns_per_sample", "speedup_vs_numpy",
                            "pareto"]}


def compute(params: dict, ctx: Context) -> Tables:
    ctx.progress("speed / accuracy of every law")
    trade, errors = speed_accuracy([law(name, **prm) for name, prm in DEFAULT_LAWS], samples=params["samples"],
                                   seed=ctx.seed)
    return Tables({"speed_accuracy": trade},
                  {"Pareto front": ", ".join(trade[trade.pareto].law),
                   "numpy binomial ns/sample": float(trade.numpy_ns.iloc[0])},
                  extra={"error_table_standard_grid": errors})


def figures(tables: Tables, ctx: Context) -> list:
    trade = tables["speed_accuracy"]
    return [ctx.save(pareto_figure(trade), "trade_pareto.png", 110),
            grid_maps(Path(ctx.out) / "error_maps_tv.png", tables["error_table_standard_grid"], list(trade.law), "tv",
                      1e-6, "magma", "TV to the binomial", "Exact TV over the standard grid: n (log, x) by p (y)")]


def pareto_figure(summary: pd.DataFrame, floor: float = 1e-6):
    """Worst (red) and median (blue) TV against ns/sample, the Pareto front joined by a line."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4))
    for i, (_, row) in enumerate(summary.sort_values("ns_per_sample").iterrows()):
        marker = "o" if row.accuracy == "exact" else "^"
        ax.plot(row.ns_per_sample, max(row.tv_max, floor), marker, color="#b2182b")
        ax.plot(row.ns_per_sample, max(row.tv_median, floor), "s", color="#2166ac", alpha=0.7)
        label = row.law + (" (exact)" if row.tv_max < floor else "") + (" (sampled)" if row.accuracy != "exact" else "")
        # Laws of similar cost and error sit on each other: stagger their labels.
        ax.annotate(label, (row.ns_per_sample, max(row.tv_max, floor)), fontsize=7, xytext=(4, 2 - 9 * (i % 3)),
                    textcoords="offset points")
    front = summary[summary.pareto].sort_values("ns_per_sample")
    ax.plot(front.ns_per_sample, np.maximum(front.tv_max, floor), "-", color="#b2182b", alpha=0.4, lw=1)
    ax.set_yscale("log")
    ax.set_xscale("log")
    ax.set_ylim(floor / 2, 2)
    ax.set_xlabel("ns / sample (from Python, both cores, mean of the timing points)")
    ax.set_ylabel("TV to the binomial")
    ax.set_title("Speed / accuracy over the standard grid (red: worst, blue: median; line: Pareto front)",
                 fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    return fig


def grid_maps(path, table: pd.DataFrame, names, column: str, floor: float, cmap: str, label: str, title: str):
    """One log-scaled map of `column` over the standard grid (n by p) per law, four to a row, written as
    the PNG ``path``; returns ``path``."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    cols = 4
    rows = (len(names) + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 2.8 * rows), squeeze=False)
    n_values, p_values = standard_grid()
    for ax, name in zip(axes.ravel(), names):
        sub = table[table.law == name].pivot(index="p", columns="n", values=column)
        im = ax.imshow(np.clip(sub.to_numpy(), floor, 1), origin="lower", aspect="auto",
                       norm=LogNorm(floor, 1), extent=[0, len(n_values), 0, len(p_values)], cmap=cmap)
        ax.set_title(name, fontsize=8)
        ax.set_xticks([0, len(n_values) / 2, len(n_values)], ["1", "1e3", "1e6"], fontsize=7)
        ax.set_yticks([0, len(p_values) / 2, len(p_values)], ["1e-6", "0.5", "1-1e-6"], fontsize=7)
    for ax in axes.ravel()[len(names):]:
        ax.axis("off")
    fig.colorbar(im, ax=axes.ravel().tolist(), shrink=0.8, label=label)
    fig.suptitle(title, fontsize=9)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def bench_tables(summary: pd.DataFrame, errors: pd.DataFrame) -> Tables:
    """``glintlab bench``'s tables: bench (one row per law) and bench_errors (per grid point)."""
    return Tables({"bench": summary}, extra={"bench_errors": errors})


def bench_figures(tables: Tables, ctx: Context) -> list:
    """``glintlab bench``'s figures: bench_pareto.png and, for exact laws, bench_error_maps_tv.png."""
    summary = tables["bench"]
    paths = [ctx.save(pareto_figure(summary), "bench_pareto.png", 110)]
    exact = list(summary[summary.accuracy == "exact"].law)
    if exact:
        paths.append(grid_maps(Path(ctx.out) / "bench_error_maps_tv.png", tables["bench_errors"], exact, "tv", 1e-6,
                               "magma", "TV to the binomial", "Exact TV over the standard grid: n (log, x) by p (y)"))
    return paths
