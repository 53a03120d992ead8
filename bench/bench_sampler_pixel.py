#!/usr/bin/env python3
"""`make bench`: the harness's global cubature rule on KPT25's Algorithm 2 at a glinty pixel, and the
calibration of the spiky pdf at the tests' threshold (docs/math/sampling.md#cubature-error).

1. ``gl.sampler_test(nd.pixel_sampler(...))`` at a glinty pixel (Beckmann alpha 0.3, alpha* 0.02, k = 4,
   1e6 points per unit area, a 0.01 footprint: about 100 points), 2e5 samples: with the old per-bin rule
   (each bin's cubature error <= 2 % of its noise; ``cubature_tol=0, rel_tol=0.02``) and with the global
   rule (the default): time, pdf evaluations, verdict. A wrong variant (the pdf of the same realization
   with lobes 10 % wider) must be rejected.
2. The spiky 200-lobe vMF pdf of tests/python/test_sampler_test.py (2e5 samples, adaptive bins) over
   ``--seeds`` seeds: the fraction of p-values below 7e-5 (the tests' Sidak-corrected threshold), 1e-3,
   0.01 and 0.05, and a Kolmogorov-Smirnov test of their uniformity (a rate of 7e-5 itself needs ~1e5
   seeds to see; uniformity over the whole range is what the seeds can show).
Writes out/bench/sampler_pixel.json; exits 1 when the global rule fails the correct pixel sampler or
passes the wrong one.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
from scipy import stats

import glintlab as gl

PIXEL = dict(density=1e6, target="beckmann", alpha=0.3, alpha_star=0.02, k=4)
UV, J, REALIZATION = (0.4, 0.6), (0.01, 0.0, 0.0, 0.01), 1


class WrongPdf:
    """Algorithm 2's draws with the pdf of an NDF whose lobes are 10 % wider (same points)."""
    domain, name = "hemisphere", "kpt25 pixel, lobes 10 % wider in the pdf"

    def __init__(self):
        self.s = gl.glinty_ndf("kpt25", **PIXEL).pixel_sampler(UV, J, seed=REALIZATION)
        self.w = gl.glinty_ndf("kpt25", **{**PIXEL, "alpha_star": 1.1 * PIXEL["alpha_star"]}).pixel_sampler(
            UV, J, seed=REALIZATION)

    def sample(self, size, seed):
        return self.s.sample(size, seed)[0], None

    def pdf(self, d):
        return self.w.pdf(d)


def run(label, sampler, **kw):
    t0 = time.perf_counter()
    r = gl.sampler_test(sampler, samples=200_000, seed=11, **kw)
    wall = time.perf_counter() - t0
    print(f"{label}: {'pass' if r.passed else 'FAIL'} p = {r.pvalue:.3g}, {r.bins} bins, {r.evaluations} pdf "
          f"evaluations, {wall:.1f} s; cubature shift <= {r.cubature_shift:.3g} (limit {r.cubature_limit:.3g}), "
          f"unconverged bins {r.unconverged}" + (f"; notes: {r.note}" if r.notes else ""), flush=True)
    return {"label": label, "wall_s": wall, **r.summary(), "unconverged": r.unconverged,
            "cubature_shift": r.cubature_shift, "cubature_limit": r.cubature_limit}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=100)
    ap.add_argument("--skip-old", action="store_true", help="leave out the per-bin rule's run (about a minute)")
    ap.add_argument("--out", default="out/bench")
    args = ap.parse_args()
    s = gl.glinty_ndf("kpt25", **PIXEL).pixel_sampler(UV, J, seed=REALIZATION)
    rows = []
    if not args.skip_old:
        rows.append(run("per-bin rule (rel_tol 0.02, budget 6e6)", s, cubature_tol=0.0, rel_tol=0.02,
                        max_evaluations=6_000_000))
    rows.append(run("global rule (default)", s))
    rows.append(run("global rule, wrong pdf", WrongPdf()))
    ok = rows[-2]["passed"] and not rows[-1]["passed"]
    spiky = gl.sampler("vmf_mixture", lobes=200, width_deg=0.3, layout="cell_centres", theta_deg=(30, 80))
    p, t0 = [], time.perf_counter()
    for seed in range(args.seeds):
        p.append(gl.sampler_test(spiky, samples=200_000, seed=1000 + seed).pvalue)
    p = np.array(p)
    cal = {"seeds": args.seeds, "seconds": time.perf_counter() - t0,
           **{f"rate_below_{a:g}": float(np.mean(p < a)) for a in (7e-5, 1e-3, 0.01, 0.05)},
           "ks_uniform_pvalue": float(stats.kstest(p, "uniform").pvalue), "min_pvalue": float(p.min())}
    print("spiky pdf calibration:", json.dumps(cal))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "sampler_pixel.json").write_text(json.dumps({"pixel": rows, "spiky_calibration": cal}, indent=1,
                                                       default=float))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
