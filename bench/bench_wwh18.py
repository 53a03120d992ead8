#!/usr/bin/env python3
"""`make bench`: cost of WWH18's model (docs/math/wwh18.md) against DB23's count of the same footprints.

1. The table build (Sec. 4.2-4.3): seconds to build the 1-degree table (91 x 91 x 181) with and without
   the blur level Table 2 picks, and its size.
2. Per pixel, footprints holding 4 to 4096 flakes on average (N |A|): ns per pixel of the truth
   (``reference_counts``), of Algorithm 1's traversal (T = infinity; lambda per node and per flake), of
   the model with the switch at T = 16, and of DB23's D_P (``gl.glinty_ndf("db23").evaluate``, gated law)
   on the same footprints, with the ratio traversal / DB23.
Writes out/bench/wwh18.json. Exits 0 when the measurements complete.
"""
from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

import glintlab as gl


def timed(fn, repeats=2):
    best, out = math.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out/bench")
    ap.add_argument("--pixels", type=int, default=4096)
    args = ap.parse_args(argv)
    density, alpha, gamma = 1e6, 0.3, 6.0
    result = {"density": density, "alpha": alpha, "gamma": gamma, "threads": gl.get_num_threads()}
    build = []
    for lod in ("none", "table2"):
        secs, w = timed(lambda: gl.glinty_ndf("wwh18", density=density, alpha=alpha, gamma=gamma, table_res=1, lod=lod), 1)
        build.append({"lod": lod, "lod_deg": w.lod_deg, "seconds": secs, "bytes": w.table_bytes, "shape": w.table_shape})
        print(f"table build lod={lod} ({w.lod_deg:g} deg): {secs:.2f} s, {w.table_bytes / 2**20:.1f} MiB")
    result["table_build"] = build
    m = args.pixels
    rng = np.random.default_rng(1)
    models = {
        "truth": gl.glinty_ndf("wwh18", density=density, alpha=alpha, gamma=gamma, dpf="exact"),
        "traversal, lambda per node": gl.glinty_ndf("wwh18", density=density, alpha=alpha, gamma=gamma, table_res=1,
                                                   T=math.inf, lambda_seeding="node"),
        "traversal, lambda per flake": gl.glinty_ndf("wwh18", density=density, alpha=alpha, gamma=gamma, table_res=1,
                                                    T=math.inf, lambda_seeding="flake"),
        "model, T = 16": gl.glinty_ndf("wwh18", density=density, alpha=alpha, gamma=gamma, table_res=1, T=16),
    }
    db23 = gl.glinty_ndf("db23", density=density, alpha=alpha, inner="gated")
    rows = []
    for flakes in (4, 16, 64, 256, 1024, 4096):
        side = math.sqrt(flakes / density)
        uv = rng.uniform(0, 100, (m, 2))
        ang = rng.uniform(0, math.pi, m)
        J = np.stack([side * np.cos(ang), side * np.sin(ang), -side * np.sin(ang), side * np.cos(ang)], -1)
        t = np.radians(rng.uniform(0, 40, m))
        h = np.stack([np.sin(t), np.zeros(m), np.cos(t)], -1)
        row = {"flakes_in_footprint": flakes}
        for label, w in models.items():
            fn = ((lambda w=w: w.reference_counts(uv, J, h, seed=1)) if label == "truth"
                  else (lambda w=w: w.counts(uv, J, h, seed=1)))
            row[f"ns_{label}"] = timed(fn)[0] / m * 1e9
        row["ns_db23"] = timed(lambda: db23.evaluate(uv, J, h, seed=1))[0] / m * 1e9
        row["traversal_per_flake_over_db23"] = row["ns_traversal, lambda per flake"] / row["ns_db23"]
        rows.append(row)
        print(f"{flakes:5d} flakes: " + ", ".join(f"{k[3:]} {v:.0f} ns" for k, v in row.items() if k.startswith("ns_")) +
              f"; traversal (per flake) / DB23 = {row['traversal_per_flake_over_db23']:.2f}")
    result["per_pixel"] = rows
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "wwh18.json").write_text(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
