"""WWH18's filterable model against its discrete-flake truth, reading by reading (docs/math/wwh18.md).

Four tables, every model configuration on the same flakes as the truth:

- ``wwh18_readings``: for each reading of the printed text (threshold test printed / flipped, lambda per
  node / per flake / per pixel, P from the table / exact, the error criterion, the filtered model alone,
  the cone around h or around wo), over
  ``pixels`` independent footprints of two kinds (rotated squares that straddle base cells, and squares
  of whole cells): the mean ratio model / truth's exact mean (the bias), the variance ratio, the TV
  distance and the chi-square p-value of the model's counts (rounded) against the truth's exact
  Poisson law, and the same numbers for the truth's own counts as the control row.
- ``wwh18_neighbours``: correlation of the counts of touching footprints (pixels that share base
  cells), the truth's (independent: about 0) beside the model's readings.
- ``wwh18_table``: the directional probability table's relative error against p_gamma(h) by quadrature,
  over random (wi, wo) pairs of the hemisphere, for the accumulation alone and per blur level.
- ``wwh18_filtered``: the filtered model (eq. 10) against T: share of pixels filtered, relative mean
  absolute difference to the truth's count on the same flakes, relative standard deviation kept.
- ``wwh18_tea``: correlation of lambda between adjacent node ids, TEA with 1 to 32 rounds and Philox.
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
from scipy.stats import chi2 as chi2_dist

from ..api.exact import poisson
from ..api.metrics import Distribution, chi2_test
from ..api.wwh18 import LOD_LEVELS, WWH18
from .base import Context, Tables

NAME = "wwh18"
TITLE = "WWH18's filterable model against its discrete-flake truth, reading by reading"
MEANING = ("On the same flakes, WWH18's printed threshold test H(lambda - P) counts the flakes that should not "
           "reflect (mean x (1 - P) / P), its per-node lambda and 4-round TEA inflate the variance; the flipped "
           "test with a per-flake lambda is exact on whole cells and unbiased with fractional overlaps.")
DEFAULTS = {"pixels": 1600, "alpha": 0.3, "gamma": 6.0, "cells_per_side": 4.0, "table_res": 2.0,
            "table_pairs": 200, "filtered_pixels": 1200, "tea_pairs": 50000}
QUICK = {"pixels": 400, "table_pairs": 60, "filtered_pixels": 300, "tea_pairs": 20000}
NOTEBOOK = "wwh18.ipynb"
TABLE = {"wwh18_readings": ["footprints", "reading", "mean_ratio", "var_ratio", "tv", "chi2_p"],
         "wwh18_neighbours": ["reading", "corr_neighbours"],
         "wwh18_table": ["what", "lod_deg", "rel_err_median", "rel_err_p90", "abs_err_over_mean"],
         "wwh18_filtered": ["T", "filtered_share", "rel_abs_diff", "kept_rel_sd"],
         "wwh18_tea": ["generator", "corr_adjacent", "chi2_pairs_p"]}

S0 = 1.0 / 64  # base cell side: a power of two, so whole-cell footprints are exact in binary
H = np.array([0.15, -0.05, 1.0])

# (label, options) of the model, each approximation on its own, then as printed; "truth" is the control
# row. Philox draws lambda unless the row is about TEA (4-round TEA correlates neighbouring ids).
_EXACT = dict(threshold_test="flipped", lambda_seeding="flake", dpf="exact", rng="philox")
READINGS = [
    ("traversal alone: H(P - lambda), lambda per flake, exact P", _EXACT),
    ("+ error criterion: nodes up to 0.25 |A| fractional", {**_EXACT, "error_eps": 0.25}),
    ("+ P from the table (Table 2 level)", {**_EXACT, "dpf": "table"}),
    ("+ 4-round TEA for lambda", {**_EXACT, "dpf": "table", "rng": "tea"}),
    ("lambda per node (printed), exact P", {**_EXACT, "lambda_seeding": "node"}),
    ("H(lambda - P) (printed), exact P", {**_EXACT, "threshold_test": "printed"}),
    ("as printed: H(lambda - P), lambda per node, table, TEA",
     dict(threshold_test="printed", lambda_seeding="node", dpf="table", rng="tea")),
    ("filtered model everywhere (T -> 0), exact P", {**_EXACT, "T": 1e-12}),
    ("filtered model everywhere (T -> 0), table P", {**_EXACT, "T": 1e-12, "dpf": "table"}),
    # The readings issue 37 added: eq. 8's lambda(x) as one lambda per pixel; Sec. 4.1's cone around the
    # outgoing direction (with wi = h: the cone of half-angle gamma / 2 around h), against the truth of
    # the half-vector cone (docs/math/wwh18.md#wwh18-lambda, #wwh18-cone).
    ("lambda per pixel (eq. 8's lambda(x)), exact P", {**_EXACT, "lambda_seeding": "pixel"}),
    ("cone around wo (Sec. 4.1), wi = h, exact P", {**_EXACT, "cone": "outgoing"}),
]


def _grid(rows, side_cells, offset, angle, spacing=None):
    spacing = spacing or (int(side_cells * 1.5) + 4)
    g = np.arange(rows) * spacing * S0
    u, v = np.meshgrid(g, g, indexing="ij")
    uv = np.stack([u.ravel() + offset[0] * S0, v.ravel() + offset[1] * S0], -1)
    a = side_cells * S0
    c, s = math.cos(angle), math.sin(angle)
    return uv, np.tile([a * c, a * s, -a * s, a * c], (len(uv), 1))


def _compare(counts, mu):
    """Mean ratio, variance ratio, TV and chi-square p of counts (rounded half up) against Poisson(mu)."""
    k = np.floor(np.asarray(counts) + 0.5)
    top = int(max(k.max(), mu + 15 * math.sqrt(mu) + 30)) + 1
    support = np.arange(top)
    pmf = poisson.pmf(support, mu)
    hist = np.bincount(k.astype(np.int64), minlength=top)[:top] / len(k)
    tv = 0.5 * float(np.abs(hist - pmf).sum())
    dist = Distribution(support.astype(float), pmf, True)
    p = float(chi2_test(k, dist).pvalue)
    return float(np.mean(counts) / mu), float(np.var(counts, ddof=1) / mu), tv, p


def _model_row(footprints, reading, mu, counts):
    """One row of ``wwh18_readings``: the counts against the truth's exact Poisson law of mean mu."""
    return {"footprints": footprints, "reading": reading, "mean": mu,
            **dict(zip(("mean_ratio", "var_ratio", "tv", "chi2_p"), _compare(counts, mu)))}


