"""Anisotropic grid schemes against the ground truth of stratified facets in the actual ellipse.

For each footprint (n = N P expected facets, ratio r, orientation phi) and reflection probability p,
the truth is the exact law of K for one jittered facet per cell of an M x M grid (N = M^2), counted in
the ellipse at a uniformly random position (``gl.ground_truth(...).pmf()``). Each configuration (grid
scheme, realization interpolation, inner law) is compared with it:

* ``mean_bias`` E[K] / (n p) and ``var_ratio`` Var[K] / Var_truth: exact when the configuration has an
  exact law, else from samples (``mean_bias_se`` is then the Monte Carlo standard error);
* ``tv``: exact total variation, or the TV of samples binned to integers (round half up: blended
  realizations and ZK16's rescaled counts are not integers) with ``tv_noise``, the TV pure sampling
  noise would give (de Moivre), next to it; moments come from the unbinned values;
* ``chi2_pvalue``: Pearson's test of ``samples`` draws against the truth (its power grows with the
  sample count: a p-value near 0 says the difference is detectable with that many pixels);
* ``weight_bias``: sum of scale x trials / (N P), the scheme's count conservation, inner-law free.

Grids have ``base_area = 1 / N`` (level 0 cells hold one facet, DB23's "one random facet per texel").

The report's aniso section and ``glintlab aniso`` run the study, the weight maps and the image timing.
"""
from __future__ import annotations

import math
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pandas as pd

from ..api import checks as V
from ..api.grids import CONFIGS, IMAGE_CONFIGS, configured_counter
from ..api.metrics import chi2_test, distance
from ..api.spatial import Ellipse, ground_truth
from ..validation.rows import row_seed, tv_noise
from .base import Context, Tables

NAME = "aniso"
TITLE = "Anisotropic grids against stratified facets in the ellipse (DB23 §5–6)"
MEANING = ("DB23's trilinear grid conserves the count exactly, the tetrahedral one over-counts by up to 26 %, "
           "the shader's 48-evaluation blend cuts the variance to 1/5-1/3, and ZK16 widens beyond r = 16.")
# The report times the image at 960 x 540 (a quarter of the pixels of `glintlab aniso` and `make bench`,
# which time 1920 x 1080): ns per pixel and the evaluation histogram are per-pixel figures, and the
# quarter-size frame covers the same range of footprint ratios (the plane and the field of view are the same).
DEFAULTS = {"samples": 10_000, "image": True, "grid": "quick", "image_width": 960}
# --quick: 2000 draws per point (make run QUICK=1 is a smoke run under 45 s; the report keeps 10000).
QUICK = {"samples": 2000, "image": False, "grid": "small"}
NOTEBOOK = "aniso_grids.ipynb"
TABLE = {"aniso_summary": ["config", "law", "max_abs_mean_bias", "max_weight_bias", "var_ratio_min", "var_ratio_max",
                           "tv_max", "evaluations_max"],
         "aniso_image": ["config", "law", "seconds", "evaluations_mean", "evaluations_max"]}

QUICK_GRID = {"n": (3.0, 30.0, 300.0), "r": (1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 16.0, 24.0, 64.0),
              "phi_deg": (0.0, 30.0, 60.0, 90.0, 120.0, 150.0), "p": (0.1,)}
# make run QUICK=1: ratios mostly between powers of 2 (at powers of 2 tetrahedral weights are exact)
# and half its angles.
SMALL_GRID = {"n": (3.0, 30.0, 300.0), "r": (1.0, 1.5, 3.0, 6.0, 24.0, 64.0), "phi_deg": (0.0, 60.0, 120.0),
              "p": (0.1,)}
FULL_GRID = {"n": (3.0, 10.0, 30.0, 100.0, 300.0),
             "r": (1.0, 1.25, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0, 16.0, 24.0, 32.0, 48.0, 64.0),
             "phi_deg": tuple(np.arange(0.0, 180.0, 11.25)), "p": (0.1, 0.5)}


def _weight_bias(terms, N, P) -> float:
    return sum(t["scale"] * t["trials"] for t in terms) / (N * P)


