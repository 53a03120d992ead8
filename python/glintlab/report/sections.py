"""The `make run` report: what glintlab knows of glint counting laws, as a page of figures.

The report is a list of *sections* (one figure family each), configured by a JSON document
(``glintlab/data/report/default.json``, schema ``glintlab/data/schema/report.schema.json``): each section has its
parameters and, for ``--quick``, overrides. A section writes its figures (PNG) and tables (CSV) into the
output directory and a record ``sections/NAME.json`` (title, meaning, parameters, seed, seconds,
headline numbers, the command that regenerates it alone); ``index.html`` is assembled from the records
present, so ``glintlab report --only NAME`` re-runs one section and rebuilds the page.

Sections (in the default order): exact laws and samplers, DB23 Fig. 9, DB23 Fig. 4, the ghosting strip
(DB23 Fig. 2), roulette vs linear blending (KPT25 Fig. 6), coherence along camera paths, WWH18's
threshold trade (Fig. 15), convergence to the target NDF (DB23 Fig. 13), the speed/accuracy trade
(Pareto plot, error maps), float32, anisotropic grids, scene profiles (DB23 Table 1), numerical
extremes and the error-bounds check.
"""
from __future__ import annotations

import html
import json
import math
import platform
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import pandas as pd

from .._core import __version__
from ..api import checks as V
from ..validation.bench import DEFAULT_LAWS as TRADE_LAWS  # the speed/accuracy trade: the laws of glintlab bench
from ..api.exact import binomial as binom_fn
from ..api.laws import law
from ..api.metrics import METRICS, chi2_test, distance

from ..resources import data_path

DEFAULT_CONFIG = data_path("report", "default.json")
SCHEMA = data_path("schema", "report.schema.json")

EXACT_POINTS = [(16, 0.1), (1e3, 1e-2), (1e6, 0.3), (1e9, 1e-6), (1e15, 1e-13), (1e12, 1 - 1e-7),
                (10.5, 0.3), (0.25, 0.8), (1e6, 1e-300)]
SAMPLER_POINTS = [(16, 0.1), (1e3, 1e-2), (1e6, 0.3), (1e9, 1e-6), (60, 0.9), (10.5, 0.3)]
# A sampler check fails below this p-value (Sidak-style: about 1e-3 false alarms per report run).
SAMPLER_ALPHA = 1e-4


# ---------------------------------------------------------------------------------------------------
# Sections


@dataclass
class Context:
    """What a section sees: where to write, the seed, quick mode, and a progress callback."""
    out: Path
    seed: int
    quick: bool
    progress: Callable[[str], None] = lambda label: None
    base: Path = Path(".")  # relative paths in a configuration are relative to its file's folder

    def path(self, value) -> Path:
        path = Path(value)
        return path if path.is_absolute() else self.base / path

    def save(self, fig, name: str, dpi: int = 100) -> Path:
        import matplotlib.pyplot as plt
        path = self.out / name
        fig.savefig(path, dpi=dpi)
        plt.close(fig)
        return path


@dataclass
class Result:
    figures: list = field(default_factory=list)
    tables: dict = field(default_factory=dict)
    stats: dict = field(default_factory=dict)     # headline numbers shown under the title
    failures: list = field(default_factory=list)  # checks that failed (exit status 1)


@dataclass
class Section:
    name: str
    title: str
    meaning: str  # one sentence: what the figure says
    defaults: dict
    run: Callable[[Context, dict], Result]
    notebook: str = ""
    show: dict = field(default_factory=dict)  # table -> columns printed on the terminal

    @property
    def short(self) -> str:
        """The title up to its first colon or parenthesis (figure captions, the thumbnail)."""
        return self.title.split(":")[0].split(" (")[0].split(",")[0]


SECTIONS: dict[str, Section] = {}


def section(name, title, meaning, defaults, notebook="", show=None):
    def register(fn):
        SECTIONS[name] = Section(name, title, meaning, dict(defaults), fn, notebook, show or {})
        return fn
    return register


def _rel(a, b):
    return abs(a - b) / abs(b) if b else abs(a - b)


@section("exact_laws", "Exact laws and their samplers",
         "The binomial and Poisson samplers reproduce their exact laws (chi-square p-values), and the uniform "
         "and Poisson facet layouts differ visibly only when p is not small.",
         {"samples": 1_000_000}, "exact_laws.ipynb",
         {"sampler_checks": ["law", "n", "p", "pvalue", "tv_hist", "ns_per_sample"]})
