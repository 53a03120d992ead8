#!/usr/bin/env python3
"""`make bench`: the direction-sampler harness on a spiky pdf (docs/math/sampling.md).

1e7 samples of the synthetic glinty pdf (200 von Mises-Fisher lobes 0.3 degree wide on the hemisphere,
``gl.sampler("vmf_mixture")``) through ``gl.sampler_test`` with adaptive bins: the time split
(sampling, binning, cubature, the pdf check), the bins and pdf evaluations, and the verdict. The goal is
under 30 s on 2 cores, cubature included. The same run at 1 thread and at all threads must give the
same p-value (determinism), checked at 1e6 samples. When a Vulkan device is present, also the shipped
GGX visible-normal shader sampler (docs/math/sampling.md#shader-samplers) against the numpy reference
``ggx_vndf``: draws per second (sample, with pdf) and pdf evaluations per second, as ratios. Also
(docs/math/sampling.md#sampler-calibration): the false-failure rate restated, ``--calibration-seeds``
seeds (default 40) of correct samplers at 1e6 samples each (counts of p < 0.05 and p < 0.01 and a
Kolmogorov-Smirnov uniformity p of the combined p-value and of its parts), and the grazing deviations
the adaptive bins alone pass (GGX at alpha 0.3 never drawn beyond 85 degrees, or squeezed beyond 80)
at 1e6 samples: the adaptive bins' chi-square, the rows' and a fixed 30 x 60 grid's p-values. Writes
out/bench/sampler_test.json; exits 1 when the correct sampler fails, the two thread counts disagree,
a grazing deviation passes or the calibration shows more than its share of small p-values.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import scipy.stats

import glintlab as gl


def _rate(fn, n: int, repeats: int = 3) -> float:
    """Calls per second of fn(n) (best of `repeats`), in items per second."""
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn(n)
        best = min(best, time.perf_counter() - t0)
    return n / best


def shader_vs_reference(n: int = 10**6) -> dict | None:
    """The shipped GGX VNDF shader sampler (HLSL) against gl.sampler("ggx_vndf") at alpha 0.3,
    wo = (0.6, 0, 0.8): samples/s and pdf evaluations/s of each, and their ratios (shader / numpy)."""
    if not gl.vulkan_devices():
        return None
    wo = (0.6, 0.0, 0.8)
    shader = gl.shader_sampler(gl.shipped_sampler("ggx_vndf", "hlsl"), wo=wo)
    ref = gl.sampler("ggx_vndf", alpha=0.3, wo=wo)
    h, _ = ref.sample(n, seed=1)
    out = {"device": shader.device, "rows": n,
           "shader_samples_per_s": _rate(lambda m: shader.sample(m, seed=1), n),
           "numpy_samples_per_s": _rate(lambda m: ref.sample(m, seed=1), n),
           "shader_pdf_per_s": _rate(lambda m: shader.pdf(h[:m]), n),
           "numpy_pdf_per_s": _rate(lambda m: ref.pdf(h[:m]), n)}
    out["sample_ratio"] = out["shader_samples_per_s"] / out["numpy_samples_per_s"]
    out["pdf_ratio"] = out["shader_pdf_per_s"] / out["numpy_pdf_per_s"]
    return out


# The correct samplers of the calibration: normals, visible normals at 37 degrees and near grazing.
CALIBRATION = [("ggx", {"alpha": 0.3}), ("ggx_vndf", {"alpha": 0.3, "wo": (0.6, 0.0, 0.8)}),
               ("beckmann_vndf", {"alpha": 0.5, "wo": (0.98, 0.1, 0.17)})]


def calibration(seeds: int, n: int = 10**6) -> dict:
    """p-values of correct samplers over `seeds` seeds each (sampler k: seeds 1000 (k + 1), ...; distinct,
    since two samplers drawing from one seed use the same uniforms and their p-values would be
    correlated): how many fall below 0.05 and 0.01 against the expected 5 % and 1 %, and Kolmogorov-Smirnov
    tests of the chi-square over the adaptive bins and over the rows (uniform, two-sided) and of the
    combined p-value (a Bonferroni minimum is conservative, with mass at 1: one-sided, against an excess
    of small p-values)."""
    rows = []
    for k, (name, params) in enumerate(CALIBRATION):
        s = gl.sampler(name, **params)
        for seed in range(1000 * (k + 1), 1000 * (k + 1) + seeds):
            r = gl.sampler_test(s, samples=n, seed=seed)
            rows.append({"sampler": name, "seed": seed, "pvalue": r.pvalue, "pvalue_chi2": r.pvalue_chi2,
                         "pvalue_marginal": r.pvalue_marginal, "passed": r.passed, "bins": r.bins,
                         "marginal_dof": r.marginal_dof, "seconds": r.times["total"]})
    p = {k: np.array([row[k] for row in rows]) for k in ("pvalue", "pvalue_chi2", "pvalue_marginal")}
    out = {"samples": n, "seeds_per_sampler": seeds, "runs": len(rows), "samplers": [c[0] for c in CALIBRATION],
           "failed_at_1e-3": int(sum(not r["passed"] for r in rows))}
    for key, values in p.items():
        out[key] = {"below_0.05": int((values < 0.05).sum()), "below_0.01": int((values < 0.01).sum()),
                    "ks_uniformity_p": float(scipy.stats.kstest(values, "uniform").pvalue),
                    "ks_excess_small_p": float(scipy.stats.kstest(values, "uniform", alternative="greater").pvalue),
                    "smallest": float(values.min()),
                    "ks_per_sampler": {name: float(scipy.stats.kstest(
                        [row[key] for row in rows if row["sampler"] == name], "uniform").pvalue)
                        for name, _ in CALIBRATION}}
    out["runs_detail"] = rows
    return out


def _grazing(kind: str):
    """GGX (alpha 0.3) bent at grazing angles, its pdf unchanged (tests/python/test_sampler_verdicts.py)."""
    ggx = gl.sampler("ggx", alpha=0.3)

    def sample(size, seed):
        h, _ = ggx.sample(size, seed)
        theta, phi = np.arccos(np.clip(h[:, 2], -1, 1)), np.arctan2(h[:, 1], h[:, 0])
        if kind == "clamp_85":
            theta = np.minimum(theta, np.radians(85))
        else:
            theta = np.where(theta > np.radians(80), np.radians(80) + (theta - np.radians(80)) / 2, theta)
        x = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], axis=1)
        return x, ggx.pdf(x)
    return sample, ggx.pdf


def grazing(n: int = 10**6, seed: int = 1) -> list:
    """The two grazing deviations at n samples: adaptive bins, rows, combined and a 30 x 60 grid."""
    out = []
    for kind in ("clamp_85", "squeeze_80"):
        sample, pdf = _grazing(kind)
        r = gl.sampler_test(sample, pdf, samples=n, seed=seed, name=kind)
        g = gl.sampler_test(sample, pdf, samples=n, seed=seed, bins=(30, 60), name=kind)
        out.append({"variant": kind, "samples": n, "pvalue": r.pvalue, "pvalue_adaptive_bins": r.pvalue_chi2,
                    "pvalue_rows": r.pvalue_marginal, "pvalue_grid_30x60": g.pvalue, "rejected": not r.passed})
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=10**7)
    ap.add_argument("--out", default="out/bench")
    ap.add_argument("--calibration-seeds", type=int, default=40,
                    help="seeds per correct sampler in the calibration at 1e6 samples (0: skip)")
    args = ap.parse_args()
    s = gl.sampler("vmf_mixture", lobes=200, width_deg=0.3)
    t0 = time.perf_counter()
    res = gl.sampler_test(s, samples=args.samples, seed=1)
    wall = time.perf_counter() - t0
    print(repr(res))
    before = gl.get_num_threads()
    gl.set_num_threads(1)
    one = gl.sampler_test(s, samples=min(args.samples, 10**6), seed=2)
    gl.set_num_threads(before)
    many = gl.sampler_test(s, samples=min(args.samples, 10**6), seed=2)
    record = {"samples": args.samples, "threads": before, "wall_s": wall, "goal_s": 30.0, **res.summary(),
              "deterministic": one.pvalue == many.pvalue and bool((one.observed == many.observed).all())}
    shader = shader_vs_reference()
    if shader is not None:
        record["shader_sampler"] = shader
    record["grazing"] = grazing()
    for g in record["grazing"]:
        print(f"grazing {g['variant']} at {g['samples']:.0e}: p = {g['pvalue']:.3g} (adaptive bins alone "
              f"{g['pvalue_adaptive_bins']:.3g}, rows {g['pvalue_rows']:.3g}; a 30 x 60 grid {g['pvalue_grid_30x60']:.3g})")
    calibrated = True
    if args.calibration_seeds > 0:
        cal = record["calibration"] = calibration(args.calibration_seeds)
        for key in ("pvalue", "pvalue_chi2", "pvalue_marginal"):
            c = cal[key]
            print(f"calibration ({cal['runs']} runs at 1e6: {', '.join(cal['samplers'])}), {key}: {c['below_0.05']} "
                  f"below 0.05, {c['below_0.01']} below 0.01, KS uniformity p = {c['ks_uniformity_p']:.3g} (one-sided, "
                  f"excess of small p: {c['ks_excess_small_p']:.3g}; per sampler "
                  + ", ".join(f"{v:.2g}" for v in c["ks_per_sampler"].values()) + f"), smallest {c['smallest']:.3g}")
        # More than three times its share below 0.01 (binomial tail well below 1e-3 for 120 runs) is a
        # harness that fails correct samplers too often.
        calibrated = cal["pvalue"]["below_0.01"] <= max(3, 3 * 0.01 * cal["runs"])
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "sampler_test.json").write_text(json.dumps(record, indent=1, default=float))
    print(f"sampler_test: {args.samples:.3g} samples of a 200-lobe pdf in {wall:.1f} s (goal 30 s on 2 cores): "
          + ", ".join(f"{k} {v:.1f} s" for k, v in res.times.items()) + f"; {res.bins} bins, "
          f"{res.evaluations} pdf evaluations in the cubature; p = {res.pvalue:.3g}; "
          f"deterministic across threads: {record['deterministic']}")
    if shader is not None:
        print(f"shader sampler (ggx_vndf.hlsl on {shader['device']}) / numpy ggx_vndf: "
              f"{shader['sample_ratio']:.2f}x the samples/s ({shader['shader_samples_per_s']:.3g} vs "
              f"{shader['numpy_samples_per_s']:.3g}), {shader['pdf_ratio']:.2f}x the pdf evaluations/s "
              f"({shader['shader_pdf_per_s']:.3g} vs {shader['numpy_pdf_per_s']:.3g})")
    grazing_seen = all(g["rejected"] for g in record["grazing"])
    return 0 if res.passed and record["deterministic"] and grazing_seen and calibrated else 1


if __name__ == "__main__":
    sys.exit(main())