def truth(N: float, n: float, r: float, phi: float, p: float):
    """Exact law of K for stratified facets in the ellipse of area n / N, ratio r, angle phi (radians)."""
    P = n / N
    a, b = math.sqrt(P * r / math.pi), math.sqrt(P / (r * math.pi))
    return ground_truth("stratified", density=N, footprint=Ellipse(a, b, phi), p=p).pmf()


def study(configs=None, laws=("binomial", "gated"), N: float = 1024.0**2, grid=None, samples: int = 10_000,
          seed: int = 1, threads: int | None = None, progress=None) -> pd.DataFrame:
    """One row per (configuration, law, n, r, phi, p); see the module docstring for the columns."""
    configs = list(CONFIGS) if configs is None else list(configs)
    grid = dict(QUICK_GRID if grid is None else grid)
    points = [(n, r, ph, p) for n in grid["n"] for r in grid["r"] for ph in grid["phi_deg"] for p in grid["p"]]
    counters = {(c, lw): configured_counter(c, lw, N) for c in configs for lw in laws}

    def one(point):
        n, r, ph, p = point
        phi = math.radians(ph)
        P = n / N
        d_truth = truth(N, n, r, phi, p)
        rows = []
        for (label, lw), c in counters.items():
            s = row_seed(seed, f"{label}|{lw}", n, p + r * 1e3 + ph)
            raw = c.sample(N, P, r, phi, p, size=samples, seed=s)
            x = c.bin(raw)  # integer bins for TV and chi-square; moments from the raw values
            terms, clamped = c._core.terms(float(N), P, r, phi)
            row = {"config": label, "law": lw, "n": n, "r": r, "phi_deg": ph, "p": p,
                   "evaluations": len(terms) * c.evaluations_per_term,
                   "weight_bias": _weight_bias(terms, N, P), "clamped": bool(clamped)}
            if c.has_pmf:
                d = c.pmf(N, P, r, phi, p)
                row.update(mean_bias=d.mean / (n * p), mean_bias_se=0.0, var_ratio=d.var / d_truth.var,
                           tv=distance(d, d_truth, "tv"), tv_noise=0.0, exact=True)
            else:
                row.update(mean_bias=raw.mean() / (n * p), mean_bias_se=raw.std() / math.sqrt(samples) / (n * p),
                           var_ratio=raw.var() / d_truth.var, tv=distance(x, d_truth, "tv"),
                           tv_noise=tv_noise(d_truth, samples), exact=False)
            row["chi2_pvalue"] = chi2_test(x, d_truth).pvalue
            rows.append(row)
        return rows

    with ThreadPoolExecutor(max_workers=threads or 2) as pool:
        rows = []
        for chunk in pool.map(one, points):
            rows.extend(chunk)
            if progress is not None:
                progress.update(1)
    return pd.DataFrame(rows)


def summary(table: pd.DataFrame) -> pd.DataFrame:
    """Per configuration and law: worst mean bias, variance ratio range, worst TV, share of points the
    chi-square test rejects at 1% and the evaluation counts."""
    g = table.groupby(["config", "law"], sort=False)
    out = g.agg(max_abs_mean_bias=("mean_bias", lambda s: float(np.max(np.abs(s - 1)))),
                max_weight_bias=("weight_bias", lambda s: float(np.max(np.abs(s - 1)))),
                var_ratio_min=("var_ratio", "min"), var_ratio_max=("var_ratio", "max"),
                tv_median=("tv", "median"), tv_max=("tv", "max"),
                chi2_reject_1pct=("chi2_pvalue", lambda s: float(np.mean(s < 0.01))),
                evaluations_min=("evaluations", "min"), evaluations_max=("evaluations", "max"),
                exact=("exact", "all")).reset_index()
    return out