def _exact_laws(ctx: Context, prm: dict) -> Result:
    import matplotlib.pyplot as plt
    samples, seed = prm["samples"], ctx.seed
    rows = []
    b = law("binomial")
    for n, p in EXACT_POINTS:
        m = math.floor(n)
        g = (n - m) * p
        var = m * p * (1 - p) + g * (1 - g)
        row = dict(n=n, p=p, mean_formula=n * p, var_formula=var)
        try:
            d = b.pmf(n, p)
            row.update(support=len(d), k_min=d.support[0], k_max=d.support[-1], mass=d.probs.sum(),
                       mean_rel_err=_rel(d.mean, n * p), var_rel_err=_rel(d.var, var))
        except ValueError:  # support too large to list: tails still exact
            row.update(support=float("nan"))
        row["P(K=0)"] = float(binom_fn.pmf(0, n, p))
        row["P(K>mean+5sd)"] = float(binom_fn.sf(math.floor(n * p + 5 * math.sqrt(var)), n, p))
        rows.append(row)
    exact = pd.DataFrame(rows)
    rows = []
    for name in ("binomial", "poisson"):
        lw = law(name)
        for n, p in SAMPLER_POINTS:
            ctx.progress(f"sampling {name} n={n:g} p={p:g}")
            t0 = time.perf_counter()
            x = lw.sample(n, p, size=samples, seed=seed)
            dt = time.perf_counter() - t0
            d = lw.pmf(n, p)
            r = chi2_test(x, d)
            rows.append(dict(law=name, n=n, p=p, samples=samples, seed=seed, chi2=r.statistic, dof=r.dof,
                             pvalue=r.pvalue, tv_hist=distance(x, d, "tv"),
                             mean_rel_err=_rel(x.mean(), d.mean), ns_per_sample=dt / samples * 1e9))
    checks = pd.DataFrame(rows)
    rows = []
    po = law("poisson")
    for n in (10, 100, 1e4, 1e6):
        for p in (1e-3, 1e-2, 0.1, 0.3, 0.5, 0.9):
            if n * p < 0.05:
                continue
            db, dp = b.pmf(n, p), po.pmf(n, p)
            row = dict(n=n, p=p, mean=n * p)
            row.update({m: distance(db, dp, m) for m in METRICS})
            rows.append(row)
    layouts = pd.DataFrame(rows)

    res = Result(tables={"exact_laws": exact, "sampler_checks": checks, "binomial_vs_poisson": layouts})
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.4))
    for ax, (n, p) in zip(axes, [(16, 0.1), (1e3, 1e-2), (10.5, 0.3)]):
        d = b.pmf(n, p)
        x = b.sample(n, p, size=samples, seed=seed)
        emp = pd.Series(x).value_counts(normalize=True).sort_index()
        ax.bar(d.support, d.probs, width=0.8, color="#9ecae1", label="exact pmf")
        ax.plot(emp.index, emp.values, "o", ms=3.5, color="#08519c", label=f"{samples:.0e} samples")
        ax.set_title(f"Binomial(n={n:g}, p={p:g})\nchi-square p = {chi2_test(x, d).pvalue:.3f}", fontsize=9)
        ax.set_xlabel("K")
    axes[0].set_ylabel("probability")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    res.figures.append(ctx.save(fig, "sampler_vs_exact.png", 110))
    fig, ax = plt.subplots(figsize=(6, 3.6))
    ps = np.logspace(-4, math.log10(0.95), 40)
    for n in (10, 100, 1e4, 1e6):
        ax.loglog(ps, [distance(b.pmf(n, p), po.pmf(n, p), "tv") for p in ps], label=f"n = {n:g}")
    ax.set_xlabel("p")
    ax.set_ylabel("TV(Binomial(n, p), Poisson(np))")
    ax.set_title("Uniform vs Poisson facet layouts: exact TV", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    res.figures.append(ctx.save(fig, "binomial_vs_poisson_tv.png", 110))
    res.stats = {"sampler checks": len(checks), "smallest p-value": float(checks.pvalue.min()),
                 "largest support relative mean error": float(exact.mean_rel_err.max())}
    res.failures = [f"{r.law} at n = {r.n:g}, p = {r.p:g}: chi-square p = {r.pvalue:.2g} < {SAMPLER_ALPHA:g}"
                    for r in checks.itertuples() if r.pvalue < SAMPLER_ALPHA]
    return res


@section("db23_figure9", "DB23 Fig. 9: approximations of the binomial",
         "The gated Gaussian is close to the binomial except when the mean n p is small (TV 0.11 at n = 1000, "
         "p = 0.002), head_cf is close everywhere, and each sampler agrees with its law's exact pmf.",
         {"samples": 1_000_000, "density": 65536.0}, "db23_figure9.ipynb",
         {"db23_figure9": ["law", "n", "p", "tv", "pvalue"]})
def _figure9(ctx: Context, prm: dict) -> Result:
    from ..api.blends import blended_law
    from ..studies.figures import figure9
    # DB23 Fig. 9a: the gated Gaussian inside the distributed binomial (N = 4^8: n = 8 sits mid-level).
    lod = blended_law("distributed", inner="gated").at_density(prm["density"])
    fig, rows = figure9(laws=("gated", "head_cf", lod), samples=prm["samples"], seed=ctx.seed)
    t = pd.DataFrame(rows)
    return Result([ctx.save(fig, "db23_figure9.png", 110)], {"db23_figure9": t},
                  {"largest TV, gated": float(t[t.law == "gated"].tv.max()),
                   "largest TV, head_cf": float(t[t.law == "head_cf"].tv.max())})


@section("db23_figure4", "DB23 Fig. 4: blending two LOD levels against spatialized Bernoulli trials",
         "Blending outputs (ZK16) has the wrong variance and a lattice of values; distributing the trials "
         "(DB23 eq. 10) reproduces the stratified ground truth exactly.",
         {"samples": 200_000}, "db23_figure4_lod.ipynb",
         {"db23_figure4": ["N", "p", "n", "w_area", "source", "pvalue", "var_ratio", "tv_vs_square"]})
def _figure4(ctx: Context, prm: dict) -> Result:
    from ..studies import lod
    from ..studies.figures import figure4
    table, panels = lod.figure4_table(samples=prm["samples"], seed=ctx.seed)
    dist = table[table.source.str.startswith("distributed")]
    zk = table[table.source.str.startswith("zk16")]
    return Result([ctx.save(figure4(table, panels), "db23_figure4.png")], {"db23_figure4": table},
                  {"smallest chi-square p, distributed": float(dist.pvalue.min()),
                   "variance ratio range, zk16_linear": f"{zk.var_ratio.min():.3f} to {zk.var_ratio.max():.3f}"})


@section("ghosting_strip", "Ghosting along a receding plane (DB23 Fig. 2 idea)",
         "Across one LOD transition, output blending (zk16_linear) shows a denser, dimmer band of ghost glints "
         "mid-way, nearest jumps at the level change, and the distributed law looks like the ground truth.",
         {"N": 1e8, "p": 0.01, "width": 256, "height": 64, "level": -10}, "lod_blending.ipynb")
def _strip(ctx: Context, prm: dict) -> Result:
    from ..studies import lod
    from ..studies.figures import strip_figure
    images, exponents = lod.strip_images(N=prm["N"], p=prm["p"], width=prm["width"], height=prm["height"],
                                         level=prm["level"], seed=ctx.seed)
    mid = (exponents > 0.4) & (exponents < 0.6)
    lit = {k: float((v[:, mid] > 0).mean()) for k, v in images.items()}
    table = pd.DataFrame([{"image": k, "lit_share_mid": lit[k], "lit_share_vs_truth": lit[k] / lit["ground truth"],
                           "mean_intensity": float(v.mean())} for k, v in images.items()])
    return Result([ctx.save(strip_figure(images, exponents), "lod_strip.png", 110)], {"lod_strip": table},
                  {"lit pixels mid-way, zk16_linear / truth": lit.get("zk16_linear", math.nan) / lit["ground truth"]})


@section("roulette_vs_linear", "Roulette versus linear blending (KPT25 Fig. 6 idea)",
         "Between two MIP levels linear blending lights about twice the pixels at half the intensity; "
         "KPT25's roulette reduces that error without removing it, and the distributed law matches the truth.",
         {"facets_lo": 4.0, "p": 0.05, "samples": 50_000, "inset_size": 64}, "lod_blending.ipynb",
         {"roulette_vs_linear": ["blend", "w", "lit_share", "lit_intensity", "lit_share_vs_truth",
                                 "lit_intensity_vs_truth"]})
def _roulette(ctx: Context, prm: dict) -> Result:
    from ..studies import lod
    from ..studies.figures import roulette_figure
    table = lod.blend_appearance(facets_lo=prm["facets_lo"], p=prm["p"], samples=prm["samples"], seed=ctx.seed)
    insets = lod.blend_insets(facets_lo=prm["facets_lo"], p=prm["p"], size=prm["inset_size"], seed=ctx.seed)
    mid = table[np.isclose(table.w, 0.5)].set_index("blend")
    stats = {f"w = 1/2, {k}": f"lit x{r.lit_share_vs_truth:.2f}, intensity x{r.lit_intensity_vs_truth:.2f}"
             for k, r in mid.iterrows() if not k.startswith("truth")}
    return Result([ctx.save(roulette_figure(insets, table), "roulette_vs_linear.png")],
                  {"roulette_vs_linear": table}, stats)


@section("lod_coherence", "Coherence along zoom and pan paths; non-integer trial counts",
         "Along zoom and pan paths every blend is temporally coherent (consecutive counts strongly correlated, "
         "as the ground truth's are); non-integer trial counts (eq. 10) cost at most a small, bounded TV.",
         {"paths": 1000}, "lod_blending.ipynb",
         {"lod_coherence": ["path", "law", "inner", "mean_abs_step", "pop_rate", "corr_lag1", "corr_ends"]})
def _coherence(ctx: Context, prm: dict) -> Result:
    from ..studies import lod
    from ..studies.figures import coherence_figure
    trials = lod.non_integer_trials_table()
    zoom, zoom_K = lod.zoom_study(paths=prm["paths"], seed=ctx.seed)
    pan, pan_K = lod.pan_study(paths=prm["paths"], seed=ctx.seed)
    coh = pd.concat([zoom, pan], ignore_index=True)
    return Result([ctx.save(coherence_figure(zoom_K, pan_K, zoom, pan), "lod_coherence.png")],
                  {"lod_coherence": coh, "lod_non_integer_trials": trials},
                  {"largest TV from non-integer trials": float(trials.max_tv.max())})


@section("wwh18_threshold", "WWH18's threshold trade (their Fig. 15 idea)",
         "Raising the filtering threshold T lowers the intensity error of the filtered model like "
         "sqrt(2 / (pi T)) while the explicit counting it keeps costs more.",
         {"thresholds": [0.25, 0.5, 1, 2, 4, 8, 16, 32, 64, 128, 256, 1024], "draws_per_point": 16},
         "wwh18_threshold.ipynb",
         {"wwh18_threshold": ["T", "filtered_share", "rel_intensity_err_p90", "rel_intensity_err_max",
                              "ns_per_draw", "cost_ratio"]})
def _threshold(ctx: Context, prm: dict) -> Result:
    from ..validation.bench import threshold_figure, threshold_trade
    table = threshold_trade(thresholds=tuple(float(t) for t in prm["thresholds"]),
                            draws_per_point=prm["draws_per_point"], seed=ctx.seed)
    at16 = table[table["T"] == 16.0]
    stats = {}
    if len(at16):
        r = at16.iloc[0]
        stats = {"T = 16: worst W1 / (n p)": float(r.rel_intensity_err_max),
                 "T = 16: cost vs explicit everywhere": float(r.cost_ratio)}
    return Result([ctx.save(threshold_figure(table), "wwh18_threshold.png")], {"wwh18_threshold": table}, stats)


@section("db23_figure13", "Convergence to the target NDF (DB23 Fig. 13 idea)",
         "The spread of D_P / D(h) falls like 1 / sqrt(n p) for Beckmann and GGX alike; with exact counts the "
         "mean is right at every density, with DB23's gated law it is off by several percent until n p ~ 100.",
         {"pixels": 20_000, "R": 0.5, "alpha": 0.5, "image_resolution": 96}, "db23_figure13.ipynb",
         {"db23_figure13_summary": ["law", "ndf", "theta_deg", "p", "slope", "spread_ratio_min", "spread_ratio_max",
                                    "max_abs_z_mean", "max_abs_mean_err"]})
def _convergence(ctx: Context, prm: dict) -> Result:
    from ..studies.convergence import convergence_summary, convergence_table, ndf_images
    from ..studies.figures import convergence_figure
    ndfs = (("beckmann", prm["alpha"]), ("ggx", prm["alpha"]))
    table = convergence_table(ndfs=ndfs, R=prm["R"], pixels=prm["pixels"], seed=ctx.seed)
    images = ndf_images(ndfs=ndfs, R=prm["R"], resolution=prm["image_resolution"], seed=ctx.seed)
    summ = convergence_summary(table)
    gated = summ[summ.law.str.contains("gated")]
    exact = summ[~summ.law.str.contains("gated")]
    return Result([ctx.save(convergence_figure(table, images), "db23_figure13.png")],
                  {"db23_figure13": table, "db23_figure13_summary": summ},
                  {"slopes (n p >= 10)": f"{summ.slope.min():.3f} to {summ.slope.max():.3f}",
                   "largest |z| of the mean, exact pipeline": float(exact.max_abs_z_mean.max()),
                   "largest mean error, gated pipeline": float(gated.max_abs_mean_err.max())})


@section("speed_accuracy", "Speed against accuracy: Pareto plot, table and error maps",
         "Each law's cost (ns per sample, this run) against its worst TV to the binomial over the standard grid: "
         "the Pareto front shows which laws are worth their cost, the maps show where each law errs.",
         {"samples": 1_000_000}, "speed_accuracy.ipynb",
         {"speed_accuracy": ["law", "tv_max", "tv_median", "mean_rel_err_max", "ns_per_sample", "speedup_vs_numpy",
                             "pareto"]})
def _trade(ctx: Context, prm: dict) -> Result:
    from ..validation.bench import grid_maps, pareto_figure, speed_accuracy
    ctx.progress("speed / accuracy of every law")
    trade, errors = speed_accuracy([law(name, **params) for name, params in TRADE_LAWS], samples=prm["samples"],
                                   seed=ctx.seed)
    errors.to_csv(ctx.out / "error_table_standard_grid.csv", index=False)
    figs = [ctx.save(pareto_figure(trade), "trade_pareto.png", 110),
            grid_maps(ctx.out / "error_maps_tv.png", errors, list(trade.law), "tv", 1e-6, "magma",
                      "TV to the binomial", "Exact TV over the standard grid: n (log, x) by p (y)")]
    return Result(figs, {"speed_accuracy": trade},
                  {"Pareto front": ", ".join(trade[trade.pareto].law),
                   "numpy binomial ns/sample": float(trade.numpy_ns.iloc[0])})


@section("float32", "float32 against float64, and (1 - p)^n four ways",
         "float32 evaluation agrees with float64 over most of the grid and breaks in identifiable corners; "
         "the gate probability 1 - (1 - p)^n is lost by pow in float32, not by exp(n log1p(-p)).",
         {"samples": 1024}, "speed_accuracy.ipynb",
         {"float32_vs_float64": ["law", "mismatch_max", "at_n", "at_p", "points_broken_f32"]})
def _precision(ctx: Context, prm: dict) -> Result:
    import matplotlib.pyplot as plt
    from ..validation.bench import grid_maps
    from ..studies.float32 import float32_summary, float32_table, one_minus_p_pow_n
    samples = prm["samples"]
    laws = [law(name, **params) for name, params in TRADE_LAWS if name != "binomial"]
    table = float32_table(laws, samples=samples, seed=ctx.seed)
    summary = float32_summary(table)
    figs = [grid_maps(ctx.out / "float32_mismatch_maps.png", table, list(summary.law), "mismatch",
                      1.0 / samples / 2, "viridis", "P(K_f32 != K_f64) >= TV",
                      f"float32 vs float64 on the same uniforms ({samples} draws per point): n (x) by p (y)")]
    pow_table = one_minus_p_pow_n()
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
    figs.append(ctx.save(fig, "one_minus_p_pow_n.png", 110))
    table.to_csv(ctx.out / "float32_vs_float64_standard_grid.csv", index=False)
    return Result(figs, {"float32_vs_float64": summary, "one_minus_p_pow_n": pow_table},
                  {"largest float32 mismatch": float(summary.mismatch_max.max())})


@section("aniso", "Anisotropic grids against stratified facets in the ellipse (DB23 §5–6)",
         "DB23's trilinear grid conserves the count exactly, the tetrahedral one over-counts by up to 26 %, "
         "the shader's 48-evaluation blend cuts the variance to 1/5-1/3, and ZK16 widens beyond r = 16.",
         {"samples": 10_000, "image": True, "grid": "quick"}, "aniso_grids.ipynb",
         {"aniso_summary": ["config", "law", "max_abs_mean_bias", "max_weight_bias", "var_ratio_min", "var_ratio_max",
                            "tv_max", "evaluations_max"],
          "aniso_image": ["config", "law", "seconds", "evaluations_mean", "evaluations_max"]})
def _aniso(ctx: Context, prm: dict) -> Result:
    from ..studies.aniso import FULL_GRID, QUICK_GRID, SMALL_GRID
    from ..studies.aniso import write_report as aniso_report
    grids = {"small": SMALL_GRID, "quick": QUICK_GRID, "full": FULL_GRID}
    if prm["grid"] not in grids:
        raise ValueError(f"grid = {prm['grid']!r} is invalid; expected one of {', '.join(grids)}")
    paths, tables = aniso_report(ctx.out, samples=prm["samples"], seed=ctx.seed, image=prm["image"],
                                 grid=grids[prm["grid"]])
    keep = {k: tables[k] for k in ("aniso_summary", "aniso_image") if k in tables}
    s = tables["aniso_summary"]
    by = s.groupby("config")
    stats = {f"largest count bias, {c}": float(by.max_weight_bias.max()[c])
             for c in ("db23_trilinear", "db23_tetrahedral", "zk16_aniso") if c in by.groups}
    if "db23_shader_48" in by.groups:
        stats["variance ratio, db23_shader_48"] = (f"{by.var_ratio_min.min()['db23_shader_48']:.2f} to "
                                                   f"{by.var_ratio_max.max()['db23_shader_48']:.2f}")
    return Result(paths, keep, stats)


@section("scenes", "Scene profiles: DB23 Table 1 scenes, modelled cost and the advisor",
         "On DB23's Table 1 scenes DB23's grid has the same cost on every pixel while ZK16's cost spreads and grows "
         "at grazing angles (worst 8 x 4 group tens of times DB23's), and the advisor names the cheapest law "
         "within TV 0.05 on every pixel.",
         {"scenes": str(data_path("scenes"))}, "scene_profiles.ipynb",
         {"scene_table1": ["scene", "method", "mean_group", "worst_group", "simd_efficiency",
                           "zk16_over_this_worst_group", "paper_ms"],
          "scene_advice": ["scene", "max_tv", "law", "cost_mean_group", "tv_worst"]})
def _scenes(ctx: Context, prm: dict) -> Result:
    from ..validation.scene import write_report as scene_report
    # A directory holding the five Table 1 files (plane_90, plane_25, sphere, heightfield_90, heightfield_25).
    directory = Path(prm["scenes"])
    paths, tables = scene_report(ctx.out, ctx.quick, ctx.seed, ctx.path(directory))
    t1 = tables["scene_table1"]
    tet = t1[t1.scheme == "db23_tetrahedral"].set_index("scene")
    stats = {f"{sc}: worst group ZK16 / DB23": float(r.zk16_over_this_worst_group) for sc, r in tet.iterrows()}
    adv = tables["scene_advice"].set_index("scene")
    stats["advisor at TV 0.05"] = ", ".join(f"{sc} {r.law}" for sc, r in adv.iterrows())
    return Result(paths, tables, stats)


@section("extremes", "Numerical extremes (LAWS.md §8)",
         "Every law gives a finite K in [0, n] at extreme n, p and uniforms in both precisions, except the "
         "shader's gated law, which returns n + 1 as the shader does; every invalid input is refused by name.",
         {"samples": 4096}, "speed_accuracy.ipynb",
         {"extremes_summary": ["law", "precision", "points", "failures", "failed_checks"]})
def _extremes(ctx: Context, prm: dict) -> Result:
    from ..validation.extremes import extremes_summary, extremes_table, invalid_inputs_table, write_extremes_report
    table = extremes_table(samples=prm["samples"], seed=ctx.seed)
    invalid = invalid_inputs_table()
    summary = extremes_summary(table)
    write_extremes_report(ctx.out / "extremes", table, invalid, summary)
    import shutil
    shutil.copy(ctx.out / "extremes" / "extremes.png", ctx.out / "extremes.png")
    failing = summary[summary.failures > 0]
    return Result([ctx.out / "extremes.png"], {"extremes_summary": summary},
                  {"laws x precisions": len(summary), "with failing rows": ", ".join(
                      f"{r.law} ({r.precision})" for r in failing.itertuples()) or "none",
                   "invalid inputs refused by name": f"{int(invalid.ok.sum())} of {len(invalid)}",
                   "details": "extremes/extremes.html"})


@section("bounds_check", "Error bounds (the shipped default.json)",
         "The error bounds a renderer's CI can gate on: every built-in law keeps its recorded worst case.",
         {"bounds": str(data_path("bounds", "default.json"))}, "speed_accuracy.ipynb",
         {"bounds_check": ["id", "law", "metric", "limit", "bound", "worst", "ok"]})
def _bounds(ctx: Context, prm: dict) -> Result:
    from ..validation.bounds import check
    table = check(ctx.path(prm["bounds"]), progress=False)
    bad = table[~table.ok]
    return Result([], {"bounds_check": table}, {"bounds holding": f"{int(table.ok.sum())} of {len(table)}"},
                  [f"bound {r.id} violated: {r.metric} = {r.worst:.6g} (bound {r.bound:.6g})" for r in bad.itertuples()])


# ---------------------------------------------------------------------------------------------------
# Configuration


def load_config(source=None) -> tuple[dict, str]:
    """(document, source name) of a report configuration: a path, or a dict; default
    ``glintlab/data/report/default.json``. Validated against ``glintlab/data/schema/report.schema.json`` and against
    the sections' parameters; a bad document raises ValueError naming the source, the JSON pointer of
    the bad field and what was expected."""
    import jsonschema
    if source is None:
        source = DEFAULT_CONFIG
    if isinstance(source, dict):
        doc, name = source, "<report config>"
    else:
        path = Path(source)
        name = str(path)
        try:
            doc = json.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise ValueError(f"{name}: no such file") from None
        except (OSError, UnicodeDecodeError) as exc:
            raise ValueError(f"{name}: cannot read ({exc})") from None
        except json.JSONDecodeError as exc:
            raise ValueError(f"{name}: at /: expected valid JSON ({exc})") from None
    schema = json.loads(SCHEMA.read_text())
    errors = sorted(jsonschema.Draft202012Validator(schema).iter_errors(doc), key=lambda e: list(e.absolute_path))
    if errors:
        e = errors[0]
        raise ValueError(f"{name}: at {V.json_pointer(e.absolute_path)}: {e.message}")
    seen = set()
    for i, entry in enumerate(doc["sections"]):
        sec = SECTIONS.get(entry["name"])
        if sec is None:
            raise ValueError(f"{name}: at /sections/{i}/name: expected one of {', '.join(SECTIONS)}, "
                             f"got {entry['name']!r}")
        if entry["name"] in seen:
            raise ValueError(f"{name}: at /sections/{i}/name: section {entry['name']!r} appears twice")
        seen.add(entry["name"])
        for part in ("params", "quick"):
            for key, value in entry.get(part, {}).items():
                where = f"{name}: at /sections/{i}/{part}/{key}"
                if key not in sec.defaults:
                    raise ValueError(f"{where}: expected a parameter of {entry['name']} "
                                     f"({', '.join(sec.defaults)}), got {key!r}")
                _check_type(where, value, sec.defaults[key])
    return doc, name


def _check_type(where, value, default):
    """A parameter has its default's type: bool, int, number (finite), string or list of numbers > 0."""
    if isinstance(default, bool):
        ok, what = isinstance(value, bool), "true or false"
    elif isinstance(default, int):  # counts (positive defaults) must be >= 1; other integers (a level) any sign
        ok = isinstance(value, int) and not isinstance(value, bool) and (value >= 1 or default <= 0)
        what = "an integer >= 1" if default > 0 else "an integer"
    elif isinstance(default, float):
        ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
        what = "a finite number"
    elif isinstance(default, str):
        ok, what = isinstance(value, str) and value != "", "a non-empty string"
    else:
        ok = (isinstance(value, list) and len(value) > 0 and all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) and x > 0 for x in value))
        what = "a non-empty list of finite numbers > 0"
    if not ok:
        raise ValueError(f"{where}: expected {what}, got {value!r}")