def _readings_table(kinds, common, truth_model, seed, ctx):
    """``wwh18_readings``: the truth's own counts (the control row), then every reading, per kind of
    footprint, all on the same flakes."""
    rows_out = []
    for kind, (uv, J) in kinds.items():
        h = np.tile(H, (len(uv), 1))
        mu = float(truth_model.expected_count(J[:1], h[:1])[0])
        ctx.progress(f"wwh18 readings: {kind}")
        ref = truth_model.reference_counts(uv, J, h, seed=seed)
        rows_out.append(_model_row(kind, "truth (control)", mu, ref))
        for label, opts in READINGS:
            w = WWH18(**{**common, **opts})
            rows_out.append(_model_row(kind, label, mu, w.counts(uv, J, h, seed=seed)))
    return pd.DataFrame(rows_out)


def _neighbours_table(pixels, common, truth_model, seed, ctx):
    """``wwh18_neighbours``: footprints tiling the plane (rows of touching squares, 2.5 cells a side, so
    base cells straddle two pixels). The truth's counts of disjoint footprints are independent (a
    Poisson process); the model shares a straddling cell's passing flakes between its pixels."""
    ctx.progress("wwh18 neighbours")
    tside, trows = 2.5, max(8, int(math.isqrt(pixels)))
    g = (np.arange(trows) * tside + 0.3) * S0
    u, v = np.meshgrid(g, (np.arange(trows) * 3 * tside + 0.6) * S0, indexing="ij")  # rows apart in v
    tuv = np.stack([u.ravel(), v.ravel()], -1)
    tJ = np.tile([tside * S0, 0.0, 0.0, tside * S0], (len(tuv), 1))
    th = np.tile(H, (len(tuv), 1))

    def neighbour_corr(c):
        c = c.reshape(trows, trows)  # [x, y]: x neighbours touch
        return float(np.corrcoef(c[:-1].ravel(), c[1:].ravel())[0, 1])

    neighbours = [{"reading": "truth (control)", "corr_neighbours": neighbour_corr(
        truth_model.reference_counts(tuv, tJ, th, seed=seed))}]
    for label, opts in READINGS[:1] + READINGS[3:5] + READINGS[6:7]:
        w = WWH18(**{**common, **opts})
        neighbours.append({"reading": label, "corr_neighbours": neighbour_corr(w.counts(tuv, tJ, th, seed=seed))})
    return pd.DataFrame(neighbours)