def weight_bias_map(configs=None, N: float = 1024.0**2, levels: float = 2.0, r_max: float = 64.0, phi_deg: float = 10.0,
                    resolution: int = 120) -> dict[str, pd.DataFrame]:
    """sum w_i N A_i / (N P) over a fine (scale position, r) grid at one orientation, per configuration:
    where the weights do not conserve the expected count, and by how much. The scale axis is the
    minor side's position in levels, log_4(m^2 / A_0)."""
    configs = [c for c in (CONFIGS if configs is None else configs)]
    s_axis = np.linspace(3.0, 3.0 + levels, resolution)
    r_axis = np.exp(np.linspace(0.0, math.log(r_max), resolution))
    out = {}
    for label in configs:
        c = configured_counter(label, "binomial", N)
        grid = np.empty((resolution, resolution))
        for i, r in enumerate(r_axis):
            for j, s in enumerate(s_axis):
                m2 = 4.0**s / N  # minor side squared (area of the isotropic square)
                grid[i, j] = _weight_bias(c._core.terms(float(N), m2 * r, float(r), math.radians(phi_deg))[0], N, m2 * r)
        out[label] = pd.DataFrame(grid, index=pd.Index(r_axis, name="r"), columns=pd.Index(s_axis, name="level"))
    return out


def image_benchmark(width: int = 1920, height: int = 1080, law: str = "gated", seed: int = 1, repeats: int = 1,
                    configs=None) -> tuple[pd.DataFrame, dict]:
    """Evaluates a whole image per configuration and times it: a ground plane seen at a grazing angle
    at 60° (every pixel sees it; the footprint stretches towards the horizon: r from 1.0 to 131).
    Returns (timings, {config: evaluation histogram})."""
    N = 1024.0**2
    uv, J = plane_image(width, height, tilt_deg=60.0)
    rows, hists = [], {}
    for label in (list(IMAGE_CONFIGS) if configs is None else configs):
        c = configured_counter(IMAGE_CONFIGS.get(label, label), law, N)
        best = math.inf
        for _ in range(repeats):
            t0 = time.perf_counter()
            res = c.count_image(uv, J, N, 0.1, seed=seed)
            best = min(best, time.perf_counter() - t0)
        hist = res.evaluation_histogram()
        hists[label] = hist
        st = res.status_counts()
        rows.append({"config": label, "law": law, "pixels": width * height, "seconds": best,
                     "ns_per_pixel": best / (width * height) * 1e9,
                     "evaluations_mean": float(res.evaluations.mean()), "evaluations_max": int(res.evaluations.max()),
                     "degenerate": st.get("degenerate", 0) + st.get("non_finite", 0), "clamped": st.get("clamped", 0)})
    return pd.DataFrame(rows), hists


def plane_image(width: int, height: int, tilt_deg: float = 80.0, yaw_deg: float = 30.0, texture_scale: float = 0.25):
    """(uv, J) of a pinhole camera (90° horizontal field of view) looking at a textured plane: the
    plane faces the camera at ``tilt_deg = 0`` and is tilted about the image's horizontal axis by
    ``tilt_deg``; its texture axes are turned by ``yaw_deg``. Pixels above the horizon get a zero
    Jacobian (degenerate: reported, not counted). Derivatives are analytic.

    The ray through pixel (xs, ys) (in units of the focal length) meets the plane
    y sin t + z cos t = 1 at depth d = 1 / (cos t + ys sin t); the in-plane coordinates are
    a = d xs and b = d (ys cos t - sin t)."""
    f = 0.5 * width
    y, x = np.mgrid[0:height, 0:width].astype(np.float64)
    xs, ys = (x + 0.5 - 0.5 * width) / f, (y + 0.5 - 0.5 * height) / f
    t = math.radians(tilt_deg)
    den = math.cos(t) + ys * math.sin(t)
    ok = den > 1e-3
    d = np.where(ok, 1.0 / np.where(ok, den, 1.0), 0.0)
    a, b = xs * d, (ys * math.cos(t) - math.sin(t)) * d
    dd_dys = -d * d * math.sin(t)
    # One pixel moves xs or ys by 1 / f.
    da_dx, da_dy = d / f, xs * dd_dys / f
    db_dx, db_dy = np.zeros_like(d), (math.cos(t) * d + (ys * math.cos(t) - math.sin(t)) * dd_dys) / f
    c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    k = texture_scale
    u, v = k * (c * a - s * b), k * (s * a + c * b)
    J = np.stack([k * (c * da_dx - s * db_dx), k * (s * da_dx + c * db_dx),
                  k * (c * da_dy - s * db_dy), k * (s * da_dy + c * db_dy)], axis=-1)
    J[~ok] = 0.0
    uv = np.stack([np.where(ok, u, 0.0), np.where(ok, v, 0.0)], axis=-1)
    return uv, J


