"""Paper figures as functions of the Python API (used by `make run` and the notebooks)."""
from __future__ import annotations

import numpy as np

from .laws import law as get_law
from .metrics import chi2_test, distance

# DB23 Figure 9's regimes: small and large n, p small and near 1/2.
FIGURE9_POINTS = [(8, 0.1), (8, 0.5), (1000, 0.002), (1000, 0.5)]


def figure9(laws=("gated",), points=FIGURE9_POINTS, reference="binomial", samples=10**6, seed=1,
            axes=None):
    """DB23 Figure 9 idea: each law's exact pmf against the reference binomial at each (n, p).

    `laws` holds law names or law-like objects with `.pmf(n, p)` and a `.name` (or (label, object)
    pairs): the hook for blended laws, e.g. the distributed binomial of two LOD levels, which draw
    the same way. For laws that can sample, `samples` draws are overlaid and tested (chi-square
    p-value in the legend), so the figure shows the sampler agrees with the pmf it plots.
    Returns (figure, rows) with one row per law and point: exact TV and chi-square p-value.
    """
    import matplotlib.pyplot as plt

    entries = [_entry(x) for x in laws]
    ref = get_law(reference) if isinstance(reference, str) else reference
    if axes is None:
        fig, axes = plt.subplots(1, len(points), figsize=(3.6 * len(points), 3.2), squeeze=False)
        axes = axes[0]
    else:
        fig = axes[0].figure
    colors = ["#d6604d", "#4393c3", "#5aae61", "#9970ab"]
    rows = []
    for ax, (n, p) in zip(axes, points):
        d_ref = ref.pmf(n, p)
        ax.bar(d_ref.support, d_ref.probs, width=0.9, color="#cccccc", label=f"{_name(ref)} (exact)")
        for (label, lw), color in zip(entries, colors):
            d = lw.pmf(n, p)
            tv = distance(d, d_ref, "tv")
            row = {"law": label, "n": n, "p": p, "tv": tv, "pvalue": float("nan")}
            ax.step(d.support, d.probs, where="mid", color=color, lw=1.4, label=f"{label}: TV {tv:.3f}")
            if samples and hasattr(lw, "sample"):
                x = lw.sample(n, p, size=samples, seed=seed)
                row["pvalue"] = chi2_test(x, d).pvalue
                values, counts = np.unique(x, return_counts=True)
                ax.plot(values, counts / samples, ".", ms=3, color=color)
            rows.append(row)
        lo, hi = _window(d_ref)
        ax.set_xlim(lo - 0.8, hi + 0.8)
        ax.set_title(f"n = {n:g}, p = {p:g}", fontsize=9)
        ax.set_xlabel("K")
        ax.legend(fontsize=7)
    axes[0].set_ylabel("probability")
    fig.suptitle("DB23 Fig. 9 idea: approximations of the binomial (lines: exact pmfs, dots: samples)",
                 fontsize=9)
    fig.tight_layout()
    return fig, rows


def _entry(x):
    if isinstance(x, tuple):
        return x
    lw = get_law(x) if isinstance(x, str) else x
    return _name(lw), lw


def _name(lw):
    params = getattr(lw, "params", {}) or {}
    return lw.name + "".join(f"[{k}={v}]" for k, v in sorted(params.items()))


def _window(d, mass=1e-4):
    """Support range holding all but `mass` of d (for readable axes)."""
    c = np.cumsum(d.probs)
    lo = d.support[np.searchsorted(c, mass / 2)]
    hi = d.support[min(np.searchsorted(c, 1 - mass / 2), len(c) - 1)]
    return lo, hi
