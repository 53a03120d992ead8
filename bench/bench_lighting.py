#!/usr/bin/env python3
"""`make bench`: the exact reflection probability of an extended light (docs/math/lighting.md#lighting-grid),
issue 40's speed goals at full size:

1. the exact p under 1 ms of CPU per (view, light) at rel_tol 1e-6: the hidden Catch2 case
   ``[.lighting_speed]`` (build/tests/glintlab_tests, built by build-all), and the same measure in Python
   over the lighting section's full probability table (median and largest per configuration);
2. per-pixel exact p of a 960 x 540 frame (plane_25 at half size, under a cap of 0.2 rad) in under a minute
   on two cores: the cubature per pixel (timed on every 50th pixel, scaled to the frame: the baseline)
   against the ProbabilityGrid (bicubic splines on 17^2 and 33^2 nodes, and Chebyshev points refined until
   1e-6), with the grid's error against the cubature;
3. the lighting section's scene images at full size (FULL_SCENE: plane_25 under a cap, a window and the
   sky, the sphere under the cap and the window at 240 x 135 and under the sky in world space at 96 x 54, each
   pixel in its own tangent frame with the exact p by cubature per pixel; the shipped area-light method shader
   when Vulkan is present; the registered image methods by quadrature over the light:
   validation.lighting_methods), seconds per light and method.

Prints each figure with PASS or FAIL against its goal. A benchmark, not a test: exits 0 when the
measurements complete.
"""
from __future__ import annotations

import argparse
import re
import subprocess
import time
from pathlib import Path

import glintlab as gl
from glintlab.api.lighting import ProbabilityGrid
from glintlab.studies import lighting as study
from glintlab.validation import lighting as VL
from glintlab.validation import lighting_images as LI
from glintlab.validation import scene_images as si

ROOT = Path(__file__).resolve().parents[1]
#: The grids timed: uniform bicubic splines (the baseline) and Chebyshev points refined until 1e-6.
GRIDS = (("spline", dict(nodes=17, interpolation="spline")), ("spline", dict(nodes=33, interpolation="spline")),
         ("chebyshev to 1e-6", dict(nodes=9, tolerance=1e-6)))


def catch2_case(binary: Path):
    """The hidden Catch2 case's ms per call (its INFO line, printed with -s), or None without the binary."""
    if not binary.exists():
        print(f"  {binary} not built (make build-all): the Catch2 case is skipped")
        return None
    out = subprocess.run([str(binary), "[.lighting_speed]", "-s"], capture_output=True, text=True, timeout=600)
    found = re.findall(r"ms per call ([0-9.eE+-]+)", out.stdout)
    return float(found[-1]) if found else None


def frame_views(scale: float):
    """The masked views of frame 0 of plane_25 at ``scale`` (tangent frame) and the cap in that frame."""
    sc = si.resolve_scene("plane_25").scaled(scale, keep_n=True)
    inp = si.frame_inputs(si.with_directional_light(sc))
    _, tbn, wo, *_ = LI._frame_geometry(inp, 1.0)
    return wo, LI.scene_light(sc, "cap", (0.2, 0.0)).in_frame(*tbn), sc


def time_grids(target, alpha, light, wo, wall):
    """Each of GRIDS over the views wo: seconds (build and every view) and error against the cubature."""
    for kind, kw in GRIDS:
        t0 = time.perf_counter()
        grid = ProbabilityGrid(target, alpha, light, wo, **kw)
        grid(wo)
        g = time.perf_counter() - t0
        e = grid.error(wo, samples=512)
        rel = e['max_rel_error_p_above_1e-3_max']
        print(f"    {kind} {grid.nodes}^2: {g:.2f} s wall ({wall / g:.0f}x faster), largest |error| / max p "
              f"{e['max_abs_error_over_max_p']:.2g}, largest relative error where p > 1e-3 max p "
              f"{rel:.2g}  {'PASS' if g < 60 and rel < 1e-6 else 'FAIL'} (goal: < 60 s at 1e-6)")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--scale", type=float, default=0.5, help="frame size per side of 1920 x 1080 (0.5: 960 x 540)")
    ap.add_argument("--tests", default=str(ROOT / "build" / "tests" / "glintlab_tests"))
    args = ap.parse_args()
    print(f"exact p of an extended light (glintlab {gl.__version__}, {gl.get_num_threads()} threads)")
    ms = catch2_case(Path(args.tests))
    if ms is not None:
        print(f"  Catch2 [.lighting_speed]: {ms:.3f} ms CPU per (view, light) at 1e-6  "
              f"{'PASS' if ms < 1.0 else 'FAIL'} (goal < 1 ms)")
    d = study.DEFAULTS
    probs = VL.probability_table(tuple(d["targets"]), tuple(d["alphas"]), tuple(d["half_angles"]),
                                 tuple(d["elevations_deg"]), tuple(d["views_deg"]))
    print(f"  section's {len(probs)} configurations: median {probs.exact_ms.median():.3f} ms, largest "
          f"{probs.exact_ms.max():.3f} ms CPU per (view, light)  {'PASS' if probs.exact_ms.median() < 1 else 'FAIL'}")
    wo, light, sc = frame_views(args.scale)
    sub = wo[::50]
    for target, alpha in (("beckmann", 1.0), ("ggx", 0.2)):
        t0, c0 = time.perf_counter(), time.process_time()
        gl.reflection_probability(target, alpha, sub, light)
        wall = (time.perf_counter() - t0) * len(wo) / len(sub)
        cpu = (time.process_time() - c0) * len(wo) / len(sub)
        print(f"  {sc.width} x {sc.height} ({len(wo)} views), {target} {alpha}: cubature per pixel ~{wall:.1f} s wall, "
              f"~{cpu:.1f} s CPU (the baseline; {'PASS' if wall < 60 else 'FAIL'} against 60 s)")
        time_grids(target, alpha, light, wo, wall)
    t0 = time.perf_counter()
    full = {**d, **study.FULL_SCENE}
    paths, table = study.scene_images(full, seed=1)
    print(f"  section's scene images at full size ({full['scene_scale']:g} of 1920 x 1080, {full['scene_frames']} frames, "
          f"{len(paths)} lights): {time.perf_counter() - t0:.1f} s")
    for p in paths:
        print(f"    {p.scene}, {p.light} ({int(p.mask.sum())} pixel-frames): "
              + ", ".join(f"{k} {v:.2f} s" for k, v in p.seconds.items()))
    columns = ["scene", "light", "method", "own_std_ratio", "own_pop_rate", "count_ratio", "expected_ratio"]
    print(table[columns].to_string(index=False))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
