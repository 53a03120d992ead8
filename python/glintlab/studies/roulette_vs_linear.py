"""Roulette versus linear blending (KPT25 Fig. 6 idea): pixel statistics and image insets between two
MIP levels per blend, against the truth (``lod.blend_appearance``, ``lod.blend_insets``)."""
from __future__ import annotations

import numpy as np

from . import lod
from .base import Context, Tables

NAME = "roulette_vs_linear"
TITLE = "Roulette versus linear blending (KPT25 Fig. 6 idea)"
MEANING = ("Between two MIP levels linear blending lights about twice the pixels at half the intensity; "
           "KPT25's roulette reduces that error without removing it, and the distributed law matches the truth.")
DEFAULTS = {"facets_lo": 4.0, "p": 0.05, "samples": 50_000, "inset_size": 64}
QUICK = {"samples": 10_000, "inset_size": 48}
NOTEBOOK = "lod_blending.ipynb"
TABLE = {"roulette_vs_linear": ["blend", "w", "lit_share", "lit_intensity", "lit_share_vs_truth",
                                "lit_intensity_vs_truth"]}


def compute(params: dict, ctx: Context) -> Tables:
    table = lod.blend_appearance(facets_lo=params["facets_lo"], p=params["p"], samples=params["samples"],
                                 seed=ctx.seed)
    insets = lod.blend_insets(facets_lo=params["facets_lo"], p=params["p"], size=params["inset_size"],
                              seed=ctx.seed)
    mid = table[np.isclose(table.w, 0.5)].set_index("blend")
    stats = {f"w = 1/2, {k}": f"lit x{r.lit_share_vs_truth:.2f}, intensity x{r.lit_intensity_vs_truth:.2f}"
             for k, r in mid.iterrows() if not k.startswith("truth")}
    return Tables({"roulette_vs_linear": table}, stats, data={"insets": insets})


def figures(tables: Tables, ctx: Context) -> list:
    return [ctx.save(roulette_figure(tables["insets"], tables["roulette_vs_linear"]), "roulette_vs_linear.png")]


def roulette_figure(insets, table, vmax: float = 8.0):
    """KPT25 Fig. 6 idea: image insets per blend at each LOD weight (rows: truth and blends, columns: w),
    then lit share and lit intensity against w relative to the truth (``lod.blend_appearance``)."""
    import matplotlib.pyplot as plt

    ws = list(insets)
    labels = list(next(iter(insets.values())))
    fig = plt.figure(figsize=(11, 2.2 * len(labels) * 0.62 + 3.2))
    grid = fig.add_gridspec(len(labels), len(ws) + 2, width_ratios=[1] * len(ws) + [1.6, 1.6])
    for j, w in enumerate(ws):
        for i, label in enumerate(labels):
            ax = fig.add_subplot(grid[i, j])
            img = insets[w][label]
            ax.imshow(np.sqrt(np.clip(img, 0, vmax) / vmax), cmap="magma", vmin=0, vmax=1, interpolation="nearest")
            ax.set_xticks([])
            ax.set_yticks([])
            if i == 0:
                ax.set_title(f"w = {w:g}", fontsize=8)
            if j == 0:
                ax.set_ylabel(label, fontsize=7)
    colors = {"truth": "k", "linear": "#d6604d", "roulette": "#4393c3", "distributed": "#5aae61"}
    for k, (column, ylabel) in enumerate([("lit_share_vs_truth", "lit pixels / truth"),
                                          ("lit_intensity_vs_truth", "intensity of lit pixels / truth")]):
        ax = fig.add_subplot(grid[:, len(ws) + k])
        for label, g in table.groupby("blend", sort=False):
            color = next(c for key, c in colors.items() if label.startswith(key))
            ax.plot(g.w, g[column], "o-" if not label.startswith("truth") else "-", ms=3, color=color, label=label)
        ax.set_xlabel("LOD weight w (0: level lo, 1: level hi)", fontsize=8)
        ax.set_title(ylabel, fontsize=8)
        ax.grid(True, alpha=0.3)
        if k == 0:
            ax.legend(fontsize=6)
    fig.suptitle("KPT25 Fig. 6 idea: blending two MIP levels; pixel intensity K / (N P p), sqrt scale "
                 "(linear at w = 1/2: twice the glints at half the intensity)", fontsize=9)
    fig.tight_layout()
    return fig
