"""DB23 Figure 9: approximations of the binomial (the gated Gaussian, head_cf, and the gated law inside
DB23's distributed LOD blend), exact pmfs against the binomial at small and large n, p small and near
1/2, with each law's samples overlaid and tested."""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..api.blends import blended_law
from ..api.laws import law as get_law
from ..api.metrics import chi2_test, distance
from .base import Context, Tables, support_window

NAME = "db23_figure9"
TITLE = "DB23 Fig. 9: approximations of the binomial"
MEANING = ("The gated Gaussian is close to the binomial except when the mean n p is small (TV 0.11 at n = 1000, "
           "p = 0.002), head_cf is close everywhere, and each sampler agrees with its law's exact pmf.")
DEFAULTS = {"samples": 1_000_000, "density": 65536.0}
QUICK = {"samples": 100_000}
NOTEBOOK = "db23_figure9.ipynb"
TABLE = {"db23_figure9": ["law", "n", "p", "tv", "pvalue"]}

# DB23 Figure 9's regimes: small and large n, p small and near 1/2.
FIGURE9_POINTS = [(8, 0.1), (8, 0.5), (1000, 0.002), (1000, 0.5)]
COLORS = ["#d6604d", "#4393c3", "#5aae61", "#9970ab"]  # one per law: at most four laws


def compute(params: dict, ctx: Context) -> Tables:
    # DB23 Fig. 9a: the gated Gaussian inside the distributed binomial (N = 4^8: n = 8 sits mid-level).
    lod = blended_law("distributed", inner="gated").at_density(params["density"])
    rows, panels = figure9_data(laws=("gated", "head_cf", lod), samples=params["samples"], seed=ctx.seed)
    t = pd.DataFrame(rows)
    return Tables({"db23_figure9": t},
                  {"largest TV, gated": float(t[t.law == "gated"].tv.max()),
                   "largest TV, head_cf": float(t[t.law == "head_cf"].tv.max())},
                  data={"panels": panels})


def figures(tables: Tables, ctx: Context) -> list:
    return [ctx.save(figure9_plot(tables["panels"]), "db23_figure9.png", 110)]


def figure9_data(laws=("gated",), points=FIGURE9_POINTS, reference="binomial", samples=10**6, seed=1):
    """(rows, panels): each law's exact pmf against the reference binomial at each (n, p).

    `laws` holds law names or law-like objects with `.pmf(n, p)` and a `.name` (or (label, object)
    pairs): the hook for blended laws, e.g. the distributed binomial of two LOD levels, which draw
    the same way. For laws that can sample, `samples` draws are tested against the law's own pmf
    (chi-square p-value). One row per law and point: exact TV and chi-square p-value; one panel per
    point for :func:`figure9_plot`."""
    entries = [_entry(x) for x in laws][:len(COLORS)]
    ref = get_law(reference) if isinstance(reference, str) else reference
    rows, panels = [], []
    for n, p in points:
        d_ref = ref.pmf(n, p)
        curves = []
        for label, lw in entries:
            d = lw.pmf(n, p)
            tv = distance(d, d_ref, "tv")
            row = {"law": label, "n": n, "p": p, "tv": tv, "pvalue": float("nan")}
            dots = None
            if samples and hasattr(lw, "sample"):
                x = lw.sample(n, p, size=samples, seed=seed)
                row["pvalue"] = chi2_test(x, d).pvalue
                values, counts = np.unique(x, return_counts=True)
                dots = (values, counts / samples)
            rows.append(row)
            curves.append((label, d, tv, dots))
        panels.append({"n": n, "p": p, "reference": (_name(ref), d_ref), "laws": curves})
    return rows, panels


def figure9_plot(panels, axes=None):
    """DB23 Figure 9 idea from :func:`figure9_data`'s panels: the reference's exact pmf (bars), each
    law's (lines) and its samples (dots, the chi-square p-value in the table)."""
    import matplotlib.pyplot as plt

    if axes is None:
        fig, axes = plt.subplots(1, len(panels), figsize=(3.6 * len(panels), 3.2), squeeze=False)
        axes = axes[0]
    else:
        fig = axes[0].figure
    for ax, panel in zip(axes, panels):
        ref_label, d_ref = panel["reference"]
        ax.bar(d_ref.support, d_ref.probs, width=0.9, color="#cccccc", label=f"{ref_label} (exact)")
        for (label, d, tv, dots), color in zip(panel["laws"], COLORS):
            ax.step(d.support, d.probs, where="mid", color=color, lw=1.4, label=f"{label}: TV {tv:.3f}")
            if dots is not None:
                ax.plot(dots[0], dots[1], ".", ms=3, color=color)
        lo, hi = support_window(d_ref)
        ax.set_xlim(lo - 0.8, hi + 0.8)
        ax.set_title(f"n = {panel['n']:g}, p = {panel['p']:g}", fontsize=9)
        ax.set_xlabel("K")
        ax.legend(fontsize=7)
    axes[0].set_ylabel("probability")
    fig.suptitle("DB23 Fig. 9 idea: approximations of the binomial (lines: exact pmfs, dots: samples)",
                 fontsize=9)
    fig.tight_layout()
    return fig


def figure9(laws=("gated",), points=FIGURE9_POINTS, reference="binomial", samples=10**6, seed=1,
            axes=None):
    """(figure, rows): :func:`figure9_data` drawn by :func:`figure9_plot` (the notebooks' one call)."""
    rows, panels = figure9_data(laws, points, reference, samples, seed)
    return figure9_plot(panels, axes), rows


def _entry(x):
    if isinstance(x, tuple):
        return x
    lw = get_law(x) if isinstance(x, str) else x
    return _name(lw), lw


def _name(lw):
    params = getattr(lw, "params", {}) or {}
    return lw.name + "".join(f"[{k}={v}]" for k, v in sorted(params.items()))