def section_params(entry: dict, quick: bool) -> dict:
    prm = {**SECTIONS[entry["name"]].defaults, **entry.get("params", {})}
    if quick:
        prm.update(entry.get("quick", {}))
    return prm


# ---------------------------------------------------------------------------------------------------
# Running


class _Progress:
    """A rich progress bar over sections on a terminal (elapsed time, current step); nothing otherwise."""

    def __init__(self, total: int, quiet: bool):
        self.enabled = not quiet and sys.stderr.isatty()
        self.total = total

    def __enter__(self):
        if self.enabled:
            from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
            self.p = Progress(TextColumn("[bold]report[/bold] {task.completed}/{task.total}"), BarColumn(),
                              TimeElapsedColumn(), TextColumn("{task.description}"), transient=True)
            self.p.__enter__()
            self.task = self.p.add_task("", total=self.total)
        return self

    def __exit__(self, *a):
        return self.p.__exit__(*a) if self.enabled else False

    def label(self, text: str):
        if self.enabled:
            self.p.update(self.task, description=text)

    def advance(self):
        if self.enabled:
            self.p.update(self.task, advance=1)


def _command(out: Path, name: str | None, quick: bool, seed: int, config: str | None) -> str:
    parts = ["glintlab report", f"--out {out}"]
    if name:
        parts.append(f"--only {name}")
    if quick:
        parts.append("--quick")
    parts.append(f"--seed {seed}")
    if config:
        parts.append(f"--config {config}")
    return " ".join(parts)