def _heat(ax, df, value, title, cmap="viridis", vmin=None, vmax=None, log_x=True):
    piv = df.pivot_table(index="r", columns="n", values=value, aggfunc="median")
    im = ax.imshow(piv.values, origin="lower", aspect="auto", cmap=cmap, vmin=vmin, vmax=vmax)
    ax.set_xticks(range(len(piv.columns)), [f"{c:g}" for c in piv.columns], fontsize=7)
    ax.set_yticks(range(len(piv.index)), [f"{c:g}" for c in piv.index], fontsize=7)
    ax.set_title(title, fontsize=8)
    return im


def maps_figure(table: pd.DataFrame, law: str = "binomial"):
    """Rows: configurations; columns: mean bias, variance ratio and TV (median over phi) on (n, r),
    and TV on (phi, r) at the middle n."""
    import matplotlib.pyplot as plt
    df = table[table.law == law]
    configs = list(dict.fromkeys(df.config))
    mid_n = sorted(df.n.unique())[len(df.n.unique()) // 2]
    fig, axes = plt.subplots(len(configs), 4, figsize=(13, 2.3 * len(configs)), squeeze=False)
    for i, cfg in enumerate(configs):
        d = df[df.config == cfg]
        ims = [_heat(axes[i, 0], d, "mean_bias", f"{cfg}: E[K]/(n p)", "coolwarm", 0.5, 1.5),
               _heat(axes[i, 1], d, "var_ratio", "Var / Var_truth", "coolwarm", 0.0, 2.0),
               _heat(axes[i, 2], d, "tv", "TV to truth", "magma", 0.0, 0.5)]
        piv = d[d.n == mid_n].pivot_table(index="r", columns="phi_deg", values="tv", aggfunc="median")
        ims.append(axes[i, 3].imshow(piv.values, origin="lower", aspect="auto", cmap="magma", vmin=0, vmax=0.5))
        axes[i, 3].set_xticks(range(len(piv.columns)), [f"{c:g}" for c in piv.columns], fontsize=7)
        axes[i, 3].set_yticks(range(len(piv.index)), [f"{c:g}" for c in piv.index], fontsize=7)
        axes[i, 3].set_title(f"TV at n = {mid_n:g} over phi (deg)", fontsize=8)
        for ax, im in zip(axes[i], ims):
            fig.colorbar(im, ax=ax, fraction=0.046)
        axes[i, 0].set_ylabel("r", fontsize=8)
    for ax in axes[-1, :3]:
        ax.set_xlabel("n = N P", fontsize=8)
    fig.suptitle(f"Anisotropic grids against stratified facets in the ellipse (inner law: {law}, p = "
                 f"{', '.join(f'{v:g}' for v in sorted(df.p.unique()))})", fontsize=10)
    fig.tight_layout()
    return fig


def weight_bias_figure(maps: dict[str, pd.DataFrame]):
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(maps), figsize=(3.3 * len(maps), 3.2), squeeze=False)
    for ax, (label, df) in zip(axes[0], maps.items()):
        im = ax.imshow(df.values, origin="lower", aspect="auto", cmap="coolwarm", vmin=0.5, vmax=1.5,
                       extent=[df.columns[0], df.columns[-1], 0, math.log2(df.index[-1])])
        ax.set_title(f"{label}\nmax {df.values.max():.3f}, min {df.values.min():.3f}", fontsize=8)
        ax.set_xlabel("scale level of the minor side", fontsize=8)
        ax.set_ylabel("log2 r", fontsize=8)
        fig.colorbar(im, ax=ax, fraction=0.046)
    fig.suptitle("Count conservation of the grid weights: sum w_i N A_i / (N P) (phi = 10 deg)", fontsize=10)
    fig.tight_layout()
    return fig


