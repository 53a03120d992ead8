"""KPT25's Algorithm 2 as an importance sampler of a lighting integral at glinty pixels
(docs/math/sampling.md#lighting-integral): its unbiasedness against a reference computed by quadrature,
and its RMSE against sampling the smooth NDF (D(h)(h.n) and the visible normals) at the same sample
counts. A helper of the ``sampling`` section (listed in ``studies.HELPERS``).

The integral is the radiance a pixel reflects towards wo with a white Fresnel,

    L_o = integral over h of D^f(h) G2(wo, wi) L(wi) |wo.h| / (wo.n) dh,   wi = 2 (wo.h) h - wo,

with D^f Algorithm 1 at the pixel (one realization) and L an analytic sky, a sun and three area lights
(:func:`radiance`). D^f is its explicit lobes plus the compensation term; Algorithm 2 samples only the
lobes, so every estimator here estimates the lobes' part by Monte Carlo and adds the compensation's part,
integrated by the same quadrature as the reference (the policy of docs/math/sampling.md#lighting-integral);
the table also shows the estimator without it, whose bias is that part.
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from ..api import checks as V
from ..api.glinty_ndf import glinty_ndf
from ..api.samplers import sampler

# The lights: (direction's polar and azimuth angle in degrees, angular radius in degrees, radiance).
# Smooth-edged caps (a C^1 ramp over the outer quarter of the radius): the reference quadrature then
# converges like that of a smooth function, and the comparison is about sampling the NDF, not the lights.
AREA_LIGHTS = ((25.0, 170.0, 8.0, 6.0), (45.0, 215.0, 5.0, 12.0), (15.0, 120.0, 10.0, 3.0))
SUN = (40.0, 190.0, 400.0, 25.0)  # polar, azimuth, vMF concentration kappa (about 2.9 degrees), peak radiance

# Pixels: (NDF parameters, uv, J, realization seed).
PIXELS = (
    (dict(density=1e6, target="beckmann", alpha=0.5, alpha_star=0.02, k=4), (0.123, 0.456), (0.003, 0.0, 0.0005, 0.0025), 3),
    (dict(density=1e6, target="beckmann", alpha=0.3, alpha_star=0.02, k=4), (0.4, 0.6), (0.01, 0.0, 0.0, 0.01), 1),
    (dict(density=2e5, target="ggx", alpha=0.3, alpha_star=0.03, k=1), (0.7, 0.2), (0.006, 0.001, 0.0, 0.006), 2),
)
ESTIMATORS = ("kpt25_alg2", "smooth_ndf", "smooth_vndf")


def _unit(theta_deg, phi_deg):
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


def radiance(wi) -> np.ndarray:
    """L(wi) for unit directions (n, 3): a sky 0.4 + 0.6 z above the horizon, a sun (a von Mises-Fisher
    lobe) and the smooth-edged area lights of AREA_LIGHTS; 0 below the horizon."""
    wi = np.asarray(wi, float)
    z = wi[:, 2]
    out = np.where(z > 0, 0.4 + 0.6 * np.maximum(z, 0.0), 0.0)
    st, sp, kappa, peak = SUN
    out = out + peak * np.exp(kappa * (wi @ _unit(st, sp) - 1.0))
    for theta, phi, radius, value in AREA_LIGHTS:
        ang = np.arccos(np.clip(wi @ _unit(theta, phi), -1.0, 1.0))
        edge = 0.25 * math.radians(radius)
        x = np.clip((math.radians(radius) - ang) / edge, 0.0, 1.0)
        out = out + value * x * x * (3.0 - 2.0 * x)
    return np.where(z > 0, out, 0.0)


def weight(ndf, h, wo, light=radiance) -> np.ndarray:
    """g(h) = G2(wo, wi) L(wi) |wo.h| / (wo.n), so that L_o = integral of D(h) g(h) dh (0 where wi is
    below the horizon; G2 the height-correlated Smith term of the smooth NDF; L = ``light``, unit directions
    (n, 3) -> radiance (n,): the analytic sky :func:`radiance`, or an environment map's lookup)."""
    h = np.asarray(h, float)
    ok = np.all(np.isfinite(h), axis=1)
    h = np.where(ok[:, None], h, [0.0, 0.0, 1.0])
    c = h @ wo
    wi = 2.0 * c[:, None] * h - wo
    up = ok & (wi[:, 2] > 0) & (h[:, 2] > 0)
    lam_o = ndf.smith_lambda(np.array([wo[2]]))[0]
    lam_i = ndf.smith_lambda(np.where(up, wi[:, 2], 1.0))
    g2 = 1.0 / (1.0 + lam_o + lam_i)
    return np.where(up, g2 * light(np.where(up[:, None], wi, [0.0, 0.0, 1.0])) * np.abs(c) / wo[2], 0.0)


def inverse_map(nd, y) -> np.ndarray:
    """T^-1 (docs/math/glinty_ndf.md#glinty-map) for isotropic Beckmann and GGX (orthographic map):
    points y (n, 2) of the disk U to half vectors; written here again, so that the reference does not
    rest on the C++ it checks."""
    d = 2.0 * np.asarray(y, float) - 1.0
    r2 = np.minimum(np.sum(d * d, axis=1), 1.0 - 1e-15)
    a = nd.alpha
    if nd.target == "beckmann":
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.sqrt(np.where(r2 > 0, -np.log1p(-r2) / np.where(r2 > 0, r2, 1.0), 1.0))
        v = np.column_stack([a * d[:, 0] * ratio, a * d[:, 1] * ratio, np.ones_like(r2)])
    else:
        v = np.column_stack([a * d[:, 0], a * d[:, 1], np.sqrt(1.0 - r2)])
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _pixel_scales(nd, J) -> tuple[int, float]:
    """The finest MIP level the pixel's sum uses and the smallest lobe std sigma in T-space, probed on a
    grid of half vectors over the disk."""
    g = np.linspace(0.05, 0.95, 7)
    y = np.array([(a, b) for a in g for b in g])
    y = y[np.hypot(y[:, 0] - 0.5, y[:, 1] - 0.5) < 0.49]
    setups = [nd.pixel(J, h) for h in inverse_map(nd, y)]
    return max(max(p["levels"]) for p in setups), min(p["sigma"] for p in setups)


def reference(nd, nd_none, uv, J, seed, wo, orders=(2, 3), max_level: int | None = None, light=radiance) -> dict:
    """The lobes' part I_lobes (Algorithm 1 with ``compensation="none"``) and the compensation's part C of
    L_o by tensor Gauss-Legendre quadrature in T-space: dh = dy / ((pi / 4) D(h)(h.n)) (T makes
    D(h)(h.n) uniform on the disk U), over square cells of side 1 / (2 2^l_max m) whose edges hold every
    line where D^f jumps (the half-cell lines of the finest level, where the blocks B(k) change), m the
    smallest integer that makes the side at most the smallest lobe std (a Gaussian over one std is a
    polynomial to a few 1e-4 at 3 nodes), with ``orders`` nodes per axis; the value of the higher order,
    its error the difference between the two."""
    level, sigma = _pixel_scales(nd, J)
    level = level if max_level is None else max_level
    half_cell = 1.0 / (2 * 2**level)
    cells = 2 * 2**level * max(1, math.ceil(half_cell / sigma))
    out = {}
    for q in orders:
        x, w = np.polynomial.legendre.leggauss(q)
        x, w = 0.5 * (x + 1.0) / cells, 0.5 * w / cells
        base = np.arange(cells) / cells
        s = (base[:, None] + x[None, :]).reshape(-1)
        ws = np.tile(w, cells)
        yy = np.stack(np.meshgrid(s, s, indexing="ij"), -1).reshape(-1, 2)
        wy = np.outer(ws, ws).reshape(-1)
        inside = np.hypot(yy[:, 0] - 0.5, yy[:, 1] - 0.5) < 0.5
        yy, wy = yy[inside], wy[inside]
        h = inverse_map(nd, yy)
        d = nd.smooth(h)
        g = weight(nd.smooth_ndf, h, wo, light)
        keep = (g > 0) & (d > 0)
        h, g, d, wy = h[keep], g[keep], d[keep], wy[keep]
        n = len(h)
        uvs, Js = np.tile(uv, (n, 1)), np.tile(J, (n, 1))
        jac = wy * g / (0.25 * math.pi * d * h[:, 2])
        lobes = float(np.sum(nd_none.evaluate(uvs, Js, h, seed=seed) * jac))
        full = float(np.sum(nd.evaluate(uvs, Js, h, seed=seed) * jac))
        out[q] = (lobes, full - lobes, n)
    lo, hi = out[orders[0]], out[orders[-1]]
    return {"lobes": hi[0], "lobes_error": abs(hi[0] - lo[0]), "compensation": hi[1],
            "compensation_error": abs(hi[1] - lo[1]), "level": level, "cells": cells,
            "evaluations": 2 * sum(v[2] for v in out.values())}


def draws(nd, nd_none, uv, J, seed, wo, estimator, size, draw_seed, pdf_scale=1.0, light=radiance) -> np.ndarray:
    """``size`` independent terms f_lobes(h) / p(h) of one estimator (h drawn by Algorithm 2 or by a smooth
    sampler, f_lobes = D^f without compensation times g); a lost draw (p = 0) gives 0. ``pdf_scale``
    multiplies Algorithm 2's pdf: a deliberately wrong pdf for the tests."""
    uvs, Js = np.tile(uv, (size, 1)), np.tile(J, (size, 1))
    if estimator == "kpt25_alg2":
        h, p = nd.sample(uvs, Js, seed=seed, draw_seed=draw_seed)
        p = p * pdf_scale
    elif estimator == "smooth_ndf":
        h, p = sampler(nd.target, alpha=nd.alpha).sample(size, draw_seed)
    elif estimator == "smooth_vndf":
        h, p = sampler(f"{nd.target}_vndf", alpha=nd.alpha, wo=tuple(wo)).sample(size, draw_seed)
    else:
        V.fail("estimator", estimator, "one of " + ", ".join(ESTIMATORS))
    ok = np.all(np.isfinite(h), axis=1) & (p > 0)
    hh = np.where(ok[:, None], h, [0.0, 0.0, 1.0])
    f = nd_none.evaluate(uvs, Js, hh, seed=seed) * weight(nd.smooth_ndf, hh, wo, light)
    return np.where(ok, f / np.where(ok, p, 1.0), 0.0)


def z_score(terms, target, target_error) -> float:
    """(mean - target) / sqrt(SE^2 + target_error^2): the unbiasedness statistic."""
    terms = np.asarray(terms, float)
    se2 = terms.var(ddof=1) / len(terms)
    return float((terms.mean() - target) / math.sqrt(se2 + target_error**2))


def pixel_study(pixel, repeats: int, max_samples: int, sizes, wo, seed: int = 0, orders=(2, 3), pdf_scale=1.0,
                estimators=ESTIMATORS, label: str | None = None, light=radiance):
    """One pixel (an index into PIXELS or a tuple (NDF parameters, uv, J, realization seed)): the reference,
    then per estimator the z of the mean of all repeats x max_samples terms against it and the relative
    RMSE over ``repeats`` estimates at each sample count in ``sizes`` (prefixes of each repeat's draws).
    ``pdf_scale`` multiplies Algorithm 2's pdf (a wrong pdf, for the tests); ``light`` is L (:func:`weight`).
    Returns (rows of the RMSE table, rows of the bias table)."""
    index = pixel if isinstance(pixel, (int, np.integer)) else 0
    kw, uv, J, real = PIXELS[pixel] if isinstance(pixel, (int, np.integer)) else pixel
    nd = glinty_ndf("kpt25", **kw)
    nd_none = glinty_ndf("kpt25", **{**kw, "compensation": "none"})
    ref = reference(nd, nd_none, np.asarray(uv), np.asarray(J), real, wo, orders, light=light)
    total = ref["lobes"] + ref["compensation"]
    label = label or f"p{index} {kw['target']} a={kw['alpha']} a*={kw['alpha_star']} k={kw['k']}"
    rmse_rows, bias_rows = [], []
    for j, est in enumerate(estimators):
        t = draws(nd, nd_none, np.asarray(uv), np.asarray(J), real, wo, est, repeats * max_samples,
                  seed + 1000 * index + j, pdf_scale, light).reshape(repeats, max_samples)
        flat = t.reshape(-1)
        bias_rows.append({"pixel": label, "estimator": est, "samples": flat.size, "reference": total,
                          "reference_error": ref["lobes_error"] + ref["compensation_error"],
                          "compensation_share": ref["compensation"] / total,
                          "mean": float(flat.mean()) + ref["compensation"],
                          "z": z_score(flat, ref["lobes"], ref["lobes_error"]),
                          "z_without_compensation": z_score(flat, total, ref["lobes_error"] + ref["compensation_error"]),
                          "relative_std_per_sample": float(flat.std(ddof=1) / total),
                          "quadrature_level": ref["level"], "quadrature_evaluations": ref["evaluations"]})
        for n in sizes:
            est_n = t[:, :n].mean(axis=1)
            rmse = float(np.sqrt(np.mean((est_n - ref["lobes"]) ** 2)) / total)
            rmse_rows.append({"pixel": label, "estimator": est, "samples": int(n), "relative_rmse": rmse})
    return rmse_rows, bias_rows


def study(pixels, repeats: int, max_samples: int, wo_theta_deg: float, seed: int = 0, progress=None, light=radiance):
    """Every pixel of ``pixels`` (indices into PIXELS): the RMSE table (with the ratio smooth / Algorithm 2
    per pixel and sample count) and the bias table, under ``light`` (:func:`weight`)."""
    th = math.radians(wo_theta_deg)
    wo = np.array([math.sin(th), 0.0, math.cos(th)])
    sizes = [int(s) for s in 2 ** np.arange(2, int(math.log2(max_samples)) + 1)]
    rmse, bias = [], []
    for i in pixels:
        if progress:
            progress(f"lighting integral, pixel {i}")
        r, b = pixel_study(int(i), repeats, max_samples, sizes, wo, seed, light=light)
        rmse += r
        bias += b
    rmse, bias = pd.DataFrame(rmse), pd.DataFrame(bias)
    alg = rmse[rmse.estimator == "kpt25_alg2"].set_index(["pixel", "samples"]).relative_rmse
    rmse["ratio_to_alg2"] = [row.relative_rmse / alg[(row.pixel, row.samples)] for row in rmse.itertuples()]
    return rmse, bias


def plot(rmse: pd.DataFrame, path):
    """Log-log relative RMSE against samples, one panel per pixel, one line per estimator."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    pixels = list(dict.fromkeys(rmse.pixel))
    fig, axes = plt.subplots(1, len(pixels), figsize=(4.3 * len(pixels), 3.8), constrained_layout=True, squeeze=False)
    for ax, px in zip(axes[0], pixels):
        for est in ESTIMATORS:
            d = rmse[(rmse.pixel == px) & (rmse.estimator == est)]
            ax.loglog(d.samples, d.relative_rmse, "o-", label=est, ms=3)
        ax.set_title(px, fontsize=8)
        ax.set_xlabel("samples per estimate")
        ax.set_ylabel("relative RMSE")
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].legend(fontsize=8)
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path
