"""float32 against float64: where a shader's single precision changes a law, and where it breaks.

Both precisions evaluate the law on the *same* uniforms (those `sample` uses), which couples the two
outputs. The coupling gives a rigorous bound: TV(law_f32, law_f64) <= P(K_f32 != K_f64), and the
mismatch rate estimates that probability (with a Clopper-Pearson 95% upper bound), free of the
upward bias of a TV between two histograms. Breaks are counted per precision: non-finite K,
K < 0, and K > ceil(n) (a count above the facets there are).

`one_minus_p_pow_n` tabulates the other float32 trap of the numerical extremes
(docs/math/extremes.md#extremes-pow): (1 - p)^n computed directly
(pow(1 - p, n), what the public shaders do) versus exp(n log1p(-p)), against an mpmath reference.

The report's float32 section runs both for the laws of the speed/accuracy trade.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from scipy.stats import beta

from ..api.laws import law as get_law, law_variants, uniforms
from ..validation.grid import standard_grid
from .base import Context, Tables
from .speed_accuracy import grid_maps
from ..api import checks as V

NAME = "float32"
TITLE = "float32 against float64, and (1 - p)^n four ways"
MEANING = ("float32 evaluation agrees with float64 over most of the grid and breaks in identifiable corners; "
           "the gate probability 1 - (1 - p)^n is lost by pow in float32, not by exp(n log1p(-p)).")
DEFAULTS = {"samples": 1024}
QUICK = {"samples": 256}
NOTEBOOK = "speed_accuracy.ipynb"
TABLE = {"float32_vs_float64": ["law", "mismatch_max", "at_n", "at_p", "points_broken_f32"]}


def compute(params: dict, ctx: Context) -> Tables:
    samples = params["samples"]
    laws = [get_law(name, **prm) for name, prm in law_variants("study", reference=False)]
    table = float32_table(laws, samples=samples, seed=ctx.seed)
    summary = float32_summary(table)
    return Tables({"float32_vs_float64": summary, "one_minus_p_pow_n": one_minus_p_pow_n()},
                  {"largest float32 mismatch": float(summary.mismatch_max.max())},
                  extra={"float32_vs_float64_standard_grid": table}, data={"samples": samples})


def figures(tables: Tables, ctx: Context) -> list:
    import matplotlib.pyplot as plt
    samples, summary = tables["samples"], tables["float32_vs_float64"]
    paths = [grid_maps(Path(ctx.out) / "float32_mismatch_maps.png", tables["float32_vs_float64_standard_grid"],
                       list(summary.law), "mismatch", 1.0 / samples / 2, "viridis", "P(K_f32 != K_f64) >= TV",
                       f"float32 vs float64 on the same uniforms ({samples} draws per point): n (x) by p (y)")]
    pow_table = tables["one_minus_p_pow_n"]
    fig, ax = plt.subplots(figsize=(6.4, 3.8))
    styles = {("float32", "pow(1-p, n)"): "-", ("float32", "exp(n log1p(-p))"): "--",
              ("float64", "pow(1-p, n)"): ":", ("float64", "exp(n log1p(-p))"): "-."}
    for (prec, method), g in pow_table[pow_table.n == 1e3].groupby(["precision", "method"]):
        ax.loglog(g.p, np.maximum(g.p1_rel_err, 1e-17), styles[(prec, method)], label=f"{prec} {method}")
    ax.set_xlabel("p (n = 1000)")
    ax.set_ylabel("relative error of P1 = 1 - (1-p)^n")
    ax.set_title("The gate probability, four ways (reference: mpmath)", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    paths.append(ctx.save(fig, "one_minus_p_pow_n.png", 110))
    return paths


def float32_table(laws, n=None, p=None, samples: int = 1024, seed: int = 1) -> pd.DataFrame:
    """One row per law and grid point (default: the standard grid): law, n, p, mismatch (share of
    draws whose binned K differs between float32 and float64), mismatch_upper95, max_abs_diff (largest
    |K_f32 - K_f64| before binning), mean_f32 and
    mean_f64 (sample means), and per precision the shares of non-finite, negative and above-n K."""
    V.integer("float32_table: samples", samples, minimum=1)
    if n is None or p is None:
        gn, gp = standard_grid()
        n = gn if n is None else np.atleast_1d(np.asarray(n, dtype=float))
        p = gp if p is None else np.atleast_1d(np.asarray(p, dtype=float))
    laws = [get_law(x) if isinstance(x, str) else x for x in laws]
    nn, pp = (a.ravel() for a in np.meshgrid(n, p, indexing="ij"))
    rows = []
    for lw in laws:
        if "float32" not in lw.precisions:
            continue
        u = uniforms(samples, lw.n_uniforms, seed=seed)
        # Every grid point sees the same uniforms: rows grid-major, samples inner.
        big_n, big_p = np.repeat(nn, samples), np.repeat(pp, samples)
        big_u = np.tile(u, (nn.size, 1))
        k64 = lw.evaluate(big_n, big_p, big_u).reshape(nn.size, samples)
        k32 = lw.evaluate(big_n, big_p, big_u, precision="float32").reshape(nn.size, samples)
        top = np.ceil(nn)[:, None]
        with np.errstate(invalid="ignore"):
            b64, b32 = _bin(lw, k64), _bin(lw, k32)
            mismatch = np.mean(b64 != b32, axis=1)
            diff = np.where(np.isfinite(k32) & np.isfinite(k64), np.abs(k32 - k64), np.inf)
            max_diff = np.max(diff, axis=1)
        hits = np.rint(mismatch * samples)
        upper = np.where(hits >= samples, 1.0, beta.ppf(0.95, hits + 1, samples - hits))
        for prec, k in (("f32", k32), ("f64", k64)):
            finite = np.isfinite(k)
            rows_prec = dict(nonfinite=np.mean(~finite, axis=1),
                             negative=np.mean(finite & (k < 0), axis=1),
                             above_n=np.mean(finite & (k > top), axis=1),
                             mean=np.where(finite.all(axis=1), np.mean(np.where(finite, k, 0), axis=1), np.nan))
            if prec == "f32":
                f32 = rows_prec
            else:
                f64 = rows_prec
        label = lw.label
        for i in range(nn.size):
            rows.append(dict(law=label, n=nn[i], p=pp[i], mismatch=mismatch[i], mismatch_upper95=upper[i],
                             max_abs_diff=max_diff[i],
                             mean_f32=f32["mean"][i], mean_f64=f64["mean"][i],
                             nonfinite_f32=f32["nonfinite"][i], negative_f32=f32["negative"][i],
                             above_n_f32=f32["above_n"][i], nonfinite_f64=f64["nonfinite"][i],
                             negative_f64=f64["negative"][i], above_n_f64=f64["above_n"][i]))
    return pd.DataFrame(rows)


def _bin(lw, k):
    return np.floor(k + 0.5) if lw.binning == "round" else k


def float32_summary(table: pd.DataFrame) -> pd.DataFrame:
    """Per law: worst and median mismatch, the share of grid points where float32 changes more than
    1% of the draws, the (n, p) of the worst point, and the grid points with breaks per precision."""
    out = []
    for name, g in table.groupby("law", sort=False):
        worst = g.loc[g.mismatch.idxmax()]
        broken = lambda s: int(((g[f"nonfinite_{s}"] + g[f"negative_{s}"] + g[f"above_n_{s}"]) > 0).sum())
        out.append(dict(law=name, mismatch_max=worst.mismatch, at_n=worst.n, at_p=worst.p,
                        max_abs_diff=g.max_abs_diff.max(),
                        mismatch_median=g.mismatch.median(), share_points_over_1pct=float((g.mismatch > 0.01).mean()),
                        points_broken_f32=broken("f32"), points_broken_f64=broken("f64")))
    return pd.DataFrame(out)


def one_minus_p_pow_n(n_values=(16, 1e3, 1e6), p_values=None) -> pd.DataFrame:
    """Relative error of q = (1 - p)^n and of P1 = 1 - q, four ways: pow(1 - p, n) and
    exp(n log1p(-p)) (P1 as -expm1(n log1p(-p))), each in float32 and float64, against mpmath."""
    import mpmath
    if p_values is None:
        p_values = np.logspace(-9, -1, 17)
    rows = []
    for n in n_values:
        for p in p_values:
            with mpmath.workdps(40):
                q_ref = mpmath.power(1 - mpmath.mpf(float(p)), mpmath.mpf(float(n)))
                q_ref, p1_ref = float(q_ref), float(1 - q_ref)
            for dtype in (np.float32, np.float64):
                nf, pf = dtype(n), dtype(p)
                with np.errstate(all="ignore"):
                    q_direct = np.power(dtype(1) - pf, nf)
                    lg = nf * np.log1p(-pf)
                    q_log = np.exp(lg)
                    p1_log = -np.expm1(lg)
                for method, q, p1 in (("pow(1-p, n)", q_direct, dtype(1) - q_direct),
                                      ("exp(n log1p(-p))", q_log, p1_log)):
                    rows.append(dict(n=n, p=p, precision=np.dtype(dtype).name, method=method,
                                     q_rel_err=abs(float(q) - q_ref) / q_ref if q_ref else abs(float(q)),
                                     p1_rel_err=abs(float(p1) - p1_ref) / p1_ref if p1_ref else abs(float(p1))))
    return pd.DataFrame(rows)