def evaluations_figure(hists: dict[str, pd.Series], size: str = "1920 x 1080"):
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(hists), figsize=(2.6 * len(hists), 2.6), squeeze=False, sharey=True)
    for ax, (label, h) in zip(axes[0], hists.items()):
        ax.bar([str(int(v)) for v in h.index], h.values / h.values.sum())
        ax.set_title(label, fontsize=8)
        ax.tick_params(axis="x", labelsize=6, rotation=90)
        ax.set_xlabel("evaluations per pixel", fontsize=8)
    axes[0, 0].set_ylabel("share of pixels", fontsize=8)
    fig.suptitle(f"Per-pixel inner-law evaluations, {size} plane tilted 60°", fontsize=10)
    fig.tight_layout()
    return fig


GRIDS = {"small": SMALL_GRID, "quick": QUICK_GRID, "full": FULL_GRID}
STATS_CONFIGS = ("db23_trilinear", "db23_tetrahedral", "zk16_aniso")


def compute(params: dict, ctx: Context) -> Tables:
    V.choice("grid", params["grid"], GRIDS, f"one of {', '.join(GRIDS)}")
    res = study_tables(GRIDS[params["grid"]], params["samples"], ctx.seed, params["image"],
                       image_width=V.integer("image_width", params["image_width"], minimum=16))
    by = res["aniso_summary"].groupby("config")
    res.stats = {f"largest count bias, {c}": float(by.max_weight_bias.max()[c]) for c in STATS_CONFIGS
                 if c in by.groups}
    if "db23_shader_48" in by.groups:
        res.stats["variance ratio, db23_shader_48"] = (f"{by.var_ratio_min.min()['db23_shader_48']:.2f} to "
                                                       f"{by.var_ratio_max.max()['db23_shader_48']:.2f}")
    return res


def study_tables(grid: dict, samples: int, seed: int, image: bool, map_resolution: int = 80, progress=None,
                 image_width: int = 1920) -> Tables:
    """The study over ``grid`` (aniso_study; its summary aniso_summary), the weight maps and (``image``) the
    image timing at ``image_width`` x 9/16 of it (aniso_image; evaluation histograms aniso_evaluations)."""
    table = study(grid=grid, samples=samples, seed=seed, progress=progress)
    res = Tables({"aniso_summary": summary(table)}, extra={"aniso_study": table},
                 data={"weight_bias": weight_bias_map(resolution=map_resolution)})
    if image:
        timing, hists = image_benchmark(image_width, image_width * 9 // 16, seed=seed)
        res.tables["aniso_image"] = timing
        res.extra["aniso_evaluations"] = pd.concat(
            [h.rename("pixels").reset_index().assign(config=label) for label, h in hists.items()], ignore_index=True)
        res.data["hists"] = hists
        res.data["image_size"] = f"{image_width} x {image_width * 9 // 16}"
    return res


def figures(tables: Tables, ctx: Context) -> list:
    paths = [ctx.save(maps_figure(tables["aniso_study"]), "aniso_maps.png", 90),
             ctx.save(weight_bias_figure(tables["weight_bias"]), "aniso_weight_bias.png", 90)]
    if "hists" in tables:
        paths.append(ctx.save(evaluations_figure(tables["hists"], tables["image_size"]), "aniso_evaluations.png", 90))
    return paths


def command_tables(full: bool = False, samples: int | None = None, seed: int = 1, progress=None,
                   image: bool = True, grid: dict | None = None) -> Tables:
    """``glintlab aniso``'s tables (written by the report runner's one writing path with ``figures``):
    the study, the weight maps and (``image``) the 1920 x 1080 image timing."""
    if samples is not None:
        V.integer("samples", samples, minimum=1, expected="an integer >= 1 (draws per footprint)")
    samples = (40_000 if full else 10_000) if samples is None else int(samples)
    return study_tables(grid or (FULL_GRID if full else QUICK_GRID), samples, seed, image,
                        map_resolution=80 if not full else 160, progress=progress)
