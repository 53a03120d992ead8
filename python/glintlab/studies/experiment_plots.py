"""The plots of an experiment (``glintlab run``, ``glintlab sweep``, ``gl.run_experiment``): one PNG per
metric. The validation layer computes and writes the tables; the drawing lives here (all plotting is in
the studies layer)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from ..validation.experiment import ExperimentResult
from ..validation.experiment import run_experiment as _run_experiment


def run_experiment(source, out=None, store=None, progress=None, threads=None, **engine) -> ExperimentResult:
    """Runs an experiment (a path, JSON text or dict; or a results.json to re-run). With ``out``,
    writes results.csv, results.json and one PNG per metric there (as the document's outputs say).
    ``engine``: sweep's engine, scheduler, workers, chunk and timeout (e.g. engine="dask")."""
    return _run_experiment(source, out=out, store=store, progress=progress, threads=threads, plot=plot_results,
                           **engine)


def plot_results(table: pd.DataFrame, metrics, out: Path) -> list:
    """One PNG per metric: a log-scaled map over (n, p) per law when both axes vary, else curves."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    paths = []
    laws = list(dict.fromkeys(table.law))
    n_vals, p_vals = np.unique(table.n), np.unique(table.p)
    for metric in metrics:
        if n_vals.size > 1 and p_vals.size > 1:
            cols = min(4, len(laws))
            rows = (len(laws) + cols - 1) // cols
            fig, axes = plt.subplots(rows, cols, figsize=(3.4 * cols, 2.9 * rows), squeeze=False)
            values = table[metric].to_numpy(dtype=float)
            positive = values[np.isfinite(values) & (values > 0)]
            lo = max(positive.min(), 1e-16) if positive.size else 1e-16
            hi = max(positive.max(), lo * 10) if positive.size else 1.0
            for ax, lw in zip(axes.ravel(), laws):
                grid = table[table.law == lw].pivot(index="p", columns="n", values=metric)
                z = np.clip(grid.to_numpy(dtype=float), lo, hi)
                im = ax.pcolormesh(np.arange(grid.shape[1] + 1), np.arange(grid.shape[0] + 1), z,
                                   norm=LogNorm(lo, hi), cmap="magma", shading="flat")
                ax.set_title(lw, fontsize=8)
                _ticks(ax.set_xticks, grid.columns.to_numpy())
                _ticks(ax.set_yticks, grid.index.to_numpy())
                ax.set_xlabel("n", fontsize=7)
                ax.set_ylabel("p", fontsize=7)
            for ax in axes.ravel()[len(laws):]:
                ax.axis("off")
            fig.colorbar(im, ax=axes.ravel().tolist(), shrink=0.8, label=metric)
        else:
            fig, ax = plt.subplots(figsize=(6, 3.6))
            x_name = "n" if n_vals.size > 1 else "p"
            for lw in laws:
                sub = table[table.law == lw]
                ax.plot(sub[x_name], sub[metric], "o-", ms=3, label=lw)
            ax.set_xscale("log")
            if (table[metric] > 0).any():
                ax.set_yscale("log")
            ax.set_xlabel(x_name)
            ax.set_ylabel(metric)
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=7)
            fig.tight_layout()
        paths.append(out / f"{metric}.png")
        fig.savefig(paths[-1], dpi=100)
        plt.close(fig)
    return paths


def _ticks(setter, values):
    idx = np.unique(np.linspace(0, values.size - 1, min(values.size, 4)).astype(int))
    setter(idx + 0.5, [f"{values[i]:.3g}" for i in idx], fontsize=6)