def run(out: Path, quick: bool = False, seed: int | None = None, quiet: bool = False, only=None,
        config=None) -> dict:
    """Runs the configured sections (or those named in ``only``) into ``out``, rebuilds index.html and
    report.json from every section record present, and returns the summary (report.json's content)."""
    doc, source = load_config(config)
    base = Path(source).parent if isinstance(config, (str, Path)) else Path.cwd()
    seed = V.seed(doc.get("seed", 1) if seed is None else seed)
    entries = doc["sections"]
    if only:
        names = [e["name"] for e in entries]
        for name in only:
            if name not in names:
                raise ValueError(f"only = {name!r} is invalid; expected a section of {source}: {', '.join(names)}")
        entries = [e for e in entries if e["name"] in only]
    out = Path(out)
    (out / "sections").mkdir(parents=True, exist_ok=True)
    import matplotlib
    matplotlib.use("Agg")
    config_arg = None if config is None else str(config)
    t0 = time.perf_counter()
    with _Progress(len(entries), quiet) as progress:
        for entry in entries:
            sec = SECTIONS[entry["name"]]
            prm = section_params(entry, quick)
            progress.label(sec.short)
            ctx = Context(out, seed, quick, lambda label, s=sec: progress.label(f"{s.short}: {label}"), base)
            t1 = time.perf_counter()
            res = sec.run(ctx, prm)
            seconds = time.perf_counter() - t1
            for name, df in res.tables.items():
                df.to_csv(out / f"{name}.csv", index=False)
            record = {"name": sec.name, "title": sec.title, "meaning": sec.meaning, "params": prm, "seed": seed,
                      "quick": quick, "seconds": round(seconds, 2), "notebook": sec.notebook,
                      "command": _command(out, sec.name, quick, seed, config_arg),
                      "figures": [Path(f).name for f in res.figures], "stats": _jsonable(res.stats),
                      "failures": res.failures,
                      "tables": {k: json.loads(v.to_json(orient="records")) for k, v in res.tables.items()},
                      "glintlab_version": __version__}
            (out / "sections" / f"{sec.name}.json").write_text(json.dumps(record, indent=1))
            progress.advance()
    order = [e["name"] for e in doc["sections"]]
    records = [json.loads(p.read_text()) for p in sorted((out / "sections").glob("*.json"))]
    records = sorted((r for r in records if r["name"] in order), key=lambda r: order.index(r["name"]))
    summary = {
        "glintlab_version": __version__,
        "config": source,
        "command": _command(out, None, quick, seed, config_arg),
        "seed": seed,
        "quick": quick,
        "python": platform.python_version(),
        "seconds": round(time.perf_counter() - t0, 2),
        "ran": [e["name"] for e in entries],
        "sections": {r["name"]: {k: r[k] for k in ("title", "seconds", "command", "stats", "failures", "params")}
                     for r in records},
        "tables": {k: v for r in records for k, v in r["tables"].items()},
        "figures": [f for r in records for f in r["figures"]],
        "failures": [f for r in records for f in r["failures"]],
    }
    (out / "report.json").write_text(json.dumps(summary, indent=1))
    _write_html(out, summary, records)
    return summary


