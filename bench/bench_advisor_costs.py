#!/usr/bin/env python3
"""The advisor's law costs against what a scene's pixels cost: are the recorded costs the scenes' own?

The recorded costs (``glintlab/data/costs/laws.json``, and ``costs="measure"``) time ``law.sample`` at a few
(n, p) points, each draw at its own (n, p) within a factor 2 of its point (``profile.spread_point``): a
scene's pixels each have their own (n, p), and a law's per-(n, p) setup (the binomial's sampler constants, a
law's regime choice) is paid at every one. Timed with all draws at one (n, p), as they were before, that
setup was paid once per 100,000 draws and the exact binomial cost 8.7 ns, cheaper than every approximation,
so the advisor picked it on every scene. ``python bench/bench_advisor_costs.py [--scale 0.25]`` times each
law, on one core by its CPU time (best of ``--repeats``), at the points (``measure_costs``) and over 100,000
of each shipped scene's lit pixels, each draw its own pixel's (n, p); and prints the advisor's pick at TV 0.05
with the recorded costs, the costs timed now at the points and the per-pixel timings.
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np
import pandas as pd

import glintlab as gl
from glintlab import _core
from glintlab.api.laws import parse_law_label
from glintlab.resources import data_path
from glintlab.validation import profile as P
from glintlab.validation.scene import load_scene

SCENES = ("sphere", "plane_90", "plane_25", "heightfield_90", "heightfield_25")


def per_pixel_ns(laws: dict, n: np.ndarray, p: np.ndarray, repeats: int) -> dict:
    """ns per draw of each law, each draw at its own (n, p) (one core, CPU time, best of ``repeats``)."""
    out = {}
    for label, law in laws.items():
        best = float("inf")
        for _ in range(repeats):
            t = time.thread_time()
            law.sample(n, p, seed=1)
            best = min(best, (time.thread_time() - t) / n.size * 1e9)
        out[label] = best
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scale", type=float, default=0.25, help="resolution factor per side (default: 0.25)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--max-tv", type=float, default=0.05)
    args = ap.parse_args(argv)
    pd.set_option("display.width", 200)
    recorded = P.recorded_costs()
    laws = P._resolve_laws([parse_law_label(label) for label in recorded.law])
    threads = _core.num_threads()
    _core.set_num_threads(1)
    try:
        fixed = P.measure_costs([parse_law_label(label) for label in laws], repeats=args.repeats)
        rng = np.random.default_rng(1)
        rows, picks = [], []
        for scene in SCENES:
            prof = P.profile_scene(load_scene(data_path("scenes", f"{scene}.json")), scale=args.scale, seed=1,
                                   schemes=("db23_tetrahedral",))
            lit = np.flatnonzero(prof.valid.ravel())
            take = lit[rng.integers(0, lit.size, 100_000)]
            n, p = prof.maps["n"].ravel()[take].astype(float), prof.maps["p"].ravel()[take].astype(float)
            ns = per_pixel_ns(laws, n, p, args.repeats)
            rows += [{"scene": scene, "law": label, "per_pixel_ns": v} for label, v in ns.items()]
            pick = {"scene": scene}
            for name, costs in (("recorded", None), ("points now", fixed),
                                ("per pixel", {label: v for label, v in ns.items()})):
                prof_c = P.profile_scene(load_scene(data_path("scenes", f"{scene}.json")), scale=args.scale, seed=1,
                                         schemes=("db23_tetrahedral",), costs=costs)
                pick[name] = gl.advise(prof_c, max_tv=args.max_tv).law
            picks.append(pick)
            print(f"{scene}: " + ", ".join(f"{k} {v:.1f}" for k, v in ns.items()) + f" ns; picks {pick}", flush=True)
    finally:
        _core.set_num_threads(threads)
    table = pd.DataFrame(rows).pivot(index="law", columns="scene", values="per_pixel_ns")
    table.insert(0, "points_now_ns", fixed.set_index("law").ns_per_eval)
    table.insert(0, "recorded_ns", recorded.set_index("law").ns_per_eval)
    print("\nns per evaluation: recorded, timed at the points now, and per pixel on each scene")
    print(table.round(1).to_string())
    print(f"\nadvisor's pick at TV {args.max_tv} (db23_tetrahedral, coverage 1):")
    print(pd.DataFrame(picks).to_string(index=False))
    return 0


if __name__ == "__main__":
    sys.exit(main())
