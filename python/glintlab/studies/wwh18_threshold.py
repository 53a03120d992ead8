"""WWH18's threshold trade (their Fig. 15 idea): the filtered model's error and cost as its threshold T
varies (numbers: ``validation.bench.threshold_trade``)."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from ..validation.bench import threshold_trade
from .base import Context, Tables

NAME = "wwh18_threshold"
TITLE = "WWH18's threshold trade (their Fig. 15 idea)"
MEANING = ("Raising the filtering threshold T lowers the intensity error of the filtered model like "
           "sqrt(2 / (pi T)) while the explicit counting it keeps costs more.")
DEFAULTS = {"thresholds": [0.25, 0.5, 1, 2, 4, 8, 16, 32, 64, 128, 256, 1024], "draws_per_point": 16}
QUICK = {"draws_per_point": 4}
NOTEBOOK = "wwh18_threshold.ipynb"
TABLE = {"wwh18_threshold": ["T", "filtered_share", "rel_intensity_err_p90", "rel_intensity_err_max",
                             "ns_per_draw", "cost_ratio"]}


def compute(params: dict, ctx: Context) -> Tables:
    table = threshold_trade(thresholds=tuple(float(t) for t in params["thresholds"]),
                            draws_per_point=params["draws_per_point"], seed=ctx.seed)
    at16 = table[table["T"] == 16.0]
    stats = {}
    if len(at16):
        r = at16.iloc[0]
        stats = {"T = 16: worst W1 / (n p)": float(r.rel_intensity_err_max),
                 "T = 16: cost vs explicit everywhere": float(r.cost_ratio)}
    return Tables({"wwh18_threshold": table}, stats)


def figures(tables: Tables, ctx: Context) -> list:
    return [ctx.save(threshold_figure(tables["wwh18_threshold"]), "wwh18_threshold.png")]


def threshold_figure(table: pd.DataFrame, paper_T: float = 16.0):
    """Error (left axis) and cost relative to the explicit count (right axis) against the threshold T."""
    import matplotlib.pyplot as plt

    t = table[~table.explicit]
    fig, ax = plt.subplots(figsize=(6.8, 3.9))
    ax.loglog(t["T"], t.rel_intensity_err_max, "o-", color="#b2182b", label="W1 / (n p): worst point")
    ax.loglog(t["T"], t.rel_intensity_err_p90, "s--", color="#b2182b", alpha=0.6, label="W1 / (n p): 90th percentile")
    # Just above T the lost spread is E|K - n p| / (n p) ~ sqrt(2 (1 - p) / (pi n p)) <= sqrt(2 / (pi T)).
    ax.loglog(t["T"], np.sqrt(2 / (math.pi * t["T"])), ":", color="k", lw=1, label="sqrt(2 / (pi T))")
    ax.set_xlabel("threshold T (filter when n p > T)")
    ax.set_ylabel("error against the explicit count", color="#b2182b")
    ax.axvline(paper_T, color="grey", lw=0.8, ls=":")
    ax.annotate(f"WWH18: T = {paper_T:g}", (paper_T, ax.get_ylim()[0]), fontsize=7, xytext=(3, 4),
                textcoords="offset points")
    ax.grid(True, which="both", alpha=0.3)
    ax2 = ax.twinx()
    ax2.loglog(t["T"], t.ns_per_draw, "D-", color="#2166ac", label="cost: ns / draw over the population")
    ax2.axhline(table.ns_per_draw.iloc[-1], color="#2166ac", lw=0.8, ls="--")
    ax2.annotate(f"explicit count everywhere: {table.ns_per_draw.iloc[-1]:.3g} ns", (t["T"].iloc[0],
                 table.ns_per_draw.iloc[-1]), fontsize=7, color="#2166ac", xytext=(2, -10), textcoords="offset points")
    ax2.set_ylabel("ns / draw (both cores)", color="#2166ac")
    lines = ax.get_legend_handles_labels()[0] + ax2.get_legend_handles_labels()[0]
    labels = ax.get_legend_handles_labels()[1] + ax2.get_legend_handles_labels()[1]
    ax.legend(lines, labels, fontsize=7, loc="lower left")
    ax.set_title(f"WWH18 Fig. 15 idea: the filtered model's threshold over the standard grid, p <= 1/2 "
                 f"({t.points.iloc[0]} (n, p) points)", fontsize=8)
    fig.tight_layout()
    return fig