def _jsonable(stats: dict) -> dict:
    return {k: (float(v) if isinstance(v, (np.floating, np.integer)) else v) for k, v in stats.items()}


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def _png_size(path: Path):
    """(width, height) from a PNG's IHDR chunk, so the page reserves each figure's box before it loads."""
    try:
        head = path.read_bytes()[:24]
    except OSError:
        return None
    if head[:8] != b"\x89PNG\r\n\x1a\n":
        return None
    return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")


def _write_html(out: Path, summary: dict, records: list):
    e = html.escape
    toc = "".join(f'<li><a href="#{r["name"]}">{e(r["title"])}</a></li>' for r in records)
    parts = [f"<h1>glintlab {e(summary['glintlab_version'])}: what is known about glint counting laws</h1>",
             f"<p>Regenerate the whole page: <code>{e(summary['command'])}</code> (configuration "
             f"<code>{e(summary['config'])}</code>, seed {summary['seed']}"
             f"{', quick sizes' if summary['quick'] else ''}). Each section says how to regenerate it alone. "
             f"Tables are the CSV files beside this page.</p>"]
    if summary["failures"]:
        parts.append('<p class="fail"><b>Failed checks:</b> ' + "; ".join(e(f) for f in summary["failures"]) + "</p>")
    parts.append(f"<ol class='toc'>{toc}</ol>")
    for r in records:
        parts.append(f'<section id="{r["name"]}"><h2>{e(r["title"])}</h2><p class="meaning">{e(r["meaning"])}</p>')
        if r["stats"]:
            parts.append("<ul class='stats'>" + "".join(f"<li>{e(k)}: <b>{e(_fmt(v))}</b></li>"
                                                        for k, v in r["stats"].items()) + "</ul>")
        for f in r["failures"]:
            parts.append(f'<p class="fail">FAILED: {e(f)}</p>')
        for fig in r["figures"]:
            size = _png_size(out / fig)
            dims = f' width="{size[0]}" height="{size[1]}"' if size else ""
            parts.append(f'<figure><img src="{e(fig)}" alt="{e(Path(fig).stem)}"{dims}></figure>')
        params = ", ".join(f"{k} = {json.dumps(v)}" for k, v in r["params"].items())
        nb = f"; notebook <code>notebooks/{e(r['notebook'])}</code>" if r["notebook"] else ""
        parts.append(f"<p class='how'>Parameters: {e(params)}; seed {r['seed']}; {r['seconds']} s. "
                     f"Regenerate alone: <code>{e(r['command'])}</code>{nb}.</p>")
        for name, rows in r["tables"].items():
            df = pd.DataFrame(rows)
            parts.append(f"<details><summary>table {e(name)} ({len(df)} rows, <a href='{e(name)}.csv'>{e(name)}.csv</a>)"
                         f"</summary>{df.head(200).to_html(index=False, float_format=lambda v: f'{v:.6g}', border=0)}"
                         "</details>")
        parts.append("</section>")
    # Marks every image that decoded with its page rectangle, and the page height, so a headless browser
    # test (tests/python/test_report.py) can find each figure in a screenshot and check it is not blank.
    script = ("<script>window.addEventListener('load',function(){var n=0;for(var i of document.images)"
              "{if(i.complete&&i.naturalWidth>0){n++;var r=i.getBoundingClientRect();i.setAttribute('data-rect',"
              "[r.left+scrollX,r.top+scrollY,r.width,r.height].map(Math.round).join(','));}}"
              "document.body.setAttribute('data-images-loaded',String(n));document.body.setAttribute("
              "'data-height',String(document.documentElement.scrollHeight));});</script>")
    (out / "index.html").write_text(
        "<!doctype html><html lang='en'><meta charset='utf-8'><title>glintlab report</title>"
        "<style>body{font-family:sans-serif;max-width:1150px;margin:auto;padding:0 12px;color:#222}"
        "img{max-width:100%;height:auto}figure{margin:8px 0}.meaning{font-size:15px}.how{font-size:12px;color:#555}"
        ".stats{font-size:13px}.fail{color:#b2182b}section{border-top:1px solid #ccc;margin-top:18px}"
        "table{border-collapse:collapse;font-size:11px}td,th{padding:2px 6px;border-bottom:1px solid #ddd}"
        "code{background:#f4f4f4;padding:1px 3px}</style><body>" + "\n".join(parts) + script + "</body></html>")


