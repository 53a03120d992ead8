#!/usr/bin/env python3
"""`make bench` (second part): ns per sample of every counting law, against numpy's binomial.

One run measures, from Python, on glintlab's default threads (both cores here):
  batch      law.sample(n, p, size=--size) at the four (n, p) points of the foundation benchmark:
             one (n, p) per call, so laws with a batch sampler build their per-(n, p) tables once;
  per pixel  law.sample(n_array, p_array) with a different (n, p) for every sample, drawn from the
             standard grid: what a renderer pays, one evaluation per pixel, no table to amortize;
  numpy      numpy.random.Generator(PCG64).binomial(int(n), p, size) (one thread: numpy has no other);
  uniforms   gl.uniforms(size, 2): the keyed Philox4x32-10 draws of a two-uniform law, returned as
             an array (16 bytes per row, twice a law's output, so a law fused with its draws can
             come in under it).
Each time is the best of --repeats calls, numpy and glintlab interleaved. Reported: ns/sample,
numpy / law (the speed-up), the ratio of ns/sample at n = 1e9 and n = 16 (constant cost in n means
about 1), and head_cf / gated (the issue's bound: at most 1.2).

Targets (project issue 3): gated at least 10x faster than numpy at each point; head_cf at most 1.2x
gated's ns/sample. PASS/FAIL is printed, never hidden; the script exits 0 when measurements complete.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pandas as pd

import glintlab as gl
from glintlab.validation.bench import best_time as best

POINTS = [(16, 0.1), (1e3, 1e-2), (1e6, 0.3), (1e9, 1e-6)]
LAWS = gl.law_variants("bench")  # declared by each law in core/laws/*.cpp


def label(name, params):
    return name + "".join(f"[{k}={v}]" for k, v in params.items())


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=10**7, help="samples per call (default: 10**7)")
    ap.add_argument("--pixels", type=int, default=10**6, help="samples of the per-pixel calls (default: 10**6)")
    ap.add_argument("--repeats", type=int, default=3, help="timed calls per measurement; best kept")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", type=Path, default=Path("out/bench"), help="directory for laws.csv/json")
    args = ap.parse_args(argv)
    if args.size < 64 or args.pixels < 1 or args.repeats < 1:
        ap.error("--size >= 64, --pixels >= 1 and --repeats >= 1 are required")
    rng = np.random.default_rng(args.seed)
    rows = []
    floor = best(lambda: gl.uniforms(args.size, 2, seed=args.seed), args.repeats) / args.size * 1e9
    numpy_ns = {}
    for n, p in POINTS:
        numpy_ns[(n, p)] = best(lambda: rng.binomial(int(n), p, size=args.size), args.repeats) / args.size * 1e9
    # Per-pixel parameters: every sample its own grid point (n, p).
    gn, gp = gl.standard_grid()
    pick = np.random.default_rng(args.seed).integers(0, gn.size * gp.size, args.pixels)
    pix_n, pix_p = gn[pick // gp.size], gp[pick % gp.size]
    for name, params in LAWS:
        law = gl.law(name, **params)
        for n, p in POINTS:
            t = best(lambda: law.sample(n, p, size=args.size, seed=args.seed), args.repeats) / args.size * 1e9
            rows.append(dict(law=label(name, params), mode="batch", n=n, p=p, ns_per_sample=t,
                             numpy_ns=numpy_ns[(n, p)], speedup_vs_numpy=numpy_ns[(n, p)] / t))
        t = best(lambda: law.sample(pix_n, pix_p, seed=args.seed), args.repeats) / args.pixels * 1e9
        rows.append(dict(law=label(name, params), mode="per_pixel", n=np.nan, p=np.nan, ns_per_sample=t,
                         numpy_ns=np.nan, speedup_vs_numpy=np.nan))
    df = pd.DataFrame(rows)
    batch = df[df["mode"] == "batch"]
    summary = batch.groupby("law", sort=False).agg(
        ns_mean=("ns_per_sample", "mean"), speedup_min=("speedup_vs_numpy", "min"),
        speedup_max=("speedup_vs_numpy", "max")).reset_index()
    ratio = {lw: g.set_index("n").ns_per_sample for lw, g in batch.groupby("law")}
    summary["ns_ratio_1e9_vs_16"] = summary.law.map(lambda lw: ratio[lw][1e9] / ratio[lw][16])
    summary["ns_per_pixel"] = summary.law.map(df[df["mode"] == "per_pixel"].set_index("law").ns_per_sample)
    args.out.mkdir(parents=True, exist_ok=True)
    df.to_csv(args.out / "laws.csv", index=False)

    gated = batch[batch.law == "gated"].set_index("n")
    head = batch[batch.law == "head_cf"].set_index("n")
    hc_batch = float(head.ns_per_sample.mean() / gated.ns_per_sample.mean())
    per_pixel = df[df["mode"] == "per_pixel"].set_index("law").ns_per_sample
    hc_pixel = float(per_pixel["head_cf"] / per_pixel["gated"])
    target_10x = bool((gated.speedup_vs_numpy >= 10).all())
    report = dict(size=args.size, pixels=args.pixels, repeats=args.repeats, seed=args.seed,
                  threads=gl.num_threads() if hasattr(gl, "num_threads") else None,
                  philox_floor_ns=floor, rows=rows, summary=summary.to_dict("records"),
                  gated_10x_numpy=target_10x, head_cf_over_gated_batch=hc_batch,
                  head_cf_over_gated_per_pixel=hc_pixel, version=gl.__version__)
    (args.out / "laws.json").write_text(json.dumps(report, indent=1, default=float))

    pd.set_option("display.width", 200)
    print(f"== counting laws, ns/sample from Python, {args.size:.0e}-sample calls (batch) and "
          f"{args.pixels:.0e} pixels with their own (n, p) (per pixel)")
    print(batch.pivot(index="law", columns="n", values="ns_per_sample").round(2).to_string())
    print("\nspeed-up over numpy's binomial (numpy ns / law ns):")
    print(batch.pivot(index="law", columns="n", values="speedup_vs_numpy").round(2).to_string())
    print("\n" + summary.round(3).to_string(index=False))
    print(f"\ngl.uniforms(size, 2) = {floor:.2f} ns/row (the keyed Philox4x32-10 draws, 16 bytes of output per row)")
    print("numpy ns/sample: " + ", ".join(f"({n:g}, {p:g}) {v:.1f}" for (n, p), v in numpy_ns.items()))
    print(f"[{'PASS' if target_10x else 'FAIL'}] gated >= 10x numpy at every point: "
          + ", ".join(f"{v:.1f}x" for v in gated.speedup_vs_numpy))
    print(f"[{'PASS' if hc_batch <= 1.2 else 'FAIL'}] head_cf / gated ns, batch: {hc_batch:.2f} (bound 1.2)")
    print(f"[{'PASS' if hc_pixel <= 1.2 else 'FAIL'}] head_cf / gated ns, per pixel: {hc_pixel:.2f} (bound 1.2)")
    print(f"wrote {args.out / 'laws.csv'} and {args.out / 'laws.json'}")


if __name__ == "__main__":
    main()
