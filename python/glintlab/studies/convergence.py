"""Convergence of the glinty NDF to its target (DB23 Fig. 13 idea, eq. 5–6).

DB23 eq. 3–4: D_P(h) = (D(n) / R) K / n with K counted by a law of (n, p = R D(h) / D(n)), so
E[D_P] = D(h) and, for the binomial, the relative spread of D_P / D(h) is sqrt((1 - p) / (n p)):
the glinty NDF converges to the target like 1 / sqrt(n p) as the facet density grows, whichever NDF
supplies D(h) (the law only sees p). The paper shows it with pictures for Beckmann and GGX; this module
measures it through the whole DB23 pipeline (the distributed LOD blend over the gated law by default),
so a law or blend that breaks convergence (a biased mean, a variance that does not shrink) shows up.
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from ..api import checks as V
from ..api.blends import blended_law
from ..api.ndf import ndf as get_ndf

DEFAULT_NDFS = (("beckmann", 0.5), ("ggx", 0.5))
DEFAULT_THETA_DEG = (0.0, 25.0, 45.0)
DEFAULT_N = tuple(float(x) for x in np.logspace(0, 5, 11))  # expected facets per pixel footprint


# (blend, inner law): DB23's pipeline, and the same blend over the exact binomial as the control that
# must converge exactly (E[D_P] = D(h), spread sqrt((1 - p) / (n p))).
DEFAULT_PIPELINES = (("distributed", "gated"), ("distributed", "binomial"))


def _pipeline(inner: str, blend: str):
    return blended_law(blend, inner=inner, level_ratio=4, base_area=1.0)


def convergence_table(ndfs=DEFAULT_NDFS, theta_deg=DEFAULT_THETA_DEG, n_values=DEFAULT_N, R: float = 0.5,
                      P: float = 1e-4, pixels: int = 20_000, seed: int = 1,
                      pipelines=DEFAULT_PIPELINES) -> pd.DataFrame:
    """One row per (pipeline, NDF, half-vector angle theta_h, n = N P): ``pixels`` independent footprints
    of area P at density N = n / P, counted by each (blend, inner law) of ``pipelines``; D_P / D(h) =
    K / (n p) per pixel. R = 1/2 by default: with R = 1, p = 1 at the normal and the count is certain.

    Columns: ndf, alpha, theta_deg, D_h, p (clamped to 1), p_raw (R D(h) / D(n)), N, n, np, mean (of
    K / (n p), the law's own bias) with mean_se, mean_vs_target (of D_P / D(h); below 1 where p_raw > 1), rel_spread
    (its standard deviation) with rel_spread_se (delta method on the sample variance, from the fourth
    moment), binomial_spread sqrt((1 - p) / (n p)), inv_sqrt_np 1 / sqrt(n p), and z_mean (mean - 1) / se.
    """
    seed = V.seed(seed)
    P = V.real("P", P)
    if not (0 < P <= 1):
        V.fail("P", P, "a footprint area in (0, 1]")
    V.integer("pixels", pixels, minimum=100)
    rows = []
    for blend, inner in pipelines:
        rows += _rows(_pipeline(inner, blend), f"{blend}[{inner}]", ndfs, theta_deg, n_values, R, P, pixels, seed)
    t = pd.DataFrame(rows)
    t["z_mean"] = (t["mean"] - 1) / t.mean_se.where(t.mean_se > 0)
    # D_P / D(h) = K / (n p_raw): equal to `mean` unless p was clamped, where it shows the energy eq. 4 loses.
    t["mean_vs_target"] = t["mean"] * t.p / t.p_raw
    t["spread_ratio"] = t.rel_spread / t.binomial_spread
    t["z_spread"] = (t.rel_spread - t.binomial_spread) / t.rel_spread_se.where(t.rel_spread_se > 0)
    return t


def _rows(bl, label, ndfs, theta_deg, n_values, R, P, pixels, seed):
    rows = []
    for k, (name, alpha) in enumerate(ndfs):
        d = get_ndf(name, alpha)
        for j, th in enumerate(theta_deg):
            D_h = float(d.D(math.cos(math.radians(th))))
            p, clamped = d.success_probability(math.cos(math.radians(th)), R)
            p = float(p)
            p_raw = R * D_h / d.D_normal  # > p where eq. 4 clamps: then E[D_P] < D(h) whatever the law
            for i, n in enumerate(n_values):
                N = n / P
                # One seed per (ndf, angle, density): rows are independent and reproducible one by one.
                K = bl.sample(N, P, p, size=pixels, seed=(seed * 1_000_003 + 7919 * k + 101 * j + i) % 2**64)
                x = K / (n * p)
                m, s2 = float(x.mean()), float(x.var(ddof=1))
                m4 = float(((x - m) ** 4).mean())
                var_s2 = max(m4 - s2 * s2 * (pixels - 3) / (pixels - 1), 0.0) / pixels
                spread = math.sqrt(s2)
                rows.append({"ndf": name, "alpha": alpha, "theta_deg": th, "D_h": D_h, "p": p, "p_raw": p_raw,
                             "p_clamped": bool(clamped), "N": N, "n": n, "np": n * p, "pixels": pixels,
                             "mean": m, "mean_se": spread / math.sqrt(pixels),
                             "rel_spread": spread,
                             "rel_spread_se": math.sqrt(var_s2) / (2 * spread) if spread > 0 else 0.0,
                             "binomial_spread": math.sqrt((1 - p) / (n * p)), "inv_sqrt_np": 1 / math.sqrt(n * p),
                             "law": label})
    return rows


def convergence_summary(table: pd.DataFrame, min_np: float = 10.0) -> pd.DataFrame:
    """Per (law, ndf, theta): the log-log slope of rel_spread against n p where n p >= min_np (DB23's
    claim: -1/2), the range of spread_ratio, the largest |z| of the mean and of the spread there, and
    the worst relative mean error over every n."""
    rows = []
    for (lw, name, th), g in table.groupby(["law", "ndf", "theta_deg"], sort=False):
        h = g[g.np >= min_np]
        slope = float(np.polyfit(np.log(h.np), np.log(h.rel_spread), 1)[0]) if len(h) >= 2 else math.nan
        rows.append({"law": lw, "ndf": name, "theta_deg": th, "p": g.p.iloc[0], "slope": slope,
                     "spread_ratio_min": h.spread_ratio.min(), "spread_ratio_max": h.spread_ratio.max(),
                     "max_abs_z_mean": h.z_mean.abs().max(), "max_abs_z_spread": h.z_spread.abs().max(),
                     "max_abs_mean_err": (g["mean"] - 1).abs().max(), "points": len(h)})
    return pd.DataFrame(rows)


def ndf_images(ndfs=DEFAULT_NDFS, n_values=(10.0, 1e3, 1e5), R: float = 0.5, resolution: int = 96,
               P: float = 1e-4, seed: int = 1, inner: str = "gated", blend: str = "distributed"):
    """D_P over the disk of half vectors (h_x, h_y) = sin(theta_h) (cos, sin): each image pixel is one
    footprint with its own half vector, counted at density N = n / P; plus the target D(h).

    Returns {ndf label: [(title, image), ...]} with images normalised by D(n) (NaN outside the disk)."""
    seed = V.seed(seed)
    bl = _pipeline(inner, blend)
    y, x = np.mgrid[-1:1:resolution * 1j, -1:1:resolution * 1j]
    rho = np.hypot(x, y)
    inside = rho < 0.999
    cos_t = np.sqrt(np.clip(1 - rho**2, 0, 1))
    out = {}
    for k, (name, alpha) in enumerate(ndfs):
        d = get_ndf(name, alpha)
        p, _ = d.success_probability(cos_t[inside], R)
        panels = []
        for i, n in enumerate(n_values):
            K = bl.sample(n / P, P, p, seed=(seed * 1_000_003 + 31 * k + i) % 2**64)
            img = np.full(x.shape, np.nan)
            img[inside] = K / (n * R)  # D_P / D(n) = K / (n R)
            panels.append((f"n = {n:g}", img))
        target = np.full(x.shape, np.nan)
        target[inside] = d.D(cos_t[inside]) / d.D_normal
        panels.append(("target D(h)", target))
        out[f"{name} (alpha = {alpha:g})"] = panels
    return out