def _hemisphere_directions(rng, size):
    """Random directions of the upper hemisphere, theta uniform up to 80 degrees."""
    t = np.radians(rng.uniform(0, 80, size))
    f = rng.uniform(0, 2 * np.pi, size)
    return np.stack([np.sin(t) * np.cos(f), np.sin(t) * np.sin(f), np.cos(t)], -1)


def _table_error_row(what, lod, est, exact, keep):
    """One row of ``wwh18_table``: the relative error of est against exact where exact is not negligible."""
    rel = np.abs(est[keep] / exact[keep] - 1)
    return {"what": what, "lod_deg": lod, "rel_err_median": float(np.median(rel)),
            "rel_err_p90": float(np.quantile(rel, 0.9)),
            "abs_err_over_mean": float(np.mean(np.abs(est[keep] - exact[keep])) / np.mean(exact[keep]))}


def _table_table(params, density, truth_model, rng, ctx):
    """``wwh18_table``: the directional probability table against quadrature over random (wi, wo) pairs,
    the accumulation alone, then the table per blur level."""
    ctx.progress("wwh18 table")
    alpha, gamma, table_res = float(params["alpha"]), float(params["gamma"]), float(params["table_res"])
    n = int(params["table_pairs"])
    wi, wo = _hemisphere_directions(rng, n), _hemisphere_directions(rng, n)
    hv = wi + wo
    hv /= np.linalg.norm(hv, axis=-1, keepdims=True)
    exact = truth_model.cone_mass(hv)
    keep = exact > 1e-6 * exact.max()
    table_rows = []
    for res in (1.0, table_res):
        acc = WWH18(density=density, alpha=alpha, gamma=gamma, dpf="exact", table_res=res)
        table_rows.append(_table_error_row(f"accumulation alone, {res:g} deg cells", 0.0, acc.accumulated(hv),
                                           exact, keep))
    for lod in (0.0,) + tuple(LOD_LEVELS):
        ctx.progress(f"wwh18 table level {lod:g}")
        t = WWH18(density=density, alpha=alpha, gamma=gamma, dpf="table", table_res=table_res,
                  lod=lod if lod > 0 else "none")
        table_rows.append(_table_error_row(
            f"table {params['table_res']:g} deg, " + ("no blur" if lod == 0 else f"blur {lod:g} deg"), lod,
            t.dpf(wi, wo), exact, keep))
    return pd.DataFrame(table_rows)


