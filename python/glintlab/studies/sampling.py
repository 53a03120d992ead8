"""Direction samplers tested (docs/math/sampling.md): the reference microfacet samplers pass the
harness and their wrong variants are rejected at the same sample size; a spiky pdf (von Mises-Fisher
lobes 0.3 degree wide) whose displaced lobes the adaptive bins reject and a fixed 30 x 60 (theta, phi)
grid passes; the furnace table of the smooth NDFs (cubature) and of KPT25's and DB23's glinty NDFs (Monte
Carlo over pixels at 1000 expected points per footprint); KPT25's Algorithm 2 as the importance sampler of
a lighting integral (sky, sun, three area lights) at glinty pixels: its bias against a quadrature reference
and its RMSE against sampling the smooth NDF (:mod:`~glintlab.studies.sampling_lighting`).

Tables: ``sampling_verdicts`` (one row per sampler and variant: p-value, bins, lost samples, pdf
mismatches, verdict, time), ``sampling_spiky`` (adaptive against fixed bins on the correct and the
displaced lobes), ``sampling_furnace`` (projected area, weak furnace and G2 furnace per NDF and
outgoing angle), ``sampling_lighting`` (relative RMSE per pixel, estimator and sample count, and its ratio
to Algorithm 2's) and ``sampling_lighting_bias`` (per pixel and estimator: the mean of all draws, the
reference, z with and without the compensation's part). A check fails (the report exits 1) when a correct
sampler is rejected, a wrong variant passes, the fixed grid sees the displacement the adaptive bins must
see, or an estimator of the lighting integral (the compensation's part added) misses the reference by
more than ``lighting_max_z`` standard errors.
"""
from __future__ import annotations

import inspect

import numpy as np
import pandas as pd

from ..api.glinty_ndf import glinty_ndf
from ..api.ndf import NDF
from ..api.samplers import SAMPLERS, sampler, samplers, wrong_sampler
from ..api.shader_samplers import shader_sampler, shipped_sampler
from ..api.shaders import vulkan_devices
from ..validation.furnace import furnace
from ..validation.sampler_test import plot_bins, sampler_test
from . import sampling_lighting
from .base import Context, Tables

NAME = "sampling"
TITLE = "Direction samplers tested: chi-square on adaptive bins, lost samples, pdf consistency, furnace tests"
MEANING = ("The reference Beckmann and GGX samplers (normals and visible normals) and the shipped GGX visible-normal "
           "shader sampler (on Vulkan, where a device exists) pass the harness and every wrong "
           "variant (alpha 2 % off, a missing Jacobian, 0.1 % of samples dropped) is rejected at the same size; "
           "adaptive bins reject lobes displaced by their own width that a fixed 30 x 60 grid passes; the smooth "
           "NDFs keep unit projected area and weak furnace; KPT25's Algorithm 2, with the compensation's part added, "
           "estimates a lighting integral without bias and with a lower RMSE than sampling the smooth NDF "
           "(parallel log-log lines: a constant variance ratio).")
DEFAULTS = {
    "samples": 200000,
    "alpha": 0.3,
    "wo_theta_deg": 60.0,
    "significance": 0.001,
    "spiky_samples": 100000, "lobes": 100, "lobe_width_deg": 0.3, "lobe_shift_deg": 0.3,
    "furnace_theta_deg": [0.0, 60.0],
    "kpt25_pixels": 32, "kpt25_directions": 64,
    "lighting_pixels": [0, 2], "lighting_repeats": 64, "lighting_samples": 256, "lighting_wo_theta_deg": 30.0,
    "lighting_max_z": 4.0,
}
QUICK = {"samples": 50000, "spiky_samples": 50000, "lobes": 50, "kpt25_pixels": 16, "kpt25_directions": 32,
         "lighting_pixels": [0], "lighting_repeats": 32, "lighting_samples": 128}
