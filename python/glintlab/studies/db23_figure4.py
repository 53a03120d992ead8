"""DB23 Figure 4 quantified: blending two LOD levels (ZK16's output blend, DB23's distributed trials)
against the exact law of spatialized Bernoulli trials in the footprint (``lod.figure4_table``)."""
from __future__ import annotations

import math

import numpy as np

from . import lod
from .base import Context, Tables, support_window

NAME = "db23_figure4"
TITLE = "DB23 Fig. 4: blending two LOD levels against spatialized Bernoulli trials"
MEANING = ("Blending outputs (ZK16) has the wrong variance and a lattice of values; distributing the trials "
           "(DB23 eq. 10) reproduces the stratified ground truth exactly.")
DEFAULTS = {"samples": 200_000}
QUICK = {"samples": 20_000}
NOTEBOOK = "db23_figure4_lod.ipynb"
TABLE = {"db23_figure4": ["N", "p", "n", "w_area", "source", "pvalue", "var_ratio", "tv_vs_square"]}


def compute(params: dict, ctx: Context) -> Tables:
    table, panels = lod.figure4_table(samples=params["samples"], seed=ctx.seed)
    dist = table[table.source.str.startswith("distributed")]
    zk = table[table.source.str.startswith("zk16")]
    return Tables({"db23_figure4": table},
                  {"smallest chi-square p, distributed": float(dist.pvalue.min()),
                   "variance ratio range, zk16_linear": f"{zk.var_ratio.min():.3f} to {zk.var_ratio.max():.3f}"},
                  data={"panels": panels})


def figures(tables: Tables, ctx: Context) -> list:
    return [ctx.save(figure4(tables["db23_figure4"], tables["panels"]), "db23_figure4.png")]


def figure4(table, panels, columns: int = 3):
    """DB23 Figure 4 quantified (from ``lod.figure4_table``): per footprint, the ground truth's exact
    law (bars), ZK16 linear blending and the distributed binomial (exact laws as lines, samples as
    dots), with each source's chi-square p-value against the truth and its variance ratio."""
    import matplotlib.pyplot as plt

    rows = math.ceil(len(panels) / columns)
    fig, axes = plt.subplots(rows, columns, figsize=(4.2 * columns, 2.9 * rows), squeeze=False)
    colors = {"zk16_linear": "#d6604d", "distributed": "#2166ac"}
    for ax, panel in zip(axes.ravel(), panels):
        truth = panel["truth"]
        ax.bar(truth.support, truth.probs, width=0.9 if len(truth) < 80 else 1.0, color="#bbbbbb",
               label="ground truth (exact)")
        sel = table[(table.N == panel["N"]) & (table.p == panel["p"]) & (table.P == panel["P"])]
        for label, src in panel["sources"].items():
            row = sel[sel.source == label].iloc[0]
            base = label.split("[")[0]
            if base not in colors:
                continue
            color = colors[base] if "[" not in label else "#5aae61"
            d = src["exact"]
            text = f"{label}: p={row.pvalue:.2g}, var x{row.var_ratio:.2f}"
            if d is not None:
                ax.step(d.support, d.probs, where="mid", color=color, lw=1.3, label=text)
            values, counts = np.unique(src["samples"], return_counts=True)
            ax.plot(values, counts / counts.sum(), ".", ms=2.5, color=color,
                    label=None if d is not None else text)
        lo, hi = support_window(truth, 1e-5)
        ax.set_xlim(lo - 1, hi + 1)
        ax.set_title(f"N={panel['N']}, p={panel['p']:g}: n={panel['n']:g} ({panel['footprint']}), "
                     f"w_area={panel['w_area']:g}", fontsize=8)
        ax.legend(fontsize=6, loc="upper right")
        ax.set_xlabel("K", fontsize=8)
    for ax in axes.ravel()[len(panels):]:
        ax.axis("off")
    fig.suptitle("DB23 Fig. 4: blending two LOD levels against spatialized Bernoulli trials "
                 "(grey: truth; red: ZK16 output blend; blue: distributed, eq. 10)", fontsize=9)
    fig.tight_layout()
    return fig
