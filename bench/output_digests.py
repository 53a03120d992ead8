#!/usr/bin/env python3
"""Digests of every law's and blend's outputs through every path, to show that a change of plumbing
(the law kernels, the drivers, a merge) kept every output bit.

    python bench/output_digests.py before.json          # on the old build
    python bench/output_digests.py after.json --compare before.json   # on the new one: exit 1 if any differs

Paths: scalar batches (5, 63, 64 and 3000 samples: below and above the batch-table threshold), float32,
exact pmfs, per-pixel arrays (log-uniform n, with a share of tiny p), runs of equal pixels mixed with
short runs, evaluate on given uniforms, a scalar n with a p array, and every blend rule over several
inner laws at one area and per pixel. A few seconds; not a test (the digests change whenever a law is
meant to change), a before/after tool.
"""
import argparse
import hashlib
import json
import sys

import numpy as np

import glintlab as gl

h_all = {}


def dig(key, a):
    a = np.ascontiguousarray(np.asarray(a, dtype=np.float64))
    h_all[key] = hashlib.sha256(a.tobytes()).hexdigest()[:16]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", help="JSON file the digests are written to")
    parser.add_argument("--compare", help="digests of another build: exit 1 if any differs")
    args = parser.parse_args()
    rng = np.random.default_rng(5)
    pts = [(0.0, 0.3), (0.5, 0.2), (1.0, 0.5), (1.7, 0.9), (3.0, 0.01), (10.0, 0.3), (37.5, 0.6), (100.0, 0.02),
           (1e3, 0.5), (1e5, 1e-3), (1e6, 0.97), (2e8, 0.4), (5.0, 1.0), (5.0, 0.0)]
    extra = {"gaussian": [{"rounding": "round"}], "threshold": [{"T": 2.5}]}
    for name in gl.laws():
        for params in [{}] + extra.get(name, []):
            lw = gl.law(name, **params)
            tag = name + str(params)
            h_all[tag + ":binning"] = lw.binning
            for (n, p) in pts:
                for cnt in (5, 63, 64, 3000):
                    dig(f"{tag}:batch:{n}:{p}:{cnt}", lw.sample(n, p, size=cnt, seed=7))
                if "float32" in lw.precisions:
                    dig(f"{tag}:f32:{n}:{p}", lw.sample(n, p, size=500, seed=3, precision="float32"))
                if lw.has_pmf and n * p < 1e6:
                    try:
                        d = lw.pmf(n, p)
                        dig(f"{tag}:pmf:{n}:{p}", np.concatenate([d.support, d.probs]))
                    except Exception as e:  # the refusal is an output too
                        h_all[f"{tag}:pmf:{n}:{p}"] = type(e).__name__
            m = 20000
            nn = np.exp(rng.uniform(np.log(0.3), np.log(1e6), m))
            pp = rng.uniform(0, 1, m)
            pp[::7] = rng.uniform(0, 1e-3, len(pp[::7]))
            dig(f"{tag}:pixels", lw.sample(nn, pp, seed=11))
            # Runs of equal pixels mixed with short runs (the drivers' run detection).
            nr = np.repeat(nn[:400], rng.integers(1, 40, 400))
            pr = np.repeat(pp[:400], rng.integers(1, 40, 400))
            runs = min(len(nr), len(pr))
            dig(f"{tag}:runs", lw.sample(nr[:runs], pr[:runs], seed=12))
            u = rng.uniform(0, 1, (2000, lw.n_uniforms))
            dig(f"{tag}:eval", lw.evaluate(nn[:2000], pp[:2000], u))
            dig(f"{tag}:pixels_scalar_n", lw.sample(25.0, pp[:5000], seed=13))
    for blend in gl.blends():
        for inner in ["binomial", "gated", "gaussian", "head_cf", "dual_gated", "threshold", "poisson"]:
            try:
                b = gl.blended_law(blend, inner=inner)
            except Exception as e:  # a refused pairing is an output too
                h_all[f"blend:{blend}:{inner}"] = type(e).__name__
                continue
            h_all[f"blend:{blend}:{inner}:binning"] = b.binning
            for (N, P, p) in [(100.0, 0.3, 0.2), (1e4, 2.0, 0.05), (50.0, 7.0, 0.6)]:
                dig(f"blend:{blend}:{inner}:{N}:{P}:{p}", b.sample(N, P, p, size=3000, seed=5))
            areas = np.exp(rng.uniform(np.log(0.05), np.log(50), 3000))
            dig(f"blend:{blend}:{inner}:pix", b.sample(1e3, areas, 0.1, seed=6))
    with open(args.out, "w") as f:
        json.dump(h_all, f, indent=0, sort_keys=True)
    print(len(h_all), "digests written to", args.out)
    if args.compare:
        with open(args.compare) as f:
            other = json.load(f)
        differ = sorted(k for k in set(h_all) | set(other) if h_all.get(k) != other.get(k))
        print(len(differ), "differ" + (": " + ", ".join(differ[:20]) if differ else ""))
        return 1 if differ else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