NOTEBOOK = "sampling.ipynb"
TABLE = {"sampling_verdicts": ["sampler", "variant", "pvalue", "bins", "lost", "mismatches", "verdict", "seconds"],
         "sampling_spiky": ["sampler", "bins_kind", "bins", "pvalue", "verdict"],
         "sampling_furnace": ["ndf", "quantity", "theta_o_deg", "value", "error"],
         "sampling_lighting": ["pixel", "estimator", "samples", "relative_rmse", "ratio_to_alg2"],
         "sampling_lighting_bias": ["pixel", "estimator", "samples", "reference", "reference_error", "mean", "z",
                                    "z_without_compensation", "compensation_share", "relative_std_per_sample"]}


def _rough_samplers(alpha: float, wo) -> list:
    """Every registered sampler with a roughness (its class takes ``alpha``), at the study's alpha and,
    where it takes one, its ``wo``: read from the registry, so a new one is tested here too (the spiky
    pdf, which takes neither, has its own table)."""
    out = []
    for name in samplers():
        params = inspect.signature(SAMPLERS.get(name)).parameters
        if "alpha" in params:
            out.append(sampler(name, alpha=alpha, **({"wo": wo} if "wo" in params else {})))
    return out


def compute(params: dict, ctx: Context) -> Tables:
    n, sig, alpha = int(params["samples"]), float(params["significance"]), float(params["alpha"])
    th = np.radians(float(params["wo_theta_deg"]))
    wo = (float(np.sin(th)), 0.0, float(np.cos(th)))
    rows, failures = [], []
    bases = _rough_samplers(alpha, wo)
    if vulkan_devices():  # the shipped shader sampler, run on Vulkan (lavapipe where there is no GPU)
        bases.append(shader_sampler(shipped_sampler("ggx_vndf"), wo=wo, defines={"ALPHA": alpha},
                                    name="ggx_vndf.hlsl (shader)"))
    for i, base in enumerate(bases):
        # The wrong variants each sampler declares (a shader's alpha is a define: no alpha+2% there).
        for variant in ("correct",) + tuple(base.wrong_variants):
            ctx.progress(f"{base.name} {variant}")
            s = base if variant == "correct" else wrong_sampler(base, variant)
            # A pdf without its Jacobian may not be integrable (GGX's visible normals over cos theta): a
            # small evaluation budget stops its cubature early; a rejection must survive the shift its errors
            # allow (docs/math/sampling.md#unresolved-pdf), an inconclusive wrong variant is not rejected.
            r = sampler_test(s, samples=n, seed=ctx.seed + i, significance=sig, max_evaluations=500_000)
            verdict = {"pass": "pass", "FAIL": "reject"}.get(r.verdict, r.verdict)
            rows.append({"sampler": base.name, "variant": variant, "pvalue": r.pvalue, "statistic": r.statistic,
                         "dof": r.dof, "bins": r.bins, "lost": r.lost, "integral": r.integral,
                         "mismatches": r.mismatches, "verdict": verdict, "pvalue_rows": r.pvalue_marginal,
                         "seconds": r.times["total"]})
            if (variant == "correct") != (verdict == "pass") or (variant != "correct" and verdict != "reject"):
                failures.append(f"sampling: {base.name} {variant}: {verdict} (p = {r.pvalue:.3g})")
    spiky_rows, data = [], {}
    common = dict(lobes=int(params["lobes"]), width_deg=float(params["lobe_width_deg"]), layout="cell_centres",
                  theta_deg=(30.0, 80.0))
    for label, s in (("vmf_mixture", sampler("vmf_mixture", **common)),
                     ("vmf_mixture displaced", sampler("vmf_mixture", shift_deg=float(params["lobe_shift_deg"]),
                                                       **common))):
        for bins in ("adaptive", (30, 60)):
            ctx.progress(f"{label} {bins}")
            r = sampler_test(s, samples=int(params["spiky_samples"]), seed=ctx.seed + 10, bins=bins, significance=sig)
            spiky_rows.append({"sampler": label, "bins_kind": r.bins_kind, "bins": r.bins, "dof": r.dof,
                               "pvalue": r.pvalue, "verdict": "pass" if r.passed else "reject",
                               "seconds": r.times["total"]})
            data[(label, r.bins_kind)] = r
            should_pass = label == "vmf_mixture" or bins != "adaptive"
            if should_pass != r.passed:
                failures.append(f"sampling: {label} with {r.bins_kind} bins: "
                                f"{'rejected' if should_pass else 'passed'} (p = {r.pvalue:.3g})")
    ctx.progress("furnace")
    thetas = [float(t) for t in params["furnace_theta_deg"]]
    parts = []
    for name in ("beckmann", "ggx"):
        t = furnace(NDF(name, alpha), theta_o_deg=thetas)
        t.insert(0, "ndf", name)
        parts.append(t)
        bad = t[(t.quantity != "furnace_g2") & ((t.value - 1).abs() > 1e-5)]
        failures += [f"sampling: furnace of {name}: {r.quantity} = {r.value:.8f}" for r in bad.itertuples()]
    for label, nd in (("kpt25 (alpha* 0.02, 1000 points)", glinty_ndf("kpt25", density=1e6, alpha=alpha, alpha_star=0.02)),
                      ("db23 (db23_trilinear, gated, 1000 points)", glinty_ndf("db23", density=1e6, alpha=alpha))):
        ctx.progress(f"furnace {label}")
        t = furnace(nd, theta_o_deg=thetas, pixels=int(params["kpt25_pixels"]),
                    directions=int(params["kpt25_directions"]), points=(1000.0,), seed=ctx.seed)
        t.insert(0, "ndf", label)
        parts.append(t)
    furnace_table = pd.concat(parts, ignore_index=True)
    # Algorithm 2 in a lighting integral: |z| of each estimator's mean (the compensation's part added,
    # docs/math/sampling.md#lighting-integral) against the quadrature reference; a threshold of 4 is a
    # false-failure rate of 6e-5 per estimator under the normal approximation of the mean.
    max_z = float(params["lighting_max_z"])
    rmse, bias = sampling_lighting.study(params["lighting_pixels"], int(params["lighting_repeats"]),
                                         int(params["lighting_samples"]), float(params["lighting_wo_theta_deg"]),
                                         seed=ctx.seed, progress=ctx.progress)
    failures += [f"sampling: lighting integral at {r.pixel}, {r.estimator}: |z| = {abs(r.z):.2f} > {max_z:g}"
                 for r in bias.itertuples() if not abs(r.z) <= max_z]
    verdicts = pd.DataFrame(rows)
    wrong = verdicts[verdicts.variant != "correct"]
    stats = {"samples per test": n, "spiky pdf samples": int(params["spiky_samples"]), "significance": sig,
             "wrong variants rejected": f"{int((wrong.verdict == 'reject').sum())} / {len(wrong)}",
             "lighting integral: draws per estimator and pixel": f"{int(params['lighting_repeats'])} estimates x "
                                                                 f"{int(params['lighting_samples'])} samples",
             "lighting integral: largest |z| (compensation added)": float(bias.z.abs().max()),
             "lighting integral: variance ratio smooth_ndf / Algorithm 2 per sample": ", ".join(
                 f"{r.pixel.split()[0]} {r.ratio:.2f}" for r in _variance_ratios(bias).itertuples())}
    return Tables(tables={"sampling_verdicts": verdicts, "sampling_spiky": pd.DataFrame(spiky_rows),
                          "sampling_furnace": furnace_table, "sampling_lighting": rmse,
                          "sampling_lighting_bias": bias},
                  stats=stats, failures=failures, data={"spiky": data})


def _variance_ratios(bias: pd.DataFrame) -> pd.DataFrame:
    """Per pixel: (std per sample of the smooth NDF's estimator / Algorithm 2's)^2."""
    std = bias.set_index(["pixel", "estimator"]).relative_std_per_sample
    pixels = list(dict.fromkeys(bias.pixel))
    return pd.DataFrame({"pixel": pixels,
                         "ratio": [(std[(p, "smooth_ndf")] / std[(p, "kpt25_alg2")]) ** 2 for p in pixels]})


def figures(tables: Tables, ctx: Context) -> list:
    paths = [sampling_lighting.plot(tables["sampling_lighting"], ctx.out / "sampling_lighting_rmse.png")]
    for (label, kind), r in tables["spiky"].items():
        if label == "vmf_mixture displaced" and kind == "adaptive":
            paths.append(plot_bins(r, ctx.out / "sampling_spiky_adaptive.png"))
    return paths
