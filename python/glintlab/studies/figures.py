"""Paper figures as functions of the Python API (used by `make run` and the notebooks)."""
from __future__ import annotations

import math

import numpy as np

from ..api.laws import law as get_law
from ..api.metrics import chi2_test, distance

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
        lo, hi = _window(truth, 1e-5)
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


def coherence_figure(zoom_K, pan_K, zoom_table, pan_table, examples: int = 3):
    """Counts along a few zoom and pan paths per law (same paths and seeds for every law), and the
    coherence metrics of ``lod.zoom_study`` / ``lod.pan_study``."""
    import matplotlib.pyplot as plt

    labels = [key for key in zoom_K if key[1] in ("-", "binomial")]
    fig, axes = plt.subplots(2, len(labels), figsize=(2.6 * len(labels), 5.2), sharey="row", squeeze=False)
    for row, (K_by, table, kind) in enumerate(((zoom_K, zoom_table, "zoom"), (pan_K, pan_table, "pan"))):
        for col, key in enumerate(labels):
            ax = axes[row, col]
            K = K_by[key]
            for j in range(min(examples, K.shape[0])):
                ax.plot(K[j], lw=1.0)
            m = table[(table.law == key[0]) & (table.inner == key[1])].iloc[0]
            ax.set_title(f"{kind}: {key[0]}\n|dK| {m.mean_abs_step:.2f}, pops {m.pop_rate:.3f}, "
                         f"r1 {m.corr_lag1:.2f}", fontsize=7)
            ax.set_xlabel("step", fontsize=7)
            ax.tick_params(labelsize=7)
        axes[row, 0].set_ylabel("K")
    fig.suptitle("Coherence along a zoom (A_lo to A_hi) and a pan (1/16 footprint per step): same paths, "
                 "same seeds; ground truth counted on one facet realization per path", fontsize=8)
    fig.tight_layout()
    return fig


def strip_figure(images, exponents, vmax: float = 4.0):
    """The receding-plane strip of ``lod.strip_images``: intensity K / (N P p) per pixel per law."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(images), 1, figsize=(9, 1.05 * len(images) + 0.6), squeeze=False)
    for ax, (label, img) in zip(axes[:, 0], images.items()):
        ax.imshow(np.sqrt(np.clip(img, 0, vmax) / vmax), cmap="magma", vmin=0, vmax=1, aspect="auto",
                  interpolation="nearest")
        ax.set_ylabel(label, rotation=0, ha="right", va="center", fontsize=8)
        ax.set_yticks([])
        edges = np.searchsorted(exponents, [0.0, 0.5, 1.0])
        ax.set_xticks(edges)
        ax.set_xticklabels(["A_lo", "w=1/2", "A_hi"], fontsize=7)
        for x in edges:
            ax.axvline(x, color="white", lw=0.4, alpha=0.5)
    fig.suptitle("A plane receding across one LOD transition (left: level lo, right: level hi); "
                 "pixel intensity K / (N P p), sqrt scale", fontsize=9)
    fig.tight_layout()
    return fig


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
