"""Anisotropic grid schemes against the ground truth of stratified facets in the actual ellipse.

For each footprint (n = N P expected facets, ratio r, orientation phi) and reflection probability p,
the truth is the exact law of K for one jittered facet per cell of an M x M grid (N = M^2), counted in
the ellipse at a uniformly random position (``gl.ground_truth(...).pmf()``). Each configuration (grid
scheme, realization interpolation, inner law) is compared with it:

* ``mean_bias`` E[K] / (n p) and ``var_ratio`` Var[K] / Var_truth: exact when the configuration has an
  exact law, else from samples (``mean_bias_se`` is then the Monte Carlo standard error);
* ``tv``: exact total variation, or the TV of binned samples with ``tv_noise``, the TV pure sampling
  noise would give (de Moivre), next to it;
* ``chi2_pvalue``: Pearson's test of ``samples`` draws against the truth (its power grows with the
  sample count: a p-value near 0 says the difference is detectable with that many pixels);
* ``weight_bias``: sum of scale x trials / (N P), the scheme's count conservation, inner-law free.

Grids have ``base_area = 1 / N`` (level 0 cells hold one facet, DB23's "one random facet per texel").
"""
from __future__ import annotations

import math
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pandas as pd

from .aniso import aniso_counter
from .metrics import chi2_test, distance
from .spatial import Ellipse, ground_truth

# label -> (scheme, keyword arguments of aniso_counter)
CONFIGS = {
    "db23_trilinear": ("db23_trilinear", {}),
    "db23_tetrahedral": ("db23_tetrahedral", {}),
    "db23_trilinear[log lod]": ("db23_trilinear", {"scale_weights": "log"}),
    "db23_tetrahedral[log lod]": ("db23_tetrahedral", {"scale_weights": "log"}),
    "db23_shader_48": ("db23_tetrahedral", {"scale_weights": "log", "spatial": "simplex", "angular": "bilinear",
                                            "realization": "blend"}),
    "zk16_aniso": ("zk16_aniso", {}),
}
QUICK_GRID = {"n": (3.0, 30.0, 300.0), "r": (1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 16.0, 24.0, 64.0),
              "phi_deg": (0.0, 30.0, 60.0, 90.0, 120.0, 150.0), "p": (0.1,)}
FULL_GRID = {"n": (3.0, 10.0, 30.0, 100.0, 300.0),
             "r": (1.0, 1.25, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0, 16.0, 24.0, 32.0, 48.0, 64.0),
             "phi_deg": tuple(np.arange(0.0, 180.0, 11.25)), "p": (0.1, 0.5)}


def _counter(label, law, N):
    scheme, kwargs = CONFIGS[label] if isinstance(label, str) else label
    kw = dict(kwargs)
    opts = {k: kw.pop(k) for k in ("spatial", "angular", "realization") if k in kw}
    return aniso_counter(scheme, inner=law, base_area=1.0 / N, **opts, **kw)


def truth(N: float, n: float, r: float, phi: float, p: float):
    """Exact law of K for stratified facets in the ellipse of area n / N, ratio r, angle phi (radians)."""
    P = n / N
    a, b = math.sqrt(P * r / math.pi), math.sqrt(P / (r * math.pi))
    return ground_truth("stratified", density=N, footprint=Ellipse(a, b, phi), p=p).pmf()


def study(configs=None, laws=("binomial", "gated"), N: float = 1024.0**2, grid=None, samples: int = 10_000,
          seed: int = 1, threads: int | None = None, progress=None) -> pd.DataFrame:
    """One row per (configuration, law, n, r, phi, p); see the module docstring for the columns."""
    from .sweep import row_seed, tv_noise
    configs = list(CONFIGS) if configs is None else list(configs)
    grid = dict(QUICK_GRID if grid is None else grid)
    points = [(n, r, ph, p) for n in grid["n"] for r in grid["r"] for ph in grid["phi_deg"] for p in grid["p"]]
    counters = {(c, lw): _counter(c, lw, N) for c in configs for lw in laws}

    def one(point):
        n, r, ph, p = point
        phi = math.radians(ph)
        P = n / N
        d_truth = truth(N, n, r, phi, p)
        rows = []
        for (label, lw), c in counters.items():
            s = row_seed(seed, f"{label}|{lw}", n, p + r * 1e3 + ph)
            x = c.bin(c.sample(N, P, r, phi, p, size=samples, seed=s))
            row = {"config": label, "law": lw, "n": n, "r": r, "phi_deg": ph, "p": p,
                   "evaluations": c.evaluations(N, P, r, phi), "weight_bias": c.mean_bias(N, P, r, phi),
                   "clamped": bool(c.terms(N, P, r, phi).attrs["clamped"])}
            if c.has_pmf:
                d = c.pmf(N, P, r, phi, p)
                row.update(mean_bias=d.mean / (n * p), mean_bias_se=0.0, var_ratio=d.var / d_truth.var,
                           tv=distance(d, d_truth, "tv"), tv_noise=0.0, exact=True)
            else:
                row.update(mean_bias=x.mean() / (n * p), mean_bias_se=x.std() / math.sqrt(samples) / (n * p),
                           var_ratio=x.var() / d_truth.var, tv=distance(x, d_truth, "tv"),
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
        c = _counter(label, "binomial", N)
        grid = np.empty((resolution, resolution))
        for i, r in enumerate(r_axis):
            for j, s in enumerate(s_axis):
                m2 = 4.0**s / N  # minor side squared (area of the isotropic square)
                grid[i, j] = c.mean_bias(N, m2 * r, r, math.radians(phi_deg))
        out[label] = pd.DataFrame(grid, index=pd.Index(r_axis, name="r"), columns=pd.Index(s_axis, name="level"))
    return out


def image_benchmark(width: int = 1920, height: int = 1080, law: str = "gated", seed: int = 1, repeats: int = 1,
                    configs=None) -> tuple[pd.DataFrame, dict]:
    """Evaluates a whole image per configuration and times it: a ground plane seen at a grazing angle
    (the footprint stretches with distance: r from 1 to about 40, orientations across the image).
    Returns (timings, {config: evaluation histogram})."""
    N = 1024.0**2
    uv, J = plane_image(width, height)
    rows, hists = [], {}
    for label in (list(CONFIGS) if configs is None else configs):
        c = _counter(label, law, N)
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
