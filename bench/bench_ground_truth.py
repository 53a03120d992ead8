#!/usr/bin/env python3
"""`make bench` (third part): cost of one ground-truth realization against the footprint's size.

Target (project issue 4): the time per realization at n = 1e6 facets in the footprint is at most
100x the time at n = 1e2 (cost proportional to the perimeter in cells: sqrt(1e4) = 100 at most;
a naive sampler that places every facet pays 1e4x). Density N = 1e12 facets per unit area, an
ellipse of axis ratio 2.25 at a random centre, p = 0.3, one thread (realizations are independent,
so threads only divide the wall time). The naive baseline, in numpy, jitters one facet in every
cell of the footprint's bounding box and tests it (stratified layout).
Prints PASS/FAIL; writes out/bench/ground_truth.json. Exits 0 when the measurements complete.
"""
from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

import glintlab as gl

DENSITY = 1e12
SIZES = [1e2, 1e4, 1e6]


def footprint(n):
    area = n / DENSITY
    return gl.footprint_for_area(area, aspect=2.25, angle=0.4, shape="ellipse")


def per_realization(fn, count, repeats):
    fn(max(1, count // 10))  # warm-up
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn(count)
        best = min(best, time.perf_counter() - t0)
    return best / count


def naive_stratified(n, p, count, rng):
    """Every cell of the bounding box gets its jittered facet, tested one by one (vectorized)."""
    fp = footprint(n)
    h = 1 / math.sqrt(DENSITY)
    cells = int(math.ceil(2 * fp._core.half_width / h)) + 1, int(math.ceil(2 * fp._core.half_height / h)) + 1
    out = np.empty(count)
    for r in range(count):
        ox, oy = rng.random(2) * h
        ix, iy = np.meshgrid(np.arange(cells[0]), np.arange(cells[1]), indexing="ij")
        x = (ix + rng.random(ix.shape)) * h - fp._core.half_width - ox
        y = (iy + rng.random(iy.shape)) * h - fp._core.half_height - oy
        out[r] = np.count_nonzero(fp.contains(x, y) & (rng.random(ix.shape) < p))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", type=Path, default=Path("out/bench"))
    args = ap.parse_args(argv)
    threads = gl.get_num_threads()
    gl.set_num_threads(1)
    rows = []
    try:
        for layout in ("stratified", "poisson", "uniform"):
            for n in SIZES:
                gt = gl.ground_truth(layout, DENSITY, footprint(n), 0.3)
                count = 20000 if n <= 1e4 else 400
                t = per_realization(lambda c: gt.sample(c, seed=1), count, args.repeats)
                rows.append(dict(method=f"glintlab {layout}", n=n, us=t * 1e6))
        rng = np.random.default_rng(1)
        for n in SIZES:
            count = 2000 if n <= 1e2 else (20 if n <= 1e4 else 1)
            t = per_realization(lambda c: naive_stratified(n, 0.3, c, rng), count, 1 if n >= 1e6 else args.repeats)
            rows.append(dict(method="naive stratified (numpy)", n=n, us=t * 1e6))
    finally:
        gl.set_num_threads(threads)
    print("== ground truth: microseconds per realization (1 thread), density 1e12, ellipse, p = 0.3")
    print(f"{'method':28s}" + "".join(f"{'n = %g' % n:>14s}" for n in SIZES) + f"{'1e6 / 1e2':>12s}")
    ratios = {}
    for method in dict.fromkeys(r["method"] for r in rows):
        us = {r["n"]: r["us"] for r in rows if r["method"] == method}
        ratios[method] = us[1e6] / us[1e2]
        print(f"{method:28s}" + "".join(f"{us[n]:14.2f}" for n in SIZES) + f"{ratios[method]:12.1f}")
    worst = max(v for k, v in ratios.items() if k.startswith("glintlab"))
    print(f"[{'PASS' if worst <= 100 else 'FAIL'}] time at n = 1e6 <= 100x time at n = 1e2: worst {worst:.1f}x "
          f"(naive: {ratios['naive stratified (numpy)']:.0f}x)")
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "ground_truth.json").write_text(json.dumps(dict(rows=rows, ratios=ratios), indent=1))
    print(f"wrote {args.out / 'ground_truth.json'}")


if __name__ == "__main__":
    main()
