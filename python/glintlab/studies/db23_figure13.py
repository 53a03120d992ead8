"""Convergence to the target NDF (DB23 Fig. 13 idea): the spread and mean of D_P / D(h) against the facet
count n p, and D_P over the disk of half vectors (numbers: :mod:`glintlab.studies.convergence`)."""
from __future__ import annotations

import numpy as np

from .base import Context, Tables
from .convergence import convergence_summary, convergence_table, ndf_images

NAME = "db23_figure13"
TITLE = "Convergence to the target NDF (DB23 Fig. 13 idea)"
MEANING = ("The spread of D_P / D(h) falls like 1 / sqrt(n p) for Beckmann and GGX alike; with exact counts the "
           "mean is right at every density, with DB23's gated law it is off by several percent until n p ~ 100.")
DEFAULTS = {"pixels": 20_000, "R": 0.5, "alpha": 0.5, "image_resolution": 96}
QUICK = {"pixels": 4000, "image_resolution": 64}
NOTEBOOK = "db23_figure13.ipynb"
TABLE = {"db23_figure13_summary": ["law", "ndf", "theta_deg", "p", "slope", "spread_ratio_min", "spread_ratio_max",
                                   "max_abs_z_mean", "max_abs_mean_err"]}


def compute(params: dict, ctx: Context) -> Tables:
    ndfs = (("beckmann", params["alpha"]), ("ggx", params["alpha"]))
    table = convergence_table(ndfs=ndfs, R=params["R"], pixels=params["pixels"], seed=ctx.seed)
    images = ndf_images(ndfs=ndfs, R=params["R"], resolution=params["image_resolution"], seed=ctx.seed)
    summ = convergence_summary(table)
    gated = summ[summ.law.str.contains("gated")]
    exact = summ[~summ.law.str.contains("gated")]
    return Tables({"db23_figure13": table, "db23_figure13_summary": summ},
                  {"slopes (n p >= 10)": f"{summ.slope.min():.3f} to {summ.slope.max():.3f}",
                   "largest |z| of the mean, exact pipeline": float(exact.max_abs_z_mean.max()),
                   "largest mean error, gated pipeline": float(gated.max_abs_mean_err.max())},
                  data={"images": images})


def figures(tables: Tables, ctx: Context) -> list:
    return [ctx.save(convergence_figure(tables["db23_figure13"], tables["images"]), "db23_figure13.png")]


def convergence_figure(table, images):
    """DB23 Fig. 13 idea: relative spread of D_P / D(h) against n p (both NDFs, each law), the mean's
    error, and D_P over the disk of half vectors at increasing density next to the target NDF."""
    import matplotlib.pyplot as plt

    rows = len(images)
    cols = len(next(iter(images.values())))
    fig = plt.figure(figsize=(12, 3.3 + 2.0 * rows))
    grid = fig.add_gridspec(1 + rows, max(cols, 2), height_ratios=[1.6] + [1] * rows)
    ax = fig.add_subplot(grid[0, : max(cols, 2) // 2])
    markers = {"beckmann": "o", "ggx": "s"}
    colors = ["#d6604d", "#4393c3", "#5aae61", "#9970ab"]
    laws = list(dict.fromkeys(table.law))
    for (lw, name, th), g in table.groupby(["law", "ndf", "theta_deg"], sort=False):
        color = colors[laws.index(lw) % len(colors)]
        ax.loglog(g.np, g.rel_spread, markers.get(name, "o"), ms=3, color=color, alpha=0.7,
                  label=f"{lw}, {name}" if th == table.theta_deg.iloc[0] else None)
    x = np.logspace(np.log10(table.np.min()), np.log10(table.np.max()), 50)
    ax.loglog(x, 1 / np.sqrt(x), "k-", lw=1, label="1 / sqrt(n p)")
    ax.set_xlabel("n p (expected reflecting facets per footprint)")
    ax.set_ylabel("std of D_P / D(h)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=6)
    ax.set_title("Relative spread (markers: every angle theta_h; the binomial's is sqrt((1 - p) / (n p)))", fontsize=8)
    ax = fig.add_subplot(grid[0, max(cols, 2) // 2:])
    for (lw, name, th), g in table.groupby(["law", "ndf", "theta_deg"], sort=False):
        color = colors[laws.index(lw) % len(colors)]
        ax.errorbar(g.np, g["mean"] - 1, yerr=2 * g.mean_se, fmt=markers.get(name, "o") + "-", ms=3, lw=0.6,
                    color=color, alpha=0.7)
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xscale("log")
    ax.set_xlabel("n p")
    ax.set_ylabel("E[D_P / D(h)] - 1 (bars: 2 SE)")
    ax.grid(True, which="both", alpha=0.3)
    ax.set_title("Mean error: " + ", ".join(f"{lw} ({c})" for lw, c in
                                           zip(laws, ["red", "blue", "green", "purple"])), fontsize=8)
    for i, (label, panels) in enumerate(images.items()):
        vmax = np.nanmax(panels[-1][1])
        for j, (title, img) in enumerate(panels):
            ax = fig.add_subplot(grid[1 + i, j])
            ax.imshow(np.clip(img, 0, 2 * vmax), cmap="inferno", vmin=0, vmax=vmax, interpolation="nearest")
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_title(title, fontsize=8)
            if j == 0:
                ax.set_ylabel(label, fontsize=8)
    fig.suptitle("DB23 Fig. 13 idea: the glinty NDF D_P converges to its target (Beckmann, GGX) as facet density "
                 "grows; disks: D_P / D(n) over half vectors", fontsize=9)
    fig.tight_layout()
    return fig