def _filtered_table(params, density, truth_model, P, rng, seed, ctx):
    """``wwh18_filtered``: the filtered model against T, on footprints of mean counts log-uniform in
    [0.5, 500]."""
    ctx.progress("wwh18 filtered")
    alpha, gamma = float(params["alpha"]), float(params["gamma"])
    m = int(params["filtered_pixels"])
    means = np.exp(rng.uniform(math.log(0.5), math.log(500.0), m))
    sides = np.sqrt(means / (density * P))
    spacing = 2 * sides.max() + 8 * S0
    idx = np.arange(m)
    uv = np.stack([(idx % 64) * spacing + 0.3 * S0, (idx // 64) * spacing + 0.7 * S0], -1)
    J = np.stack([sides, np.zeros(m), np.zeros(m), sides], -1)
    h = np.tile(H, (m, 1))
    ref = truth_model.reference_counts(uv, J, h, seed=seed)
    filt_rows = []
    for T in (math.inf, 64.0, 32.0, 16.0, 8.0, 4.0, 2.0, 1.0):
        w = WWH18(density=density, alpha=alpha, gamma=gamma, **{**_EXACT, "T": T})
        d = w.counts_detail(uv, J, h, seed=seed)
        filtered = d["mode"] == 2
        # kept spread: the model's count sd relative to the truth's among pixels of similar mean
        # (standardised residuals (K - mu) / sqrt(mu) pooled).
        mu = means
        kept = float(np.std((d["count"] - mu) / np.sqrt(mu)) / np.std((ref - mu) / np.sqrt(mu)))
        filt_rows.append({"T": T, "filtered_share": float(filtered.mean()),
                          "rel_abs_diff": float(np.mean(np.abs(d["count"] - ref)) / np.mean(ref)),
                          "kept_rel_sd": kept})
    return pd.DataFrame(filt_rows)


def _tea_table(params, density, seed, ctx):
    """``wwh18_tea``: TEA's lambda for adjacent node ids (i, j), (i + 1, j), by rounds, beside Philox."""
    ctx.progress("wwh18 tea")
    alpha, gamma = float(params["alpha"]), float(params["gamma"])
    q = int(params["tea_pairs"])
    i = np.arange(q, dtype=np.int64)
    j = np.full(q, 12345, dtype=np.int64)
    tea_rows = []
    for label, opts in [(f"tea {r} rounds", dict(rng="tea", tea_rounds=r)) for r in (1, 2, 4, 8, 16, 32)] + \
                       [("philox4x32-10", dict(rng="philox"))]:
        lam = WWH18(density=density, alpha=alpha, gamma=gamma, dpf="exact", **opts).lambdas(seed, 0, i, j)
        a, b = lam[:-1], lam[1:]
        grid = np.histogram2d(a, b, bins=16, range=[[0, 1], [0, 1]])[0].ravel()
        expected = len(a) / 256
        stat = float(((grid - expected) ** 2 / expected).sum())
        tea_rows.append({"generator": label, "corr_adjacent": float(np.corrcoef(a, b)[0, 1]),
                         "chi2_pairs_p": float(chi2_dist.sf(stat, 255))})
    return pd.DataFrame(tea_rows)


def _headline_stats(readings, neighbours, P, pixels_per_row):
    """The numbers shown under the section title."""
    printed = readings[(readings.footprints == "straddling") & (readings.reading == READINGS[6][0])].iloc[0]
    flipped = readings[(readings.footprints == "whole cells") & (readings.reading == READINGS[0][0])].iloc[0]
    stats = {"P (exact cone mass at h)": P, "mean flakes-in-cone per pixel (straddling)": float(readings.iloc[0]["mean"]),
             "as printed: mean ratio (straddling)": float(printed.mean_ratio),
             "as printed: variance ratio (straddling)": float(printed.var_ratio),
             "flipped, per flake, exact P: chi2 p on whole cells": float(flipped.chi2_p),
             "pixels per row": pixels_per_row}
    stats["neighbour correlation, truth / as printed"] = (
        f"{neighbours.corr_neighbours.iloc[0]:.3f} / {neighbours.corr_neighbours.iloc[-1]:.3f}")
    return stats


def compute(params: dict, ctx: Context) -> Tables:
    pixels = int(params["pixels"])
    rows = max(2, int(math.isqrt(pixels)))
    alpha, gamma, side = float(params["alpha"]), float(params["gamma"]), float(params["cells_per_side"])
    density = 4.0 / S0**2
    common = dict(density=density, alpha=alpha, gamma=gamma, T=math.inf, table_res=float(params["table_res"]))
    seed = ctx.seed
    kinds = {
        # Rotated squares straddling cells (fractional overlaps), and squares of whole cells.
        "straddling": _grid(rows, side * 1.1, (0.37, 0.81), 0.4),
        "whole cells": _grid(rows, side, (side / 2, side / 2), 0.0),
    }
    truth_model = WWH18(**common, dpf="exact")
    readings = _readings_table(kinds, common, truth_model, seed, ctx)
    neighbours = _neighbours_table(pixels, common, truth_model, seed, ctx)
    # One generator, in this order: the table's (wi, wo) pairs, then the filtered rows' mean counts.
    rng = np.random.default_rng(seed)
    table = _table_table(params, density, truth_model, rng, ctx)
    P = float(truth_model.cone_mass(H))
    filt = _filtered_table(params, density, truth_model, P, rng, seed, ctx)
    tea = _tea_table(params, density, seed, ctx)
    stats = _headline_stats(readings, neighbours, P, len(kinds["straddling"][0]))
    return Tables({"wwh18_readings": readings, "wwh18_neighbours": neighbours, "wwh18_table": table,
                   "wwh18_filtered": filt, "wwh18_tea": tea}, stats)


def figures(tables: Tables, ctx: Context) -> list:
    import matplotlib.pyplot as plt

    r = tables["wwh18_readings"]
    fig, axes = plt.subplots(1, 3, figsize=(12, 4.2))
    ax = axes[0]
    for k, (kind, marker) in enumerate((("straddling", "o"), ("whole cells", "s"))):
        sub = r[r.footprints == kind]
        y = np.arange(len(sub)) + 0.15 * k
        ax.scatter(sub.mean_ratio, y, marker=marker, label=f"mean ratio, {kind}")
        ax.scatter(sub.var_ratio, y, marker=marker, facecolors="none", edgecolors="C3", label=f"variance ratio, {kind}")
        if k == 0:
            ax.set_yticks(np.arange(len(sub)))
            ax.set_yticklabels([s[:38] for s in sub.reading], fontsize=6)
    ax.axvline(1, color="grey", lw=0.8)
    ax.set_xscale("log")
    ax.set_xlabel("model / truth's exact Poisson law")
    ax.legend(fontsize=6)
    ax.set_title("readings of eq. 8 and Algorithm 1", fontsize=8)
    t = tables["wwh18_table"]
    ax = axes[1]
    lv = t[t.lod_deg >= 0]
    ax.semilogy(np.arange(len(lv)), lv.rel_err_median, "o-", label="median relative error")
    ax.semilogy(np.arange(len(lv)), lv.rel_err_p90, "s--", label="90th percentile")
    ax.set_xticks(np.arange(len(lv)))
    ax.set_xticklabels([w.replace("accumulation alone, ", "acc ").replace("table ", "").replace(" deg", "")[:14]
                        for w in lv.what], rotation=60, fontsize=6)
    ax.set_title("table P against p_gamma(h) by quadrature", fontsize=8)
    ax.legend(fontsize=6)
    f = tables["wwh18_filtered"]
    ax = axes[2]
    ff = f[np.isfinite(f["T"])]
    ax.semilogx(ff["T"], ff.rel_abs_diff, "o-", label="E|model - truth| / E truth")
    ax.semilogx(ff["T"], ff.kept_rel_sd, "s-", label="spread kept (sd ratio)")
    ax.semilogx(ff["T"], ff.filtered_share, "^-", label="share filtered")
    ax.axhline(float(f[~np.isfinite(f["T"])].rel_abs_diff.iloc[0]), color="grey", ls=":", lw=0.8,
               label="never filtered")
    ax.axvline(16, color="grey", lw=0.8)
    ax.set_xlabel("threshold T")
    ax.legend(fontsize=6)
    ax.set_title("the filtered model (eq. 10) against T", fontsize=8)
    fig.tight_layout()
    return [ctx.save(fig, "wwh18.png")]
