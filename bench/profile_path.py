#!/usr/bin/env python3
"""One path of bench_paths.py in a loop, for a profiler: where its time goes.

    perf record -g .venv/bin/python bench/profile_path.py per_pixel gated --seconds 10
    perf report --no-children --percent-limit 1

Paths (the same calls and inputs as bench_paths.py):
  batch LAW N P        law.sample(N, P, size=--size)
  per_pixel LAW        law.sample(n_array, p_array): --pixels random (n, p) of the standard grid
  blend RULE LAW       gl.blended_law(RULE, inner=LAW).sample(1e4, P, 0.01), P log-uniform over [1, 16]
  count_image CONFIG   AnisoCounter.count_image on the 1920 x 1080 tilted plane, gated inside

The loop runs for --seconds after one warm-up call, so that the profile is dominated by the path and
not by Python's start-up; the calls' mean time is printed at the end.
"""
from __future__ import annotations

import argparse
import math
import time

import numpy as np

import glintlab as gl


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("path", choices=["batch", "per_pixel", "blend", "count_image"])
    ap.add_argument("args", nargs="+", help="LAW N P | LAW | RULE LAW | CONFIG")
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--size", type=int, default=10**7)
    ap.add_argument("--pixels", type=int, default=10**6)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args(argv)
    gl.set_num_threads(a.threads)
    if a.path == "batch":
        if len(a.args) != 3:
            ap.error("batch takes LAW N P")
        law, n, p = gl.law(a.args[0]), float(a.args[1]), float(a.args[2])
        out = np.empty(a.size)
        call, items = (lambda: law.sample(n, p, size=a.size, seed=a.seed, out=out)), a.size
    elif a.path == "per_pixel":
        gn, gp = gl.standard_grid()
        pick = np.random.default_rng(a.seed).integers(0, gn.size * gp.size, a.pixels)
        n, p = gn[pick // gp.size], gp[pick % gp.size]
        law = gl.law(a.args[0])
        out = np.empty(a.pixels)
        call, items = (lambda: law.sample(n, p, seed=a.seed, out=out)), a.pixels
    elif a.path == "blend":
        if len(a.args) != 2:
            ap.error("blend takes RULE LAW")
        b = gl.blended_law(a.args[0], inner=a.args[1])
        P = np.exp(np.random.default_rng(a.seed + 1).uniform(0, math.log(16), a.pixels))
        call, items = (lambda: b.sample(1e4, P, 0.01, seed=a.seed)), a.pixels
    else:
        from glintlab.api.grids import IMAGE_CONFIGS, configured_counter
        from glintlab.studies.aniso import plane_image
        uv, J = plane_image(1920, 1080, tilt_deg=60.0)
        N = 1024.0**2
        c = configured_counter(IMAGE_CONFIGS[a.args[0]], "gated", N)
        call, items = (lambda: c.count_image(uv, J, N, 0.1, seed=a.seed)), uv.shape[0]
    call()  # warm-up: tables, caches, first-touch of reused buffers
    calls, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < a.seconds:
        call()
        calls += 1
    dt = (time.perf_counter() - t0) / calls
    print(f"{a.path} {' '.join(a.args)}: {calls} calls, {dt:.4f} s per call, {dt / items * 1e9:.2f} ns per item "
          f"({a.threads} thread{'s' if a.threads > 1 else ''})")


if __name__ == "__main__":
    main()