def print_summary(summary) -> None:
    tables = summary["tables"]
    for name in summary["ran"]:
        sec, rec = SECTIONS[name], summary["sections"][name]
        print(f"\n== {sec.title} ({rec['seconds']} s)")
        for k, v in rec["stats"].items():
            print(f"   {k}: {_fmt(v)}")
        for table, cols in sec.show.items():
            if table in tables and tables[table]:
                df = pd.DataFrame(tables[table])
                print(df[[c for c in cols if c in df]].head(40).to_string(index=False, float_format=lambda v: f"{v:.4g}"))
        for f in rec["failures"]:
            print(f"   FAILED: {f}")


def thumbnail(out, path, columns: int = 4, width_px: int = 1400) -> Path:
    """A contact sheet of a report's figures (the first figure of each section, titled), e.g. the
    README's picture: ``thumbnail("out/report", "docs/figures/report_thumbnail.png")``."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.image import imread
    out = Path(out)
    summary = json.loads((out / "report.json").read_text())
    picks = [(SECTIONS[k].short, next(iter(json.loads((out / "sections" / f"{k}.json").read_text())["figures"]), None))
             for k in summary["sections"]]
    picks = [(title, fig) for title, fig in picks if fig]
    rows = math.ceil(len(picks) / columns)
    fig, axes = plt.subplots(rows, columns, figsize=(width_px / 100, width_px / 100 * 0.62 * rows / columns * 1.6),
                             squeeze=False)
    for ax, (title, name) in zip(axes.ravel(), picks):
        ax.imshow(imread(out / name))
        ax.set_title(title, fontsize=9)
    for ax in axes.ravel():
        ax.axis("off")
    fig.suptitle(f"glintlab report{' (quick)' if summary['quick'] else ''}: the first figure of each section", fontsize=10)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
